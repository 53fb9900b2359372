"""Runs one tabular experiment from a settings dict and writes its run directory.

Shared by `python -m baselines.tabular` and the experiment scripts. `DEFAULTS` lists every
setting; `execute(settings)` fills in the defaults, runs, and writes
`<output_dir>/<algo>/<task or model>/<run_name>/` (docs/architecture.md#run-directories).
"""

from __future__ import annotations

import dataclasses
import os
import time

import numpy as np

import cpg_suite
from baselines import runs
from baselines.tabular import discretize, exploration, learners, model_env, models, planning
from baselines.tabular.online import balance_metrics, run_online
from cpg_suite.crawler import GRID

PLANNERS = ("value_iteration", "policy_iteration")
ALGOS = PLANNERS + tuple(learners.LEARNERS)


@dataclasses.dataclass(frozen=True)
class TabularSettings:
    """Every setting of a tabular run (the flags of `python -m baselines.tabular`).

    Exactly one of `task` (a discrete task id) and `model` (a tabular model) is given; see
    the CLI's flag help for each field. Validated on construction.
    """

    task: str | None = None
    model: str | None = None
    algo: str = "q_learning"
    gamma: float = 0.9
    alpha: float = 0.1
    lam: float = 0.9
    trace: str = "accumulating"
    double_alpha: bool = False
    epsilon: str | None = None
    steps: int = 20000
    sweeps: int | None = None
    iterations: int | None = None
    eval_sweeps: int | None = None
    tol: float = 1e-9
    slip: float = 0.0
    bins: str = "20x20"
    force: float | None = None
    actions: int = 3
    reward: str = "angle"
    seed: int = 0
    output_dir: str = "runs"
    run_name: str | None = None
    overwrite: bool = False
    realtime: bool = False
    explore_moves: int = 0
    stochastic: float = 0.0
    eval_moves: int = 100

    def __post_init__(self):
        _check_target(self)
        _check_ranges(self)
        try:
            if self.epsilon is not None:
                exploration.EpsilonSchedule.parse(self.epsilon)
            bins = discretize.parse_bins(self.bins)
        except ValueError as e:
            raise ValueError(str(e)) from None
        require(len(bins) in (1, 2), f"--bins takes 1 or 2 counts, got {self.bins!r}")


def require(condition: bool, message: str) -> None:
    if not condition:
        raise ValueError(message)


def _check_target(s: TabularSettings) -> None:
    """The task or model, and which algorithms can run on it."""
    require(
        (s.task is None) != (s.model is None),
        f"give exactly one of --task (a discrete task) or --model ({', '.join(models.MODELS)})",
    )
    require(s.algo in ALGOS, f"unknown --algo {s.algo!r}; valid: {', '.join(ALGOS)}")
    if s.model is not None:
        require(
            s.model in models.MODELS,
            f"unknown --model {s.model!r}; valid: {', '.join(models.MODELS)}",
        )
        return
    cpg_suite.split_task_id(s.task)  # ValueError listing the valid ids
    crawler = s.task.startswith("crawler")
    require(
        s.algo not in PLANNERS or (crawler and (s.realtime or s.explore_moves > 0)),
        f"{s.algo} needs a complete model (--model=tokic), or on the crawler a model "
        "measured online (--realtime or --explore_moves=N)",
    )
    require(
        s.algo not in ("td0", "td_lambda") or not s.task.startswith("pole"),
        f"{s.algo} learns state values and acts through a known successor "
        "function, which the pole does not have; use q_learning, sarsa or sarsa_lambda",
    )
    require(
        hasattr(cpg_suite.load(s.task).action_spec(), "num_values"),
        f"{s.task} has continuous actions; tabular methods need a discrete "
        "task such as pole_balance",
    )
    require(s.task.startswith(("pole", "crawler")), f"no discretizer is defined for {s.task}")


