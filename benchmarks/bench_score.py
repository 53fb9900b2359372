r"""Time to score one gait on the test protocol (4 tiers × 50 trials of 16 s).

  python benchmarks/bench_score.py [--params=hand_tuned] [--threads=2]

Prints the wall time of `baselines.score.score_gait` per tier and in all, the physics steps
simulated and their rate, and the rate of a raw `mujoco.rollout` of the nominal model with
the same threads measured in the same run (their ratio is what the evaluator costs).
"""

from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np
from mujoco import rollout

from baselines import gait, protocol, score
from baselines.batch_eval import BatchEvaluator


def raw_rate(amplitudes: np.ndarray, threads: int, trials: int = 20) -> float:
    """Physics steps per second of a raw threaded rollout of the nominal gait."""
    with BatchEvaluator("darwin_walk", 1000, threads) as evaluator:
        ctrl = evaluator.controls(amplitudes)[0].repeat(evaluator.n_sub, axis=0)
        state = evaluator.initial_state(protocol.TEST.start)
        model = evaluator.model
        data = [mujoco.MjData(model) for _ in range(threads)]
        start = time.perf_counter()
        with rollout.Rollout(nthread=threads) as runner:
            runner.rollout(model, data, np.tile(state, (trials, 1)), np.tile(ctrl, (trials, 1, 1)))
        return trials * len(ctrl) / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--params", default="hand_tuned")
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    amplitudes = gait.parse_params(args.params)
    total, steps = 0.0, 0
    for tier in protocol.TIERS:
        settings = score.ScoreSettings(tiers=(tier,), threads=args.threads)
        start = time.perf_counter()
        card = score.score_gait(amplitudes, settings)
        wall = time.perf_counter() - start
        total += wall
        steps += card["scoring_sim_steps"]
        print(f"{tier:24s} {wall:6.1f} s  {card['scoring_sim_steps']:>10,} physics steps")
    raw = raw_rate(amplitudes, args.threads)
    print(
        f"all tiers: {total:.1f} s for {steps:,} physics steps = {steps / total:,.0f} steps/s; "
        f"raw nominal rollout {raw:,.0f} steps/s (ratio {steps / total / raw:.2f})"
    )


if __name__ == "__main__":
    main()
