"""The MJX walking tiers (`cpg_suite.mjx`) against the CPU reference, on JAX's CPU backend.

Every comparison runs in float64 (`jax.enable_x64`, entered per fixture and test, never
process-wide), so that the differences left are MJX's, not float32's. The step functions
compile once per module, with XLA's backend optimizations off (`_jit`: compiling takes
about 35 % less time, stepping 2.3× more, a gain for the few hundred steps here); one `step`
of the randomized tier's env serves all three tiers (the tier only changes what `reset`
draws).
"""

import functools

import numpy as np
import pytest

pytestmark = pytest.mark.slow  # MJX compiled on JAX's CPU backend: minutes

jax = pytest.importorskip("jax")
pytest.importorskip("mujoco.mjx")

import jax.numpy as jnp  # noqa: E402
import mujoco  # noqa: E402

import cpg_suite  # noqa: E402
from cpg_suite import (  # noqa: E402
    cpg,
    darwin,
    electrical,
    perturbations,
    residual,
)
from cpg_suite.darwin import perturb as darwin_perturb  # noqa: E402
from cpg_suite.darwin import pose as darwin_pose  # noqa: E402
from cpg_suite.mjx import modulated, physics, walk  # noqa: E402

SEED = 3  # CPU task seed of the comparisons.
STEPS = 40  # control steps compared reading by reading.
# float64 MJX vs MuJoCo C from the same state: the readings agree to ~1e-12 over 60 steps
# (measured: 2e-12 largest, accelerometer); 1e-8 leaves room for other CPUs' roundoff.
ATOL = 1e-8
# Full trials (1000 steps): contact events amplify the last-bit differences, so trials drift
# apart as the CPU's own trials do from a start moved by 1e-9 rad. Measured with
# investigations/mjx_agreement.py, hand-tuned gait, seeds 0-4: float64 MJX within 5.6e-4 m of
# the CPU's distance and 3.4e-3 m of its lateral drift; the CPU from the moved start within
# 3.6e-3 m and 6.8e-3 m (docs/architecture.md#the-mjx-path).
DISTANCE_ATOL = 5e-3  # m
LATERAL_ATOL = 1e-2  # m


_jit = functools.partial(jax.jit, compiler_options={"xla_backend_optimization_level": 0})


@pytest.fixture(autouse=True)
def x64():
    """float64 for each test's own JAX calls (the fixtures below enter it themselves)."""
    with jax.enable_x64(True):
        yield


@pytest.fixture(scope="module")
def joints():
    """The randomized tier's env (joint actions) and its compiled step."""
    with jax.enable_x64(True):
        env = walk.WalkEnv("darwin_walk_randomized")
        return env, _jit(env.step)


@pytest.fixture(scope="module")
def episode_model(joints):
    """The randomized tier's `episode_model`, compiled."""
    return _jit(joints[0].episode_model)


@pytest.fixture(scope="module")
def cpg_env():
    """The nominal tier with the CPG action space, and its compiled step."""
    with jax.enable_x64(True):
        env = walk.WalkEnv("darwin_walk", "cpg")
        return env, _jit(env.step)


@pytest.fixture(scope="module")
def soles():
    """The nominal tier computing the floor's and soles' contact pairs only, and its step."""
    with jax.enable_x64(True):
        env = walk.WalkEnv("darwin_walk", contacts="soles")
        return env, _jit(env.step)


@pytest.fixture(scope="module")
def resets(joints):
    """64 resets of the randomized tier, each followed by the push tier's draws."""
    env, _ = joints
    with jax.enable_x64(True):
        keys = jax.random.split(jax.random.key(0), 64)
        states = _jit(jax.vmap(env.reset))(keys)
        pushes = walk.WalkEnv("darwin_walk_push")
        schedules = jax.jit(jax.vmap(pushes.sample_pushes))(keys)
        return jax.device_get(states), jax.device_get(schedules)


