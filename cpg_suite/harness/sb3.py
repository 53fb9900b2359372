r"""Stable-Baselines3 on the DARwIn-OP walking tiers: what any SB3 learner (PPO, SAC, ...) reuses.

Needs the `rl` extra (Stable-Baselines3, PyTorch, Gymnasium); only learners import this
module. As a command, `python -m cpg_suite.harness.sb3 --export=FOLDER` writes the selected
policy of every SB3 run under FOLDER as data, `selected_policy.npz` beside its pickles
(`export_run`), which verify then scores without SB3 or torch, the same trials.

* `make_vector_env`: the (dict-observation) vector env a policy acts in,
  `cpg_suite.vector.DarwinVectorEnv` with same-step autoreset, in one of two action spaces:
  `joints` (the 12 normalized leg joint targets) or `cpg` (the policy modulates the study's
  CPG every control step, `cpg_suite.vector.CPGActions`, and also sees its phase).
* `FlatVecEnv`: that env as an SB3 `VecEnv`, the observation dict flattened in the fixed
  order `OBS_KEYS` (then the CPG phase); `normalized` wraps it in SB3's `VecNormalize`.
* `predict`: torch's deterministic actions (training's validation).
* `export_run`: a run's selected policy written as data, `selected_policy.npz` beside its
  pickles (`python -m cpg_suite.harness.sb3 --export=FOLDER`, every run under a folder);
  verify then scores the arrays, the same trials bit for bit, without SB3 or torch.

The policy as a run folder holds it — `TrainedPolicy`, `export_policy`, `load_model`,
`model_bytes`, `import_torch`, `single_threaded`, `load_shipped_policy` — is
`cpg_suite.runfiles.sb3_policy`'s, which verify loads too.

Import order: with MUJOCO_GL=egl, torch must be imported before dm_control loads (README);
this module imports torch before any module of `cpg_suite`.
"""

from __future__ import annotations

import math
import os

import gymnasium
import numpy as np
import torch  # before cpg_suite: with MUJOCO_GL=egl the other order crashes torch (README)
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.vec_env import VecEnv, VecNormalize

from cpg_suite import cli, darwin, electrical, protocol, residual, vector
from cpg_suite.runfiles import exported, runs, sb3_policy

# The flattened observation: these keys of the task's observation, in this order (then the
# CPG phase for the cpg action space).
OBS_KEYS = darwin.OBSERVATION_KEYS


# Environments.
def make_vector_env(
    settings: sb3_policy.EnvSettings,
    num_envs: int,
    threads: int | None = None,
    task: str | None = None,
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
        env = vector.CPGActions(
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


# Torch's arithmetic.
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
    policy = sb3_policy.load_shipped_policy(run_dir, method, config["settings"])
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
