"""The vectorized DARwIn-OP env (`cpg_suite.vector`) against Gymnasium's SyncVectorEnv."""

import gymnasium
import numpy as np
import pytest
from gymnasium.vector import SyncVectorEnv

import cpg_suite
import cpg_suite.gym  # registers the environments
from cpg_suite import cpg, vector

# 40 control steps per episode, so that episodes end by the time limit as well as by falls.
SHORT = {"time_limit": 40 * 0.016}


def _gait_actions(steps: int) -> np.ndarray:
    """The hand-tuned open-loop gait as normalized actions (it walks without falling)."""
    env = cpg_suite.load("darwin_walk")
    targets = cpg.trajectories(cpg.amplitudes_from("hand_tuned"), steps, env.control_timestep())
    return env.physics.targets_to_action(targets[0])


def _actions(rng, n: int, t: int, gait: np.ndarray) -> np.ndarray:
    """The gait for some sub-environments, random targets (quick falls) for the others."""
    noise = rng.uniform(-1.0, 1.0, size=(n, 12))
    return np.where(np.arange(n)[:, None] % 2 == 0, gait[t % len(gait)], noise)


def _assert_same(a, b, where):
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=f"{key} at {where}")


def _run(envs, steps, seed=3):
    rng = np.random.default_rng(0)
    gait = _gait_actions(100)
    observations, _ = envs.reset(seed=seed)
    out = [observations]
    for t in range(steps):
        out.append(envs.step(_actions(rng, envs.num_envs, t, gait)))
    return out


@pytest.mark.parametrize("task", vector.WALK_TASKS)
def test_transitions_equal_sync_vector_env_of_single_envs(task):
    env_id = f"cpg_suite/{task}-v0"
    ours = gymnasium.make_vec(env_id, num_envs=3, threads=2, **SHORT)
    sync = gymnasium.make_vec(env_id, num_envs=3, vectorization_mode="sync", **SHORT)
    assert isinstance(ours, vector.DarwinVectorEnv) and isinstance(sync, SyncVectorEnv)
    a, b = _run(ours, 90), _run(sync, 90)
    _assert_same(a[0], b[0], "reset")
    ended = {"terminated": 0, "truncated": 0}
    for t, (x, y) in enumerate(zip(a[1:], b[1:])):
        _assert_same(x[0], y[0], t)
        for i, name in enumerate(("reward", "terminated", "truncated"), start=1):
            np.testing.assert_array_equal(x[i], y[i], err_msg=f"{name} at {t}")
        ended["terminated"] += int(x[2].sum())
        ended["truncated"] += int(x[3].sum())
    assert ended["terminated"] > 0 and ended["truncated"] > 0, ended  # both autoresets seen
    assert ours.physics_steps > 0


def test_results_do_not_depend_on_the_thread_count():
    runs = [
        _run(vector.DarwinVectorEnv("darwin_walk_rough", 5, threads=k, **SHORT), 30) for k in (1, 4)
    ]
    for x, y in zip(runs[0][1:], runs[1][1:]):
        _assert_same(x[0], y[0], "step")
        np.testing.assert_array_equal(x[1], y[1])


def test_same_step_autoreset_returns_the_final_observation_and_the_reset_one():
    nxt = vector.DarwinVectorEnv("darwin_walk", 2, **SHORT)
    same = vector.DarwinVectorEnv("darwin_walk", 2, autoreset_mode="SameStep", **SHORT)
    gait = _gait_actions(100)
    a, _ = nxt.reset(seed=7)
    b, _ = same.reset(seed=7)
    for t in range(40):
        a, ra, _, trunc_a, _ = nxt.step(np.stack([gait[t]] * 2))
        b, rb, _, trunc_b, info = same.step(np.stack([gait[t]] * 2))
        np.testing.assert_array_equal(ra, rb)
    assert trunc_a.all() and trunc_b.all() and info["_final_obs"].all()
    for i in range(2):
        _assert_same(info["final_obs"][i], {k: v[i] for k, v in a.items()}, "final")
    a, ra, term, trunc, _ = nxt.step(np.zeros((2, 12)))  # next-step mode resets now
    assert not ra.any() and not term.any() and not trunc.any()
    _assert_same(a, b, "the reset observation")


def test_seeding():
    envs = vector.DarwinVectorEnv("darwin_walk_randomized", 3)
    first, _ = envs.reset(seed=11)
    again, _ = envs.reset(seed=[11, 12, 13])
    _assert_same(first, again, "same seeds")
    single = gymnasium.make("cpg_suite/darwin_walk_randomized-v0")
    single.reset(seed=12)
    follow, _ = single.reset()  # no seed: the task's random stream goes on
    envs.reset(seed=11)
    nxt, _ = envs.reset()
    _assert_same({k: v[1] for k, v in nxt.items()}, follow, "continued stream")
    masked, _ = envs.reset(seed=[None, 12, None], options={"reset_mask": [False, True, False]})
    _assert_same(
        {k: v[[0, 2]] for k, v in masked.items()},
        {k: v[[0, 2]] for k, v in nxt.items()},
        "unmasked untouched",
    )
    _assert_same(
        {k: v[1] for k, v in masked.items()}, {k: v[1] for k, v in first.items()}, "masked"
    )


def test_spaces():
    envs = gymnasium.make_vec("cpg_suite/darwin_walk_push-v0", num_envs=4)
    single = gymnasium.make("cpg_suite/darwin_walk_push-v0")
    assert envs.single_observation_space == single.observation_space
    assert envs.single_action_space == single.action_space
    observations, _ = envs.reset(seed=0)
    assert envs.observation_space.contains(observations)
    assert envs.action_space.shape == (4, 12)
    step = envs.step(envs.action_space.sample())
    assert envs.observation_space.contains(step[0])
    assert step[1].shape == (4,) and step[2].dtype == bool and step[3].dtype == bool


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"task_id": "darwin_balance"}, "unknown walking task"),
        ({"task_id": "darwin_walk", "num_envs": 0}, "num_envs"),
        ({"task_id": "darwin_walk", "threads": 0}, "threads"),
        ({"task_id": "darwin_walk", "random": 3}, "seed"),
        ({"task_id": "darwin_walk", "autoreset_mode": "Disabled"}, "autoreset_mode"),
    ],
)
def test_bad_construction(kwargs, match):
    with pytest.raises(ValueError, match=match):
        vector.DarwinVectorEnv(**{"num_envs": 2, **kwargs})


def test_bad_actions():
    envs = vector.DarwinVectorEnv("darwin_walk", 2)
    envs.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        envs.step(np.zeros((3, 12)))
    with pytest.raises(ValueError, match="NaN"):
        envs.step(np.full((2, 12), np.nan))
    with pytest.raises(ValueError, match="seeds"):
        envs.reset(seed=[1, 2, 3])
