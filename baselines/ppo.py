r"""PPO (Stable-Baselines3) on the DARwIn-OP walking tiers: a deep-RL baseline.

  python -m baselines.ppo --task=darwin_walk --action_space=joints
  python -m baselines.ppo --task=darwin_walk --action_space=cpg --total_steps=2500000

Beyond the study (docs/decisions.md#ppo). Proximal Policy Optimization (SB3 `PPO`,
`MlpPolicy`) trains on `num_envs` sub-environments of `cpg_suite.vector.DarwinVectorEnv`
(same-step autoreset) through `FlatVecEnv`, an SB3 `VecEnv` that flattens the observation
dict in the fixed order `OBS_KEYS`, and SB3's `VecNormalize` (observations and rewards).
Two action spaces:

* `joints`: the policy outputs the 12 normalized leg joint targets;
* `cpg`: the policy modulates the study's CPG every control step
  (`cpg_suite.residual.CPGActions`): 11 amplitude corrections (± `amplitude_scale`
  degrees around the hand-tuned amplitudes) and one phase-rate correction
  (ω (1 ± `rate_scale`)); action 0 is the hand-tuned open-loop gait. The policy also
  sees the CPG phase (cos φ_L, sin φ_L).

Training runs in segments of `validation_every` env steps (whole rollouts). Each segment
starts every sub-environment afresh from new training seeds, then learns; at its end the
deterministic policy is scored on `validation_seeds` validation seeds of the training tier,
a row goes to progress.csv and `checkpoint.pkl` is written atomically (SB3 model with its
optimizer, VecNormalize statistics, NumPy's and torch's generator states, the
best-validation policy). Because a segment depends only on that state, `--resume`
continues a killed run bit for bit. At the end the best-validation policy is scored on the
test protocol (`cpg_suite.protocol.score.score_policy`) and summary.json gets the "test" card and
the simulation budget (training plus validation physics steps), which makes a leaderboard
row (`analysis.leaderboard`).

Run directory `<output_dir>/ppo/<task>/<run_name>/` (default run name
`<action_space>_seed<seed>`): config.json, progress.csv, checkpoint.pkl,
selected_model.zip + selected_vecnormalize.pkl (the reported policy; load with
`PPOPolicy.load`), final_model.zip + final_vecnormalize.pkl, summary.json.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import io
import math
import os
import pickle
import time
from collections.abc import Callable

import gymnasium
import numpy as np
import torch  # before cpg_suite: with MUJOCO_GL=egl the other order crashes torch (README)
from absl import flags
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env import VecEnv, VecNormalize

import cpg_suite
from cpg_suite import cli, darwin, progress, protocol, residual, vector
from cpg_suite.harness import runs
from cpg_suite.protocol import score

METHOD = "ppo"  # its run directories' second level and its leaderboard rows
TASKS = protocol.TIERS
ACTION_SPACES = ("joints", "cpg")
# The flattened observation: these keys of the task's observation, in this order (then the
# CPG phase for the cpg action space).
OBS_KEYS = (
    "joint_angles",
    "joint_velocities",
    "torso_orientation",
    "torso_height",
    "torso_velocity",
    "gyro",
    "accelerometer",
    "foot_touch",
)


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
        require(
            self.validation_seeds <= len(protocol.VALIDATION),
            f"--validation_seeds must be ≤ {len(protocol.VALIDATION)}",
        )
        require(
            0 <= self.test_seeds <= len(protocol.TEST),
            f"--test_seeds must lie in [0, {len(protocol.TEST)}], got {self.test_seeds}",
        )
        tiers = tuple(self.test_tiers)
        object.__setattr__(self, "test_tiers", tiers)
        unknown = [t for t in tiers if t not in protocol.TIERS]
        require(
            bool(tiers) and not unknown,
            f"unknown --test_tiers {unknown or list(tiers)}; valid: {', '.join(protocol.TIERS)}",
        )
        require(
            self.amplitude_scale >= 0, f"--amplitude_scale must be ≥ 0, got {self.amplitude_scale}"
        )
        require(0 <= self.rate_scale < 1, f"--rate_scale must lie in [0, 1), got {self.rate_scale}")
        require(self.learning_rate > 0, f"--learning_rate must be > 0, got {self.learning_rate}")
        require(0 < self.gamma <= 1, f"--gamma must lie in (0, 1], got {self.gamma}")
        require(
            0 <= self.gae_lambda <= 1, f"--gae_lambda must lie in [0, 1], got {self.gae_lambda}"
        )
        require(self.clip_range > 0, f"--clip_range must be > 0, got {self.clip_range}")
        require(self.ent_coef >= 0, f"--ent_coef must be ≥ 0, got {self.ent_coef}")
        require(self.vf_coef >= 0, f"--vf_coef must be ≥ 0, got {self.vf_coef}")
        require(self.max_grad_norm > 0, f"--max_grad_norm must be > 0, got {self.max_grad_norm}")
        require(
            math.isfinite(self.log_std_init),
            f"--log_std_init must be finite, got {self.log_std_init}",
        )
        try:
            arch = tuple(int(v) for v in self.net_arch)
        except (TypeError, ValueError):
            raise ValueError(f"--net_arch must be layer sizes, got {self.net_arch!r}") from None
        require(
            bool(arch) and all(v >= 1 for v in arch),
            f"--net_arch must be positive layer sizes, got {self.net_arch!r}",
        )
        object.__setattr__(self, "net_arch", arch)

    @property
    def rollout_steps(self) -> int:
        """Env steps per rollout (one PPO update)."""
        return self.n_steps * self.num_envs


def default_run_name(settings: PPOSettings) -> str:
    """`<action_space>_seed<seed>`."""
    return f"{settings.action_space}_seed{settings.seed}"


# Environments.
def make_vector_env(
    settings: PPOSettings, num_envs: int, threads: int | None = None, task: str | None = None
) -> gymnasium.vector.VectorEnv:
    """The (dict-observation) vector env the policy acts in: same-step autoreset, episodes
    of `trial_steps`, and the CPG action space for `action_space="cpg"`."""
    env = vector.DarwinVectorEnv(
        task or settings.task,
        num_envs,
        threads=threads,
        autoreset_mode=AutoresetMode.SAME_STEP,
        time_limit=settings.trial_steps * darwin.CONTROL_TIMESTEP,
    )
    if settings.action_space == "cpg":
        env = residual.CPGActions(
            env, amplitude_scale=settings.amplitude_scale, rate_scale=settings.rate_scale
        )
    return env


def observation_keys(space: gymnasium.spaces.Dict) -> tuple[str, ...]:
    """`OBS_KEYS`, then the CPG phase if the space has it."""
    return OBS_KEYS + ((residual.PHASE_KEY,) if residual.PHASE_KEY in space.spaces else ())


def flatten(observations: dict, keys: tuple[str, ...]) -> np.ndarray:
    """(N, D) float64 from a dict of (N, ...) arrays, the keys in order."""
    n = len(observations[keys[0]])
    return np.concatenate(
        [np.asarray(observations[k], dtype=np.float64).reshape(n, -1) for k in keys], axis=1
    )


def flatten_one(observation: dict, keys: tuple[str, ...]) -> np.ndarray:
    """(D,) float64 from one environment's observation dict."""
    return np.concatenate([np.asarray(observation[k], dtype=np.float64).ravel() for k in keys])