def _cpu_env(task="darwin_walk", **kwargs):
    env = cpg_suite.load(task, task_kwargs={"random": SEED, **kwargs})
    return env, env.reset()


def _flat(observation) -> np.ndarray:
    return np.concatenate([np.ravel(observation[k]) for k in walk.OBSERVATION_KEYS])


def _touch(obs) -> np.ndarray:
    return np.asarray(obs)[..., 38:40]


def _without_touch(obs) -> np.ndarray:
    return np.asarray(obs)[..., :38]


def _gait_actions(physics, steps: int, noise: float = 0.0) -> np.ndarray:
    targets = cpg.trajectories(cpg.amplitudes_from("hand_tuned"), steps, darwin.CONTROL_TIMESTEP)
    actions = physics.targets_to_action(targets[0])
    rng = np.random.default_rng(0)
    return np.clip(actions + rng.uniform(-noise, noise, actions.shape), -1.0, 1.0)


def _feet_touch_each_other(physics) -> bool:
    """Whether the soles collide (box-box contacts, which MJX generates differently)."""
    feet = {physics.model.name2id(n, "geom") for n in darwin.FOOT_GEOMS}
    geoms = physics.data.contact.geom[: physics.data.ncon]
    return any(set(pair) == feet for pair in geoms.tolist())


def test_box_plane_contacts_match_mujoco():
    """A sole landing tilted: MuJoCo C's contacts, which MJX's own routine thins out."""
    env = walk.WalkEnv("darwin_walk")
    cpu, _ = _cpu_env()
    data, model = cpu.physics.data, cpu.physics.model.ptr
    root = env._root_qpos
    tilt = np.deg2rad(0.6)  # about the y axis: the toes lower than the heels
    data.qpos[root + 3 : root + 7] = [np.cos(tilt / 2), 0.0, np.sin(tilt / 2), 0.0]
    mujoco.mj_kinematics(model, data.ptr)
    lowest = min(darwin_pose.lowest_corner(cpu.physics, g) for g in env._feet)
    # The deepest corner 2.5 mm into the floor: MuJoCo C finds 7 corners below it, 0.2 to
    # 2.5 mm deep, of which MJX's 1 mm skin depth keeps 4.
    data.qpos[root + 2] -= lowest + 0.0025
    mujoco.mj_forward(model, data.ptr)
    expected = _active_contacts(data.contact.geom[: data.ncon], data.contact.pos[: data.ncon])
    depths = data.contact.dist[: data.ncon]
    assert depths.max() - depths.min() > 2e-3  # beyond MJX's 1 mm skin depth
    d = mujoco.mjx.put_data(env.mj_model, data.ptr)
    ours = _jit(physics.fwd_position)(env.model, d)._impl.contact

    def active(c):
        on = np.asarray(c.dist) < 0
        return _active_contacts(np.asarray(c.geom)[on], np.asarray(c.pos)[on])

    assert len(expected) == 7
    assert [k for k, _ in active(ours)] == [k for k, _ in expected]
    np.testing.assert_allclose([p for _, p in active(ours)], [p for _, p in expected], atol=1e-12)


def _active_contacts(geoms, positions) -> list:
    """(geom pair, position) of contacts, sorted: a comparable set of contacts."""
    pairs = [tuple(sorted(g)) for g in np.asarray(geoms).tolist()]
    return sorted(zip(pairs, np.asarray(positions).tolist()))


def test_observation_layout():
    assert list(walk.OBSERVATION_SIZES) == list(walk.OBSERVATION_KEYS)
    assert sum(walk.OBSERVATION_SIZES.values()) == 40
    env, ts = _cpu_env()
    assert list(ts.observation) == list(walk.OBSERVATION_KEYS)
    for key, size in walk.OBSERVATION_SIZES.items():
        assert np.size(ts.observation[key]) == size, key


