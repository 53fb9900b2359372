"""Attacks on the re-score ledger: a run whose files were edited may not be shown as
re-scored in full, whether edited before `update_cards` or after its row was written."""

import json
import os
import shutil

import numpy as np
import pytest

from cpg_suite.protocol import admission, verify

SHIPPED = os.path.join("results", "protocol", "runs", "cem", "darwin_walk", "K50_n0.8_e2_seed0")


def _copy(tmp_path, name="X_seed0"):
    if not os.path.isdir(SHIPPED):
        pytest.skip("no shipped run")
    run_dir = tmp_path / "cem" / "darwin_walk" / name
    shutil.copytree(SHIPPED, run_dir)
    return str(run_dir)


def _edit_trials(run_dir):
    path = os.path.join(run_dir, "trials.csv")
    with open(path, encoding="utf-8") as f:
        lines = f.read().splitlines(keepends=True)
    fields = lines[1].split(",")
    fields[2] = str(float(fields[2]) + 0.5)  # distance_m of the first trial
    lines[1] = ",".join(fields)
    with open(path, "w", encoding="utf-8") as f:
        f.writelines(lines)


def _edit_gait(run_dir):
    path = os.path.join(run_dir, admission.GAIT)
    with open(path, encoding="utf-8") as f:
        gait = json.load(f)
    gait["amplitudes"]["knee"] *= 1.2
    with open(path, "w", encoding="utf-8") as f:
        json.dump(gait, f)


def _ledger_row(tmp_path, run_dir):
    ledger = str(tmp_path / "rescored.csv")
    verify.write_ledger(ledger, {run_dir: []})  # as update_cards writes it
    return ledger


@pytest.mark.parametrize("edit", [_edit_trials, _edit_gait], ids=["trials", "gait"])
def test_row_does_not_survive_a_later_edit(tmp_path, edit):
    run_dir = _copy(tmp_path)
    ledger = _ledger_row(tmp_path, run_dir)
    assert admission.rescored_in_full(run_dir, admission.read_ledger(ledger))
    edit(run_dir)
    assert admission.rescored_in_full(run_dir, admission.read_ledger(ledger)) is None


def test_row_does_not_survive_a_card_edit(tmp_path):
    run_dir = _copy(tmp_path)
    ledger = _ledger_row(tmp_path, run_dir)
    path = os.path.join(run_dir, "summary.json")
    with open(path, encoding="utf-8") as f:
        summary = json.load(f)
    summary["test"]["edited"] = 1
    with open(path, "w", encoding="utf-8") as f:
        json.dump(summary, f)
    assert admission.rescored_in_full(run_dir, admission.read_ledger(ledger)) is None


def test_row_does_not_survive_a_new_artifact_that_outranks_the_gait(tmp_path):
    """A policy file verify would score before the gait, dropped in after the row."""
    run_dir = _copy(tmp_path)
    ledger = _ledger_row(tmp_path, run_dir)
    np.save(os.path.join(run_dir, admission.ACTIONS), np.zeros((3, 2)))
    assert admission.rescored_in_full(run_dir, admission.read_ledger(ledger)) is None


def test_row_is_keyed_to_its_own_run(tmp_path):
    run_dir = _copy(tmp_path)
    other = _copy(tmp_path, "Y_seed0")
    ledger = _ledger_row(tmp_path, run_dir)
    assert admission.rescored_in_full(other, admission.read_ledger(ledger)) is None


def test_sampled_or_differing_rows_are_not_full(tmp_path):
    run_dir = _copy(tmp_path)
    ledger = str(tmp_path / "rescored.csv")
    verify.write_ledger(ledger, {run_dir: []}, sample_trials=5)
    assert admission.rescored_in_full(run_dir, admission.read_ledger(ledger)) is None
    verify.write_ledger(ledger, {run_dir: ["trial 0 differs"]})
    assert admission.rescored_in_full(run_dir, admission.read_ledger(ledger)) is None