class FlatVecEnv(VecEnv):
    """A same-step-autoreset Gymnasium vector env with dict observations as an SB3 `VecEnv`.

    Observations are flattened in `observation_keys` order. `step_wait` returns
    `dones = terminated | truncated` and, for each finished sub-environment,
    `infos[i]["terminal_observation"]` (its last observation, flattened),
    `infos[i]["TimeLimit.truncated"]` (truncated and not terminated, so SB3 bootstraps
    it), `infos[i]["fell"]` and `infos[i]["episode"]` (raw return `r`, length `l`, as
    SB3's `Monitor` gives). `seed(s)` makes the next `reset` seed sub-environment i with
    s + i. Finished episodes are collected for `drain_episodes`.
    """

    def __init__(self, env: gymnasium.vector.VectorEnv):
        if env.metadata.get("autoreset_mode") != AutoresetMode.SAME_STEP:
            raise ValueError("FlatVecEnv needs a vector env with AutoresetMode.SAME_STEP")
        self.env = env
        self.keys = observation_keys(env.single_observation_space)
        size = sum(int(np.prod(env.single_observation_space[k].shape)) for k in self.keys)
        space = gymnasium.spaces.Box(-np.inf, np.inf, (size,), np.float64)
        super().__init__(env.num_envs, space, env.single_action_space)
        self._next_seed: int | None = None
        self._actions = None
        self._returns = np.zeros(self.num_envs)
        self._lengths = np.zeros(self.num_envs, dtype=np.int64)
        self._episodes: list[tuple[float, int, bool]] = []

    @property
    def physics_steps(self) -> int:
        """Physics steps simulated by the sub-environments so far."""
        return int(self.env.unwrapped.physics_steps)

    def drain_episodes(self) -> list[tuple[float, int, bool]]:
        """(return, length, fell) of the episodes finished since the last call."""
        out, self._episodes = self._episodes, []
        return out

    def seed(self, seed: int | None = None):
        self._next_seed = seed
        return [None if seed is None else seed + i for i in range(self.num_envs)]

    def reset(self) -> np.ndarray:
        observations, _ = self.env.reset(seed=self._next_seed)
        self._next_seed = None
        self._returns[:] = 0.0
        self._lengths[:] = 0
        return flatten(observations, self.keys)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self):
        observations, rewards, terminated, truncated, extra = self.env.step(self._actions)
        rewards = np.asarray(rewards, dtype=np.float64)
        terminated, truncated = np.asarray(terminated), np.asarray(truncated)
        dones = terminated | truncated
        self._returns += rewards
        self._lengths += 1
        infos: list[dict] = [{} for _ in range(self.num_envs)]
        for i in np.flatnonzero(dones):
            fell = bool(terminated[i])
            infos[i] = {
                "terminal_observation": flatten_one(extra["final_obs"][i], self.keys),
                "TimeLimit.truncated": bool(truncated[i] and not terminated[i]),
                "fell": fell,
                "episode": {"r": float(self._returns[i]), "l": int(self._lengths[i]), "t": 0.0},
            }
            self._episodes.append((float(self._returns[i]), int(self._lengths[i]), fell))
            self._returns[i], self._lengths[i] = 0.0, 0
        return flatten(observations, self.keys), rewards, dones, infos

    def close(self) -> None:
        self.env.close()

    def get_attr(self, attr_name: str, indices=None) -> list:
        n = len(self._indices(indices))
        value = None if attr_name == "render_mode" else getattr(self.env, attr_name)
        return [value] * n

    def set_attr(self, attr_name: str, value, indices=None) -> None:
        setattr(self.env, attr_name, value)

    def env_method(self, method_name: str, *args, indices=None, **kwargs) -> list:
        raise NotImplementedError("FlatVecEnv has no per-environment methods")

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        return [False] * len(self._indices(indices))

    def _indices(self, indices) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        return [indices] if isinstance(indices, int) else list(indices)


