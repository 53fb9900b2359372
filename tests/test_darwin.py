"""DARwIn-OP model and tasks: dimensions, masses, contacts, the hand-tuned gait."""

import copy

import mujoco as mj
import numpy as np
import pytest

import cpg_suite
from cpg_suite import cpg, darwin
from cpg_suite.darwin import contacts as darwin_contacts
from cpg_suite.darwin import pose as darwin_pose
from cpg_suite.evaluation.gait import evaluate_gait


@pytest.fixture(scope="module")
def physics():
    return darwin.Physics.from_xml_string(*darwin.get_model_and_assets())


def _body(physics, name):
    return physics.named.data.xpos[name].copy()


def test_total_mass(physics):
    assert physics.model.body_mass.sum() == pytest.approx(2.9, abs=0.1)
    # docs/darwin_op_model.md#masses
    assert physics.model.body_mass.sum() == pytest.approx(2.925324, abs=1e-5)


def test_twenty_joints_with_servos(physics):
    model = physics.model
    hinges = [
        model.id2name(j, "joint")
        for j in range(model.njnt)
        if model.jnt_type[j] == mj.mjtJoint.mjJNT_HINGE
    ]
    assert len(hinges) == 20
    assert set(hinges) == set(cpg.LEG_JOINTS) | set(darwin.ARM_JOINTS)
    assert model.nu == 20
    np.testing.assert_allclose(model.actuator_forcerange, [[-2.5, 2.5]] * 20)


def test_standing_height_and_leg_segments(physics):
    darwin_pose.set_standing_pose(physics, np.zeros(12), darwin.ARM_POSE)
    # Straight legs: torso origin 0.3417 m above the sole plane
    # (docs/darwin_op_model.md#dimensions).
    assert physics.torso_height() == pytest.approx(0.3417, abs=0.002)
    for side in ("l", "r"):
        hip = _body(physics, f"pelv_y_{side}")
        knee = _body(physics, f"leg_lower_{side}")
        ankle = _body(physics, f"ankle_{side}")
        sole = physics.named.data.site_xpos[f"sole_{side}"]
        assert np.linalg.norm(knee - hip) == pytest.approx(0.093, abs=1e-6)
        assert np.linalg.norm(ankle - knee) == pytest.approx(0.093, abs=1e-6)
        assert ankle[2] - sole[2] == pytest.approx(0.0335, abs=1e-6)
    hips = _body(physics, "pelv_y_l") - _body(physics, "pelv_y_r")
    assert hips[1] == pytest.approx(0.074, abs=1e-6)
    # Overall height with a level head: about 0.455 m
    # (thesis Sec. 5.1, docs/darwin_op_model.md#dimensions).
    pose = darwin.ARM_POSE.copy()
    pose[-1] = 0.785
    darwin_pose.set_standing_pose(physics, np.zeros(12), pose)
    head = physics.model.name2id("head", "geom")
    top = physics.data.geom_xpos[head][2] + physics.model.geom_size[head][0]
    assert top == pytest.approx(0.455, abs=0.01)


def test_joint_signs_match_the_facts_sheet(physics):
    """LegUpperL > 0 swings the left thigh forward; LegUpperR > 0 swings the right back."""
    for joint, foot, forward in (("LegUpperL", "foot_l", True), ("LegUpperR", "foot_r", False)):
        angles = np.zeros(12)
        angles[cpg.LEG_JOINTS.index(joint)] = 0.3
        darwin_pose.set_standing_pose(physics, np.zeros(12))
        x0 = _body(physics, foot)[0]
        physics.data.qpos[physics.model.jnt_qposadr[physics.model.name2id(joint, "joint")]] = 0.3
        mj.mj_kinematics(physics.model.ptr, physics.data.ptr)
        assert (_body(physics, foot)[0] > x0) == forward


def _sole_tilt_deg(physics, leg_angles):
    """Tilt of each sole from horizontal with the torso held upright (kinematics only)."""
    darwin_pose.set_standing_pose(physics, leg_angles)
    z = [physics.named.data.xmat[f"foot_{s}"].reshape(3, 3)[:, 2] for s in ("l", "r")]
    return np.degrees(np.arccos(np.clip([v[2] for v in z], -1, 1)))


