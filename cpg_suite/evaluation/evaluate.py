r"""Evaluate a CPG gait on a DARwIn-OP task by stepping the dm_control environment.

  python -m cpg_suite.evaluation.evaluate --task=darwin_walk --params=hand_tuned --seeds=0-9

`--params` takes a preset (`hand_tuned`, `table6_1`, `table6_2`: thesis Tables 6.1/6.2) or a
JSON file holding the 11 amplitudes by name. Prints one JSON line per seed (`seed`,
`distance_m`, `lateral_m`, `fell`, `fall_step`) and a summary line. The seed is the task's
`random` (the initial-state perturbation). This path steps the environment control step by
control step and is the reference that faster evaluators are checked against.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import json
from collections.abc import Iterator

import numpy as np
from absl import flags

from cpg_suite import cli, cpg
from cpg_suite.evaluation.gait import DARWIN_TASKS, evaluate_gait, parse_params, summarize
from cpg_suite.evaluation.open_loop import BatchEvaluator


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    flags.DEFINE_string("task", "darwin_walk", f"One of {', '.join(DARWIN_TASKS)}.")
    flags.DEFINE_string(
        "params", "hand_tuned", f"Preset ({', '.join(cpg.PRESETS)}) or a JSON file of amplitudes."
    )
    flags.DEFINE_string("seeds", "0-9", "Initial-state seeds: N, A-B or a comma list.")
    flags.DEFINE_integer("steps", 1000, "Control steps per trial (the study: 1000).")
    flags.DEFINE_bool("fast", False, "Use the batched mujoco.rollout evaluator (same results).")
    flags.DEFINE_integer("threads", 2, "Threads of the --fast evaluator.")


@dataclasses.dataclass(frozen=True)
class EvaluateSettings:
    """Which gait to evaluate, where and how (flags of `python -m cpg_suite.evaluation.evaluate`).

    Attributes:
      task: One of `cpg_suite.evaluation.gait.DARWIN_TASKS`.
      params: A preset (`cpg.PRESETS`) or a JSON file of the 11 amplitudes.
      seeds: Initial-state seeds: `N`, `A-B` or a comma list.
      steps: Control steps per trial.
      fast: Use the batched `mujoco.rollout` evaluator (same results).
      threads: Threads of the fast evaluator.
    """

    task: str = "darwin_walk"
    params: str = "hand_tuned"
    seeds: str = "0-9"
    steps: int = 1000
    fast: bool = False
    threads: int = 2

    def __post_init__(self):
        cli.require(
            self.task in DARWIN_TASKS,
            f"unknown --task {self.task!r}; valid: {', '.join(DARWIN_TASKS)}",
        )
        self.seed_list()  # validates the seeds
        cli.require(self.steps >= 1, f"--steps must be ≥ 1, got {self.steps}")
        cli.require(self.threads >= 1, f"--threads must be ≥ 1, got {self.threads}")

    def seed_list(self) -> list[int]:
        """The seeds, parsed.

        Raises:
          ValueError: If `seeds` is malformed.
        """
        try:
            return cli.parse_seeds(self.seeds)
        except cli.UsageError as e:
            raise ValueError(str(e)) from None


def trials(settings: EvaluateSettings, amplitudes: np.ndarray) -> Iterator[dict]:
    """Evaluates the gait from each seed, yielding one result per seed as it is known.

    Args:
      settings: Task, seeds, steps, and which evaluator.
      amplitudes: The 11 amplitudes, degrees.

    Returns:
      An iterator of `seed`, `distance_m`, `lateral_m`, `fell`, `fall_step` (and, from
      the reference evaluator, `return`) per seed.
    """
    seeds = settings.seed_list()
    if not settings.fast:
        for seed in seeds:
            yield evaluate_gait(amplitudes, seed, settings.task, settings.steps)
        return
    with BatchEvaluator(settings.task, settings.steps, settings.threads) as evaluator:
        batch = evaluator.evaluate(amplitudes, seeds)
    for j, seed in enumerate(seeds):
        step = int(batch.fall_step[0, j])
        yield {
            "seed": seed,
            "distance_m": float(batch.distance_m[0, j]),
            "lateral_m": float(batch.lateral_m[0, j]),
            "fell": step > 0,
            "fall_step": step or None,
        }


def main(argv):
    del argv
    settings = cli.settings_from_flags(EvaluateSettings)
    try:
        amplitudes = parse_params(settings.params)
    except ValueError as e:
        raise cli.UsageError(str(e)) from None
    results = []
    for result in trials(settings, amplitudes):
        results.append(result)
        print(json.dumps(result), flush=True)
    print(json.dumps({**summarize(results), "task": settings.task, "params": settings.params}))


if __name__ == "__main__":
    define_flags()
    cli.run(main)
