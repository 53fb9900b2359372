"""The MJX walking tiers on MJX's Warp backend (MuJoCo Warp), on Warp's CPU device.

Warp's physics is float32 only, so the comparisons with the CPU reference (float64) hold to
float32 tolerances, per reading. Measured on this model (hand-tuned gait, CPU seed 3, 40
control steps; `tests/test_mjx.py`'s comparison): the largest differences from the CPU were
2.1e-7 rad (joint angles), 9.9e-6 rad/s (joint velocities), 9.7e-8 (orientation), 8.7e-8 m
(height), 2.0e-6 m/s (torso velocity), 5.2e-6 rad/s (gyro), 3.5e-4 m/s² (accelerometer),
8.7e-9 m (reward), 4.5e-7 of the supply's running total; MJX's JAX backend in float32 gave
5.4e-7, 3.1e-5, 3.2e-7, 8.2e-8, 2.6e-6, 1.6e-5, 4.5e-4, 2.4e-8 and 5.6e-7. The tolerances
below are about 30 times Warp's figures, room for other CPUs' float32 sums. Warp compiles its
kernels once per machine (about a minute, cached in ~/.cache/warp); a step compiles in
seconds after that.
"""

import os

import numpy as np
import pytest

pytestmark = pytest.mark.slow  # Warp kernels and MJX steps compiled on the CPU: minutes

jax = pytest.importorskip("jax")
pytest.importorskip("mujoco.mjx")
pytest.importorskip("warp")

import jax.numpy as jnp  # noqa: E402

import cpg_suite  # noqa: E402
from cpg_suite import (  # noqa: E402
    cpg,
    darwin,
    electrical,
    perturbations,
    protocol,
    residual,
)
from cpg_suite.darwin import perturb as darwin_perturb  # noqa: E402
from cpg_suite.mjx import training, walk  # noqa: E402

SEED = 3  # CPU task seed of the comparisons.
STEPS = 40  # control steps compared reading by reading.
# Per reading (`walk.OBSERVATION_KEYS` without the touch sensors): its size and tolerance.
TOLERANCES = {
    "joint_angles": (12, 1e-5),  # rad
    "joint_velocities": (12, 3e-4),  # rad/s
    "torso_orientation": (4, 3e-6),
    "torso_height": (1, 3e-6),  # m
    "torso_velocity": (3, 6e-5),  # m/s
    "gyro": (3, 1.5e-4),  # rad/s
    "accelerometer": (3, 1e-2),  # m/s²
}
# With an episode's drawn parameters (and pushes), which float32 rounds (the servo gain
# 44.49144048 N·m/rad, ...), both float32 backends part further from the CPU's float64 over
# 20 steps: measured 7.5e-6 rad, 9.8e-4 rad/s, 1.5e-6, 1.9e-7 m, 3.2e-5 m/s, 3.1e-4 rad/s
# and 3.6e-3 m/s² on Warp, 7.9e-6, 9.9e-4, 1.7e-6, 1.9e-7, 3.2e-5, 3.2e-4 and 3.7e-3 on
# MJX-JAX; Warp and MJX-JAX stayed within 7.2e-6 rad/s of each other. Five times those:
DRAWN_TOLERANCES = {
    "joint_angles": (12, 4e-5),
    "joint_velocities": (12, 5e-3),
    "torso_orientation": (4, 8e-6),
    "torso_height": (1, 1e-6),
    "torso_velocity": (3, 1.6e-4),
    "gyro": (3, 1.6e-3),
    "accelerometer": (3, 2e-2),
}
REWARD_ATOL = 3e-7  # m
SUPPLY_RTOL = 1.5e-5


@pytest.fixture(scope="module")
def warp():
    """The randomized tier's env on Warp (joint actions) and its compiled step."""
    env = walk.WalkEnv("darwin_walk_randomized", impl="warp", max_robots=8)
    return env, jax.jit(env.step)


def _cpu_env(task="darwin_walk", **kwargs):
    env = cpg_suite.load(task, task_kwargs={"random": SEED, **kwargs})
    return env, env.reset()


def _flat(observation) -> np.ndarray:
    return np.concatenate([np.ravel(observation[k]) for k in walk.OBSERVATION_KEYS])


def _gait_actions(physics, steps: int) -> np.ndarray:
    targets = cpg.trajectories(cpg.amplitudes_from("hand_tuned"), steps, darwin.CONTROL_TIMESTEP)
    return physics.targets_to_action(targets[0])


def _assert_close_per_reading(obs, expected, tolerances=TOLERANCES):
    start = 0
    for name, (size, atol) in tolerances.items():
        got, want = np.asarray(obs)[start : start + size], expected[start : start + size]
        np.testing.assert_allclose(got, want, atol=atol, err_msg=name)
        start += size


