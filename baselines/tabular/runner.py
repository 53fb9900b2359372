"""Runs one tabular experiment from its settings and writes its run directory.

Shared by `python -m baselines.tabular` and the experiment scripts: `execute(settings)` runs
a `TabularSettings` (or a dict of settings; missing keys take their defaults) and writes
`<output_dir>/<algo>/<task or model>/<run_name>/` (docs/architecture.md#run-directories).
"""

from __future__ import annotations

import dataclasses
import os
import time

import numpy as np

import cpg_suite
from baselines.tabular import discretize, exploration, learners, model_env, models, planning
from baselines.tabular.online import OnlineResult, balance_metrics, run_online
from baselines.tabular.settings import (  # noqa: F401  (re-exported: the runner's settings)
    ALGOS,
    CRAWLER_EPSILON,
    DEFAULTS,
    PLANNERS,
    TabularSettings,
    default_epsilon,
)
from cpg_suite import crawler
from cpg_suite.runfiles import runs


def make_learner(
    settings: TabularSettings,
    n_states: int,
    n_actions: int,
    rng: np.random.RandomState,
    allowed: np.ndarray | None = None,
    successor=None,
    tie_order=None,
) -> learners.Learner:
    """Builds the learner `settings.algo` with the settings' γ, α, λ, trace, double α.

    Args:
      settings: The run's settings.
      n_states: Number of states.
      n_actions: Number of actions.
      rng: Random generator for exploration and ties.
      allowed: (n_states, n_actions) mask of allowed actions (default: all).
      successor: Known deterministic successor `(s, a) -> s2` (V-learners, planners).
      tie_order: Action order for deterministic tie-breaking.

    Returns:
      The learner.
    """
    algo = settings.algo
    kwargs = dict(rng=rng, allowed=allowed, tie_order=tie_order)
    if algo in learners.REALTIME_PLANNERS:
        return learners.REALTIME_PLANNERS[algo](
            n_states,
            n_actions,
            settings.gamma,
            settings.alpha,
            successor=successor,
            slip=settings.stochastic,
            **kwargs,
        )
    if algo in ("sarsa_lambda", "td_lambda"):
        kwargs.update(lam=settings.lam, trace=settings.trace, double_alpha=settings.double_alpha)
    if algo in ("td0", "td_lambda"):
        kwargs["successor"] = successor
    return learners.LEARNERS[algo](n_states, n_actions, settings.gamma, settings.alpha, **kwargs)


def _cycle_summary(model: models.TabularModel, policy: np.ndarray) -> dict:
    cycle = planning.policy_cycle(model, policy)
    label = model.label
    return {
        "cycle": [list(label(s)) if model.grid_shape else label(s) for s in cycle.states],
        "cycle_length": cycle.length,
        "cycle_reward": cycle.reward,
        "cycle_move_rewards": cycle.rewards,
        "transient": [list(label(s)) if model.grid_shape else label(s) for s in cycle.transient],
    }


def _values_table(model: models.TabularModel, values: np.ndarray) -> np.ndarray:
    return values.reshape(model.grid_shape) if model.grid_shape else values[None, :]


# ---------------------------------------------------------------------------------------
# Planning on a complete model (thesis Alg. 4.1).


def run_planner(run_dir: str, settings: TabularSettings, model: models.TabularModel) -> dict:
    """Value or policy iteration on a complete model; writes values, history and progress.

    Args:
      run_dir: The run directory.
      settings: The run's settings (`algo` is a planner).
      model: The complete model.

    Returns:
      The summary entries: iterations, convergence and the greedy cycle.
    """
    gamma = settings.gamma
    if settings.algo == "value_iteration":
        result = planning.value_iteration(model, gamma, sweeps=settings.sweeps, tol=settings.tol)
    else:
        result = planning.policy_iteration(
            model,
            gamma,
            np.random.RandomState(settings.seed),
            eval_sweeps=settings.eval_sweeps,
            iterations=settings.iterations,
        )
    runs.write_rows_csv(
        os.path.join(run_dir, "progress.csv"), _planner_progress(model, result.history, gamma)
    )
    runs.write_matrix_csv(os.path.join(run_dir, "values.csv"), _values_table(model, result.values))
    runs.save_npy(os.path.join(run_dir, "values_history.npy"), np.array(result.history))
    runs.write_matrix_csv(
        os.path.join(run_dir, "policy.csv"), _values_table(model, result.policy), fmt="%d"
    )
    summary = {"iterations": result.iterations, "converged": result.converged}
    summary.update(_cycle_summary(model, result.policy))
    return summary


