"""The checks dm_control runs over its own suite (dm_control/suite/suite_test.py), applied
to every cpg_suite task.

Differences, all deliberate:
  * rewards follow the study (metres, −θ², ...), so the [0, 1] reward-range check is
    replaced by "a float"; reward visualization maps rewards through the task's
    `reward_to_unit` instead of clipping them;
  * random policies draw integers for discrete action specs;
  * the [−1, 1] control-range check applies to every continuous task, not only to the
    benchmarking ones.
"""

from unittest import mock

import numpy as np
import pytest
from dm_control.rl import control
from dm_env import specs

import cpg_suite

TASKS = [f"{d}_{t}" for d, t in cpg_suite.ALL_TASKS]


def random_policy(action_spec, seed=None):
    rng = np.random.RandomState(seed)
    if isinstance(action_spec, specs.DiscreteArray):
        return lambda ts: rng.randint(action_spec.num_values)
    low, high = action_spec.minimum, action_spec.maximum
    return lambda ts: rng.uniform(low, high, size=action_spec.shape)


def step_environment(env, policy, num_episodes=5, max_steps_per_episode=10):
    for _ in range(num_episodes):
        steps = 0
        ts = env.reset()
        yield ts
        while not ts.last():
            ts = env.step(policy(ts))
            steps += 1
            yield ts
            if steps >= max_steps_per_episode:
                break


def make_trajectory(task_id, seed, **kwargs):
    env = cpg_suite.load(task_id, task_kwargs={"random": seed})
    return step_environment(env, random_policy(env.action_spec(), seed), **kwargs)


def test_constants():
    assert len(cpg_suite.ALL_TASKS) == sum(len(t) for t in cpg_suite.TASKS_BY_DOMAIN.values())
    assert set(cpg_suite.BENCHMARKING) <= set(cpg_suite.ALL_TASKS)
    assert len(set(cpg_suite.ALL_TASKS)) == len(cpg_suite.ALL_TASKS)


@pytest.mark.parametrize("task_id", TASKS)
def test_components_have_names(task_id):
    model = cpg_suite.load(task_id).physics.model
    for object_type, size_field in [
        ("body", "nbody"),
        ("joint", "njnt"),
        ("geom", "ngeom"),
        ("site", "nsite"),
        ("camera", "ncam"),
        ("light", "nlight"),
        ("mesh", "nmesh"),
        ("hfield", "nhfield"),
        ("texture", "ntex"),
        ("material", "nmat"),
        ("equality", "neq"),
        ("tendon", "ntendon"),
        ("actuator", "nu"),
        ("sensor", "nsensor"),
        ("numeric", "nnumeric"),
        ("text", "ntext"),
        ("tuple", "ntuple"),
    ]:
        for idx in range(getattr(model, size_field)):
            assert model.id2name(idx, object_type), f"unnamed {object_type} {idx} in {task_id}"


@pytest.mark.parametrize("task_id", TASKS)
def test_model_has_at_least_2_cameras(task_id):
    assert cpg_suite.load(task_id).physics.model.ncam >= 2


def _validate_observation(observation, observation_spec):
    obs = dict(observation)
    for name, spec in observation_spec.items():
        arr = obs.pop(name)
        assert arr.shape == spec.shape, name
        assert arr.dtype == spec.dtype, name
        assert np.all(np.isfinite(arr)), f"{name} has non-finite values: {arr}"
    assert not obs, f"observation has entries not in the spec: {list(obs)}"


@pytest.mark.parametrize("task_id", TASKS)
def test_task_conforms_to_spec(task_id):
    env = cpg_suite.load(task_id)
    action_spec = env.action_spec()
    if isinstance(action_spec, specs.DiscreteArray):
        assert action_spec.minimum == 0 and action_spec.maximum == action_spec.num_values - 1
    else:
        assert np.all(action_spec.minimum == -1.0) and np.all(action_spec.maximum == 1.0)
    for ts in step_environment(env, random_policy(action_spec)):
        _validate_observation(ts.observation, env.observation_spec())
        if ts.first():
            assert ts.reward is None and ts.discount is None
        else:
            assert isinstance(ts.reward, float) and np.isfinite(ts.reward)
            assert isinstance(ts.discount, float) and 0.0 <= ts.discount <= 1.0