def test_warp_model_and_data_are_float32_with_room_for_the_batch(warp):
    env, _ = warp
    assert env.model.impl.value == "warp" and env.model.qpos0.dtype == jnp.float32
    # 114 MJX-JAX contact slots per robot, twice that on Warp, for 8 robots.
    assert env.warp_contacts_per_robot == 228 and env.warp_naconmax == 8 * 228


def test_warp_steps_match_cpu_reading_by_reading(warp):
    env, step = warp
    cpu, _ = _cpu_env()
    state = env.state_from_mujoco(cpu.physics.data)
    actions = _gait_actions(cpu.physics, STEPS)
    for t in range(STEPS):
        ts = cpu.step(actions[t])
        state = step(state, actions[t])
        _assert_close_per_reading(state.obs, _flat(ts.observation))
        np.testing.assert_allclose(state.reward, ts.reward, atol=REWARD_ATOL)
        np.testing.assert_allclose(float(state.supply[0]), cpu.task.supply.total, rtol=SUPPLY_RTOL)
        assert not state.done and not ts.last()


def test_warp_episode_parameters_and_pushes_act_as_on_the_cpu(warp):
    env, step = warp
    cpu, _ = _cpu_env("darwin_walk_randomized")
    physics = cpu.physics
    params = walk.EpisodeParams(
        **{k: np.asarray(v) for k, v in cpu.task.episode_parameters.items()}
    )
    state = env.state_from_mujoco(physics.data)
    pushes = walk.PushSchedule(
        start=jnp.asarray([2, 10, 30, 40], jnp.int32),
        steps=jnp.asarray(6, jnp.int32),
        force=jnp.asarray([[3.0, 1.0, 0.0]] * 4),
    )
    state = state._replace(params=params, invweights=env.invweights(params), pushes=pushes)
    schedule = [(int(s), 6, np.array([3.0, 1.0, 0.0])) for s in pushes.start]
    actions = _gait_actions(physics, 20)
    for t in range(20):
        darwin_perturb.set_torso_push(physics, perturbations.push_force(schedule, t))
        ts = cpu.step(actions[t])
        state = step(state, actions[t])
        _assert_close_per_reading(state.obs, _flat(ts.observation), DRAWN_TOLERANCES)
        np.testing.assert_allclose(state.reward, ts.reward, atol=10 * REWARD_ATOL)


def test_warp_cpg_action_space_matches_cpu():
    """The CPG-modulating actions reach Warp's physics as the CPU wrapper's reach the task."""
    env = walk.WalkEnv("darwin_walk", "cpg", impl="warp", max_robots=1)
    step = jax.jit(env.step)
    cpu, _ = _cpu_env()
    physics = cpu.physics
    state = env.state_from_mujoco(physics.data)
    rows = residual.ModulatedCPG(1)
    for a in np.random.default_rng(2).uniform(-1, 1, (20, residual.N_ACTIONS)):
        joint_actions = residual.joint_actions(a[None], rows, physics, darwin.CONTROL_TIMESTEP)
        ts = cpu.step(joint_actions[0])
        state = step(state, a)
        _assert_close_per_reading(state.obs, _flat(ts.observation))
        # The CPG's phase in float32 (JAX's default here): 1.1e-6 off after 20 steps.
        np.testing.assert_allclose(state.obs[40:], rows.phase_features()[0], atol=1e-5)


def test_warp_resets_are_the_jax_backends(warp):
    """The same keys draw the same episodes on both backends; the standing poses agree to
    float32 roundoff. The first accelerometer and touch readings may not: the lowest sole
    corner is put on the floor exactly, and whether float32 roundoff leaves it touching
    differs between the backends (measured: one robot of these four touches on Warp, with
    3.2 m/s² on the accelerometer; none on MJX-JAX, none on the CPU in float64)."""
    env, _ = warp
    jax_env = walk.WalkEnv("darwin_walk_randomized")
    keys = jax.random.split(jax.random.key(0), 4)
    ours = jax.jit(jax.vmap(env.reset))(keys)
    theirs = jax.jit(jax.vmap(jax_env.reset))(keys)
    for a, b in zip(ours.params, theirs.params):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_allclose(ours.invweights[0], theirs.invweights[0], rtol=1e-5)
    np.testing.assert_allclose(ours.data.qpos, theirs.data.qpos, atol=1e-6)
    np.testing.assert_allclose(ours.obs[:, :35], theirs.obs[:, :35], atol=1e-5)


