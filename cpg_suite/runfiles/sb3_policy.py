r"""A Stable-Baselines3 policy as a run folder holds it: `selected_model.zip` (the SB3 model)
and `selected_vecnormalize.pkl` (its observation normalizer), loaded as a policy.

Needs the `rl` extra (Stable-Baselines3, PyTorch); only runs of policy learners import this
module: `cpg_suite.harness.sb3` (training, and `--export`) and `cpg_suite.protocol.verify`
(scoring a shipped run's pickles). Loading a pickle runs its code.

* `TrainedPolicy`: a trained model and its `VecNormalize` statistics as a policy for one
  environment, as `cpg_suite.protocol.score.score_policy` runs it; it acts through its
  export (`export_policy`: the network's arithmetic in NumPy, `exported.NumpyPolicy`, the
  same bits on any x86-64 CPU).
* `load_shipped_policy`: a run's selected policy from its pickles.
* `import_torch`, `load_model`, `model_bytes`: torch imported safely, models to and from
  bytes; `single_threaded`: torch on one thread for a while (training and scoring use it:
  a policy's actions then do not depend on the machine's core count).

Import order: with MUJOCO_GL=egl, torch must be imported before dm_control loads (README);
this module imports torch before any module of `cpg_suite`.
"""

from __future__ import annotations

import contextlib
import importlib
import io
import os
import pickle
import sys
import types
from typing import Protocol

import numpy as np
import stable_baselines3
import torch  # before cpg_suite: with MUJOCO_GL=egl the other order crashes torch (README)
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.distributions import DiagGaussianDistribution
from stable_baselines3.common.vec_env import VecEnv, VecNormalize

from cpg_suite.runfiles import exported

# The SB3 algorithm of each policy learner's method name (its run directories' second level).
ALGORITHMS = {"ppo": "PPO"}


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
    (`darwin.OBSERVATION_KEYS`, plus the CPG phase for the cpg action space), normalizes it
    with the run's VecNormalize statistics, takes the policy's mean action and, for the cpg
    action space, steps its own CPG row (`reset()` before each episode). `actor`: its network alone,
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