@pytest.mark.parametrize("task_id", TASKS)
def test_environment_is_deterministic(task_id):
    t1 = make_trajectory(task_id, seed=0)
    t2 = make_trajectory(task_id, seed=0)
    n = 0
    for a, b in zip(t1, t2):
        assert a.step_type == b.step_type
        assert a.reward == b.reward
        assert a.discount == b.discount
        for key in a.observation:
            np.testing.assert_array_equal(a.observation[key], b.observation[key], err_msg=key)
        n += 1
    assert n > 5


def _assert_correct_colors(physics, unit):
    colors = physics.named.model.mat_rgba
    for name in ("self", "effector", "target"):
        blend = unit**4
        expected = blend * colors[name + "_highlight"] + (1 - blend) * colors[name + "_default"]
        np.testing.assert_array_almost_equal(expected, colors[name], err_msg=name)


@pytest.mark.parametrize("task_id", [f"{d}_{t}" for d, t in cpg_suite.REWARD_VIZ])
def test_visualize_reward(task_id):
    env = cpg_suite.load(task_id, visualize_reward=True)
    action = (
        0
        if isinstance(env.action_spec(), specs.DiscreteArray)
        else np.zeros(env.action_spec().shape)
    )
    task = env.task
    for value in (-3.0, 0.0, 0.5, 2.0, -1e-3):
        with mock.patch.object(task, "get_reward", return_value=value) as get_reward:
            env.reset()
            get_reward.assert_called_with(env.physics)
            _assert_correct_colors(env.physics, float(np.clip(task.reward_to_unit(value), 0, 1)))
            env.step(action)
            _assert_correct_colors(env.physics, float(np.clip(task.reward_to_unit(value), 0, 1)))
    # The mapping is monotone: a better reward never looks worse.
    units = [task.reward_to_unit(r) for r in np.linspace(-5, 5, 41)]
    assert all(b >= a for a, b in zip(units, units[1:]))


@pytest.mark.parametrize("task_id", TASKS)
def test_task_supports_environment_kwargs(task_id):
    env = cpg_suite.load(task_id, environment_kwargs=dict(flat_observation=True))
    assert set(env.observation_spec()) == {control.FLAT_OBSERVATION_KEY}


@pytest.mark.parametrize("task_id", TASKS)
def test_observation_arrays_dont_share_memory(task_id):
    env = cpg_suite.load(task_id)
    first = env.reset()
    action = (
        0
        if isinstance(env.action_spec(), specs.DiscreteArray)
        else np.zeros(env.action_spec().shape)
    )
    second = env.step(action)
    for name, arr in first.observation.items():
        assert not np.may_share_memory(arr, second.observation[name]), name


@pytest.mark.parametrize("task_id", TASKS)
def test_observations_dont_contain_constant_elements(task_id):
    env = cpg_suite.load(task_id)
    observations = {name: [] for name in env.observation_spec()}
    for ts in make_trajectory(task_id, seed=0, num_episodes=2, max_steps_per_episode=1000):
        for name, arr in ts.observation.items():
            observations[name].append(arr)
    for name, arrays in observations.items():
        stacked = np.array(arrays)
        assert not np.any(np.all(stacked == stacked[0], axis=0)), f"{name} has constant elements"


@pytest.mark.parametrize("task_id", TASKS)
def test_initial_state_is_randomized(task_id):
    env = cpg_suite.load(task_id, task_kwargs={"random": 42})
    obs1 = env.reset().observation
    obs2 = env.reset().observation
    assert not all(np.all(obs1[k] == obs2[k]) for k in obs1)


@pytest.mark.parametrize("task_id", TASKS)
def test_factory_signature(task_id):
    """Factories take (time_limit, random, environment_kwargs) as in dm_control."""
    domain, task = cpg_suite.split_task_id(task_id)
    factory = getattr(cpg_suite, domain).SUITE[task]
    params = factory.__code__.co_varnames[: factory.__code__.co_argcount]
    for name in ("time_limit", "random", "environment_kwargs"):
        assert name in params
