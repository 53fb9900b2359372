r"""Throughput of the batched gait evaluator (docs/architecture.md#the-batched-evaluator).

  python benchmarks/bench_eval.py [--candidates=20] [--cem_rounds=10]

Measures, in one process:
  1. the evaluator's physics steps per second vs a raw `mujoco.rollout` of the same model,
     initial states and controls with the same thread count (ratio; target ≥ 0.85), for
     1 and 2 threads;
  2. its speedup over stepping the dm_control environment (`baselines.gait.evaluate_gait`)
     for the same candidates;
  3. a whole CEM run (default settings, `--cem_rounds` rounds): wall time vs its ideal,
     simulated steps / raw rollout rate (target ≤ 1.25).
Candidates are drawn around the hand-tuned amplitudes with the CEM's initial spread
(N(hand-tuned, I)), so some fall, as in a CEM round; the evaluator stops simulating a
fallen candidate, the raw rollout does not, so both are compared in steps per second.
Absolute rates are noisy on a shared machine; the ratios are measured back to back.
"""

from __future__ import annotations

import argparse
import tempfile
import time

import mujoco
import numpy as np
from mujoco import rollout

from baselines import cem, runs
from baselines.batch_eval import BatchEvaluator
from baselines.gait import evaluate_gait
from cpg_suite import cpg


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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--candidates", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--cem_rounds", type=int, default=10)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    hand = cpg.amplitudes_from("hand_tuned")
    amplitudes = hand + rng.standard_normal((args.candidates, 11))

    print(f"{args.candidates} candidates around the hand-tuned gait, 1000 control steps each")
    raw_rates = {}
    for threads in (1, 2):
        with BatchEvaluator(threads=threads) as evaluator:
            evaluator.evaluate(amplitudes[:1], [0])  # warm the initial-state cache
            rate, seconds = evaluator_rate(evaluator, amplitudes, 0, args.repeats)
            raw = raw_rollout_rate(evaluator, amplitudes, 0, threads, args.repeats)
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
        settings = cem.CEMSettings(rounds=args.cem_rounds)
        options = runs.RunOptions(output_dir=out, run_name="bench", threads=2)
        start = time.perf_counter()
        _, summary = cem.run_cem(settings, options, log=lambda line: None)
        wall = time.perf_counter() - start
    ideal = summary["sim_steps"] / raw_rates[2]
    print(
        f"CEM K=50, {args.cem_rounds} rounds: {summary['sim_steps']:,} steps in {wall:.1f} s; "
        f"ideal (steps / raw 2-thread rate) {ideal:.1f} s; wall/ideal = {wall / ideal:.3f}"
    )


if __name__ == "__main__":
    main()
