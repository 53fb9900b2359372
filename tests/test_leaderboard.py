"""analysis.leaderboard: rows, published values, and bad run files."""

import csv
import json
import os
import shutil

import pytest

from analysis import leaderboard, published
from cpg_suite.evaluation import footing, quality


def _run(root, method, task, name, summary):
    path = root / method / task / name
    path.mkdir(parents=True)
    (path / "summary.json").write_text(json.dumps(summary))


def _read(path):
    with open(path, encoding="utf-8") as f:
        return list(csv.DictReader(f))


SHIPPED = os.path.join(
    os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "results", "protocol", "runs"
)


def test_leaderboard_rows_and_published_values(tmp_path, capsys):
    """The study's metrics: a DARwIn walking configuration by its admitted runs' in-sample
    best tried again (a run the board refuses counts for nothing), the published best
    trial beside it; other tasks by their summaries."""
    runs = tmp_path / "runs"
    tried = []
    for seed in (0, 1):
        name = f"K50_n0.8_e2_seed{seed}"
        shutil.copytree(
            os.path.join(SHIPPED, "cem", "darwin_walk", name), runs / "cem" / "darwin_walk" / name
        )
        tried.append(
            json.loads((runs / "cem" / "darwin_walk" / name / "summary.json").read_text())[
                "in_sample"
            ]["distance_m"]
        )
    _run(
        runs,
        "cem",
        "darwin_walk",
        "K50_n0.8_e2_seed2",
        {"best_distance_m": 9.0, "in_sample": {"distance_m": 9.0, "fell": False}},
    )
    for seed in range(3):
        _run(
            runs,
            "value_iteration",
            "tokic",
            f"seed{seed}",
            {"cycle_reward": 53.0, "cycle_length": 6, "converged": True},
        )
    (runs / "cem" / "darwin_walk" / "broken_seed0").mkdir()
    (runs / "cem" / "darwin_walk" / "broken_seed0" / "summary.json").write_text("[1, 2")
    out = tmp_path / "out" / "leaderboard.csv"
    line = leaderboard.write_tables(str(runs), str(out))
    # The broken run is counted and listed as not admitted, with why (and on stderr).
    assert line.startswith("7 runs: ") and str(out) in line
    not_admitted = _read(out.parent / "darwin_not_admitted.csv")
    (broken,) = [r for r in not_admitted if r["run"].endswith("broken_seed0")]
    assert broken["reason"].startswith("missing ") or "unreadable" in broken["reason"]
    rows = _read(out)
    assert list(rows[0]) == leaderboard.LEADERBOARD_FIELDS
    (k50,) = [r for r in rows if r["config"] == "K50_n0.8_e2"]
    assert k50["metric"] == leaderboard.IN_SAMPLE_METRIC == "in_sample_best_m"
    assert k50["n"] == "2" and float(k50["mean"]) == (tried[0] + tried[1]) / 2
    assert float(k50["best"]) == max(tried)
    assert {r["run"].rsplit("/", 1)[-1] for r in not_admitted} == {
        "broken_seed0",
        "K50_n0.8_e2_seed2",
    }
    assert float(k50["published"]) == published.TABLE6_3["K50_n0.8_e2"][0]
    assert "CEM-N25" in k50["published_source"] and "Webots, one run" in k50["published_source"]
    assert "beats_published" not in k50 and "ratio_to_published" not in k50
    assert k50["checked_by"] == leaderboard.CHECKED_BY_VERIFY
    tokic = [r for r in rows if r["task"] == "tokic"]
    assert tokic and all(r["checked_by"] == leaderboard.UNCHECKED for r in tokic)
    (board,) = _read(out.parent / "darwin_leaderboard.csv")  # the same value, on the board
    assert board["published_best_trial"] == k50["published"]
    assert board["published_source"] == k50["published_source"]
    assert not (out.parent / "claims.csv").exists()  # the claims: analysis.study's alone
    err = capsys.readouterr().err
    assert "broken_seed0" in err


def test_runs_are_read_in_path_order_whatever_the_file_system_lists(tmp_path):
    """The board sums and resamples a configuration's runs in a fixed order: names sorted,
    not the directory listing's (hash) order, which differs between file systems."""
    names = [f"cpg_seed{s}" for s in (7, 3, 11, 0, 5, 1, 9, 2, 6, 4, 10, 8)]
    for i, name in enumerate(names):
        _run(tmp_path, "ppo", "darwin_walk", name, {"best_distance_m": float(i)})
    _run(tmp_path, "cem", "darwin_walk", "K50_seed0", {"best_distance_m": 0.0})
    found, skipped = leaderboard.find_runs(str(tmp_path))
    assert not skipped
    assert [r["dir"] for r in found] == sorted(r["dir"] for r in found)
    assert [(r["method"], r["seed"]) for r in found][:2] == [("cem", 0), ("ppo", 0)]


def test_missing_runs_directory(tmp_path):
    with pytest.raises(ValueError, match="not a directory"):
        leaderboard.write_tables(str(tmp_path / "nope"), str(tmp_path / "leaderboard.csv"))
    with pytest.raises(ValueError, match="not a directory"):
        leaderboard.LeaderboardSettings(runs=str(tmp_path / "nope"))
    assert list(tmp_path.iterdir()) == []


def test_published_data_is_complete():
    assert len(published.NUMBERS) == 108
    assert published.NUMBERS["CEM-N25"]["value"] == "1.782815"
    assert "6 states" in published.CLAIMS["CR-1"]
    assert all(row["source"] for row in published.NUMBERS.values())


