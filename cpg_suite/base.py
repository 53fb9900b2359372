"""Pieces shared by the cpg_suite domains: assets, the task base class, action checks."""

from __future__ import annotations

import math
import os

import mujoco
import numpy as np
from dm_env import specs

from cpg_suite._headless import suite_base

_XML_DIR = os.path.join(os.path.dirname(__file__), "xml")
_COMMON_FILES = ("materials.xml", "skybox.xml", "visual.xml")


def read_model(filename: str) -> str:
    """Returns the text of an MJCF file in `cpg_suite/xml/`.

    Args:
      filename: File name relative to the `xml/` folder, e.g. `"pole.xml"`.

    Returns:
      The file's contents.
    """
    with open(os.path.join(_XML_DIR, filename), encoding="utf-8") as f:
        return f.read()


def _read_assets() -> dict[str, bytes]:
    return {
        f"./common/{name}": read_model(os.path.join("common", name)).encode("utf-8")
        for name in _COMMON_FILES
    }


# Assets shared by every model (included as ./common/<name>.xml).
ASSETS = _read_assets()


def make_environment(
    physics,
    task,
    time_limit: float,
    control_timestep: float,
    environment_kwargs: dict | None = None,
):
    """`control.Environment` with the domain's control step unless the caller sets one."""
    from dm_control.rl import control

    environment_kwargs = dict(environment_kwargs or {})
    environment_kwargs.setdefault("control_timestep", control_timestep)
    return control.Environment(physics, task, time_limit=time_limit, **environment_kwargs)


def model_and_assets(filename: str) -> tuple[str, dict[str, bytes]]:
    """Returns `(xml_string, assets)` for `Physics.from_xml_string`."""
    return read_model(filename), ASSETS


class Task(suite_base.Task):
    """Base class of cpg_suite tasks.

    Identical to `dm_control.suite.base.Task` except for reward visualization: our rewards
    follow the study (metres, −θ², ...) and are not confined to [0, 1], so each task maps
    its reward into [0, 1] with `reward_to_unit` before the colours are blended.
    """

    def reseed(self, seed: int) -> None:
        """Replaces the task's random generator by a new one seeded with `seed`.

        The next reset then draws exactly what a task created with `random=seed` draws in
        its first episode: evaluators reuse one environment for many seeds this way.
        """
        self._random = np.random.RandomState(seed)

    def action_spec(self, physics):
        """The task's own action spec, `self._action_spec` (set by each task)."""
        del physics
        return self._action_spec

    def reward_to_unit(self, reward: float) -> float:
        """Maps a reward to [0, 1] for colouring (1 = best). Override per task."""
        return float(np.clip(reward, 0.0, 1.0))

    def after_step(self, physics) -> None:
        if self._visualize_reward:
            unit = float(np.clip(self.reward_to_unit(self.get_reward(physics)), 0.0, 1.0))
            set_reward_colors(physics, unit)


# The materials that reward visualization blends (xml/common/materials.xml), the same
# scheme as the dm_control suite's: each `<name>` goes from `<name>_default` to
# `<name>_highlight` as the reward goes from 0 to 1.
_REWARD_MATERIALS = ("self", "effector", "target")


def set_reward_colors(physics, unit_reward: float) -> None:
    """Blends the self/effector/target materials by a reward in [0, 1] (1 = highlight).

    Args:
      physics: A physics whose model has the materials of `xml/common/materials.xml`.
      unit_reward: The reward mapped into [0, 1].

    Raises:
      ValueError: If `unit_reward` is outside [0, 1].
    """
    if not 0.0 <= unit_reward <= 1.0:
        raise ValueError(f"unit reward must lie in [0, 1], got {unit_reward}")
    colors = physics.named.model.mat_rgba
    default = colors[[f"{m}_default" for m in _REWARD_MATERIALS]]
    highlight = colors[[f"{m}_highlight" for m in _REWARD_MATERIALS]]
    blend = unit_reward**4  # Like dm_control: better contrast near high rewards.
    colors[list(_REWARD_MATERIALS)] = blend * highlight + (1.0 - blend) * default


def check_continuous_action(
    action, spec: specs.BoundedArray, out: np.ndarray | None = None
) -> np.ndarray:
    """Validates a continuous action and clips it to the spec's bounds.

    Args:
      action: Array-like action.
      spec: The task's action spec.
      out: A float64 array of `spec.shape` for the clipped action (None: a new one).

    Returns:
      A float64 array of `spec.shape`, clipped to `[spec.minimum, spec.maximum]` (`out`
      when given).

    Raises:
      ValueError: If the shape differs from the spec's or a value is NaN or infinite.
    """
    if isinstance(action, np.ndarray) and action.dtype == np.float64:
        arr = action  # Fast path: the common case on the per-step hot path.
    else:
        try:
            arr = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise ValueError(
                f"action must be numeric with shape {spec.shape}, got {action!r}"
            ) from e
    if arr.shape != spec.shape:
        if arr.size == int(np.prod(spec.shape)) and arr.ndim <= 1:
            arr = arr.reshape(spec.shape)
        else:
            raise ValueError(f"action has shape {arr.shape}, expected {spec.shape}")
    if not _all_finite(arr):
        raise ValueError(f"action contains NaN or infinite values: {arr!r}")
    # `np.clip` for finite values, without its Python wrapper's cost on the hot path.
    return np.minimum(np.maximum(arr, spec.minimum, out=out), spec.maximum, out=out)


def _all_finite(arr: np.ndarray) -> bool:
    """`np.isfinite(arr).all()` for the few numbers of an action, in Python: a fraction
    of NumPy's two calls."""
    return all(map(math.isfinite, arr.reshape(-1).tolist()))


def check_discrete_action(action, spec: specs.DiscreteArray) -> int:
    """Validates a discrete action.

    Args:
      action: An integer (or an integral float, or a size-1 array of one).
      spec: The task's `DiscreteArray` spec.

    Returns:
      The action as a Python int.

    Raises:
      ValueError: If the action is not a single integral value in `[0, num_values)`.
    """
    arr = np.asarray(action)
    if arr.size != 1:
        raise ValueError(
            f"action must be a single integer in [0, {spec.num_values}), got shape {arr.shape}"
        )
    try:
        value = float(arr.reshape(()))
    except (TypeError, ValueError) as e:
        raise ValueError(f"action must be an integer, got {action!r}") from e
    if not np.isfinite(value) or value != int(value):
        raise ValueError(f"action must be an integer in [0, {spec.num_values}), got {value!r}")
    index = int(value)
    if not 0 <= index < spec.num_values:
        raise ValueError(f"action {index} is out of range [0, {spec.num_values})")
    return index


# The warnings after which dm_control declares the physics state invalid (PhysicsError).
_INVALID_STATE_WARNINGS = list(
    int(w)
    for w in (
        mujoco.mjtWarning.mjWARN_BADQACC,
        mujoco.mjtWarning.mjWARN_BADQVEL,
        mujoco.mjtWarning.mjWARN_BADQPOS,
    )
)


def clear_invalid_state_warnings(data: mujoco.MjData) -> None:
    """Zeroes the warning counters that `invalid_state` reads (before a step)."""
    data.warning.number[_INVALID_STATE_WARNINGS] = 0


def invalid_state(data: mujoco.MjData) -> bool:
    """Whether the step raised a warning after which dm_control raises `PhysicsError`."""
    return bool(np.count_nonzero(data.warning.number[_INVALID_STATE_WARNINGS]))