@pytest.mark.slow
@pytest.mark.parametrize("edit", [_edit_trials, _edit_gait], ids=["trials", "gait"])
def test_update_cards_refuses_an_edited_run(tmp_path, edit):
    """Re-scores a full run (~1-2 min): an edited run gets no card and no ledger row."""
    run_dir = _copy(tmp_path)
    edit(run_dir)
    with open(os.path.join(run_dir, "summary.json"), "rb") as f:
        summary = f.read()
    ledger = str(tmp_path / "rescored.csv")
    with pytest.raises(ValueError, match=r"trials changed|trial table"):
        verify.update_cards([run_dir], threads=1, record=ledger)
    assert admission.read_ledger(ledger) == {}
    with open(os.path.join(run_dir, "summary.json"), "rb") as f:
        assert f.read() == summary


@pytest.mark.parametrize("call", ["update_cards", "upgrade_run"])
def test_maintenance_calls_refuse_what_the_board_refuses(tmp_path, call):
    """As library calls, not only through the CLI: a run the board refuses (a copy shipped
    as a second seed; a run whose card was edited) gets no card and no ledger row, and
    nothing is scored first (this test scores nothing: it takes seconds)."""
    first, second = _copy(tmp_path, "X_seed0"), _copy(tmp_path, "X_seed1")
    config_path = os.path.join(second, "config.json")
    with open(config_path, encoding="utf-8") as f:
        config = json.load(f)
    config["settings"]["seed"] = 1  # its folder's seed: a copy passed off as a second seed
    with open(config_path, "w", encoding="utf-8") as f:
        json.dump(config, f)
    ledger = str(tmp_path / "rescored.csv")
    if call == "update_cards":
        before = _files(tmp_path)
        with pytest.raises(verify.NotAdmitted, match=r"X_seed1: .*cop"):
            verify.update_cards([first, second], threads=1, record=ledger)
        assert _files(tmp_path) == before
    summary_path = os.path.join(second, "summary.json")
    with open(summary_path, encoding="utf-8") as f:
        summary = json.load(f)
    summary["test"]["all"]["fall_rate"]["value"] = 0.0
    with open(summary_path, "w", encoding="utf-8") as f:
        json.dump(summary, f)
    before = _files(tmp_path)
    with pytest.raises(verify.NotAdmitted, match=r"X_seed1: "):
        if call == "update_cards":
            verify.update_cards([second], threads=1, record=ledger)
        else:
            verify.upgrade_run(second, version=1, threads=1)
    assert _files(tmp_path) == before


def _files(root) -> dict:
    return {str(p): p.read_bytes() for p in root.rglob("*") if p.is_file()}


def test_a_row_that_scored_fewer_cards_than_a_full_check_is_not_full(tmp_path):
    """A run keeping a version-1 card: a full check now scores it too (450 trials); a row of
    an earlier check that scored the test card's 250 only is no full re-score."""
    source = os.path.join(
        "results", "protocol", "runs", "cem", "darwin_walk", "K50_n0.8_e2_v1_seed0"
    )
    if not os.path.isdir(source):
        pytest.skip("no shipped run")
    run_dir = str(tmp_path / "cem" / "darwin_walk" / "K50_v1_seed0")
    shutil.copytree(source, run_dir)
    ledger = _ledger_row(tmp_path, run_dir)
    row = admission.read_ledger(ledger)[admission.run_key(run_dir)]
    assert row["trials"] == "450" and admission.rescored_in_full(run_dir, {row["run"]: row})
    earlier = {**row, "trials": "250"}
    assert admission.rescored_in_full(run_dir, {row["run"]: earlier}) is None


def test_a_short_or_symlinked_ledger_row_is_no_record(tmp_path):
    """A row cut short (its check and result missing) is no re-score and breaks nothing; a
    ledger that is a symbolic link is not read as the board's record."""
    run_dir = _copy(tmp_path)
    ledger = tmp_path / "rescored.csv"
    ledger.write_text(
        ",".join(admission.LEDGER_FIELDS) + "\n" + f"{admission.run_key(run_dir)},"
        f"{admission.run_digest(run_dir)}\n"
    )
    rows = admission.read_ledger(str(ledger))
    assert rows[admission.run_key(run_dir)]["check"] == ""
    assert admission.rescored_in_full(run_dir, rows) is None
    assert admission.refusals([run_dir]) == {}
    real = tmp_path / "elsewhere.csv"
    ledger.rename(real)
    ledger.symlink_to(real)
    with pytest.raises(ValueError, match="symbolic link"):
        admission.read_ledger(str(ledger))