def _card(scores):
    """A test card whose four tiers score `scores` (m) with no falls."""
    tier = lambda s: {  # noqa: E731
        "success_weighted_distance_m": {"mean": s, "ci95": [s, s]},
        "fall_rate": {"value": 0.0},
    }
    tiers = dict(zip(leaderboard.TIERS, (tier(s) for s in scores)))
    mean = sum(scores) / len(scores)
    return {"tiers": tiers, "all": {**tier(mean), "quality": {}}}


def _configuration(root, method, name, seeds, level, evaluations=2501):
    for seed in range(seeds):
        s = level + 0.01 * seed
        summary = {"evaluations": evaluations, "sim_steps": 1, "test": _card([s, s, s, s])}
        _run(root, method, "darwin_walk", f"{name}_seed{seed}", summary)


@pytest.mark.slow  # trains runs for two tracks
def test_tracks_ranks_ties_and_provisional_rows(tmp_path):
    runs = tmp_path / "runs"
    _configuration(runs, "cmaes", "K50", 10, 5.0)  # clearly first
    _configuration(runs, "cem", "K30", 10, 3.005)  # tied with the next
    _configuration(runs, "cem", "K50", 10, 3.0)
    _configuration(runs, "cem", "K10", 3, 9.0)  # best scores, too few seeds
    _configuration(runs, "cmaes", "long", 5, 7.0, evaluations=10004)  # 4x the budget
    found, _ = leaderboard.find_runs(str(runs))
    rows = leaderboard.darwin_rows(found)
    study = [r for r in rows if r["track"] == "study"]
    assert [(r["config"], r["rank"], r["status"]) for r in study] == [
        ("K50", 1, "ranked"),
        ("K30", 2, "ranked"),
        ("K50", 3, "ranked"),
        ("K10", "", "provisional"),
    ]
    first, second = study[0], study[1]
    assert first["method"] == "cmaes" and first["p_improvement_next"] == 1.0
    assert first["tied_with_next"] is False and first["p_improvement_ci95_low"] > 0.5
    assert second["tied_with_next"] is True  # 3.005-3.095 vs 3.00-3.09: not resolved
    assert second["p_improvement_ci95_low"] <= 0.5 <= second["p_improvement_ci95_high"]
    assert first["iqm_ci95_low"] <= first["iqm_m"] <= first["iqm_ci95_high"]
    (long,) = [r for r in rows if r["track"] == "4x"]
    assert long["rank"] == 1 and long["status"] == "ranked"


def test_a_learner_is_on_the_track_of_the_budget_it_was_given(tmp_path):
    """PPO trains whole rollouts: 2,502,656 steps for 2.5 M given is the study's budget;
    without its config the steps taken count."""
    runs = tmp_path / "runs"
    card = _card([1.0, 1.0, 1.0, 1.0])
    summary = {"env_steps": 2_502_656, "sim_steps": 1, "test": card}
    _run(runs, "ppo", "darwin_walk", "joints_seed0", summary)
    config = {"settings": {"total_steps": 2_500_000}}
    (runs / "ppo" / "darwin_walk" / "joints_seed0" / "config.json").write_text(json.dumps(config))
    _run(runs, "ppo", "darwin_walk", "cpg_seed0", summary)  # no config.json
    found, _ = leaderboard.find_runs(str(runs))
    tracks = {r["config"]: r["track"] for r in leaderboard.darwin_rows(found)}
    assert tracks == {"joints": "study", "cpg": "4x"}


def test_board_shows_card_quality_fields_and_every_electrical_one():
    assert set(leaderboard.QUALITY) <= set(quality.FIELDS)
    assert set(quality.ELECTRICAL_FIELDS) <= set(leaderboard.QUALITY)
    assert set(footing.FIELDS) <= set(leaderboard.QUALITY)


def test_a_configuration_trained_under_an_earlier_version_is_listed_not_ranked(tmp_path):
    """Re-scored under version 2, a run trained under version 1 keeps its version-1 card as
    history: ranked on the version-1 board, listed below the ranked rows on version 2's."""
    runs = tmp_path / "runs"
    for name, trained, level in (("old", 1, 5.0), ("new", 2, 3.0)):
        for seed in range(5):
            s = level + 0.01 * seed
            card = {**_card([s] * 4), "benchmark_version": 2}
            summary = {"evaluations": 2501, "sim_steps": 1, "test": card}
            if trained == 1:
                summary["history"] = {"v1": {**_card([s + 1] * 4), "benchmark_version": 1}}
            _run(runs, "cem", "darwin_walk", f"{name}_seed{seed}", summary)
            config = {"settings": {"seed": seed}}
            if trained == 2:
                config["settings"]["benchmark_version"] = 2
            path = runs / "cem" / "darwin_walk" / f"{name}_seed{seed}" / "config.json"
            path.write_text(json.dumps(config))
    found, _ = leaderboard.find_runs(str(runs))
    board = leaderboard.darwin_rows(found, version=2)
    assert [(r["config"], r["trained_version"], r["rank"], r["status"]) for r in board] == [
        ("new", 2, 1, "ranked"),
        ("old", 1, "", "trained_v1"),
    ]
    history = leaderboard.darwin_rows(found, version=1)
    assert [(r["config"], r["rank"], r["status"]) for r in history] == [("old", 1, "ranked")]
