"""Gait-quality measures of one trial, from what the robot's physics steps record.

Both evaluation paths (the batched `mujoco.rollout` evaluator and the step-by-step policy
scorer) collect, after every physics step up to the end of the trial or its fall, the 12
leg joint velocities, the 12 leg servo torques (`actuatorfrc` sensors), the two sole touch
forces and the two soles' velocities, then call `measures` on the arrays: the same inputs
give the same numbers.

* cost of transport: positive mechanical work of the leg servos, Σ max(0, τ·q̇) Δt, divided
  by m·g·distance (NaN for a distance under 5 cm, where it means nothing);
* slip per metre: horizontal speed of the stance soles (touch force above 5 % of the
  weight) integrated over time, per metre walked (NaN under 5 cm);
* share of servo-steps at the torque limit (|τ| ≥ 99 % of it);
* flight share: physics steps with neither sole carrying 1 % of the weight;
* peak joint speed, rad/s, to compare with the MX-28's no-load speed of 5.76 rad/s.
"""

from __future__ import annotations

import numpy as np

MX28_NO_LOAD_SPEED = 5.76  # rad/s at 12 V (ROBOTIS MX-28 e-Manual).
GRAVITY = 9.81  # m/s²
MIN_DISTANCE = 0.05  # m: below this, per-metre measures are undefined (NaN).
_STANCE_FRACTION = 0.05  # of the weight: a sole carrying more is in stance.
_FLIGHT_FRACTION = 0.01  # of the weight: both soles below this is flight.
_LIMIT_FRACTION = 0.99  # of the torque limit: a servo at or above it is saturated.

FIELDS = (
    "cost_of_transport",
    "slip_per_m",
    "torque_limit_share",
    "flight_share",
    "peak_joint_speed",
)


def measures(
    joint_velocity: np.ndarray,
    torque: np.ndarray,
    touch: np.ndarray,
    sole_velocity: np.ndarray,
    *,
    timestep: float,
    torque_limit: float,
    mass: float,
    distance: float,
) -> dict:
    """The gait-quality measures of one trial.

    Args:
      joint_velocity: (T, 12) leg joint velocities after each physics step, rad/s.
      torque: (T, 12) leg servo torques, N·m.
      touch: (T, 2) normal force on the (left, right) soles, N.
      sole_velocity: (T, 2, 3) sole velocities in the world frame, m/s.
      timestep: Physics step, s.
      torque_limit: The servos' torque limit in this episode, N·m.
      mass: The robot's mass in this episode, kg.
      distance: Forward distance of the trial, m.

    Returns:
      A dict with `FIELDS`.
    """
    weight = mass * GRAVITY
    work = float(np.sum(np.maximum(torque * joint_velocity, 0.0)) * timestep)
    stance = touch > _STANCE_FRACTION * weight
    speed = np.hypot(sole_velocity[..., 0], sole_velocity[..., 1])
    slip = float(np.sum(np.where(stance, speed, 0.0)) * timestep)
    per_metre = distance >= MIN_DISTANCE
    return {
        "cost_of_transport": work / (weight * distance) if per_metre else float("nan"),
        "slip_per_m": slip / distance if per_metre else float("nan"),
        "torque_limit_share": float(np.mean(np.abs(torque) >= _LIMIT_FRACTION * torque_limit))
        if len(torque)
        else 0.0,
        "flight_share": float(np.mean(np.all(touch < _FLIGHT_FRACTION * weight, axis=1)))
        if len(touch)
        else 0.0,
        "peak_joint_speed": float(np.max(np.abs(joint_velocity), initial=0.0)),
    }
