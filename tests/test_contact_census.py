"""investigations/contact_census.py: it sees contacts outside the soles' pairs, runs a trial as
the score card does, and stops on bad input with one line."""

import csv
import importlib.util
import os
import subprocess
import sys

import mujoco

import cpg_suite

SCRIPT = os.path.join(os.path.dirname(__file__), "..", "investigations", "contact_census.py")


def _module():
    spec = importlib.util.spec_from_file_location("contact_census", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclass looks its annotations up there
    spec.loader.exec_module(module)
    return module


def _run(*args):
    return subprocess.run(
        [sys.executable, SCRIPT, *args], capture_output=True, text=True, timeout=300
    )


def test_a_torso_on_the_floor_is_another_contact():
    census = _module()
    physics = cpg_suite.load("darwin_walk", task_kwargs={"random": 0}).physics
    kept = census.kept_geoms(physics.model)
    mujoco.mj_forward(physics.model.ptr, physics.data.ptr)
    assert census.other_contacts(physics, kept) == ()  # standing on its soles
    physics.data.qpos[2] = 0.02  # the torso sunk to 2 cm above the floor
    mujoco.mj_forward(physics.model.ptr, physics.data.ptr)
    names = {physics.model.id2name(g, "geom") for g in census.other_contacts(physics, kept)}
    assert "torso_lower" in names or "torso_middle" in names


def test_the_hand_tuned_gait_touches_with_its_soles_only(tmp_path):
    out_file = tmp_path / "census.csv"
    args = ["--runs=", "--seeds=1", "--tiers=darwin_walk", "--steps=100", f"--out={out_file}"]
    out = _run(*args)
    assert out.returncode == 0, out.stderr
    assert "hand_tuned" in out.stdout
    with open(out_file, encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 1 and rows[0]["physics_steps"] == "800"
    assert rows[0]["fell"] == "False" and rows[0]["other_contact_steps"] == "0"


def test_bad_input_is_one_line_exit_2(tmp_path):
    for args, words in (
        (["--seeds=0"], "--seeds"),
        (["--tiers=darwin_walk,nowhere"], "--tiers"),
        ([f"--runs={tmp_path / 'missing'}"], "--runs"),
    ):
        out = _run(*args)
        lines = out.stderr.strip().splitlines()
        assert out.returncode == 2 and len(lines) == 1, out.stderr
        assert lines[0].startswith("error: ") and words in lines[0]


def test_a_feedback_run_is_censused_with_its_gains(tmp_path):
    """The census runs each gait with its own controller, as the scorer reads it: a feedback
    run's gains are not dropped (it loaded every gait as open-loop amplitudes)."""
    import shutil

    import numpy as np

    from cpg_suite.evaluation import closed_loop
    from cpg_suite.protocol import score, verify

    shipped = os.path.join(os.path.dirname(__file__), "..", "results", "protocol", "runs")
    rel = os.path.join("cmaes", "darwin_walk_rough", "K50_s1_feedback_seed1")
    shutil.copytree(os.path.join(shipped, rel), tmp_path / rel)
    rel_cem = os.path.join("cem", "darwin_walk", "K50_n0.8_e2_seed0")
    shutil.copytree(os.path.join(shipped, rel_cem), tmp_path / rel_cem)
    found = {run: policy for _, run, policy in _module().configurations(str(tmp_path))}
    gains = found[rel]
    assert isinstance(gains, closed_loop.FeedbackPolicy)
    want = verify.gait_params(str(tmp_path / rel), "feedback")
    assert np.array_equal(gains.params, want)
    assert isinstance(found[rel_cem], score.OpenLoopPolicy)
