"""The test tiers of the walking task: randomized physics, pushes, rough ground, contact."""

import dataclasses

import numpy as np
import pytest

import cpg_suite
from cpg_suite import cpg, perturbations
from cpg_suite.evaluation.gait import evaluate_gait
from cpg_suite.evaluation.open_loop import BatchEvaluator

TIERS = ("darwin_walk_randomized", "darwin_walk_push", "darwin_walk_rough", "darwin_walk_contact")


def _trajectory(task, seed, steps, task_kwargs=None):
    """Torso positions after each control step of the hand-tuned gait, stepping the env."""
    kwargs = {"random": seed, "posture": cpg.CPGConfig().offsets(), **(task_kwargs or {})}
    env = cpg_suite.load(task, task_kwargs=kwargs)
    env.reset()
    targets = cpg.trajectories(cpg.PRESETS["hand_tuned"], steps, env.control_timestep())[0]
    out = []
    for t in range(steps):
        env.step(env.physics.targets_to_action(targets[t]))
        out.append(env.physics.torso_position())
    return np.array(out)


def test_zero_height_rough_ground_is_the_plane_bit_for_bit():
    flat = {"terrain": perturbations.Terrain(max_height=0.0)}
    for seed in (0, 1):
        np.testing.assert_array_equal(
            _trajectory("darwin_walk_rough", seed, 250, flat), _trajectory("darwin_walk", seed, 250)
        )


def _tile_contacts(terrain):
    env = cpg_suite.load("darwin_walk_rough", task_kwargs={"random": 0, "terrain": terrain})
    env.reset()
    physics = env.physics
    names = [physics.model.id2name(g, "geom") or "" for g in physics.data.contact.geom.ravel()]
    return sum(n.startswith("tile") for n in names)


def test_rough_ground_is_level_at_the_start_and_raised_elsewhere():
    assert _tile_contacts(perturbations.Terrain()) == 0  # the start pad is the plane
    assert _tile_contacts(perturbations.Terrain(start_pad=0.0, max_height=0.008)) > 0


@pytest.mark.parametrize("task", TIERS)
def test_batched_evaluator_equals_env_stepping(task):
    rng = np.random.default_rng(0)
    amps = cpg.amplitudes_from("hand_tuned") + rng.normal(0.0, 3.0, (3, 11))
    steps = 300  # past the first push (3-4 s)
    reference = [[evaluate_gait(a, s, task=task, steps=steps) for s in (5, 6)] for a in amps]
    with BatchEvaluator(task, steps=steps, threads=2) as evaluator:
        batch = evaluator.evaluate(amps, [5, 6])
    distance = [[r["distance_m"] for r in row] for row in reference]
    fall_step = [[r["fall_step"] or 0 for r in row] for row in reference]
    np.testing.assert_array_equal(batch.distance_m, distance)
    np.testing.assert_array_equal(batch.fall_step, fall_step)


def test_randomized_parameters_are_drawn_per_episode_within_their_ranges():
    ranges = perturbations.Randomization()
    env = cpg_suite.load("darwin_walk_randomized", task_kwargs={"random": 3})
    drawn = []
    for _ in range(3):
        env.reset()
        p = dict(env.task.episode_parameters)
        drawn.append(p["servo_gain"])
        model = env.physics.model
        assert ranges.servo_gain[0] <= p["servo_gain"] <= ranges.servo_gain[1]
        assert model.actuator_gainprm[0, 0] == p["servo_gain"]
        assert model.actuator_forcerange[0, 1] == p["torque_limit"]
        assert np.all(np.abs(p["torso_com_shift"]) <= ranges.torso_com_shift)
    assert len(set(drawn)) == 3
    again = cpg_suite.load("darwin_walk_randomized", task_kwargs={"random": 3})
    again.reset()
    assert again.task.episode_parameters["servo_gain"] == drawn[0]


def test_pushes_act_on_the_torso_when_scheduled():
    pushes = perturbations.Pushes()
    env = cpg_suite.load("darwin_walk_push", task_kwargs={"random": 2})
    env.reset()
    schedule = env.task.push_schedule
    assert len(schedule) == len(pushes.times)
    start, steps, force = schedule[0]
    dt = env.control_timestep()
    assert pushes.times[0] <= start * dt <= pushes.times[0] + pushes.jitter + dt
    impulse = np.linalg.norm(force) * steps * dt
    assert pushes.impulse[0] - 1e-12 <= impulse <= pushes.impulse[1] + 1e-12
    torso = env.physics.torso_body()
    targets = cpg.trajectories(cpg.PRESETS["hand_tuned"], start + 2, dt)[0]
    for t in range(start + 2):
        env.step(env.physics.targets_to_action(targets[t]))
        applied = env.physics.data.xfrc_applied[torso, :3]
        assert np.array_equal(applied, force) == (start <= t < start + steps), t


def test_hand_tuned_gait_survives_nominal_and_randomized_tiers():
    """The acceptance of the tiers' ranges: the study's hand-tuned gait keeps standing."""
    amps = cpg.amplitudes_from("hand_tuned")
    for task in ("darwin_walk", "darwin_walk_randomized"):
        with BatchEvaluator(task, threads=2) as evaluator:
            result = evaluator.evaluate(amps, range(1000, 1040))
        assert not result.fell.any(), task


def test_custom_ranges_are_constructor_flags():
    narrow = dataclasses.replace(perturbations.Randomization(), servo_gain=(40.0, 40.0))
    env = cpg_suite.load(
        "darwin_walk_randomized", task_kwargs={"random": 0, "randomization": narrow}
    )
    env.reset()
    assert env.physics.model.actuator_gainprm[0, 0] == 40.0
