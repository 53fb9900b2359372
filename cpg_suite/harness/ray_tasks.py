"""Runs of a grid and sweeps as Ray tasks (docs/architecture.md#ray-backend).

Each task is one whole run (or one sweep point) of a module-level function; a task whose
worker process dies runs again, so the functions given here resume or redo their own run
directory. The Ray connection is `cpg_suite.evaluation.ray_backend`'s.
"""

from __future__ import annotations

import dataclasses
import importlib
import sys
from collections.abc import Callable, Sequence

from cpg_suite.evaluation.ray_backend import connect, disconnect, ray_module, release_actors

_TASK_RETRIES = 3  # runs of a grid run again if their worker process dies


def importable(obj):
    """The module-level function or class `obj` as imported from its module, so that Ray
    pickles it by reference: under `python -m baselines.x` the CLI's own definitions live
    in `__main__`, which a worker cannot import."""
    if obj.__module__ != "__main__":
        return obj
    module = importlib.import_module(sys.modules["__main__"].__spec__.name)
    return getattr(module, obj.__qualname__)


def importable_settings(settings):
    """A settings dataclass rebuilt as an instance of its `importable` class."""
    return importable(type(settings))(**dataclasses.asdict(settings))


def map_tasks(
    fn: Callable,
    items: Sequence,
    *,
    address: str | None = None,
    num_cpus: int = 1,
    on_result: Callable[[int, object], None] | None = None,
) -> list:
    """`[fn(item) for item in items]`, each call a Ray task (a run of a grid or a sweep).

    A task whose process dies is run again (`max_retries`), so `fn` must be safe to
    repeat: the runs given here resume or redo their own run directory. `fn` and the items
    are pickled to the workers (every node needs the package installed; run files go where
    `fn` writes them, so a multi-node cluster needs a shared file system for them).

    Args:
      fn: A module-level function (pickled by reference).
      items: Its arguments, one per task.
      address: Ray address (see `connect`).
      num_cpus: CPUs each task reserves (its evaluator threads).
      on_result: Called with (index, result) as each task finishes.

    Returns:
      The results in the order of `items`.

    Raises:
      ClusterUnreachable: If no cluster answers at `address`.
      Exception: The first exception a task raised (Ray's error is an instance of it).
    """
    ray = ray_module()
    owns = connect(address)
    try:
        release_actors()  # idle evaluator actors would hold the CPUs the tasks need
        task = ray.remote(num_cpus=num_cpus, max_retries=_TASK_RETRIES)(fn)
        pending = {task.remote(item): i for i, item in enumerate(items)}
        results: list = [None] * len(items)
        try:
            while pending:
                (ref,), _ = ray.wait(list(pending), num_returns=1)
                i = pending.pop(ref)
                results[i] = ray.get(ref)
                if on_result:
                    on_result(i, results[i])
        except BaseException:
            for ref in pending:  # a failed run (or Ctrl-C) stops the grid
                ray.cancel(ref)
            raise
        return results
    finally:
        if owns:
            disconnect()
