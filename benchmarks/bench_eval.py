r"""Throughput of the batched gait evaluator (docs/architecture.md#the-batched-evaluator).

  python benchmarks/bench_eval.py [--candidates=20] [--cem_rounds=10]

Measures, in one process:
  1. the evaluator's physics steps per second vs a raw `mujoco.rollout` of the same model,
     initial states and controls with the same thread count (ratio; target ≥ 0.85), for
     1 and 2 threads;
  2. its speedup over stepping the dm_control environment
     (`cpg_suite.evaluation.gait.evaluate_gait`) for the same candidates;
  3. a whole CEM run (default settings, `--cem_rounds` rounds): wall time vs its ideal,
     simulated steps / raw rollout rate (target ≤ 1.25).
Candidates are drawn around the hand-tuned amplitudes with the CEM's initial spread
(N(hand-tuned, I)), so some fall, as in a CEM round; the evaluator stops simulating a
fallen candidate, the raw rollout does not, so both are compared in steps per second.
Absolute rates are noisy on a shared machine; the ratios are measured back to back.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import tempfile
import time

import mujoco
import numpy as np
from absl import flags
from mujoco import rollout

from baselines import cem
from cpg_suite import cli, cpg
from cpg_suite.evaluation.gait import evaluate_gait
from cpg_suite.evaluation.open_loop import BatchEvaluator
from cpg_suite.runfiles import runs


def raw_rollout_rate(
    evaluator: BatchEvaluator, amplitudes: np.ndarray, seed: int, threads: int, repeats: int
) -> float:
    """Physics steps per second of one multi-threaded `mujoco.rollout` call, full length."""
    model = evaluator.model
    controls = np.repeat(evaluator.controls(amplitudes), evaluator.n_sub, axis=1)
    initial = np.tile(evaluator.initial_state(seed), (len(amplitudes), 1))
    datas = [mujoco.MjData(model) for _ in range(threads)]
    runner = rollout.Rollout(nthread=threads if threads > 1 else 0)
    best = np.inf
    try:
        for _ in range(repeats):
            start = time.perf_counter()
            runner.rollout(model, datas if threads > 1 else datas[0], initial, controls)
            best = min(best, time.perf_counter() - start)
    finally:
        runner.close()
    return controls.shape[0] * controls.shape[1] / best


def evaluator_rate(evaluator: BatchEvaluator, amplitudes, seed: int, repeats: int):
    best, steps = np.inf, 0
    for _ in range(repeats):
        start = time.perf_counter()
        steps = evaluator.evaluate(amplitudes, [seed]).sim_steps
        best = min(best, time.perf_counter() - start)
    return steps / best, best


@dataclasses.dataclass(frozen=True)
class BenchEvalSettings:
    """What the benchmark measures.

    Attributes:
      candidates: Candidates around the hand-tuned gait per evaluation.
      repeats: Timings per figure (the best is kept).
      cem_rounds: Rounds of the timed CEM run.
    """

    candidates: int = 20
    repeats: int = 2
    cem_rounds: int = 10

    def __post_init__(self):
        cli.require(self.candidates >= 1, f"--candidates must be ≥ 1, got {self.candidates}")
        cli.require(self.repeats >= 1, f"--repeats must be ≥ 1, got {self.repeats}")
        cli.require(self.cem_rounds >= 1, f"--cem_rounds must be ≥ 1, got {self.cem_rounds}")


def benchmark(settings: BenchEvalSettings) -> None:
    """Measures the evaluator against raw rollouts, env stepping and a CEM run; prints each.

    Args:
      settings: Candidates, repeats and CEM rounds.
    """
    rng = np.random.default_rng(0)
    hand = cpg.amplitudes_from("hand_tuned")
    amplitudes = hand + rng.standard_normal((settings.candidates, 11))

    print(f"{settings.candidates} candidates around the hand-tuned gait, 1000 control steps each")
    raw_rates = {}
    for threads in (1, 2):
        with BatchEvaluator(threads=threads) as evaluator:
            evaluator.evaluate(amplitudes[:1], [0])  # warm the initial-state cache
            rate, seconds = evaluator_rate(evaluator, amplitudes, 0, settings.repeats)
            raw = raw_rollout_rate(evaluator, amplitudes, 0, threads, settings.repeats)
            raw_rates[threads] = raw
            print(
                f"threads={threads}: evaluator {rate:,.0f} steps/s ({seconds:.2f} s), raw "
                f"rollout {raw:,.0f} steps/s, evaluator/raw = {rate / raw:.3f}"
            )
            if threads == 2:
                eval_seconds = seconds
    start = time.perf_counter()
    for a in amplitudes:
        evaluate_gait(a, 0)
    env_seconds = time.perf_counter() - start
    print(
        f"environment stepping: {env_seconds:.2f} s for the same candidates; evaluator with "
        f"2 threads is {env_seconds / eval_seconds:.2f}x faster"
    )

    with tempfile.TemporaryDirectory() as out:
        cem_settings = cem.CEMSettings(rounds=settings.cem_rounds)
        options = runs.RunOptions(output_dir=out, run_name="bench", threads=2)
        start = time.perf_counter()
        _, summary = cem.run_cem(cem_settings, options, log=lambda line: None)
        wall = time.perf_counter() - start
    ideal = summary["sim_steps"] / raw_rates[2]
    print(
        f"CEM K=50, {settings.cem_rounds} rounds: {summary['sim_steps']:,} steps in {wall:.1f} s; "
        f"ideal (steps / raw 2-thread rate) {ideal:.1f} s; wall/ideal = {wall / ideal:.3f}"
    )


def define_flags() -> None:
    """Defines this script's command-line flags (only when it runs as a program)."""
    d = BenchEvalSettings()
    flags.DEFINE_integer("candidates", d.candidates, "Candidates around the hand-tuned gait.")
    flags.DEFINE_integer("repeats", d.repeats, "Timings per figure (the best is kept).")
    flags.DEFINE_integer("cem_rounds", d.cem_rounds, "Rounds of the timed CEM run.")


def main(argv: list[str]) -> None:
    del argv
    benchmark(cli.settings_from_flags(BenchEvalSettings))


if __name__ == "__main__":
    define_flags()
    cli.run(main)
