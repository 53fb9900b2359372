"""Known answers of the gait-quality measures (`cpg_suite.evaluation.quality`)."""

import math

import numpy as np
import pytest

from cpg_suite.evaluation import quality

TIMESTEP = 0.002  # s
MASS = 2.0  # kg
WEIGHT = MASS * quality.GRAVITY


def _trial(joint_velocity, torque, distance=1.0):
    steps = len(joint_velocity)
    return quality.measures(
        np.asarray(joint_velocity, float),
        np.asarray(torque, float),
        np.full((steps, 2), WEIGHT),  # both soles in stance
        np.zeros((steps, 2, 3)),
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
    velocity = [[fast, -fast], [fast, slow]]
    torque = [[1.0, 1.0], [0.0, 1.0]]
    m = _trial(velocity, torque)
    assert m["over_speed_motor_share"] == 0.25
    assert m["over_speed_external_share"] == 0.5
    assert m["over_speed_share"] == 0.75
    assert m["peak_joint_speed"] == pytest.approx(fast)


def test_electrical_power_at_stall_is_the_datasheet_input():
    # At stall (2.5 N·m, not moving) a servo draws its stall current at 12 V: 16.8 W.
    power = quality.electrical_power(np.array([2.5, -2.5]), np.zeros(2))
    np.testing.assert_allclose(power, 12.0 * 1.4)


def test_electrical_power_adds_mechanical_power_and_recovers_nothing():
    torque, velocity = np.array([1.0, 1.0, 0.1]), np.array([2.0, -2.0, -5.0])
    copper = (1.4 * np.abs(torque) / 2.5) ** 2 * (12.0 / 1.4)
    expected = np.maximum(copper + torque * velocity, 0.0)
    np.testing.assert_allclose(quality.electrical_power(torque, velocity), expected)
    assert expected[2] == 0.0  # a back-driven joint returning more than the copper loss


def test_power_and_energy_per_metre():
    steps = 10
    torque = np.full((steps, 12), 1.0)
    velocity = np.full((steps, 12), 0.5)
    per_servo = (1.4 / 2.5) ** 2 * (12.0 / 1.4) + 0.5
    m = _trial(velocity, torque, distance=0.2)
    assert m["electrical_power_w"] == pytest.approx(12 * per_servo)
    assert m["energy_per_m"] == pytest.approx(12 * per_servo * steps * TIMESTEP / 0.2)
    assert math.isnan(_trial(velocity, torque, distance=0.01)["energy_per_m"])


def test_every_field_is_measured():
    m = _trial(np.zeros((3, 12)), np.zeros((3, 12)))
    assert tuple(m) == quality.FIELDS