def _check_ranges(s: TabularSettings) -> None:
    """Numeric ranges of the settings."""
    for name in ("gamma", "alpha", "lam"):
        value = getattr(s, name)
        require(0.0 <= value <= 1.0, f"--{name} must lie in [0, 1], got {value}")
    require(0.0 <= s.slip < 1.0, f"--slip must lie in [0, 1), got {s.slip}")
    require(s.steps >= 1, f"--steps must be ≥ 1, got {s.steps}")
    for name, low in (("sweeps", 0), ("iterations", 1), ("eval_sweeps", 1)):
        value = getattr(s, name)
        require(value is None or value >= low, f"--{name} must be ≥ {low}, got {value}")
    require(s.tol > 0, f"--tol must be > 0, got {s.tol}")
    require(s.seed >= 0, f"--seed must be ≥ 0, got {s.seed}")
    require(s.actions in (2, 3), f"--actions must be 2 or 3, got {s.actions}")
    require(
        s.force is None or (np.isfinite(s.force) and s.force > 0),
        f"--force must be a positive number of newtons, got {s.force}",
    )
    require(s.explore_moves >= 0, f"--explore_moves must be ≥ 0, got {s.explore_moves}")
    require(0.0 <= s.stochastic < 1.0, f"--stochastic must lie in [0, 1), got {s.stochastic}")
    require(s.eval_moves >= 0, f"--eval_moves must be ≥ 0, got {s.eval_moves}")
    require(
        not (s.algo == "policy_iteration" and s.gamma >= 1.0 and s.model is None),
        "policy_iteration in real time needs --gamma < 1",
    )


# Every setting of a tabular run and its default (the fields of `TabularSettings`).
DEFAULTS = {f.name: f.default for f in dataclasses.fields(TabularSettings)}

# The study's real-time ε schedule (thesis Sec. 4.1.7): 0.9 for 100 moves, 0 at move 300.
CRAWLER_EPSILON = "0:0.9,100:0.9,300:0"


def default_epsilon(settings: dict) -> str:
    """ε when none is given: the study's schedule on the crawler, 0 elsewhere."""
    if settings.get("epsilon") is not None:
        return settings["epsilon"]
    return CRAWLER_EPSILON if (settings.get("task") or "").startswith("crawler") else "0"


def make_learner(
    settings: dict,
    n_states: int,
    n_actions: int,
    rng: np.random.RandomState,
    allowed: np.ndarray | None = None,
    successor=None,
    tie_order=None,
) -> learners.Learner:
    """Builds the learner `settings["algo"]` with the settings' γ, α, λ, trace, double α."""
    algo = settings["algo"]
    kwargs = dict(rng=rng, allowed=allowed, tie_order=tie_order)
    if algo in learners.REALTIME_PLANNERS:
        return learners.REALTIME_PLANNERS[algo](
            n_states,
            n_actions,
            settings["gamma"],
            settings["alpha"],
            successor=successor,
            slip=settings.get("stochastic", 0.0),
            **kwargs,
        )
    if algo in ("sarsa_lambda", "td_lambda"):
        kwargs.update(
            lam=settings["lam"], trace=settings["trace"], double_alpha=settings["double_alpha"]
        )
    if algo in ("td0", "td_lambda"):
        kwargs["successor"] = successor
    return learners.LEARNERS[algo](
        n_states, n_actions, settings["gamma"], settings["alpha"], **kwargs
    )


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


def run_planner(run_dir: str, settings: dict, model: models.TabularModel) -> dict:
    """Value or policy iteration on a complete model; writes values, history and progress."""
    gamma = settings["gamma"]
    if settings["algo"] == "value_iteration":
        result = planning.value_iteration(
            model, gamma, sweeps=settings["sweeps"], tol=settings["tol"]
        )
    else:
        result = planning.policy_iteration(
            model,
            gamma,
            np.random.RandomState(settings["seed"]),
            eval_sweeps=settings["eval_sweeps"],
            iterations=settings["iterations"],
        )
    rows = []
    for k in range(1, len(result.history)):
        policy_k = planning.greedy_policy(model, result.history[k], gamma)
        rows.append(
            {
                "iteration": k,
                "max_change": float(np.abs(result.history[k] - result.history[k - 1]).max()),
                "start_value": float(result.history[k][model.start_state]),
                "cycle_length": planning.policy_cycle(model, policy_k).length,
            }
        )
    runs.write_rows_csv(os.path.join(run_dir, "progress.csv"), rows)
    runs.write_matrix_csv(os.path.join(run_dir, "values.csv"), _values_table(model, result.values))
    runs.save_npy(os.path.join(run_dir, "values_history.npy"), np.array(result.history))
    runs.write_matrix_csv(
        os.path.join(run_dir, "policy.csv"), _values_table(model, result.policy), fmt="%d"
    )
    summary = {"iterations": result.iterations, "converged": result.converged}
    summary.update(_cycle_summary(model, result.policy))
    return summary


