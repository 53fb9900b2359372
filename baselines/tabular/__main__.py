r"""Tabular RL baselines of the study (thesis Ch. 4) from the command line.

Planning on a complete model (thesis Alg. 4.1, Tables A.2/A.3):

  python -m baselines.tabular --model=tokic --algo=value_iteration --gamma=0.9 \
      --sweeps=2 --output_dir=runs

Online learning on a discrete task (thesis Alg. 4.2, Sec. 4.2):

  python -m baselines.tabular --task=pole_balance --algo=q_learning --steps=20000 \
      --alpha=0.01 --gamma=0.9 --bins=20x20 --seed=0 --output_dir=runs

Writes `<output_dir>/<algo>/<task or model>/<run_name>/` (DESIGN Sec. 6).
"""

from __future__ import annotations

import os
import time

import numpy as np
from absl import flags

import cpg_suite
from baselines import cli, runs
from baselines.tabular import discretize, exploration, learners, model_env, models, planning
from baselines.tabular.online import balance_metrics, run_online

PLANNERS = ("value_iteration", "policy_iteration")
ALGOS = PLANNERS + tuple(learners.LEARNERS)

_TASK = flags.DEFINE_string("task", None, "Discrete task id, e.g. pole_balance.")
_MODEL = flags.DEFINE_string("model", None, f"Tabular model: {', '.join(models.MODELS)}.")
_ALGO = flags.DEFINE_string("algo", "q_learning", f"One of: {', '.join(ALGOS)}.")
_GAMMA = flags.DEFINE_float("gamma", 0.9, "Discount factor γ in [0, 1].")
_ALPHA = flags.DEFINE_float("alpha", 0.1, "Learning rate α in [0, 1] (TD learners).")
_LAMBDA = flags.DEFINE_float("lam", 0.9, "Trace decay λ in [0, 1] (sarsa_lambda, td_lambda).")
_TRACE = flags.DEFINE_enum("trace", "accumulating", list(learners.TRACES), "Trace type.")
_DOUBLE_ALPHA = flags.DEFINE_bool(
    "double_alpha", False, "Use the thesis' printed δ = α[...] (α applied twice).")
_EPSILON = flags.DEFINE_string(
    "epsilon", "0", "ε: a constant like 0.1, or step:value points like 0:0.9,100:0.9,300:0.")
_STEPS = flags.DEFINE_integer("steps", 20000, "Online learning steps (iterations).")
_SWEEPS = flags.DEFINE_integer(
    "sweeps", None, "value_iteration: exactly this many sweeps (default: until converged).")
_ITERATIONS = flags.DEFINE_integer(
    "iterations", None, "policy_iteration: exactly this many iterations (default: until stable).")
_EVAL_SWEEPS = flags.DEFINE_integer(
    "eval_sweeps", None, "policy_iteration: sweeps per evaluation (default: exact solve).")
_TOL = flags.DEFINE_float("tol", 1e-9, "value_iteration convergence tolerance.")
_SLIP = flags.DEFINE_float("slip", 0.0, "Model: probability that a move does not happen.")
_BINS = flags.DEFINE_string("bins", "20x20", "Pole: ANGLExVELOCITY bins (20x20) or ANGLE (100).")
_FORCE = flags.DEFINE_float("force", None, "Pole: push force, N (task default 0.5).")
_ACTIONS = flags.DEFINE_integer("actions", 3, "Pole: 3 for {-F, 0, +F}, 2 for {-F, +F}.")
_REWARD = flags.DEFINE_enum("reward", "angle", ["angle", "approach"], "Pole reward variant.")
_SEED = flags.DEFINE_integer("seed", 0, "Random seed (initial states, exploration, ties).")
_OUTPUT_DIR = flags.DEFINE_string("output_dir", "runs", "Root of the output tree.")
_RUN_NAME = flags.DEFINE_string("run_name", None, "Run directory name (default seed<N>).")
_OVERWRITE = flags.DEFINE_bool("overwrite", False, "Replace an existing run directory.")


