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
* peak joint speed, rad/s, to compare with the MX-28's no-load speed of 5.76 rad/s;
* over-speed share: servo-steps in which a leg joint turns faster than that no-load speed,
  split into motor-driven (the servo's torque along the motion, τ·q̇ > 0: the servo itself
  pushes the joint on) and externally driven (τ·q̇ ≤ 0: the servo brakes or is idle, and
  gravity, contacts or the rest of the body turn the joint);
* the leg servos' electrical power, W, and energy per metre, J/m, from the MX-28 datasheet
  (docs/darwin_op_model.md#servos-dynamixel-mx-28): current I = 1.4 A · |τ| / 2.5 N·m
  (stall current at stall torque), winding resistance R = 12 V / 1.4 A, each servo drawing
  its copper loss I²R plus the mechanical power it delivers, τ·q̇, and never less than 0
  (power a joint returns is not recovered). Summed over the 12 leg servos, averaged over
  the trial (power) or integrated and divided by the distance (energy per metre).
"""

from __future__ import annotations

import numpy as np

from cpg_suite import portable

MX28_NO_LOAD_SPEED = 5.76  # rad/s at 12 V (ROBOTIS MX-28 e-Manual).
GRAVITY = 9.81  # m/s²
MIN_DISTANCE = 0.05  # m: below this, per-metre measures are undefined (NaN).
_STANCE_FRACTION = 0.05  # of the weight: a sole carrying more is in stance.
_FLIGHT_FRACTION = 0.01  # of the weight: both soles below this is flight.
_LIMIT_FRACTION = 0.99  # of the torque limit: a servo at or above it is saturated.
MX28_STALL_TORQUE = 2.5  # N·m at 12 V (ROBOTIS MX-28 e-Manual).
MX28_STALL_CURRENT = 1.4  # A at 12 V (ROBOTIS MX-28 e-Manual).
MX28_VOLTAGE = 12.0  # V: the supply of the datasheet figures.
MX28_RESISTANCE = MX28_VOLTAGE / MX28_STALL_CURRENT  # Ω: winding resistance, 8.57.

FIELDS = (
    "cost_of_transport",
    "slip_per_m",
    "torque_limit_share",
    "flight_share",
    "peak_joint_speed",
    "over_speed_share",
    "over_speed_motor_share",
    "over_speed_external_share",
    "electrical_power_w",
    "energy_per_m",
)


def electrical_power(torque: np.ndarray, joint_velocity: np.ndarray) -> np.ndarray:
    """Each servo's electrical power from the datasheet: max(0, I²R + τ·q̇), W.

    Args:
      torque: Servo torques, N·m (any shape).
      joint_velocity: Joint velocities of the same shape, rad/s.

    Returns:
      The power of each servo, W, the shape of `torque`.
    """
    current = MX28_STALL_CURRENT * np.abs(torque) / MX28_STALL_TORQUE
    return np.maximum(current * current * MX28_RESISTANCE + torque * joint_velocity, 0.0)


def over_speed(torque: np.ndarray, joint_velocity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which servo-steps turn faster than the MX-28's no-load speed, and by whose drive.

    Args:
      torque: Servo torques, N·m (any shape).
      joint_velocity: Joint velocities of the same shape, rad/s.

    Returns:
      `(motor, external)` boolean arrays: over the no-load speed with the servo's torque
      along the motion (τ·q̇ > 0), and over it otherwise.
    """
    fast = np.abs(joint_velocity) > MX28_NO_LOAD_SPEED
    along = torque * joint_velocity > 0.0
    return fast & along, fast & ~along


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
    speed = portable.hypot(sole_velocity[..., 0], sole_velocity[..., 1])
    slip = float(np.sum(np.where(stance, speed, 0.0)) * timestep)
    per_metre = distance >= MIN_DISTANCE
    motor, external = over_speed(torque, joint_velocity)
    energy = float(np.sum(electrical_power(torque, joint_velocity)) * timestep)
    steps = len(torque)
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
        "over_speed_share": float(np.mean(motor | external)) if steps else 0.0,
        "over_speed_motor_share": float(np.mean(motor)) if steps else 0.0,
        "over_speed_external_share": float(np.mean(external)) if steps else 0.0,
        "electrical_power_w": energy / (steps * timestep) if steps else 0.0,
        "energy_per_m": energy / distance if per_metre else float("nan"),
    }
