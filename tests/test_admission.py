"""The leaderboard admits a run only with what verify needs and a protocol card its trials
produce; forged runs, built by hand from a shipped one, are refused by the board and by
verify, each with its reason (docs/protocol.md#admission)."""

import csv
import json
import os
import pickle
import shutil
import subprocess
import sys

import numpy as np
import pytest

from analysis import leaderboard
from cpg_suite import cpg, darwin, protocol
from cpg_suite.protocol import admission, files, score, verify
from cpg_suite.protocol import card as card_stats
from cpg_suite.runfiles import exported

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# How verify --quick ends on a tree without a ledger (no run on record in full).
QUICK = (
    "on --quick's trials (the first 5 test seeds a tier), 0 of them on record as re-scored in full"
)
RUNS = os.path.join(ROOT, "results", "protocol", "runs")
GAIT_RUN = os.path.join(RUNS, "cem", "darwin_walk", "K50_n0.8_e2_seed0")  # the cheapest
OTHER_GAIT_RUN = os.path.join(RUNS, "cem", "darwin_walk", "K50_n0.8_e2_seed1")  # another seed
# An SB3 policy: the one shipped run that keeps its pickles beside its exported arrays
# (`selected_policy.npz`, which verify scores); a copy without the arrays is an SB3 run.
POLICY_RUN = os.path.join(RUNS, "ppo", "darwin_walk", "cpg_seed0")
SB3 = (admission.SB3_MODEL, admission.SB3_NORMALIZER)


def _copy(runs, name, source=GAIT_RUN, method="cem"):
    dest = runs / method / "darwin_walk" / name
    shutil.copytree(source, dest)
    return dest


def _edit_json(path, change):
    data = json.loads(path.read_text())
    change(data)
    path.write_text(json.dumps(data, indent=2))


