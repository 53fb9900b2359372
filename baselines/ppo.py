r"""PPO (Stable-Baselines3) on the DARwIn-OP walking tiers: a deep-RL baseline.

  python -m baselines.ppo --task=darwin_walk --action_space=joints
  python -m baselines.ppo --task=darwin_walk --action_space=cpg --total_steps=2500000

Beyond the study (docs/decisions.md#ppo). Proximal Policy Optimization (SB3 `PPO`,
`MlpPolicy`, separate policy and value networks) learns on `num_envs` sub-environments of
the training tier, its observations and rewards normalized by SB3's `VecNormalize`
(`cpg_suite.harness.sb3`). Two action spaces:

* `joints`: the policy outputs the 12 normalized leg joint targets;
* `cpg`: the policy modulates the study's CPG every control step
  (`cpg_suite.vector.CPGActions`): 11 amplitude corrections (± `amplitude_scale`
  degrees around the hand-tuned amplitudes) and one phase-rate correction
  (ω (1 ± `rate_scale`)); action 0 is the hand-tuned open-loop gait. The policy also
  sees the CPG phase (cos φ_L, sin φ_L).

Each rollout collects `n_steps` steps of every sub-environment and computes GAE
advantages (discount `gamma`, λ = `gae_lambda`); then `n_epochs` passes over it in
minibatches of `batch_size` (advantages normalized per minibatch) minimize the clipped
surrogate loss (probability ratio clipped to 1 ± `clip_range`) + `vf_coef` · value loss
− `ent_coef` · entropy, with Adam at `learning_rate` and gradients clipped at
`max_grad_norm`.

The run (`cpg_suite.harness.learner`): segments of `validation_every` env steps, each
followed by a validation on `validation_seeds` validation seeds and a checkpoint
(`--resume` continues bit for bit); the best-validation policy is scored on the test
protocol. Run directory `<output_dir>/ppo/<task>/<run_name>/` (default run name
`<action_space>_seed<seed>`); load its policy with `load_policy`.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import os
from collections.abc import Callable

# torch before cpg_suite: with MUJOCO_GL=egl the other order crashes torch (README).
import torch  # noqa: F401
from absl import flags
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecEnv

from cpg_suite import cli, progress, protocol, residual
from cpg_suite.harness import checkpoints, learner
from cpg_suite.protocol import score
from cpg_suite.runfiles import runs, sb3_policy

METHOD = "ppo"  # its run directories' second level and its leaderboard rows
TASKS = protocol.TIERS
ACTION_SPACES = residual.ACTION_SPACES


@dataclasses.dataclass(frozen=True)
class PPOSettings:
    """The settings of a PPO run; all of them decide the result.

    Attributes:
      task: The training tier (`cpg_suite.protocol.TIERS`).
      action_space: "joints" (12 joint targets) or "cpg" (CPG modulation).
      total_steps: Training env steps (control steps summed over the sub-environments),
        rounded up to whole rollouts (`n_steps` × `num_envs`).
      num_envs: Sub-environments stepped together.
      seed: Seed of the network, the sampling and the training seeds.
      trial_steps: Control steps per episode: training, validation and test (1000 = 16 s).
      validation_every: Env steps between validations and checkpoints (rounded up to
        whole rollouts).
      validation_seeds: Validation seeds of the training tier the policy is selected on.
      test_seeds: Test seeds per tier of the final score card (0: no card).
      test_tiers: The tiers of the score card.
      amplitude_scale: cpg: degrees of amplitude correction per unit action.
      rate_scale: cpg: phase-rate correction per unit action (ω (1 + rate_scale · a)).
      n_steps, batch_size, n_epochs, learning_rate, gamma, gae_lambda, clip_range,
        ent_coef, vf_coef, max_grad_norm: SB3 PPO's hyperparameters (n_steps per
        sub-environment).
      log_std_init: Initial log standard deviation of the Gaussian policy.
      net_arch: Hidden layers of the policy and of the value network (separate).
      benchmark_version: The benchmark version trained under: its supply limit holds in
        the training and validation envs (a brown-out ends the episode like a fall).
      supply_cost: κ, metres of training reward per coulomb the robot draws above its
        idle current (`sb3.FlatVecEnv`; 0: the task's reward). Validation and test scores
        are the task's.
    """

    task: str = "darwin_walk"
    action_space: str = "joints"
    total_steps: int = 2_500_000
    num_envs: int = 16
    seed: int = 0
    trial_steps: int = 1000
    validation_every: int = 100_000
    validation_seeds: int = 10
    test_seeds: int = len(protocol.TEST)
    test_tiers: tuple[str, ...] = protocol.TIERS
    amplitude_scale: float = residual.AMPLITUDE_SCALE
    rate_scale: float = residual.RATE_SCALE
    n_steps: int = 256
    batch_size: int = 512
    n_epochs: int = 10
    learning_rate: float = 3e-4
    gamma: float = 0.99
    gae_lambda: float = 0.95
    clip_range: float = 0.2
    ent_coef: float = 0.0
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5
    log_std_init: float = -1.0
    net_arch: tuple[int, ...] = (256, 256)
    benchmark_version: int = protocol.BENCHMARK_VERSION
    supply_cost: float = 0.0

    def __post_init__(self):
        require = cli.require
        require(self.task in TASKS, f"unknown --task {self.task!r}; valid: {', '.join(TASKS)}")
        require(
            self.action_space in ACTION_SPACES,
            f"--action_space must be one of {', '.join(ACTION_SPACES)}, got {self.action_space!r}",
        )
        for name in (
            "total_steps",
            "num_envs",
            "trial_steps",
            "validation_every",
            "validation_seeds",
            "n_steps",
            "batch_size",
            "n_epochs",
        ):
            value = getattr(self, name)
            require(isinstance(value, int) and value >= 1, f"--{name} must be ≥ 1, got {value!r}")
        require(self.seed >= 0, f"--seed must be ≥ 0, got {self.seed}")
        require(
            self.num_envs <= protocol.TRAINING.stop // 2,
            f"--num_envs must be ≤ {protocol.TRAINING.stop // 2}, got {self.num_envs}",
        )
        tiers = cli.require_scoring(self.validation_seeds, self.test_seeds, self.test_tiers)
        object.__setattr__(self, "test_tiers", tiers)
        number = cli.require_number
        number("amplitude_scale", self.amplitude_scale, 0, residual.MAX_AMPLITUDE_SCALE)
        number("rate_scale", self.rate_scale, 0, 1, high_open=True)
        # Upper ends marked "a choice" bound only values that mean nothing or overflow.
        number("learning_rate", self.learning_rate, 0, 1, low_open=True)  # a choice
        number("gamma", self.gamma, 0, 1, low_open=True)
        number("gae_lambda", self.gae_lambda, 0, 1)
        number("clip_range", self.clip_range, 0, 10, low_open=True)  # a choice
        number("ent_coef", self.ent_coef, 0, 1e3)  # a choice
        # > 0: the value network is separate, and with no value loss it never learns.
        number("vf_coef", self.vf_coef, 0, 1e3, low_open=True)  # upper end: a choice
        number("max_grad_norm", self.max_grad_norm, 0, 1e6, low_open=True)  # a choice
        number("log_std_init", self.log_std_init, -20, 5)  # a choice: σ from 2e-9 to 148
        number("supply_cost", self.supply_cost, 0, 1e3)  # upper end: a choice
        try:
            arch = tuple(int(v) for v in self.net_arch)
        except (TypeError, ValueError):
            raise ValueError(f"--net_arch must be layer sizes, got {self.net_arch!r}") from None
        require(
            bool(arch) and all(v >= 1 for v in arch),
            f"--net_arch must be positive layer sizes, got {self.net_arch!r}",
        )
        object.__setattr__(self, "net_arch", arch)
        protocol.require_version(self.benchmark_version)

    @property
    def rollout_steps(self) -> int:
        """Env steps per rollout (one PPO update)."""
        return self.n_steps * self.num_envs


def default_run_name(settings: PPOSettings) -> str:
    """`<action_space>_seed<seed>`, or `<action_space>_c<supply_cost>_seed<seed>` when the
    reward is shaped by the supply."""
    cost = f"_c{settings.supply_cost:g}" if settings.supply_cost else ""
    return f"{settings.action_space}{cost}_seed{settings.seed}"


# The algorithm.
def new_model(settings: PPOSettings, env: VecEnv) -> PPO:
    """A fresh PPO model of the settings' hyperparameters (CPU, seeded by `settings.seed`).

    Args:
      settings: The run's settings.
      env: The env it learns on (the normalized training env).

    Returns:
      The model.
    """
    arch = list(settings.net_arch)
    return PPO(
        "MlpPolicy",
        env,
        learning_rate=settings.learning_rate,
        n_steps=settings.n_steps,
        batch_size=settings.batch_size,
        n_epochs=settings.n_epochs,
        gamma=settings.gamma,
        gae_lambda=settings.gae_lambda,
        clip_range=settings.clip_range,
        ent_coef=settings.ent_coef,
        vf_coef=settings.vf_coef,
        max_grad_norm=settings.max_grad_norm,
        policy_kwargs={"net_arch": {"pi": arch, "vf": arch}, "log_std_init": settings.log_std_init},
        seed=settings.seed,
        device="cpu",
        verbose=0,
    )


LEARNER = learner.Learner(
    method=METHOD,
    program="baselines.ppo",
    algorithm=PPO,
    make_model=new_model,
    run_name=default_run_name,
)


# Runs.
def run(
    settings: PPOSettings,
    options: runs.RunOptions | None = None,
    log: Callable[[str], None] = progress.write,
    on_checkpoint: Callable[[dict], None] | None = None,
) -> tuple[str, dict]:
    """Trains, selects and scores one PPO policy in `<output_dir>/ppo/<task>/<run_name>/`.

    Args:
      settings: The run's settings.
      options: Output directory, run name (default `default_run_name(settings)`),
        physics threads (results do not depend on them), resume, overwrite.
      log: Receives a line per segment.
      on_checkpoint: Called with the totals after each checkpoint is written.

    Returns:
      `(run_dir, summary)`; the summary holds the test score card unless `test_seeds` = 0.

    Raises:
      runs.RunDirectoryExists: The run directory holds a run and neither resume nor
        overwrite was asked.
      checkpoints.CheckpointError: On a corrupt or foreign checkpoint when resuming.
    """
    return learner.run(LEARNER, settings, options, log, on_checkpoint)


def load_policy(run_dir: str, which: str = "selected") -> sb3_policy.TrainedPolicy:
    """A PPO run's `selected` (best validation) or `final` policy.

    Args:
      run_dir: The run directory.
      which: "selected" or "final".

    Returns:
      The policy (`cpg_suite.protocol.score.score_policy` runs it).
    """
    config = runs.read_json(os.path.join(run_dir, "config.json"))
    settings = PPOSettings(**config["settings"])
    return sb3_policy.TrainedPolicy.load(run_dir, PPO, settings, which)


def summary_line(run_dir: str, summary: dict) -> str:
    """One line describing a finished run."""
    line = (
        f"{run_dir}: {summary['env_steps']:,} env steps, {summary['sim_steps']:,} physics steps, "
        f"selected {summary['selected']['source']} (validation "
        f"{summary['selected']['validation_success_weighted_m']:+.3f} m)"
    )
    if "test" in summary:
        line += "; test score " + score.score_text(summary["test"]["all"])
    return line


# Command line.
def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    d = PPOSettings()
    flags.DEFINE_string("task", d.task, f"Training tier: {', '.join(TASKS)}.")
    flags.DEFINE_string("action_space", d.action_space, f"One of {', '.join(ACTION_SPACES)}.")
    flags.DEFINE_integer("total_steps", d.total_steps, "Training env steps (whole rollouts).")
    flags.DEFINE_integer("num_envs", d.num_envs, "Sub-environments stepped together.")
    flags.DEFINE_integer("seed", d.seed, "Seed of the network, sampling and training seeds.")
    flags.DEFINE_integer(
        "benchmark_version", d.benchmark_version, "Benchmark version (supply limit) trained under."
    )
    flags.DEFINE_float(
        "supply_cost",
        d.supply_cost,
        "Training reward shaping: metres per coulomb drawn above the idle current (0: none).",
    )
    flags.DEFINE_integer("trial_steps", d.trial_steps, "Control steps per episode (1000 = 16 s).")
    flags.DEFINE_integer(
        "validation_every", d.validation_every, "Env steps between validations and checkpoints."
    )
    flags.DEFINE_integer("validation_seeds", d.validation_seeds, "Validation seeds.")
    flags.DEFINE_integer("test_seeds", d.test_seeds, "Test seeds per tier (0: no score card).")
    flags.DEFINE_list("test_tiers", list(d.test_tiers), "Tiers of the final score card.")
    flags.DEFINE_float("amplitude_scale", d.amplitude_scale, "cpg: degrees per unit action.")
    flags.DEFINE_float("rate_scale", d.rate_scale, "cpg: phase rate ω (1 + rate_scale · a).")
    flags.DEFINE_integer("n_steps", d.n_steps, "PPO: steps per sub-environment per rollout.")
    flags.DEFINE_integer("batch_size", d.batch_size, "PPO: minibatch size.")
    flags.DEFINE_integer("n_epochs", d.n_epochs, "PPO: epochs per rollout.")
    flags.DEFINE_float("learning_rate", d.learning_rate, "PPO: Adam learning rate.")
    flags.DEFINE_float("gamma", d.gamma, "PPO: discount.")
    flags.DEFINE_float("gae_lambda", d.gae_lambda, "PPO: GAE λ.")
    flags.DEFINE_float("clip_range", d.clip_range, "PPO: clip range.")
    flags.DEFINE_float("ent_coef", d.ent_coef, "PPO: entropy coefficient.")
    flags.DEFINE_float("vf_coef", d.vf_coef, "PPO: value loss coefficient.")
    flags.DEFINE_float("max_grad_norm", d.max_grad_norm, "PPO: gradient clipping norm.")
    flags.DEFINE_float("log_std_init", d.log_std_init, "Initial log std of the policy.")
    flags.DEFINE_list("net_arch", [str(v) for v in d.net_arch], "Hidden layer sizes.")
    o = runs.RunOptions()
    flags.DEFINE_integer("threads", o.threads, "Physics threads (results do not depend on it).")
    flags.DEFINE_string("output_dir", o.output_dir, "Root of the output tree.")
    flags.DEFINE_string("run_name", o.run_name, "Run directory name (default from settings).")
    flags.DEFINE_bool("resume", o.resume, "Continue the run from its checkpoint.")
    flags.DEFINE_bool("overwrite", o.overwrite, "Replace an existing run directory.")


def main(argv: list[str]) -> None:
    """Trains, selects and scores one PPO policy as the flags say; prints a summary line."""
    del argv
    settings = cli.settings_from_flags(PPOSettings)
    options = cli.settings_from_flags(runs.RunOptions)
    try:
        run_dir, summary = run(settings, options)
    except runs.RunDirectoryExists as e:
        raise cli.UsageError(f"{e} (or --resume to continue it)") from None
    except checkpoints.CheckpointError as e:
        raise cli.UsageError(str(e)) from None
    progress.write(summary_line(run_dir, summary))


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_dirs=("output_dir",))