# The trained policy.
class PPOPolicy:
    """A trained policy for one environment (`cpg_suite.protocol.score.score_policy`): a dm_env
    observation → (12,) normalized joint targets, deterministic.

    Flattens the observation (`OBS_KEYS`, plus the CPG phase for the cpg action space),
    normalizes it with the run's VecNormalize statistics, takes the policy's mean action
    and, for the cpg action space, steps its own CPG row (`reset()` before each episode).
    """

    def __init__(self, model, normalizer: VecNormalize, settings: PPOSettings):
        self.model, self.normalizer, self.settings = model, normalizer, settings
        self.cpg = None
        if settings.action_space == "cpg":
            self.cpg = residual.ModulatedCPG(
                1, amplitude_scale=settings.amplitude_scale, rate_scale=settings.rate_scale
            )
            self._physics = cpg_suite.load("darwin_walk").physics
        self.keys = OBS_KEYS + ((residual.PHASE_KEY,) if self.cpg is not None else ())

    @classmethod
    def load(cls, run_dir: str, which: str = "selected") -> PPOPolicy:
        """The run's `selected` (best validation) or `final` policy."""
        settings = _settings_from_config(runs.read_json(os.path.join(run_dir, "config.json")))
        with open(os.path.join(run_dir, f"{which}_model.zip"), "rb") as f:
            model_bytes = f.read()
        with open(os.path.join(run_dir, f"{which}_vecnormalize.pkl"), "rb") as f:
            normalizer = pickle.loads(f.read())
        return cls(_load_model(model_bytes), normalizer, settings)

    def reset(self) -> None:
        if self.cpg is not None:
            self.cpg.reset()

    def __call__(self, observation: dict) -> np.ndarray:
        features = dict(observation)
        if self.cpg is not None:
            features[residual.PHASE_KEY] = self.cpg.phase_features()[0]
        flat = flatten_one(features, self.keys)[None]
        action = predict(self.model, self.normalizer, flat)
        if self.cpg is None:
            return action[0]
        return residual.joint_actions(action, self.cpg, self._physics, darwin.CONTROL_TIMESTEP)[0]


