"""Pole domain physics and task semantics (thesis Sec. 4.2)."""

import numpy as np
import pytest

import cpg_suite
from cpg_suite import pole


def _env(**kwargs):
    kwargs.setdefault("random", 0)
    return cpg_suite.load("pole_balance", task_kwargs=kwargs)


def test_timing():
    env = _env()
    assert env.control_timestep() == pytest.approx(0.02)
    assert env.physics.model.opt.timestep == pytest.approx(0.005)


def test_push_moves_cart_in_force_direction_and_tilts_pole_back():
    env = _env()
    env.reset()
    env.physics.set_pole_angle(0.0)
    for _ in range(5):
        ts = env.step(2)  # +F
    assert env.physics.cart_velocity() > 0
    # Accelerating the cart to +x leaves the pole behind: it leans toward −x.
    assert ts.observation["angle"][0] < 0


def test_pole_leaning_right_falls_right_and_terminates():
    env = _env()
    env.reset()
    env.physics.set_pole_angle(0.1)
    steps, ts = 0, None
    while True:
        ts = env.step(1)  # no force
        steps += 1
        if ts.last():
            break
    assert ts.observation["angle"][0] > np.pi / 2
    assert ts.discount == 0.0
    assert ts.reward == pytest.approx(-(ts.observation["angle"][0] ** 2))
    assert steps < 100


def test_reward_is_minus_angle_squared():
    env = _env()
    env.reset()
    ts = env.step(0)
    assert ts.reward == pytest.approx(-(env.physics.pole_angle() ** 2))


def test_approach_reward_sign():
    env = _env(reward="approach")
    env.reset()
    env.physics.set_pole_angle(0.1)
    ts = env.step(1)  # Falling away from upright.
    assert ts.reward == pytest.approx(-(ts.observation["angle"][0] ** 2) - 0.05)


def test_forces_of_the_action_sets():
    assert list(_env().task.forces) == [-0.5, 0.0, 0.5]
    assert list(_env(force=4.0, num_actions=2).task.forces) == [-4.0, 4.0]
    assert cpg_suite.load("pole_balance_continuous").task.forces is None


def test_continuous_action_scales_force():
    env = cpg_suite.load("pole_balance_continuous", task_kwargs={"random": 0, "force": 4.0})
    env.reset()
    env.step([0.5])
    assert env.physics.data.ctrl[0] == pytest.approx(2.0)
    env.step([3.0])  # Clipped to the spec.
    assert env.physics.data.ctrl[0] == pytest.approx(4.0)


@pytest.mark.parametrize("force", [0.5, 4.0])
def test_both_forces_can_balance_the_pole(force):
    """A simple bang-bang rule on θ + 0.1 θ̇ keeps the pole up for 60 s with either force."""
    env = cpg_suite.load(
        "pole_balance", task_kwargs={"random": 0, "force": force, "time_limit": 60.0}
    )
    ts = env.reset()
    steps = 0
    while not ts.last():
        s = ts.observation["angle"][0] + 0.1 * ts.observation["angular_velocity"][0]
        ts = env.step(2 if s > 0 else 0)
        steps += 1
    assert ts.discount == 1.0  # Ended by the time limit, not by a fall.
    assert steps == 3000


def test_half_newton_cannot_catch_a_large_tilt():
    """0.5 N accelerates the system at 2 m/s²: it cannot recover from 0.5 rad."""
    env = _env()
    env.reset()
    env.physics.set_pole_angle(0.5)
    ts = env.step(2)
    while not ts.last():
        ts = env.step(2)
    assert ts.discount == 0.0


def test_physics_accessors_use_names():
    physics = pole.Physics.from_xml_string(*pole.get_model_and_assets())
    physics.named.data.qpos["hinge"] = 0.3
    physics.named.data.qvel["slider"] = -1.5
    assert physics.pole_angle() == pytest.approx(0.3)
    assert physics.cart_velocity() == pytest.approx(-1.5)
    assert physics.cart_position() == 0.0
