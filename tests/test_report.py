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


def test_the_best_gait_shown_is_the_one_the_board_can_check(tmp_path):
    """The figures' best gait (Fig. 6.8-6.9) is chosen by the in-sample best tried again
    (`in_sample`, which verify re-makes), never by a training record a run's summary.json
    merely states; a value that is no finite number counts for nothing; only with no run
    tried again is the training record used, and the figure says it is unchecked."""
    from analysis import report
    from cpg_suite.protocol import admission

    def run(name, summary, method="cem", task="darwin_walk", gait=True):
        folder = tmp_path / name
        folder.mkdir()
        if gait:
            (folder / admission.IN_SAMPLE).write_text("{}")
        return {"dir": str(folder), "method": method, "task": task, "summary": summary}

    forged = run("forged", {"best_distance_m": 99.0})  # no in_sample: never tried again
    tried = run("tried", {"best_distance_m": 1.0, "in_sample": {"distance_m": 2.5}})
    better = run("better", {"best_distance_m": 0.5, "in_sample": {"distance_m": 3.0}})
    nan = run("nan", {"in_sample": {"distance_m": float("nan")}})
    flag = run("flag", {"in_sample": {"distance_m": True}})
    text = run("text", {"in_sample": {"distance_m": "9"}})
    other_task = run("other", {"in_sample": {"distance_m": 9.0}}, task="darwin_walk_rough")
    policy = run("policy", {"in_sample": {"distance_m": 9.0}}, method="ppo")
    no_file = run("nofile", {"in_sample": {"distance_m": 9.0}}, gait=False)
    runs = [forged, tried, better, nan, flag, text, other_task, policy, no_file]
    path, distance, checked = report._best_gait_file(runs)
    assert (path, distance, checked) == (str(tmp_path / "better" / admission.IN_SAMPLE), 3.0, True)
    path, distance, checked = report._best_gait_file([forged, nan])
    assert (path, distance, checked) == (
        str(tmp_path / "forged" / admission.IN_SAMPLE),
        99.0,
        False,
    )
    assert "unchecked" in report._best_label(distance, checked)
    assert "unchecked" not in report._best_label(3.0, True)
    assert report._best_gait_file([policy, other_task])[0] is None
