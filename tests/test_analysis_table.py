"""analysis.table6_3 reads run files only and survives bad ones."""

import json

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


def test_table_aggregates_seeds_and_skips_bad_runs(tmp_path, capsys):
    _run(tmp_path, "K50_n0.8_e2_seed0", 2.0, 40)
    _run(tmp_path, "K50_n0.8_e2_seed1", 3.0, 50, fell=True)
    broken = _run(tmp_path, "K10_n0_e1_seed0", 0.1, 2)
    (broken / "summary.json").write_text("{oops")
    (tmp_path / "cem" / "darwin_walk" / "K10_n0_e2_seed0").mkdir()  # no summary yet
    assert table6_3.main(["--runs", str(tmp_path), "--out", str(tmp_path / "t.md")]) == 0
    out = capsys.readouterr()
    row = [line for line in out.out.splitlines() if line.startswith("| K50_n0.8_e2 ")][0]
    assert "| 2 | 2.500 ± 0.707 | 45.0 ± 7.1 |" in row
    assert "50%" in row and "1.783 (CEM-N25)" in row
    assert "K10_n0_e1/" not in out.out and "K10_n0_e1_seed0" in out.err
    assert "K10_n0_e2_seed0" in out.err
    assert (tmp_path / "t.md").read_text() == out.out


def test_missing_tree_is_reported(tmp_path, capsys):
    assert table6_3.main(["--runs", str(tmp_path / "nothing")]) == 0
    assert "no such directory" in capsys.readouterr().err
