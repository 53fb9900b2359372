r"""Tabular RL baselines of the study (thesis Ch. 4) from the command line.

Planning on a complete model (thesis Alg. 4.1, Tables A.2/A.3):

  python -m baselines.tabular --model=tokic --algo=value_iteration --gamma=0.9 \
      --sweeps=2 --output_dir=runs

Online learning on a discrete task (thesis Alg. 4.2, Sec. 4.2):

  python -m baselines.tabular --task=pole_balance --algo=q_learning --steps=20000 \
      --alpha=0.01 --gamma=0.9 --bins=20x20 --seed=0 --output_dir=runs

Writes `<output_dir>/<algo>/<task or model>/<run_name>/` (docs/architecture.md#run-directories).
"""

from __future__ import annotations

import numpy as np
from absl import flags

import cpg_suite
from baselines import cli, runs
from baselines.tabular import discretize, exploration, learners, models, runner
from baselines.tabular.runner import ALGOS, PLANNERS

_D = runner.DEFAULTS


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    global \
        _TASK, \
        _MODEL, \
        _ALGO, \
        _GAMMA, \
        _ALPHA, \
        _LAMBDA, \
        _TRACE, \
        _DOUBLE_ALPHA, \
        _EPSILON, \
        _STEPS, \
        _SWEEPS, \
        _ITERATIONS, \
        _EVAL_SWEEPS, \
        _TOL, \
        _SLIP, \
        _BINS, \
        _FORCE, \
        _ACTIONS, \
        _REWARD, \
        _SEED, \
        _OUTPUT_DIR, \
        _RUN_NAME, \
        _OVERWRITE, \
        _REALTIME, \
        _MOVES, \
        _EXPLORE_MOVES, \
        _STOCHASTIC, \
        _EVAL_MOVES
    _TASK = flags.DEFINE_string("task", _D["task"], "Discrete task id, e.g. pole_balance.")
    _MODEL = flags.DEFINE_string(
        "model", _D["model"], f"Tabular model: {', '.join(models.MODELS)}."
    )
    _ALGO = flags.DEFINE_string("algo", _D["algo"], f"One of: {', '.join(ALGOS)}.")
    _GAMMA = flags.DEFINE_float("gamma", _D["gamma"], "Discount factor γ in [0, 1].")
    _ALPHA = flags.DEFINE_float("alpha", _D["alpha"], "Learning rate α in [0, 1] (TD learners).")
    _LAMBDA = flags.DEFINE_float(
        "lam", _D["lam"], "Trace decay λ in [0, 1] (sarsa_lambda, td_lambda)."
    )
    _TRACE = flags.DEFINE_enum("trace", _D["trace"], list(learners.TRACES), "Trace type.")
    _DOUBLE_ALPHA = flags.DEFINE_bool(
        "double_alpha", _D["double_alpha"], "Use the thesis' printed δ = α[...] (α applied twice)."
    )
    _EPSILON = flags.DEFINE_string(
        "epsilon",
        _D["epsilon"],
        "ε: a constant like 0.1, or step:value points like 0:0.9,100:0.9,300:0 (default: the "
        "study's real-time schedule on the crawler, 0 elsewhere).",
    )
    _STEPS = flags.DEFINE_integer("steps", _D["steps"], "Online learning steps (iterations).")
    _SWEEPS = flags.DEFINE_integer(
        "sweeps",
        _D["sweeps"],
        "value_iteration: exactly this many sweeps (default: until converged).",
    )
    _ITERATIONS = flags.DEFINE_integer(
        "iterations",
        _D["iterations"],
        "policy_iteration: exactly this many iterations (default: until stable).",
    )
    _EVAL_SWEEPS = flags.DEFINE_integer(
        "eval_sweeps",
        _D["eval_sweeps"],
        "policy_iteration: sweeps per evaluation (default: exact solve).",
    )
    _TOL = flags.DEFINE_float("tol", _D["tol"], "value_iteration convergence tolerance.")
    _SLIP = flags.DEFINE_float(
        "slip", _D["slip"], "Model: probability that a move does not happen."
    )
    _BINS = flags.DEFINE_string(
        "bins", _D["bins"], "Pole: ANGLExVELOCITY bins (20x20) or ANGLE (100)."
    )
    _FORCE = flags.DEFINE_float("force", _D["force"], "Pole: push force, N (task default 0.5).")
    _ACTIONS = flags.DEFINE_integer(
        "actions", _D["actions"], "Pole: 3 for {-F, 0, +F}, 2 for {-F, +F}."
    )
    _REWARD = flags.DEFINE_enum(
        "reward", _D["reward"], ["angle", "approach"], "Pole reward variant."
    )
    _SEED = flags.DEFINE_integer(
        "seed", _D["seed"], "Random seed (initial states, exploration, ties)."
    )
    _OUTPUT_DIR = flags.DEFINE_string("output_dir", _D["output_dir"], "Root of the output tree.")
    _RUN_NAME = flags.DEFINE_string(
        "run_name", _D["run_name"], "Run directory name (default seed<N>)."
    )
    _OVERWRITE = flags.DEFINE_bool(
        "overwrite", _D["overwrite"], "Replace an existing run directory."
    )
    _REALTIME = flags.DEFINE_bool(
        "realtime",
        _D["realtime"],
        "Crawler: plan (value/policy iteration) on rewards measured online.",
    )
    _MOVES = flags.DEFINE_integer("moves", None, "Crawler: learning moves (same as --steps).")
    _EXPLORE_MOVES = flags.DEFINE_integer(
        "explore_moves", _D["explore_moves"], "Crawler: first N moves random (ε = 1), approach 1b."
    )
    _STOCHASTIC = flags.DEFINE_float(
        "stochastic", _D["stochastic"], "Crawler: probability that a move does not happen."
    )
    _EVAL_MOVES = flags.DEFINE_integer(
        "eval_moves", _D["eval_moves"], "Crawler: moves of the frozen greedy policy after learning."
    )