def test_episode_model_matches_cpu_randomization(joints, episode_model):
    """The randomized tier's parameters land in the model where `CPGTask` puts them, and
    the inverse weights are recomputed as `mj_setConst` does (`setconst.invweights`)."""
    env, _ = joints
    params = walk.EpisodeParams(
        servo_gain=jnp.asarray(44.0),
        torque_limit=jnp.asarray(2.3),
        joint_damping=jnp.asarray(0.4),
        friction=jnp.asarray(0.9),
        torso_mass_scale=jnp.asarray(1.03),
        torso_com_shift=jnp.asarray([0.002, -0.001]),
    )
    mx = episode_model(params)
    cpu, _ = _cpu_env("darwin_walk_randomized")
    task, physics = cpu.task, cpu.physics
    nominal_weights = physics.model.body_invweight0.copy()
    task._apply_parameters(physics, {k: np.asarray(v) for k, v in params._asdict().items()})
    m = physics.model
    assert np.abs(m.body_invweight0 - nominal_weights).max() > 1e-3  # mj_setConst mattered
    for field in (
        "actuator_gainprm",
        "actuator_biasprm",
        "actuator_forcerange",
        "dof_damping",
        "geom_friction",
        "body_mass",
        "body_inertia",
        "body_ipos",
        "body_invweight0",
        "dof_invweight0",
    ):
        np.testing.assert_allclose(getattr(mx, field), getattr(m, field), rtol=1e-10, err_msg=field)
    nominal = episode_model(env.nominal_params())
    for field in ("actuator_gainprm", "dof_damping", "body_ipos", "body_invweight0"):
        np.testing.assert_allclose(getattr(nominal, field), getattr(env.model, field), rtol=1e-12)


def test_reset_matches_cpu_standing_pose(resets):
    """MJX's reset places the robot as `darwin_pose.set_standing_pose` does for the same posture."""
    states, _ = resets
    env = walk.WalkEnv("darwin_walk_randomized")
    cpu, _ = _cpu_env()
    physics = cpu.physics
    for i in range(3):
        legs = states.data.qpos[i, env._leg_qpos]
        params = {k: np.asarray(v[i]) for k, v in states.params._asdict().items()}
        cpu.task._apply_parameters(physics, params)
        with physics.reset_context():
            darwin_pose.set_standing_pose(physics, legs)
        np.testing.assert_allclose(states.data.qpos[i], physics.data.qpos, atol=1e-12)
        obs = _flat(cpu.task.get_observation(physics))
        np.testing.assert_allclose(_without_touch(states.obs[i]), obs[:38], atol=ATOL)
        assert states.step[i] == 0 and states.done[i] == 0 and states.reward[i] == 0


def test_reset_draws_follow_the_tier_distributions(resets):
    states, schedules = resets
    r = perturbations.Randomization()
    noise = states.data.qpos[:, walk.WalkEnv("darwin_walk")._leg_qpos] - cpg.CPGConfig().offsets()
    assert np.abs(noise).max() <= r.init_noise + 1e-12
    assert np.abs(noise).max() > 0.8 * r.init_noise  # the randomized tier's wider noise
    p = states.params
    for name in ("servo_gain", "torque_limit", "joint_damping", "friction", "torso_mass_scale"):
        low, high = getattr(r, name)
        values = np.asarray(getattr(p, name))
        assert low <= values.min() and values.max() <= high, name
        assert values.std() > 0.2 * (high - low) / np.sqrt(12), name  # spread, not constant
    assert np.abs(p.torso_com_shift).max() <= r.torso_com_shift
    pushes, dt = perturbations.Pushes(), darwin.CONTROL_TIMESTEP
    start_s = schedules.start * dt
    assert np.all(start_s >= np.array(pushes.times) - dt / 2)
    assert np.all(start_s <= np.array(pushes.times) + pushes.jitter + dt / 2)
    impulse = np.linalg.norm(schedules.force, axis=-1) * pushes.steps * dt
    assert pushes.impulse[0] - 1e-12 <= impulse.min() and impulse.max() <= pushes.impulse[1]
    assert np.all(schedules.force[..., 2] == 0) and np.all(schedules.steps == pushes.steps)