PRIMITIVES = {
    # name: amplitudes with the ankle terms that complete the primitive
    "balancing": {"balancing_hip": 11.0, "balancing_ankle": 11.0},
    "flexion": {"hip": 20.0, "knee": 40.0, "ankle_hip": 20.0, "ankle_knee": 40.0},
    "flex_knee": {"flex_knee": 5.0, "flex_ankle": -5.0},
    "pelvis_rotation": {"pelvis_rotation": 10.0},
    "compass": {"compass_hip": 15.0, "compass_ankle": -15.0},
}


@pytest.mark.parametrize("primitive", list(PRIMITIVES))
def test_each_primitive_keeps_the_soles_parallel(physics, primitive):
    amps = np.zeros(cpg.N_AMPLITUDES)
    for name, value in PRIMITIVES[primitive].items():
        amps[cpg.AMPLITUDE_NAMES.index(name)] = value
    targets = cpg.trajectories(amps, 150, 0.016)[0]  # 2.4 s: more than two cycles
    moved = np.abs(targets - targets[0]).max()
    assert moved > np.deg2rad(2)  # The primitive does move the joints.
    for t in range(0, 150, 5):
        assert _sole_tilt_deg(physics, targets[t]).max() <= 2.0


def test_printed_compass_signs_tilt_the_sole(physics):
    """With one sign per joint, equal positive compass amplitudes do not cancel (module doc)."""
    amps = np.zeros(cpg.N_AMPLITUDES)
    amps[cpg.AMPLITUDE_NAMES.index("compass_hip")] = 15.0
    amps[cpg.AMPLITUDE_NAMES.index("compass_ankle")] = 15.0
    targets = cpg.trajectories(amps, 150, 0.016)[0]
    assert max(_sole_tilt_deg(physics, q).max() for q in targets) > 10.0


def test_legs_mirror_each_other(physics):
    """The right leg repeats the left leg's motion half a cycle later, mirrored in y."""
    config = cpg.CPGConfig()
    dt = 0.001 * 11  # 100 samples per 1.1 s cycle
    pattern = cpg.CPG("hand_tuned", cpg.CPGConfig(substep=0.0011))
    z = []
    for _ in range(800):
        pattern.step(dt)
        z.append(pattern.z[0].copy())
    z = np.array(z)
    half = 50  # half a cycle
    np.testing.assert_allclose(z[600:700, 6:], z[600 - half : 700 - half, :6], atol=1e-6)
    assert config.stride_period == pytest.approx(100 * dt)
    # Kinematics: the right foot mirrors the left foot (y -> -y) half a cycle later.
    angles = cpg.to_joint_angles(z)
    for t in range(600, 700, 10):
        darwin_pose.set_standing_pose(physics, angles[t])
        right = _body(physics, "foot_r") - _body(physics, "torso")
        darwin_pose.set_standing_pose(physics, angles[t - half])
        left = _body(physics, "foot_l") - _body(physics, "torso")
        np.testing.assert_allclose(right, left * [1, -1, 1], atol=2e-3)


def test_standing_centre_of_pressure_inside_the_soles():
    env = cpg_suite.load("darwin_balance", task_kwargs={"random": 0})
    env.reset()
    physics = env.physics
    hold = physics.targets_to_action(env.task.posture)
    for _ in range(125):  # 2 s
        ts = env.step(hold)
    cop, force = darwin_contacts.centres_of_pressure(physics)
    assert np.all(force > 2.0)  # both feet carry weight
    assert force.sum() == pytest.approx(physics.model.body_mass.sum() * 9.81, rel=0.05)
    for foot, side in enumerate(("l", "r")):
        local = (
            cop[foot] - physics.named.data.site_xpos[f"sole_{side}"]
        ) @ physics.named.data.site_xmat[f"sole_{side}"].reshape(3, 3)
        assert abs(local[0]) < 0.0525 and abs(local[1]) < 0.033
    assert -0.03 < ts.reward <= 0.0  # balance reward: minus the COP offsets, m


