"""Shipped artifacts: a run ships with its trials, and `verify` reproduces (or flags) it."""

import concurrent.futures
import csv
import json
import os
import shutil
import subprocess
import sys

import cpu_variants
import pytest

from baselines import cem
from cpg_suite import protocol
from cpg_suite.protocol import admission, verify
from cpg_suite.runfiles import runs

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@pytest.fixture(scope="module")
def shipped(tmp_path_factory):
    """A small real CEM run, shipped."""
    root = tmp_path_factory.mktemp("verify")
    settings = cem.CEMSettings(
        population=4, rounds=1, trial_steps=120, validation_seeds=2, test_seeds=3
    )
    options = runs.RunOptions(output_dir=str(root / "runs"), threads=2)
    run_dir, _ = cem.run_cem(settings, options, log=lambda line: None)
    dest = verify.ship(run_dir, str(root / "shipped" / "cem" / "darwin_walk" / "run_seed0"))
    return run_dir, dest


def test_a_shipped_run_has_its_trials_versions_and_no_machine_path(shipped):
    run_dir, dest = shipped
    assert sorted(os.listdir(dest)) == [
        "best_params.json",
        "config.json",
        "progress.csv",
        "selected_params.json",
        "summary.json",
        "trials.csv",
        "versions.json",
    ]
    trials = verify.read_trials(os.path.join(dest, "trials.csv"))
    assert [t["tier"] for t in trials] == [t for t in protocol.TIERS for _ in range(3)]
    assert "--output_dir=runs" in runs.read_json(os.path.join(dest, "config.json"))["command"]
    assert set(runs.read_json(os.path.join(dest, "versions.json"))) == {"made_with", "scored_with"}
    assert all(set(t["quality"]) >= set(admission.BOARD_MEASURES) for t in trials)
    summary = runs.read_json(os.path.join(dest, "summary.json"))  # trained by this code:
    tried = {"distance_m": summary["best_distance_m"], "fell": summary["best_fell"]}
    assert summary["in_sample"] == tried  # its in-sample best tried again is its record


def test_verify_reproduces_a_shipped_run_bit_for_bit(shipped):
    _, dest = shipped
    assert verify.verify_run(dest) == []
    assert verify.verify_run(dest, quick=True) == []