def test_push_force_matches_cpu_schedule(joints):
    env, _ = joints
    schedule = walk.PushSchedule(
        start=jnp.asarray([5, 20]),
        steps=jnp.asarray(3),
        force=jnp.asarray([[1.0, 2, 0], [3, 4, 0]]),
    )
    cpu_schedule = [(5, 3, np.array([1.0, 2, 0])), (20, 3, np.array([3.0, 4, 0]))]
    force = jax.jit(jax.vmap(env.push_force, in_axes=(None, 0)))(schedule, jnp.arange(30))
    np.testing.assert_array_equal(force, perturbations.push_forces(cpu_schedule, 30))


def test_steps_match_cpu_reading_by_reading(joints):
    """From the CPU's reset state, the same actions give the same readings and rewards."""
    _assert_readings_match_cpu(*joints)


def test_sole_contacts_step_as_the_cpu(soles):
    """With only the floor's and soles' pairs (12 of 114 contact slots, 68 of 476
    constraint rows), a walking robot that touches with its soles alone reads the same as
    the CPU reference, which computes every pair."""
    env, step = soles
    data = jax.jit(env.reset)(jax.random.key(0)).data
    assert data._impl.contact.geom.shape == (12, 2) and data._impl.efc_J.shape[0] == 68
    _assert_readings_match_cpu(env, step)


def test_sole_contacts_leave_out_the_body(soles):
    """A torso lying on the floor touches it in the full model and not with `soles`."""
    env, _ = soles
    full = walk.WalkEnv("darwin_walk")
    data = mujoco.MjData(full.mj_model)
    data.qpos[2] = 0.02  # the torso origin 2 cm above the floor, upright: its boxes sink in
    mujoco.mj_forward(full.mj_model, data)
    torso = full.mj_model.body("torso").id
    assert any(full.mj_model.geom_bodyid[g] == torso for g in data.contact.geom.ravel())
    mujoco.mj_forward(env.mj_model, data)
    kept = {env.mj_model.geom(n).id for n in (darwin.FLOOR_GEOM, *darwin.FOOT_GEOMS)}
    assert set(data.contact.geom.ravel()) <= kept


def _assert_readings_match_cpu(env, step):
    cpu, _ = _cpu_env()
    state = env.state_from_mujoco(cpu.physics.data)
    actions = _gait_actions(cpu.physics, STEPS)
    touch_mjx, touch_cpu = [], []
    for t in range(STEPS):
        ts = cpu.step(actions[t])
        assert not _feet_touch_each_other(cpu.physics), "foot-foot contacts differ in MJX"
        state = step(state, actions[t])
        np.testing.assert_allclose(_without_touch(state.obs), _flat(ts.observation)[:38], atol=ATOL)
        np.testing.assert_allclose(state.reward, ts.reward, atol=ATOL)
        assert not state.done and not ts.last()
        touch_mjx.append(_touch(state.obs))
        touch_cpu.append(ts.observation["foot_touch"])
    # The touch sensors count the contacts whose ray meets the sole zone; the box-floor
    # contacts lie on the zone's edges, so which count is decided by roundoff on both
    # sides (docs/architecture.md#the-mjx-path): equal in 40 % of these steps, up to
    # 26.7 N apart. Their means over a trial agree (`test_hand_tuned_trial_matches_cpu`).
    weight = cpu.physics.total_mass() * 9.81
    assert np.all(np.asarray(touch_mjx) >= 0) and np.max(touch_mjx) < 2 * weight
    assert np.max(touch_cpu) < 2 * weight