def _planner_progress(model: models.TabularModel, history: list, gamma: float) -> list[dict]:
    """One progress row per iteration: value change, start value, greedy cycle length."""
    rows = []
    for k in range(1, len(history)):
        policy_k = planning.greedy_policy(model, history[k], gamma)
        rows.append(
            {
                "iteration": k,
                "max_change": float(np.abs(history[k] - history[k - 1]).max()),
                "start_value": float(history[k][model.start_state]),
                "cycle_length": planning.policy_cycle(model, policy_k).length,
            }
        )
    return rows


# ---------------------------------------------------------------------------------------
# A model-free learner sampling a complete model.


def run_online_on_model(
    run_dir: str, settings: TabularSettings, model: models.TabularModel
) -> dict:
    """A model-free learner on a `ModelEnvironment` sampling the model.

    Args:
      run_dir: The run directory.
      settings: The run's settings (`algo` is a learner).
      model: The model the environment samples.

    Returns:
      The summary entries: steps, return and the greedy cycle.
    """
    seed = settings.seed
    env = model_env.ModelEnvironment(model, random=np.random.RandomState(seed + 1_000_003))
    learner = make_learner(
        settings,
        model.n_states,
        model.n_actions,
        np.random.RandomState(seed),
        allowed=model.allowed,
        successor=model.intended_successor,
        tie_order=model.tie_order,
    )
    schedule = exploration.EpsilonSchedule.parse(default_epsilon(settings))
    result = run_online(env, learner, model_env.state_of, settings.steps, schedule)
    policy = np.array([learner.greedy(s) for s in range(model.n_states)])
    runs.write_rows_csv(
        os.path.join(run_dir, "progress.csv"),
        [
            {
                "step": t + 1,
                "state": int(result.states[t]),
                "action": int(result.actions[t]),
                "reward": float(result.rewards[t]),
            }
            for t in range(len(result.rewards))
        ],
    )
    runs.write_matrix_csv(
        os.path.join(run_dir, "values.csv"), _values_table(model, learner.state_values())
    )
    runs.save_npy(
        os.path.join(run_dir, "table.npy"), learner.v if learner.learns == "V" else learner.q
    )
    summary = {"steps": settings.steps, "return": float(result.rewards.sum())}
    summary.update(_cycle_summary(model, policy))
    return summary


# ---------------------------------------------------------------------------------------
# Real-time learning on the MuJoCo crawler (thesis Sec. 4.1.4).


def learned_reward_table(
    states: np.ndarray, actions: np.ndarray, rewards: np.ndarray, model: models.TabularModel
) -> dict[tuple[tuple[int, int], tuple[int, int]], float]:
    """The latest measured reward of every transition made: {((r, c), (r2, c2)): reward}."""
    table = {}
    for s, a, r in zip(states.tolist(), actions.tolist(), rewards.tolist()):
        if model.allowed[s, a]:
            table[model.label(s), model.label(model.intended_successor(s, a))] = r
    return table


