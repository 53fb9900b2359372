"""An outside method's gait, submitted: scored under the protocol into a run folder that the
board admits and verify reproduces (docs/submit.md)."""

import csv
import os
import subprocess
import sys

import numpy as np
import pytest

from analysis import leaderboard
from cpg_suite import cpg
from cpg_suite.protocol import admission, submit, verify


@pytest.mark.parametrize(
    "fields, words",
    [
        ({"method": ""}, "--method must be letters"),
        ({"method": "a/b"}, "--method must be letters"),
        ({"method": "preset"}, "--method=preset"),
        ({"seed": -1}, "--seed must be an integer"),
        ({"training_task": "darwin_walk_icy"}, "--training_task must be one of"),
        ({"evaluations": 10, "control_steps": 10}, "not both"),
        ({"evaluations": 0}, "--evaluations must be an integer"),
    ],
)
def test_a_submission_says_what_is_wrong_in_one_line(fields, words):
    with pytest.raises(ValueError, match=words):
        submit.Submission(**{"method": "mine", **fields})


def test_cli_needs_a_gait_or_a_policy(tmp_path):
    out = subprocess.run(
        [sys.executable, "-m", "cpg_suite.protocol.submit", "--method=mine", f"--root={tmp_path}"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 2
    assert out.stderr.splitlines() == ["error: give exactly one of --gait and --policy"]


@pytest.mark.slow  # scores a gait on the whole protocol (200 trials of 16 s), ~40 s
def test_a_submitted_gait_is_admitted_ranked_as_its_budget_and_verified(tmp_path):
    root = tmp_path / "runs"
    amplitudes = np.array(cpg.PRESETS["hand_tuned"]) * 1.05  # an outside method's gait
    submission = submit.Submission(
        root=str(root), method="my_search", config="K20", seed=0, evaluations=400
    )
    run_dir = submit.submit_gait(amplitudes, submission)
    assert run_dir == str(root / "my_search" / "darwin_walk" / "K20_seed0")
    assert sorted(os.listdir(run_dir)) == [
        "config.json",
        "selected_params.json",
        "summary.json",
        "trials.csv",
        "versions.json",
    ]
    assert admission.refusals([run_dir]) == {}
    out = tmp_path / "board"
    leaderboard.write_tables(str(root), str(out / "leaderboard.csv"))
    with open(out / "darwin_leaderboard.csv", newline="", encoding="utf-8") as f:
        (row,) = list(csv.DictReader(f))
    assert (row["method"], row["config"], row["track"], row["status"]) == (
        "my_search",
        "K20",
        "study",
        "provisional",  # one seed of five
    )
    logged = []
    assert verify.verify(str(root), quick=True, log=logged.append) == 0
    assert logged[-1] == "1 of 1 shipped runs reproduced bit for bit"
    with pytest.raises(ValueError, match="exists"):
        submit.submit_gait(amplitudes, submission)
