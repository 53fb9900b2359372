"""A third outside attack on the board and a re-attack of its fixes (2026-11-28; each test
is an attack's minimal form): a table written in another CSV form or spelling, a ledger
planted inside a submitted tree or moved by a folder at another depth, a learner's budget
that contradicts its own counts or passes its budget, a version-1 history table the
sampled check never drew from, a gait entered again as its (shifted) action table. Each is
refused or caught."""

import json
import os
import shutil

import numpy as np
import pytest

from analysis import leaderboard
from cpg_suite import cpg
from cpg_suite.protocol import admission, copies, sample, verify
from cpg_suite.runfiles import exported

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RUNS = os.path.join(ROOT, "results", "protocol", "runs")
CMAES = os.path.join(RUNS, "cmaes", "darwin_walk")
CMAES_RANDOMIZED = os.path.join(RUNS, "cmaes", "darwin_walk_randomized", "K50_s1_seed0")
PPO = os.path.join(RUNS, "ppo", "darwin_walk", "cpg_seed0")
V1_RUN = os.path.join(RUNS, "cem", "darwin_walk", "K50_n0.8_e2_v1_seed3")


def _read(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def _write(path, value):
    with open(path, "w", encoding="utf-8") as f:
        json.dump(value, f, indent=1)


def _copy(tmp_path, source, *where):
    dest = tmp_path.joinpath("runs", *where)
    shutil.copytree(source, dest)
    return dest


@pytest.mark.parametrize(
    "rewrite",
    [
        lambda t: t.replace("\r\n", "\n"),  # Unix line endings
        lambda t: t.replace("\r\n", "\r"),  # old Mac line endings: crashed every board build
        lambda t: t + "\r\n",  # a blank line at the end
        lambda t: t.replace(",True,", ',"True",', 1),  # a cell quoted csv would not quote
        lambda t: t.replace("\r\n", ",\r\n", 1),  # an empty column named ""
        # the re-attack (helper-32): cells that read as the same trials, spelled otherwise
        lambda t: _cell(t, 1, lambda c: c.replace("2000000", "2_000_000")),
        lambda t: _cell(t, 2, lambda c: c + "000"),  # trailing zeros on a distance
        lambda t: _cell(t, 3, lambda c: "no" if c == "False" else "yes"),
        lambda t: _cell(t, 4, lambda c: "+" + c),
        lambda t: "x" * 140_000 + t,  # a cell past csv's field limit: csv.Error
    ],
)
def test_a_trial_table_in_another_csv_form_is_refused_in_one_line(tmp_path, rewrite):
    run = _copy(tmp_path, os.path.join(CMAES, "K50_s1_seed3"), "cmaes", "darwin_walk", "s_seed3")
    path = run / "trials.csv"
    path.write_bytes(rewrite(path.read_bytes().decode()).encode())
    reason = admission.run_refusal(str(run))
    assert reason is not None and "\n" not in reason
    found, _ = leaderboard.find_runs(str(tmp_path / "runs"))
    admitted, refused = leaderboard.admit(found)  # the board still builds
    assert admitted == [] and [r["reason"] for r in refused] == [reason]


def _cell(text, column, change):
    """The table's text with one cell of its first trial's row changed."""
    lines = text.split("\r\n")
    cells = lines[1].split(",")
    cells[column] = change(cells[column])
    return "\r\n".join([lines[0], ",".join(cells), *lines[2:]])


def test_every_shipped_trial_table_is_in_the_scorer_s_form():
    for dirpath, _, names in os.walk(RUNS):
        for name in names:
            if name.startswith("trials") and name.endswith(".csv"):
                admission.read_trials(os.path.join(dirpath, name))


def test_a_ledger_inside_a_submitted_tree_puts_no_run_on_record(tmp_path):
    """A run nested a folder deeper, named like a shipped seed, with a ledger row for its own
    digest beside it and an early start: the board's ledger is the one beside the outer
    tree, so the shipped seed stays and the refusal names the nested run by its path."""
    shipped = _copy(
        tmp_path, os.path.join(CMAES, "K50_s1_seed0"), "cmaes", "darwin_walk", "K50_s1_seed0"
    )
    mine = _copy(tmp_path, CMAES_RANDOMIZED, "zz", "cmaes", "darwin_walk", "K50_s1_seed0")
    config = _read(mine / "config.json")
    config["settings"].update(task="darwin_walk", eval_seeds=1)
    config["command"] = config["command"].replace("--eval_seeds=2", "--eval_seeds=1")
    config["environment"]["started_utc"] = "2000-01-01T00:00:00Z"
    _write(mine / "config.json", config)
    summary = _read(mine / "summary.json")
    _write(mine / "summary.json", {**summary, "evaluations": 2501})
    row = (
        f"cmaes/darwin_walk/K50_s1_seed0,{admission.run_digest(str(mine))},full,250,reproduced,x,x"
    )
    (tmp_path / "runs" / "rescored.csv").write_text(
        ",".join(admission.LEDGER_FIELDS) + "\n" + row + "\n"
    )
    # the board's ledger, beside the outer tree, records the shipped seed as re-scored
    shutil.copy(os.path.join(os.path.dirname(RUNS), "rescored.csv"), tmp_path / "rescored.csv")
    refused = admission.refusals(
        [str(shipped), str(mine)], ledger=admission.ledger_beside(str(tmp_path / "runs"))
    )
    assert list(refused) == [str(mine)]
    found, _ = leaderboard.find_runs(str(tmp_path / "runs"))  # the board, as it reads them
    _, board_refused = leaderboard.admit(found)
    assert [r["run"] for r in board_refused] == ["zz/cmaes/darwin_walk/K50_s1_seed0"]
    assert "(cmaes/darwin_walk/K50_s1_seed0: the first)" in refused[str(mine)]
    assert admission.shown(str(mine), str(tmp_path / "runs")) == os.path.join(
        "zz", "cmaes", "darwin_walk", "K50_s1_seed0"
    )


def test_a_folder_at_another_depth_does_not_move_the_board_s_ledger(tmp_path):
    """The re-attack (helper-32): a folder two levels under the root made every run read a
    ledger beside the root's parent (none), so a thief's copy with an earlier start won.
    The board reads the ledger beside the root it was given."""
    _copy(tmp_path, os.path.join(CMAES, "K50_s1_seed0"), "cmaes", "darwin_walk", "K50_s1_seed0")
    thief = _copy(tmp_path, os.path.join(CMAES, "K50_s1_seed0"), "thief", "darwin_walk", "s_seed0")
    config = _read(thief / "config.json")
    config["environment"]["started_utc"] = "2000-01-01T00:00:00Z"
    _write(thief / "config.json", config)
    decoy = tmp_path / "runs" / "darwin_walk_x" / "anything"
    decoy.mkdir(parents=True)
    (decoy / "config.json").write_text("{}")
    shutil.copy(os.path.join(os.path.dirname(RUNS), "rescored.csv"), tmp_path / "rescored.csv")
    found, _ = leaderboard.find_runs(str(tmp_path / "runs"))
    _, refused = leaderboard.admit(found)
    assert "thief/darwin_walk/s_seed0" in [r["run"] for r in refused]
    assert "cmaes/darwin_walk/K50_s1_seed0" not in [r["run"] for r in refused]


def test_a_learner_s_budget_may_not_contradict_its_own_counts(tmp_path):
    """A trial method restated as a learner of one control step keeps its 5,002 trials:
    refused; so is a learner whose control steps outnumber its physics steps."""
    run = _copy(tmp_path, CMAES_RANDOMIZED, "cmaes", "darwin_walk_randomized", "K50_s1_seed0")
    config = _read(run / "config.json")
    for key in ("population", "rounds", "eval_seeds"):
        config["settings"].pop(key, None)
    config["settings"]["total_steps"] = 1
    _write(run / "config.json", config)
    summary = _read(run / "summary.json")
    _write(run / "summary.json", {**summary, "env_steps": 1})
    assert "fewer than its 5002 training episodes" in admission.run_refusal(str(run))
    _write(run / "summary.json", {**summary, "env_steps": 1, "evaluations": 1, "sim_steps": 0})
    assert admission.run_refusal(str(run)) == (
        "summary.json claims 0 physics steps (sim_steps), fewer than its 1 training control "
        "steps take (8 each at least)"
    )


def test_a_learner_past_its_budget_by_more_than_a_rollout_counts_by_its_steps():
    summary = _read(os.path.join(PPO, "summary.json"))
    given = {**summary, "budget_control_steps": 2_500_000}
    assert leaderboard.budget_track([given]) == "study"  # 2,502,656: the last rollout
    assert leaderboard.budget_track([{**given, "env_steps": 2_539_520}]) == "study"
    assert leaderboard.budget_track([{**given, "env_steps": 10_000_000}]) == "4x"
    assert leaderboard.budget_track([{**given, "env_steps": 10_000_001}]) == "over_4x"
    # what it simulated counts too: 4 times the physics steps of 2.5 M control steps
    assert leaderboard.budget_track([{**given, "sim_steps": 8 * 10_000_000}]) == "4x"
    # a trial method relabelled a learner of its own trial count (helper-32)
    relabelled = {"env_steps": 10_004, "budget_control_steps": 10_004, "sim_steps": 55_000_000}
    assert leaderboard.budget_track([relabelled]) == "4x"
    cmaes = _read(os.path.join(CMAES_RANDOMIZED, "summary.json"))
    assert leaderboard.budget_track([cmaes]) == "4x"  # 5,002 trials, as before


def test_the_sampled_check_draws_from_a_version_1_history_table_too(tmp_path):
    """The version-1 board ranks a card its test trials do not vouch for: the sampled check
    re-scores trials drawn from its table, so an edited row is caught (~5 s)."""
    run = _copy(tmp_path, V1_RUN, "cem", "darwin_walk", "K50_n0.8_e2_v1_seed3")
    how = {"sample": 1, "entropy": 7, "threads": 1, "trust_code": False, "trusted": None}
    name = "cem/darwin_walk/K50_n0.8_e2_v1_seed3"
    assert verify.sample_history(str(run), how, name) == []
    table = run / "trials_v1.csv"
    stored = admission.read_trials(str(table))
    chosen = sample.draw([(t["tier"], t["seed"]) for t in stored], 1, 7, f"{name}/v1")
    [(tier, [seed])] = chosen.items()
    edited = [
        {**t, "distance_m": t["distance_m"] + 1.0} if (t["tier"], t["seed"]) == (tier, seed) else t
        for t in stored
    ]
    verify.write_trials(str(table), edited)
    assert verify.sample_history(str(run), how, name) == [
        f"{tier} seed {seed} differs from trials_v1.csv"
    ]


def _table_run(tmp_path, name, actions):
    run = tmp_path / name
    run.mkdir()
    np.save(run / "selected_actions.npy", actions, allow_pickle=False)
    return run


def test_a_gait_entered_again_as_its_action_table_is_a_copy(tmp_path):
    """A shipped open-loop gait as its own table (`ActionTable.from_gait`), its last 20 rows
    held still so its trials move by more than the trial tolerance: the same gait; a table
    of another seed's gait is not."""
    seed0 = os.path.join(CMAES, "K50_s1_seed0")
    trials = admission.read_trials(os.path.join(seed0, "trials.csv"))
    moved = [{**t, "distance_m": t["distance_m"] + 0.1} for t in trials]
    gait = copies.fingerprint(seed0, ("selected_params.json",), trials)
    table = exported.ActionTable.from_gait(cpg.load_amplitudes(f"{seed0}/selected_params.json"))
    actions = table.actions.copy()
    actions[980:] = actions[979]
    forged = _table_run(tmp_path, "forged", actions)
    forged_print = copies.fingerprint(str(forged), ("selected_actions.npy",), moved)
    assert copies.copy_of(forged_print, gait) == "gait or policy"
    assert copies.copy_of(gait, forged_print) == "gait or policy"
    # a re-attack (helper-32): the table started a step or two later or earlier
    longer = exported.ActionTable.from_gait(
        cpg.load_amplitudes(f"{seed0}/selected_params.json"), 1002
    ).actions
    for shifted in (longer[1:1001], longer[2:1002], np.vstack([longer[:1], longer[:999]])):
        shifted_run = _table_run(tmp_path, f"shifted{len(list(tmp_path.iterdir()))}", shifted)
        shifted_print = copies.fingerprint(str(shifted_run), ("selected_actions.npy",), moved)
        assert copies.copy_of(shifted_print, gait) == "gait or policy"
    seed1 = os.path.join(CMAES, "K50_s1_seed1")
    other = exported.ActionTable.from_gait(cpg.load_amplitudes(f"{seed1}/selected_params.json"))
    honest = _table_run(tmp_path, "honest", other.actions)
    honest_print = copies.fingerprint(str(honest), ("selected_actions.npy",), moved)
    assert copies.copy_of(honest_print, gait) is None


def test_a_feedback_gait_has_no_action_table_to_compare():
    feedback_run = os.path.join(RUNS, "cmaes", "darwin_walk_rough", "K50_s1_feedback_seed1")
    trials = admission.read_trials(os.path.join(feedback_run, "trials.csv"))
    gains = copies.fingerprint(feedback_run, ("selected_params.json",), trials)
    fake = copies.Fingerprint(
        (),
        np.zeros(0),
        "selected_actions.npy",
        (("actions", (1000, 12), "f", None),),
        (np.zeros(12000),),
        None,
        None,
    )
    assert not copies.across_kinds(gains, fake)
