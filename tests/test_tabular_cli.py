"""`python -m baselines.tabular`: outputs and one-line errors with exit code 2."""

import json
import subprocess
import sys

import numpy as np
import pytest

from baselines.tabular import models, planning


def run_cli(*args):
    """Runs the installed `baselines.tabular` module in a fresh interpreter."""
    return subprocess.run(
        [sys.executable, "-m", "baselines.tabular", *args],
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_value_iteration_two_sweeps_writes_the_library_values(tmp_path):
    """values.csv holds V after 2 sweeps (= thesis Table A.3, see test_tabular_planning)."""
    out = run_cli(
        "--model=tokic",
        "--algo=value_iteration",
        "--gamma=0.9",
        "--sweeps=2",
        f"--output_dir={tmp_path}",
    )
    assert out.returncode == 0, out.stderr
    run_dir = tmp_path / "value_iteration" / "tokic" / "seed0"
    values = np.loadtxt(run_dir / "values.csv", delimiter=",")
    expected = planning.value_iteration(models.tokic_model(), 0.9, sweeps=2).values
    np.testing.assert_allclose(values, expected.reshape(5, 5), atol=5e-7)
    assert values[3, 4] == 113.038306
    assert "," in (run_dir / "values.csv").read_text().splitlines()[0]  # No header.
    summary = json.loads((run_dir / "summary.json").read_text())
    assert {"cycle", "cycle_reward"} <= set(summary)
    config = json.loads((run_dir / "config.json").read_text())
    assert config["settings"]["sweeps"] == 2 and config["environment"]["mujoco_version"]


def test_value_iteration_converged_cycle(tmp_path):
    out = run_cli("--model=tokic", "--algo=value_iteration", f"--output_dir={tmp_path}")
    assert out.returncode == 0, out.stderr
    summary = json.loads((tmp_path / "value_iteration/tokic/seed0/summary.json").read_text())
    assert summary["cycle_length"] == 6 and summary["cycle_reward"] == 53
    assert summary["cycle"] == [[2, 1], [2, 2], [3, 2], [3, 1], [3, 0], [2, 0]]


def test_pole_q_learning_run_files(tmp_path):
    out = run_cli(
        "--task=pole_balance",
        "--algo=q_learning",
        "--steps=3000",
        "--alpha=0.01",
        "--gamma=0.9",
        "--bins=20x20",
        "--seed=0",
        f"--output_dir={tmp_path}",
    )
    assert out.returncode == 0, out.stderr
    run_dir = tmp_path / "q_learning" / "pole_balance" / "seed0"
    summary = json.loads((run_dir / "summary.json").read_text())
    for key in ("falls", "last_fall_step", "longest_balance_steps", "rms_angle_last_5000"):
        assert key in summary
    lines = (run_dir / "progress.csv").read_text().splitlines()
    assert lines[0].startswith("episode,")
    assert len(lines) - 1 == summary["falls"] + 1  # one row per episode
    assert np.load(run_dir / "angles.npy").shape == (3000,)
    assert np.load(run_dir / "q_table.npy").shape == (20, 20, 3)


def test_existing_run_directory_is_not_overwritten(tmp_path):
    args = ("--model=tokic", "--algo=value_iteration", "--sweeps=1", f"--output_dir={tmp_path}")
    assert run_cli(*args).returncode == 0
    summary = tmp_path / "value_iteration/tokic/seed0/summary.json"
    before = summary.read_text()
    out = run_cli(*args)
    assert out.returncode == 2 and "--overwrite" in out.stderr
    assert summary.read_text() == before
    assert run_cli(*args, "--overwrite").returncode == 0


@pytest.mark.parametrize(
    "args, words",
    [
        (["--task=pole_swingup"], "unknown task"),
        (["--model=nope"], "unknown --model"),
        (["--model=tokic", "--algo=deep_q"], "unknown --algo"),
        (["--task=pole_balance", "--bins=20x"], "malformed bins"),
        (["--task=pole_balance", "--bins=axb"], "malformed bins"),
        (["--task=pole_balance", "--alpha=1.5"], "--alpha must be a finite number in [0, 1]"),
        (["--task=pole_balance", "--alpha=-0.1"], "--alpha must be a finite number in [0, 1]"),
        (["--task=pole_balance", "--gamma=2"], "--gamma must be a finite number in [0, 1]"),
        (["--task=pole_balance", "--gamma=abc"], "gamma"),
        (["--task=pole_balance", "--epsilon=0:2"], "ε"),
        (["--task=pole_balance", "--algo=value_iteration"], "complete model"),
        (["--task=pole_balance", "--algo=td0"], "successor"),
        (["--task=pole_balance_continuous"], "continuous"),
        (["--model=tokic", "--task=pole_balance"], "exactly one"),
        ([], "exactly one"),
        (["--task=pole_balance", "--no_such_flag=1"], "no_such_flag"),
        (["--task=pole_balance", "--force=-4"], "--force"),
    ],
)
def test_bad_input_one_line_exit_2(tmp_path, args, words):
    out = run_cli(*args, f"--output_dir={tmp_path}")
    assert out.returncode == 2, (out.returncode, out.stderr)
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1, out.stderr
    assert lines[0].startswith("error: ") and words in lines[0]
    assert not any(tmp_path.iterdir())  # Nothing was written.


@pytest.mark.parametrize(
    "args, words",
    [(["--seeds=1"], "--seeds"), (["--steps=100"], "--steps"), (["--seeds=x"], "seeds")],
)
def test_pole_claims_bad_input(tmp_path, args, words):
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "baselines.experiments.pole_claims",
            *args,
            f"--output_dir={tmp_path}",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 2
    assert len(out.stderr.strip().splitlines()) == 1 and words in out.stderr
