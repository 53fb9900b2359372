"""analysis.report: figures and report.md from a small run tree."""

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from analysis import report
from baselines import cem
from baselines.tabular import runner
from cpg_suite.runfiles import runs as baselines_runs


def test_report_from_small_runs(tmp_path):
    runs = tmp_path / "runs"
    cem.run_cem(
        cem.CEMSettings(population=3, elite=1, rounds=2, trial_steps=60),
        baselines_runs.RunOptions(output_dir=str(runs), run_name="K3_n0.8_e1_seed0"),
        log=lambda line: None,
    )
    runner.execute(
        {
            "task": "pole_balance",
            "algo": "q_learning",
            "steps": 300,
            "output_dir": str(runs),
            "run_name": "base_seed0",
            "seed": 0,
        }
    )
    runner.execute(
        {
            "task": "crawler_walk",
            "algo": "value_iteration",
            "realtime": True,
            "steps": 300,
            "output_dir": str(runs),
            "run_name": "value_iteration_seed0",
            "seed": 0,
        }
    )
    bad = runs / "cem" / "darwin_walk" / "junk_seed9"
    bad.mkdir()
    (bad / "summary.json").write_text("nope")
    out = tmp_path / "report"
    line = report.write_report(str(runs), str(out))
    assert line.endswith(f"-> {out}")
    text = (out / "report.md").read_text()
    for name in ("cem_rounds.png", "joint_trajectories.png", "rms_error.png", "pole_angles.png"):
        assert (out / name).stat().st_size > 5000
        assert f"({name})" in text
    assert "junk_seed9" in text  # listed as skipped
    assert (out / "leaderboard.csv").exists() and not (out / "claims.csv").exists()
    assert "python -m analysis.study" in text
    assert np.isfinite(float((out / "leaderboard.csv").read_text().splitlines()[1].split(",")[6]))


def test_the_report_reads_run_files_as_the_board_does(tmp_path):
    """A third outside attack: a run's progress.csv a FIFO (a plain `open` waits forever for
    a writer) or a link to /dev/zero; a refused run's budget that is no count."""
    import os

    from analysis import leaderboard, report

    fifo = tmp_path / "progress.csv"
    os.mkfifo(fifo)
    assert report._read_csv(str(fifo)) == []
    (tmp_path / "zero.csv").symlink_to("/dev/zero")
    assert report._read_csv(str(tmp_path / "zero.csv")) == []
    assert leaderboard.budget_track([{"evaluations": "2501"}]) == "over_4x"
    assert leaderboard.budget_track([{"evaluations": 2501}]) == "study"