def run_online_on_model(run_dir: str, settings: dict, model: models.TabularModel) -> dict:
    """A model-free learner on a `ModelEnvironment` sampling the model."""
    seed = settings["seed"]
    rng = np.random.RandomState(seed)
    env = model_env.ModelEnvironment(model, random=np.random.RandomState(seed + 1_000_003))
    learner = make_learner(
        settings,
        model.n_states,
        model.n_actions,
        rng,
        allowed=model.allowed,
        successor=model.intended_successor,
        tie_order=model.tie_order,
    )
    schedule = exploration.EpsilonSchedule.parse(default_epsilon(settings))
    result = run_online(env, learner, model_env.state_of, settings["steps"], schedule)
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
    summary = {"steps": settings["steps"], "return": float(result.rewards.sum())}
    summary.update(_cycle_summary(model, policy))
    return summary


def learned_reward_table(
    states: np.ndarray, actions: np.ndarray, rewards: np.ndarray, model: models.TabularModel
) -> dict[tuple[tuple[int, int], tuple[int, int]], float]:
    """The latest measured reward of every transition made: {((r, c), (r2, c2)): reward}."""
    table = {}
    for s, a, r in zip(states.tolist(), actions.tolist(), rewards.tolist()):
        if model.allowed[s, a]:
            table[model.label(s), model.label(model.intended_successor(s, a))] = r
    return table


def run_crawler(run_dir: str, settings: dict) -> dict:
    """Online learning on `crawler_walk` (thesis Sec. 4.1.4 "real-time learning").

    Every algorithm acts in the MuJoCo crawler for `steps` moves; value and policy
    iteration plan on the reward table they measure as they go (Alg. 4.1). With
    `explore_moves` = N the first N moves are random (ε = 1; the study's approach 1b).
    Then the greedy policy is frozen and run for `eval_moves` moves: its displacement is the
    figure of merit; its cycle is read from the grid model from cell (0, 0).
    """
    env, grid, to_state = _crawler_env(settings)
    learner, schedule, result, values = _learn_online(env, grid, to_state, settings)
    # Freeze and evaluate the greedy policy from where learning ended.
    policy = np.array([learner.greedy(s) for s in range(grid.n_states)])
    displacement = _run_policy(env, learner, to_state, settings["eval_moves"])
    rewards = learned_reward_table(result.states, result.actions, result.rewards, grid)
    learned = models.grid_model(rewards, name="crawler_learned")
    reference = planning.value_iteration(learned, settings["gamma"], tol=1e-10).values
    rms = np.sqrt(np.mean((values - reference) ** 2, axis=1))
    _write_crawler_files(run_dir, result, schedule, rms, rewards, values, learner)
    cycle = planning.policy_cycle(learned, policy)  # its reward: the learned move rewards
    return {
        "moves": settings["steps"],
        "eval_moves": settings["eval_moves"],
        "cycle": [list(grid.label(s)) for s in cycle.states],
        "cycle_length": cycle.length,
        "cycle_joints": _cycle_joints(grid, cycle.states),
        "cycle_learned_reward_m": cycle.reward,
        "displacement_m": displacement,
        "displacement_per_move_m": displacement / max(1, settings["eval_moves"]),
        "learning_displacement_m": float(result.rewards.sum()),
        "final_rms": float(rms[-1]),
        "transitions_measured": len(rewards),
    }


def _crawler_env(settings: dict):
    """The crawler environment, its grid model, and the observation → state map."""
    from cpg_suite import crawler

    env = cpg_suite.load(
        "crawler_walk",
        task_kwargs={
            "random": settings["seed"],
            "time_limit": float("inf"),
            "stochastic": settings["stochastic"],
        },
    )

    def to_state(obs):
        row, col = (int(v) for v in obs["grid_cell"])
        return crawler.cell_index(row, col)

    return env, models.grid_model({}, name="crawler_grid"), to_state


