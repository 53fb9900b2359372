r"""Sweep of the CPG and servo constants the study does not give (docs/decisions.md#cpg).

  python -m baselines.experiments.calibrate_cpg --output=runs/calibration.csv

For every combination of stride period (ω = 2π / period), relaxation β, standing knee
crouch and servo gain kp, runs the thesis gaits (`--params`, default the hand-tuned
amplitudes and the two CEM results of Tables 6.1/6.2) from `--seeds` initial states with the
reference evaluator, and appends one CSV row per trial (`--resume` skips rows already
there). It then prints, per setting, the hand-tuned gait's falls and mean distance.

The criterion for the defaults (the study's own observation, thesis Table 6.3): the
hand-tuned amplitudes step in place — no fall in 1000 control steps from any seed, and
millimetres of displacement (the study: 0.0036 m).
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import csv
import dataclasses
import itertools
import multiprocessing
import os
import sys
from collections.abc import Callable

import pandas as pd
from absl import flags

from cpg_suite import cli, cpg, progress
from cpg_suite.evaluation.gait import evaluate_gait


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    flags.DEFINE_string("output", "runs/calibration.csv", "CSV of trials (appended).")
    flags.DEFINE_string("periods", "0.8,1.1,1.4", "Stride periods, s.")
    flags.DEFINE_string("betas", "4,8,16", "Relaxation rates β, 1/s.")
    flags.DEFINE_string("crouches", "15,23,30", "Standing knee flexion, degrees.")
    flags.DEFINE_string("gains", "20,40,80", "Servo gains kp, N·m/rad.")
    flags.DEFINE_string("params", "hand_tuned,table6_1,table6_2", "Amplitude presets.")
    flags.DEFINE_integer("seeds", 3, "Initial-state seeds per setting (0..N-1).")
    flags.DEFINE_integer("processes", 2, "Worker processes.")
    flags.DEFINE_bool("resume", False, "Skip trials already in --output.")


FIELDS = [
    "period",
    "beta",
    "crouch",
    "gain",
    "params",
    "seed",
    "distance_m",
    "lateral_m",
    "fell",
    "fall_step",
]


def _floats(text: str, name: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ValueError(f"--{name} must be a comma list of numbers, got {text!r}") from None
    cli.require(
        bool(values) and all(v > 0 for v in values),
        f"--{name} must be positive numbers, got {text!r}",
    )
    return values


@dataclasses.dataclass(frozen=True)
class CalibrationSettings:
    """The sweep (the flags of `python -m baselines.experiments.calibrate_cpg`); validated.

    Attributes:
      output: CSV of trials (appended to with `resume`).
      periods: Stride periods to try, s (comma list).
      betas: Relaxation rates β to try, 1/s (comma list).
      crouches: Standing knee flexions to try, degrees (comma list).
      gains: Servo gains kp to try, N·m/rad (comma list).
      params: Amplitude presets (comma list).
      seeds: Initial-state seeds per setting (0..N-1).
      processes: Worker processes.
      resume: Skip trials already in `output`.
    """

    output: str = "runs/calibration.csv"
    periods: str = "0.8,1.1,1.4"
    betas: str = "4,8,16"
    crouches: str = "15,23,30"
    gains: str = "20,40,80"
    params: str = "hand_tuned,table6_1,table6_2"
    seeds: int = 3
    processes: int = 2
    resume: bool = False

    def __post_init__(self):
        self.grid()  # validates the lists
        for p in self.presets():
            cli.require(p in cpg.PRESETS, f"unknown preset {p!r}; valid: {', '.join(cpg.PRESETS)}")
        cli.require(self.seeds >= 1, f"--seeds must be ≥ 1, got {self.seeds}")
        cli.require(self.processes >= 1, f"--processes must be ≥ 1, got {self.processes}")

    def grid(self) -> list[tuple]:
        """(period, β, crouch, gain) of every setting."""
        lists = [_floats(getattr(self, n), n) for n in ("periods", "betas", "crouches", "gains")]
        return list(itertools.product(*lists))

    def presets(self) -> list[str]:
        """The amplitude presets, in order."""
        return [p for p in self.params.split(",") if p]

    def jobs(self) -> list[tuple]:
        """(period, β, crouch, gain, preset, seed) of every trial."""
        return [(*g, p, s) for g in self.grid() for p in self.presets() for s in range(self.seeds)]


def _trial(job: tuple) -> dict:
    period, beta, crouch, gain, params, seed = job
    config = cpg.CPGConfig(stride_period=period, beta=beta, crouch=crouch, ramp_time=period)
    result = evaluate_gait(
        cpg.amplitudes_from(params), seed, "darwin_walk", 1000, config, {"servo_gain": gain}
    )
    return {
        "period": period,
        "beta": beta,
        "crouch": crouch,
        "gain": gain,
        "params": params,
        "seed": seed,
        **{k: result[k] for k in FIELDS[6:]},
    }


def summarize(trials: pd.DataFrame) -> pd.DataFrame:
    """One row per setting: falls and mean distance of each gait."""
    keys = ["period", "beta", "crouch", "gain"]
    rows = []
    for setting, group in trials.groupby(keys):
        row = dict(zip(keys, setting))
        for params, g in group.groupby("params"):
            row[f"{params}_falls"] = int(g["fell"].sum())
            row[f"{params}_distance_m"] = float(g["distance_m"].mean())
        rows.append(row)
    return pd.DataFrame(rows)


def _trials_to_run(settings: CalibrationSettings) -> list[tuple]:
    """The sweep's trials not yet in the output file.

    Raises:
      FileExistsError: If the output exists and `resume` is off.
    """
    output, done = settings.output, set()
    if settings.resume and os.path.exists(output):
        old = pd.read_csv(output)
        done = {tuple(r) for r in old[FIELDS[:6]].itertuples(index=False)}
    elif os.path.exists(output):
        raise FileExistsError(f"{output} exists; pass --resume to extend it")
    return [j for j in settings.jobs() if j not in done]


def _write_flushed(line: str) -> None:
    progress.write(line)
    sys.stdout.flush()  # the sweep's log is followed while it runs


def run_calibration(
    settings: CalibrationSettings, log: Callable[[str], None] = _write_flushed
) -> pd.DataFrame:
    """Runs the sweep's missing trials, appending a CSV row per trial; summarises the file.

    Args:
      settings: The sweep.
      log: Receives a line every 20 trials and at the end.

    Returns:
      One row per setting (`summarize`), the hand-tuned gait's fewest falls and smallest
      displacement first.

    Raises:
      FileExistsError: If the output exists and `resume` is off.
    """
    output = settings.output
    todo = _trials_to_run(settings)
    os.makedirs(os.path.dirname(os.path.abspath(output)), exist_ok=True)
    new_file = not os.path.exists(output)
    with open(output, "a", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=FIELDS)
        if new_file:
            writer.writeheader()
        with multiprocessing.Pool(settings.processes) as pool:
            trials = pool.imap(_trial, todo, chunksize=1)
            for i, row in enumerate(progress.track(trials, total=len(todo), desc="trials"), 1):
                writer.writerow(row)
                f.flush()
                if i % 20 == 0 or i == len(todo):
                    log(f"{i}/{len(todo)} trials")
    table = summarize(pd.read_csv(output))
    if "hand_tuned_falls" in table:
        table["abs_hand_tuned_m"] = table["hand_tuned_distance_m"].abs()
        table = table.sort_values(["hand_tuned_falls", "abs_hand_tuned_m"])
    return table


def main(argv):
    del argv
    settings = cli.settings_from_flags(CalibrationSettings)
    try:
        table = run_calibration(settings)
    except FileExistsError as e:
        raise cli.UsageError(str(e)) from None
    with pd.option_context("display.width", 200, "display.max_rows", 500):
        print(table.to_string(index=False, float_format=lambda v: f"{v:.4f}"))


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_files=("output",))
