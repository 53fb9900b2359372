"""The crawler domain (thesis Sec. 4.1) and tabular learning on it and on `tokic`."""

import json
import subprocess
import sys

import numpy as np
import pytest

import cpg_suite
from baselines.tabular import exploration, learners, model_env, models, planning
from baselines.tabular.online import run_online
from cpg_suite import crawler

UP, RIGHT, DOWN, LEFT = range(4)


def _env(seed=0, **kw):
    env = cpg_suite.load(
        "crawler_walk", task_kwargs={"random": seed, "time_limit": float("inf"), **kw}
    )
    env.reset()
    return env


def _goto(env, row, col):
    for _ in range(row):
        env.step(DOWN)
    for _ in range(col):
        env.step(RIGHT)
    assert env.task.cell == (row, col)


def test_a_grid_cycle_moves_forward_and_its_reverse_moves_back():
    forward = [DOWN, RIGHT, RIGHT, UP, LEFT, LEFT]  # (2,2) (3,2) (3,3) (3,4) (2,4) (2,3) (2,2)
    backward = [RIGHT, RIGHT, DOWN, LEFT, LEFT, UP]  # the same cells in reverse order
    results = []
    for cycle in (forward, backward):
        env = _env()
        _goto(env, 2, 2)
        start = env.physics.chassis_x()
        for _ in range(5):
            for a in cycle:
                env.step(a)
        assert env.task.cell == (2, 2)
        results.append(env.physics.chassis_x() - start)
    assert results[0] > 0.15  # 5 cycles, about 4 cm each
    assert results[1] < -0.05


def test_rows_0_to_2_keep_the_tip_off_the_ground():
    env = _env()
    for row in range(3):
        for col in range(crawler.GRID):
            env.reset()
            _goto(env, row, col)
            assert env.physics.tip_force() == 0.0, (row, col)
    env.reset()
    _goto(env, 4, 2)
    assert env.physics.tip_force() > 1.0


def test_blocked_moves_leave_the_arm_in_place():
    env = _env()
    ts = env.step(UP)
    assert env.task.cell == (0, 0) and ts.observation["blocked"][0] == 1.0
    assert ts.reward == 0.0
    ts = env.step(DOWN)
    assert env.task.cell == (1, 0) and ts.observation["blocked"][0] == 0.0
    np.testing.assert_array_equal(ts.observation["grid_cell"], [1.0, 0.0])


def test_stochastic_moves_sometimes_do_not_happen():
    env = _env(seed=3, stochastic=0.5)
    stays = 0
    for _ in range(200):
        before = env.task.cell
        env.step(RIGHT if before[1] < 4 else LEFT)
        stays += env.task.cell == before
    assert 70 < stays < 130


def test_crawler_is_deterministic():
    rewards = []
    for _ in range(2):
        env = _env(seed=5)
        rng = np.random.RandomState(0)
        rewards.append([env.step(rng.randint(4)).reward for _ in range(40)])
    assert rewards[0] == rewards[1]


def test_bad_stochastic_argument():
    with pytest.raises(ValueError):
        cpg_suite.load("crawler_walk", task_kwargs={"stochastic": 1.0})


def test_a_backward_penalty_scales_only_backward_moves():
    """The same moves with backward moves punished ×10: forward rewards equal, backward
    ones ten times the displacement, which `move_displacement` still reports."""
    backward = [RIGHT, RIGHT, DOWN, LEFT, LEFT, UP]
    plain, punished = _env(), _env(backward_penalty=10.0)
    for env in (plain, punished):
        _goto(env, 2, 2)
    seen = set()
    for a in backward * 3 + [DOWN, RIGHT]:
        r0, r1 = plain.step(a).reward, punished.step(a).reward
        d = punished.task.move_displacement(punished.physics)
        assert d == plain.task.move_displacement(plain.physics)
        assert r1 == (10.0 * r0 if r0 < 0 else r0) and r0 == d
        seen.add(d < 0)
    assert seen == {True, False}


@pytest.mark.parametrize("k", [0.5, float("nan"), float("inf")])
def test_bad_backward_penalty(k):
    with pytest.raises(ValueError, match="backward_penalty"):
        cpg_suite.load("crawler_walk", task_kwargs={"backward_penalty": k})


TOKIC = models.tokic_model()
SIX_CYCLE_REWARD = 53.0


@pytest.mark.parametrize(
    "algo",
    [
        "q_learning",
        "sarsa",
        "sarsa_lambda",
        "td0",
        "td_lambda",
        "value_iteration",
        "policy_iteration",
    ],
)
def test_every_learner_reaches_the_six_state_cycle_on_tokic(algo):
    """Learning online from the tokic model with a GLIE ε (1 → 0), every algorithm's greedy
    policy ends in the 6-state cycle of thesis CR-1."""
    kwargs = {"allowed": TOKIC.allowed, "tie_order": TOKIC.tie_order}
    if algo in learners.REALTIME_PLANNERS:
        cls = learners.REALTIME_PLANNERS[algo]
        kwargs["successor"] = TOKIC.intended_successor
    else:
        cls = learners.LEARNERS[algo]
        if algo in ("td0", "td_lambda"):
            kwargs["successor"] = TOKIC.intended_successor
        if algo in ("sarsa_lambda", "td_lambda"):
            kwargs["lam"] = 0.5
    steps = 2000 if algo in learners.REALTIME_PLANNERS else 20000
    learner = cls(25, 4, 0.9, 0.2, np.random.RandomState(0), **kwargs)
    env = model_env.ModelEnvironment(TOKIC, random=0)
    run_online(
        env,
        learner,
        model_env.state_of,
        steps,
        exploration.EpsilonSchedule([(0, 1.0), (steps // 2, 0.0)]),
    )
    cycle = planning.policy_cycle(TOKIC, np.array([learner.greedy(s) for s in range(25)]))
    assert cycle.length == 6 and cycle.reward == SIX_CYCLE_REWARD


def _cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "baselines.tabular", *args],
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_realtime_value_iteration_on_the_crawler(tmp_path):
    out = _cli(
        "--task=crawler_walk",
        "--algo=value_iteration",
        "--realtime",
        "--moves=400",
        "--seed=0",
        f"--output_dir={tmp_path}",
    )
    assert out.returncode == 0, out.stderr
    run_dir = tmp_path / "value_iteration" / "crawler_walk" / "seed0"
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["cycle_length"] >= 2 and summary["cycle_learned_reward_m"] > 0.01
    assert summary["displacement_m"] > 0.2  # the greedy policy walks over 100 moves
    lines = (run_dir / "learned_rewards.csv").read_text().splitlines()
    assert lines[0] == "transition,reward_m" and "->" in lines[1]
    learned = json.loads((run_dir / "learned_rewards.json").read_text())["rewards"]
    assert len(learned) == summary["transitions_measured"] == len(lines) - 1
    assert np.load(run_dir / "values_history.npy").shape == (401, 25)


@pytest.mark.parametrize(
    "args, words",
    [
        (["--algo=value_iteration"], "--realtime"),
        (["--stochastic=1.5"], "--stochastic"),
        (["--moves=0"], "--moves"),
        (["--explore_moves=-1"], "--explore_moves"),
    ],
)
def test_crawler_cli_bad_input(tmp_path, args, words):
    out = _cli("--task=crawler_walk", *args, f"--output_dir={tmp_path}")
    assert out.returncode == 2 and words in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1