def test_randomized_and_pushed_steps_match_cpu(joints, episode_model):
    """A drawn episode's parameters and pushes act in MJX as in the CPU task."""
    env, step = joints
    cpu, _ = _cpu_env("darwin_walk_randomized")
    physics = cpu.physics
    params = {k: np.asarray(v) for k, v in cpu.task.episode_parameters.items()}
    state = env.state_from_mujoco(physics.data)
    mx = episode_model(walk.EpisodeParams(**params))
    pushes = walk.PushSchedule(
        start=jnp.asarray([2, 10, 30, 40], jnp.int32),
        steps=jnp.asarray(6, jnp.int32),
        force=jnp.asarray([[3.0, 1.0, 0.0]] * 4),
    )
    state = state._replace(
        params=walk.EpisodeParams(**params),
        invweights=(mx.body_invweight0, mx.dof_invweight0),
        pushes=pushes,
    )
    schedule = [(int(s), 6, np.array([3.0, 1.0, 0.0])) for s in pushes.start]
    actions = _gait_actions(physics, 20)
    for t in range(20):
        darwin_perturb.set_torso_push(physics, perturbations.push_force(schedule, t))
        ts = cpu.step(actions[t])
        state = step(state, actions[t])
        np.testing.assert_allclose(_without_touch(state.obs), _flat(ts.observation)[:38], atol=ATOL)
        np.testing.assert_allclose(state.reward, ts.reward, atol=ATOL)


def test_hand_tuned_trial_matches_cpu(joints):
    """The hand-tuned gait over a full trial: the same distance and drift, no fall, and the
    same mean touch readings (`evaluation.gait.evaluate_gait`'s stepping on the CPU side)."""
    env, step = joints
    cpu, _ = _cpu_env("darwin_walk", time_limit=float("inf"))
    steps = walk.EPISODE_STEPS
    state = env.state_from_mujoco(cpu.physics.data)
    start = cpu.physics.torso_position()
    actions = _gait_actions(cpu.physics, steps)
    fell, cpu_fell, touch_mjx, touch_cpu = False, False, 0.0, 0.0
    for t in range(steps):
        state = step(state, actions[t])
        ts = cpu.step(actions[t])
        fell, cpu_fell = fell or bool(state.fell), cpu_fell or ts.last()
        touch_mjx += _touch(state.obs).sum()
        touch_cpu += ts.observation["foot_touch"].sum()
    assert not fell and not cpu_fell and bool(state.done)  # the time limit ends it
    assert int(state.step) == steps
    end = cpu.physics.torso_position()
    distance, lateral = np.asarray(state.data.qpos[:2]) - start[:2]
    np.testing.assert_allclose(distance, end[0] - start[0], atol=DISTANCE_ATOL)
    np.testing.assert_allclose(lateral, end[1] - start[1], atol=LATERAL_ATOL)
    # Measured over the first 200 steps: means 11.34 N (MJX) and 11.44 N (CPU).
    np.testing.assert_allclose(touch_mjx, touch_cpu, rtol=0.1)


def test_modulated_cpg_matches_residual():
    rng = np.random.default_rng(1)
    actions = rng.uniform(-1.2, 1.2, (60, residual.N_ACTIONS))
    actions[:10] = 0.0  # action 0: the open-loop gait
    config = cpg.CPGConfig()
    reference = residual.ModulatedCPG(1)
    nominal = cpg.amplitudes_from("hand_tuned")
    advance = jax.jit(
        functools.partial(
            modulated.step,
            nominal=nominal,
            control_timestep=darwin.CONTROL_TIMESTEP,
            config=config,
        )
    )
    row = modulated.initial_state(config)
    open_loop = cpg.CPG("hand_tuned")
    for t, a in enumerate(actions):
        reference.modulate(a[None])
        expected = reference.step(darwin.CONTROL_TIMESTEP)[0]
        row, targets = advance(row, jnp.asarray(a))
        np.testing.assert_allclose(targets, expected, atol=1e-12)
        np.testing.assert_allclose(
            modulated.phase_features(row, config), reference.phase_features()[0], atol=1e-12
        )
        if t < 10:
            np.testing.assert_allclose(targets, open_loop.step(darwin.CONTROL_TIMESTEP), atol=1e-12)


