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
    code (benchmarks/, baselines/experiments/)."""
    import os

    root = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "results")
    code = [
        os.path.join(dirpath, name)
        for dirpath, _, names in os.walk(root)
        for name in names
        if name.endswith((".py", ".sh"))
    ]
    assert not code, code