def test_verify_flags_a_changed_trial_and_a_changed_card(shipped, tmp_path):
    _, dest = shipped
    copy = _copy(dest, tmp_path / "copy")
    with open(copy / "trials.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    rows[0]["distance_m"] = repr(float(rows[0]["distance_m"]) + 1e-12)
    runs.write_rows_csv(str(copy / "trials.csv"), rows)
    assert verify.verify_run(str(copy)) == ["1 trials differ from trials.csv"]
    summary = json.loads((copy / "summary.json").read_text())
    summary["test"]["all"]["fall_rate"]["value"] = 0.5
    (copy / "summary.json").write_text(json.dumps(summary))
    assert "the score card differs from summary.json" in verify.verify_run(str(copy))
    logged = []
    assert verify.verify(str(tmp_path), log=logged.append) == 1
    assert logged[-1] == "0 of 1 shipped runs reproduced bit for bit"


def _copy(dest, to):
    to.mkdir()
    for name in os.listdir(dest):
        (to / name).write_bytes(open(os.path.join(dest, name), "rb").read())
    return to


def test_update_card_restores_a_card_only_while_the_trials_hold(shipped, tmp_path):
    _, dest = shipped
    copy = _copy(dest, tmp_path / "copy")
    summary = json.loads((copy / "summary.json").read_text())
    del summary["test"]["all"]["quality"]["energy_per_m"]  # a card older than a measure
    (copy / "summary.json").write_text(json.dumps(summary))
    assert verify.verify_run(str(copy)) == ["the score card differs from summary.json"]
    verify.update_card(str(copy))
    assert verify.verify_run(str(copy)) == []
    with open(copy / "trials.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    rows[-1]["fell"] = str(rows[-1]["fell"] != "True")
    rows[-1]["cause"] = "fall" if rows[-1]["fell"] == "True" else ""  # the scorer's spelling
    runs.write_rows_csv(str(copy / "trials.csv"), rows)
    stored = (copy / "summary.json").read_text()
    with pytest.raises(ValueError, match="its trials changed"):
        verify.update_card(str(copy))
    assert (copy / "summary.json").read_text() == stored


@pytest.mark.slow
def test_update_cards_records_each_stored_card_in_the_ledger(tmp_path):
    """`--update_cards --record`: a run whose card is stored is recorded as re-scored in full,
    with the digest of its files as they are after the update (not before). A shipped run
    under the protocol's settings (the board admits no other; a full re-score, ~1-2 min)."""
    shipped = os.path.join(ROOT, "results", "protocol", "runs", "cem", "darwin_walk")
    (tmp_path / "cem").mkdir()
    copy = tmp_path / "cem" / "darwin_walk" / "run_seed0"
    shutil.copytree(os.path.join(shipped, "K50_n0.8_e2_seed0"), copy)
    summary = json.loads((copy / "summary.json").read_text())
    cards = {"trials.csv": summary["test"], "trials_v2.csv": summary["history"]["v2"]}
    for name, card in cards.items():  # cards and tables older than a measure
        for row in [card["all"], *card["tiers"].values()]:
            del row["quality"]["flight_share"]
        with open(copy / name, newline="") as f:
            rows = [{k: v for k, v in r.items() if k != "flight_share"} for r in csv.DictReader(f)]
        runs.write_rows_csv(str(copy / name), rows)
    (copy / "summary.json").write_text(json.dumps(summary))
    assert admission.run_refusal(str(copy)) is None
    old_digest = admission.run_digest(str(copy))
    ledger = str(tmp_path / "rescored.csv")
    verify.update_cards([str(copy)], threads=1, record=ledger)
    assert verify.verify_run(str(copy)) == []
    row = admission.read_ledger(ledger)[admission.run_key(str(copy))]
    assert (row["check"], row["result"]) == ("full", "reproduced")
    assert row["files_sha256"] == admission.run_digest(str(copy)) != old_digest
    stored = json.loads((copy / "summary.json").read_text())
    assert "flight_share" in stored["test"]["all"]["quality"]  # the card gained it back,
    assert "flight_share" in verify.read_trials(str(copy / "trials.csv"))[0]["quality"]  # its table


def test_rescore_run_stores_the_trials_and_card_the_code_gives_now(shipped, tmp_path):
    _, dest = shipped
    copy = _copy(dest, tmp_path / "copy")
    with open(copy / "trials.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    rows[0]["distance_m"] = repr(float(rows[0]["distance_m"]) + 0.5)  # as scored by other code
    runs.write_rows_csv(str(copy / "trials.csv"), rows)
    summary = json.loads((copy / "summary.json").read_text())
    summary["test"]["all"]["fall_rate"]["value"] = 0.5
    (copy / "summary.json").write_text(json.dumps(summary))
    assert len(verify.verify_run(str(copy))) == 2
    verify.rescore_run(str(copy))
    assert verify.verify_run(str(copy)) == []
    assert (copy / "trials.csv").read_bytes() == open(f"{dest}/trials.csv", "rb").read()
    before = {p.name: p.read_bytes() for p in copy.iterdir()}
    verify.rescore_run(str(copy))  # its cards reproduce: it keeps its files, byte for byte
    assert {p.name: p.read_bytes() for p in copy.iterdir()} == before


V1_RUN = os.path.join(ROOT, verify.ARTIFACTS, "cem", "darwin_walk", "K50_n0.8_e2_v1_seed0")


def _inflate_first_v1_trial(run):
    """The version-1 card's first trial walks 1 m more, its history card made from the
    table as a card makes it: the board's file checks cannot tell (version 1 scores other
    physics than the test card), only scoring it again can."""
    rows = admission.read_trials(str(run / "trials_v1.csv"))
    with open(run / "trials_v1.csv", newline="") as f:
        raw = list(csv.DictReader(f))
    raw[0]["distance_m"] = repr(rows[0]["distance_m"] + 1.0)
    runs.write_rows_csv(str(run / "trials_v1.csv"), raw)
    rows = admission.read_trials(str(run / "trials_v1.csv"))
    summary = json.loads((run / "summary.json").read_text())
    kept = summary["history"]["v1"]
    for tier in kept["tiers"]:
        made = admission._card_row([t for t in rows if t["tier"] == tier], 1000)
        kept["tiers"][tier].update(admission._jsonable(admission._without_quality(made)))
    kept["all"].update(
        admission._jsonable(admission._without_quality(admission._card_row(rows, 1000)))
    )
    (run / "summary.json").write_text(json.dumps(summary, indent=2))


def test_verify_scores_a_version_1_history_card_again(tmp_path):
    """The cards a run keeps as history: a version-2 card's table the board holds to the
    test card's; a version-1 card (no supply limit) verify scores again, quick and full."""
    summary = json.loads(open(os.path.join(V1_RUN, "summary.json")).read())
    assert [v for v, _ in admission.unvouched_history(summary)] == [1]
    assert admission.full_check_trials(summary) == 250 + 200
    v2_only = json.loads(
        open(
            os.path.join(
                ROOT, verify.ARTIFACTS, "cem", "darwin_walk", "K50_n0.8_e2_seed0", "summary.json"
            )
        ).read()
    )
    assert (
        admission.unvouched_history(v2_only) == [] and admission.full_check_trials(v2_only) == 250
    )
    copy = tmp_path / "cem" / "darwin_walk" / "K50_v1_seed0"
    shutil.copytree(V1_RUN, copy)
    assert verify.history_problems(str(copy), summary, seeds=2, threads=1) == []
    _inflate_first_v1_trial(copy)
    assert admission.refusals([str(copy)]) == {}  # admitted on its files
    assert verify.history_problems(
        str(copy), json.loads((copy / "summary.json").read_text()), seeds=2, threads=1
    ) == ["1 trials differ from trials_v1.csv"]


def test_a_card_extends_an_older_one_only_by_new_keys():
    stored = {"all": {"n": 3, "quality": {"peak_joint_speed": 4.0}}}
    fresh = {"all": {"n": 3, "quality": {"peak_joint_speed": 4.0, "energy_per_m": 9.0}}}
    assert verify.extends(fresh, stored) and verify.extends(stored, stored)
    assert not verify.extends(stored, fresh)  # a measure missing
    changed = {"all": {"n": 3, "quality": {"peak_joint_speed": 4.5, "energy_per_m": 9.0}}}
    assert not verify.extends(changed, stored)


@pytest.mark.parametrize("configuration", ["cem/darwin_walk", "ppo_mjx/darwin_walk"])
def test_a_shipped_reference_run_reproduces_quickly(configuration):
    """A shipped CEM run and a PPO-on-MJX run (the first: `cpg`, its CPG inside the policy's
    loop), re-scored on their first test seeds here; the slow tier does every configuration
    as on two other CPUs (`cpu_variants.machines`)."""
    artifacts = os.path.join(ROOT, verify.ARTIFACTS)
    shipped = verify.shipped_runs(os.path.join(artifacts, configuration))
    assert shipped, f"results/protocol/runs ships no {configuration} run"
    assert verify.verify_run(shipped[0], quick=True) == []


@pytest.mark.slow
def test_the_reference_artifacts_reproduce_under_every_cpu_variant():
    """`verify --quick` as on two other CPUs (`cpu_variants.machines`: an AVX2 one and one
    without AVX2, every library's variant at once), side by side on one evaluator thread
    each. Natively, every run is re-scored by test_board_sample (a sample of its trials)
    and the fast tier (--quick's trials of two runs); NumPy's and OpenBLAS's variants one
    at a time by test_portable (torch's only here, within the two machines)."""
    artifacts = os.path.join(ROOT, verify.ARTIFACTS)
    command = ["-m", "cpg_suite.protocol.verify", "--quick", "--threads=1", "--jobs=1"]
    other = {k: v for k, v in cpu_variants.machines().items() if v}
    pending, failures = list(other.items()), []
    while pending:
        batch, pending = pending[:2], pending[2:]
        children = [
            (name, cpu_variants.start(variant, [*command, f"--artifacts={artifacts}"]))
            for name, variant in batch
        ]
        for name, child in children:
            stdout, stderr = child.communicate(timeout=1800)
            lines = stdout.strip().splitlines()
            if child.returncode != 0 or not lines or "DIFF" in stdout:
                failures.append(f"{name}: {[x for x in lines if 'DIFF' in x] or stderr[-500:]}")
    runs_checked = len(verify._quick_sample(verify.shipped_runs(artifacts)))
    assert runs_checked >= 8
    assert not failures, "\n".join(failures)


def test_cli_without_artifacts_is_one_line(tmp_path):
    out = subprocess.run(
        [sys.executable, "-m", "cpg_suite.protocol.verify", f"--artifacts={tmp_path}/none"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 2
    assert out.stderr.splitlines() == [f"error: --artifacts={tmp_path}/none is not a directory"]


def test_cli_rescore_of_a_missing_folder_is_one_line(tmp_path):
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "cpg_suite.protocol.verify",
            f"--artifacts={tmp_path}",
            "--rescore=ppo_mjx",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 2
    assert out.stderr.splitlines() == [f"error: --rescore=ppo_mjx is not a folder of {tmp_path}"]


def test_verify_in_processes_records_each_run_as_it_is_done(tmp_path):
    """`--jobs=2 --record`: every run's row is written when its process finishes it (a stop
    keeps what was checked), and the log still lists the runs in path order."""
    tree = tmp_path / "protocol" / "runs" / "cem" / "darwin_walk"
    for seed in (0, 1):
        source = os.path.join(
            ROOT, verify.ARTIFACTS, "cem", "darwin_walk", f"K50_n0.8_e2_seed{seed}"
        )
        shutil.copytree(source, tree / f"K50_n0.8_e2_seed{seed}")
    ledger = str(tmp_path / "protocol" / admission.LEDGER)
    logged = []
    failed = verify.verify(
        str(tmp_path / "protocol" / "runs"), log=logged.append, jobs=2, threads=1,
        sample_trials=1, entropy=7, record=ledger,
    )  # fmt: skip
    assert failed == 0
    assert [line.split("/")[-1] for line in logged[1:3]] == [
        "K50_n0.8_e2_seed0",
        "K50_n0.8_e2_seed1",
    ]
    rows = admission.read_ledger(ledger)
    assert sorted(rows) == [f"cem/darwin_walk/K50_n0.8_e2_seed{s}" for s in (0, 1)]
    assert {(r["check"], r["result"]) for r in rows.values()} == {("sample 1", "reproduced")}


def test_a_run_done_early_is_recorded_before_an_earlier_one_in_path_order(tmp_path):
    """The first run in path order still running, the second done: its row is written now,
    not when the first ends (a stop then keeps it)."""
    import threading
    import time

    tree = tmp_path / "protocol" / "runs" / "cem" / "darwin_walk"
    dirs = []
    for seed in (0, 1):
        source = os.path.join(
            ROOT, verify.ARTIFACTS, "cem", "darwin_walk", f"K50_n0.8_e2_seed{seed}"
        )
        dirs.append(str(shutil.copytree(source, tree / f"K50_n0.8_e2_seed{seed}")))
    ledger = str(tmp_path / "protocol" / admission.LEDGER)
    release = threading.Event()
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        futures = {  # `_check_run`'s results: problems, the digest checked
            dirs[0]: pool.submit(lambda: release.wait(60) and ([], None)),
            dirs[1]: pool.submit(lambda: ([], None)),
        }
        writer = threading.Thread(target=verify._record_as_done, args=(ledger, futures, 0))
        writer.start()
        for _ in range(200):
            if os.path.exists(ledger):
                break
            time.sleep(0.05)
        assert sorted(admission.read_ledger(ledger)) == ["cem/darwin_walk/K50_n0.8_e2_seed1"]
        release.set()
        writer.join(60)
    assert len(admission.read_ledger(ledger)) == 2


def test_a_summary_s_bytes_do_not_depend_on_the_order_its_parts_were_made(tmp_path):
    """An upgrade after the in-sample check and one before it write the same file (the slow
    upgrade test failed on key order alone): the training record, then test, history and
    in-sample."""
    trained = {"best_distance_m": 1.5, "rounds": 3}
    parts = {"test": {"n": 1}, "history": {"v2": {"n": 1}}, "in_sample": {"fell": False}}
    written = []
    for order in (("in_sample", "history", "test"), ("test", "history", "in_sample")):
        path = tmp_path / f"{order[0]}.json"
        verify._write_summary(str(path), {**{k: parts[k] for k in order}, **trained})
        written.append(path.read_bytes())
    assert written[0] == written[1]
    assert list(json.loads(written[0])) == ["best_distance_m", "rounds", *verify.SCORED_KEYS]
