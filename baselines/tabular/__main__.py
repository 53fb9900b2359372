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

from absl import flags

from baselines import cli, runs
from baselines.tabular import learners, models, runner
from baselines.tabular.runner import ALGOS

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


def main(argv):
    del argv
    values = flags.FLAGS
    cli.check(values.moves is None or values.moves >= 1, f"--moves must be ≥ 1, got {values.moves}")
    overrides = {"steps": values.moves} if values.moves is not None else {}
    settings = cli.settings_from_flags(runner.TabularSettings, **overrides)
    try:
        run_dir, summary = runner.execute(settings)
    except runs.RunDirectoryExists as e:
        raise cli.UsageError(str(e)) from None
    shown = {k: v for k, v in summary.items() if not isinstance(v, list) or k == "cycle"}
    print(f"{run_dir}: {shown}")


if __name__ == "__main__":
    define_flags()
    cli.run(main)
