r"""Time to score an exported policy: trial by trial, as before batching, against batched.

  python benchmarks/bench_policy_score.py
      [--run=results/protocol/runs/ppo_mjx/darwin_walk/cpg_seed0] [--tier=darwin_walk]
      [--seeds=50] [--steps=100] [--repeats=2]

In one process, the same trials (`--seeds` test seeds of `--tier`, `--steps` control steps)
of a shipped exported policy (`selected_policy.npz`) are scored two ways:

  * one by one, as `score_policy` scored every policy before batching: one policy call
    per trial and control step, the gait-quality inputs read by four accessors after each
    physics step (`score.step_policy` with `record=score._record`);
  * batched: `score.batched_policy_trials` (one `act_batch` call per control step for all
    trials, the inputs recorded inside the substep loop).

It prints each wall time (the best of `--repeats`) and the speed-ups over the first, and
checks that the two give the same distances and failures. Absolute times are noisy on a
shared machine; the ratios, measured in one run, are the figures to compare.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import os
import time

import numpy as np
from absl import flags

from cpg_suite import cli, protocol
from cpg_suite.protocol import score
from cpg_suite.runfiles import exported

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RUN = os.path.join(ROOT, "results", "protocol", "runs", "ppo_mjx", "darwin_walk", "cpg_seed0")


@dataclasses.dataclass(frozen=True)
class BenchPolicyScoreSettings:
    """What the benchmark scores.

    Attributes:
      run: A shipped run folder holding `selected_policy.npz` (checked by `main`).
      tier: The test tier.
      seeds: Test seeds (trials).
      steps: Control steps per trial.
      repeats: Timings per figure (the best is kept).
    """

    run: str = RUN
    tier: str = "darwin_walk"
    seeds: int = 50
    steps: int = 100
    repeats: int = 2

    def __post_init__(self):
        for name in ("seeds", "steps", "repeats"):
            cli.require_integer(name, getattr(self, name), 1)
        cli.require(
            self.tier in protocol.TIERS,
            f"--tier must be one of {', '.join(protocol.TIERS)}, got {self.tier!r}",
        )


def one_by_one(policy, settings: BenchPolicyScoreSettings, seeds: list[int]) -> list[tuple]:
    """The trials scored as before batching; their (distance, failure step) pairs."""
    results = []
    for seed in seeds:
        env, observation, n_sub = score.start_trial(policy, settings.tier, seed)
        start = env.physics.torso_position()
        last, (fall_step, _), records = score.step_policy(
            policy, env.task, env.physics, observation, settings.steps, n_sub, score._record
        )
        last = start if last is None else last
        score._quality([tuple(np.array(c) for c in zip(*records))], env.physics, 0.0)  # as then
        results.append((float(last[0] - start[0]), fall_step))
    return results


def batched(policy, settings: BenchPolicyScoreSettings, seeds: list[int]) -> list[tuple]:
    """The trials scored in a batch; their (distance, failure step) pairs."""
    trials = score.batched_policy_trials(
        policy, settings.tier, seeds, settings.steps, score.ScoreSettings().task_kwargs()
    )
    return [(t["distance_m"], t["fall_step"]) for t in trials]


def _best(run, repeats: int) -> tuple[float, list]:
    times, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = run()
        times.append(time.perf_counter() - start)
    return min(times), result


def benchmark(settings: BenchPolicyScoreSettings) -> None:
    """Times the three ways and prints them with their speed-ups."""
    policy = exported.NumpyPolicy.load(os.path.join(settings.run, exported.FILE))
    seeds = protocol.held_out_seeds(settings.seeds)
    base, reference = _best(lambda: one_by_one(policy, settings, seeds), settings.repeats)
    print(f"{settings.seeds} trials x {settings.steps} control steps of {settings.tier}")
    print(f"one by one (before batching)   {base:7.2f} s")
    wall, result = _best(lambda: batched(policy, settings, seeds), settings.repeats)
    same = "same trials" if result == reference else "TRIALS DIFFER"
    print(f"batched                        {wall:7.2f} s  {base / wall:5.2f}x  {same}")


def define_flags() -> None:
    """Defines this script's command-line flags (only when it runs as a program)."""
    d = BenchPolicyScoreSettings()
    flags.DEFINE_string("run", d.run, "A shipped run folder with selected_policy.npz.")
    flags.DEFINE_string("tier", d.tier, "Test tier.")
    flags.DEFINE_integer("seeds", d.seeds, "Test seeds (trials).")
    flags.DEFINE_integer("steps", d.steps, "Control steps per trial.")
    flags.DEFINE_integer("repeats", d.repeats, "Timings per figure (the best is kept).")


def main(argv: list[str]) -> None:
    del argv
    settings = cli.settings_from_flags(BenchPolicyScoreSettings)
    path = os.path.join(settings.run, exported.FILE)
    cli.check(os.path.isfile(path), f"--run={settings.run} holds no {exported.FILE}")
    benchmark(settings)


if __name__ == "__main__":
    define_flags()
    cli.run(main)
