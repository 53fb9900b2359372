"""`python -m analysis.reproduce --quick` runs every experiment small and writes the report
(the CI smoke test of the whole pipeline, about two minutes)."""

import csv
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow  # re-runs the study's experiments


def test_quick_reproduction(tmp_path):
    out = subprocess.run(
        [sys.executable, "-m", "analysis.reproduce", "--quick", f"--out={tmp_path}"],
        capture_output=True,
        text=True,
        timeout=1200,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    for name in (
        "leaderboard.csv",
        "report.md",
        "cem_rounds.png",
        "rms_error.png",
        "pole_angles.png",
        "value_evolution.png",
        "joint_trajectories.png",
    ):
        assert (tmp_path / name).stat().st_size > 0, name
    with open(tmp_path / "leaderboard.csv", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    tasks = {r["task"] for r in rows}
    assert {"darwin_walk", "pole_balance", "crawler_walk", "tokic", "darwin_balance"} <= tasks
    report = (tmp_path / "report.md").read_text()
    assert "(no data)" not in report


def test_needs_quick_or_full(tmp_path):
    out = subprocess.run(
        [sys.executable, "-m", "analysis.reproduce", f"--out={tmp_path}"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 2
