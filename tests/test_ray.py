"""The Ray backend on a real local Ray instance: identical results, a killed worker, an
unreachable cluster."""

import dataclasses
import json
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from baselines import cem
from baselines.experiments import nac_experiments
from baselines.tabular import runner
from baselines.tabular.settings import TabularSettings
from cpg_suite import cpg, evaluation
from cpg_suite.evaluation import ray_backend
from cpg_suite.evaluation.open_loop import BatchEvaluator
from cpg_suite.protocol import score
from cpg_suite.runfiles import runs

pytestmark = pytest.mark.slow  # real local Ray clusters

ray = pytest.importorskip("ray")


@pytest.fixture(scope="module")
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False)
    yield
    ray.shutdown()


def _candidates(k=5):
    rng = np.random.default_rng(0)
    return cpg.amplitudes_from("hand_tuned") + rng.normal(0, 1.5, (k, cpg.N_AMPLITUDES))


def _same(a, b):
    assert np.array_equal(a.distance_m, b.distance_m)
    assert np.array_equal(a.lateral_m, b.lateral_m)
    assert np.array_equal(a.fall_step, b.fall_step) and a.sim_steps == b.sim_steps
    if a.quality is not None:
        assert all(np.array_equal(a.quality[f], b.quality[f], equal_nan=True) for f in a.quality)


@pytest.mark.parametrize("workers, chunk", [(1, None), (2, 1), (2, 3)])
def test_ray_evaluation_equals_local_for_any_chunk_and_workers(local_ray, workers, chunk):
    amps, seeds = _candidates(), [0, 7, 1_000_003]
    with BatchEvaluator("darwin_walk_push", 150, 2) as local:
        expected = local.evaluate(amps, seeds, quality=True)
        one_gait = local.evaluate(amps[0], list(range(5)))
    with ray_backend.RayEvaluator("darwin_walk_push", 150, workers=workers, chunk=chunk) as remote:
        _same(remote.evaluate(amps, seeds, quality=True), expected)
        _same(remote.evaluate(amps[0], list(range(5))), one_gait)  # split along the seeds


def _worker_pids(busy: bool, prefix: bytes = b"ray::_Worker") -> list[int]:
    """Pids of this machine's Ray processes titled `prefix` (Ray titles an actor
    `ray::_Worker.<method>` while it runs a call, `ray::_Worker` when idle, and a task's
    process `ray::<function>` while it runs it)."""
    prefix = prefix + b".evaluate" if busy and prefix == b"ray::_Worker" else prefix
    pids = []
    for entry in os.listdir("/proc"):
        try:
            with open(f"/proc/{entry}/cmdline", "rb") as f:
                if f.read().startswith(prefix):
                    pids.append(int(entry))
        except (OSError, ValueError):
            continue
    return pids


class _Killer(threading.Thread):
    """Kills the first actor process seen in the middle of an evaluation (or the first
    process titled `prefix`), once, `settle_s` after it is first seen."""

    def __init__(self, prefix: bytes = b"ray::_Worker", settle_s: float = 0.0):
        super().__init__(daemon=True)
        self.killed, self._done = None, threading.Event()
        self._prefix, self._settle_s = prefix, settle_s

    def run(self):
        while not self._done.is_set() and self.killed is None:
            for pid in _worker_pids(busy=True, prefix=self._prefix):
                time.sleep(self._settle_s)
                os.kill(pid, signal.SIGKILL)
                self.killed = pid
                return
            time.sleep(0.01)

    def stop(self):
        self._done.set()
        self.join()


def test_a_worker_killed_mid_chunk_is_retried_with_the_same_numbers(local_ray):
    amps = _candidates(4)
    with BatchEvaluator("darwin_walk", 600, 1) as local:
        expected = local.evaluate(amps, [0, 1, 2])
    with ray_backend.RayEvaluator("darwin_walk", 600, workers=2, chunk=1) as remote:
        pids = ray.get([actor.pid.remote() for actor in remote.actors])
        killer = _Killer()
        killer.start()
        result = remote.evaluate(amps, [0, 1, 2])
        killer.stop()
        assert killer.killed in pids, "no worker was seen mid-evaluation"
        _same(result, expected)  # the killed actor's chunks were retried on its restart
        assert killer.killed not in ray.get([actor.pid.remote() for actor in remote.actors])
        _same(remote.evaluate(amps, [0, 1, 2]), expected)


