"""CEM (thesis Alg. 6.1): the update, the toy example, run files, determinism, resume."""

import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest

from baselines import cem
from cpg_suite.harness import checkpoints
from cpg_suite.runfiles import runs


def test_first_sample_is_the_mean():
    opt = cem.CEM(np.arange(11.0), population=5, elite=2, noise=0.8, seed=0)
    samples = opt.ask()
    assert samples.shape == (5, 11)
    np.testing.assert_array_equal(samples[0], np.arange(11.0))


def test_update_known_answer():
    opt = cem.CEM(np.zeros(2), population=4, elite=2, noise=0.5, seed=0)
    samples = np.array([[0.0, 0.0], [1.0, 3.0], [3.0, 1.0], [9.0, 9.0]])
    opt.tell(samples, np.array([5.0, 1.0, 2.0, 0.5]))  # elite: rows 3 and 1
    np.testing.assert_allclose(opt.mean, [5.0, 6.0])
    # Σ about the NEW mean, weights 1/elite, plus noise on the diagonal.
    np.testing.assert_allclose(opt.cov, [[16.0 + 0.5, 12.0], [12.0, 9.0 + 0.5]])


def test_elite_one_without_noise_collapses_the_covariance():
    """Thesis 6.1: with elite = 1 and no noise the new covariance is 0."""
    opt = cem.CEM(np.zeros(3), population=6, elite=1, noise=0.0, seed=1)
    samples = opt.ask()
    opt.tell(samples, np.arange(6.0)[::-1])
    np.testing.assert_array_equal(opt.mean, samples[-1])
    np.testing.assert_array_equal(opt.cov, np.zeros((3, 3)))


def _toy(noise, seed, rounds=60):
    """Thesis Sec. 6.1: a point in the plane, cost = distance to the origin."""
    opt = cem.CEM(
        np.array([8.0, 8.0]),
        population=10,
        elite=5,
        noise=noise,
        seed=seed,
        covariance=9.0 * np.eye(2),
    )
    for _ in range(rounds):
        samples = opt.ask()
        opt.tell(samples, np.linalg.norm(samples, axis=1))
    return opt


def test_toy_example_claims():
    # CEMT-1: the mean starts 11.31 from the target; it is the first sample CEM evaluates.
    start = _toy(0.0, 0, rounds=0)
    assert np.linalg.norm(start.ask()[0]) == pytest.approx(11.31, abs=0.01)
    plain = [_toy(0.0, s) for s in range(5)]
    noisy = [_toy(0.8, s) for s in range(5)]
    # CEMT-2: without noise Σ collapses and the mean stops short of the origin.
    assert all(o.sigma < 1e-3 for o in plain)
    assert np.mean([np.linalg.norm(o.mean) for o in plain]) > 0.3
    # CEMT-3: with noise 0.8 the mean gets close to the origin (the study: error ≈ 0.1).
    assert np.mean([np.linalg.norm(o.mean) for o in noisy]) < 0.5


def test_invalid_configuration():
    for kwargs in (
        {"population": 1, "elite": 1},
        {"population": 4, "elite": 5},
        {"population": 4, "elite": 0},
        {"population": 4, "elite": 2, "noise": -1},
    ):
        with pytest.raises(ValueError):
            cem.CEM(np.zeros(11), **{"noise": 0.8, "seed": 0, **kwargs})


def _settings(**kw):
    base = dict(
        population=4,
        elite=2,
        noise=0.8,
        rounds=3,
        trial_steps=120,
        fall_penalty=1.0,
        validation_seeds=2,
        test_seeds=2,
    )
    return cem.CEMSettings(**{**base, **kw})


def _options(tmp_path, **kw):
    return runs.RunOptions(output_dir=str(tmp_path), run_name="r", **kw)


def _without_wall(summary):
    return {k: v for k, v in summary.items() if k != "wall_s"}