def predict(model, normalizer: VecNormalize, flat: np.ndarray) -> np.ndarray:
    """The deterministic (mean) actions, clipped to [−1, 1], for raw flat observations."""
    actions, _ = model.predict(normalizer.normalize_obs(flat), deterministic=True)
    return np.asarray(actions, dtype=np.float64)


def _import_torch():
    """torch, with `torch._dynamo` imported while Triton is hidden.

    With MUJOCO_GL=egl, dm_control's EGL bindings are loaded when `cpg_suite` is imported,
    and importing Triton's native library after them crashes the process (segmentation
    fault). torch imports Triton lazily, through `torch._dynamo`, when the first optimizer
    is built; CPU training never uses Triton, so `torch._dynamo` is imported with Triton
    reported missing (only if neither is imported yet). Nothing else changes.
    """
    import sys

    import torch

    if "torch._dynamo" not in sys.modules and "triton" not in sys.modules:
        sys.modules["triton"] = None  # `import triton` raises ImportError
        try:
            import torch._dynamo
        finally:
            del sys.modules["triton"]
    return torch


def _load_model(model_bytes: bytes, env=None):
    _import_torch()
    from stable_baselines3 import PPO

    return PPO.load(io.BytesIO(model_bytes), env=env, device="cpu")


def _model_bytes(model) -> bytes:
    buf = io.BytesIO()
    model.save(buf)
    return buf.getvalue()


def _settings_from_config(config: dict) -> PPOSettings:
    return PPOSettings(**config["settings"])


def validate(
    model, normalizer: VecNormalize, env, settings: PPOSettings
) -> tuple[float, float, int]:
    """Scores the deterministic policy on the first `validation_seeds` validation seeds.

    Args:
      model: The SB3 model.
      normalizer: Its VecNormalize (statistics only; not updated).
      env: `make_vector_env(settings, settings.validation_seeds)`.
      settings: The run's settings.

    Returns:
      (success-weighted distance, m: mean over the seeds of the distance, 0 for a fall;
      fall rate; physics steps of the trials).
    """
    keys = observation_keys(env.single_observation_space)
    observations, _ = env.reset(seed=protocol.VALIDATION.start)  # seeds validation_seeds(n)
    n = env.num_envs
    distance, fell, done = np.zeros(n), np.zeros(n, bool), np.zeros(n, bool)
    control_steps = 0
    for _ in range(settings.trial_steps):
        actions = predict(model, normalizer, flatten(observations, keys))
        observations, rewards, terminated, truncated, _ = env.step(actions)
        active = ~done
        distance[active] += np.asarray(rewards)[active]
        control_steps += int(active.sum())
        fell |= np.asarray(terminated) & active
        done |= np.asarray(terminated) | np.asarray(truncated)
        if done.all():
            break
    n_sub = env.unwrapped.n_sub
    return float(np.where(fell, 0.0, distance).mean()), float(fell.mean()), control_steps * n_sub


