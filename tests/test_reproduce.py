"""`python -m analysis.reproduce --quick` runs every experiment small, writes the report and
ends with the study's verdicts judged from its own runs beside the shipped ones (the CI
smoke test of the whole pipeline, a few minutes)."""

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
    assert {"pole_balance", "crawler_walk", "tokic", "darwin_balance"} <= tasks
    # DARwIn walking rows count admitted runs only, and the board admits none of a quick
    # reproduction's (2 seeds, short trials: its report says so)
    assert "darwin_walk" not in tasks
    report = (tmp_path / "report.md").read_text()
    assert "(no data)" not in report
    # The study's verdicts from these runs only, beside the shipped ones, every claim.
    with open(tmp_path / "claims.csv", encoding="utf-8") as f:
        here = {r["id"]: r for r in csv.DictReader(f)}
    with open("results/study/claims.csv", encoding="utf-8") as f:
        shipped = {r["id"]: r for r in csv.DictReader(f)}
    assert set(here) == set(shipped)
    # Computed from these runs: the Tokic model's claims are judged, not missing.
    assert here["CR-1b"]["verdict"] == shipped["CR-1b"]["verdict"] == "holds"
    # Too few seeds is inconclusive, naming the runs, never a fallback on shipped runs.
    assert here["CEM-14a"]["verdict"] == "inconclusive"
    assert "of 5 seeds" in here["CEM-14a"]["why"]
    verdicts = (tmp_path / "verdicts.md").read_text()
    assert "| CR-1b | holds | holds |" in verdicts
    assert "| claim | here | shipped |" in out.stdout
    assert "the study's full evidence took" in out.stdout


def test_needs_quick_or_full(tmp_path):
    out = subprocess.run(
        [sys.executable, "-m", "analysis.reproduce", f"--out={tmp_path}"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 2
