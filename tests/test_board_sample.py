"""What CI checks of the board on every run (issue 51): every admitted run re-scored on 10
of its trials (issue 51 asked for 20: halved on 2026-11-29, when CI passed its 90 minutes;
`verify --sample=20` does what it asked), drawn with fresh entropy at the time of the check
(`verify --sample`), and
the board's record of full re-scores true to the files it names (`verify --record`)."""

import os
import shutil

import pytest

from analysis import leaderboard
from cpg_suite.protocol import admission, verify

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RUNS = os.path.join(ROOT, "results", "protocol", "runs")
GAIT_RUN = os.path.join(RUNS, "cem", "darwin_walk", "K50_n0.8_e2_seed0")


@pytest.mark.slow  # 103 runs × 10 trials: about 11 CPU-minutes, 6 on 2 cores
def test_every_admitted_run_reproduces_a_fresh_sample_of_its_trials():
    logged = []
    failed = verify.verify(RUNS, log=logged.append, jobs=2, sample_trials=10)
    # On a failure, the first line gives --entropy to replay the same draw.
    assert failed == 0, "\n".join([logged[0], *(line for line in logged if "ok" not in line)])
    assert logged[-1] == "103 of 103 shipped runs, 10 random trials each, reproduced bit for bit"


def test_the_ledger_counts_a_run_only_while_its_files_are_those_it_checked(tmp_path):
    runs = tmp_path / "runs"
    run = runs / "cem" / "darwin_walk" / "K50_seed0"
    shutil.copytree(GAIT_RUN, run)
    ledger = str(tmp_path / admission.LEDGER)
    verify.write_ledger(ledger, {str(run): []})
    rows = admission.read_ledger(ledger)
    assert rows["cem/darwin_walk/K50_seed0"]["check"] == "full"
    assert rows["cem/darwin_walk/K50_seed0"]["trials"] == "250"
    date = admission.rescored_in_full(str(run), rows)
    assert date and len(date) == 10
    found, _ = leaderboard.find_runs(str(runs))
    (row,) = leaderboard.darwin_rows(found)
    assert (row["rescored_full_runs"], row["rescored_full_on"]) == (1, date)
    (run / "versions.json").write_text((run / "versions.json").read_text() + " ")
    assert admission.rescored_in_full(str(run), rows) is None  # changed since: not counted
    verify.write_ledger(ledger, {str(run): ["1 trials differ from trials.csv"]}, 20)
    row = admission.read_ledger(ledger)["cem/darwin_walk/K50_seed0"]
    assert (row["check"], row["trials"], row["result"]) == ("sample 20", "20", "differs")
