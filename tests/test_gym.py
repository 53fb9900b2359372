"""Gymnasium loading of every task, checked by Gymnasium's own env checker."""

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")
pytest.importorskip("shimmy")

from gymnasium.utils.env_checker import check_env  # noqa: E402

import cpg_suite.gym  # noqa: E402


@pytest.mark.parametrize("env_id", cpg_suite.gym.ENV_IDS)
def test_env_checker_passes(env_id):
    env = gymnasium.make(env_id)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


@pytest.mark.parametrize("env_id", cpg_suite.gym.ENV_IDS)
def test_reset_seed_makes_runs_reproducible(env_id):
    runs = []
    for _ in range(2):
        env = gymnasium.make(env_id)
        obs, _ = env.reset(seed=7)
        env.action_space.seed(3)
        rewards = [env.step(env.action_space.sample())[1] for _ in range(5)]
        runs.append((obs, rewards))
        env.close()
    for key in runs[0][0]:
        np.testing.assert_array_equal(runs[0][0][key], runs[1][0][key])
    assert runs[0][1] == runs[1][1]


def test_module_prefixed_id_and_task_kwargs():
    env = gymnasium.make("cpg_suite.gym:cpg_suite/pole_balance-v0", time_limit=0.1)
    env.reset(seed=0)
    steps, done = 0, False
    while not done:
        _, _, terminated, truncated, _ = env.step(1)
        done = terminated or truncated
        steps += 1
    assert steps == 5 and truncated and not terminated
