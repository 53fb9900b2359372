"""The round loop shared by the gait optimizers (CEM, CMA-ES, any ask/tell optimizer).

An optimizer (`cpg_suite.harness.interface.Optimizer`) proposes a batch of parameter
vectors (`ask`), learns from their costs (`tell`), and can save and restore its whole state
(`state_dict` / `load_state_dict`, JSON-serializable). `run_rounds` evaluates each batch
with the batched rollout evaluator, keeps the best vector seen, appends a row to
`progress.csv`, writes `checkpoint.json` atomically after every round
(`cpg_suite.harness.checkpoints`), and on resume continues from it bit-identically; at the
end it selects the reported gait and scores it on test (`cpg_suite.harness.selection`).

Cost of a trial (thesis Sec. 6.2): −distance (m) + fall_penalty · [fell] +
lateral_penalty · |lateral displacement| (m), averaged over the initial-state seeds of the
round (the same seeds for every candidate). The study gives a fall penalty "high" enough
that fallen trials never make the elite, and no lateral weight; ours are settings (default
fall penalty 10 m, more than any distance walked in 16 s). A NaN or infinite cost is a
failed trial: it is never the round's or the run's best, and optimizers sort it last.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable

import numpy as np

from cpg_suite import progress, protocol
from cpg_suite.evaluation.open_loop import BatchEvaluator, BatchResult
from cpg_suite.harness import checkpoints, selection
from cpg_suite.harness.interface import Optimizer, OptimizerSettings
from cpg_suite.runfiles import runs

PROGRESS_FIELDS = [
    "round",
    "best_cost",
    "best_distance_m",
    "best_fell",
    "mean_distance_m",
    "mean_fell",
    "falls",
    "cost_mean",
    "sigma",
    "evaluations",
    "sim_steps",
    "steps_per_s",
    "wall_s",
    "validation_m",
    "distances_by_cost_m",
]


def trial_costs(result: BatchResult, fall_penalty: float, lateral_penalty: float) -> np.ndarray:
    """Cost per candidate, averaged over its initial states (lower is better; NaN = failed)."""
    per_trial = (
        -result.distance_m + fall_penalty * result.fell + lateral_penalty * np.abs(result.lateral_m)
    )
    return per_trial.mean(axis=1)


def best_index(costs: np.ndarray) -> int | None:
    """The cheapest candidate with a finite cost (the first on ties), or None if none is."""
    finite = np.isfinite(costs)
    if not finite.any():
        return None
    return int(np.argmin(np.where(finite, costs, np.inf)))


def round_seeds(settings: OptimizerSettings, round_number: int) -> list[int]:
    """The training seeds of a round (1-based; `rounds + 1` for the final mean's trial).

    The study's setting reuses seeds 0..eval_seeds-1; with `fresh_starts` each round draws
    its own from the training range with a generator keyed by (seed, round)
    (`protocol.round_seeds`, which verify tries an in-sample best on).
    """
    return protocol.round_seeds(
        settings.seed, round_number, settings.eval_seeds, settings.fresh_starts
    )


def run_rounds(
    optimizer: Optimizer,
    evaluator: BatchEvaluator,
    run_dir: str,
    settings: OptimizerSettings,
    *,
    resume: bool = False,
    threads: int = 2,
    backend: str = "local",
    ray_address: str | None = None,
    log: Callable[[str], None] = progress.write,
) -> dict:
    """Runs the optimizer for `settings.rounds` rounds and writes the run files.

    Each round: ask → evaluate every candidate from the round's training seeds → cost →
    tell → record the best → (validation score of the mean) → progress row → checkpoint.
    Then: the final mean is tried once; the reported gait is selected on validation seeds
    among the final mean and the in-sample best; it is scored on the test tiers.

    Args:
      optimizer: See `Optimizer`; `first_sample_is_mean = True` when `ask()` puts the
        current mean first (then its trial is logged as the mean vector's).
      evaluator: The batched evaluator of the training task.
      run_dir: The run directory (already created, with config.json).
      settings: The run's settings; all of them must match to resume.
      resume: Continue from `checkpoint.json` if present.
      threads: Threads of the test scoring.
      backend, ray_address: Evaluator backend of the test scoring (`runs.RunOptions`).
      log: Receives one line per round.

    Returns:
      The summary (also written to `summary.json`).

    Raises:
      CheckpointError: On a corrupt or foreign checkpoint when resuming.
    """
    identity = dataclasses.asdict(settings)
    checkpoint_path = os.path.join(run_dir, "checkpoint.json")
    state = checkpoints.restore(checkpoint_path, identity, optimizer, resume)
    has_mean = bool(getattr(optimizer, "first_sample_is_mean", False))
    # progress.csv is rewritten from the checkpoint's rows: a row written after the last
    # checkpoint (a kill between the two writes) is dropped and recomputed.
    with runs.ProgressCSV(os.path.join(run_dir, "progress.csv"), PROGRESS_FIELDS) as rows_file:
        for row in state.rows:
            rows_file.append(row)
        pending = range(state.totals["round"], settings.rounds)
        for _ in progress.track(pending, desc=os.path.basename(run_dir), unit="round"):
            row, trials = _train_round(optimizer, evaluator, settings, state, has_mean)
            _validate_mean(optimizer, evaluator, settings, state, row)
            state.rows.append(row)
            rows_file.append(row)
            runs.write_json(checkpoint_path, state.to_json(identity, optimizer))
            log(round_line(row, trials))
    # The final mean has not been tried by the algorithm itself (thesis Sec. 6.3): try it.
    start = time.perf_counter()
    final = evaluator.evaluate(optimizer.mean, round_seeds(settings, settings.rounds + 1))
    summary = _finish(run_dir, state, optimizer, final, time.perf_counter() - start)
    scoring = {"threads": threads, "backend": backend, "ray_address": ray_address}
    scoring["controller"] = settings.controller
    summary.update(
        selection.select_and_test(run_dir, state, optimizer, evaluator, settings, scoring, log)
    )
    runs.write_json(os.path.join(run_dir, "summary.json"), summary)
    return summary


def _train_round(optimizer, evaluator, settings, state, has_mean) -> tuple[dict, int]:
    """One round: ask, evaluate from the round's training seeds, tell, record."""
    start = time.perf_counter()
    seeds = round_seeds(settings, state.totals["round"] + 1)
    samples = optimizer.ask()
    result = evaluator.evaluate(samples, seeds)
    costs = trial_costs(result, settings.fall_penalty, settings.lateral_penalty)
    optimizer.tell(samples, costs)
    state.keep_top(samples, costs, settings.validation_top)
    row = _record_round(
        state, samples, result, costs, optimizer.sigma, has_mean, time.perf_counter() - start
    )
    return row, len(samples) * len(seeds)


def _validate_mean(optimizer, evaluator, settings, state, row) -> None:
    """Adds the mean's validation score to the row every `validation_every` rounds."""
    every = settings.validation_every
    if every and (row["round"] % every == 0 or row["round"] == settings.rounds):
        value, steps = selection.validation_score(evaluator, optimizer.mean[None], settings)
        row["validation_m"] = float(value[0])
        state.totals["validation_sim_steps"] = state.totals.get("validation_sim_steps", 0) + steps


def _record_round(
    state: checkpoints.RunState,
    samples: np.ndarray,
    result: BatchResult,
    costs: np.ndarray,
    sigma: float,
    has_mean: bool,
    elapsed: float,
) -> dict:
    """Updates totals and the best vector with one evaluated round; returns its progress row."""
    totals = state.totals
    distance, fell = result.distance_m.mean(axis=1), result.fell.any(axis=1)
    k = best_index(costs)
    totals["round"] += 1
    totals["falls_total"] += int(result.fell.sum())
    totals["evaluations"] += int(result.fell.size)
    totals["sim_steps"] += result.sim_steps
    totals["wall_s"] += elapsed
    if k is not None and costs[k] < state.best["cost"]:
        state.best = {
            "cost": float(costs[k]),
            "distance_m": float(distance[k]),
            "lateral_m": float(result.lateral_m[k].mean()),
            "fell": bool(fell[k]),
            "round": totals["round"],
            "params": samples[k].tolist(),
        }
    return _progress_row(totals, result, distance, fell, costs, k, sigma, has_mean, elapsed)


def _progress_row(totals, result, distance, fell, costs, k, sigma, has_mean, elapsed) -> dict:
    """The round's row of progress.csv (its best candidate: the first if none is finite)."""
    shown = 0 if k is None else k
    return {
        "round": totals["round"],
        "best_cost": float(costs[shown]),
        "best_distance_m": float(distance[shown]),
        "best_fell": int(fell[shown]),
        # Sample 1 is the current mean for CEM (thesis 6.2); not for CMA-ES.
        "mean_distance_m": float(distance[0]) if has_mean else "",
        "mean_fell": int(fell[0]) if has_mean else "",
        "falls": int(result.fell.sum()),
        "cost_mean": float(np.mean(costs[np.isfinite(costs)])) if k is not None else "",
        "sigma": float(sigma),
        "evaluations": totals["evaluations"],
        "sim_steps": totals["sim_steps"],
        "steps_per_s": round(result.sim_steps / elapsed) if elapsed > 0 else 0,
        "wall_s": round(totals["wall_s"], 3),
        "distances_by_cost_m": distances_by_cost(distance, costs),
    }


def ranking(costs: np.ndarray) -> np.ndarray:
    """The candidates' indices, cheapest first: a failed trial's (NaN or infinite) cost
    after every finite one, ties in sample order (how CEM picks its elite)."""
    return np.argsort(np.where(np.isfinite(costs), costs, np.inf), kind="stable")


def distances_by_cost(distance: np.ndarray, costs: np.ndarray) -> str:
    """The round's candidates' distances (m) in `ranking` order, joined by ";": the elite
    of CEM are the first `elite` (claim CEM-13b compares them with the next round's mean)."""
    return ";".join(repr(float(d)) for d in distance[ranking(costs)])


def round_line(row: dict, trials: int) -> str:
    """The line printed after a round."""
    mean_text = ""
    if row["mean_distance_m"] != "":
        fell = " (fell)" if row["mean_fell"] else ""
        mean_text = f"mean vector {row['mean_distance_m']:+.3f} m{fell}  "
    return (
        f"round {row['round']:3d}  best {row['best_distance_m']:+.3f} m"
        f"{' (fell)' if row['best_fell'] else ''}  {mean_text}"
        f"falls {row['falls']:2d}/{trials}  {row['steps_per_s']:,} sim steps/s"
    )


def _finish(
    run_dir: str,
    state: checkpoints.RunState,
    optimizer: Optimizer,
    final: BatchResult,
    wall_s: float,
) -> dict:
    """Writes best_params.json and mean_params.json; returns the training summary.

    summary.json is written only once the selection and the test card are in it: it marks
    a finished run, so a run killed while scoring its test card is completed on resume.
    """
    totals, best = state.totals, state.best
    if "params" not in best:
        raise RuntimeError("every trial of the run failed (NaN or infinite cost)")
    summary = {
        "best_distance_m": best["distance_m"],
        "best_round": best["round"],
        "best_fell": best["fell"],
        "best_lateral_m": best["lateral_m"],
        "best_cost": best["cost"],
        "final_mean_distance_m": float(final.distance_m.mean()),
        "final_mean_fell": bool(final.fell.any()),
        "falls_total": totals["falls_total"],
        "rounds": totals["round"],
        "evaluations": totals["evaluations"] + int(final.fell.size),
        "sim_steps": totals["sim_steps"] + final.sim_steps,
        "wall_s": totals["wall_s"] + wall_s,
    }
    _write_params_files(run_dir, best, optimizer.mean, summary)
    return summary


def _write_params_files(run_dir: str, best: dict, mean: np.ndarray, summary: dict) -> None:
    """best_params.json (the in-sample best) and mean_params.json (the final mean)."""
    best_json = {"round": best["round"], "distance_m": best["distance_m"], "fell": best["fell"]}
    runs.write_json(
        os.path.join(run_dir, "best_params.json"),
        {**selection.params_json(best["params"]), **best_json},
    )
    runs.write_json(
        os.path.join(run_dir, "mean_params.json"),
        {
            **selection.params_json(mean),
            "distance_m": summary["final_mean_distance_m"],
            "fell": summary["final_mean_fell"],
        },
    )
