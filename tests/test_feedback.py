"""The feedback CPG: open loop at zero gains (bit for bit), input and reflex signs."""

import numpy as np
import pytest

import cpg_suite
from cpg_suite import cpg, feedback


def _amplitudes(k=3):
    rng = np.random.default_rng(1)
    return cpg.amplitudes_from("hand_tuned") + rng.normal(0, 3, (k, cpg.N_AMPLITUDES))


def test_zero_gains_give_the_open_loop_targets_bit_for_bit():
    amps = _amplitudes()
    params = np.concatenate([amps, np.zeros((len(amps), feedback.N_GAINS))], axis=1)
    open_loop, closed = cpg.CPG(amps), feedback.FeedbackCPG(params)
    rng = np.random.default_rng(2)
    for _ in range(300):
        inputs = rng.normal(0, 1, (len(amps), len(feedback.INPUT_NAMES)))
        assert np.array_equal(closed.step(0.016, inputs), open_loop.step(0.016))
    one = feedback.FeedbackCPG(params[0])
    assert one.step(0.016, inputs[0]).shape == (12,)


@pytest.mark.parametrize(
    "config",
    [
        cpg.CPGConfig(),
        cpg.CPGConfig(ramp_time=0.0, flexion_form="printed"),
        cpg.CPGConfig(ramp_time=0.05),
    ],
    ids=["default", "no-ramp-printed", "short-ramp"],
)
@pytest.mark.parametrize("k", [1, 7, 21, 120, 334])  # both sides of combine's switch
def test_the_batched_step_is_the_reference_loop_bit_for_bit(config, k):
    """`FeedbackCPG.step` (phases one substep at a time, the rest over all substeps at
    once) equals `cpg.CPG.step`'s loop over substeps through the same hooks: targets, z, δ
    and time, with strong gains and loads, inputs held (None) on some steps, signed zeros."""
    rng = np.random.default_rng(k)
    amps = cpg.amplitudes_from("hand_tuned") + rng.normal(0, 5, (k, cpg.N_AMPLITUDES))
    gains = rng.normal(0, 2, (k, feedback.N_GAINS))
    gains[0] = -0.0  # a trial with every gain −0: δ and the offsets stay signed zeros
    params = np.concatenate([amps, gains], axis=1)
    fast, reference = feedback.FeedbackCPG(params, config), feedback.FeedbackCPG(params, config)
    for step in range(120):
        inputs = rng.normal(0, 0.5, (k, len(feedback.INPUT_NAMES)))
        inputs[:, 4:] = rng.uniform(0, 1.5, (k, 2))
        inputs = None if step % 5 == 4 else inputs
        dt = (0.016, 0.008, 0.0161, 0.0015)[(step % 7 == 0) + 2 * (step % 11 == 0)]
        if step % 13 == 6:  # the DMP term's roll input, as NAC sets it
            roll = rng.normal(0, 20, (k, 2))
            fast.set_roll_input(roll)
            reference.set_roll_input(roll)
        got = fast.step(dt, inputs)
        if inputs is not None:
            reference.inputs = inputs.copy()
        want = cpg.CPG.step(reference, dt)
        assert got.tobytes() == want.tobytes(), step
    for name in ("z", "delta", "time", "_sin_phi"):
        assert (
            np.asarray(getattr(fast, name)).tobytes()
            == np.asarray(getattr(reference, name)).tobytes()
        ), name


def test_a_refused_step_leaves_the_cpg_as_it_was():
    """A non-finite input (a NaN sole load makes a phase NaN, which sin refuses) raises
    before any of the CPG's state changes: time, z, δ."""
    params = np.concatenate([_amplitudes(2), np.ones((2, feedback.N_GAINS))], axis=1)
    closed = feedback.FeedbackCPG(params)
    closed.step(0.016, np.full((2, 6), 0.5))
    before = (closed.time, closed.z.copy(), closed.delta.copy())
    with pytest.raises(ValueError, match="finite"):
        closed.step(0.016, [0.0, 0.0, 0.0, 0.0, np.nan, 0.0])
    assert closed.time == before[0]
    assert np.array_equal(closed.z, before[1]) and np.array_equal(closed.delta, before[2])


def test_gains_change_the_targets_and_the_phases():
    params = np.concatenate([_amplitudes(1)[0], np.ones(feedback.N_GAINS)])
    closed, open_loop = feedback.FeedbackCPG(params), cpg.CPG(_amplitudes(1)[0])
    inputs = [0.1, -0.1, 0.5, 0.2, 1.0, 0.0]
    for _ in range(20):
        targets = closed.step(0.016, inputs)
    assert not np.array_equal(targets, [open_loop.step(0.016) for _ in range(20)][-1])
    assert closed.delta[0, 0] != 0 and closed.delta[0, 1] == 0  # only the loaded leg


def _tilted(axis, angle):
    """The quaternion of a rotation by `angle` about the unit `axis`."""
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * np.asarray(axis, float)])


