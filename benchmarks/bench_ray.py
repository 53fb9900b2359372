r"""Ray backend vs local threads on the same machine, in one run, and a projection.

  python benchmarks/bench_ray.py [--rounds=2] [--cpus=2]

1. Throughput at K = 50: rounds of 50 candidates × the protocol's training starts (2 fresh
   starts per candidate, as in `--fresh_starts --eval_seeds=2`) on the randomized tier,
   1000-step trials, evaluated alternately by the local evaluator (`--cpus` threads) and by
   the Ray evaluator (`--cpus` one-thread actors of a private local Ray instance); the
   results must be equal. Prints trials/s of each and their ratio.
2. Overhead per chunk: the time of a one-trial, one-step Ray call minus the same local
   call, the median of many.
3. On paper: the time of the reference results (`results/protocol/darwin_leaderboard.csv`:
   each configuration's simulation budget × its seeds, plus the test scoring of each run)
   on 10 and 100 one-CPU workers, from the measured cost per physics step on one CPU and
   the overhead per chunk, in two layouts: runs as Ray tasks (one CPU each, the longest
   run bounds the time), and each run's rounds spread over all workers (runs one after
   another, a round's chunks wait for the slowest).
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import csv
import dataclasses
import math
import os
import statistics
import time

import numpy as np
from absl import flags

from cpg_suite import cli, cpg, protocol
from cpg_suite.evaluation import ray_backend
from cpg_suite.evaluation.open_loop import BatchEvaluator

_K, _STARTS, _STEPS = 50, 2, 1000
_TIER = "darwin_walk_randomized"
_SCORING_TRIALS = len(protocol.TIERS) * len(protocol.TEST)  # per scored gait
_LEADERBOARD = os.path.join(
    os.path.dirname(__file__), "..", "results", "protocol", "darwin_leaderboard.csv"
)


def _round(rng: np.random.Generator) -> tuple[np.ndarray, list[int]]:
    """A CEM-like round: the hand-tuned mean plus noise 0.8, two fresh training starts."""
    mean = cpg.amplitudes_from("hand_tuned")
    candidates = mean + rng.normal(0.0, 0.8, (_K, cpg.N_AMPLITUDES))
    starts = [int(s) for s in rng.integers(protocol.TRAINING.start, protocol.TRAINING.stop, 2)]
    return candidates, starts


def throughput(rounds: int, cpus: int) -> dict:
    """Trials/s and physics steps/s of both backends over the same rounds, interleaved."""
    rng = np.random.default_rng(0)
    work = [_round(rng) for _ in range(rounds)]
    wall = {"local": 0.0, "ray": 0.0}
    steps = 0
    with (
        BatchEvaluator(_TIER, _STEPS, cpus) as local,
        ray_backend.RayEvaluator(_TIER, _STEPS, workers=cpus) as remote,
    ):
        remote.evaluate(work[0][0][:cpus], [0])  # actors built before the clock starts
        for candidates, starts in work:
            results = {}
            for name, evaluator in (("local", local), ("ray", remote)):
                start = time.perf_counter()
                results[name] = evaluator.evaluate(candidates, starts)
                wall[name] += time.perf_counter() - start
            assert np.array_equal(results["local"].distance_m, results["ray"].distance_m)
            assert np.array_equal(results["local"].fall_step, results["ray"].fall_step)
            steps += results["local"].sim_steps
    trials = rounds * _K * _STARTS
    return {"trials": trials, "steps": steps, **{f"{k}_s": v for k, v in wall.items()}}


def chunk_overhead(calls: int = 60) -> float:
    """Median seconds a one-trial, one-step chunk costs on Ray beyond the local call."""
    amplitudes = cpg.amplitudes_from("hand_tuned")
    times = {"local": [], "ray": []}
    with (
        BatchEvaluator(_TIER, 1, 1) as local,
        ray_backend.RayEvaluator(_TIER, 1, workers=1) as remote,
    ):
        remote.evaluate(amplitudes, [0])
        for _ in range(calls):
            for name, evaluator in (("local", local), ("ray", remote)):
                start = time.perf_counter()
                evaluator.evaluate(amplitudes, [0])
                times[name].append(time.perf_counter() - start)
    return statistics.median(times["ray"]) - statistics.median(times["local"])


def reference_budget() -> tuple[float, float, int]:
    """(physics steps of all reference runs with their test scoring, steps of the longest
    run, number of runs) from the reference leaderboard."""
    total, longest, count = 0.0, 0.0, 0
    with open(_LEADERBOARD, encoding="utf-8") as f:
        for row in csv.DictReader(f):
            if row["method"] == "preset" or not row["budget_sim_steps"]:
                continue
            seeds = int(row["n_seeds"])
            per_run = float(row["budget_sim_steps"])
            total += seeds * per_run
            longest = max(longest, per_run)
            count += seeds
    return total, longest, count


def project(step_s: float, overhead_s: float, workers: int) -> dict:
    """Hours of the reference results on `workers` one-CPU workers, two layouts."""
    total, longest, runs = reference_budget()
    trial_s = step_s * _STEPS * 8  # a full trial: 1000 control steps × 8 physics steps
    scoring = runs * _SCORING_TRIALS * trial_s
    # Runs as tasks: perfect packing, but no run finishes before its own serial time.
    tasks = max((total * step_s + scoring) / workers, longest * step_s + _SCORING_TRIALS * trial_s)
    # Rounds over all workers: a round of K × starts trials takes ceil(trials / workers)
    # trials' time plus one chunk's overhead; rounds and runs follow one another.
    rounds_total = total / (_K * _STARTS * _STEPS * 8)
    waves = math.ceil(_K * _STARTS / workers)
    spread = rounds_total * (waves * trial_s + overhead_s)
    spread += runs * (math.ceil(_SCORING_TRIALS / workers) * trial_s + overhead_s)
    return {"tasks_h": tasks / 3600, "spread_h": spread / 3600}


@dataclasses.dataclass(frozen=True)
class BenchRaySettings:
    """What the benchmark measures.

    Attributes:
      rounds: Rounds of K = 50 candidates × 2 starts.
      cpus: Local evaluator threads, and one-thread actors of the private Ray instance.
    """

    rounds: int = 2
    cpus: int = 2

    def __post_init__(self):
        cli.require(self.rounds >= 1, f"--rounds must be ≥ 1, got {self.rounds}")
        cli.require(self.cpus >= 1, f"--cpus must be ≥ 1, got {self.cpus}")


def benchmark(settings: BenchRaySettings) -> None:
    """Measures Ray against local threads and the overhead per chunk, prints a projection.

    Args:
      settings: Rounds and CPUs.
    """
    ray_backend.connect(None, num_cpus=settings.cpus)
    try:
        t = throughput(settings.rounds, settings.cpus)
        overhead = chunk_overhead()
    finally:
        ray_backend.disconnect()
    local, remote = t["trials"] / t["local_s"], t["trials"] / t["ray_s"]
    print(
        f"K={_K} x {_STARTS} starts x {settings.rounds} rounds on {_TIER}, {settings.cpus} CPUs: "
        f"local {local:.2f} trials/s ({t['local_s']:.1f} s), ray {remote:.2f} trials/s "
        f"({t['ray_s']:.1f} s); ray/local throughput {remote / local:.2f} (goal >= 0.8); "
        f"results equal"
    )
    print(f"overhead per chunk (ray minus local, one-step call, median): {overhead * 1e3:.1f} ms")
    step_s = t["local_s"] * settings.cpus / t["steps"]  # seconds per physics step on one CPU
    total, longest, runs = reference_budget()
    print(
        f"reference results: {runs} runs, {total / 1e6:.0f} M training physics steps "
        f"(+ {runs} x {_SCORING_TRIALS} test trials); one CPU: {step_s * 1e6:.1f} us/step"
    )
    for workers in (settings.cpus, 10, 100):
        p = project(step_s, overhead, workers)
        print(
            f"  {workers:3d} workers: runs as tasks {p['tasks_h']:.2f} h, "
            f"rounds spread over all workers {p['spread_h']:.2f} h"
        )


def define_flags() -> None:
    """Defines this script's command-line flags (only when it runs as a program)."""
    d = BenchRaySettings()
    flags.DEFINE_integer("rounds", d.rounds, "Rounds of K = 50 candidates x 2 starts.")
    flags.DEFINE_integer("cpus", d.cpus, "Local threads, and Ray actors of one thread.")


def main(argv: list[str]) -> None:
    del argv
    benchmark(cli.settings_from_flags(BenchRaySettings))


if __name__ == "__main__":
    define_flags()
    cli.run(main)
