"""Every tracked file under results/ that derives from the shipped runs equals its rebuild."""

import pytest

from analysis import rebuild


def test_the_board_table_goes_between_the_markers():
    text = f"intro\n{rebuild.MARKERS[0]}\n| old |\n{rebuild.MARKERS[1]}\nafter\n"
    out = rebuild.readme_with_table(text, "| new |\n")
    assert out == f"intro\n{rebuild.MARKERS[0]}\n| new |\n{rebuild.MARKERS[1]}\nafter\n"
    with pytest.raises(ValueError, match="board markers"):
        rebuild.readme_with_table("no markers", "| new |\n")


@pytest.mark.slow
def test_nothing_derived_differs_from_its_rebuild():
    """The boards, their not-admitted lists, the README's board table and results/study/
    are what `python -m analysis.rebuild` makes from the shipped runs (about 2 minutes)."""
    assert rebuild.check() == []


def test_results_holds_data_not_code():
    """results/ keeps data, figures and READMEs; the scripts that made them live with the
    code (investigations/, benchmarks/, baselines/experiments/)."""
    import os

    root = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "results")
    code = [
        os.path.join(dirpath, name)
        for dirpath, _, names in os.walk(root)
        for name in names
        if name.endswith((".py", ".sh"))
    ]
    assert not code, code


def _shipped(root, name: str, test_m: float, v1_m: float | None = None) -> None:
    run = root / "ppo" / "darwin_walk" / name
    run.mkdir(parents=True)
    card = {"all": {"success_weighted_distance_m": {"mean": test_m}}}
    summary = {"test": card, "selected": {"validation_success_weighted_m": test_m + 1}}
    summary["train_wall_s"] = 1000.0 * test_m
    if v1_m is not None:
        summary["history"] = {"v1": {"all": {"success_weighted_distance_m": {"mean": v1_m}}}}
    (run / "summary.json").write_text(__import__("json").dumps(summary))


def test_quoted_numbers_are_written_from_the_runs(tmp_path):
    from analysis import facts

    for seed, (m, old) in enumerate([(3.2, 5.0), (4.456, 6.0), (1.0, 7.25)]):
        _shipped(tmp_path, f"cpg_seed{seed}", m, old)
    stale = (
        "scored <!-- fact: test_range ppo/darwin_walk/cpg_seed* -->9.99<!-- /fact --> m, "
        "<!-- fact: v1_test_range ppo/darwin_walk/cpg_seed* --><!-- /fact --> before; "
        "<!-- fact: seeds ppo/darwin_walk/* -->2<!-- /fact --> seeds of "
        "<!-- fact: runs -->0<!-- /fact -->, trained "
        "<!-- fact: train_s_range ppo/darwin_walk/cpg_seed0 --><!-- /fact --> s"
    )
    filled = facts.fill(stale, str(tmp_path))
    assert facts.PATTERN.sub(lambda m: f"[{m.group(3)}]", filled) == (
        "scored [1.00-4.46] m, [5.00-7.25] before; [3] seeds of [3], trained [3,200] s"
    )
    assert facts.fill(filled, str(tmp_path)) == filled  # a rebuild of a rebuild: the same


@pytest.mark.parametrize(
    "text, words",
    [
        ("<!-- fact: speed ppo/* -->1<!-- /fact -->", "unknown fact 'speed'"),
        ("<!-- fact: test_range -->1<!-- /fact -->", "needs a glob"),
        ("<!-- fact: seeds cem/* -->1<!-- /fact -->", "no shipped run matches 'cem/\\*'"),
    ],
)
def test_a_bad_quote_is_refused(tmp_path, text, words):
    from analysis import facts

    _shipped(tmp_path, "cpg_seed0", 1.0)
    with pytest.raises(ValueError, match=words):
        facts.fill(text, str(tmp_path))


def test_the_pages_quote_the_shipped_runs_as_they_are():
    """Every number the README, docs/ and results/ READMEs quote between fact markers is
    the shipped runs' (the board table and results/study are the slow test's)."""
    import os

    from analysis import facts

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    stale = []
    for page in facts.pages(root):
        with open(page, encoding="utf-8") as f:
            text = f.read()
        if facts.fill(text, os.path.join(root, rebuild.RUNS)) != text:
            stale.append(page)
    assert not stale, f"rebuild with python -m analysis.rebuild: {stale}"


def test_the_mean_and_the_failures_per_tier_are_written_from_the_cards(tmp_path):
    import json

    from analysis import facts

    for seed, (m, falls) in enumerate([(2.0, (0.0, 0.02)), (3.0, (0.1, 0.0))]):
        _shipped(tmp_path, f"fb_seed{seed}", m)
        path = tmp_path / "ppo" / "darwin_walk" / f"fb_seed{seed}" / "summary.json"
        summary = json.loads(path.read_text())
        summary["test"]["tiers"] = {
            t: {"fall_rate": {"value": f}}
            for t, f in zip(("darwin_walk", "darwin_walk_rough"), falls)
        }
        path.write_text(json.dumps(summary))
    text = (
        "<!-- fact: test_mean ppo/darwin_walk/fb_seed* -->0<!-- /fact --> m, "
        "<!-- fact: tier_failures ppo/darwin_walk/fb_seed* -->0<!-- /fact --> %"
    )
    filled = facts.fill(text, str(tmp_path))
    assert facts.PATTERN.sub(lambda m: f"[{m.group(3)}]", filled) == "[2.50] m, [5.0 / 1.0] %"
    summary["test"]["tiers"] = {"darwin_walk": {"fall_rate": {"value": 0.0}}}
    path.write_text(json.dumps(summary))
    with pytest.raises(ValueError, match="cards of different tiers"):
        facts.fill(text, str(tmp_path))