def _validate() -> dict:
    """Checks the flags; returns them as a settings dict."""
    cli.check((_TASK.value is None) != (_MODEL.value is None),
              "give exactly one of --task (a discrete task) or --model "
              f"({', '.join(models.MODELS)})")
    cli.check(_ALGO.value in ALGOS,
              f"unknown --algo {_ALGO.value!r}; valid: {', '.join(ALGOS)}")
    if _MODEL.value is not None:
        cli.check(_MODEL.value in models.MODELS,
                  f"unknown --model {_MODEL.value!r}; valid: {', '.join(models.MODELS)}")
    else:
        try:
            cpg_suite.split_task_id(_TASK.value)
        except ValueError as e:
            raise cli.UsageError(str(e)) from None
        cli.check(_ALGO.value not in PLANNERS,
                  f"{_ALGO.value} needs a complete model (--model=tokic); "
                  f"the task {_TASK.value} has none (use q_learning, sarsa or sarsa_lambda)")
        cli.check(_ALGO.value not in ("td0", "td_lambda") or not _TASK.value.startswith("pole"),
                  f"{_ALGO.value} learns state values and acts through a known successor "
                  "function, which the pole does not have; use q_learning, sarsa or sarsa_lambda")
        cli.check(hasattr(cpg_suite.load(_TASK.value).action_spec(), "num_values"),
                  f"{_TASK.value} has continuous actions; tabular methods need a discrete "
                  "task such as pole_balance")
        cli.check(_TASK.value.startswith("pole"), f"no discretizer is defined for {_TASK.value}")
    for name, flag in (("gamma", _GAMMA), ("alpha", _ALPHA), ("lam", _LAMBDA)):
        cli.check(0.0 <= flag.value <= 1.0, f"--{name} must lie in [0, 1], got {flag.value}")
    cli.check(0.0 <= _SLIP.value < 1.0, f"--slip must lie in [0, 1), got {_SLIP.value}")
    cli.check(_STEPS.value >= 1, f"--steps must be ≥ 1, got {_STEPS.value}")
    cli.check(_SWEEPS.value is None or _SWEEPS.value >= 0,
              f"--sweeps must be ≥ 0, got {_SWEEPS.value}")
    cli.check(_ITERATIONS.value is None or _ITERATIONS.value >= 1,
              f"--iterations must be ≥ 1, got {_ITERATIONS.value}")
    cli.check(_EVAL_SWEEPS.value is None or _EVAL_SWEEPS.value >= 1,
              f"--eval_sweeps must be ≥ 1, got {_EVAL_SWEEPS.value}")
    cli.check(_TOL.value > 0, f"--tol must be > 0, got {_TOL.value}")
    cli.check(_SEED.value >= 0, f"--seed must be ≥ 0, got {_SEED.value}")
    cli.check(_ACTIONS.value in (2, 3), f"--actions must be 2 or 3, got {_ACTIONS.value}")
    cli.check(_FORCE.value is None or (np.isfinite(_FORCE.value) and _FORCE.value > 0),
              f"--force must be a positive number of newtons, got {_FORCE.value}")
    try:
        exploration.EpsilonSchedule.parse(_EPSILON.value)
        bins = discretize.parse_bins(_BINS.value)
    except ValueError as e:
        raise cli.UsageError(str(e)) from None
    cli.check(len(bins) in (1, 2), f"--bins takes 1 or 2 counts, got {_BINS.value!r}")
    return {name: flags.FLAGS[name].value for name in (
        "task", "model", "algo", "gamma", "alpha", "lam", "trace", "double_alpha", "epsilon",
        "steps", "sweeps", "iterations", "eval_sweeps", "tol", "slip", "bins", "force",
        "actions", "reward", "seed", "output_dir", "run_name", "overwrite")}


def make_learner(algo: str, n_states: int, n_actions: int, rng, allowed=None,
                 successor=None, tie_order=None, random_ties=True,
                 gamma=None, alpha=None, lam=None, trace=None, double_alpha=None):
    """Builds the learner `algo` from the flags (explicit arguments override them)."""
    kwargs = dict(rng=rng, allowed=allowed, tie_order=tie_order, random_ties=random_ties)
    if algo in ("sarsa_lambda", "td_lambda"):
        kwargs.update(lam=_LAMBDA.value if lam is None else lam,
                      trace=_TRACE.value if trace is None else trace,
                      double_alpha=_DOUBLE_ALPHA.value if double_alpha is None else double_alpha)
    if algo in ("td0", "td_lambda"):
        kwargs["successor"] = successor
    return learners.LEARNERS[algo](
        n_states, n_actions, _GAMMA.value if gamma is None else gamma,
        _ALPHA.value if alpha is None else alpha, **kwargs)


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
        result = planning.value_iteration(model, gamma, sweeps=settings["sweeps"],
                                          tol=settings["tol"])
    else:
        result = planning.policy_iteration(
            model, gamma, np.random.RandomState(settings["seed"]),
            eval_sweeps=settings["eval_sweeps"], iterations=settings["iterations"])
    rows = []
    for k in range(1, len(result.history)):
        policy_k = planning.greedy_policy(model, result.history[k], gamma)
        rows.append({"iteration": k,
                     "max_change": float(np.abs(result.history[k] - result.history[k - 1]).max()),
                     "start_value": float(result.history[k][model.start_state]),
                     "cycle_length": planning.policy_cycle(model, policy_k).length})
    runs.write_rows_csv(os.path.join(run_dir, "progress.csv"), rows)
    runs.write_matrix_csv(os.path.join(run_dir, "values.csv"), _values_table(model, result.values))
    runs.save_npy(os.path.join(run_dir, "values_history.npy"), np.array(result.history))
    runs.write_matrix_csv(os.path.join(run_dir, "policy.csv"),
                          _values_table(model, result.policy), fmt="%d")
    summary = {"iterations": result.iterations, "converged": result.converged}
    summary.update(_cycle_summary(model, result.policy))
    return summary