def test_run_files_and_thread_independence(tmp_path):
    d1, s1 = cem.run_cem(_settings(), _options(tmp_path / "a", threads=1), log=lambda line: None)
    d2, s2 = cem.run_cem(_settings(), _options(tmp_path / "b", threads=2), log=lambda line: None)
    assert _without_wall(s1) == _without_wall(s2)
    for name in (
        "config.json",
        "progress.csv",
        "checkpoint.json",
        "best_params.json",
        "mean_params.json",
        "summary.json",
    ):
        assert (tmp_path / "a" / "cem" / "darwin_walk" / "r" / name).exists()
    for key in (
        "best_distance_m",
        "best_round",
        "final_mean_distance_m",
        "falls_total",
        "rounds",
        "evaluations",
        "sim_steps",
        "wall_s",
    ):
        assert key in s1
    assert s1["rounds"] == 3 and s1["evaluations"] == 3 * 4 + 1
    lines = (tmp_path / "a/cem/darwin_walk/r/progress.csv").read_text().splitlines()
    assert len(lines) == 4 and lines[0].startswith("round,")
    best = json.loads((tmp_path / "a/cem/darwin_walk/r/best_params.json").read_text())
    assert len(best["amplitudes"]) == 11


class Killed(Exception):
    pass


def test_kill_and_resume_gives_the_same_summary(tmp_path):
    _, full = cem.run_cem(_settings(rounds=4), _options(tmp_path / "full"), log=lambda line: None)

    def die_after_two(line):
        if line.startswith("round   2"):
            raise Killed

    settings, options = _settings(rounds=4), _options(tmp_path / "killed")
    with pytest.raises(Killed):
        cem.run_cem(settings, options, log=die_after_two)
    run_dir = tmp_path / "killed/cem/darwin_walk/r"
    assert not (run_dir / "summary.json").exists()
    assert json.loads((run_dir / "checkpoint.json").read_text())["totals"]["round"] == 2
    resume = dataclasses.replace(options, resume=True)
    _, resumed = cem.run_cem(settings, resume, log=lambda line: None)
    assert _without_wall(resumed) == _without_wall(full)
    full_rows = (tmp_path / "full/cem/darwin_walk/r/progress.csv").read_text().splitlines()
    rows = (run_dir / "progress.csv").read_text().splitlines()
    assert [r.split(",")[:11] for r in rows] == [r.split(",")[:11] for r in full_rows]


def test_corrupt_and_foreign_checkpoints_are_refused(tmp_path):
    settings, options = _settings(rounds=5), _options(tmp_path)

    def die(line):
        raise Killed

    with pytest.raises(Killed):
        cem.run_cem(settings, options, log=die)
    checkpoint = tmp_path / "cem/darwin_walk/r/checkpoint.json"
    resume = dataclasses.replace(options, resume=True)
    with pytest.raises(checkpoints.CheckpointError, match="another configuration"):
        cem.run_cem(dataclasses.replace(settings, population=6), resume, log=die)
    checkpoint.write_text("{not json")
    with pytest.raises(checkpoints.CheckpointError, match="cannot read"):
        cem.run_cem(settings, resume, log=die)


def test_existing_run_is_not_overwritten(tmp_path):
    cem.run_cem(_settings(rounds=1), _options(tmp_path), log=lambda line: None)
    with pytest.raises(runs.RunDirectoryExists):
        cem.run_cem(_settings(rounds=1), _options(tmp_path), log=lambda line: None)


def _cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "baselines.cem", *args], capture_output=True, text=True, timeout=300
    )


@pytest.mark.parametrize(
    "args, words",
    [
        (["--elite=11", "--population=10"], "--elite"),
        (["--population=1"], "--population"),
        (["--noise=-0.1"], "--noise"),
        (["--task=darwin_run"], "unknown --task"),
        (["--rounds=0"], "--rounds"),
        (["--resume", "--overwrite"], "exclude"),
        (["--grid=table6_3", "--settings=K7"], "unknown --settings"),
        (["--grid=table9"], "grid"),
    ],
)
def test_cli_bad_flags(tmp_path, args, words):
    out = _cli(*args, f"--output_dir={tmp_path}")
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and words in lines[0]
    assert not any(tmp_path.iterdir())


def test_cli_run_and_refusal_to_overwrite(tmp_path):
    args = (
        "--population=3",
        "--rounds=1",
        "--trial_steps=50",
        "--test_seeds=2",
        f"--output_dir={tmp_path}",
    )
    out = _cli(*args)
    assert out.returncode == 0, out.stderr
    assert "round   1" in out.stdout
    again = _cli(*args)
    assert again.returncode == 2 and "--overwrite" in again.stderr


