"""Trials and runs on a Ray cluster (docs/architecture.md#ray-backend).

`RayEvaluator` has the evaluator interface (`cpg_suite.evaluation.Evaluator`) around either
local evaluator, open-loop or feedback. A run's evaluators share one set of Ray actors, one CPU and
one evaluator thread each; an actor builds a local evaluator from the controller, the task
name and the CPG settings the first time it is asked for that task (what is shipped: a few hundred
bytes of arguments, put into Ray's object store once per evaluator, never a model), so a
round only sends the amplitudes and the seeds. A round's trials are split into chunks (of
candidates, or of seeds when one gait is scored), one actor call per chunk, and the
results are put back in order. A trial's result depends only on its amplitudes and its
seed, so the result is the local backend's, bit for bit, for any chunk size and worker
count. An actor whose process dies is restarted by Ray and its calls are retried
(`max_restarts=-1`, `max_task_retries=-1`): the retried chunk gives the same numbers.

Ray is an extra (`pip install "cpg-suite[cluster]"`); it is imported only when a Ray
evaluator is made.
"""

from __future__ import annotations

import contextlib
import hashlib
import math
import os
import pickle
import socket
from collections.abc import Iterator

import numpy as np

from cpg_suite.cli import UsageError
from cpg_suite.evaluation.local import check_params, local_evaluator
from cpg_suite.evaluation.open_loop import BatchResult


class ClusterUnreachable(UsageError, ConnectionError):
    """No Ray cluster answers at the address given (a usage error: one line, exit 2)."""


def ray_module():
    """The `ray` package, or an ImportError that says how to install it."""
    try:
        import ray
    except ImportError as e:  # pragma: no cover - depends on the installation
        raise ImportError('the Ray backend needs Ray: pip install "cpg-suite[cluster]"') from e
    return ray


def connect(address: str | None, num_cpus: int | None = None) -> bool:
    """Connects this process to Ray, unless it already is.

    Args:
      address: `host:port` of a running cluster's head, "auto" for the one started on this
        machine with `ray start`, or None for a private local instance.
      num_cpus: CPUs of a private local instance (None: all).

    Returns:
      True if this call started or joined Ray (the caller then shuts it down).

    Raises:
      ClusterUnreachable: If no cluster answers at `address`.
    """
    ray = ray_module()
    if ray.is_initialized():
        return False
    if address and address != "auto":
        host, _, port = address.rpartition(":")
        try:
            socket.create_connection((host or "127.0.0.1", int(port)), timeout=5).close()
        except (OSError, ValueError):
            raise ClusterUnreachable(
                f"no Ray cluster answers at --ray_address={address} (expected host:port of a "
                "running head node, or auto)"
            ) from None
    try:
        ray.init(
            address=address,
            num_cpus=None if address else num_cpus,
            include_dashboard=False,
            log_to_driver=False,
            configure_logging=False,
        )
    except ConnectionError as e:
        raise ClusterUnreachable(f"no Ray cluster at --ray_address={address}: {e}") from None
    return True


@contextlib.contextmanager
def connected(backend: str, address: str | None) -> Iterator[None]:
    """Within the block this process is connected to Ray when `backend` is "ray" (and
    leaves it after, if the block's connection was the first).

    Raises:
      ClusterUnreachable: If no cluster answers at `address`.
    """
    owns = backend == "ray" and connect(address)
    try:
        yield
    finally:
        if owns:
            disconnect()


def release_actors() -> None:
    """Ends this driver's idle evaluator actors (they would hold CPUs that tasks need)."""
    ray = ray_module()
    for actor in _POOLS.pop(ray.get_runtime_context().get_job_id(), []):
        ray.kill(actor)


def disconnect() -> None:
    """Ends this driver's actors and leaves Ray (shuts a private local instance down)."""
    _POOLS.clear()
    ray_module().shutdown()


class _Worker:
    """One Ray actor: local batched evaluators, one per evaluator specification, each built
    on the first call that needs it and kept for the actor's life."""

    def __init__(self):
        self._evaluators: dict = {}

    def pid(self) -> int:
        return os.getpid()

    def evaluate(self, key: str, spec: tuple, amplitudes, seeds: list, quality: bool):
        if key not in self._evaluators:
            controller, args, kwargs = spec
            self._evaluators[key] = local_evaluator(controller, *args, **kwargs)
        return self._evaluators[key].evaluate(amplitudes, seeds, quality)