def test_tilted_robot_falls_and_terminates():
    env = cpg_suite.load("darwin_walk", task_kwargs={"random": 0})
    env.reset()
    physics = env.physics
    physics.named.data.qvel["root"][4] = 6.0  # pitch the torso forward fast
    hold = physics.targets_to_action(env.task.posture)
    for _ in range(200):
        ts = env.step(hold)
        if ts.last():
            break
    assert ts.last() and ts.discount == 0.0 and physics.fallen()


def test_action_and_radians_round_trip(physics):
    angles = cpg.CPGConfig().offsets()
    np.testing.assert_allclose(
        physics.action_to_targets(physics.targets_to_action(angles)), angles, atol=1e-12
    )
    assert np.all(physics.targets_to_action(physics.leg_joint_range()[:, 0]) == -1.0)
    assert np.all(physics.targets_to_action(physics.leg_joint_range()[:, 1]) == 1.0)


def test_walk_reward_sums_to_the_distance():
    env = cpg_suite.load("darwin_walk", task_kwargs={"random": 1})
    env.reset()
    physics = env.physics
    start = physics.forward_position()
    pattern = cpg.CPG("hand_tuned")
    total = 0.0
    for _ in range(100):
        total += env.step(physics.targets_to_action(pattern.step(0.016))).reward
    assert total == pytest.approx(physics.forward_position() - start, abs=1e-12)


def test_physics_steps_per_control_step_is_what_the_task_steps():
    """16 ms control steps over the MJCF's 2 ms: the count MJX and the summaries use."""
    env = cpg_suite.load("darwin_walk", task_kwargs={"random": 1})
    env.reset()
    before = env.physics.data.time
    env.step(np.zeros(env.action_spec().shape))
    steps = round((env.physics.data.time - before) / env.physics.model.opt.timestep)
    assert darwin.physics_steps_per_control_step() == steps == 8
    assert darwin.physics_steps_per_control_step(env.physics.model.ptr) == 8


def test_hand_tuned_gait_steps_in_place_without_falling():
    """Thesis Table 6.3: the hand-tuned amplitudes barely move (0.0036 u.d.)."""
    for seed in (0, 1):
        result = evaluate_gait(cpg.amplitudes_from("hand_tuned"), seed)
        assert not result["fell"]
        assert abs(result["distance_m"]) < 0.05


def test_evaluation_is_deterministic():
    a = evaluate_gait(cpg.amplitudes_from("hand_tuned"), 3, steps=200)
    b = evaluate_gait(cpg.amplitudes_from("hand_tuned"), 3, steps=200)
    assert a == b
    c = evaluate_gait(cpg.amplitudes_from("hand_tuned"), 4, steps=200)
    assert c["distance_m"] != a["distance_m"]


def test_bad_task_arguments():
    with pytest.raises(ValueError):
        cpg_suite.load("darwin_walk", task_kwargs={"posture": np.zeros(3)})
    with pytest.raises(ValueError):
        cpg_suite.load("darwin_walk", task_kwargs={"init_noise": -1.0})
    with pytest.raises(ValueError):
        cpg_suite.load("darwin_walk", task_kwargs={"servo_gain": 0.0})


def test_centre_of_pressure_matches_mj_contact_force():
    """The fast COP path equals MuJoCo's own mj_contactForce on a copy put through mj_forward.

    dm_control's step ends with `mj_step1` (contacts found, forces not solved), so the
    reference solves the forces of the same state afresh on a copy of the data.
    """
    env = cpg_suite.load("darwin_balance", task_kwargs={"random": 2})
    env.reset()
    physics = env.physics
    model = physics.model.ptr
    pattern = cpg.CPG("hand_tuned")
    f6 = np.zeros(6)
    checked = 0
    for _ in range(300):
        env.step(physics.targets_to_action(pattern.step(0.016)))
        data = copy.copy(physics.data.ptr)
        mj.mj_forward(model, data)
        force_ref, weighted = np.zeros(2), np.zeros((2, 3))
        for i in range(data.ncon):
            g = tuple(data.contact.geom[i])
            if physics._floor not in g:
                continue
            other = g[1] if g[0] == physics._floor else g[0]
            if other not in physics._foot_index:
                continue
            mj.mj_contactForce(model, data, i, f6)
            if f6[0] <= 0:  # A (numerically) pulling contact carries no load.
                continue
            foot = physics._foot_index[other]
            force_ref[foot] += f6[0]
            weighted[foot] += f6[0] * data.contact.pos[i]
        cop, force = darwin_contacts.centres_of_pressure(physics)
        np.testing.assert_allclose(force, force_ref, rtol=1e-12, atol=1e-12)
        for foot in (0, 1):
            if force_ref[foot] > 0:
                np.testing.assert_allclose(cop[foot], weighted[foot] / force_ref[foot], atol=1e-12)
                checked += 1
    assert checked > 300  # both single and double support were seen


