r"""Stable-Baselines3 on the DARwIn-OP walking tiers: what any SB3 learner (PPO, SAC, ...) reuses.

Needs the `rl` extra (Stable-Baselines3, PyTorch, Gymnasium); only learners import this
module. As a command, `python -m cpg_suite.harness.sb3 --export=FOLDER` writes the selected
policy of every SB3 run under FOLDER as data, `selected_policy.npz` beside its pickles
(`export_run`), which verify then scores without SB3 or torch, the same trials.

* `make_vector_env`: the (dict-observation) vector env a policy acts in,
  `cpg_suite.vector.DarwinVectorEnv` with same-step autoreset, in one of two action spaces:
  `joints` (the 12 normalized leg joint targets) or `cpg` (the policy modulates the study's
  CPG every control step, `cpg_suite.residual.CPGActions`, and also sees its phase).
* `FlatVecEnv`: that env as an SB3 `VecEnv`, the observation dict flattened in the fixed
  order `OBS_KEYS` (then the CPG phase); `normalized` wraps it in SB3's `VecNormalize`.
* `TrainedPolicy`: a trained model and its `VecNormalize` statistics as a policy for one
  environment, as `cpg_suite.protocol.score.score_policy` runs it; it acts through its
  export (`export_policy`: the network's arithmetic in NumPy, `exported.NumpyPolicy`, the
  same bits on any x86-64 CPU).
* `export_run`: a run's selected policy written as data, `selected_policy.npz` beside its
  pickles (`python -m cpg_suite.harness.sb3 --export=FOLDER`, every run under a folder);
  verify then scores the arrays, the same trials bit for bit, without SB3 or torch.
* `import_torch`, `load_model`, `model_bytes`: torch imported safely, models to and from
  bytes; `single_threaded`: torch on one thread for a while (training and scoring use it:
  a policy's actions then do not depend on the machine's core count);
  `load_shipped_policy`: a run's selected policy from its pickles.

Import order: with MUJOCO_GL=egl, torch must be imported before dm_control loads (README);
this module imports torch before any module of `cpg_suite`.
"""

from __future__ import annotations

import contextlib
import importlib
import io
import math
import os
import pickle
import sys
import types
from typing import Protocol

import gymnasium
import numpy as np
import stable_baselines3
import torch  # before cpg_suite: with MUJOCO_GL=egl the other order crashes torch (README)
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.distributions import DiagGaussianDistribution
from stable_baselines3.common.vec_env import VecEnv, VecNormalize

from cpg_suite import cli, darwin, electrical, protocol, residual, vector
from cpg_suite.harness import exported, runs

# The SB3 algorithm of each policy learner's method name (its run directories' second level).
ALGORITHMS = {"ppo": "PPO"}

# The flattened observation: these keys of the task's observation, in this order (then the
# CPG phase for the cpg action space).
OBS_KEYS = darwin.OBSERVATION_KEYS


class EnvSettings(Protocol):
    """The settings of a run that decide the environment its policy acts in."""

    @property
    def task(self) -> str: ...  # the training tier

    @property
    def action_space(self) -> str: ...  # "joints" or "cpg"

    @property
    def trial_steps(self) -> int: ...  # control steps per episode

    @property
    def amplitude_scale(self) -> float: ...  # cpg: degrees per unit action

    @property
    def rate_scale(self) -> float: ...  # cpg: phase rate ω (1 + rate_scale · a)

    @property
    def benchmark_version(self) -> int: ...  # its supply limit holds in the envs


