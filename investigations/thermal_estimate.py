"""The servos' temperatures under the shipped gaits and policies (`cpg_suite.thermal`).

Each shipped run's selected gait or policy walks the nominal tier's first test seeds again,
as the scorer steps it under the run's card's benchmark version; every physics step's 20
servo forces and joint velocities give each servo's copper loss (`electrical.copper_loss`),
and the two-node model (`thermal.temperatures`) each winding's and housing's temperature
from 25 °C, for both neighbour motors (`thermal.MOTORS`). Per trial it writes the hottest
servo (the highest mean loss), its mean copper loss, the highest winding and housing
temperatures within the trial, and, had the gait gone on at each servo's mean loss, the
minutes until the first winding and the first housing reach the MX-28's 80 °C limit (two
hours at most). The feedback-CPG runs are left out: their controller reads the sensors
inside the evaluator (`evaluation.closed_loop`), not through a policy.

The table (`summary`) gives per configuration the minutes to the winding's limit with the
copper's temperature coefficient and without it (α = 0), from the trials' mean losses.

    python investigations/thermal_estimate.py                   # every run, 5 nominal seeds each
    python investigations/thermal_estimate.py --seeds=2 --runs=ppo/darwin_walk
    python investigations/thermal_estimate.py --summary          # the table of the kept trials.csv

Writes `trials.csv` (a row per trial and motor) beside this file, or under --out.
"""

from __future__ import annotations

import csv
import os
import sys
from collections.abc import Callable

import numpy as np
import pandas as pd
from absl import app, flags

from cpg_suite import electrical, protocol, thermal
from cpg_suite.protocol import score, verify

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # the repository
HERE = os.path.join(ROOT, "results", "thermal")  # where its table goes
EXTRAPOLATION = 2 * 3600  # s: how long the gait is taken to go on
FIELDS = (
    "run", "seed", "distance_m", "failed", "motor", "hottest_servo", "mean_loss_w",
    "winding_peak_c", "housing_peak_c", "minutes_to_limit_winding", "minutes_to_limit_housing",
)  # fmt: skip


def run_policy(run_dir: str) -> Callable[[dict], np.ndarray]:
    """The run's policy as the scorer steps it (a gait as `score.OpenLoopPolicy`)."""
    policy = verify.shipped_policy(run_dir)
    if policy is not None:
        return policy
    settings = verify.run_settings(run_dir)
    return score.OpenLoopPolicy(verify.gait_params(run_dir, settings.controller), settings.steps)


def _servo_state(physics) -> tuple[np.ndarray, np.ndarray]:
    """The 20 servos' forces and joint velocities after a physics step (copies)."""
    return np.array(physics.servo_forces()), np.array(physics.servo_velocities())


def trial_losses(policy: Callable, settings: score.ScoreSettings, seed: int) -> tuple:
    """One nominal-tier trial of `policy`, stepped as `score.policy_trial` steps it.

    Args:
      policy: The run's policy (`run_policy`).
      settings: The run's card's settings (its trial length and benchmark version).
      seed: The trial's test seed.

    Returns:
      `(distance m, failed, (steps, 20) copper loss W, physics step s, the servos' names)`.
    """
    tier = protocol.TIERS[0]
    env, observation, n_sub = score.start_trial(policy, tier, seed, settings.task_kwargs())
    physics = env.physics
    start = physics.torso_position()
    last, ended, records = score.step_policy(
        policy, env.task, physics, observation, settings.steps, n_sub, _servo_state
    )
    force, velocity = (np.array(c) for c in zip(*records))
    loss = electrical.copper_loss(force, velocity, physics.servo_damping())
    distance = float((start if last is None else last)[0] - start[0])
    names = [physics.model.id2name(i, "actuator") for i in range(physics.model.nu)]
    return distance, bool(ended[0]), loss, float(physics.model.opt.timestep), names


def minutes_to_limit(temperature: np.ndarray) -> float:
    """Minutes (rows of 1 s) until any servo reaches the limit; inf if none does."""
    hot = np.flatnonzero(np.any(temperature >= thermal.SHUTDOWN_TEMPERATURE, axis=1))
    return (hot[0] + 1) / 60.0 if hot.size else float("inf")


def going_on(mean_loss: np.ndarray, motor: thermal.MotorThermal, coefficient: float):
    """Winding and housing temperatures, a row a second for `EXTRAPOLATION` s, of servos
    whose losses stay at `mean_loss` (W at 25 °C) from 25 °C."""
    losses = np.tile(np.atleast_1d(mean_loss), (EXTRAPOLATION, 1))
    return thermal.temperatures(losses, 1.0, motor, coefficient)


