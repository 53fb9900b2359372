"""analysis.table6_3 reads run files only and survives bad ones."""

import json

import pytest

from analysis import table6_3


def _run(root, name, best, rnd, final=0.1, fell=False):
    path = root / "cem" / "darwin_walk" / name
    path.mkdir(parents=True)
    (path / "summary.json").write_text(
        json.dumps(
            {
                "best_distance_m": best,
                "best_round": rnd,
                "final_mean_distance_m": final,
                "final_mean_fell": fell,
                "falls_total": 3,
                "evaluations": 10,
            }
        )
    )
    return path


def test_table_aggregates_seeds_and_skips_bad_runs(tmp_path):
    _run(tmp_path, "K50_n0.8_e2_seed0", 2.0, 40)
    _run(tmp_path, "K50_n0.8_e2_seed1", 3.0, 50, fell=True)
    broken = _run(tmp_path, "K10_n0_e1_seed0", 0.1, 2)
    (broken / "summary.json").write_text("{oops")
    (tmp_path / "cem" / "darwin_walk" / "K10_n0_e2_seed0").mkdir()  # no summary yet
    text, skipped = table6_3.write_table(str(tmp_path), str(tmp_path / "t.md"))
    err = "; ".join(skipped)
    row = [line for line in text.splitlines() if line.startswith("| K50_n0.8_e2 ")][0]
    assert "| 2 | 2.500 ± 0.707 | 45.0 ± 7.1 |" in row
    assert "50%" in row and "1.783 (CEM-N25)" in row
    assert "K10_n0_e1/" not in text and "K10_n0_e1_seed0" in err
    assert "K10_n0_e2_seed0" in err
    assert (tmp_path / "t.md").read_text() == text


def test_missing_tree_is_reported(tmp_path):
    text, skipped = table6_3.write_table(str(tmp_path / "nothing"))
    assert "no such directory" in "; ".join(skipped)
    assert text.count("\n") == 2  # the header only
    # The command line wants an existing --runs directory (a one-line error, exit code 2).
    with pytest.raises(ValueError, match="--runs=.*nothing is not a directory"):
        table6_3.Table63Settings(runs=str(tmp_path / "nothing"))