def _trials(run, version=None):
    name = "trials.csv" if version is None else f"trials_v{version}.csv"
    with open(run / name, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _write_trials(run, rows, version=None):
    name = "trials.csv" if version is None else f"trials_v{version}.csv"
    with open(run / name, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def _scored_as(
    run, seeds=50, steps=1000, tiers=protocol.TIERS, config_seeds=None, config_steps=None
):
    """Rewrites a copied run as if its card had been made under other settings, every file
    consistent with the others (the card's statistics made from the trials as a card makes
    them): what a run scored with `--test_seeds`, `--trial_steps` or `--test_tiers` holds.
    `config_seeds` and `config_steps` make its config claim other settings."""
    rows = [r for r in _trials(run) if r["tier"] in tiers]
    rows = [r for r in rows if int(r["seed"]) < protocol.TEST.start + seeds]
    for r in rows:  # a trial that failed after the last step did not fail
        if int(r["fall_step"]) > steps:
            r.update(fell="False", fall_step="0", cause="")
    _write_trials(run, rows)
    summary = json.loads((run / "summary.json").read_text())
    card = _card_of(rows, tiers, summary["test"], steps)
    (run / "summary.json").write_text(json.dumps({**summary, "test": card}, indent=2))

    def config(c):
        c["settings"]["test_seeds"] = seeds if config_seeds is None else config_seeds
        c["settings"]["trial_steps"] = steps if config_steps is None else config_steps
        c["settings"]["test_tiers"] = list(tiers)

    _edit_json(run / "config.json", config)


def _card_of(rows, tiers, old, steps=1000):
    """The card a trial table (CSV rows) makes, as a card makes it, with `old`'s version and
    gait-quality medians (which need the simulation)."""

    def row(part, name="all"):
        made = card_stats.row(
            np.array([float(r["distance_m"]) for r in part]),
            np.array([r["fell"] == "True" for r in part]),
            {},
            np.array(
                [1 + ("fall", "brownout").index(r["cause"]) if r["cause"] else 0 for r in part]
            ),
            steps,
        )
        kept = old["all"] if name == "all" else old["tiers"].get(name, old["all"])
        return {**made, "quality": kept["quality"]}  # the measures' cells are not edited

    return json.loads(
        json.dumps(
            {
                "benchmark_version": old["benchmark_version"],
                "tiers": {t: row([r for r in rows if r["tier"] == t], t) for t in tiers},
                "all": row(rows),
                "scoring_sim_steps": len(rows) * steps * 8,
            }
        )
    )


def _history_ranked_as_test(run):
    """The helper's attack: the version-2 card, inflated and rebuilt, shown as the test
    card while the version-3 card the board checks sits in the history."""
    rows = [{**r, "distance_m": repr(3 * float(r["distance_m"]))} for r in _trials(run, 2)]
    summary = json.loads((run / "summary.json").read_text())
    fake = _card_of(rows, protocol.tiers(2), summary["history"]["v2"])
    summary = {**summary, "test": fake, "history": {"v3": summary["test"]}}
    (run / "summary.json").write_text(json.dumps(summary))
    (run / "trials.csv").replace(run / "trials_v3.csv")
    _write_trials(run, rows)
    (run / "trials_v2.csv").unlink()


def _history_trials_inflated(run):
    """Every trial of the version-2 table that did not fail walks 2 m more, its history
    card made from it: the version-2 board would rank it, verify re-scores only the test."""
    rows = [
        {**r, "distance_m": repr(float(r["distance_m"]) + (0 if r["fell"] == "True" else 2))}
        for r in _trials(run, 2)
    ]
    _write_trials(run, rows, 2)
    summary = json.loads((run / "summary.json").read_text())
    summary["history"]["v2"] = _card_of(rows, protocol.tiers(2), summary["history"]["v2"])
    (run / "summary.json").write_text(json.dumps(summary))


def _symlink(run, name, target):
    (run / name).unlink()
    (run / name).symlink_to(target)


def _raw(run, name, text):
    (run / name).write_text(text)


# name -> (how the copied run is forged, the start of the reason it is refused with)
FORGERIES = {
    "summary_alone": (
        lambda run: [p.unlink() for p in run.iterdir() if p.name != "summary.json"],
        "missing config.json, trials.csv, versions.json, the gait or policy",
    ),
    "no_versions": (lambda run: (run / "versions.json").unlink(), "missing versions.json"),
    "two_seeds": (
        lambda run: _scored_as(run, seeds=2),
        "not under the protocol's card settings: 2 of the 50 test seeds",
    ),
    "two_seeds_config_says_50": (
        lambda run: _scored_as(run, seeds=2, config_seeds=50),
        "not under the protocol's card settings: 2 of the 50 test seeds",
    ),
    "steps200": (
        lambda run: _scored_as(run, steps=200),
        "not under the protocol's card settings: 200-step trials",
    ),
    "steps2000": (
        lambda run: _scored_as(run, steps=2000),
        "not under the protocol's card settings: 2000-step trials",
    ),
    "steps200_config_says_1000": (
        lambda run: _scored_as(run, steps=200, config_steps=1000),
        "its card's darwin_walk speed is that of 200-step trials, not 1000",
    ),
    "one_tier": (
        lambda run: _scored_as(run, tiers=("darwin_walk",)),
        "not under the protocol's card settings: tiers left out: darwin_walk_randomized",
    ),
    "card_edited": (
        lambda run: _edit_json(
            run / "summary.json",
            lambda s: s["test"]["all"]["success_weighted_distance_m"].update(mean=2.5),
        ),
        "its trial table does not produce the card (all: success_weighted_distance_m",
    ),
    "trial_edited": (
        lambda run: _write_trials(
            run, [{**r, "distance_m": "4.0"} if i == 3 else r for i, r in enumerate(_trials(run))]
        ),
        "its trial table does not produce the card (darwin_walk: success_weighted_distance_m",
    ),
    "trials_short": (
        lambda run: _write_trials(run, _trials(run)[:-1]),
        "its trial table (249 trials) is not the card's 5 tiers × 50 test seeds",
    ),
    "config_claims_v1": (
        lambda run: _edit_json(
            run / "config.json", lambda c: c["settings"].pop("benchmark_version")
        ),
        "config.json claims benchmark version 1, but the run's cards are of version 2, 3",
    ),
    "config_claims_v3": (  # trained under 2, upgraded: its first card is version 2's
        lambda run: _edit_json(
            run / "config.json", lambda c: c["settings"].update(benchmark_version=3)
        ),
        "config.json claims benchmark version 3, but the run's cards are of version 2, 3",
    ),
    "config_claims_v4": (
        lambda run: _edit_json(
            run / "config.json", lambda c: c["settings"].update(benchmark_version=4)
        ),
        "config.json claims benchmark version 4, not one of [1, 2, 3]",
    ),
    "v3_card_without_contact": (  # a version-3 card of version 2's four tiers
        lambda run: _scored_as(run, tiers=protocol.tiers(2)),
        "not under the protocol's card settings: tiers left out: darwin_walk_contact",
    ),
    "v2_card_relabelled_v3": (  # the history card and its trials passed off as version 3's
        lambda run: (
            _edit_json(
                run / "summary.json",
                lambda s: s.update(test={**s["history"]["v2"], "benchmark_version": 3}),
            ),
            (run / "trials_v2.csv").replace(run / "trials.csv"),
        ),
        "not under the protocol's card settings: tiers left out: darwin_walk_contact",
    ),
    "v3_card_claims_five_tiers": (  # the same, its card claiming settings of five
        lambda run: (
            _scored_as(run, tiers=protocol.tiers(2)),
            _edit_json(
                run / "summary.json",
                lambda s: s["test"].update(
                    settings={"tiers": list(protocol.TIERS), "seeds": 50, "steps": 1000}
                ),
            ),
        ),
        "not under the protocol's card settings: tiers left out: darwin_walk_contact",
    ),
    "card_claims_v1": (
        lambda run: _edit_json(
            run / "summary.json", lambda s: s["test"].update(benchmark_version=1)
        ),
        "its test card (version 1) is not its latest: it keeps a version-2 card as history",
    ),
    # The cards a run keeps as history: the board checks every card a run holds.
    "history_ranked_as_test": (
        _history_ranked_as_test,
        "its test card (version 2) is not its latest: it keeps a version-3 card as history",
    ),
    "history_trials_inflated": (
        _history_trials_inflated,
        "its version-2 trials differ from its version-3 trials on darwin_walk, which both",
    ),
    "history_card_edited": (
        lambda run: _edit_json(
            run / "summary.json",
            lambda s: s["history"]["v2"]["all"]["success_weighted_distance_m"].update(mean=9.0),
        ),
        "its trial table does not produce the card (all: success_weighted_distance_m differs) "
        "(its version-2 card, trials_v2.csv)",
    ),
    "history_key_with_newline": (  # "v2\n" read as v2 by a `$` pattern: the forged "v2" shown
        lambda run: _edit_json(
            run / "summary.json",
            lambda s: s["history"].update(
                {"v2\n": s["history"]["v2"], "v2": {**s["history"]["v2"], "edited": 1}}
            ),
        ),
        "summary.json's history holds 'v2\\n', not a card under a version v<n>",
    ),
    "history_bogus_key": (  # and the board's list of history versions does not crash on it
        lambda run: _edit_json(run / "summary.json", lambda s: s["history"].update(vbogus={})),
        "summary.json's history holds 'vbogus', not a card under a version v<n>",
    ),
    "history_quality_edited": (  # a median its own table's measures do not make
        lambda run: _edit_json(
            run / "summary.json",
            lambda s: s["history"]["v2"]["tiers"]["darwin_walk"]["quality"].update(
                cost_of_transport=0.01
            ),
        ),
        "its trial table does not produce the card (darwin_walk: cost_of_transport differs) "
        "(its version-2 card, trials_v2.csv)",
    ),
    "card_version_float": (
        lambda run: _edit_json(
            run / "summary.json", lambda s: s["test"].update(benchmark_version=3.0)
        ),
        "its test card claims benchmark version 3.0, not one of [1, 2, 3]",
    ),
    "history_not_a_card": (
        lambda run: _edit_json(run / "summary.json", lambda s: s["history"].update(v2=5)),
        "summary.json's history holds 'v2', not a card under a version v<n>",
    ),
    "history_card_of_v1_tiers": (  # the history card claims another version than its key
        lambda run: _edit_json(
            run / "summary.json", lambda s: s["history"]["v2"].update(benchmark_version=1)
        ),
        "its history card v2 says it was scored under version 1",
    ),
    # What a run says of its training, held to what its config says.
    "task_relabelled": (
        lambda run: _edit_json(
            run / "config.json", lambda c: c["settings"].update(task="darwin_walk_randomized")
        ),
        "config.json says it trained on 'darwin_walk_randomized', its folder on 'darwin_walk'",
    ),
    "budget_understated": (
        lambda run: _edit_json(run / "summary.json", lambda s: s.update(evaluations=1000)),
        "summary.json claims 1000 training trials, fewer than its config's 50 × 50 rounds × 1",
    ),
    "budget_population_float": (
        lambda run: _edit_json(
            run / "config.json", lambda c: c["settings"].update(population=50.0)
        ),
        "config.json's budget {'population': 50.0, 'rounds': 50, 'eval_seeds': 1} is not three",
    ),
    "budget_no_seeds": (
        lambda run: _edit_json(run / "config.json", lambda c: c["settings"].update(eval_seeds=0)),
        "config.json's budget {'population': 50, 'rounds': 50, 'eval_seeds': 0} is not three",
    ),
    "budget_left_out": (
        lambda run: _edit_json(run / "summary.json", lambda s: s.pop("evaluations")),
        "summary.json does not say how many training trials it took (evaluations)",
    ),
    "task_left_out": (
        lambda run: _edit_json(run / "config.json", lambda c: c["settings"].pop("task")),
        "config.json says it trained on None, its folder on 'darwin_walk'",
    ),
    "budget_negative": (
        lambda run: _edit_json(run / "summary.json", lambda s: s.update(evaluations=-1)),
        "summary.json's evaluations is -1, not a count",
    ),
    # Files the board may not read, and JSON or CSV a reviewer and a parser read apart.
    "summary_to_dev_zero": (
        lambda run: _symlink(run, "summary.json", "/dev/zero"),
        "summary.json is a symbolic link, not a file of the run's own",
    ),
    "trials_outside": (
        lambda run: _symlink(run, "trials.csv", OTHER_GAIT_RUN + "/trials.csv"),
        "trials.csv is a symbolic link, not a file of the run's own",
    ),
    "versions_huge": (
        lambda run: os.truncate(run / "versions.json", files.MAX_BYTES + 1),  # sparse
        f"versions.json holds {files.MAX_BYTES + 1} bytes, over the",
    ),
    "summary_nan": (
        lambda run: _raw(
            run,
            "summary.json",
            (run / "summary.json").read_text().replace('"evaluations": 2501', '"evaluations": NaN'),
        ),
        "unreadable run files (ValueError: summary.json: NaN is not a JSON number)",
    ),
    "summary_key_twice": (
        lambda run: _raw(
            run, "summary.json", '{"test": {}, ' + (run / "summary.json").read_text()[1:]
        ),
        "unreadable run files (ValueError: summary.json: the key 'test' appears twice",
    ),
    "gait_key_twice": (
        lambda run: _raw(
            run,
            "selected_params.json",
            '{"amplitudes": {}, ' + (run / "selected_params.json").read_text().lstrip()[1:],
        ),
        "unreadable run files (ValueError: selected_params.json: the key 'amplitudes' appears",
    ),
    "policy_unpacks_huge": (  # 128 MiB of zeros in a 130 kB .npz, beside the gait it outranks
        lambda run: np.savez_compressed(run / "selected_policy.npz", w=np.zeros(2**24)),
        "selected_policy.npz unpacks to",  # the policy's own check (`policy_refusal`)
    ),
    # A third outside attack (2026-11-28): nesting past Python's recursion limit, a number
    # past a float's range, a seed left out of the config (two folders of one seed).
    "summary_nested_deeply": (
        lambda run: _raw(run, "summary.json", "[" * 100_000 + "]" * 100_000),
        "unreadable run files (ValueError: summary.json: nested more than 32 lists and "
        "objects deep)",
    ),
    "summary_number_overflows": (
        lambda run: _raw(
            run,
            "summary.json",
            (run / "summary.json")
            .read_text()
            .replace('"evaluations": 2501', '"evaluations": 3e309'),
        ),
        "unreadable run files (ValueError: summary.json: 3e309 does not fit a float",
    ),
    "budget_track_by_env_steps": (  # the board's budget track reads env_steps first
        lambda run: _edit_json(run / "summary.json", lambda s: s.update(env_steps=0)),
        "summary.json claims env_steps, a learner's budget, but config.json sets no total_steps",
    ),
    "budget_both_kinds": (  # a population's run claiming a learner's budget too
        lambda run: (
            _edit_json(run / "config.json", lambda c: c["settings"].update(total_steps=1)),
            _edit_json(run / "summary.json", lambda s: s.update(env_steps=1)),
        ),
        "config.json sets both a population's rounds and a learner's total_steps",
    ),
    "validation_steps_not_a_count": (
        lambda run: _edit_json(run / "summary.json", lambda s: s.update(validation_sim_steps="x")),
        "summary.json's validation_sim_steps is 'x', not a count",
    ),
    "code_nested_deeply": (  # `ast.parse` of a flat sum of 100,000 terms recurses
        lambda run: (
            os.remove(run / "selected_params.json"),
            (run / "policy_code.py").write_text("x = " + "+".join(["1"] * 100_000) + "\n"),
        ),
        "unreadable gait or policy (ValueError: policy_code.py is nested too deeply to parse)",
    ),
    "seed_left_out": (
        lambda run: _edit_json(run / "config.json", lambda c: c["settings"].pop("seed")),
        "config.json's seed None is not the seed of its folder's name (0)",
    ),
    "trials_column_twice": (
        lambda run: _raw(
            run,
            "trials.csv",
            (run / "trials.csv").read_text().replace("distance_m", "distance_m,distance_m", 1),
        ),
        "unreadable run files (ValueError: trials.csv names the column 'distance_m' twice)",
    ),
}

# Verify checks each card as it stands, not under a board's version.
AS_VERIFY_SEES_IT: dict[str, str] = {}


@pytest.fixture(scope="module")
def forged(tmp_path_factory):
    """A run tree: a genuine copy of a shipped gait run, each forgery of `FORGERIES` (its
    own configuration), and five "seeds" that are one run copied (config seeds edited)."""
    runs = tmp_path_factory.mktemp("forged") / "runs"
    genuine = _copy(runs, "genuine_seed0", source=OTHER_GAIT_RUN)
    _edit_json(genuine / "config.json", lambda c: c["settings"].update(seed=0))
    for name, (forge, _) in FORGERIES.items():
        forge(_copy(runs, f"{name}_seed0"))
    for seed in range(5):
        copy = _copy(runs, f"copied_seed{seed}")
        _edit_json(copy / "config.json", lambda c, s=seed: c["settings"].update(seed=s))
    _copy(runs, "wrong_seed_seed1")  # a copy not even renamed inside
    return runs


def _not_admitted(out):
    with open(out / "darwin_not_admitted.csv", newline="", encoding="utf-8") as f:
        return {r["run"].split("/")[-1]: r for r in csv.DictReader(f)}


def test_the_board_refuses_each_forgery_with_its_reason(forged, tmp_path):
    out = tmp_path / "board"
    line = leaderboard.write_tables(str(forged), str(out / "leaderboard.csv"))
    refused = _not_admitted(out)
    assert f"{len(refused)} runs not admitted" in line
    for name, (_, reason) in FORGERIES.items():
        assert refused[f"{name}_seed0"]["reason"].startswith(reason), name
        assert refused[f"{name}_seed0"]["benchmark_version"] == "3"
    for seed in range(1, 5):
        reason = refused[f"copied_seed{seed}"]["reason"]
        assert reason.startswith(
            "a copy of cem/darwin_walk/copied_seed0: the same trial outcomes as values"
        )
    assert refused["wrong_seed_seed1"]["reason"].startswith("config.json's seed 0 is not")
    assert set(refused) == {f"{n}_seed0" for n in FORGERIES} | {
        *(f"copied_seed{s}" for s in range(1, 5)),
        "wrong_seed_seed1",
    }
    with open(out / "darwin_leaderboard.csv", newline="", encoding="utf-8") as f:
        board = list(csv.DictReader(f))
    assert sorted((r["config"], r["n_seeds"], r["rank"]) for r in board) == [
        ("copied", "1", ""),  # one run: provisional, never ranked
        ("genuine", "1", ""),
    ]


def test_verify_refuses_each_forgery_without_scoring_it(forged):
    logged = []
    failed = verify.verify(str(forged), quick=True, log=logged.append)
    refused = {
        line.split(";")[0].split("/")[-1]: line.split("; ", 1)[1]
        for line in logged
        if line.startswith("REFUSED")
    }
    for name, (_, reason) in FORGERIES.items():
        reason = AS_VERIFY_SEES_IT.get(name, reason)
        assert refused[f"{name}_seed0"].startswith(reason), name
    assert all(refused[f"copied_seed{s}"].startswith("a copy of") for s in range(1, 5))
    assert failed == len(refused) == len(FORGERIES) + 5
    reproduced = [line for line in logged if line.startswith("ok")]
    assert [line.split("/")[-1] for line in reproduced] == ["copied_seed0", "genuine_seed0"]
    assert logged[-1] == f"2 of {2 + failed} shipped runs reproduced bit for bit {QUICK}"


def test_a_changed_gait_passes_the_board_but_not_verify(tmp_path):
    """The board reads files only: a gait swapped under its card is verify's to find."""
    runs = tmp_path / "runs"
    run = _copy(runs, "swapped_seed0")
    params = json.loads((run / "selected_params.json").read_text())
    params["amplitudes"]["knee"] += 1.0
    (run / "selected_params.json").write_text(json.dumps(params))
    assert admission.refusals([str(run)]) == {}
    logged = []
    assert verify.verify(str(runs), quick=True, log=logged.append) == 1
    assert logged[0].startswith("DIFF") and "trials differ from trials.csv" in logged[0]


def test_every_shipped_run_is_admitted():
    found, skipped = leaderboard.find_runs(RUNS)
    assert not skipped
    admitted, refused = leaderboard.admit(found)
    assert refused == [] and len(admitted) == len(found) == 103
    # The version-1 board: every run kept its version-1 card, or was trained under 2.
    admitted, refused = leaderboard.admit(found, 1)
    assert {r["reason"] for r in refused} == {
        "no card under benchmark version 1 (its card: version 3)"
    }
    assert all(admission.trained_version(run["dir"]) == 1 for run in admitted)
    # The version-2 board: every run kept its version-2 card (version 3 added a tier).
    admitted, refused = leaderboard.admit(found, 2)
    assert refused == [] and len(admitted) == 103


def test_the_board_executes_nothing_from_a_run_folder(tmp_path):
    """A policy run's pickle that would write a file when unpickled: the board reads the
    run and the file is never written."""
    runs = tmp_path / "runs"
    run = _copy(runs, "cpg_seed0", source=POLICY_RUN, method="ppo")
    (run / admission.EXPORTED).unlink()  # its pickles are its policy
    marker = tmp_path / "executed"

    class Payload:
        def __reduce__(self):
            return (open, (str(marker), "w"))

    (run / "selected_vecnormalize.pkl").write_bytes(pickle.dumps(Payload()))
    leaderboard.write_tables(str(runs), str(tmp_path / "board" / "leaderboard.csv"))
    assert not marker.exists()
    assert _not_admitted(tmp_path / "board") == {}  # its files are all there


def test_a_score_card_alone_is_listed_not_ranked(tmp_path):
    preset = tmp_path / "runs" / "hand_tuned"
    preset.mkdir(parents=True)
    summary = json.loads(open(os.path.join(GAIT_RUN, "summary.json")).read())
    (preset / "score.json").write_text(json.dumps(summary["test"]))
    found, _ = leaderboard.find_runs(str(tmp_path / "runs"))
    rows, refused = leaderboard.darwin_board(found)
    assert rows == [] and [r["reason"] for r in refused] == [leaderboard.PRESET_REFUSAL]


def test_a_card_says_when_it_is_not_the_protocols():
    settings = score.ScoreSettings(tiers=("darwin_walk",), seeds=2, steps=30)
    card = score.score_gait(np.zeros(11), settings)
    deviations = [
        "tiers left out: darwin_walk_randomized, darwin_walk_push, darwin_walk_rough, "
        "darwin_walk_contact",
        "2 of the 50 test seeds",
        "30-step trials (the protocol's: 1000)",
    ]
    assert card["protocol"] is False and card["not_protocol"] == deviations
    assert score.stored_card(card)["not_protocol"] == deviations
    first = score.format_card(card).splitlines()[0]
    assert first.startswith("NOT A PROTOCOL CARD (tiers left out: darwin_walk_randomized")
    assert "2 of the 50 test seeds; 30-step trials" in first
    stored = {
        k: v for k, v in score.stored_card(card).items() if k not in ("protocol", "not_protocol")
    }
    assert card_stats.card_deviations(stored) == deviations  # what the card shows of itself


def test_a_protocol_card_is_unmarked():
    assert card_stats.deviations(protocol.TIERS, 50, 1000, 3) == []
    assert card_stats.deviations(protocol.tiers(2), 50, 1000, 2) == []
    assert card_stats.deviations(protocol.TIERS, 50, 1000, 3, 0.25) == [
        "supply window 0.25 s (version 3's: 1 s)"
    ]
    assert card_stats.deviations(protocol.tiers(1), 50, 1000, 1, 0.25) == []  # no limit in v1
    assert card_stats.deviations(protocol.tiers(2), 50, 1000, 3) == [
        "tiers left out: darwin_walk_contact"
    ]
    assert card_stats.deviations(protocol.TIERS, 50, 1000, 2) == [
        "tiers not of version 2: darwin_walk_contact"
    ]
    assert card_stats.deviations(protocol.TIERS[::-1], 50, 1000, 3)[0].startswith(
        "tiers not in the protocol's order"
    )
    card = json.loads(open(os.path.join(GAIT_RUN, "summary.json")).read())["test"]
    assert "protocol" not in card and card_stats.is_protocol(card)
    assert score.format_card(card).startswith("benchmark version 3; speed = ")
    assert score.stored_card(card) == card


def test_the_cards_time_constants_are_the_models():
    import cpg_suite

    assert card_stats.CONTROL_TIMESTEP == darwin.CONTROL_TIMESTEP
    env = cpg_suite.load("darwin_walk")
    n_sub = env.control_timestep() / env.physics.model.opt.timestep
    assert round(n_sub) == card_stats.PHYSICS_STEPS_PER_CONTROL_STEP


def test_ship_from_names_what_a_folder_lacks(tmp_path):
    half = tmp_path / "half" / "mine" / "darwin_walk" / "a_seed0"
    half.mkdir(parents=True)
    shutil.copy(os.path.join(GAIT_RUN, "summary.json"), half)
    (tmp_path / "shipped").mkdir()
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "cpg_suite.protocol.verify",
            f"--ship_from={tmp_path / 'half'}",
            f"--artifacts={tmp_path / 'shipped'}",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    lacks = "config.json, the gait or policy (selected_params.json, selected_policy.npz, "
    assert out.returncode == 2
    (line,) = out.stderr.splitlines()
    assert line.startswith(f"error: nothing to ship from {tmp_path / 'half'}: {half} lacks {lacks}")
    assert out.stdout.startswith(f"not shippable {half}: missing {lacks}")


# The formats added for submissions: an action table is data (read without unpickling);
# a policy's Python file and SB3 pickles are code, run by verify only when asked.
class _Payload:
    """Pickled, it makes a file when unpickled: whether a pickle was loaded shows."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (open, (str(self.marker), "w"))


_CODE = """
import os

from cpg_suite.protocol import score

open(os.path.join(os.path.dirname(__file__), "executed"), "a").close()


def make_policy():
    return score.OpenLoopPolicy({amplitudes})
"""


def _as_actions(run):
    """The copied gait run with its gait as a table of actions (the same card, bit for bit)."""
    amplitudes = cpg.load_amplitudes(str(run / "selected_params.json"))
    (run / "selected_params.json").unlink()
    exported.ActionTable.from_gait(amplitudes).save(str(run / "selected_actions.npy"))
    return run


def _as_code(run):
    """The copied gait run with its gait as a policy's Python file (the same card)."""
    amplitudes = cpg.load_amplitudes(str(run / "selected_params.json")).tolist()
    (run / "selected_params.json").unlink()
    (run / "policy_code.py").write_text(_CODE.format(amplitudes=amplitudes))
    return run


@pytest.fixture(scope="module")
def formats(tmp_path_factory):
    """A run tree: an action-table run, its forgeries (card edited, a table of the wrong
    shape, a table of pickled objects), a policy-code run, and a copy of a shipped SB3 run
    whose normalizer pickle was swapped (each pickle makes a marker file if loaded)."""
    runs = tmp_path_factory.mktemp("formats") / "runs"
    _as_actions(_copy(runs, "actions_seed0"))
    edited = _as_actions(_copy(runs, "actions_card_edited_seed0"))
    FORGERIES["card_edited"][0](edited)
    short = _as_actions(_copy(runs, "actions_short_seed0"))
    table = exported.ActionTable.load(str(short / "selected_actions.npy"))
    exported.ActionTable(table.actions[:999]).save(str(short / "selected_actions.npy"))
    pickled = _as_actions(_copy(runs, "actions_pickled_seed0"))
    payload = np.array([_Payload(pickled / "unpickled")], dtype=object)
    np.save(pickled / "selected_actions.npy", payload, allow_pickle=True)
    code = _as_code(_copy(runs, "code_seed0", source=OTHER_GAIT_RUN))  # not the tables' run
    _edit_json(code / "config.json", lambda c: c["settings"].update(seed=0))
    sb3 = _copy(runs, "cpg_seed0", source=POLICY_RUN, method="ppo")
    (sb3 / admission.EXPORTED).unlink()  # its pickles are its policy
    (sb3 / "selected_vecnormalize.pkl").write_bytes(pickle.dumps(_Payload(sb3 / "unpickled")))
    return runs


def _executed(runs):
    return sorted(
        os.path.relpath(os.path.join(d, n), runs)
        for d, _, names in os.walk(runs)
        for n in names
        if n in ("executed", "unpickled")
    )


def test_the_board_admits_an_action_table_or_code_on_its_files_alone(formats, tmp_path):
    leaderboard.write_tables(str(formats), str(tmp_path / "board" / "leaderboard.csv"))
    refused = {name: row["reason"] for name, row in _not_admitted(tmp_path / "board").items()}
    assert refused == {
        "actions_card_edited_seed0": (
            "its trial table does not produce the card (all: success_weighted_distance_m differs)"
        ),
        "actions_short_seed0": (
            "its selected_actions.npy is a (999, 12) table, not one row of 12 actions per "
            "control step of its 1000-step trials"
        ),
        "actions_pickled_seed0": (
            "its selected_actions.npy holds Python objects (pickles), not float64 actions"
        ),
    }
    assert _executed(formats) == []  # the code run and the tampered SB3 run: admitted, not run
    assert admission.artifact_files(str(formats / "cem" / "darwin_walk" / "code_seed0")) == (
        "policy_code.py",
    )


def test_verify_replays_a_table_and_runs_no_code_it_was_not_asked_to(formats):
    logged = []
    assert verify.verify(str(formats), quick=True, log=logged.append) == 5
    lines = {line.split(";")[0].split()[-1].split("/")[-1]: line for line in logged[:-1]}
    assert lines["actions_seed0"].startswith("ok ")  # the table replays the gait's trials
    reasons = {name: line.split("; ", 1)[1] for name, line in lines.items() if ";" in line}
    assert reasons["code_seed0"] == (
        "its policy_code.py runs code: re-run with --trust_code to execute it"
    )
    assert reasons["cpg_seed0"] == (
        "its selected_vecnormalize.pkl (pickles: loading runs code) is not in "
        "cpg_suite/data/trusted_pickles.txt: re-run with --trust_code to load them"
    )
    assert reasons["actions_pickled_seed0"].startswith("its selected_actions.npy holds Python")
    assert reasons["actions_card_edited_seed0"].startswith("its trial table does not produce")
    assert logged[-1] == f"1 of 6 shipped runs reproduced bit for bit {QUICK}"
    sb3 = str(formats / "ppo" / "darwin_walk" / "cpg_seed0")
    with pytest.raises(verify.UntrustedCode, match="selected_vecnormalize.pkl"):
        verify.shipped_policy(sb3)
    with pytest.raises(ValueError, match="allow_pickle=False"):  # read as data, refused
        exported.ActionTable.load(
            str(formats / "cem" / "darwin_walk" / "actions_pickled_seed0" / "selected_actions.npy")
        )
    assert _executed(formats) == []
    # The payloads are live: loaded as pickles, each would have run.
    with open(os.path.join(sb3, "selected_vecnormalize.pkl"), "rb") as f:
        pickle.load(f)
    assert _executed(formats) == ["ppo/darwin_walk/cpg_seed0/unpickled"]
    os.remove(os.path.join(sb3, "unpickled"))


def test_verify_cli_refuses_code_without_trust_code_and_runs_it_with(tmp_path):
    runs = tmp_path / "runs"
    code_run = _as_code(_copy(runs, "code_seed0"))

    def verify_cli(*flags):
        command = ["-m", "cpg_suite.protocol.verify", f"--artifacts={runs}", "--quick", *flags]
        return subprocess.run(
            [sys.executable, *command], capture_output=True, text=True, timeout=600
        )

    out = verify_cli()
    assert out.returncode == 1
    assert out.stdout.splitlines() == [
        f"REFUSED {code_run}; its policy_code.py runs code: re-run with --trust_code to execute it",
        f"0 of 1 shipped runs reproduced bit for bit {QUICK}",
    ]
    assert not (code_run / "executed").exists()
    out = verify_cli("--trust_code")
    assert out.returncode == 0, out.stderr[-500:]
    assert out.stdout.splitlines() == [
        f"ok   {code_run}",
        f"1 of 1 shipped runs reproduced bit for bit {QUICK}",
    ]
    assert (code_run / "executed").exists()


def test_the_trusted_list_is_every_shipped_sb3_pickle(tmp_path):
    with open(os.path.join(ROOT, verify.TRUSTED_LIST), encoding="utf-8") as f:
        listed = f.read()
    assert listed == verify.trusted_artifacts_text(RUNS, ROOT)  # paths from this checkout
    # One shipped run keeps its pickles; it is scored from its arrays, which are data.
    kept = [r for r in verify.shipped_runs(RUNS) if set(SB3) <= set(os.listdir(r))]
    assert kept == [POLICY_RUN] and len(listed.splitlines()) == 2
    assert admission.artifact_files(POLICY_RUN) == (admission.EXPORTED,)
    assert verify.code_refusal(POLICY_RUN, trusted=frozenset()) is None
    sb3_run = _copy(tmp_path / "runs", "cpg_seed0", source=POLICY_RUN, method="ppo")
    (sb3_run / admission.EXPORTED).unlink()  # its pickles are its policy
    assert admission.artifact_files(str(sb3_run)) == SB3
    assert verify.code_refusal(str(sb3_run)) is None  # verified by default
    assert verify.code_refusal(str(sb3_run), trusted=frozenset()) is not None
    assert verify.code_refusal(str(sb3_run), trust_code=True, trusted=frozenset()) is None