# Environments.
def make_vector_env(
    settings: EnvSettings, num_envs: int, threads: int | None = None, task: str | None = None
) -> gymnasium.vector.VectorEnv:
    """The (dict-observation) vector env the policy acts in.

    Args:
      settings: The run's settings.
      num_envs: Sub-environments.
      threads: Physics threads (results do not depend on them; None: the usable CPUs).
      task: The tier (None: `settings.task`).

    Returns:
      `DarwinVectorEnv` with same-step autoreset and episodes of `trial_steps` under the
      supply limit of the settings' benchmark version, wrapped in the CPG action space for
      `action_space="cpg"`.
    """
    env = vector.DarwinVectorEnv(
        task or settings.task,
        num_envs,
        threads=threads,
        autoreset_mode=AutoresetMode.SAME_STEP,
        time_limit=settings.trial_steps * darwin.CONTROL_TIMESTEP,
        supply=protocol.supply_limit(settings.benchmark_version),
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
    it), `infos[i]["fell"]` and `infos[i]["episode"]` (the task's return `r`, length `l`,
    as SB3's `Monitor` gives). `seed(s)` makes the next `reset` seed sub-environment i with
    s + i. Finished episodes are collected for `drain_episodes`.

    With a `supply_cost` κ > 0 the learner's reward is shaped by the supply: each control
    step's reward loses κ times the charge the robot drew above its idle current in that
    step, r − κ·Σ_k (i_k − `electrical.IDLE_CURRENT`)·h over its physics steps k of h
    seconds (κ in metres per coulomb). The episodes' returns stay the task's.
    """

    def __init__(self, env: gymnasium.vector.VectorEnv, supply_cost: float = 0.0):
        """Args:
          env: The vector env (`make_vector_env`).
          supply_cost: κ, metres of reward per coulomb above the idle robot's draw (0: the
            task's reward).

        Raises:
          ValueError: If its autoreset mode is not same-step, or κ is negative or not finite.
        """
        if env.metadata.get("autoreset_mode") != AutoresetMode.SAME_STEP:
            raise ValueError("FlatVecEnv needs a vector env with AutoresetMode.SAME_STEP")
        if not (math.isfinite(supply_cost) and supply_cost >= 0):
            raise ValueError(f"supply_cost must be a finite number ≥ 0, got {supply_cost!r}")
        self.env = env
        self.supply_cost = float(supply_cost)
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

    def seed(self, seed: int | None = None) -> list[int | None]:
        """Seeds the next `reset`: sub-environment i with `seed` + i."""
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

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict]]:
        observations, rewards, terminated, truncated, extra = self.env.step(self._actions)
        rewards = np.asarray(rewards, dtype=np.float64)
        terminated, truncated = np.asarray(terminated), np.asarray(truncated)
        dones = terminated | truncated
        self._returns += rewards
        if self.supply_cost:
            rewards = rewards - self.supply_cost * self.charge_above_idle()
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

    def charge_above_idle(self) -> np.ndarray:
        """(N,) the charge each robot drew above its idle current in the last control step,
        C: Σ_k (i_k − `electrical.IDLE_CURRENT`)·h over its physics steps."""
        vector_env = self.env.unwrapped
        currents = vector_env.supply_currents()
        timestep = vector_env.envs[0].physics.timestep()
        return (currents - electrical.IDLE_CURRENT).sum(axis=1) * timestep

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


def normalized(env: VecEnv, gamma: float) -> VecNormalize:
    """`env` behind SB3's `VecNormalize`: observations (clipped at 10) and rewards.

    Args:
      env: The training env (`FlatVecEnv`).
      gamma: The learner's discount (the reward scale is that of the discounted return).

    Returns:
      The normalizing wrapper, its statistics fresh.
    """
    return VecNormalize(env, norm_obs=True, norm_reward=True, clip_obs=10.0, gamma=gamma)


# The trained policy.
def export_policy(
    model: BaseAlgorithm, normalizer: VecNormalize, settings: EnvSettings
) -> exported.NumpyPolicy:
    """A PPO `MlpPolicy`'s deterministic action as data, run with `cpg_suite.portable`'s
    arithmetic (`exported.NumpyPolicy`).

    Torch multiplies matrices with kernels (MKL, oneDNN) it picks for the CPU it runs on,
    and their last bits differ from CPU to CPU; in a walking robot's trial a last bit grows
    into a different fall. The export computes the same function portably: the raw
    observation normalized as `VecNormalize` does (its mean, var, epsilon and clip_obs;
    clipped, then rounded to float32, which is what SB3 hands torch), the policy network's
    layers (torch's float32 weights, exactly, as float64) with tanh between them
    (`exported.mlp`, `portable.tanh`), the Gaussian's mean clipped to the action box. It
    agrees with torch's float32 `predict` to about 1e-6 (a test) and with itself on every
    CPU, row by row, whatever the batch.

    Args:
      model: A trained SB3 model whose policy is an `ActorCriticPolicy` with a flat
        observation, Tanh hidden layers and a diagonal Gaussian head (PPO's `MlpPolicy`).
      normalizer: Its VecNormalize (statistics only), normalizing observations.
      settings: The run's settings (its action space and, for `cpg`, its scales).

    Returns:
      The policy (`exported.NumpyPolicy`; `.save` writes its `selected_policy.npz`).

    Raises:
      ValueError: On any other policy (another activation, head or extractor), or a
        normalizer that does not normalize observations.
    """
    policy = model.policy
    hidden = list(policy.mlp_extractor.policy_net)
    linear = [m for m in hidden if isinstance(m, torch.nn.Linear)]
    if (
        not isinstance(policy.action_dist, DiagGaussianDistribution)
        or policy.squash_output
        or any(not isinstance(m, (torch.nn.Linear, torch.nn.Tanh)) for m in hidden)
        or len(linear) * 2 != len(hidden)
    ):
        raise ValueError("export_policy needs an MlpPolicy: Tanh layers, a Gaussian head")
    if not normalizer.norm_obs:
        raise ValueError("export_policy needs a VecNormalize that normalizes observations")
    rms, space = normalizer.obs_rms, policy.action_space
    arrays = {
        "mean": np.asarray(rms.mean, np.float64),
        "var": np.asarray(rms.var, np.float64),
        "epsilon": np.float64(normalizer.epsilon),
        "clip_obs": np.float64(normalizer.clip_obs),
        "input_dtype": np.array("float32"),
        "activation": np.array("tanh"),
        "head": np.array("normal"),
        "action_low": np.asarray(space.low, np.float64),
        "action_high": np.asarray(space.high, np.float64),
    }
    if settings.action_space == "cpg":
        arrays["amplitude_scale"] = np.float64(settings.amplitude_scale)
        arrays["rate_scale"] = np.float64(settings.rate_scale)
    for i, layer in enumerate([*linear, policy.action_net]):
        arrays[f"kernel_{i}"], arrays[f"bias_{i}"] = _float64(layer)
    return exported.NumpyPolicy(arrays, settings.action_space)


def _float64(layer: torch.nn.Linear) -> tuple[np.ndarray, np.ndarray]:
    """A linear layer's (inputs, outputs) weight and its bias, exactly, as float64."""
    weight = layer.weight.detach().cpu().numpy().astype(np.float64).T
    return np.ascontiguousarray(weight), layer.bias.detach().cpu().numpy().astype(np.float64)


class TrainedPolicy:
    """A trained policy for one environment (`cpg_suite.protocol.score.score_policy`): a dm_env
    observation → (12,) normalized joint targets, deterministic.

    Its export (`export_policy`, `self.exported`) acts: it flattens the observation
    (`OBS_KEYS`, plus the CPG phase for the cpg action space), normalizes it with the run's
    VecNormalize statistics, takes the policy's mean action and, for the cpg action space,
    steps its own CPG row (`reset()` before each episode). `actor`: its network alone,
    (N, D) raw flat observations → (N, A) actions.
    """

    def __init__(self, model: BaseAlgorithm, normalizer: VecNormalize, settings: EnvSettings):
        """Args:
        model: The trained SB3 model.
        normalizer: Its VecNormalize (statistics only; not updated).
        settings: The run's settings (its action space).
        """
        self.model, self.normalizer, self.settings = model, normalizer, settings
        self.exported = export_policy(model, normalizer, settings)
        self.actor = self.exported.act

    @classmethod
    def load(
        cls,
        run_dir: str,
        algorithm: type[BaseAlgorithm],
        settings: EnvSettings,
        which: str = "selected",
    ) -> TrainedPolicy:
        """A run's policy from `<which>_model.zip` and `<which>_vecnormalize.pkl`.

        Args:
          run_dir: The run directory.
          algorithm: The SB3 algorithm class that trained it (e.g. `PPO`).
          settings: The run's settings.
          which: "selected" (the best validation) or "final".

        Returns:
          The policy.
        """
        with open(os.path.join(run_dir, f"{which}_model.zip"), "rb") as f:
            data = f.read()
        with open(os.path.join(run_dir, f"{which}_vecnormalize.pkl"), "rb") as f:
            normalizer = pickle.loads(f.read())
        return cls(load_model(algorithm, data), normalizer, settings)

    def reset(self) -> None:
        """Restarts the policy's CPG (before each episode)."""
        self.exported.reset()

    def reset_batch(self, rows: int) -> None:
        """Starts `rows` trials stepped together (`act_batch`; `score.batched_policy_trials`)."""
        self.exported.reset_batch(rows)

    def act_batch(self, observations: dict) -> np.ndarray:
        """(n, 12) actions for n trials' observations ((n, ...) arrays), each row what
        `__call__` gives that trial (`exported.NumpyPolicy.act_batch`)."""
        return self.exported.act_batch(observations)

    def __call__(self, observation: dict) -> np.ndarray:
        return self.exported(observation)


def predict(model: BaseAlgorithm, normalizer: VecNormalize, flat: np.ndarray) -> np.ndarray:
    """The deterministic (mean) actions, clipped to [−1, 1], for raw flat observations.

    Args:
      model: The SB3 model.
      normalizer: Its VecNormalize (statistics only; not updated).
      flat: (N, D) raw flattened observations.

    Returns:
      (N, A) float64 actions.

    `model.predict(..., deterministic=True)`'s steps with the policy's own methods, but the
    policy is put in evaluation mode only when it is not (SB3 walks all its modules on
    every call, a third of a one-row call's time); the same arithmetic, the same bits.
    Torch's: training's validation uses it; the test protocol uses `export_policy`'s.
    """
    policy = model.policy
    if policy.training:
        policy.set_training_mode(False)
    observation, _ = policy.obs_to_tensor(normalizer.normalize_obs(flat))
    with torch.no_grad():
        actions = policy._predict(observation, deterministic=True)
    actions = actions.cpu().numpy().reshape((-1, *policy.action_space.shape))
    if policy.squash_output:
        actions = policy.unscale_action(actions)
    else:
        actions = np.clip(actions, policy.action_space.low, policy.action_space.high)
    return np.asarray(actions, dtype=np.float64)


# Torch and models.
def import_torch() -> types.ModuleType:
    """torch, with `torch._dynamo` imported while Triton is hidden.

    With MUJOCO_GL=egl, dm_control's EGL bindings are loaded when `cpg_suite` is imported,
    and importing Triton's native library after them crashes the process (segmentation
    fault). torch imports Triton lazily, through `torch._dynamo`, when the first optimizer
    is built; CPU training never uses Triton, so `torch._dynamo` is imported with Triton
    reported missing (only if neither is imported yet). Nothing else changes.

    Returns:
      The `torch` module.
    """
    if "torch._dynamo" not in sys.modules and "triton" not in sys.modules:
        sys.modules["triton"] = None  # `import triton` raises ImportError
        try:
            importlib.import_module("torch._dynamo")
        finally:
            del sys.modules["triton"]
    return torch


def load_model(
    algorithm: type[BaseAlgorithm], data: bytes, env: VecEnv | None = None
) -> BaseAlgorithm:
    """A model saved by `model_bytes`, on the CPU.

    Args:
      algorithm: Its SB3 algorithm class (e.g. `PPO`).
      data: The saved model (an SB3 zip file's bytes).
      env: The env it goes on training in (None: it only predicts).

    Returns:
      The model, with its optimizer state.
    """
    import_torch()
    return algorithm.load(io.BytesIO(data), env=env, device="cpu")


def model_bytes(model: BaseAlgorithm) -> bytes:
    """The model saved as an SB3 zip file (with its optimizer state), as bytes."""
    buf = io.BytesIO()
    model.save(buf)
    return buf.getvalue()


@contextlib.contextmanager
def single_threaded():
    """Runs the block with torch on one thread, then restores the thread count."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(threads)


def load_shipped_policy(run_dir: str, method: str, settings: dict) -> TrainedPolicy:
    """The selected policy of a run (`selected_model.zip`, `selected_vecnormalize.pkl`).

    Args:
      run_dir: The run directory or shipped run.
      method: The learner's method name (a key of `ALGORITHMS`).
      settings: The run's settings (config.json's "settings").

    Returns:
      The policy.

    Raises:
      ValueError: On a method without a known SB3 algorithm.
    """
    if method not in ALGORITHMS:
        raise ValueError(f"unknown policy learner {method!r}; known: {', '.join(ALGORITHMS)}")
    algorithm = getattr(stable_baselines3, ALGORITHMS[method])
    return TrainedPolicy.load(run_dir, algorithm, types.SimpleNamespace(**settings))


# Exporting shipped runs as data.
SB3_FILES = ("selected_model.zip", "selected_vecnormalize.pkl")  # a run's selected policy


def sb3_runs(folder: str) -> list[str]:
    """The run folders under `folder` (itself included) that hold `SB3_FILES`, sorted."""
    return sorted(d for d, _, names in os.walk(folder) if all(n in names for n in SB3_FILES))


def export_run(run_dir: str, overwrite: bool = False) -> tuple[str, str]:
    """Writes a run's selected SB3 policy as data: `selected_policy.npz` beside its pickles
    (`export_policy`), which verify then scores instead of them (the same trials).

    Loading the pickles runs their code: export runs of your own, or the project's.

    Args:
      run_dir: A run folder with `SB3_FILES` and config.json, under `<method>/<task>/`
        (the method names the SB3 algorithm, `ALGORITHMS`).
      overwrite: Whether an existing `selected_policy.npz` that differs is replaced.

    Returns:
      (the file's path, "wrote", "same" (the file held these arrays already) or "replaced").

    Raises:
      OSError, KeyError, ValueError: On a run without readable files, of an unknown
        method, or whose policy `export_policy` does not compute.
      FileExistsError: If the run holds another `selected_policy.npz` and not `overwrite`.
    """
    config = runs.read_json(os.path.join(run_dir, "config.json"))
    method = os.path.basename(os.path.dirname(os.path.dirname(os.path.abspath(run_dir))))
    policy = load_shipped_policy(run_dir, method, config["settings"])
    arrays = {**policy.exported.arrays(), "action_space": np.array(policy.exported.action_space)}
    path = os.path.join(run_dir, exported.FILE)
    status = "wrote"
    if os.path.exists(path):
        with np.load(path, allow_pickle=False) as old:
            if set(old.files) == set(arrays) and all(
                old[k].dtype == v.dtype and np.array_equal(old[k], v) for k, v in arrays.items()
            ):
                return path, "same"
        if not overwrite:
            raise FileExistsError(f"{path} holds another policy (--overwrite replaces it)")
        status = "replaced"
    policy.exported.save(path)
    return path, status


def main(argv: list[str]) -> None:
    """`--export`: every SB3 run under a folder written as data (`export_run`)."""
    del argv
    from absl import flags

    values = flags.FLAGS
    folder = values.export
    cli.check(os.path.isdir(folder), f"--export={folder}: no such folder")
    found = sb3_runs(folder)
    cli.check(bool(found), f"--export={folder}: no run under it holds {' and '.join(SB3_FILES)}")
    for run_dir in found:
        try:
            path, status = export_run(run_dir, values.overwrite)
        except (OSError, KeyError, ValueError) as e:
            raise cli.UsageError(f"{run_dir}: {e}") from None
        print(f"{status:8} {path}")
    print(f"{len(found)} runs' policies exported as {exported.FILE}")


if __name__ == "__main__":
    from absl import flags

    flags.DEFINE_string(
        "export",
        None,
        f"A run folder, or a folder of runs: writes {exported.FILE} (the selected policy as "
        f"NumPy arrays, no pickle) beside the {' and '.join(SB3_FILES)} of each run under it.",
        required=True,
    )
    flags.DEFINE_bool("overwrite", False, f"Replace a {exported.FILE} that holds another policy.")
    cli.run(main)
