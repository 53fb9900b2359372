r"""What running a policy's code in its own process costs (`cpg_suite.protocol.sandbox`).

  python benchmarks/bench_sandbox.py [--tier=darwin_walk] [--seeds=10] [--steps=1000]

In one process, the same trials (`--seeds` test seeds of `--tier`) of the hand-tuned gait
as a coded policy (`score.OpenLoopPolicy` in a `policy_code.py`) are scored twice: in the
scorer's process (as before the sandbox) and in a process of its own, with a trial process
forked per trial (`sandbox.IsolatedPolicy`). It prints the per-step cost of a round trip
(an observation out, an action back) beside a raw `env.step`, each scoring's wall time and
their ratio, and checks that both give the same trials. Times on a shared machine are
noisy: compare the ratios, measured in one run.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import os
import tempfile
import time

import numpy as np
from absl import flags

import cpg_suite
from cpg_suite import cli, protocol
from cpg_suite.protocol import sandbox, score

CODE = """
import numpy as np

from cpg_suite import cpg
from cpg_suite.protocol import score


def make_policy():
    return score.OpenLoopPolicy(np.array(cpg.PRESETS["hand_tuned"]), {steps})
"""


def define_flags() -> None:
    """The benchmark's flags."""
    flags.DEFINE_string("tier", "darwin_walk", "The tier.")
    flags.DEFINE_integer("seeds", 10, "Test seeds scored.")
    flags.DEFINE_integer("steps", 1000, "Control steps a trial.")


def round_trip_us(policy: sandbox.IsolatedPolicy, calls: int = 2000) -> tuple[float, float]:
    """Microseconds per policy call across the boundary, and per raw `env.step`."""
    env = cpg_suite.load("darwin_walk")
    observation = env.reset().observation
    policy.reset()
    start = time.perf_counter()
    for _ in range(calls):
        policy(observation)
    call = (time.perf_counter() - start) / calls * 1e6
    start = time.perf_counter()
    for _ in range(calls // 4):
        env.step(np.zeros(12))
    return call, (time.perf_counter() - start) / (calls // 4) * 1e6


def main(argv: list[str]) -> None:
    """Scores the trials both ways and prints the times."""
    del argv
    values = flags.FLAGS
    cli.check(1 <= values.seeds <= len(protocol.TEST), "--seeds must be in [1, 50]")
    cli.check(values.steps >= 1, f"--steps must be ≥ 1, got {values.steps}")
    cli.check(
        values.tier in protocol.TIERS,
        f"unknown --tier {values.tier!r}; valid: {', '.join(protocol.TIERS)}",
    )
    settings = score.ScoreSettings(steps=values.steps)
    chosen = {values.tier: list(protocol.TEST[: values.seeds])}
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "policy_code.py")
        with open(path, "w", encoding="utf-8") as f:
            f.write(CODE.format(steps=values.steps))
        start = time.perf_counter()
        inside = score.seed_trials(sandbox.load_policy_code(path), settings, chosen)
        in_process = time.perf_counter() - start
        start = time.perf_counter()
        policy = sandbox.IsolatedPolicy(path)
        isolated_trials = score.seed_trials(policy, settings, chosen)
        isolated = time.perf_counter() - start
        call, step = round_trip_us(policy)
        policy.close()
    print(f"round trip {call:.0f} µs a step, beside {step:.0f} µs a raw env.step")
    print(
        f"{values.seeds} trials of {values.steps} steps on {values.tier}: in the scorer's "
        f"process {in_process:.1f} s, in its own {isolated:.1f} s "
        f"({isolated / in_process:.2f}x); same trials: {inside == isolated_trials}"
    )


if __name__ == "__main__":
    define_flags()
    cli.run(main)