def test_balance_reward_is_its_definition_over_cop_offsets_bit_for_bit():
    """The reward's one-pass hot path equals its definition: −(mean of `cop_offsets`'
    distances over the stance feet), 0 without one, bit for bit, over states with both,
    either and neither foot in stance (the gait, then random targets that topple it)."""
    env = cpg_suite.load("darwin_balance", task_kwargs={"random": 4})
    physics, rng = env.physics, np.random.default_rng(4)
    pattern, seen = cpg.CPG("hand_tuned"), set()
    for episode in range(3):
        env.reset()
        for _ in range(250):
            gait = physics.targets_to_action(pattern.step(0.016))
            action = gait if episode == 0 else rng.uniform(-1, 1, 12) * 0.3 * episode
            reward = env.step(action).reward
            distance, stance = darwin_contacts.cop_offsets(physics)
            offsets = [d for d, s in zip(distance, stance) if s]
            expected = -sum(offsets) / len(offsets) if offsets else 0.0
            assert np.float64(reward).tobytes() == np.float64(expected).tobytes()
            assert darwin_contacts.balance_reward(physics) == reward  # the same state again
            seen.add(tuple(bool(s) for s in stance))
            if env.physics.fallen():
                break
    assert {(True, True), (True, False), (False, True)} <= seen


def test_reading_the_foot_loads_leaves_the_trajectory_alone():
    """Solving the contact forces for the balance reward changes no later state."""

    def trajectory(read_loads: bool) -> np.ndarray:
        env = cpg_suite.load("darwin_balance", task_kwargs={"random": 3})
        env.reset()
        pattern, states = cpg.CPG("hand_tuned"), []
        for _ in range(200):
            # Environment.step without the reward: before_step, the physics steps, after_step.
            env.task.before_step(env.physics.targets_to_action(pattern.step(0.016)), env.physics)
            env.physics.step(8)
            env.task.after_step(env.physics)
            if read_loads:
                darwin_contacts.centres_of_pressure(env.physics)
            states.append(env.physics.data.qpos.copy())
        return np.array(states)

    np.testing.assert_array_equal(trajectory(True), trajectory(False))


def test_a_new_invalid_state_warning_raises_or_is_logged_as_dm_control_does(caplog):
    """`Physics.step` and `check_invalid_state` compare the warning counts' bytes on every
    step; a warning that appears raises `PhysicsError` naming it, or is logged inside
    `suppress_physics_errors`, and a step without one raises nothing."""
    from dm_control.rl import control

    env = darwin.walk(random=0)
    env.reset()
    env.physics.step(8)  # a good state: no warning
    env.physics.data.qpos[2] = np.nan
    with pytest.raises(control.PhysicsError, match="mjWARN_BADQPOS"):
        env.physics.step(8)
    env.reset()
    env.physics.data.qpos[2] = np.nan
    with env.physics.suppress_physics_errors():
        env.physics.step(8)
    assert "mjWARN_BADQPOS" in caplog.text
    env.reset()
    env.physics.data.qpos[2] = np.nan
    with pytest.raises(control.PhysicsError, match="mjWARN_BADQPOS"):
        with env.physics.check_invalid_state():
            mj.mj_step(env.physics.model.ptr, env.physics.data.ptr)