def test_cmaes_runs_resumes_and_is_thread_independent(tmp_path):
    from baselines import cmaes

    settings = cmaes.CMAESSettings(
        population=4, rounds=3, trial_steps=120, fall_penalty=1.0, validation_seeds=2, test_seeds=2
    )
    _, full = cmaes.run_cmaes(settings, _options(tmp_path / "a", threads=1), log=lambda x: None)
    _, two = cmaes.run_cmaes(settings, _options(tmp_path / "b", threads=2), log=lambda x: None)
    assert _without_wall(full) == _without_wall(two)
    assert full["evaluations"] == 3 * 4 + 1
    rows = (tmp_path / "a" / "cmaes" / "darwin_walk" / "r" / "progress.csv").read_text()
    header, first = rows.splitlines()[:2]
    cells = dict(zip(header.split(","), first.split(",")))
    assert cells["mean_distance_m"] == ""  # CMA-ES does not sample its mean

    def die_after_one(line):
        if line.startswith("round   1"):
            raise Killed

    killed = _options(tmp_path / "c")
    with pytest.raises(Killed):
        cmaes.run_cmaes(settings, killed, log=die_after_one)
    np.random.seed(12345)  # Something else touches NumPy's global generator in between.
    resume = dataclasses.replace(killed, resume=True)
    _, resumed = cmaes.run_cmaes(settings, resume, log=lambda line: None)
    assert _without_wall(resumed) == _without_wall(full)


def test_cmaes_cli_bad_flags(tmp_path):
    out = subprocess.run(
        [sys.executable, "-m", "baselines.cmaes", "--sigma0=0", f"--output_dir={tmp_path}"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 2 and "--sigma0" in out.stderr


def test_config_command_reruns_the_run(tmp_path):
    import shlex
    import shutil

    args = ("--population=3", "--rounds=2", "--trial_steps=60", "--seed=4", "--test_seeds=2")
    out = _cli(*args, f"--output_dir={tmp_path}", "--run_name=r")
    assert out.returncode == 0, out.stderr
    run_dir = tmp_path / "cem" / "darwin_walk" / "r"
    config = json.loads((run_dir / "config.json").read_text())
    first = json.loads((run_dir / "summary.json").read_text())
    command = shlex.split(config["command"])
    assert command[:3] == ["python", "-m", "baselines.cem"]
    assert config["settings"] == dataclasses.asdict(
        cem.CEMSettings(population=3, rounds=2, trial_steps=60, seed=4, test_seeds=2)
    )
    shutil.rmtree(run_dir)
    again = subprocess.run(
        [sys.executable, *command[1:]], capture_output=True, text=True, timeout=300
    )
    assert again.returncode == 0, again.stderr
    assert _without_wall(json.loads((run_dir / "summary.json").read_text())) == _without_wall(first)


def test_a_rounds_distances_are_logged_cheapest_first_as_the_elite_is_chosen():
    """progress.csv's distances_by_cost_m: the order CEM's `tell` ranks samples in (a failed
    trial last, ties in sample order), so its first `elite` are the elite (claim CEM-13b)."""
    from cpg_suite.harness import rounds

    distance = np.array([0.5, 2.0, -0.1, 1.0, 3.0])
    costs = np.array([-0.5, -2.0, np.nan, -2.0, np.inf])
    text = rounds.distances_by_cost(distance, costs)
    assert [float(x) for x in text.split(";")] == [2.0, 1.0, 0.5, -0.1, 3.0]


def test_a_resumed_progress_file_keeps_its_own_columns(tmp_path):
    """A run resumed from a progress.csv written before a column was added appends rows
    under the file's own header, the new column left out."""
    from cpg_suite.runfiles import runs

    path = tmp_path / "progress.csv"
    with runs.ProgressCSV(str(path), ["round", "best"]) as f:
        f.append({"round": 1, "best": 0.5})
    with runs.ProgressCSV(str(path), ["round", "best", "new"], truncate=False) as f:
        f.append({"round": 2, "best": 0.7, "new": "x"})
    assert path.read_text().splitlines() == ["round,best", "1,0.5", "2,0.7"]