def run_crawler(run_dir: str, settings: TabularSettings) -> dict:
    """Online learning on `crawler_walk` (thesis Sec. 4.1.4 "real-time learning").

    Every algorithm acts in the MuJoCo crawler for `steps` moves; value and policy
    iteration plan on the reward table they measure as they go (Alg. 4.1). With
    `explore_moves` = N the first N moves are random (ε = 1; the study's approach 1b).
    Then the greedy policy is frozen and run for `eval_moves` moves: its displacement is the
    figure of merit; its cycle is read from the grid model from cell (0, 0).

    Args:
      run_dir: The run directory.
      settings: The run's settings (`task` is a crawler task).

    Returns:
      The summary entries (cycle, displacement, RMS error of the values, ...).
    """
    env, grid, to_state = _crawler_env(settings)
    learner, schedule, result, values = _learn_online(env, grid, to_state, settings)
    # Freeze and evaluate the greedy policy from where learning ended.
    policy = np.array([learner.greedy(s) for s in range(grid.n_states)])
    displacement = _run_policy(env, learner, to_state, settings.eval_moves)
    rewards = learned_reward_table(result.states, result.actions, result.rewards, grid)
    learned = models.grid_model(rewards, name="crawler_learned")
    reference = planning.value_iteration(learned, settings.gamma, tol=1e-10).values
    rms = np.sqrt(np.mean((values - reference) ** 2, axis=1))
    _write_crawler_files(run_dir, result, schedule, rms, rewards, values, learner)
    cycle = planning.policy_cycle(learned, policy)  # its reward: the learned move rewards
    return {
        "moves": settings.steps,
        "eval_moves": settings.eval_moves,
        "cycle": [list(grid.label(s)) for s in cycle.states],
        "cycle_length": cycle.length,
        "cycle_joints": _cycle_joints(grid, cycle.states),
        "cycle_learned_reward_m": cycle.reward,
        "displacement_m": displacement,
        "displacement_per_move_m": displacement / max(1, settings.eval_moves),
        "learning_displacement_m": float(result.rewards.sum()),
        "final_rms": float(rms[-1]),
        "transitions_measured": len(rewards),
    }


def _crawler_env(settings: TabularSettings):
    """The crawler environment, its grid model, and the observation → state map."""
    env = cpg_suite.load(
        "crawler_walk",
        task_kwargs={
            "random": settings.seed,
            "time_limit": float("inf"),
            "stochastic": settings.stochastic,
            "backward_penalty": settings.backward_penalty,
        },
    )

    def to_state(obs):
        row, col = (int(v) for v in obs["grid_cell"])
        return crawler.cell_index(row, col)

    return env, models.grid_model({}, name="crawler_grid"), to_state


def _learn_online(env, grid, to_state, settings: TabularSettings):
    """Learns for `steps` moves; returns the learner, ε schedule, trajectory and values."""
    learner = make_learner(
        settings,
        grid.n_states,
        grid.n_actions,
        np.random.RandomState(settings.seed),
        allowed=grid.allowed,
        successor=grid.intended_successor,
        tie_order=grid.tie_order,
    )
    schedule = exploration.EpsilonSchedule.parse(default_epsilon(settings))
    if settings.explore_moves > 0:
        schedule = _ExploreFirst(settings.explore_moves, schedule)
    history = []
    result = run_online(
        env,
        learner,
        to_state,
        settings.steps,
        schedule,
        on_step=lambda: history.append(learner.state_values()),
    )
    values = np.array([learner.state_values()] + history)[: settings.steps + 1]
    return learner, schedule, result, values


def _write_crawler_files(run_dir, result, schedule, rms, rewards, values, learner) -> None:
    """progress.csv (a row per move), the learned reward table, the value history."""
    keyed = {f"{a[0]},{a[1]}->{b[0]},{b[1]}": v for (a, b), v in rewards.items()}
    runs.write_rows_csv(
        os.path.join(run_dir, "progress.csv"),
        [
            {
                "move": t + 1,
                "state": int(result.states[t]),
                "action": int(result.actions[t]),
                "reward_m": float(result.rewards[t]),
                "epsilon": schedule(t),
                "rms": float(rms[t + 1]),
            }
            for t in range(len(result.rewards))
        ],
    )
    runs.write_rows_csv(
        os.path.join(run_dir, "learned_rewards.csv"),
        [{"transition": k, "reward_m": v} for k, v in sorted(keyed.items())],
    )
    runs.write_json(os.path.join(run_dir, "learned_rewards.json"), {"rewards": keyed})
    runs.save_npy(os.path.join(run_dir, "values_history.npy"), values)
    grid_values = learner.state_values().reshape(crawler.GRID, crawler.GRID)
    runs.write_matrix_csv(os.path.join(run_dir, "values.csv"), grid_values)


