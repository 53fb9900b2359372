r"""Write a CPG gait's joint targets over a trial to CSV (no physics).

  python -m cpg_suite.trajectories --params=hand_tuned --out=hand_tuned_joints.csv

`--params` takes a preset (`hand_tuned`, `table6_1`, `table6_2`) or a JSON file of the 11
amplitudes by name. The CSV has a column `t` (s, the time each target is reached) and one
column per anatomical variable, degrees (`<side>_<joint>`, e.g. `left_hip_pitch`), one row
per control step (16 ms). It is what `analysis.report` plots as the joint-trajectory figure:
the analysis reads this file and never imports the CPG.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import numpy as np
from absl import flags

from cpg_suite import cli, cpg, darwin
from cpg_suite.evaluation import gait

COLUMNS = tuple(f"{side}_{joint}" for side in ("left", "right") for joint in cpg.JOINTS_PER_LEG)


def anatomical_targets(amplitudes: np.ndarray, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """The open-loop CPG's targets as anatomical angles.

    Args:
      amplitudes: The 11 amplitudes, degrees.
      steps: Control steps.

    Returns:
      `(t, z)`: times (s, shape (steps,)) and angles (degrees, shape (steps, 12)).
    """
    dt = darwin.CONTROL_TIMESTEP
    z = cpg.to_anatomical(cpg.trajectories(amplitudes, steps, dt)[0])
    return (np.arange(steps) + 1) * dt, z


def write_csv(path: str, t: np.ndarray, z: np.ndarray) -> None:
    """Writes the times and angles with a header line."""
    table = np.column_stack([t, z])
    np.savetxt(
        path, table, fmt="%.6f", delimiter=",", header=",".join(("t", *COLUMNS)), comments=""
    )


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    flags.DEFINE_string("params", "hand_tuned", "Preset or JSON file of amplitudes.")
    flags.DEFINE_integer("steps", 1000, "Control steps (16 ms each).")
    flags.DEFINE_string("out", None, "CSV file to write.")
    flags.mark_flag_as_required("out")


def main(argv: list[str]) -> None:
    """Writes the gait's joint targets; bad input is a `cli.UsageError`."""
    del argv
    values = flags.FLAGS
    cli.check(values.steps >= 1, f"--steps must be ≥ 1, got {values.steps}")
    try:
        amplitudes = gait.parse_params(values.params)
    except ValueError as e:
        raise cli.UsageError(str(e)) from None
    write_csv(values.out, *anatomical_targets(amplitudes, values.steps))
    print(values.out)


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_files=("out",))
