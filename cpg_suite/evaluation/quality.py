"""Gait-quality measures of one trial, from what the robot's physics steps record.

Both evaluation paths (the batched `mujoco.rollout` evaluator and the step-by-step policy
scorer) collect, after every physics step up to the end of the trial (its time limit, fall
or brown-out), the 20 servos' joint velocities and forces (`actuatorfrc` sensors; the legs'
are the first 12, in `cpg.LEG_JOINTS` order), the two sole touch forces and the two soles'
velocities, and each foot's floor contacts and sole pose (`footing`), then call
`measures` on the arrays: the same inputs give the same numbers.

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
* the robot's electrical load (`cpg_suite.electrical`, docs/darwin_op_model.md#electrical-model),
  from all 20 servos' forces and joint velocities: mean supply current, A, and its worst
  1 s window; mean supply power, W (12 V × current), and supply energy per metre, J/m;
  the most loaded servo's RMS torque over its stall torque, and its mean copper loss over
  its stall copper loss (16.8 W; both 1 at a servo held stalled);
* how the feet meet the floor (`cpg_suite.evaluation.footing`, issue 54): slip at the
  floor contacts per metre (a foot rolling about an edge does not count, as it does in
  `slip_per_m`), the share of stance with the sole flat, the swing sole's clearance, and
  the shares of touchdowns that are toe and heel strikes.
"""

from __future__ import annotations

import numpy as np

from cpg_suite import electrical, portable
from cpg_suite.evaluation import footing

MX28_NO_LOAD_SPEED = electrical.NO_LOAD_SPEED  # rad/s at 12 V: 55 rpm.
GRAVITY = 9.81  # m/s²
MIN_DISTANCE = 0.05  # m: below this, per-metre measures are undefined (NaN).
_STANCE_FRACTION = 0.05  # of the weight: a sole carrying more is in stance.
_FLIGHT_FRACTION = 0.01  # of the weight: both soles below this is flight.
_LIMIT_FRACTION = 0.99  # of the torque limit: a servo at or above it is saturated.
N_LEGS = 12  # the leg servos: the first 12 of the 20
PEAK_WINDOW = electrical.SupplyLimit(window=1.0)  # the card's worst-window supply current

# The robot's electrical load (`_electrical`), then how the feet meet the floor
# (`footing.FIELDS`, added in issue 54): the last of `FIELDS`.
ELECTRICAL_FIELDS = (
    "electrical_power_w",
    "energy_per_m",
    "supply_current_a",
    "supply_peak_1s_a",
    "rms_torque_ratio",
    "copper_loss_ratio",
)
FIELDS = (
    "cost_of_transport",
    "slip_per_m",
    "torque_limit_share",
    "flight_share",
    "peak_joint_speed",
    "over_speed_share",
    "over_speed_motor_share",
    "over_speed_external_share",
    *ELECTRICAL_FIELDS,
    *footing.FIELDS,
)


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
    servo_velocity: np.ndarray,
    servo_force: np.ndarray,
    touch: np.ndarray,
    sole_velocity: np.ndarray,
    feet: np.ndarray,
    *,
    damping: np.ndarray,
    timestep: float,
    torque_limit: float,
    mass: float,
    distance: float,
) -> dict:
    """The gait-quality measures of one trial.

    Args:
      servo_velocity: (T, 20) the servos' joint velocities after each physics step, rad/s,
        in actuator order (the 12 legs' first).
      servo_force: (T, 20) the servos' forces, N·m.
      touch: (T, 2) normal force on the (left, right) soles, N.
      sole_velocity: (T, 2, 3) sole velocities in the world frame, m/s.
      feet: (T, 2, `footing.FOOT_WIDTH`) the (left, right) feet's footing sensors (floor
        contacts, sole pose: `darwin.robot.sensor_slices`' "footing").
      damping: (20,) the servos' joint damping in this episode, N·m·s/rad.
      timestep: Physics step, s.
      torque_limit: The servos' torque limit in this episode, N·m.
      mass: The robot's mass in this episode, kg.
      distance: Forward distance of the trial, m.

    Returns:
      A dict with `FIELDS`.
    """
    joint_velocity, torque = servo_velocity[:, :N_LEGS], servo_force[:, :N_LEGS]
    weight = mass * GRAVITY
    work = float(np.sum(np.maximum(torque * joint_velocity, 0.0)) * timestep)
    stance = touch > _STANCE_FRACTION * weight
    speed = portable.hypot(sole_velocity[..., 0], sole_velocity[..., 1])
    slip = float(np.sum(np.where(stance, speed, 0.0)) * timestep)
    per_metre = distance >= MIN_DISTANCE
    motor, external = over_speed(torque, joint_velocity)
    steps = len(torque)
    load = _electrical(servo_velocity, servo_force, damping, timestep)
    return {
        "cost_of_transport": work / (weight * distance) if per_metre else float("nan"),
        "slip_per_m": slip / distance if per_metre else float("nan"),
        "torque_limit_share": float(np.mean(np.abs(torque) >= _LIMIT_FRACTION * torque_limit))
        if steps
        else 0.0,
        "flight_share": float(np.mean(np.all(touch < _FLIGHT_FRACTION * weight, axis=1)))
        if steps
        else 0.0,
        "peak_joint_speed": float(np.max(np.abs(joint_velocity), initial=0.0)),
        "over_speed_share": float(np.mean(motor | external)) if steps else 0.0,
        "over_speed_motor_share": float(np.mean(motor)) if steps else 0.0,
        "over_speed_external_share": float(np.mean(external)) if steps else 0.0,
        "electrical_power_w": load["power"],
        "energy_per_m": load["energy"] / distance if per_metre else float("nan"),
        "supply_current_a": load["current"],
        "supply_peak_1s_a": load["peak"],
        "rms_torque_ratio": load["rms_torque"],
        "copper_loss_ratio": load["copper"],
        **footing.measures(
            sole_velocity,
            feet,
            stance_force=_STANCE_FRACTION * weight,
            timestep=timestep,
            distance=distance,
            min_distance=MIN_DISTANCE,
        ),
    }


def _electrical(velocity: np.ndarray, force: np.ndarray, damping, timestep: float) -> dict:
    """The robot's electrical load over a trial (`cpg_suite.electrical`)."""
    if not len(force):
        return dict.fromkeys(("power", "energy", "current", "peak", "rms_torque", "copper"), 0.0)
    current = electrical.supply_current(force, velocity, damping)
    monitor = electrical.SupplyMonitor(PEAK_WINDOW, timestep, enforce=False)
    monitor.update(current)
    mean = monitor.mean()
    rms = np.sqrt(np.mean(force * force, axis=0))
    copper = np.mean(electrical.copper_loss(force, velocity, damping), axis=0)
    return {
        "power": mean * electrical.SUPPLY_VOLTAGE,
        "energy": mean * electrical.SUPPLY_VOLTAGE * len(force) * timestep,
        "current": mean,
        "peak": monitor.worst,
        "rms_torque": float(rms.max() / electrical.STALL_TORQUE),
        "copper": float(copper.max() / electrical.STALL_COPPER_LOSS),
    }
