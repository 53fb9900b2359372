"""The over-speed diagnosis (`cpg_suite.protocol.overspeed`): its force split adds up, and
its events and shares have known answers."""

import mujoco
import numpy as np
import pytest

import cpg_suite
from cpg_suite import cpg, perturbations
from cpg_suite.evaluation import quality
from cpg_suite.protocol import overspeed, score

STEPS = 40  # control steps: 320 physics steps


@pytest.fixture(scope="module")
def hand_tuned():
    return score.OpenLoopPolicy(cpg.PRESETS["hand_tuned"], steps=STEPS)


def test_the_sources_add_up_to_the_explicit_acceleration(hand_tuned):
    """Euler without implicit damping: each step's Δq̇ is h q̈, MuJoCo's constraint solver's
    q̈, which satisfies M q̈ = Σ f to the solver's tolerance (measured: 1.1e-5 and 2.5e-5 of
    the largest Δq̇ without and with a push)."""
    pushes = perturbations.Pushes(times=(0.2,), jitter=0.0, impulse=(0.25, 0.25))
    env = cpg_suite.load("darwin_walk_push", task_kwargs={"random": 3, "pushes": pushes})
    env.physics.model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    env.physics.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_EULERDAMP
    t = overspeed.trace_environment(hand_tuned, env, STEPS)
    assert t.sources.shape == (STEPS * 8, len(overspeed.SOURCES), 12)
    assert np.abs(t.sources[:, overspeed.SOURCES.index("push")]).max() > 1.0  # pushed
    assert overspeed.closure(t) < 1e-4


def test_the_sources_add_up_to_each_velocity_change_of_the_implicit_integrator(hand_tuned):
    """The task's implicit-fast integrator takes damping implicitly: (M + h D)⁻¹ Σ f."""
    t = overspeed.trace(hand_tuned, "darwin_walk", seed=0, steps=STEPS)
    assert overspeed.closure(t) < 1e-9


def test_at_rest_nothing_but_the_servos_and_the_floor_turns_a_joint():
    """Weight alone turns no joint of the floating robot, and at rest there are no
    velocity forces: the body-motion source is zero (to round-off)."""
    env = cpg_suite.load("darwin_walk", task_kwargs={"random": 0})
    env.reset()
    physics = env.physics
    physics.data.qvel[:] = 0.0
    mujoco.mj_forward(physics.model.ptr, physics.data.ptr)
    drive = overspeed.drives(physics)
    assert np.abs(drive[overspeed.SOURCES.index("body_motion")]).max() < 1e-9
    assert not drive[overspeed.SOURCES.index("push")].any()
    assert np.abs(drive[overspeed.SOURCES.index("contacts")]).max() > 1.0


def _synthetic(velocity, sources, touch):
    steps = len(velocity)
    return overspeed.Trace(
        velocity=np.asarray(velocity, float),
        torque=np.ones((steps, 12)),
        touch=np.asarray(touch, float),
        sources=np.asarray(sources, float),
        qacc=np.zeros((steps, 12)),
        weight=10.0,
        timestep=0.002,
    )


def test_an_event_names_its_joint_phase_and_sources():
    fast = quality.MX28_NO_LOAD_SPEED + 1.0
    velocity = np.zeros((4, 12))
    velocity[2:, 9] = -fast  # LegLowerR over speed from step 2, backwards; servo torque +1
    sources = np.zeros((4, len(overspeed.SOURCES), 12))
    sources[:, overspeed.SOURCES.index("contacts"), 9] = -1000.0  # along the motion
    sources[:, overspeed.SOURCES.index("own_motor"), 9] = 200.0  # against it
    touch = [[0.0, 0.0], [0.0, 0.0], [0.0, 5.0], [0.0, 5.0]]  # the right foot lands at 2
    first, second = overspeed.events(_synthetic(velocity, sources, touch), window=2)
    assert first["joint"] == second["joint"] == "LegLowerR" and first["speed"] == fast
    assert not first["motor"] and first["stance"] and first["touchdown"]
    assert not second["touchdown"]  # in stance for the whole window
    # Summed from the first step over the speed: one step for the first, two for the second.
    assert first["delta"]["contacts"] == pytest.approx(1000.0 * 0.002)
    assert second["delta"]["contacts"] == pytest.approx(2 * 1000.0 * 0.002)
    assert second["delta"]["own_motor"] == pytest.approx(-2 * 200.0 * 0.002)
    table = overspeed.summarize([first, second], servo_steps=4)
    assert list(table) == ["LegLowerR"]
    assert table["LegLowerR"]["largest"]["contacts"] == 1.0
    assert table["LegLowerR"]["share"] == pytest.approx(2 / 4)
    assert table["LegLowerR"]["touchdown"] == 0.5


def test_no_servo_accelerates_its_own_joint_past_clamp_over_damping(hand_tuned):
    """|q̇| > |τ| / c: the own motor's part along the motion is ≤ 0 (M⁻¹ⱼⱼ > 0)."""
    env = cpg_suite.load("darwin_walk", task_kwargs={"random": 1})
    damping = float(env.physics.model.dof_damping[env.physics.leg_dofs()[0]])
    t = overspeed.trace_environment(hand_tuned, env, STEPS)
    # Row k: forces at the state step k started from, whose velocity is row k − 1's.
    own = t.sources[1:, overspeed.SOURCES.index("own_motor")]
    velocity, torque = t.velocity[:-1], t.torque[1:]
    beyond = np.abs(velocity) > np.abs(torque) / damping
    assert beyond.any()
    assert np.all(own[beyond] * np.sign(velocity[beyond]) <= 1e-9)
