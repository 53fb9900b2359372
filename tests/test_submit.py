"""An outside method's gait, action table or policy code, submitted: scored under the
protocol into a run folder that the board admits and verify reproduces (docs/submit.md)."""

import csv
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from analysis import leaderboard
from cpg_suite import cpg
from cpg_suite.protocol import admission, score, submit, verify
from cpg_suite.runfiles import exported

# How verify --quick ends on a tree without a ledger (no run on record in full).
QUICK = (
    "on --quick's trials (the first 5 test seeds a tier), 0 of them on record as re-scored in full"
)


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
    assert out.stderr.splitlines() == [
        "error: give exactly one of --gait, --policy, --actions and --code"
    ]


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
    assert logged[-1] == f"1 of 1 shipped runs reproduced bit for bit {QUICK}"
    with pytest.raises(ValueError, match="exists"):
        submit.submit_gait(amplitudes, submission)


def _board_row(root, out):
    leaderboard.write_tables(str(root), str(out / "leaderboard.csv"))
    with open(out / "darwin_not_admitted.csv", newline="", encoding="utf-8") as f:
        assert list(csv.DictReader(f)) == []
    with open(out / "darwin_leaderboard.csv", newline="", encoding="utf-8") as f:
        (row,) = list(csv.DictReader(f))
    return row


def test_an_action_table_plays_row_t_at_step_t_as_the_gait_it_was_made_from():
    """A table of a CPG gait's actions scores that gait's trials and card, bit for bit."""
    amplitudes = cpg.amplitudes_from("hand_tuned")
    table = exported.ActionTable.from_gait(amplitudes)
    assert table.actions.shape == (1000, 12) and table.actions.dtype == np.float64
    settings = score.ScoreSettings(tiers=("darwin_walk_push",), seeds=3, steps=300)
    card, trials = score.score_policy_trials(table, settings)
    gait_card, gait_trials = score.score_gait_trials(amplitudes, settings)
    assert trials == gait_trials
    assert json.dumps(card["tiers"], sort_keys=True) == json.dumps(
        gait_card["tiers"], sort_keys=True
    )
    short = exported.ActionTable(table.actions[:10])
    short.reset()
    for _ in range(10):
        short({})
    with pytest.raises(ValueError, match="10 rows: control step 10 is past its end"):
        short({})


@pytest.mark.parametrize(
    "actions, words",
    [
        (np.zeros((1000, 11)), "must be a \\(control steps, 12\\) table"),
        (np.zeros(12), "must be a \\(control steps, 12\\) table"),
        (np.full((1000, 12), 1.5), "action space \\[-1, 1\\]"),
        (np.full((1000, 12), np.nan), "not finite"),
    ],
)
def test_an_action_table_in_another_space_is_refused(actions, words):
    with pytest.raises(ValueError, match=words):
        exported.ActionTable(actions)