def _validate() -> dict:
    """Checks the flags; returns them as a settings dict."""
    cli.check(
        (_TASK.value is None) != (_MODEL.value is None),
        f"give exactly one of --task (a discrete task) or --model ({', '.join(models.MODELS)})",
    )
    cli.check(_ALGO.value in ALGOS, f"unknown --algo {_ALGO.value!r}; valid: {', '.join(ALGOS)}")
    if _MODEL.value is not None:
        cli.check(
            _MODEL.value in models.MODELS,
            f"unknown --model {_MODEL.value!r}; valid: {', '.join(models.MODELS)}",
        )
    else:
        try:
            cpg_suite.split_task_id(_TASK.value)
        except ValueError as e:
            raise cli.UsageError(str(e)) from None
        crawler = _TASK.value.startswith("crawler")
        cli.check(
            _ALGO.value not in PLANNERS
            or (crawler and (_REALTIME.value or _EXPLORE_MOVES.value > 0)),
            f"{_ALGO.value} needs a complete model (--model=tokic), or on the crawler a model "
            "measured online (--realtime or --explore_moves=N)",
        )
        cli.check(
            _ALGO.value not in ("td0", "td_lambda") or not _TASK.value.startswith("pole"),
            f"{_ALGO.value} learns state values and acts through a known successor "
            "function, which the pole does not have; use q_learning, sarsa or sarsa_lambda",
        )
        cli.check(
            hasattr(cpg_suite.load(_TASK.value).action_spec(), "num_values"),
            f"{_TASK.value} has continuous actions; tabular methods need a discrete "
            "task such as pole_balance",
        )
        cli.check(
            _TASK.value.startswith(("pole", "crawler")),
            f"no discretizer is defined for {_TASK.value}",
        )
    for name, flag in (("gamma", _GAMMA), ("alpha", _ALPHA), ("lam", _LAMBDA)):
        cli.check(0.0 <= flag.value <= 1.0, f"--{name} must lie in [0, 1], got {flag.value}")
    cli.check(0.0 <= _SLIP.value < 1.0, f"--slip must lie in [0, 1), got {_SLIP.value}")
    cli.check(_STEPS.value >= 1, f"--steps must be ≥ 1, got {_STEPS.value}")
    cli.check(
        _SWEEPS.value is None or _SWEEPS.value >= 0, f"--sweeps must be ≥ 0, got {_SWEEPS.value}"
    )
    cli.check(
        _ITERATIONS.value is None or _ITERATIONS.value >= 1,
        f"--iterations must be ≥ 1, got {_ITERATIONS.value}",
    )
    cli.check(
        _EVAL_SWEEPS.value is None or _EVAL_SWEEPS.value >= 1,
        f"--eval_sweeps must be ≥ 1, got {_EVAL_SWEEPS.value}",
    )
    cli.check(_TOL.value > 0, f"--tol must be > 0, got {_TOL.value}")
    cli.check(_SEED.value >= 0, f"--seed must be ≥ 0, got {_SEED.value}")
    cli.check(_ACTIONS.value in (2, 3), f"--actions must be 2 or 3, got {_ACTIONS.value}")
    cli.check(
        _FORCE.value is None or (np.isfinite(_FORCE.value) and _FORCE.value > 0),
        f"--force must be a positive number of newtons, got {_FORCE.value}",
    )
    cli.check(_MOVES.value is None or _MOVES.value >= 1, f"--moves must be ≥ 1, got {_MOVES.value}")
    cli.check(_EXPLORE_MOVES.value >= 0, f"--explore_moves must be ≥ 0, got {_EXPLORE_MOVES.value}")
    cli.check(
        0.0 <= _STOCHASTIC.value < 1.0, f"--stochastic must lie in [0, 1), got {_STOCHASTIC.value}"
    )
    cli.check(_EVAL_MOVES.value >= 0, f"--eval_moves must be ≥ 0, got {_EVAL_MOVES.value}")
    cli.check(
        not (_ALGO.value == "policy_iteration" and _GAMMA.value >= 1.0 and _MODEL.value is None),
        "policy_iteration in real time needs --gamma < 1",
    )
    try:
        if _EPSILON.value is not None:
            exploration.EpsilonSchedule.parse(_EPSILON.value)
        bins = discretize.parse_bins(_BINS.value)
    except ValueError as e:
        raise cli.UsageError(str(e)) from None
    cli.check(len(bins) in (1, 2), f"--bins takes 1 or 2 counts, got {_BINS.value!r}")
    settings = {name: flags.FLAGS[name].value for name in runner.DEFAULTS}
    if _MOVES.value is not None:
        settings["steps"] = _MOVES.value
    return settings


def main(argv):
    del argv
    settings = _validate()
    try:
        run_dir, summary = runner.execute(settings)
    except runs.RunDirectoryExists as e:
        raise cli.UsageError(str(e)) from None
    shown = {k: v for k, v in summary.items() if not isinstance(v, list) or k == "cycle"}
    print(f"{run_dir}: {shown}")


if __name__ == "__main__":
    define_flags()
    cli.run(main)
