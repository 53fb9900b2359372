"""`cpg_suite.evaluation.evaluate` and `cpg_suite.explore` from the command line."""

import json
import os
import subprocess
import sys

import pytest

from cpg_suite import cpg


def run(module, *args, env=None):
    return subprocess.run(
        [sys.executable, "-m", module, *args], capture_output=True, text=True, timeout=600, env=env
    )


def test_evaluate_prints_a_json_line_per_seed_and_a_summary(tmp_path):
    gait = tmp_path / "gait.json"
    gait.write_text(json.dumps(dict(zip(cpg.AMPLITUDE_NAMES, cpg.PRESETS["hand_tuned"]))))
    out = run(
        "cpg_suite.evaluation.evaluate",
        "--task=darwin_walk",
        f"--params={gait}",
        "--seeds=0-1",
        "--steps=150",
    )
    assert out.returncode == 0, out.stderr
    lines = [json.loads(line) for line in out.stdout.splitlines()]
    assert [r["seed"] for r in lines[:2]] == [0, 1]
    for r in lines[:2]:
        assert set(r) >= {"seed", "distance_m", "lateral_m", "fell", "fall_step"}
    assert lines[2]["summary"] and lines[2]["n"] == 2
    # The file and the preset give the same numbers, and so does the fast evaluator
    # (its lines lack only the environment's "return").
    preset = run(
        "cpg_suite.evaluation.evaluate", "--params=hand_tuned", "--seeds=0-1", "--steps=150"
    )
    assert preset.stdout.splitlines()[:2] == out.stdout.splitlines()[:2]
    fast = run(
        "cpg_suite.evaluation.evaluate",
        "--params=hand_tuned",
        "--seeds=0-1",
        "--steps=150",
        "--fast",
        "--threads=2",
    )
    assert fast.returncode == 0, fast.stderr
    for line, ref in zip(fast.stdout.splitlines()[:2], lines[:2]):
        got = json.loads(line)
        assert got == {k: ref[k] for k in got}


@pytest.mark.parametrize(
    "args, words",
    [
        (["--params=walk_fast"], "neither a preset"),
        (["--seeds=3-1"], "malformed seeds"),
        (["--seeds=a"], "malformed seeds"),
        (["--task=pole_balance"], "unknown --task"),
        (["--steps=0"], "--steps"),
        (["--fast", "--threads=0"], "--threads"),
    ],
)
def test_evaluate_bad_input(args, words):
    out = run("cpg_suite.evaluation.evaluate", *args)
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and words in lines[0]


def test_evaluate_bad_params_file(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"hip": 1.0}))
    out = run("cpg_suite.evaluation.evaluate", f"--params={bad}")
    assert out.returncode == 2 and "missing" in out.stderr


@pytest.mark.slow  # renders a whole trial twice
@pytest.mark.parametrize("fmt, suffix", [("gif", ".gif"), ("mp4", ".mp4")])
def test_explore_renders_a_video_and_a_filmstrip(tmp_path, fmt, suffix):
    pytest.importorskip("PIL")
    if fmt == "mp4":
        pytest.importorskip("imageio_ffmpeg")
    out = run(
        "cpg_suite.explore",
        "--params=hand_tuned",
        f"--out={tmp_path}",
        "--steps=60",
        "--width=64",
        "--height=48",
        f"--format={fmt}",
        "--frames=4",
    )
    assert out.returncode == 0, out.stderr
    assert (tmp_path / f"hand_tuned{suffix}").stat().st_size > 1000
    from PIL import Image

    strip = Image.open(tmp_path / "hand_tuned_filmstrip.png")
    assert strip.size == (4 * 64, 48 + 24)


@pytest.mark.parametrize(
    "args, words",
    [
        (["--camera=nope"], "unknown camera"),
        (["--task=pole_balance"], "unknown --task"),
        (["--params=nope"], "--params"),
        (["--frames=0"], "--frames"),
    ],
)
def test_explore_bad_input(tmp_path, args, words):
    out = run("cpg_suite.explore", f"--out={tmp_path}", *args)
    assert out.returncode == 2
    assert len(out.stderr.strip().splitlines()) == 1 and words in out.stderr


def test_explore_renders_headless_without_mujoco_gl(tmp_path):
    """Without a display and without MUJOCO_GL the command chooses EGL for itself."""
    pytest.importorskip("PIL")
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "DISPLAY")}
    out = run(
        "cpg_suite.explore",
        "--params=hand_tuned",
        f"--out={tmp_path}",
        "--steps=20",
        "--width=32",
        "--height=32",
        "--format=gif",
        "--frames=2",
        env=env,
    )
    assert out.returncode == 0, out.stderr
    assert (tmp_path / "hand_tuned_filmstrip.png").exists()


@pytest.mark.slow  # renders the three tasks and 150 frames of the leader's trial
def test_the_front_page_pictures_are_the_packages_renders(tmp_path):
    """`python -m cpg_suite.pictures` (what `analysis.rebuild` runs) draws the three tasks
    and the board leader's filmstrip, headless, without MUJOCO_GL."""
    from PIL import Image

    from cpg_suite import pictures

    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "DISPLAY")}
    out = run("cpg_suite.pictures", f"--out={tmp_path}", env=env)
    assert out.returncode == 0, out.stderr
    width, height = pictures.TILE
    assert Image.open(tmp_path / "tasks.png").size == (3 * width, height)
    strip = Image.open(tmp_path / "leader_gait.png")
    assert strip.size == (pictures.FRAMES * width, height + 24)
    assert out.stdout.splitlines()[-1].startswith("the leader's gait (")


def test_the_leader_is_the_study_tracks_first_row(tmp_path):
    from cpg_suite import pictures

    board = tmp_path / "darwin_leaderboard.csv"
    head = "track,rank,method,training_task,config\n"
    board.write_text(head + "4x,1,cmaes,darwin_walk,K50\nstudy,2,cem,darwin_walk,K50\n")
    with pytest.raises(ValueError, match="no ranked study row"):
        pictures.leader(str(board), str(tmp_path))
    board.write_text(head + "study,1,cem,darwin_walk,K50\n")
    with pytest.raises(ValueError, match="no shipped run matches"):
        pictures.leader(str(board), str(tmp_path))
    for seed in (10, 2):
        (tmp_path / "cem" / "darwin_walk" / f"K50_seed{seed}").mkdir(parents=True)
    label, run_dir = pictures.leader(str(board), str(tmp_path))
    assert label == "cem K50" and run_dir.endswith("K50_seed2")
