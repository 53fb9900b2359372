r"""How hard MuJoCo C's constraint solver works on the walking robot: iterations per step.

  python investigations/solver_stats.py [--params=hand_tuned] [--seeds=0-1] [--steps=1000]

Runs the gait in the CPU task `darwin_walk` and, after each control step, reads the last
physics step's solver statistics (`MjData.solver_niter`, and `neval`, the line search's
cost evaluations, of each of its iterations). Prints their mean, 99th percentile and
maximum per trial. MJX under `vmap` pays the model's caps (100 iterations, 50 of line
search) for every robot wherever its while loop is unrolled into a fixed-length scan
(the line search), so these figures say how far the caps sit above what the reference
needs (results/mjx).
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses

import numpy as np
from absl import flags

import cpg_suite
from cpg_suite import cli, cpg
from cpg_suite.evaluation.gait import parse_params


@dataclasses.dataclass(frozen=True)
class SolverStatsSettings:
    """What to run.

    Attributes:
      params: A preset (`cpg.PRESETS`) or a JSON file of the 11 amplitudes.
      seeds: Seeds of the CPU task: `N`, `A-B` or a comma list.
      steps: Control steps per trial.
    """

    params: str = "hand_tuned"
    seeds: str = "0-1"
    steps: int = 1000

    def __post_init__(self):
        parse_params(self.params)  # a preset or a readable file of amplitudes
        cli.parse_seeds(self.seeds)
        cli.require(self.steps >= 1, f"--steps must be ≥ 1, got {self.steps}")


def trial_stats(amplitudes: np.ndarray, seed: int, steps: int) -> dict:
    """Solver statistics of one trial (sampled at each control step's last physics step).

    Args:
      amplitudes: The gait's 11 amplitudes, degrees.
      seed: The CPU task's seed.
      steps: Control steps (the trial ends earlier on a fall).

    Returns:
      `distance_m`, `iterations` (one per control step) and `line_search_evals` (one per
      solver iteration), the last two as integer arrays.
    """
    env = cpg_suite.load("darwin_walk", task_kwargs={"random": seed})
    pattern = cpg.CPG(amplitudes)
    time_step, distance, iterations, evals = env.reset(), 0.0, [], []
    for _ in range(steps):
        if time_step.last():
            break
        targets = pattern.step(env.control_timestep())
        time_step = env.step(env.physics.targets_to_action(targets))
        distance += time_step.reward
        data = env.physics.data
        n = int(data.solver_niter[0])
        iterations.append(n)
        evals += [int(data.solver[i].neval) for i in range(min(n, len(data.solver)))]
    return {
        "distance_m": distance,
        "iterations": np.array(iterations),
        "line_search_evals": np.array(evals),
    }


def _spread(values: np.ndarray) -> str:
    return f"mean {values.mean():.2f}, p99 {np.percentile(values, 99):.0f}, max {values.max()}"


def define_flags() -> None:
    """Defines this script's command-line flags (only when it runs as a program)."""
    d = SolverStatsSettings()
    flags.DEFINE_string("params", d.params, "Preset or JSON file of the 11 amplitudes.")
    flags.DEFINE_string("seeds", d.seeds, "Seeds of the CPU task: N, A-B or a comma list.")
    flags.DEFINE_integer("steps", d.steps, "Control steps per trial.")


def main(argv: list[str]) -> None:
    """Prints each seed's distance and its solver statistics, one line per seed.

    Args:
      argv: absl's leftover arguments (none are used).
    """
    del argv
    settings = cli.settings_from_flags(SolverStatsSettings)
    amplitudes = parse_params(settings.params)
    for seed in cli.parse_seeds(settings.seeds):
        stats = trial_stats(amplitudes, seed, settings.steps)
        print(
            f"seed {seed}: {stats['distance_m']:+.3f} m; solver iterations per step: "
            f"{_spread(stats['iterations'])}; line-search evaluations per iteration: "
            f"{_spread(stats['line_search_evals'])}",
            flush=True,
        )


if __name__ == "__main__":
    define_flags()
    cli.run(main)
