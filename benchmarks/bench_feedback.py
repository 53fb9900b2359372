r"""Closed-loop (feedback CPG) vs open-loop evaluator throughput, in one run.

  python benchmarks/bench_feedback.py [--threads=2] [--rounds=2] [--steps=1000]

A round is K = 50 candidates × 2 starts on the randomized tier, CEM-like candidates around
the hand-tuned gait (noise 0.8°); the feedback candidates are the same amplitudes with
small random gains. Each round is evaluated by the open-loop `BatchEvaluator` and by the
`FeedbackEvaluator` with the same threads, alternately. Prints physics steps per second of
each and their ratio (the goal: closed loop ≥ 0.5× open loop).
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import time

import numpy as np
from absl import flags

from cpg_suite import cli, cpg, feedback
from cpg_suite.evaluation.closed_loop import FeedbackEvaluator
from cpg_suite.evaluation.open_loop import BatchEvaluator

_K, _STARTS, _TIER = 50, (11, 12), "darwin_walk_randomized"


@dataclasses.dataclass(frozen=True)
class BenchFeedbackSettings:
    """What the benchmark measures.

    Attributes:
      threads: Threads of both evaluators.
      rounds: Rounds of K = 50 candidates × 2 starts.
      steps: Control steps per trial.
    """

    threads: int = 2
    rounds: int = 2
    steps: int = 1000

    def __post_init__(self):
        cli.require(self.threads >= 1, f"--threads must be ≥ 1, got {self.threads}")
        cli.require(self.rounds >= 1, f"--rounds must be ≥ 1, got {self.rounds}")
        cli.require(self.steps >= 1, f"--steps must be ≥ 1, got {self.steps}")


def benchmark(settings: BenchFeedbackSettings) -> None:
    """Evaluates the same rounds open- and closed-loop, alternately; prints both rates.

    Args:
      settings: Threads, rounds and trial length.
    """
    rng = np.random.default_rng(0)
    wall = {"open": 0.0, "closed": 0.0}
    steps = {"open": 0, "closed": 0}
    with (
        BatchEvaluator(_TIER, settings.steps, settings.threads) as open_loop,
        FeedbackEvaluator(_TIER, settings.steps, settings.threads) as closed_loop,
    ):
        for _ in range(settings.rounds):
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
        f"K={_K} x {len(_STARTS)} starts x {settings.rounds} rounds on {_TIER}, "
        f"{settings.threads} threads: open loop {rate['open']:,.0f} physics steps/s "
        f"({steps['open']:,} in {wall['open']:.1f} s), closed loop {rate['closed']:,.0f} "
        f"({steps['closed']:,} in {wall['closed']:.1f} s); ratio {ratio:.2f} (goal >= 0.5)"
    )


def define_flags() -> None:
    """Defines this script's command-line flags (only when it runs as a program)."""
    d = BenchFeedbackSettings()
    flags.DEFINE_integer("threads", d.threads, "Threads of both evaluators.")
    flags.DEFINE_integer("rounds", d.rounds, "Rounds of K = 50 candidates x 2 starts.")
    flags.DEFINE_integer("steps", d.steps, "Control steps per trial.")


def main(argv: list[str]) -> None:
    del argv
    benchmark(cli.settings_from_flags(BenchFeedbackSettings))


if __name__ == "__main__":
    define_flags()
    cli.run(main)