def trial_rows(run: str, seed: int, distance, failed, loss, timestep, names) -> list[list]:
    """The trial's rows of trials.csv, one per motor (`FIELDS`).

    Args:
      run: The run's folder under the shipped runs.
      seed: The trial's test seed.
      distance, failed, loss, timestep, names: `trial_losses`' values.
    """
    mean = loss.mean(axis=0)
    hottest = int(np.argmax(mean))
    rows = []
    for name, motor in thermal.MOTORS.items():
        winding, housing = thermal.temperatures(loss, timestep, motor)
        on_w, on_h = going_on(mean, motor, thermal.COPPER_COEFFICIENT)
        rows.append([
            run, seed, f"{distance:.4f}", int(failed), name, names[hottest],
            f"{mean[hottest]:.4f}", f"{winding.max():.2f}", f"{housing.max():.2f}",
            f"{minutes_to_limit(on_w):.2f}", f"{minutes_to_limit(on_h):.2f}",
        ])  # fmt: skip
    return rows


def _without_coefficient(row: pd.Series) -> float:
    """Minutes to the winding's limit of the row's hottest servo at α = 0."""
    winding, _ = going_on(row["mean_loss_w"], thermal.MOTORS[row["motor"]], 0.0)
    return minutes_to_limit(winding)


def summary(path: str) -> str:
    """The markdown table of a trials.csv, a row per configuration and motor.

    Columns: walked trials (not failed) of all; the servos most often hottest; their mean
    loss (median over all trials); the trials whose winding reached 80 °C within the trial;
    the medians over the walked trials of the minutes to 80 °C, had they gone on, of the
    winding, of the housing, and of the winding without the copper's coefficient (α = 0).
    """
    trials = pd.read_csv(path)
    trials["configuration"] = trials["run"].str.replace(r"seed\d+$", "", regex=True)
    lines = [
        "| configuration | motor | walked | hottest servos | loss, W | winding ≥ 80 °C in "
        "the trial | minutes to 80 °C: winding, housing; winding at α = 0 |",
        "|---|---|---|---|---|---|---|",
    ]
    for (name, motor), group in trials.groupby(["configuration", "motor"], sort=False):
        walked = group[group["failed"] == 0]
        servos = ", ".join(group["hottest_servo"].value_counts().index[:2])
        hot = int((group["winding_peak_c"] >= thermal.SHUTDOWN_TEMPERATURE).sum())
        minutes = "—"
        if len(walked):
            flat = walked.apply(_without_coefficient, axis=1).median()
            minutes = (
                f"{walked['minutes_to_limit_winding'].median():.1f}, "
                f"{walked['minutes_to_limit_housing'].median():.1f}; {flat:.1f}"
            )
        lines.append(
            f"| {name.rstrip('_/')} | {motor} | {len(walked)} of {len(group)} | {servos} | "
            f"{group['mean_loss_w'].median():.2f} | {hot} | {minutes} |"
        )
    return "\n".join(lines)


def main(argv: list[str]) -> None:
    """Writes trials.csv and prints the table (or, with --summary, only prints it)."""
    del argv
    values = flags.FLAGS
    path = os.path.join(values.out, "trials.csv")
    if values.summary:
        print(summary(path))
        return
    root = os.path.join(verify.ARTIFACTS, values.runs) if values.runs else verify.ARTIFACTS
    chosen = [
        r for r in verify.shipped_runs(root) if verify.run_settings(r).controller != "feedback"
    ]
    if not chosen:
        print(f"no shipped gait or policy runs under {root}", file=sys.stderr)
        raise SystemExit(2)
    os.makedirs(values.out, exist_ok=True)
    with open(path + ".tmp", "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(FIELDS)
        for run_dir in chosen:
            run = os.path.relpath(run_dir, verify.ARTIFACTS)
            settings, policy = verify.run_settings(run_dir), run_policy(run_dir)
            with verify.policy_threads(run_dir):
                for seed in protocol.TEST[: values.seeds]:
                    out.writerows(trial_rows(run, seed, *trial_losses(policy, settings, seed)))
            f.flush()
            print(run, flush=True)
    os.replace(path + ".tmp", path)
    print(summary(path))


if __name__ == "__main__":
    flags.DEFINE_integer("seeds", 5, "Nominal-tier test seeds per run.", lower_bound=1)
    flags.DEFINE_string("runs", "", "A subfolder of the shipped runs (default: all).")
    flags.DEFINE_string("out", HERE, "Folder of trials.csv.")
    flags.DEFINE_bool("summary", False, "Only print the table of the folder's trials.csv.")
    app.run(main)
