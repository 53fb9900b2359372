r"""The CPG's cost per control step beside the physics it drives, in one run.

  python benchmarks/bench_cpg.py [--repeats=200]

Times one control step (16 ms) of the modulated CPG (the `cpg` action space) for 1 and 16
rows, of the feedback CPG for 50 rows (with its sensor inputs), and, as the yardstick, the
physics of one DARwIn-OP control step (8 `mj_step`s of the nominal task's model). Prints
microseconds per control step and each CPG's cost as a fraction of the physics'. The CPG's
sin, cos and exp are `cpg_suite.portable`'s (the same bits on every CPU:
docs/decisions.md#same-bits-on-every-cpu).
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import time
from collections.abc import Callable

import mujoco
import numpy as np
from absl import flags

import cpg_suite
from cpg_suite import cli, cpg, darwin, feedback, residual


@dataclasses.dataclass(frozen=True)
class BenchCPGSettings:
    """What the benchmark measures.

    Attributes:
      repeats: Control steps timed per measurement (the best of 5 measurements counts).
    """

    repeats: int = 200

    def __post_init__(self):
        cli.require(self.repeats >= 1, f"--repeats must be ≥ 1, got {self.repeats}")


def _per_call(step: Callable[[], object], repeats: int) -> float:
    """The best of 5 timings of `repeats` calls, in microseconds per call."""
    best = np.inf
    for _ in range(5):
        start = time.perf_counter()
        for _ in range(repeats):
            step()
        best = min(best, (time.perf_counter() - start) / repeats)
    return best * 1e6


def measure(settings: BenchCPGSettings) -> dict[str, float]:
    """Microseconds per control step of each CPG and of the physics.

    Args:
      settings: Repeats per timing.

    Returns:
      `{name: microseconds}`, with "physics" the yardstick.
    """
    physics = cpg_suite.load("darwin_walk").physics
    model, data = physics.model.ptr, physics.data.ptr
    n_physics = int(round(darwin.CONTROL_TIMESTEP / model.opt.timestep))

    def physics_step() -> None:
        for _ in range(n_physics):
            mujoco.mj_step(model, data)

    rng = np.random.default_rng(0)
    out = {"physics": _per_call(physics_step, settings.repeats)}
    for rows in (1, 16):
        modulated = residual.ModulatedCPG(rows)
        modulated.modulate(rng.uniform(-0.2, 0.2, (rows, residual.N_ACTIONS)))
        out[f"modulated CPG, {rows} rows"] = _per_call(
            lambda m=modulated: (m.step(darwin.CONTROL_TIMESTEP), m.phase_features()),
            settings.repeats,
        )
    params = np.concatenate(
        [
            np.tile(np.array(cpg.PRESETS["hand_tuned"]), (50, 1)),
            rng.normal(0, 0.1, (50, feedback.N_GAINS)),
        ],
        axis=1,
    )
    closed = feedback.FeedbackCPG(params)
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (50, 1))
    out["feedback CPG, 50 rows"] = _per_call(
        lambda: closed.step(
            darwin.CONTROL_TIMESTEP,
            feedback.sensor_inputs(quat, np.zeros((50, 3)), np.full((50, 2), 10.0)),
        ),
        settings.repeats,
    )
    return out


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    flags.DEFINE_integer("repeats", BenchCPGSettings.repeats, "Control steps per timing.")


def main(argv: list[str]) -> None:
    del argv
    timings = measure(cli.settings_from_flags(BenchCPGSettings))
    physics = timings["physics"]
    for name, micros in timings.items():
        print(f"{name:24s} {micros:9.1f} µs per control step  {micros / physics:5.2f}x physics")


if __name__ == "__main__":
    define_flags()
    cli.run(main)