# Runs.
PROGRESS_FIELDS = [
    "segment",
    "env_steps",
    "physics_steps",
    "episodes",
    "mean_return_m",
    "fall_rate",
    "validation_m",
    "validation_fall_rate",
    "best_validation_m",
    "steps_per_s",
    "wall_s",
]


class CheckpointError(Exception):
    """A checkpoint that cannot be read or belongs to another configuration."""


def segment_seed(settings: PPOSettings, segment: int) -> int:
    """The training seed of sub-environment 0 in a segment (sub-environment i: + i)."""
    rng = np.random.default_rng([settings.seed, segment])
    return int(rng.integers(protocol.TRAINING.start, protocol.TRAINING.stop - settings.num_envs))


def _read_checkpoint(path: str, identity: dict) -> dict:
    try:
        with open(path, "rb") as f:
            checkpoint = pickle.load(f)
    except (OSError, pickle.UnpicklingError, EOFError, AttributeError) as e:
        raise CheckpointError(f"cannot read checkpoint {path}: {e}") from None
    if not isinstance(checkpoint, dict) or checkpoint.get("identity") != identity:
        raise CheckpointError(
            f"checkpoint {path} belongs to another configuration; use another --run_name "
            "or --overwrite"
        )
    return checkpoint


def _write_bytes(path: str, data: bytes) -> None:
    """Writes bytes atomically (a temporary file moved into place)."""
    runs._atomic_write_bytes(path, data)


def run(
    settings: PPOSettings,
    options: runs.RunOptions | None = None,
    log: Callable[[str], None] = progress.write,
    on_checkpoint: Callable[[dict], None] | None = None,
) -> tuple[str, dict]:
    """Trains, selects and scores one PPO policy in `<output_dir>/ppo/<task>/<run_name>/`.

    Torch runs on one CPU thread inside this call (restored after): the numbers of a run
    then do not depend on the machine's core count (a multi-threaded reduction may sum
    in another order), and the environment's physics threads (`options.threads`) get the
    cores. The network is small, so more torch threads would gain little.

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
      CheckpointError: On a corrupt or foreign checkpoint when resuming.
    """
    options = options or runs.RunOptions()
    name = options.run_name or default_run_name(settings)
    run_dir = runs.run_directory(
        options.output_dir,
        METHOD,
        settings.task,
        name,
        overwrite=options.overwrite,
        resume=options.resume,
    )
    summary_path = os.path.join(run_dir, "summary.json")
    if options.resume and os.path.exists(summary_path):
        log(f"{run_dir}: already finished")
        return run_dir, runs.read_json(summary_path)
    checkpoint_path = os.path.join(run_dir, "checkpoint.pkl")
    identity = dataclasses.asdict(settings)
    checkpoint = None
    if options.resume and os.path.exists(checkpoint_path):
        checkpoint = _read_checkpoint(checkpoint_path, identity)
    else:
        flags_of_run = {**identity, "output_dir": options.output_dir, "run_name": name}
        runs.write_config(run_dir, settings, runs.command_line(f"baselines.{METHOD}", flags_of_run))
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        summary = _train_and_score(settings, options, run_dir, checkpoint, log, on_checkpoint)
    finally:
        torch.set_num_threads(threads)
    runs.write_json(summary_path, summary)
    return run_dir, summary


def _new_model(settings: PPOSettings, env):
    _import_torch()
    from stable_baselines3 import PPO

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