def test_an_action_table_file_is_data_read_without_unpickling(tmp_path):
    table = exported.ActionTable(np.linspace(-1, 1, 24).reshape(2, 12))
    table.save(str(tmp_path / "a.npy"))
    assert np.array_equal(exported.ActionTable.load(str(tmp_path / "a.npy")).actions, table.actions)
    np.save(tmp_path / "f32.npy", table.actions.astype(np.float32))
    with pytest.raises(ValueError, match="holds float32 values, not float64"):
        exported.ActionTable.load(str(tmp_path / "f32.npy"))
    np.save(tmp_path / "objects.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(ValueError, match="allow_pickle=False"):
        exported.ActionTable.load(str(tmp_path / "objects.npy"))
    with pytest.raises(ValueError, match="one row per control step of a protocol trial"):
        submit.submit_actions(table, submit.Submission(root=str(tmp_path), method="mine"))
    assert not (tmp_path / "mine").exists()


@pytest.mark.slow  # scores an action table on the whole protocol (200 trials of 16 s), ~80 s
def test_a_submitted_action_table_is_admitted_and_verify_reproduces_it(tmp_path):
    root = tmp_path / "runs"
    amplitudes = np.array(cpg.PRESETS["hand_tuned"]) * 1.05
    actions = exported.ActionTable.from_gait(amplitudes).actions.copy()
    actions[500:] = actions[500:] * 0.9  # a time-indexed controller: not a gait any more
    submission = submit.Submission(
        root=str(root), method="my_planner", config="T1", seed=0, evaluations=100
    )
    run_dir = submit.submit_actions(actions, submission)
    assert sorted(os.listdir(run_dir)) == [
        "config.json",
        "selected_actions.npy",
        "summary.json",
        "trials.csv",
        "versions.json",
    ]
    assert np.array_equal(np.load(os.path.join(run_dir, "selected_actions.npy")), actions)
    assert admission.artifact_files(run_dir) == ("selected_actions.npy",)
    assert admission.refusals([run_dir]) == {} and verify.code_refusal(run_dir) is None
    row = _board_row(root, tmp_path / "board")
    assert (row["method"], row["config"], row["status"]) == ("my_planner", "T1", "provisional")
    out = subprocess.run(
        [sys.executable, "-m", "cpg_suite.protocol.verify", f"--artifacts={root}", "--quick"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stderr[-500:]
    assert out.stdout.splitlines() == [
        f"ok   {run_dir}",
        f"1 of 1 shipped runs reproduced bit for bit {QUICK}",
    ]
    assert verify.verify_run(run_dir) == []  # the whole card, re-scored in this process


POLICY_CODE = """
import os

import numpy as np

from cpg_suite.runfiles import exported

open(os.path.join(os.path.dirname(__file__), "executed"), "a").close()  # marks each run


def make_policy():
    amplitudes = np.array({amplitudes}) * 1.05
    return exported.ActionTable.from_gait(amplitudes)  # any callable observation -> action
"""


@pytest.mark.slow  # scores a coded policy on the whole protocol (200 trials of 16 s), ~80 s
def test_submitted_code_runs_when_submitted_and_in_verify_only_with_trust_code(
    tmp_path, monkeypatch
):
    """Also: the code given by a path relative to the working folder (as docs/submit.md
    writes `--code=my_policy.py`; its process runs in a folder of its own)."""
    code = tmp_path / "my_policy.py"
    code.write_text(POLICY_CODE.format(amplitudes=list(cpg.PRESETS["hand_tuned"])))
    root = tmp_path / "runs"
    submission = submit.Submission(root="runs", method="my_controller", seed=0)
    monkeypatch.chdir(tmp_path)  # the code and the run tree both relative to it
    run_dir = os.path.abspath(submit.submit_code("my_policy.py", submission))
    assert sorted(os.listdir(run_dir)) == [
        "config.json",
        "executed",  # written by the code while it was scored: it ran
        "policy_code.py",
        "summary.json",
        "trials.csv",
        "versions.json",
    ]
    os.remove(os.path.join(run_dir, "executed"))
    row = _board_row(root, tmp_path / "board")  # admitted on its files
    assert (row["method"], row["status"]) == ("my_controller", "reference")
    assert not os.path.exists(os.path.join(run_dir, "executed"))
    logged = []
    assert verify.verify(str(root), quick=True, log=logged.append) == 1
    assert logged == [
        f"REFUSED {run_dir}; its policy_code.py runs code: re-run with --trust_code to execute it",
        f"0 of 1 shipped runs reproduced bit for bit {QUICK}",
    ]
    assert not os.path.exists(os.path.join(run_dir, "executed"))
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "cpg_suite.protocol.verify",
            f"--artifacts={root}",
            "--quick",
            "--trust_code",
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stderr[-500:]
    assert out.stdout.splitlines()[-1] == f"1 of 1 shipped runs reproduced bit for bit {QUICK}"
    assert os.path.exists(os.path.join(run_dir, "executed"))
