"""Runs trained without the supply limit beside the same seeds trained under it.

    python investigations/limit_check.py

For each run here (trained under benchmark version 1 with the code of commit 165bf9d), and
its namesake in `results/protocol/runs/` (trained under version 2): whether every round of
`progress.csv` is the same (all columns but the timings) and the selected gait the same.
"""

from __future__ import annotations

import csv
import json
import os

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # the repository
HERE = os.path.join(ROOT, "results", "protocol", "limit_check")  # the runs it compares
RUNS = os.path.join(ROOT, "results", "protocol", "runs")
TIMINGS = ("steps_per_s", "wall_s")


def _rounds(path: str) -> list[dict]:
    with open(os.path.join(path, "progress.csv"), encoding="utf-8") as f:
        return [{k: v for k, v in row.items() if k not in TIMINGS} for row in csv.DictReader(f)]


def _gait(path: str):
    with open(os.path.join(path, "selected_params.json"), encoding="utf-8") as f:
        return json.load(f)


def main() -> None:
    for dirpath, _, names in sorted(os.walk(HERE)):
        if "progress.csv" not in names:
            continue
        run = os.path.relpath(dirpath, HERE)
        other = os.path.join(RUNS, run)
        same_rounds = _rounds(dirpath) == _rounds(other)
        same_gait = _gait(dirpath) == _gait(other)
        print(f"{run}: every round the same: {same_rounds}; the same gait: {same_gait}")


if __name__ == "__main__":
    main()
