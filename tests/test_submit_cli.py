"""`python -m cpg_suite.protocol.submit` refuses what it cannot take in its own words, in one
line with exit 2, before any scoring: a gait not given by name, a policy or action table
that is not NumPy's format (a pickle, text), and an output folder it cannot make, named as
the output folder (--root), not as the input file."""

import json
import os
import pickle
import subprocess
import sys

import numpy as np
import pytest

from cpg_suite import cpg

HEADLESS = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "DISPLAY")}


def _submit(cwd, *args) -> list[str]:
    out = subprocess.run(
        [sys.executable, "-m", "cpg_suite.protocol.submit", "--method=mine", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        env=HEADLESS,
        timeout=300,
    )
    assert out.returncode == 2, out.stderr[-2000:]
    assert out.stdout == ""
    return out.stderr.splitlines()


@pytest.fixture
def inputs(tmp_path):
    """A folder of submitted files, good and bad."""
    hand_tuned = dict(zip(cpg.AMPLITUDE_NAMES, cpg.PRESETS["hand_tuned"]))
    (tmp_path / "by_name.json").write_text(json.dumps(hand_tuned))
    (tmp_path / "list.json").write_text(json.dumps(list(cpg.PRESETS["hand_tuned"])))
    listed = {"amplitudes": list(cpg.PRESETS["hand_tuned"])}
    (tmp_path / "listed.json").write_text(json.dumps(listed))
    (tmp_path / "notes.txt").write_text("my policy, in words\n")
    with open(tmp_path / "model.pkl", "wb") as f:
        pickle.dump({"weights": [1.0, 2.0]}, f)
    np.savez(tmp_path / "objects.npz", layer=np.array([{"w": 1}], dtype=object))
    (tmp_path / "a_file").write_text("")
    return tmp_path


@pytest.mark.parametrize("name", ["list.json", "listed.json"])
def test_a_gait_goes_by_name_only(inputs, name):
    (line,) = _submit(inputs, f"--gait={name}")
    assert line.startswith(f"error: --gait={name}: the amplitudes go by name, ")
    assert "got a JSON array" in line and "balancing_hip" in line


@pytest.mark.parametrize(
    "flag, name, words",
    [
        ("policy", "notes.txt", "is not a NumPy .npz archive of arrays"),
        ("policy", "model.pkl", "is not a NumPy .npz archive of arrays"),
        ("actions", "model.pkl", "is not a NumPy .npy array"),
        ("policy", "objects.npz", ": it holds pickled (object) arrays"),
    ],
)
def test_a_pickle_or_text_is_refused_in_submits_own_words(inputs, flag, name, words):
    (line,) = _submit(inputs, f"--{flag}={name}")
    assert line.startswith(f"error: --{flag}={name}") and words in line, line
    assert "allow_pickle" not in line and "pickle.load" not in line
    assert not (inputs / "runs").exists()


def test_output_folder_errors_name_the_output_folder(inputs):
    (line,) = _submit(inputs, "--gait=by_name.json", "--root=a_file/runs")
    assert line == "error: --root=a_file/runs: a_file is not a directory"
    taken = inputs / "runs" / "mine" / "darwin_walk" / "default_seed0"
    taken.mkdir(parents=True)
    (line,) = _submit(inputs, "--gait=by_name.json")
    run_dir = os.path.join("runs", "mine", "darwin_walk", "default_seed0")
    assert line == f"error: --root=runs: {run_dir} exists: a submission makes a new run"
    assert "by_name.json" not in line
    assert os.listdir(taken) == []
