"""How candidates are evaluated: one interface, its implementations, one factory.

Every evaluator runs K parameter vectors × S initial-state seeds of one walking tier and
returns a `BatchResult` ((K, S) distances, lateral drifts, fall steps and, on request, gait
quality). The implementations:

  * `open_loop.BatchEvaluator`: open-loop CPG amplitudes; precomputed controls run through
    threaded `mujoco.rollout` (docs/architecture.md#the-batched-evaluator);
  * `closed_loop.FeedbackEvaluator`: feedback-CPG parameters; the controller is stepped
    with the physics, K × S trials at once;
  * `ray_backend.RayEvaluator`: either of them on Ray actors, chunked (same results).

`open_evaluator` is the one place that picks among them (from the controller and the
backend); a new backend is a new module here with an `Evaluator` and a branch there.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

import numpy as np

from cpg_suite.cli import BACKENDS, CONTROLLERS

if TYPE_CHECKING:
    from cpg_suite.evaluation.open_loop import BatchResult


class Evaluator(Protocol):
    """What every evaluator does (a context manager that `close`s on exit)."""

    task: str
    steps: int

    def evaluate(self, params: np.ndarray, seeds=(0,), quality: bool = False) -> BatchResult:
        """Runs every parameter vector (K, n) from every seed; (K, S) results."""

    def close(self) -> None:
        """Releases threads and actors."""

    def __enter__(self) -> Evaluator: ...

    def __exit__(self, *exc) -> None: ...


def open_evaluator(
    task: str,
    steps: int,
    threads: int,
    backend: str = "local",
    ray_address: str | None = None,
    controller: str = "open_loop",
    **evaluator_kwargs,
) -> Evaluator:
    """The evaluator of `controller` on `backend`.

    Args:
      task: A walking tier.
      steps: Control steps per trial.
      threads: Threads of a local evaluator (the Ray backend runs one per actor).
      backend: One of `cpg_suite.cli.BACKENDS`.
      ray_address: The Ray cluster (see `ray_backend.connect`).
      controller: One of `cpg_suite.cli.CONTROLLERS`: "open_loop" amplitudes or "feedback"
        parameters.
      **evaluator_kwargs: Passed to the local evaluator (e.g. `config`).

    Returns:
      A `BatchEvaluator`, a `FeedbackEvaluator` or a `RayEvaluator` around either.

    Raises:
      ValueError: On an unknown backend or controller, and as the evaluators do.
      ray_backend.ClusterUnreachable: For the Ray backend, if no cluster answers.
    """
    # The implementations load MuJoCo and dm_control: imported here, so that a command of
    # this package (`python -m cpg_suite.evaluation.evaluate`) can choose its rendering
    # backend before they load.
    from cpg_suite.evaluation.local import local_evaluator
    from cpg_suite.evaluation.ray_backend import RayEvaluator

    if controller not in CONTROLLERS:
        raise ValueError(f"unknown controller {controller!r}; valid: {', '.join(CONTROLLERS)}")
    if backend == "ray":  # one single-thread actor per CPU: `threads` is the local backend's
        return RayEvaluator(
            task, steps, controller=controller, address=ray_address, **evaluator_kwargs
        )
    if backend != "local":
        raise ValueError(f"unknown backend {backend!r}; valid: {', '.join(BACKENDS)}")
    return local_evaluator(controller, task, steps, threads, **evaluator_kwargs)