def _train_and_score(settings, options, run_dir, checkpoint, log, on_checkpoint) -> dict:
    torch = _import_torch()

    train_env = FlatVecEnv(make_vector_env(settings, settings.num_envs, options.threads))
    threads = min(options.threads, settings.validation_seeds)
    validation_env = make_vector_env(settings, settings.validation_seeds, threads)
    try:
        if checkpoint is None:
            normalizer = VecNormalize(
                train_env, norm_obs=True, norm_reward=True, clip_obs=10.0, gamma=settings.gamma
            )
            model = _new_model(settings, normalizer)
            totals = {
                "segment": 0,
                "rollouts": 0,
                "env_steps": 0,
                "physics_steps": 0,
                "validation_sim_steps": 0,
                "episodes": 0,
                "falls": 0,
                "best_return_m": None,
                "last_mean_return_m": None,
                "wall_s": 0.0,
            }
            rows, best = [], None
        else:
            normalizer = pickle.loads(checkpoint["vecnormalize"])
            normalizer.set_venv(train_env)
            model = _load_model(checkpoint["model"], normalizer)
            np.random.set_state(checkpoint["np_rng"])
            torch.set_rng_state(checkpoint["torch_rng"])
            totals, rows, best = checkpoint["totals"], checkpoint["rows"], checkpoint["best"]
        identity = dataclasses.asdict(settings)
        checkpoint_path = os.path.join(run_dir, "checkpoint.pkl")
        total_rollouts = math.ceil(settings.total_steps / settings.rollout_steps)
        per_segment = math.ceil(settings.validation_every / settings.rollout_steps)
        with runs.ProgressCSV(os.path.join(run_dir, "progress.csv"), PROGRESS_FIELDS) as csv:
            for row in rows:
                csv.append(row)
            while totals["rollouts"] < total_rollouts:
                k = min(per_segment, total_rollouts - totals["rollouts"])
                start, physics_before = time.perf_counter(), train_env.physics_steps
                train_env.seed(segment_seed(settings, totals["segment"]))
                model._last_obs = None  # every segment starts from fresh episodes
                model.learn(k * settings.rollout_steps, reset_num_timesteps=False)
                episodes = train_env.drain_episodes()
                value, falls, val_steps = validate(model, normalizer, validation_env, settings)
                elapsed = time.perf_counter() - start
                physics = train_env.physics_steps - physics_before
                totals["segment"] += 1
                totals["rollouts"] += k
                totals["env_steps"] = int(model.num_timesteps)
                totals["physics_steps"] += physics
                totals["validation_sim_steps"] += val_steps
                totals["episodes"] += len(episodes)
                totals["falls"] += sum(e[2] for e in episodes)
                returns = [e[0] for e in episodes]
                if returns:
                    top = max(returns)
                    previous = totals["best_return_m"]
                    totals["best_return_m"] = top if previous is None else max(previous, top)
                    totals["last_mean_return_m"] = float(np.mean(returns))
                totals["wall_s"] += elapsed
                model_bytes = _model_bytes(model)
                normalizer_bytes = pickle.dumps(normalizer)
                if best is None or value > best["validation_m"]:
                    best = {
                        "validation_m": value,
                        "validation_fall_rate": falls,
                        "segment": totals["segment"],
                        "env_steps": totals["env_steps"],
                        "model": model_bytes,
                        "vecnormalize": normalizer_bytes,
                    }
                row = {
                    "segment": totals["segment"],
                    "env_steps": totals["env_steps"],
                    "physics_steps": totals["physics_steps"],
                    "episodes": len(episodes),
                    "mean_return_m": float(np.mean(returns)) if returns else "",
                    "fall_rate": float(np.mean([e[2] for e in episodes])) if episodes else "",
                    "validation_m": value,
                    "validation_fall_rate": falls,
                    "best_validation_m": best["validation_m"],
                    "steps_per_s": round(k * settings.rollout_steps / elapsed) if elapsed else 0,
                    "wall_s": round(totals["wall_s"], 3),
                }
                rows.append(row)
                state = {
                    "identity": identity,
                    "totals": totals,
                    "rows": rows,
                    "best": best,
                    "model": model_bytes,
                    "vecnormalize": normalizer_bytes,
                    "np_rng": np.random.get_state(),
                    "torch_rng": torch.get_rng_state(),
                }
                _write_bytes(checkpoint_path, pickle.dumps(state))
                csv.append(row)
                log(
                    f"segment {row['segment']:3d}  {row['env_steps']:,} steps  episodes "
                    f"{row['episodes']}  mean return {_fmt(row['mean_return_m'])} m  validation "
                    f"{value:+.3f} m (falls {falls:.0%})  {row['steps_per_s']:,} steps/s"
                )
                if on_checkpoint is not None:
                    on_checkpoint(dict(totals))
        final_model = _model_bytes(model)
        final_normalizer = pickle.dumps(normalizer)
    finally:
        train_env.close()
        validation_env.close()
    _write_bytes(os.path.join(run_dir, "final_model.zip"), final_model)
    _write_bytes(os.path.join(run_dir, "final_vecnormalize.pkl"), final_normalizer)
    _write_bytes(os.path.join(run_dir, "selected_model.zip"), best["model"])
    _write_bytes(os.path.join(run_dir, "selected_vecnormalize.pkl"), best["vecnormalize"])
    summary = {
        "action_space": settings.action_space,
        "best_distance_m": totals["best_return_m"],
        "final_mean_distance_m": totals["last_mean_return_m"],
        "evaluations": totals["episodes"],
        "falls_total": totals["falls"],
        "env_steps": totals["env_steps"],
        "sim_steps": totals["physics_steps"],
        "validation_sim_steps": totals["validation_sim_steps"],
        "segments": totals["segment"],
        "wall_s": totals["wall_s"],
        "selected": {
            "source": f"segment_{best['segment']}",
            "env_steps": best["env_steps"],
            "validation_success_weighted_m": best["validation_m"],
            "validation_fall_rate": best["validation_fall_rate"],
            "validation_seeds": settings.validation_seeds,
        },
    }
    if settings.test_seeds:
        policy = PPOPolicy(_load_model(best["model"]), pickle.loads(best["vecnormalize"]), settings)
        card = score.score_policy(
            policy,
            score.ScoreSettings(
                tiers=settings.test_tiers,
                seeds=settings.test_seeds,
                steps=settings.trial_steps,
                threads=options.threads,
            ),
        )
        summary["test"] = {k: card[k] for k in ("tiers", "all", "scoring_sim_steps")}
        log(
            f"selected policy: segment {best['segment']} (validation {best['validation_m']:+.3f} m)"
        )
        log(score.format_card(card))
    return summary


def _fmt(value) -> str:
    return "n/a" if value == "" or value is None else f"{value:+.3f}"


def summary_line(run_dir: str, summary: dict) -> str:
    """One line describing a finished run."""
    line = (
        f"{run_dir}: {summary['env_steps']:,} env steps, {summary['sim_steps']:,} physics steps, "
        f"selected {summary['selected']['source']} (validation "
        f"{summary['selected']['validation_success_weighted_m']:+.3f} m)"
    )
    if "test" in summary:
        swd = summary["test"]["all"]["success_weighted_distance_m"]
        line += f"; test score {swd['mean']:+.3f} m [{swd['ci95'][0]:+.3f}, {swd['ci95'][1]:+.3f}]"
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


def main(argv):
    del argv
    settings = cli.settings_from_flags(PPOSettings)
    options = cli.settings_from_flags(runs.RunOptions)
    try:
        run_dir, summary = run(settings, options)
    except runs.RunDirectoryExists as e:
        raise cli.UsageError(f"{e} (or --resume to continue it)") from None
    except CheckpointError as e:
        raise cli.UsageError(str(e)) from None
    progress.write(summary_line(run_dir, summary))


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_dirs=("output_dir",))