def test_optimizer_run_on_ray_with_a_killed_worker_has_the_local_summary_and_card(
    local_ray, tmp_path
):
    settings = cem.CEMSettings(
        population=6, rounds=3, trial_steps=300, validation_seeds=2, test_seeds=2
    )
    summaries = []
    for backend in ("local", "ray"):
        options = runs.RunOptions(output_dir=str(tmp_path / backend), backend=backend, threads=1)
        killer = _Killer()
        if backend == "ray":
            killer.start()
        _, summary = cem.run_cem(settings, options, log=str)
        if backend == "ray":
            killer.stop()
            assert killer.killed is not None, "no worker was seen mid-evaluation"
        summaries.append({k: v for k, v in summary.items() if k != "wall_s"})
    assert summaries[0] == summaries[1]
    card = dict(seeds=3, steps=150, tiers=("darwin_walk_rough",))
    local = score.score_gait(_candidates(1)[0], score.ScoreSettings(**card))
    remote = score.score_gait(_candidates(1)[0], score.ScoreSettings(**card, backend="ray"))
    assert json.dumps(local, sort_keys=True) == json.dumps(remote, sort_keys=True)


def _cem_grid(out, *extra) -> subprocess.Popen:
    command = [sys.executable, "-m", "baselines.cem", "--grid=table6_3"]
    command += ["--settings=K10_n0_e2", "--seeds=2", "--rounds=4", "--trial_steps=400"]
    command += ["--validation_seeds=2", "--test_seeds=2", "--threads=1", f"--output_dir={out}"]
    return subprocess.Popen(
        command + list(extra), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def _summaries(out) -> list[dict]:
    found = []
    for seed in (0, 1):
        path = out / "cem" / "darwin_walk" / f"K10_n0_e2_seed{seed}" / "summary.json"
        summary = json.loads(path.read_text())
        found.append({k: v for k, v in summary.items() if k != "wall_s"})
    return found


def test_grid_runs_as_ray_tasks_survive_a_killed_task_and_resume_per_run(tmp_path):
    local = _cem_grid(tmp_path / "local")
    assert local.wait(timeout=600) == 0, local.stderr.read()
    killer = _Killer(prefix=b"ray::_run_job", settle_s=2.0)  # mid-run, past a checkpoint
    killer.start()
    grid = _cem_grid(tmp_path / "ray", "--backend=ray")
    stdout, stderr = grid.communicate(timeout=600)
    killer.stop()
    assert grid.returncode == 0, stderr
    assert killer.killed is not None, "no grid task was seen running"
    assert _summaries(tmp_path / "ray") == _summaries(tmp_path / "local")
    assert stdout.count("test score (all tiers") == 2  # a summary line per run
    again = _cem_grid(tmp_path / "ray", "--backend=ray")
    _, stderr = again.communicate(timeout=600)
    errors = [line for line in stderr.splitlines() if line.startswith("error")]
    assert again.returncode == 2 and len(errors) == 1 and "--resume" in errors[0], stderr
    resumed = _cem_grid(tmp_path / "ray", "--backend=ray", "--resume")
    assert resumed.wait(timeout=600) == 0, resumed.stderr.read()
    assert _summaries(tmp_path / "ray") == _summaries(tmp_path / "local")


def test_experiment_sweeps_as_ray_tasks_equal_the_local_ones(local_ray, tmp_path):
    def table(backend):
        settings = nac_experiments.NACExperimentSettings(
            output_dir=str(tmp_path / backend), seeds=2, steps=300, eval_seeds=1, backend=backend
        )
        lines = nac_experiments.run_experiments(settings)
        return [line.replace(settings.output_dir, "OUT") for line in lines]

    assert table("local") == table("ray")
    pole = [
        TabularSettings(task="pole_balance", algo="q_learning", bins="20x20", steps=400, seed=s)
        for s in (0, 1)
    ]

    def sweep(backend):
        out = str(tmp_path / f"pole_{backend}")
        done = runner.execute_all(
            [dataclasses.replace(p, output_dir=out) for p in pole], False, backend
        )
        return [{k: v for k, v in summary.items() if k != "wall_s"} for _, summary in done]

    assert sweep("local") == sweep("ray")
    with pytest.raises(runs.RunDirectoryExists):  # the driver checks before any task runs
        sweep("ray")


def test_unreachable_cluster_is_a_one_line_error_and_writes_nothing(tmp_path):
    with socket_port() as port:  # a port nobody listens on
        address = f"127.0.0.1:{port}"
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "baselines.cem",
            "--backend=ray",
            f"--ray_address={address}",
            f"--output_dir={tmp_path / 'runs'}",
            "--rounds=1",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 2, out.stderr
    lines = [line for line in out.stderr.splitlines() if line.startswith("error")]
    assert len(lines) == 1 and "no Ray cluster answers" in lines[0]
    assert not (tmp_path / "runs").exists()
    with pytest.raises(ValueError, match="backend"):
        runs.RunOptions(backend="slurm")
    with pytest.raises(ValueError, match="valid: local, ray"):
        evaluation.open_evaluator("darwin_walk", 10, 1, backend="mpi")


class socket_port:
    """A free TCP port on localhost (bound, then released on exit)."""

    def __enter__(self):
        import socket

        self._socket = socket.socket()
        self._socket.bind(("127.0.0.1", 0))
        return self._socket.getsockname()[1]

    def __exit__(self, *exc):
        self._socket.close()
