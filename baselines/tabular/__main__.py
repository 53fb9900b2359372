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

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

from absl import flags

from baselines.tabular import learners, models, runner
from baselines.tabular.settings import ALGOS, DEFAULTS, POLE_REWARDS, TabularSettings
from cpg_suite import cli
from cpg_suite.runfiles import runs

# Flag help per setting: (absl definer, help). Defaults come from `TabularSettings`.
_FLAGS = {
    "task": ("string", "none: --model instead. Discrete task id, e.g. pole_balance."),
    "model": ("string", f"none: --task instead. Tabular model: {', '.join(models.MODELS)}."),
    "algo": ("string", f"One of: {', '.join(ALGOS)}."),
    "gamma": ("float", "Discount factor γ in [0, 1]."),
    "alpha": ("float", "Learning rate α in [0, 1] (TD learners)."),
    "lam": ("float", "Trace decay λ in [0, 1] (sarsa_lambda, td_lambda)."),
    "trace": (list(learners.TRACES), "Trace type."),
    "double_alpha": ("bool", "Use the thesis' printed δ = α[...] (α applied twice)."),
    "epsilon": (
        "string",
        "ε: a constant like 0.1, or step:value points like 0:0.9,100:0.9,300:0 (default: the "
        "study's real-time schedule on the crawler, 0 elsewhere).",
    ),
    "steps": ("integer", "Online learning steps (iterations)."),
    "sweeps": ("integer", "value_iteration: exactly this many sweeps (default: until converged)."),
    "iterations": (
        "integer",
        "policy_iteration: exactly this many iterations (default: until stable).",
    ),
    "eval_sweeps": ("integer", "policy_iteration: sweeps per evaluation (default: exact solve)."),
    "tol": ("float", "value_iteration convergence tolerance."),
    "slip": ("float", "Model: probability that a move does not happen."),
    "bins": ("string", "Pole: ANGLExVELOCITY bins (20x20) or ANGLE (100)."),
    "force": ("float", "none: the task's, 0.5 N. Pole: push force, N."),
    "actions": ("integer", "Pole: 3 for {-F, 0, +F}, 2 for {-F, +F}."),
    "reward": (list(POLE_REWARDS), "Pole reward variant."),
    "seed": ("integer", "Random seed (initial states, exploration, ties)."),
    "output_dir": ("string", "Root of the output tree."),
    "run_name": ("string", "Run directory name (default seed<N>)."),
    "overwrite": ("bool", "Replace an existing run directory."),
    "realtime": ("bool", "Crawler: plan (value/policy iteration) on rewards measured online."),
    "explore_moves": ("integer", "Crawler: first N moves random (ε = 1), approach 1b."),
    "stochastic": ("float", "Crawler: probability that a move does not happen."),
    "backward_penalty": ("float", "Crawler: factor k ≥ 1 on backward moves' reward (1: none)."),
    "eval_moves": ("integer", "Crawler: moves of the frozen greedy policy after learning."),
}


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program).

    One flag per field of `TabularSettings`, with its default, plus `--moves` (the crawler's
    name for `--steps`).
    """
    for name, (kind, help_text) in _FLAGS.items():
        if isinstance(kind, list):
            flags.DEFINE_enum(name, DEFAULTS[name], kind, help_text)
        else:
            getattr(flags, f"DEFINE_{kind}")(name, DEFAULTS[name], help_text)
    flags.DEFINE_integer(
        "moves", None, "none: --steps. Crawler: learning moves (its name for --steps)."
    )


def main(argv: list[str]) -> None:
    """Builds the settings from the flags, runs them and prints the summary."""
    del argv
    moves = flags.FLAGS.moves
    cli.check(moves is None or moves >= 1, f"--moves must be ≥ 1, got {moves}")
    overrides = {"steps": moves} if moves is not None else {}
    settings = cli.settings_from_flags(TabularSettings, **overrides)
    try:
        run_dir, summary = runner.execute(settings)
    except runs.RunDirectoryExists as e:
        raise cli.UsageError(str(e)) from None
    shown = {k: v for k, v in summary.items() if not isinstance(v, list) or k == "cycle"}
    print(f"{run_dir}: {shown}")


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_dirs=("output_dir",))
