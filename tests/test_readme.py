"""The README's code runs as written."""

import os
import re

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
README = os.path.join(ROOT, "README.md")
# Pages whose Python examples run with the README's (the examples moved off the front page).
EXAMPLES = (README, os.path.join(ROOT, "docs", "tasks.md"))


def _blocks(language, path=README):
    with open(path, encoding="utf-8") as f:
        return re.findall(rf"```{language}\n(.*?)```", f.read(), flags=re.S)


def test_python_examples_run(tmp_path, monkeypatch):
    """Every Python block, in a scratch folder (the submission example writes runs/)."""
    monkeypatch.chdir(tmp_path)
    for path in EXAMPLES:
        blocks = _blocks("python", path)
        assert blocks, path
        for code in blocks:
            exec(compile(code, path, "exec"), {"__name__": "__readme__"})
    assert (
        tmp_path / "submissions" / "my_method" / "darwin_walk" / "first_seed0" / "trials.csv"
    ).exists()


def test_the_front_page_fits_250_lines():
    with open(README, encoding="utf-8") as f:
        assert len(f.read().splitlines()) <= 250


def test_quick_start_has_the_main_job_and_both_test_tiers():
    quick = _blocks("bash")[0]
    commands = [line for line in quick.splitlines() if line and not line.startswith("#")]
    assert len(commands) == 3
    assert commands[0].startswith("pip install . && python -m baselines.")
    assert commands[1] == 'pip install ".[test]" && pytest -q -m "not slow"'
    assert commands[2] == 'pip install ".[test,rl,mjx,cluster]" && pytest -q -m slow'
