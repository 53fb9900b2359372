"""analysis.leaderboard: rows, published values, claims, and bad run files."""

import csv
import json

import pytest

from analysis import leaderboard, published


def _run(root, method, task, name, summary):
    path = root / method / task / name
    path.mkdir(parents=True)
    (path / "summary.json").write_text(json.dumps(summary))


def _read(path):
    with open(path, encoding="utf-8") as f:
        return list(csv.DictReader(f))


def test_leaderboard_and_claims(tmp_path, capsys):
    runs = tmp_path / "runs"
    for seed, best in enumerate((2.0, 3.0)):
        _run(
            runs,
            "cem",
            "darwin_walk",
            f"K50_n0.8_e2_seed{seed}",
            {"best_distance_m": best, "final_mean_distance_m": best - 0.5},
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
    (runs / "pole_claims.csv").write_text(
        "claim_id,statement,rule,evidence,holds\nPB-8,two actions fail,r,e,yes\n"
    )
    out = tmp_path / "out" / "leaderboard.csv"
    line = leaderboard.write_tables(str(runs), str(out))
    assert line.startswith("5 runs, ") and str(out) in line
    rows = _read(out)
    assert list(rows[0]) == leaderboard.LEADERBOARD_FIELDS
    k50 = [r for r in rows if r["config"] == "K50_n0.8_e2" and r["metric"] == "best_distance_m"][0]
    assert k50["n"] == "2" and float(k50["mean"]) == 2.5 and float(k50["best"]) == 3.0
    assert float(k50["published"]) == published.TABLE6_3["K50_n0.8_e2"][0]
    assert "CEM-N25" in k50["published_source"] and "Webots, one run" in k50["published_source"]
    assert "beats_published" not in k50 and "ratio_to_published" not in k50
    claims = {c["claim_id"]: c for c in _read(out.parent / "claims.csv")}
    assert claims["CR-1"]["holds"] == "yes"
    assert claims["PB-8"]["holds"] == "yes"  # carried over from pole_claims.csv
    assert claims["NAC-3"]["holds"] == "untested"
    assert set(published.CLAIMS) <= set(claims)
    err = capsys.readouterr().err
    assert "broken_seed0" in err


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


def test_carried_rows_fill_in_configurations_without_runs(tmp_path):
    fields = leaderboard.DARWIN_FIELDS
    earlier = [dict.fromkeys(fields, "") for _ in range(3)]
    for row, (config, score) in zip(earlier, (("a", 3.0), ("b", 2.0), ("c", 1.0))):
        row.update(training_task="darwin_walk", method="cmaes", config=config, n_seeds=3)
        row.update(test_score_m=score, budget_sim_steps=1.5e7)
    path = str(tmp_path / "darwin_leaderboard.csv")
    leaderboard.write_csv(path, earlier, fields)
    # Runs at hand for "b" (now the best) and a new configuration; "a" and "c" are carried.
    fresh = [
        {"training_task": "darwin_walk", "method": "cmaes", "config": "b", "test_score_m": 4.0},
        {"training_task": "darwin_walk", "method": "ppo", "config": "cpg", "test_score_m": 0.5},
    ]
    merged = leaderboard.carry_darwin_rows(fresh, path)
    assert [(r["config"], r["test_score_m"], r["rank"]) for r in merged] == [
        ("b", 4.0, 1),
        ("a", 3.0, 2),
        ("c", 1.0, 3),
        ("cpg", 0.5, 4),
    ]
    assert merged[1]["n_seeds"] == 3 and merged[1]["budget_sim_steps"] == 1.5e7
    assert merged[1]["darwin_walk_score_m"] == ""  # empty cells stay empty
    (tmp_path / "other.csv").write_text("rank,score\n1,2\n")
    with pytest.raises(ValueError, match="not a DARwIn leaderboard"):
        leaderboard.carry_darwin_rows(fresh, str(tmp_path / "other.csv"))