def test_warp_brownout_ends_the_episode_as_on_the_cpu():
    """A limit the hand-tuned gait crosses (3.4 A over 1 s) browns it out at the CPU's step."""
    low = electrical.SupplyLimit(current=3.4)
    env = walk.WalkEnv("darwin_walk", impl="warp", max_robots=1, supply=low)
    step = jax.jit(env.step)
    cpu, _ = _cpu_env(time_limit=float("inf"), supply=low)
    state = env.state_from_mujoco(cpu.physics.data)
    actions = _gait_actions(cpu.physics, 400)
    for t in range(400):
        state = step(state, actions[t])
        ts = cpu.step(actions[t])
        if ts.last() or bool(state.done):
            break
    assert cpu.task.failure == "brownout" and ts.last()
    assert bool(state.done) and state.brownout == 1 and state.fell == 1
    assert int(state.step) == t + 1 < 400


def test_fresh_reset_keeps_warps_shared_contact_list():
    """`FreshResetWrapper`'s merge takes each robot's fields from the fresh or the current
    episode, and keeps Warp's contact list, which all robots share, from the current one."""
    env = walk.WalkEnv("darwin_walk", impl="warp", max_robots=4)
    reset = jax.jit(jax.vmap(env.reset))
    current = reset(jax.random.split(jax.random.key(1), 4))
    current = jax.jit(jax.vmap(env.step))(current, jnp.zeros((4, 12)))
    fresh = reset(jax.random.split(jax.random.key(2), 4))
    done = jnp.asarray([1.0, 0.0, 1.0, 0.0])
    data, obs = training._where_done(done, (fresh.data, fresh.obs), (current.data, current.obs))
    for rows, source in ((np.array([0, 2]), fresh), (np.array([1, 3]), current)):
        np.testing.assert_array_equal(data.qpos[rows], source.data.qpos[rows])
        np.testing.assert_array_equal(obs[rows], source.obs[rows])
    shared = current.data._impl.contact__dist
    assert shared.shape[0] == env.warp_naconmax
    assert not np.array_equal(fresh.data._impl.contact__dist, shared)  # the choice shows
    np.testing.assert_array_equal(data._impl.contact__dist, shared)


def test_bad_backend_and_physics_arguments():
    with pytest.raises(ValueError, match="impl must be one of"):
        walk.WalkEnv("darwin_walk", impl="cuda")
    with pytest.raises(ValueError, match="physics must be one of"):
        walk.WalkEnv("darwin_walk", physics="fast")
    for robots in (0, 2.5, True):
        with pytest.raises(ValueError, match="max_robots must be an integer"):
            walk.WalkEnv("darwin_walk", impl="warp", max_robots=robots)
    for timestep in (0.003, 0.0, -0.002, 0.032):
        with pytest.raises(ValueError, match="timestep must divide"):
            walk.WalkEnv("darwin_walk", timestep=timestep)
    with jax.enable_x64(True), pytest.raises(ValueError, match="float32"):
        walk.WalkEnv("darwin_walk", physics="training")


def test_the_training_physics_is_its_named_parts():
    env = walk.WalkEnv("darwin_walk", physics="training", impl="warp", max_robots=1)
    settings = walk.PHYSICS["training"]
    assert env.contacts == settings.contacts == "soles"
    opt = env.mj_model.opt
    assert (opt.iterations, opt.ls_iterations) == settings.solver_iterations
    assert opt.timestep == (settings.timestep or 0.002)
    assert env.n_substeps == round(darwin.CONTROL_TIMESTEP / opt.timestep)
    # 12 MJX-JAX slots for the floor's and soles' pairs, twice that on Warp.
    assert env.warp_contacts_per_robot == 24


def test_ppo_trains_on_warp_and_validates_on_the_cpu(tmp_path):
    """Brax's PPO through the whole chain on Warp (fresh resets, the training physics, the
    supply limit): two updates, each followed by a CPU validation of the exported policy."""
    from baselines import ppo_mjx
    from cpg_suite.runfiles import runs

    settings = ppo_mjx.PPOMJXSettings(
        action_space="cpg",
        impl="warp",
        num_envs=8,
        batch_size=4,
        num_minibatches=2,
        unroll_length=5,
        total_steps=80,
        validation_every=40,
        validation_seeds=1,
        trial_steps=10,
        test_seeds=0,
        policy_layers=(8,),
        value_layers=(8,),
    )
    run_dir, summary = ppo_mjx.run(settings, runs.RunOptions(output_dir=str(tmp_path)))
    progress = (tmp_path / "ppo_mjx" / "darwin_walk" / "cpg_seed0" / "progress.csv").read_text()
    rows = progress.strip().splitlines()[1:]
    assert len(rows) >= 2 and summary["env_steps"] >= 80
    assert all(np.isfinite(float(r.split(",")[1])) for r in rows)  # validation distances
    config = runs.read_json(os.path.join(run_dir, "config.json"))
    assert config["settings"]["impl"] == "warp"
    assert config["settings"]["benchmark_version"] == protocol.BENCHMARK_VERSION
