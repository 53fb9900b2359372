"""The local batched evaluator of a controller: the one choice between the two.

Used by `cpg_suite.evaluation.open_evaluator` for the local backend and by the Ray actors
(`ray_backend`), which each run a one-thread local evaluator.
"""

from __future__ import annotations

import numpy as np

from cpg_suite import feedback
from cpg_suite.evaluation.closed_loop import FeedbackEvaluator
from cpg_suite.evaluation.open_loop import BatchEvaluator, check_amplitudes


def local_evaluator(
    controller: str, task: str, steps: int, threads: int, **evaluator_kwargs
) -> BatchEvaluator | FeedbackEvaluator:
    """A `FeedbackEvaluator` for "feedback" parameters, else a `BatchEvaluator`.

    Raises:
      ValueError: As the evaluators do (unknown task, non-positive sizes).
    """
    if controller == "feedback":
        return FeedbackEvaluator(task, steps, threads, **evaluator_kwargs)
    return BatchEvaluator(task, steps, threads, **evaluator_kwargs)


def check_params(controller: str, params) -> np.ndarray:
    """(K, n) float64 parameter vectors of `controller`, checked as its evaluator does.

    Raises:
      ValueError: On a wrong shape (or, for amplitudes, a non-finite value).
    """
    if controller == "feedback":
        p = np.atleast_2d(np.asarray(params, dtype=np.float64))
        feedback.split(p)  # raises ValueError on a wrong shape
        return p
    return check_amplitudes(params)