def test_cpg_action_space_matches_cpu(cpg_env):
    env, step = cpg_env
    cpu, _ = _cpu_env()
    physics = cpu.physics
    state = env.state_from_mujoco(physics.data)
    assert state.obs.shape == (env.observation_size,) == (42,)
    np.testing.assert_allclose(state.obs[40:], [-1.0, 0.0], atol=1e-12)  # φ_L(0) = π
    rows = residual.ModulatedCPG(1)
    actions = np.random.default_rng(2).uniform(-1, 1, (20, residual.N_ACTIONS))
    for a in actions:
        joint_actions = residual.joint_actions(a[None], rows, physics, darwin.CONTROL_TIMESTEP)
        ts = cpu.step(joint_actions[0])
        state = step(state, a)
        np.testing.assert_allclose(_without_touch(state.obs), _flat(ts.observation)[:38], atol=ATOL)
        np.testing.assert_allclose(state.obs[40:], rows.phase_features()[0], atol=1e-12)
        np.testing.assert_allclose(state.reward, ts.reward, atol=ATOL)


def test_fall_ends_the_episode(joints):
    env, step = joints
    cpu, _ = _cpu_env()
    state = env.state_from_mujoco(cpu.physics.data)
    # Throw the legs to one end of their ranges: the robot topples within a few seconds.
    for t in range(300):
        state = step(state, np.full(12, 1.0 if t % 50 < 25 else -1.0))
        if state.done:
            break
    assert state.done == 1 and state.fell == 1 and int(state.step) < 300
    assert darwin.has_fallen(np.asarray(state.data.qpos[:7]))


def test_supply_current_and_brownout_match_cpu():
    """The supply's running total follows the CPU task's, and a limit the hand-tuned gait
    crosses (3.4 A over 1 s; its 1 s mean peaks near 3.5 A) browns it out at the same step."""
    low = electrical.SupplyLimit(current=3.4)
    with jax.enable_x64(True):
        env = walk.WalkEnv("darwin_walk", contacts="soles", supply=low)
        step = _jit(env.step)
    cpu, _ = _cpu_env(time_limit=float("inf"), supply=low)
    state = env.state_from_mujoco(cpu.physics.data)
    actions = _gait_actions(cpu.physics, 400)
    for t in range(400):
        state = step(state, actions[t])
        ts = cpu.step(actions[t])
        np.testing.assert_allclose(float(state.supply[0]), cpu.task.supply.total, rtol=1e-9)
        if ts.last() or bool(state.done):
            break
    assert cpu.task.failure == "brownout" and ts.last()
    assert bool(state.done) and state.brownout == 1 and state.fell == 1
    assert int(state.step) == t + 1 < 400


def test_bad_arguments():
    with pytest.raises(ValueError, match="unknown MJX task"):
        walk.WalkEnv("darwin_walk_rough")
    with pytest.raises(ValueError, match="action_space"):
        walk.WalkEnv("darwin_walk", "torques")
    with pytest.raises(ValueError, match="posture"):
        walk.WalkEnv("darwin_walk", posture=np.zeros(11))
    with pytest.raises(ValueError, match="contacts must be one of"):
        walk.WalkEnv("darwin_walk", contacts="feet")
    for caps in ((0, 8), (4,), (4, 8, 2), (4.5, 8), ("4", "8"), (True, 8), 4):
        with pytest.raises(ValueError, match="solver_iterations must be two integers"):
            walk.WalkEnv("darwin_walk", solver_iterations=caps)


def test_solver_caps_reach_the_mjx_model():
    """The model's own solver (the CPU reference's) unless caps are given; then MJX's."""
    own = walk.WalkEnv("darwin_walk")
    capped = walk.WalkEnv("darwin_walk", solver_iterations=(4, 8))
    assert (own.model.opt.iterations, own.model.opt.ls_iterations) == (100, 50)
    assert (capped.model.opt.iterations, capped.model.opt.ls_iterations) == (4, 8)
    assert (capped.mj_model.opt.iterations, capped.mj_model.opt.ls_iterations) == (4, 8)
