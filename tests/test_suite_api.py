"""The suite's loading API and its input checks."""

import numpy as np
import pytest

import cpg_suite


def test_task_ids_and_tables():
    assert ("pole", "balance") in cpg_suite.ALL_TASKS
    assert ("pole", "balance_continuous") in cpg_suite.ALL_TASKS
    assert cpg_suite.TASKS_BY_DOMAIN["pole"] == ("balance", "balance_continuous")
    assert "pole_balance" in cpg_suite.TASK_IDS


def test_load_by_id_equals_load_by_pair():
    a = cpg_suite.load("pole_balance", task_kwargs={"random": 3})
    b = cpg_suite.load("pole", "balance", task_kwargs={"random": 3})
    ta, tb = a.reset(), b.reset()
    for key in ta.observation:
        np.testing.assert_array_equal(ta.observation[key], tb.observation[key])
    for _ in range(20):
        ta, tb = a.step(2), b.step(2)
        assert ta.reward == tb.reward


@pytest.mark.parametrize(
    "args", [("pole_swingup",), ("walker_walk",), ("pole", "nope"), ("nodomain", "balance"), ("",)]
)
def test_unknown_task_lists_valid_ids(args):
    with pytest.raises(ValueError) as err:
        cpg_suite.load(*args)
    for task_id in cpg_suite.TASK_IDS:
        assert task_id in str(err.value)


def test_task_kwargs_and_time_limit():
    env = cpg_suite.load("pole_balance", task_kwargs={"time_limit": 0.1, "random": 0})
    ts = env.reset()
    steps = 0
    while not ts.last():
        ts = env.step(1)
        steps += 1
    assert steps == 5  # 0.1 s at 20 ms per control step.
    assert ts.discount == 1.0  # A time limit is a truncation, not a failure.


def test_random_state_object_is_accepted():
    env = cpg_suite.load("pole_balance", task_kwargs={"random": np.random.RandomState(5)})
    env.reset()


@pytest.mark.parametrize("action", [np.nan, [0, 1], 3, -1, 1.5, "left", np.inf])
def test_bad_discrete_action_raises_value_error(action):
    env = cpg_suite.load("pole_balance")
    env.reset()
    with pytest.raises(ValueError):
        env.step(action)


@pytest.mark.parametrize("action", [[np.nan], [np.inf], [0.1, 0.2], np.zeros((2, 2)), "x"])
def test_bad_continuous_action_raises_value_error(action):
    env = cpg_suite.load("pole_balance_continuous")
    env.reset()
    with pytest.raises(ValueError) as err:
        env.step(action)
    assert str(err.value)


def test_discrete_action_forms_are_equivalent():
    results = []
    for action in (2, np.int64(2), 2.0, np.array([2])):
        env = cpg_suite.load("pole_balance", task_kwargs={"random": 1})
        env.reset()
        results.append(env.step(action).observation["angle"][0])
    assert len(set(results)) == 1


def test_bad_task_kwargs():
    with pytest.raises(ValueError):
        cpg_suite.load("pole_balance", task_kwargs={"force": -1.0})
    with pytest.raises(ValueError):
        cpg_suite.load("pole_balance", task_kwargs={"num_actions": 4})
    with pytest.raises(ValueError):
        cpg_suite.load("pole_balance", task_kwargs={"reward": "sparse"})