# The actors of this driver's Ray session (one CPU each): every Ray evaluator of a run
# (training and the test tiers) shares them, so a run never waits for CPUs that its own
# idle actors hold. Filled on demand, emptied by `disconnect`.
_POOLS: dict[str, list] = {}


def _actors(ray, workers: int) -> list:
    pool = _POOLS.setdefault(ray.get_runtime_context().get_job_id(), [])
    actor = ray.remote(num_cpus=1, max_restarts=-1, max_task_retries=-1)(_Worker)
    while len(pool) < workers:
        pool.append(actor.remote())
    return pool[:workers]


class RayEvaluator:
    """A local evaluator's `evaluate` (open-loop or feedback) with the trials spread over
    Ray actors."""

    def __init__(
        self,
        task: str = "darwin_walk",
        steps: int = 1000,
        *,
        controller: str = "open_loop",
        workers: int | None = None,
        chunk: int | None = None,
        address: str | None = None,
        **evaluator_kwargs,
    ):
        """Args:
          task, steps, evaluator_kwargs: As for the local evaluator.
          controller: "open_loop" (`BatchEvaluator`) or "feedback" (`FeedbackEvaluator`).
          workers: Actors, each a one-thread evaluator on one CPU (None: one per CPU of the
            cluster; actors beyond its CPUs wait for one to be free).
          chunk: Candidates per actor call (None: a round split evenly over the actors).
          address: Ray address (see `connect`); ignored if Ray is already initialized.

        Raises:
          ValueError: On non-positive sizes or a task the evaluator does not run.
          ClusterUnreachable: If no cluster answers at `address`.
        """
        if (workers is not None and workers < 1) or (chunk is not None and chunk < 1):
            raise ValueError(f"workers and chunk must be ≥ 1, got {workers} and {chunk}")
        local_evaluator(controller, task, steps, 1, **evaluator_kwargs).close()  # validates
        self._controller = controller
        ray = self._ray = ray_module()
        self._owns_ray = connect(address)
        if workers is None:
            workers = max(1, int(ray.cluster_resources().get("CPU", 1)))
        spec = (controller, (task, steps, 1), evaluator_kwargs)
        self._key = hashlib.sha256(pickle.dumps(spec)).hexdigest()
        self._spec = ray.put(spec)  # to the object store once; each actor reads it once
        self.actors = _actors(ray, workers)
        self.chunk = chunk

    def evaluate(self, amplitudes, seeds=(0,), quality: bool = False) -> BatchResult:
        """As `BatchEvaluator.evaluate`. The trials are split along the longer of the two
        axes (candidates, or seeds when there are fewer candidates than seeds, as when one
        gait is scored), `chunk` at a time, and the chunks go to the actors in turn."""
        amps = check_params(self._controller, amplitudes)
        seeds = [int(s) for s in np.atleast_1d(seeds)]
        axis = 0 if len(amps) >= len(seeds) else 1
        n = (len(amps), len(seeds))[axis]
        chunk = self.chunk or math.ceil(n / len(self.actors))
        calls = []
        for i, a in enumerate(range(0, n, chunk)):
            part = (amps[a : a + chunk], seeds) if axis == 0 else (amps, seeds[a : a + chunk])
            actor = self.actors[i % len(self.actors)]
            calls.append(actor.evaluate.remote(self._key, self._spec, *part, quality))
        return concatenate(self._ray.get(calls), axis)

    def close(self) -> None:
        """Releases the evaluator (the actors stay for the session's next evaluator; Ray
        is shut down if this evaluator started it)."""
        self.actors = []
        if getattr(self, "_owns_ray", False):
            disconnect()
            self._owns_ray = False

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def concatenate(parts: list[BatchResult], axis: int = 0) -> BatchResult:
    """The results of consecutive chunks of candidates (axis 0) or seeds (axis 1) as one."""

    def join(arrays):
        return np.concatenate(arrays, axis=axis)

    quality = None
    if parts[0].quality is not None:
        quality = {f: join([p.quality[f] for p in parts]) for f in parts[0].quality}
    return BatchResult(
        join([p.distance_m for p in parts]),
        join([p.lateral_m for p in parts]),
        join([p.fall_step for p in parts]),
        int(sum(p.sim_steps for p in parts)),
        quality,
        join([p.cause for p in parts]),
    )
