"""Bring your own optimizer: pycma's own ask/tell through the benchmark's loop."""

import dataclasses

import numpy as np
import pytest

from analysis import leaderboard
from cpg_suite import cpg
from cpg_suite.harness import interface, optimize
from cpg_suite.protocol import score
from cpg_suite.runfiles import runs

cma = pytest.importorskip("cma")


class Killed(Exception):
    pass


def _pycma(seed):
    es = cma.CMAEvolutionStrategy(
        cpg.amplitudes_from("hand_tuned"), 1.0, {"popsize": 5, "seed": seed, "verbose": -9}
    )
    return optimize.AskTell(es)


SETTINGS = interface.OptimizerSettings(
    population=5, rounds=3, trial_steps=120, validation_seeds=2, test_seeds=2
)


def _without_wall(summary):
    return {k: v for k, v in summary.items() if k != "wall_s"}


@pytest.mark.slow  # a training run
def test_pycma_runs_resumes_and_reaches_the_leaderboard(tmp_path):
    full_options = runs.RunOptions(output_dir=str(tmp_path / "a"))
    run_dir, full = optimize.run(_pycma(1), SETTINGS, full_options, "pycma", log=lambda x: None)
    assert run_dir.endswith("pycma/darwin_walk/pycma_seed0")
    assert "test" in full and set(full["test"]["tiers"]) == set(interface.TASKS)

    def die_after_one(line):
        if line.startswith("round   1"):
            raise Killed

    options = runs.RunOptions(output_dir=str(tmp_path / "b"))
    with pytest.raises(Killed):
        optimize.run(_pycma(1), SETTINGS, options, "pycma", log=die_after_one)
    np.random.seed(999)  # pycma samples from NumPy's global generator; the checkpoint has it
    resume = dataclasses.replace(options, resume=True)
    _, resumed = optimize.run(_pycma(1), SETTINGS, resume, "pycma", log=lambda x: None)
    assert _without_wall(resumed) == _without_wall(full)

    found, skipped = leaderboard.find_runs(str(tmp_path / "a"))
    assert not skipped
    rows = leaderboard.darwin_rows(found)
    assert [r["method"] for r in rows] == ["pycma"]


def test_run_killed_while_scoring_its_test_card_is_finished_on_resume(tmp_path, monkeypatch):
    """summary.json marks a finished run: a kill during the test scoring leaves none, and
    --resume completes the run with the summary of an undisturbed one."""
    _, full = optimize.run(
        _pycma(2), SETTINGS, runs.RunOptions(output_dir=str(tmp_path / "a")), "pycma", log=str
    )
    options = runs.RunOptions(output_dir=str(tmp_path / "b"))

    def killed(*args, **kwargs):
        raise Killed

    with monkeypatch.context() as patch:
        patch.setattr(score, "score_gait", killed)
        with pytest.raises(Killed):
            optimize.run(_pycma(2), SETTINGS, options, "pycma", log=str)
    run_dir = tmp_path / "b" / "pycma" / "darwin_walk" / "pycma_seed0"
    assert (run_dir / "checkpoint.json").exists() and not (run_dir / "summary.json").exists()
    np.random.seed(5)
    resume = dataclasses.replace(options, resume=True)
    _, resumed = optimize.run(_pycma(2), SETTINGS, resume, "pycma", log=str)
    assert "test" in resumed and _without_wall(resumed) == _without_wall(full)