class _ExploreFirst:
    """ε = 1 for the first `n` moves, then the given schedule (shifted by n)."""

    def __init__(self, n: int, then: exploration.EpsilonSchedule):
        self.n, self.then = n, then

    def __call__(self, step: int) -> float:
        return 1.0 if step < self.n else self.then(step - self.n)


def _cycle_joints(grid: models.TabularModel, states: list[int]) -> int:
    """How many of the two joints the cycle moves (1: rows or columns only, 2: both)."""
    cells = [grid.label(s) for s in states]
    return int(len({r for r, _ in cells}) > 1) + int(len({c for _, c in cells}) > 1)


def _run_policy(env, learner, to_state, moves: int) -> float:
    """Runs the learner's greedy policy (no learning) for `moves` moves; returns the
    displacement, m, from the environment's current state (the moves' displacements, not
    their rewards, which a backward penalty scales)."""
    total = 0.0
    s = to_state(env.task.get_observation(env.physics))
    for _ in range(moves):
        ts = env.step(learner.greedy(s))
        total += env.task.move_displacement(env.physics)
        s = to_state(ts.observation)
    return total


# ---------------------------------------------------------------------------------------
# Online learning on the pole (thesis Alg. 4.2).


def run_online_on_task(run_dir: str, settings: TabularSettings) -> dict:
    """A learner on a discrete cpg_suite task: the crawler, or the pole through a discretizer.

    Args:
      run_dir: The run directory.
      settings: The run's settings (`task` is given).

    Returns:
      The summary entries of `run_crawler` or `run_pole`.
    """
    if settings.on_crawler:
        return run_crawler(run_dir, settings)
    return run_pole(run_dir, settings)


def run_pole(run_dir: str, settings: TabularSettings) -> dict:
    """Online learning on a pole task; writes one progress row per episode and the arrays.

    Args:
      run_dir: The run directory.
      settings: The run's settings (`task` is a pole task).

    Returns:
      The balance metrics of `balance_metrics` (last 5000 steps), physics steps, return.
    """
    env = _pole_env(settings)
    n_actions = env.action_spec().num_values
    to_state = discretize.pole_discretizer(discretize.parse_bins(settings.bins))
    learner = make_learner(
        settings, to_state.n_states, n_actions, np.random.RandomState(settings.seed)
    )
    schedule = exploration.EpsilonSchedule.parse(default_epsilon(settings))
    fields = ["episode", "start_step", "end_step", "length", "fell", "return"]
    with runs.ProgressCSV(os.path.join(run_dir, "progress.csv"), fields) as progress:
        result = run_online(
            env,
            learner,
            to_state,
            settings.steps,
            schedule,
            record=("angle", "angular_velocity"),
            on_episode=lambda ep: progress.append(
                {
                    "episode": ep.index,
                    "start_step": ep.start_step,
                    "end_step": ep.end_step,
                    "length": ep.length,
                    "fell": int(ep.fell),
                    "return": ep.episode_return,
                }
            ),
        )
    _write_pole_files(run_dir, result, learner.q.reshape(to_state.bins + (n_actions,)))
    summary = balance_metrics(result, last=5000)
    summary["physics_steps"] = settings.steps * int(
        round(env.control_timestep() / env.physics.model.opt.timestep)
    )
    summary["return"] = float(result.rewards.sum())
    return summary


def _pole_env(settings: TabularSettings):
    """The pole environment without a time limit, with the settings' actions, reward, force."""
    task_kwargs = {"random": settings.seed, "time_limit": float("inf")}
    if settings.task.startswith("pole"):
        task_kwargs.update(num_actions=settings.actions, reward=settings.reward)
        if settings.force is not None:
            task_kwargs["force"] = settings.force
    return cpg_suite.load(settings.task, task_kwargs=task_kwargs)


def _write_pole_files(run_dir: str, result: OnlineResult, q_table: np.ndarray) -> None:
    """angles.npy (float32), actions.npy (int8), q_table.npy (bins × actions)."""
    runs.save_npy(
        os.path.join(run_dir, "angles.npy"), result.observations["angle"].astype(np.float32)
    )
    runs.save_npy(os.path.join(run_dir, "actions.npy"), result.actions.astype(np.int8))
    runs.save_npy(os.path.join(run_dir, "q_table.npy"), q_table)


