r"""Training wall time of a PPO-on-MJX run to reach the CPU PPO's validation score.

  python benchmarks/ppo_mjx_time_to_target.py \
      --run=runs/ppo_mjx/darwin_walk/cpg_seed0 --reference=runs/ppo/darwin_walk/cpg_seed0

The target is the mean, over the `--reference` runs (CPU PPO run directories, comma-
separated), of the validation score their selected policy had (summary.json
`selected.validation_success_weighted_m`); `--target` gives it directly instead. Prints
the first validation of the MJX run (progress.csv, validated on the CPU task on the same
seeds) at or above it: env steps and training wall time (compilation included) on the
device its summary names, or that it was not reached. Both scores are in-sample
(validation seeds): the held-out comparison is the two runs' test cards.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import csv
import json
import os

from absl import flags

from cpg_suite import cli


def time_to_target(rows: list[dict], target: float) -> dict | None:
    """The first progress row whose validation score reaches `target`.

    Args:
      rows: progress.csv rows of a `baselines.ppo_mjx` run, in order.
      target: Success-weighted distance on the validation seeds, m.

    Returns:
      `{"env_steps", "train_wall_s", "validation_m"}` of that row, or None.
    """
    for row in rows:
        if float(row["validation_m"]) >= target:
            return {
                "env_steps": int(row["env_steps"]),
                "train_wall_s": float(row["train_wall_s"]),
                "validation_m": float(row["validation_m"]),
            }
    return None


def reference_target(run_dirs: list[str]) -> float:
    """Mean selected validation score of CPU PPO runs (their summary.json).

    Raises:
      cli.UsageError: If a run has no summary.json.
    """
    scores = []
    for run_dir in run_dirs:
        path = os.path.join(run_dir, "summary.json")
        if not os.path.exists(path):
            raise cli.UsageError(f"--reference {run_dir} has no summary.json")
        with open(path, encoding="utf-8") as f:
            scores.append(json.load(f)["selected"]["validation_success_weighted_m"])
    return sum(scores) / len(scores)


def main(argv: list[str]) -> None:
    """Prints the time to target of `--run`."""
    del argv
    run = flags.FLAGS.run
    progress_path, summary_path = (os.path.join(run, n) for n in ("progress.csv", "summary.json"))
    if not os.path.exists(progress_path):
        raise cli.UsageError(f"--run {run!r} has no progress.csv")
    if flags.FLAGS.target is None and not flags.FLAGS.reference:
        raise cli.UsageError("give --reference (CPU PPO run directories) or --target (m)")
    if flags.FLAGS.target is not None:
        target = flags.FLAGS.target
    else:
        target = reference_target(flags.FLAGS.reference)
    with open(progress_path, newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    device = "unknown device"
    if os.path.exists(summary_path):
        with open(summary_path, encoding="utf-8") as f:
            device = json.load(f).get("device", device)
    reached = time_to_target(rows, target)
    if reached is None:
        best = max((float(r["validation_m"]) for r in rows), default=float("nan"))
        print(f"target {target:+.3f} m not reached (best validation {best:+.3f} m)")
    else:
        print(
            f"target {target:+.3f} m reached at {reached['env_steps']:,} env steps after "
            f"{reached['train_wall_s']:.0f} s of training on {device} "
            f"(validation {reached['validation_m']:+.3f} m)"
        )


if __name__ == "__main__":
    flags.DEFINE_string("run", None, "A baselines.ppo_mjx run directory.", required=True)
    flags.DEFINE_list("reference", [], "CPU PPO run directories whose validation is the target.")
    flags.DEFINE_float(
        "target",
        None,
        "none: the --reference runs' mean. The target validation score, m.",
    )
    cli.run(main)
