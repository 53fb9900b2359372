r"""Closed-loop (feedback CPG) vs open-loop evaluator throughput, in one run.

  python benchmarks/bench_feedback.py [--threads=2] [--rounds=2] [--steps=1000]

A round is K = 50 candidates × 2 starts on the randomized tier, CEM-like candidates around
the hand-tuned gait (noise 0.8°); the feedback candidates are the same amplitudes with
small random gains. Each round is evaluated by the open-loop `BatchEvaluator` and by the
`FeedbackEvaluator` with the same threads, alternately. Prints physics steps per second of
each and their ratio (the goal: closed loop ≥ 0.5× open loop).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from baselines.batch_eval import BatchEvaluator
from baselines.feedback_eval import FeedbackEvaluator
from cpg_suite import cpg, feedback

_K, _STARTS, _TIER = 50, (11, 12), "darwin_walk_randomized"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--steps", type=int, default=1000)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    wall = {"open": 0.0, "closed": 0.0}
    steps = {"open": 0, "closed": 0}
    with (
        BatchEvaluator(_TIER, args.steps, args.threads) as open_loop,
        FeedbackEvaluator(_TIER, args.steps, args.threads) as closed_loop,
    ):
        for _ in range(args.rounds):
            amplitudes = cpg.amplitudes_from("hand_tuned") + rng.normal(0, 0.8, (_K, 11))
            gains = rng.normal(0, 1.0, (_K, feedback.N_GAINS))
            params = np.concatenate([amplitudes, gains], axis=1)
            for name, evaluator, x in (
                ("open", open_loop, amplitudes),
                ("closed", closed_loop, params),
            ):
                start = time.perf_counter()
                result = evaluator.evaluate(x, _STARTS)
                wall[name] += time.perf_counter() - start
                steps[name] += result.sim_steps
    rate = {k: steps[k] / wall[k] for k in wall}
    ratio = rate["closed"] / rate["open"]
    print(
        f"K={_K} x {len(_STARTS)} starts x {args.rounds} rounds on {_TIER}, "
        f"{args.threads} threads: open loop {rate['open']:,.0f} physics steps/s "
        f"({steps['open']:,} in {wall['open']:.1f} s), closed loop {rate['closed']:,.0f} "
        f"({steps['closed']:,} in {wall['closed']:.1f} s); ratio {ratio:.2f} (goal >= 0.5)"
    )


if __name__ == "__main__":
    main()
