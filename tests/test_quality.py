"""Known answers of the gait-quality measures (`cpg_suite.evaluation.quality`)."""

import math

import numpy as np
import pytest

from cpg_suite import electrical
from cpg_suite.evaluation import footing, quality

TIMESTEP = 0.002  # s
MASS = 2.0  # kg
WEIGHT = MASS * quality.GRAVITY
DAMPING = 0.43  # N·m·s/rad: the model's back-EMF braking


def _trial(joint_velocity, torque, distance=1.0):
    """The 12 legs' velocities and torques; the arms and head idle."""
    steps = len(joint_velocity)
    idle = np.zeros((steps, 8))
    return quality.measures(
        np.hstack([np.asarray(joint_velocity, float).reshape(steps, -1), idle]),
        np.hstack([np.asarray(torque, float).reshape(steps, -1), idle]),
        np.full((steps, 2), WEIGHT),  # both soles in stance
        np.zeros((steps, 2, 3)),
        np.zeros((steps, 2, footing.FOOT_WIDTH)),  # no floor contacts recorded
        damping=np.full(20, DAMPING),
        timestep=TIMESTEP,
        torque_limit=2.5,
        mass=MASS,
        distance=distance,
    )


def test_over_speed_is_split_by_the_servos_drive():
    fast = quality.MX28_NO_LOAD_SPEED + 0.1
    slow = quality.MX28_NO_LOAD_SPEED - 0.1
    # Four servo-steps: fast with the servo along the motion, fast against it, fast with no
    # torque (idle: external), slow with the servo along it.
    # The other ten leg servos stand still: 24 servo-steps in all.
    velocity = [[fast, -fast] + [0.0] * 10, [fast, slow] + [0.0] * 10]
    torque = [[1.0, 1.0] + [0.0] * 10, [0.0, 1.0] + [0.0] * 10]
    m = _trial(velocity, torque)
    assert m["over_speed_motor_share"] == 1 / 24
    assert m["over_speed_external_share"] == 2 / 24
    assert m["over_speed_share"] == 3 / 24
    assert m["peak_joint_speed"] == pytest.approx(fast)


def _legs(value):
    return np.full((10, 12), value)


def test_power_is_the_robots_supply_at_12_v():
    # Twelve stalled leg servos (2.5 N·m, still) draw 1.4 A each, plus the idle robot.
    m = _trial(_legs(0.0), _legs(2.5), distance=0.2)
    current = 12 * 1.4 + electrical.IDLE_CURRENT
    assert m["supply_current_a"] == pytest.approx(current)
    assert m["supply_peak_1s_a"] == pytest.approx(
        (10 * current + 490 * electrical.IDLE_CURRENT) / 500
    )  # the 1 s window holds 10 stalled steps after the idle robot's
    assert m["electrical_power_w"] == pytest.approx(12.0 * current)
    assert m["energy_per_m"] == pytest.approx(12.0 * current * 10 * TIMESTEP / 0.2)
    assert m["rms_torque_ratio"] == pytest.approx(1.0)
    assert m["copper_loss_ratio"] == pytest.approx(1.0)
    assert math.isnan(_trial(_legs(0.0), _legs(2.5), distance=0.01)["energy_per_m"])


def test_servos_at_their_no_load_speed_draw_standby_only():
    m = _trial(_legs(2.5 / DAMPING), _legs(2.5))
    assert m["supply_current_a"] == pytest.approx(electrical.IDLE_CURRENT)
    assert m["copper_loss_ratio"] == pytest.approx(0.0, abs=1e-20)


def test_every_field_is_measured():
    m = _trial(np.zeros((3, 12)), np.zeros((3, 12)))
    assert tuple(m) == quality.FIELDS
    # The footing measures follow the older ones, which keep their places (the cards'
    # history); without floor contacts: no slip, no stance, no swing.
    assert quality.FIELDS[-len(footing.FIELDS) :] == footing.FIELDS
    assert quality.FIELDS[:2] == ("cost_of_transport", "slip_per_m")
    assert m["contact_slip_per_m"] == 0.0
    assert all(np.isnan(m[f]) for f in footing.FIELDS[1:])