def _learn_online(env, grid, to_state, settings: dict):
    """Learns for `steps` moves; returns the learner, ε schedule, trajectory and values."""
    learner = make_learner(
        settings,
        grid.n_states,
        grid.n_actions,
        np.random.RandomState(settings["seed"]),
        allowed=grid.allowed,
        successor=grid.intended_successor,
        tie_order=grid.tie_order,
    )
    schedule = exploration.EpsilonSchedule.parse(default_epsilon(settings))
    if settings["explore_moves"] > 0:
        schedule = _ExploreFirst(settings["explore_moves"], schedule)
    history = []
    result = run_online(
        env,
        learner,
        to_state,
        settings["steps"],
        schedule,
        on_step=lambda: history.append(learner.state_values()),
    )
    values = np.array([learner.state_values()] + history)[: settings["steps"] + 1]
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
    grid_values = learner.state_values().reshape(GRID, GRID)
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
    displacement, m, from the environment's current state."""
    total = 0.0
    s = to_state(env.task.get_observation(env.physics))
    for _ in range(moves):
        ts = env.step(learner.greedy(s))
        total += float(ts.reward)
        s = to_state(ts.observation)
    return total


def run_online_on_task(run_dir: str, settings: dict) -> dict:
    """A learner on a discrete cpg_suite task (the pole through a discretizer)."""
    if settings["task"].startswith("crawler"):
        return run_crawler(run_dir, settings)
    seed = settings["seed"]
    task_kwargs = {"random": seed, "time_limit": float("inf")}
    if settings["task"].startswith("pole"):
        task_kwargs.update(num_actions=settings["actions"], reward=settings["reward"])
        if settings["force"] is not None:
            task_kwargs["force"] = settings["force"]
    env = cpg_suite.load(settings["task"], task_kwargs=task_kwargs)
    spec = env.action_spec()
    to_state = discretize.pole_discretizer(discretize.parse_bins(settings["bins"]))
    learner = make_learner(
        settings, to_state.n_states, spec.num_values, np.random.RandomState(seed)
    )
    schedule = exploration.EpsilonSchedule.parse(default_epsilon(settings))
    fields = ["episode", "start_step", "end_step", "length", "fell", "return"]
    with runs.ProgressCSV(os.path.join(run_dir, "progress.csv"), fields) as progress:
        result = run_online(
            env,
            learner,
            to_state,
            settings["steps"],
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
    runs.save_npy(
        os.path.join(run_dir, "angles.npy"), result.observations["angle"].astype(np.float32)
    )
    runs.save_npy(os.path.join(run_dir, "actions.npy"), result.actions.astype(np.int8))
    runs.save_npy(
        os.path.join(run_dir, "q_table.npy"), learner.q.reshape(to_state.bins + (spec.num_values,))
    )
    summary = balance_metrics(result, last=5000)
    summary["physics_steps"] = settings["steps"] * int(
        round(env.control_timestep() / env.physics.model.opt.timestep)
    )
    summary["return"] = float(result.rewards.sum())
    return summary


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
    settings = dataclasses.asdict(settings)
    task = settings["task"] or settings["model"]
    run_name = settings["run_name"] or f"seed{settings['seed']}"
    summary_path = os.path.join(
        settings["output_dir"], settings["algo"], task, run_name, "summary.json"
    )
    if resume and os.path.exists(summary_path):
        return os.path.dirname(summary_path), runs.read_json(summary_path)
    run_dir = runs.run_directory(
        settings["output_dir"],
        settings["algo"],
        task,
        run_name,
        overwrite=settings["overwrite"] or resume,
    )
    flags_of_run = {k: v for k, v in settings.items() if k not in ("overwrite",)}
    runs.write_config(
        run_dir,
        settings,
        runs.command_line("baselines.tabular", {**flags_of_run, "run_name": run_name}),
    )
    start = time.perf_counter()
    if settings["model"] is not None:
        model = models.MODELS[settings["model"]](slip=settings["slip"])
        if settings["algo"] in PLANNERS:
            summary = run_planner(run_dir, settings, model)
        else:
            summary = run_online_on_model(run_dir, settings, model)
    else:
        summary = run_online_on_task(run_dir, settings)
    summary = {
        "method": settings["algo"],
        "task": task,
        "seed": settings["seed"],
        **summary,
        "wall_s": time.perf_counter() - start,
    }
    runs.write_json(os.path.join(run_dir, "summary.json"), summary)
    return run_dir, summary
