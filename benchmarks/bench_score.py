r"""Time to score one gait on the test protocol (5 tiers × 50 trials of 16 s).

  python benchmarks/bench_score.py [--params=hand_tuned] [--threads=2]

Prints the wall time of `cpg_suite.protocol.score.score_gait` per tier and in all, the physics steps
simulated and their rate, and the rate of a raw `mujoco.rollout` of the nominal model with
the same threads measured in the same run (their ratio is what the evaluator costs).
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import time

import mujoco
import numpy as np
from absl import flags
from mujoco import rollout

from cpg_suite import cli, protocol
from cpg_suite.evaluation import gait
from cpg_suite.evaluation.open_loop import BatchEvaluator
from cpg_suite.protocol import score


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


@dataclasses.dataclass(frozen=True)
class BenchScoreSettings:
    """What the benchmark scores.

    Attributes:
      params: A preset or a JSON file of the 11 amplitudes
        (`cpg_suite.evaluation.gait.parse_params`).
      threads: Evaluator threads.
    """

    params: str = "hand_tuned"
    threads: int = 2

    def __post_init__(self):
        cli.require(self.threads >= 1, f"--threads must be ≥ 1, got {self.threads}")


def benchmark(settings: BenchScoreSettings, amplitudes: np.ndarray) -> None:
    """Scores the gait on every tier, then times a raw rollout; prints the times and rates.

    Args:
      settings: The threads (`params` names the gait in `amplitudes`).
      amplitudes: The 11 amplitudes, degrees.
    """
    total, steps = 0.0, 0
    for tier in protocol.TIERS:
        tier_settings = score.ScoreSettings(tiers=(tier,), threads=settings.threads)
        start = time.perf_counter()
        card = score.score_gait(amplitudes, tier_settings)
        wall = time.perf_counter() - start
        total += wall
        steps += card["scoring_sim_steps"]
        print(f"{tier:24s} {wall:6.1f} s  {card['scoring_sim_steps']:>10,} physics steps")
    raw = raw_rate(amplitudes, settings.threads)
    print(
        f"all tiers: {total:.1f} s for {steps:,} physics steps = {steps / total:,.0f} steps/s; "
        f"raw nominal rollout {raw:,.0f} steps/s (ratio {steps / total / raw:.2f})"
    )


def define_flags() -> None:
    """Defines this script's command-line flags (only when it runs as a program)."""
    d = BenchScoreSettings()
    flags.DEFINE_string("params", d.params, "Preset or a JSON file of amplitudes.")
    flags.DEFINE_integer("threads", d.threads, "Evaluator threads.")


def main(argv: list[str]) -> None:
    del argv
    settings = cli.settings_from_flags(BenchScoreSettings)
    try:
        amplitudes = gait.parse_params(settings.params)
    except ValueError as e:
        raise cli.UsageError(str(e)) from None
    benchmark(settings, amplitudes)


if __name__ == "__main__":
    define_flags()
    cli.run(main)