def run_online_on_model(run_dir: str, settings: dict, model: models.TabularModel) -> dict:
    """A model-free learner on a `ModelEnvironment` sampling the model."""
    seed = settings["seed"]
    rng = np.random.RandomState(seed)
    env = model_env.ModelEnvironment(model, random=np.random.RandomState(seed + 1_000_003))
    learner = make_learner(settings["algo"], model.n_states, model.n_actions, rng,
                           allowed=model.allowed, successor=model.intended_successor,
                           tie_order=model.tie_order)
    schedule = exploration.EpsilonSchedule.parse(settings["epsilon"])
    result = run_online(env, learner, model_env.state_of, settings["steps"], schedule)
    policy = np.array([learner.greedy(s) for s in range(model.n_states)])
    runs.write_rows_csv(os.path.join(run_dir, "progress.csv"), [
        {"step": t + 1, "state": int(result.states[t]), "action": int(result.actions[t]),
         "reward": float(result.rewards[t])} for t in range(len(result.rewards))])
    runs.write_matrix_csv(os.path.join(run_dir, "values.csv"),
                          _values_table(model, learner.state_values()))
    runs.save_npy(os.path.join(run_dir, "table.npy"),
                  learner.v if learner.learns == "V" else learner.q)
    summary = {"steps": settings["steps"], "return": float(result.rewards.sum())}
    summary.update(_cycle_summary(model, policy))
    return summary


def run_online_on_task(run_dir: str, settings: dict) -> dict:
    """A model-free learner on a discrete cpg_suite task through a discretizer."""
    seed = settings["seed"]
    task_kwargs = {"random": seed, "time_limit": float("inf")}
    if settings["task"].startswith("pole"):
        task_kwargs.update(num_actions=settings["actions"], reward=settings["reward"])
        if settings["force"] is not None:
            task_kwargs["force"] = settings["force"]
    env = cpg_suite.load(settings["task"], task_kwargs=task_kwargs)
    spec = env.action_spec()
    to_state = discretize.pole_discretizer(discretize.parse_bins(settings["bins"]))
    learner = make_learner(settings["algo"], to_state.n_states, spec.num_values,
                           np.random.RandomState(seed))
    schedule = exploration.EpsilonSchedule.parse(settings["epsilon"])
    fields = ["episode", "start_step", "end_step", "length", "fell", "return"]
    with runs.ProgressCSV(os.path.join(run_dir, "progress.csv"), fields) as progress:
        result = run_online(env, learner, to_state, settings["steps"], schedule,
                            record=("angle", "angular_velocity"),
                            on_episode=lambda ep: progress.append({
                                "episode": ep.index, "start_step": ep.start_step,
                                "end_step": ep.end_step, "length": ep.length,
                                "fell": int(ep.fell), "return": ep.episode_return}))
    runs.save_npy(os.path.join(run_dir, "angles.npy"),
                  result.observations["angle"].astype(np.float32))
    runs.save_npy(os.path.join(run_dir, "actions.npy"), result.actions.astype(np.int8))
    runs.save_npy(os.path.join(run_dir, "q_table.npy"),
                  learner.q.reshape(to_state.bins + (spec.num_values,)))
    summary = balance_metrics(result, last=5000)
    summary["physics_steps"] = settings["steps"] * int(round(
        env.control_timestep() / env.physics.model.opt.timestep))
    summary["return"] = float(result.rewards.sum())
    return summary


def main(argv):
    del argv
    settings = _validate()
    task = settings["task"] or settings["model"]
    run_name = settings["run_name"] or f"seed{settings['seed']}"
    try:
        run_dir = runs.run_directory(settings["output_dir"], settings["algo"], task, run_name,
                                     overwrite=settings["overwrite"])
    except runs.RunDirectoryExists as e:
        raise cli.UsageError(str(e)) from None
    runs.write_config(run_dir, settings)
    start = time.perf_counter()
    if settings["model"] is not None:
        model = models.MODELS[settings["model"]](slip=settings["slip"])
        if settings["algo"] in PLANNERS:
            summary = run_planner(run_dir, settings, model)
        else:
            summary = run_online_on_model(run_dir, settings, model)
    else:
        summary = run_online_on_task(run_dir, settings)
    summary = {"method": settings["algo"], "task": task, "seed": settings["seed"], **summary,
               "wall_s": time.perf_counter() - start}
    runs.write_json(os.path.join(run_dir, "summary.json"), summary)
    shown = {k: v for k, v in summary.items() if not isinstance(v, list) or k == "cycle"}
    print(f"{run_dir}: {shown}")


if __name__ == "__main__":
    cli.run(main)