# ---------------------------------------------------------------------------------------
# One run, from settings to run directory.


def execute(settings: TabularSettings | dict, resume: bool = False) -> tuple[str, dict]:
    """Runs one experiment and writes its run directory.

    Args:
      settings: The settings, or a dict of them (missing keys take their defaults);
        validated either way.
      resume: If the run directory already holds a `summary.json`, return it without
        running again (a finished run is never repeated).

    Returns:
      `(run_dir, summary)`.

    Raises:
      runs.RunDirectoryExists: If the run directory exists and neither `overwrite` nor
        `resume` applies.
      ValueError: On invalid settings.
    """
    if isinstance(settings, dict):
        settings = TabularSettings(**settings)
    summary_path = os.path.join(
        settings.output_dir,
        settings.algo,
        settings.target,
        settings.run_name_or_default(),
        "summary.json",
    )
    if resume and os.path.exists(summary_path):
        return os.path.dirname(summary_path), runs.read_json(summary_path)
    run_dir = runs.run_directory(
        settings.output_dir,
        settings.algo,
        settings.target,
        settings.run_name_or_default(),
        overwrite=settings.overwrite or resume,
    )
    runs.write_config(run_dir, settings, command=rerun_command(settings))
    start = time.perf_counter()
    summary = {
        "method": settings.algo,
        "task": settings.target,
        "seed": settings.seed,
        **_run(run_dir, settings),
        "wall_s": time.perf_counter() - start,
    }
    runs.write_json(os.path.join(run_dir, "summary.json"), summary)
    return run_dir, summary


def _run(run_dir: str, settings: TabularSettings) -> dict:
    """Dispatches to the planner or learner the settings name; returns their summary."""
    if settings.model is None:
        return run_online_on_task(run_dir, settings)
    model = models.MODELS[settings.model](slip=settings.slip)
    if settings.algo in PLANNERS:
        return run_planner(run_dir, settings, model)
    return run_online_on_model(run_dir, settings, model)


def rerun_command(settings: TabularSettings) -> str:
    """The `python -m baselines.tabular ...` line that re-runs exactly this run.

    Every setting is spelled out (None values left out) with the run name made explicit;
    `overwrite` is left out: it says how to treat an existing directory, not what to run.

    Args:
      settings: The run's settings.

    Returns:
      The command line (see `runs.command_line`).
    """
    flags_of_run = dataclasses.asdict(settings)
    del flags_of_run["overwrite"]
    flags_of_run["run_name"] = settings.run_name_or_default()
    return runs.command_line("baselines.tabular", flags_of_run)


def execute_all(
    settings: list[TabularSettings],
    resume: bool = False,
    backend: str = "local",
    ray_address: str | None = None,
) -> list[tuple[str, dict]]:
    """`execute` for every settings, in this process or as Ray tasks (the seed sweeps of
    the experiment scripts); the results in order.

    On Ray, the driver checks every run directory first (one that exists is an error
    unless `resume`), then each task runs with `resume=True`, so a task that runs again
    after its worker died redoes its unfinished run.

    Raises:
      runs.RunDirectoryExists: If a run exists and neither `overwrite` nor `resume` applies.
      ray_backend.ClusterUnreachable: On Ray, if no cluster answers.
    """
    if backend == "local":
        return [execute(s, resume=resume) for s in settings]
    from cpg_suite.evaluation import ray_backend
    from cpg_suite.harness import ray_tasks

    with ray_backend.connected("ray", ray_address):
        for s in settings:
            path = os.path.join(s.output_dir, s.algo, s.target, s.run_name_or_default())
            if os.path.isdir(path) and os.listdir(path) and not (resume or s.overwrite):
                raise runs.RunDirectoryExists(
                    f"run directory {path} already exists; pass --overwrite to replace it"
                )
        return ray_tasks.map_tasks(_execute_resumed, settings)


def _execute_resumed(settings: TabularSettings) -> tuple[str, dict]:
    return execute(settings, resume=True)
