r"""Evaluate a CPG gait on a DARwIn-OP task by stepping the dm_control environment.

  python -m baselines.evaluate --task=darwin_walk --params=hand_tuned --seeds=0-9

`--params` takes a preset (`hand_tuned`, `table6_1`, `table6_2`: thesis Tables 6.1/6.2) or a
JSON file holding the 11 amplitudes by name. Prints one JSON line per seed (`seed`,
`distance_m`, `lateral_m`, `fell`, `fall_step`) and a summary line. The seed is the task's
`random` (the initial-state perturbation). This path steps the environment control step by
control step and is the reference that faster evaluators are checked against.
"""

from __future__ import annotations

import json
import os

import numpy as np
from absl import flags

from baselines import cli
from baselines.batch_eval import BatchEvaluator
from baselines.gait import DARWIN_TASKS, evaluate_gait, summarize
from cpg_suite import cpg


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    global _TASK, _PARAMS, _SEEDS, _STEPS, _FAST, _THREADS
    _TASK = flags.DEFINE_string("task", "darwin_walk", f"One of {', '.join(DARWIN_TASKS)}.")
    _PARAMS = flags.DEFINE_string(
        "params", "hand_tuned", f"Preset ({', '.join(cpg.PRESETS)}) or a JSON file of amplitudes."
    )
    _SEEDS = flags.DEFINE_string("seeds", "0-9", "Initial-state seeds: N, A-B or a comma list.")
    _STEPS = flags.DEFINE_integer("steps", 1000, "Control steps per trial (the study: 1000).")
    _FAST = flags.DEFINE_bool(
        "fast", False, "Use the batched mujoco.rollout evaluator (same results)."
    )
    _THREADS = flags.DEFINE_integer("threads", 2, "Threads of the --fast evaluator.")


def parse_params(text: str) -> np.ndarray:
    """A preset name or a JSON file of amplitudes -> (11,) degrees.

    Raises:
      cli.UsageError: With the valid presets, or what is wrong with the file.
    """
    if text in cpg.PRESETS:
        return cpg.amplitudes_from(text)
    if not os.path.isfile(text):
        raise cli.UsageError(
            f"--params {text!r} is neither a preset ({', '.join(cpg.PRESETS)}) "
            "nor an existing JSON file"
        )
    try:
        return cpg.load_amplitudes(text)
    except (ValueError, json.JSONDecodeError) as e:
        raise cli.UsageError(f"--params file {text}: {e}") from None


def main(argv):
    del argv
    cli.check(
        _TASK.value in DARWIN_TASKS,
        f"unknown --task {_TASK.value!r}; valid: {', '.join(DARWIN_TASKS)}",
    )
    cli.check(_STEPS.value >= 1, f"--steps must be ≥ 1, got {_STEPS.value}")
    cli.check(_THREADS.value >= 1, f"--threads must be ≥ 1, got {_THREADS.value}")
    amplitudes = parse_params(_PARAMS.value)
    seeds = cli.parse_seeds(_SEEDS.value)
    results = []
    if _FAST.value:
        with BatchEvaluator(_TASK.value, _STEPS.value, _THREADS.value) as evaluator:
            batch = evaluator.evaluate(amplitudes, seeds)
        for j, seed in enumerate(seeds):
            step = int(batch.fall_step[0, j])
            results.append(
                {
                    "seed": seed,
                    "distance_m": float(batch.distance_m[0, j]),
                    "lateral_m": float(batch.lateral_m[0, j]),
                    "fell": step > 0,
                    "fall_step": step or None,
                }
            )
            print(json.dumps(results[-1]))
    else:
        for seed in seeds:
            result = evaluate_gait(amplitudes, seed, _TASK.value, _STEPS.value)
            results.append(result)
            print(json.dumps(result), flush=True)
    print(json.dumps({**summarize(results), "task": _TASK.value, "params": _PARAMS.value}))


if __name__ == "__main__":
    define_flags()
    cli.run(main)
