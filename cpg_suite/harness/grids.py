"""Grids of runs of a gait optimizer (e.g. `python -m baselines.cem --grid=table6_3`).

The runs go one after another in this process, or with `--backend=ray` each as a Ray task
(`cpg_suite.harness.ray_tasks`, docs/architecture.md#ray-backend); either way one summary
line per finished run.
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
from collections.abc import Callable

from cpg_suite import cli, progress
from cpg_suite.evaluation import ray_backend
from cpg_suite.harness import checkpoints, optimize, ray_tasks
from cpg_suite.harness.interface import OptimizerSettings
from cpg_suite.runfiles import runs


def run_jobs(
    jobs: list[tuple[OptimizerSettings, runs.RunOptions]],
    run: Callable[..., tuple[str, dict]],
    log: Callable[[str], None] = progress.write,
    *,
    method: str | None = None,
) -> list[tuple[str, dict]]:
    """Runs each job with `run(settings, options, log=...)`, printing a summary line per run.

    With `backend="ray"` in the jobs' options and more than one job, the runs are Ray
    tasks (each on its node's threads, `options.threads` CPUs), one summary line as each
    finishes; a single run spreads its trials over Ray actors instead.

    Args:
      jobs: (settings, options) per run, options with their run names set.
      run: The method's run function (e.g. `baselines.cem.run_cem`), module-level.
      log: Receives progress and summary lines.
      method: The method's name (its run directories' second level); needed for Ray tasks.

    Returns:
      `(run_dir, summary)` per job.

    Raises:
      cli.UsageError: For a run directory that exists or a foreign/corrupt checkpoint.
      ray_backend.ClusterUnreachable: If the jobs run on Ray and no cluster answers.
    """
    start = time.perf_counter()
    if len(jobs) > 1 and jobs[0][1].backend == "ray":
        done = _run_jobs_on_ray(jobs, run, method, log)
    else:
        done = _run_jobs_here(jobs, run, log)
    if len(jobs) > 1:
        log(f"{len(jobs)} runs in {time.perf_counter() - start:.0f} s")
    return done


def _run_jobs_here(jobs, run, log) -> list[tuple[str, dict]]:
    """The runs one after another in this process, their lines prefixed in a grid."""
    done = []
    for i, (settings, options) in enumerate(progress.track(jobs, desc="runs", unit="run"), 1):
        prefix = f"[{i}/{len(jobs)} {options.run_name}] " if len(jobs) > 1 else ""
        with _usage_errors():
            run_dir, summary = run(settings, options, log=lambda x, p=prefix: log(p + x))
        log(prefix + optimize.summary_line(run_dir, summary))
        done.append((run_dir, summary))
    return done


@contextlib.contextmanager
def _usage_errors():
    """A run directory that exists or a foreign checkpoint as a one-line usage error (also
    when raised in a Ray task: Ray's error is an instance of the task's exception)."""
    try:
        yield
    except runs.RunDirectoryExists as e:
        raise cli.UsageError(f"{getattr(e, 'cause', e)} (or --resume to continue it)") from None
    except checkpoints.CheckpointError as e:
        raise cli.UsageError(str(getattr(e, "cause", e))) from None


def _run_job(job: tuple) -> tuple[str, dict]:
    """One run of a grid in a Ray task (quiet: its summary line is the driver's)."""
    run, settings, options = job
    return run(settings, options, log=lambda line: None)


def _run_jobs_on_ray(jobs, run, method, log) -> list[tuple[str, dict]]:
    """The runs as Ray tasks. The driver reaches the cluster, then opens every run
    directory as the options say (an existing one is an error without --resume or
    --overwrite), so that a task that runs again after its worker died resumes its own
    run's checkpoint (`resume=True` in the tasks)."""
    if method is None:
        raise ValueError("run_jobs needs the method's name to run jobs on Ray")
    with ray_backend.connected("ray", jobs[0][1].ray_address):
        tasks = []
        for settings, options in jobs:
            with _usage_errors():
                optimize.open_run_directory(method, settings, options)
            local = dataclasses.replace(options, backend="local", resume=True, overwrite=False)
            settings = ray_tasks.importable_settings(settings)
            tasks.append((ray_tasks.importable(run), settings, local))

        def finished(i, result):
            log(f"[{i + 1}/{len(jobs)} {jobs[i][1].run_name}] " + optimize.summary_line(*result))

        with _usage_errors():
            return ray_tasks.map_tasks(
                _run_job, tasks, num_cpus=jobs[0][1].threads, on_result=finished
            )
