r"""Natural Actor-Critic on a DMP term for balance, as the study ran it (thesis Alg. 5.1).

  python -m baselines.nac --task=darwin_balance                 # normalisation + ridge on
  python -m baselines.nac --task=darwin_balance --nonormalize --ridge=0   # the study's first try

The CPG walks in place with the hand-tuned amplitudes; a DMP term adds a learned rate to
hip and ankle roll of both legs (Eq. 5.21-5.22):

  F(φ) = Σₖ ψₖ(φ) θₖ / Σₖ ψₖ(φ),  ψₖ = exp(h (cos(φ − cₖ) − 1)),  h = 2.5 · 15, cₖ = 2πk/15
  uᵢ ~ N(F(φᵢ), σ²) for each leg i (its own phase, one θ shared by both legs)

Algorithm 5.1, one control step t (16 ms):

  3  draw u ~ π(u | x_t), apply it; 4  observe r_t and x_{t+1}
  7  φ̃_t = [φ(x_{t+1}); 0]                   8  φ̂_t = [φ(x_t); ∇_θ log π(u_t | x_t)]
  9  z ← λ z + φ̂_t                          10  A ← A + z (φ̂_t − γ φ̃_t)ᵀ   (γ restored)
  11 b ← b + z r_t                          12  [v; w] = (A + δ I)⁻¹ b      (ridge δ)
  14 if the gradient estimate is accurate:  15  θ ← θ + α w
  16-17 forget: z ← β z, A ← β A, b ← β b   (only after an actor update)

The γ restored in line 10, the ridge δ and the forgetting rule are our readings of the
printed algorithm (docs/decisions.md#nac).

Basis φ(x) (15): 1, the 12 joint positions the CPG generates (rad), and the two phases
(wrapped to [0, 2π)). With `--normalize` each is divided by its running standard
deviation; the constant stays 1 (`--constant_rule=samples` divides it by the number of
samples, the literal reading of thesis Sec. 5.5). ∇_θ log π = Σᵢ (uᵢ − Fᵢ)/σ² · ψ(φᵢ)/Σψ(φᵢ):
the two legs' samples are independent, so their scores add.

Step size: the rewards are metres per step (|r| ≈ 0.05), so the natural gradient w is
small; α = 100 lets θ reach tens of degrees per second, comparable to the roll primitives'
rates (≈ 60°/s), within 20,000 steps. The study gives no α.

"Accurate" (the study does not define it): the angle between the current w and the w at
the previous check, `--check_every` steps earlier, is below `--accuracy_angle` degrees.

Reward: the task's (darwin_balance: −COP distance to the stance sole centre, m; darwin_walk:
forward displacement, m — the reward-hypothesis test), minus `--fall_penalty` at a fall,
after which the episode restarts (and z is cleared). Evaluation: mean reward per step of
the deterministic policy (u = F) over `--eval_seeds` initial states, before (θ = 0, the
CPG alone) and after learning.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import math
import os
import time
from collections.abc import Callable

import numpy as np
from absl import flags

import cpg_suite
from cpg_suite import cli, cpg, progress
from cpg_suite.runfiles import runs

TASKS = ("darwin_balance", "darwin_walk")
N_FEATURES = 15  # 1, 12 joint positions, 2 phases (thesis Sec. 5.4)


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    flags.DEFINE_string("task", "darwin_balance", f"One of {', '.join(TASKS)}.")
    flags.DEFINE_integer("steps", 20000, "Learning steps (16 ms each).")
    flags.DEFINE_float(
        "alpha", 100.0, "Actor learning rate α (rewards are metres per step: small; see docstring)."
    )
    flags.DEFINE_float("beta", 0.9, "Forgetting factor β in [0, 1].")
    flags.DEFINE_float("gamma", 0.95, "Discount γ in [0, 1).")
    flags.DEFINE_float("lam", 0.8, "LSTD trace decay λ in [0, 1].")
    flags.DEFINE_float("sigma", 5.0, "Exploration σ of u, degrees/s.")
    flags.DEFINE_float("ridge", 1e-2, "Ridge δ added to A's diagonal before solving (0: off).")
    flags.DEFINE_bool("normalize", True, "Divide the basis by its running std.")
    flags.DEFINE_enum(
        "constant_rule", "one", ["one", "samples"], "Normalisation of the constant feature."
    )
    flags.DEFINE_float("eps_a", 1e-6, "A starts as eps_a · I.")
    flags.DEFINE_float("accuracy_angle", 10.0, "Accuracy test: angle of w, degrees.")
    flags.DEFINE_integer("check_every", 50, "Steps between accuracy checks.")
    flags.DEFINE_float("fall_penalty", 1.0, "Reward subtracted at a fall.")
    flags.DEFINE_integer("eval_seeds", 5, "Evaluation initial states (100..100+N-1).")
    flags.DEFINE_integer("seed", 0, "Seed of exploration and training initial states.")
    flags.DEFINE_string("output_dir", "runs", "Root of the output tree.")
    flags.DEFINE_string("run_name", None, "Run directory name (default from settings).")
    flags.DEFINE_bool("overwrite", False, "Replace an existing run directory.")


THETA_LIMIT = 1e6  # |θ| above this (or a NaN) counts as divergence; the run stops.


class NaturalActorCritic:
    """LSTD(λ)-Q critic with the natural-gradient actor of thesis Alg. 5.1."""

    def __init__(
        self,
        n_features: int,
        n_params: int,
        alpha: float,
        beta: float,
        gamma: float,
        lam: float,
        ridge: float = 0.0,
        eps_a: float = 1e-6,
        accuracy_angle: float = 10.0,
        check_every: int = 50,
    ):
        n = n_features + n_params
        self.n_features, self.n_params = n_features, n_params
        self.alpha, self.beta, self.gamma, self.lam = alpha, beta, gamma, lam
        self.ridge, self.eps_a = ridge, eps_a
        self.cos_limit = math.cos(math.radians(accuracy_angle))
        self.check_every = check_every
        self.theta = np.zeros(n_params)
        self.z = np.zeros(n)
        self.A = eps_a * np.eye(n)
        self.b = np.zeros(n)
        self.v = np.zeros(n_features)
        self.w = np.zeros(n_params)
        self._w_checked: np.ndarray | None = None
        self.steps = 0
        self.updates = 0

    def clear_trace(self) -> None:
        """Episode boundary: the eligibility trace z starts again."""
        self.z[:] = 0.0

    def step(
        self,
        features: np.ndarray,
        score: np.ndarray,
        reward: float,
        next_features: np.ndarray,
        terminal: bool = False,
    ) -> bool:
        """One critic update (steps 7-12) and, if the gradient is accurate, an actor update.

        Args:
          features: φ(x_t).
          score: ∇_θ log π(u_t | x_t).
          reward: r_t.
          next_features: φ(x_{t+1}) (ignored at a terminal transition).
          terminal: The episode ended with this transition (no bootstrap).

        Returns:
          Whether θ was updated.
        """
        phi_hat = np.concatenate([features, score])
        phi_tilde = np.zeros_like(phi_hat)
        if not terminal:
            phi_tilde[: self.n_features] = next_features
        self.z = self.lam * self.z + phi_hat
        self.A += np.outer(self.z, phi_hat - self.gamma * phi_tilde)
        self.b += self.z * reward
        matrix = self.A + self.ridge * np.eye(len(self.b)) if self.ridge else self.A
        try:
            solution = np.linalg.solve(matrix, self.b)
        except np.linalg.LinAlgError:
            solution = np.linalg.lstsq(matrix, self.b, rcond=None)[0]
        self.v, self.w = solution[: self.n_features], solution[self.n_features :]
        self.steps += 1
        if self.steps % self.check_every:
            return False
        accurate = False
        if self._w_checked is not None:
            norms = np.linalg.norm(self.w) * np.linalg.norm(self._w_checked)
            accurate = norms > 0 and float(self.w @ self._w_checked) / norms > self.cos_limit
        self._w_checked = self.w.copy()
        if not accurate:
            return False
        self.theta = self.theta + self.alpha * self.w  # step 15
        self.z *= self.beta  # steps 16-17: forget after an actor update
        self.A *= self.beta
        self.b *= self.beta
        self.updates += 1
        return True


class RunningStd:
    """Welford running standard deviation of feature vectors."""

    def __init__(self, n: int):
        self.n, self.mean, self.m2 = 0, np.zeros(n), np.zeros(n)

    def update(self, x: np.ndarray) -> None:
        self.n += 1
        delta = x - self.mean
        self.mean += delta / self.n
        self.m2 += delta * (x - self.mean)

    def std(self) -> np.ndarray:
        return np.sqrt(self.m2 / max(1, self.n - 1))


class Features:
    """φ(x) = [1, 12 CPG joint positions (rad), φ_L, φ_R] with optional normalisation."""

    def __init__(self, normalize: bool, constant_rule: str = "one"):
        self.normalize, self.constant_rule = normalize, constant_rule
        self.stats = RunningStd(N_FEATURES)

    def raw(self, pattern: cpg.CPG) -> np.ndarray:
        phases = np.mod(pattern.phases(), 2 * np.pi)
        return np.concatenate([[1.0], np.deg2rad(pattern.z[0]), phases])

    def __call__(self, pattern: cpg.CPG, learn: bool = True) -> np.ndarray:
        x = self.raw(pattern)
        if not self.normalize:
            return x
        if learn:
            self.stats.update(x)
        std = self.stats.std()
        out = x.copy()
        out[1:] = np.where(std[1:] > 1e-9, x[1:] / np.maximum(std[1:], 1e-9), x[1:])
        out[0] = 1.0 / max(1, self.stats.n) if self.constant_rule == "samples" else 1.0
        return out


def dmp_policy(theta: np.ndarray, phases: np.ndarray, sigma: float, rng=None):
    """F per leg, the applied u per leg, and ∇_θ log π (summed over the two legs)."""
    psi = cpg.dmp_kernels(np.mod(phases, 2 * np.pi), len(theta))  # (2, N)
    weights = psi / psi.sum(axis=1, keepdims=True)
    mean = weights @ theta
    if rng is None:
        return mean, mean, np.zeros_like(theta)
    u = mean + sigma * rng.standard_normal(2)
    score = ((u - mean) / sigma**2) @ weights
    return mean, u, score


def evaluate_policy(
    task: str, theta: np.ndarray, seeds, steps: int = 1000, fall_penalty: float = 1.0
) -> dict:
    """Mean reward per step of the deterministic DMP policy (u = F) over initial states.

    Returns:
      `reward_per_step` (a fall's penalty included), `per_seed`, `falls`, and
      `task_reward_per_step`: the task's own reward per step, without the penalty.
    """
    rewards, plain, falls = [], [], 0
    for seed in seeds:
        env = cpg_suite.load(task, task_kwargs={"random": int(seed)})
        pattern = cpg.CPG("hand_tuned")
        env.reset()
        total, n = 0.0, 0
        for _ in range(steps):
            _, u, _ = dmp_policy(theta, pattern.phases(), 0.0)
            pattern.set_roll_input(u)
            ts = env.step(env.physics.targets_to_action(pattern.step(env.control_timestep())))
            total += ts.reward
            n += 1
            if ts.last():
                break
        plain.append(total / n)
        if ts.last() and ts.discount == 0.0:
            falls += 1
            total -= fall_penalty
        rewards.append(total / n)
    return {
        "reward_per_step": float(np.mean(rewards)),
        "per_seed": rewards,
        "falls": falls,
        "task_reward_per_step": float(np.mean(plain)),
    }


@dataclasses.dataclass(frozen=True)
class NACSettings:
    """Every setting of a NAC run (the flags of `python -m baselines.nac`); validated.

    Attributes:
      task: `darwin_balance` (COP reward) or `darwin_walk` (forward distance).
      steps: Learning steps (16 ms control steps).
      alpha: Actor learning rate α.
      beta: Forgetting factor β in [0, 1].
      gamma: Discount γ in [0, 1).
      lam: LSTD trace decay λ in [0, 1].
      sigma: Exploration σ of u, degrees/s.
      ridge: Ridge δ added to A's diagonal before solving (0: off).
      normalize: Divide the basis by its running standard deviation.
      constant_rule: Normalisation of the constant feature, `one` or `samples`.
      eps_a: A starts as eps_a · I.
      accuracy_angle: Accuracy test: largest angle between successive w, degrees.
      check_every: Steps between accuracy checks.
      fall_penalty: Reward subtracted at a fall.
      eval_seeds: Evaluation initial states (100..100+N-1).
      seed: Seed of exploration and of the training initial states.
      output_dir: Root of the output tree.
      run_name: Run directory name (None: `default_run_name`).
      overwrite: Replace an existing run directory.
    """

    task: str = "darwin_balance"
    steps: int = 20000
    alpha: float = 100.0
    beta: float = 0.9
    gamma: float = 0.95
    lam: float = 0.8
    sigma: float = 5.0
    ridge: float = 0.01
    normalize: bool = True
    constant_rule: str = "one"
    eps_a: float = 1e-6
    accuracy_angle: float = 10.0
    check_every: int = 50
    fall_penalty: float = 1.0
    eval_seeds: int = 5
    seed: int = 0
    output_dir: str = "runs"
    run_name: str | None = None
    overwrite: bool = False

    def __post_init__(self):
        require = cli.require
        require(self.task in TASKS, f"unknown --task {self.task!r}; valid: {', '.join(TASKS)}")
        require(self.steps >= 1, f"--steps must be ≥ 1, got {self.steps}")
        # Upper ends marked "a choice" bound only what would overflow or mean nothing.
        cli.require_number("alpha", self.alpha, 0, 1e6, low_open=True)  # a choice (default 100)
        cli.require_number("beta", self.beta, 0, 1)
        cli.require_number("lam", self.lam, 0, 1)
        cli.require_number("gamma", self.gamma, 0, 1, high_open=True)
        cli.require_number("sigma", self.sigma, 0, 1e4, low_open=True)  # a choice, degrees/s
        cli.require_number("ridge", self.ridge, 0, 1e6)  # a choice
        cli.require_number("eps_a", self.eps_a, 0, 1e6, low_open=True)  # a choice
        cli.require_number("accuracy_angle", self.accuracy_angle, 0, 180, low_open=True)
        require(self.check_every >= 1, f"--check_every must be ≥ 1, got {self.check_every}")
        require(self.eval_seeds >= 1, f"--eval_seeds must be ≥ 1, got {self.eval_seeds}")
        require(self.seed >= 0, f"--seed must be ≥ 0, got {self.seed}")
        cli.require_number("fall_penalty", self.fall_penalty, 0, 1e6)  # a choice

    def evaluation_seeds(self) -> range:
        """The evaluation initial states: 100, 101, ..., 100 + eval_seeds − 1."""
        return range(100, 100 + self.eval_seeds)


def as_settings(settings: NACSettings | dict) -> NACSettings:
    """The settings themselves, or built from a dict (missing keys take their defaults).

    Raises:
      ValueError: On invalid settings.
    """
    return settings if isinstance(settings, NACSettings) else NACSettings(**settings)


@dataclasses.dataclass
class _Tally:
    """What a training run keeps count of, and the progress window between report rows."""

    episode: int = 0
    falls: int = 0
    theta_norm_max: float = 0.0
    diverged: bool = False
    reward_sum: float = 0.0
    reward_n: int = 0
    f_abs_max: float = 0.0
    rows: list = dataclasses.field(default_factory=list)

    def track_theta(self, theta: np.ndarray) -> float:
        norm = float(np.linalg.norm(theta))
        if not np.isfinite(norm) or norm > THETA_LIMIT:
            self.diverged = True
        self.theta_norm_max = max(self.theta_norm_max, norm if np.isfinite(norm) else np.inf)
        return norm

    def close_window(self, step: int, norm: float, updates: int) -> str:
        """Appends a progress row for the window that ends at `step`; returns its line."""
        mean = self.reward_sum / self.reward_n
        self.rows.append(
            {
                "step": step,
                "episode": self.episode,
                "mean_reward": mean,
                "theta_norm": norm,
                "max_abs_F": self.f_abs_max,
                "updates": updates,
                "falls": self.falls,
            }
        )
        line = (
            f"step {step:6d}  reward/step {mean:+.5f}  |θ| {norm:.3g}  "
            f"max|F| {self.f_abs_max:.3g}  actor updates {updates}  falls {self.falls}"
        )
        self.reward_sum, self.reward_n, self.f_abs_max = 0.0, 0, 0.0
        return line


def _learner(settings: NACSettings) -> NaturalActorCritic:
    s = settings
    return NaturalActorCritic(
        N_FEATURES,
        cpg.N_KERNELS,
        s.alpha,
        s.beta,
        s.gamma,
        s.lam,
        s.ridge,
        s.eps_a,
        s.accuracy_angle,
        s.check_every,
    )


def _episode(settings: NACSettings, episode: int):
    """A fresh environment and CPG for an episode (the seed's own state first, then new ones)."""
    seed = settings.seed if episode == 0 else settings.seed * 100_003 + episode
    env = cpg_suite.load(settings.task, task_kwargs={"random": seed})
    pattern = cpg.CPG("hand_tuned")
    env.reset()
    return env, pattern


def _act(env, pattern: cpg.CPG, u: np.ndarray, fall_penalty: float) -> tuple[float, bool, bool]:
    """Alg. 5.1 steps 3-4: applies u for one control step; observes r_t (fall penalised).

    Returns:
      `(reward, fell, episode_ended)`.
    """
    pattern.set_roll_input(u)
    ts = env.step(env.physics.targets_to_action(pattern.step(env.control_timestep())))
    fell = bool(ts.last() and ts.discount == 0.0)
    return float(ts.reward) - (fall_penalty if fell else 0.0), fell, ts.last()


def train(settings: NACSettings | dict, log: Callable[[str], None] = progress.write) -> dict:
    """Runs Algorithm 5.1 for `settings.steps` control steps.

    Args:
      settings: The run's settings (a dict is validated through `NACSettings`).
      log: Receives a progress line every 500 steps (and at a divergence).

    Returns:
      The learning record: `theta`, progress `rows`, `theta_norm_max`, `diverged`,
      `updates` (actor updates), training `falls` and the `steps` taken.

    Raises:
      ValueError: On invalid settings.
    """
    settings = as_settings(settings)
    rng = np.random.default_rng(settings.seed)
    nac = _learner(settings)
    features = Features(settings.normalize, settings.constant_rule)
    tally = _Tally()
    env, pattern = _episode(settings, 0)
    x = features(pattern)
    t = 0
    bar = progress.track(range(settings.steps), desc=f"NAC {settings.task}", unit="step")
    for t in bar:
        mean, u, score = dmp_policy(nac.theta, pattern.phases(), settings.sigma, rng)  # step 3
        tally.f_abs_max = max(tally.f_abs_max, float(np.abs(mean).max()))
        reward, fell, ended = _act(env, pattern, u, settings.fall_penalty)  # step 4
        tally.falls += int(fell)
        x_next = features(pattern)
        nac.step(x, score, reward, x_next, terminal=fell)  # steps 7-17
        tally.reward_sum += reward
        tally.reward_n += 1
        norm = tally.track_theta(nac.theta)
        if ended:
            tally.episode += 1
            nac.clear_trace()
            env, pattern = _episode(settings, tally.episode)
            x_next = features(pattern)
        x = x_next
        if (t + 1) % 500 == 0 or tally.diverged:
            log(tally.close_window(t + 1, norm, nac.updates))
        if tally.diverged:
            break
    return {
        "theta": nac.theta,
        "rows": tally.rows,
        "theta_norm_max": tally.theta_norm_max,
        "diverged": tally.diverged,
        "updates": nac.updates,
        "falls": tally.falls,
        "steps": t + 1,
    }


def default_run_name(settings: NACSettings | dict) -> str:
    """`norm|nonorm` + `_ridge<δ>|_noridge` + `_seed<N>`, e.g. `norm_ridge0.01_seed0`."""
    settings = as_settings(settings)
    fixes = ("norm" if settings.normalize else "nonorm") + (
        f"_ridge{settings.ridge:g}" if settings.ridge else "_noridge"
    )
    return f"{fixes}_seed{settings.seed}"


def _start_run(settings: NACSettings) -> str:
    """Creates the run directory and writes config.json with the command that re-runs it."""
    run_name = settings.run_name or default_run_name(settings)
    run_dir = runs.run_directory(
        settings.output_dir, "nac", settings.task, run_name, overwrite=settings.overwrite
    )
    flags_of_run = {k: v for k, v in dataclasses.asdict(settings).items() if k != "overwrite"}
    command = runs.command_line("baselines.nac", {**flags_of_run, "run_name": run_name})
    runs.write_config(run_dir, settings, command)
    return run_dir


def _evaluate_before_after(settings: NACSettings, record: dict) -> tuple[dict, dict]:
    """The deterministic policy's reward before (θ = 0) and after learning (unless diverged)."""
    seeds, penalty = settings.evaluation_seeds(), settings.fall_penalty
    before = evaluate_policy(settings.task, np.zeros(cpg.N_KERNELS), seeds, fall_penalty=penalty)
    if record["diverged"]:
        return before, {"reward_per_step": None, "per_seed": [], "falls": None}
    return before, evaluate_policy(settings.task, record["theta"], seeds, fall_penalty=penalty)


def _summary(settings: NACSettings, record: dict, before: dict, after: dict) -> dict:
    theta = record["theta"]
    return {
        "task": settings.task,
        "seed": settings.seed,
        "normalize": settings.normalize,
        "ridge": settings.ridge,
        "reward_before": before["reward_per_step"],
        "reward_after": after["reward_per_step"],
        "reward_before_per_seed": before["per_seed"],
        "reward_after_per_seed": after["per_seed"],
        "falls_before": before["falls"],
        "falls_after": after["falls"],
        "theta_norm_max": record["theta_norm_max"],
        "theta_norm_final": float(np.linalg.norm(theta)) if np.all(np.isfinite(theta)) else None,
        "diverged": record["diverged"],
        "actor_updates": record["updates"],
        "training_falls": record["falls"],
        "steps": record["steps"],
    }


def run_nac(
    settings: NACSettings | dict, log: Callable[[str], None] = progress.write
) -> tuple[str, dict]:
    """Trains, evaluates before and after, and writes the run directory.

    Files: `config.json` (the settings and the command that re-runs the run),
    `progress.csv`, `theta.json` and `summary.json`.

    Args:
      settings: The settings, or a dict of them (missing keys take their defaults).
      log: Receives progress lines.

    Returns:
      `(run_dir, summary)`.

    Raises:
      ValueError: On invalid settings.
      runs.RunDirectoryExists: If the run directory exists and `overwrite` is off.
    """
    settings = as_settings(settings)
    run_dir = _start_run(settings)
    start = time.perf_counter()
    record = train(settings, log)
    before, after = _evaluate_before_after(settings, record)
    runs.write_rows_csv(os.path.join(run_dir, "progress.csv"), record["rows"])
    runs.write_json(os.path.join(run_dir, "theta.json"), {"theta": record["theta"].tolist()})
    summary = {
        **_summary(settings, record, before, after),
        "wall_s": time.perf_counter() - start,
    }
    runs.write_json(os.path.join(run_dir, "summary.json"), summary)
    return run_dir, summary


def main(argv):
    del argv
    settings = cli.settings_from_flags(NACSettings)
    try:
        run_dir, summary = run_nac(settings)
    except runs.RunDirectoryExists as e:
        raise cli.UsageError(str(e)) from None
    after = summary["reward_after"]
    after = "n/a (diverged)" if after is None else f"{after:+.5f}"
    print(
        f"{run_dir}: reward/step before {summary['reward_before']:+.5f}, after {after}, "
        f"max |θ| {summary['theta_norm_max']:.3g}, diverged {summary['diverged']}"
    )


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_dirs=("output_dir",))
