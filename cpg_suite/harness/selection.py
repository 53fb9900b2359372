"""The gait a gait optimizer's run reports: selected on validation seeds, scored on test.

At the end of a run the final mean and the in-sample best candidates are scored on the
validation seeds; the best of them (ties: the final mean) is written to
`selected_params.json` and scored once on the test tiers (docs/protocol.md).
"""

from __future__ import annotations

import os
from collections.abc import Callable

import numpy as np

from cpg_suite import cpg, feedback, protocol
from cpg_suite.evaluation.open_loop import BatchEvaluator
from cpg_suite.harness.checkpoints import RunState
from cpg_suite.harness.interface import Optimizer, OptimizerSettings
from cpg_suite.protocol import score
from cpg_suite.runfiles import runs


def validation_score(
    evaluator: BatchEvaluator, candidates: np.ndarray, settings: OptimizerSettings
) -> tuple[np.ndarray, int]:
    """Mean success-weighted distance (a fall scores 0) of each candidate on the
    validation seeds; and the physics steps it took."""
    result = evaluator.evaluate(candidates, protocol.validation_seeds(settings.validation_seeds))
    return np.where(result.fell, 0.0, result.distance_m).mean(axis=1), result.sim_steps


def params_json(vector) -> dict:
    """The parameters by name: the amplitudes (and the feedback gains, if any)."""
    if len(vector) == feedback.N_PARAMS:
        return feedback.params_json(vector)
    return {"amplitudes": {n: float(v) for n, v in zip(cpg.AMPLITUDE_NAMES, vector)}}


def select_and_test(
    run_dir: str,
    state: RunState,
    optimizer: Optimizer,
    evaluator: BatchEvaluator,
    settings: OptimizerSettings,
    scoring: dict,
    log: Callable[[str], None],
) -> dict:
    """Selects the reported gait on validation seeds and scores it on the test tiers.

    Args:
      run_dir: The run directory; receives `selected_params.json`.
      state: The finished run's state (its in-sample best candidates and totals).
      optimizer: The finished optimizer (its final mean is a candidate).
      evaluator: The training task's evaluator, which scores the validation seeds.
      settings: The run's settings (validation seeds, test seeds, trial steps).
      scoring: `threads`, `backend`, `ray_address` and `controller` of the test scoring.
      log: Receives the selection and the test score card.

    Returns:
      The summary's `selected`, `validation_sim_steps` and (with test seeds) `test`.
    """
    names = ["final_mean"] + [f"in_sample_{i + 1}" for i in range(len(state.top))]
    candidates = np.array([optimizer.mean] + [e["params"] for e in state.top])
    values, steps = validation_score(evaluator, candidates, settings)
    k = int(np.argmax(values))  # ties go to the final mean
    selected = {
        "source": names[k],
        "validation_success_weighted_m": float(values[k]),
        "validation_seeds": settings.validation_seeds,
        "candidates": dict(zip(names, (float(v) for v in values))),
    }
    runs.write_json(
        os.path.join(run_dir, "selected_params.json"),
        {**params_json(candidates[k]), "source": names[k]},
    )
    out = {
        "selected": selected,
        "validation_sim_steps": state.totals.get("validation_sim_steps", 0) + steps,
    }
    if settings.test_seeds:
        chosen = f"{names[k]} (validation {values[k]:+.3f} m)"
        out["test"] = _test_card(candidates[k], settings, scoring, chosen, log)
    return out


def _test_card(params, settings, scoring, chosen, log) -> dict:
    """The selected gait's test score card (tiers, all tiers, physics steps); logs it."""
    card = score.score_gait(
        params,
        score.ScoreSettings(
            seeds=settings.test_seeds,
            steps=settings.trial_steps,
            benchmark_version=getattr(settings, "benchmark_version", protocol.BENCHMARK_VERSION),
            **scoring,
        ),
    )
    log(f"selected gait: {chosen}; test score card:")
    log(score.format_card(card))
    return score.stored_card(card)