def test_sensor_inputs_read_forward_and_left_lean_as_positive():
    forward = feedback.sensor_inputs(_tilted([0, 1, 0], 0.2), [0, 0.3, 0], [14.35, 0])
    assert forward[0] == pytest.approx(0.2) and abs(forward[1]) < 1e-12
    assert forward[2] == pytest.approx(0.3) and forward[4] == pytest.approx(0.5)
    left = feedback.sensor_inputs(_tilted([-1, 0, 0], 0.2), [-0.3, 0, 0], [0, 0])
    assert left[1] == pytest.approx(0.2) and left[3] == pytest.approx(0.3)


def test_sensor_inputs_take_each_tilt_as_its_own_arctan2_bit_for_bit():
    """Pitch and roll come from one `portable.arctan2` call over both (the hot path's);
    each equals its own call's bits, for one robot and many, upright, tilted, on either
    side of ±π/2 and with signed zeros."""
    from cpg_suite import portable

    rng = np.random.default_rng(5)
    q = rng.standard_normal((64, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q[:6] = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, -0.0, 1], [-1, 0, 0, -0.0],
             [0.5, 0.5, -0.5, 0.5]]  # fmt: skip
    gyro, touch = rng.standard_normal((64, 3)), rng.uniform(0, 30, (64, 2))
    for n in (1, 64):
        w, x, y, z = (q[:n, i] for i in range(4))
        zz = 1.0 - 2.0 * (x * x + y * y)
        want = [portable.arctan2(2.0 * (x * z + w * y), zz),
                portable.arctan2(2.0 * (y * z - w * x), zz)]  # fmt: skip
        got = feedback.sensor_inputs(q[:n], gyro[:n], touch[:n])
        for column, expected in enumerate(want):
            assert got[:, column].tobytes() == expected.tobytes()
    one = feedback.sensor_inputs(q[5], gyro[5], touch[5])
    assert (
        one.shape == (6,)
        and one.tobytes() == feedback.sensor_inputs(q[5:6], gyro[5:6], touch[5:6])[0].tobytes()
    )


def test_phase_feedback_holds_back_a_loaded_leg_late_in_stance():
    params = np.concatenate([cpg.amplitudes_from("hand_tuned"), np.zeros(feedback.N_GAINS)])
    params[cpg.N_AMPLITUDES + feedback.GAIN_NAMES.index("phase")] = 2.0
    config = cpg.CPGConfig(initial_phase=-np.pi / 2)  # left leg late in stance: sin φ < 0
    closed = feedback.FeedbackCPG(params, config)
    closed.step(0.016, [0, 0, 0, 0, 1.0, 0.0])
    assert closed.delta[0, 0] < 0 and closed.delta[0, 1] == 0


def _standing_torso(anatomical_offsets_deg, steps=30):
    """Torso (x, y) displacement and pitch after holding the CPG posture plus offsets."""
    config = cpg.CPGConfig()
    env = cpg_suite.load(
        "darwin_walk",
        task_kwargs={"random": 0, "posture": config.offsets(), "time_limit": float("inf")},
    )
    env.reset()
    physics = env.physics
    start = physics.torso_position().copy()
    targets = cpg.to_joint_angles(config.anatomical_offsets() + anatomical_offsets_deg)
    for _ in range(steps):
        env.step(physics.targets_to_action(targets))
    pitch = feedback.sensor_inputs(physics.torso_orientation(), physics.gyro(), [0, 0])[0]
    return physics.torso_position()[:2] - start[:2], pitch


def test_reflexes_with_positive_gains_correct_a_lean_on_the_model():
    gains = np.zeros((1, feedback.N_GAINS))
    gains[0, :10] = 20.0  # deg/rad and deg/(rad/s)
    lean_forward = feedback.reflex_offsets(gains, np.array([[0.1, 0, 0, 0, 0, 0]]))[0]
    lean_left = feedback.reflex_offsets(gains, np.array([[0, 0.1, 0, 0, 0, 0]]))[0]
    assert lean_forward[cpg.HPITCH] < 0 and lean_forward[cpg.APITCH] < 0  # extend, plantarflex
    assert lean_forward[cpg.KNEE] > 0 and lean_forward[6 + cpg.HPITCH] < 0
    _, pitch_still = _standing_torso(np.zeros(12))
    _, pitch_reflex = _standing_torso(lean_forward)
    assert pitch_reflex < pitch_still - 0.01  # the torso rotates backward
    shift_still, _ = _standing_torso(np.zeros(12))
    shift_reflex, _ = _standing_torso(lean_left)
    assert shift_reflex[1] < shift_still[1] - 0.002  # the torso moves to its right


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError, match="22 columns"):
        feedback.FeedbackCPG(np.zeros(11))
    with pytest.raises(ValueError, match="finite"):
        feedback.FeedbackCPG(np.full(feedback.N_PARAMS, np.nan))


def test_the_imu_orientation_is_the_torso_frame():
    # A framequat of objtype "body" is the body's inertial frame in MuJoCo; the torso's
    # principal axes are tilted, so the observation read 1.68 rad of pitch standing.
    env = cpg_suite.load("darwin_walk", task_kwargs={"random": 3})
    env.reset()
    for _ in range(5):
        observation = env.step(np.zeros(12)).observation
    quaternion = env.physics.root_qpos()[3:]
    assert np.allclose(observation["torso_orientation"], quaternion, atol=1e-9)
    assert abs(feedback.sensor_inputs(quaternion, np.zeros(3), np.zeros(2))[0]) < 0.1
