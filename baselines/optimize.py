"""The round loop shared by the gait optimizers (CEM, CMA-ES): cost, bookkeeping, checkpoints.

An optimizer proposes a batch of amplitude vectors (`ask`), learns from their costs
(`tell`), and can save and restore its whole state (`state_dict` / `load_state_dict`,
JSON-serializable). `run_rounds` evaluates each batch with the batched rollout evaluator,
keeps the best vector seen, appends a row to `progress.csv`, writes `checkpoint.json`
atomically after every round, and on resume continues from it bit-identically.

Cost of a trial (thesis Sec. 6.2): −distance (m) + fall_penalty · [fell] +
lateral_penalty · |lateral displacement| (m), averaged over the initial-state seeds of the
round (the same seeds for every candidate). The study gives a fall penalty "high" enough
that fallen trials never make the elite, and no lateral weight; ours are flags (default
fall penalty 10 m, more than any distance walked in 16 s).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable

import numpy as np
from absl import flags

from baselines import cli, runs
from baselines.batch_eval import BatchEvaluator, BatchResult
from cpg_suite import cpg

TASKS = ("darwin_walk",)


# Flags shared by every gait optimizer (`baselines.cem`, `baselines.cmaes`).
def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    global \
        _TASK, \
        _POPULATION, \
        _ROUNDS, \
        _SEED, \
        _TRIAL_STEPS, \
        _EVAL_SEEDS, \
        _FALL_PENALTY, \
        _LATERAL_PENALTY, \
        _THREADS, \
        _OUTPUT_DIR, \
        _RUN_NAME, \
        _RESUME, \
        _OVERWRITE
    _TASK = flags.DEFINE_string("task", "darwin_walk", f"Task: {', '.join(TASKS)}.")
    _POPULATION = flags.DEFINE_integer("population", 50, "Samples per round K (the study: 10-50).")
    _ROUNDS = flags.DEFINE_integer("rounds", 50, "Rounds.")
    _SEED = flags.DEFINE_integer("seed", 0, "Sampling seed.")
    _TRIAL_STEPS = flags.DEFINE_integer(
        "trial_steps", 1000, "Control steps per trial (the study: 1000)."
    )
    _EVAL_SEEDS = flags.DEFINE_integer(
        "eval_seeds", 1, "Initial states each candidate is scored on (seeds 0..N-1), every round."
    )
    _FALL_PENALTY = flags.DEFINE_float(
        "fall_penalty", 10.0, "Cost of a fall (m): high, so falls never make the elite."
    )
    _LATERAL_PENALTY = flags.DEFINE_float(
        "lateral_penalty", 0.0, "Cost per metre of lateral displacement (the study's variant)."
    )
    _THREADS = flags.DEFINE_integer(
        "threads", 2, "Evaluator threads (results do not depend on it)."
    )
    _OUTPUT_DIR = flags.DEFINE_string("output_dir", "runs", "Root of the output tree.")
    _RUN_NAME = flags.DEFINE_string("run_name", None, "Run directory name (default from settings).")
    _RESUME = flags.DEFINE_bool("resume", False, "Continue runs from their checkpoints.")
    _OVERWRITE = flags.DEFINE_bool("overwrite", False, "Replace existing run directories.")


# Settings that must match for a checkpoint to be resumed (plus the method's own).
_IDENTITY = (
    "task",
    "population",
    "rounds",
    "seed",
    "trial_steps",
    "eval_seeds",
    "fall_penalty",
    "lateral_penalty",
)

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
]


class CheckpointError(Exception):
    """A checkpoint that cannot be read or belongs to another configuration."""


def trial_costs(result: BatchResult, fall_penalty: float, lateral_penalty: float) -> np.ndarray:
    """Cost per candidate, averaged over its initial states (lower is better)."""
    per_trial = (
        -result.distance_m + fall_penalty * result.fell + lateral_penalty * np.abs(result.lateral_m)
    )
    return per_trial.mean(axis=1)


def _amplitudes_json(vector: np.ndarray) -> dict:
    return {"amplitudes": {n: float(v) for n, v in zip(cpg.AMPLITUDE_NAMES, vector)}}


def _read_checkpoint(path: str, identity: dict) -> dict:
    try:
        with open(path, encoding="utf-8") as f:
            checkpoint = json.load(f)
    except (OSError, json.JSONDecodeError) as e:
        raise CheckpointError(f"cannot read checkpoint {path}: {e}") from None
    if not isinstance(checkpoint, dict) or checkpoint.get("identity") != identity:
        raise CheckpointError(
            f"checkpoint {path} belongs to another configuration; use another --run_name "
            "or --overwrite"
        )
    return checkpoint


def run_rounds(
    optimizer,
    evaluator: BatchEvaluator,
    run_dir: str,
    *,
    rounds: int,
    eval_seeds: list[int],
    fall_penalty: float,
    lateral_penalty: float,
    identity: dict,
    resume: bool = False,
    log: Callable[[str], None] = print,
) -> dict:
    """Runs `rounds` rounds of `optimizer` and writes the run files.

    Args:
      optimizer: Has `ask() -> (K, 11)`, `tell(samples, costs)`, `mean` (the current
        distribution mean), `sigma` (its average standard deviation), `state_dict()` and
        `load_state_dict(d)`; `first_sample_is_mean = True` when `ask()` puts the current
        mean first (then its trial is logged as the mean vector's).
      evaluator: The batched evaluator.
      run_dir: The run directory (already created, with config.json).
      rounds: Number of rounds.
      eval_seeds: Initial-state seeds every candidate is scored on.
      fall_penalty: Cost added for a fall.
      lateral_penalty: Cost per metre of lateral displacement.
      identity: Settings that must match to resume (a foreign checkpoint is refused).
      resume: Continue from `checkpoint.json` if present.
      log: Receives one line per round.

    Returns:
      The summary (also written to `summary.json`).

    Raises:
      CheckpointError: On a corrupt or foreign checkpoint when resuming.
    """
    checkpoint_path = os.path.join(run_dir, "checkpoint.json")
    progress_path = os.path.join(run_dir, "progress.csv")
    totals = {"round": 0, "falls_total": 0, "evaluations": 0, "sim_steps": 0, "wall_s": 0.0}
    best = {"cost": np.inf}
    rows: list[dict] = []
    if resume and os.path.exists(checkpoint_path):
        checkpoint = _read_checkpoint(checkpoint_path, identity)
        optimizer.load_state_dict(checkpoint["optimizer"])
        totals, best, rows = checkpoint["totals"], checkpoint["best"], checkpoint["rows"]
        best["cost"] = float(best["cost"])
    # progress.csv is rewritten from the checkpoint's rows: a row written after the last
    # checkpoint (a kill between the two writes) is dropped and recomputed.
    has_mean = bool(getattr(optimizer, "first_sample_is_mean", False))
    progress = runs.ProgressCSV(progress_path, PROGRESS_FIELDS, truncate=True)
    for row in rows:
        progress.append(row)
    try:
        while totals["round"] < rounds:
            start = time.perf_counter()
            samples = optimizer.ask()
            result = evaluator.evaluate(samples, eval_seeds)
            costs = trial_costs(result, fall_penalty, lateral_penalty)
            optimizer.tell(samples, costs)

            distance = result.distance_m.mean(axis=1)
            fell = result.fell.any(axis=1)
            k = int(np.argmin(costs))
            totals["round"] += 1
            totals["falls_total"] += int(result.fell.sum())
            totals["evaluations"] += int(result.fell.size)
            totals["sim_steps"] += result.sim_steps
            if costs[k] < best["cost"]:
                best = {
                    "cost": float(costs[k]),
                    "distance_m": float(distance[k]),
                    "lateral_m": float(result.lateral_m[k].mean()),
                    "fell": bool(fell[k]),
                    "round": totals["round"],
                    "params": samples[k].tolist(),
                }
            elapsed = time.perf_counter() - start
            totals["wall_s"] += elapsed
            row = {
                "round": totals["round"],
                "best_cost": float(costs[k]),
                "best_distance_m": float(distance[k]),
                "best_fell": int(fell[k]),
                # Sample 1 is the current mean for CEM (thesis 6.2); not for CMA-ES.
                "mean_distance_m": float(distance[0]) if has_mean else "",
                "mean_fell": int(fell[0]) if has_mean else "",
                "falls": int(result.fell.sum()),
                "cost_mean": float(costs.mean()),
                "sigma": float(optimizer.sigma),
                "evaluations": totals["evaluations"],
                "sim_steps": totals["sim_steps"],
                "steps_per_s": round(result.sim_steps / elapsed),
                "wall_s": round(totals["wall_s"], 3),
            }
            rows.append(row)
            progress.append(row)
            runs.write_json(
                checkpoint_path,
                {
                    "identity": identity,
                    "totals": totals,
                    "best": best,
                    "rows": rows,
                    "optimizer": optimizer.state_dict(),
                },
            )
            mean_text = (
                f"mean vector {row['mean_distance_m']:+.3f} m"
                f"{' (fell)' if row['mean_fell'] else ''}  "
                if has_mean
                else ""
            )
            log(
                f"round {row['round']:3d}  best {row['best_distance_m']:+.3f} m"
                f"{' (fell)' if row['best_fell'] else ''}  {mean_text}"
                f"falls {row['falls']:2d}/{len(samples) * len(eval_seeds)}  "
                f"{row['steps_per_s']:,} sim steps/s"
            )
    finally:
        progress.close()

    # The final mean has not been tried by the algorithm itself (thesis Sec. 6.3): try it.
    start = time.perf_counter()
    final = evaluator.evaluate(optimizer.mean, eval_seeds)
    totals["wall_s"] += time.perf_counter() - start
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
        "wall_s": totals["wall_s"],
    }
    runs.write_json(
        os.path.join(run_dir, "best_params.json"),
        {
            **_amplitudes_json(np.array(best["params"])),
            "round": best["round"],
            "distance_m": best["distance_m"],
            "fell": best["fell"],
        },
    )
    runs.write_json(
        os.path.join(run_dir, "mean_params.json"),
        {
            **_amplitudes_json(optimizer.mean),
            "distance_m": summary["final_mean_distance_m"],
            "fell": summary["final_mean_fell"],
        },
    )
    runs.write_json(os.path.join(run_dir, "summary.json"), summary)
    return summary


def common_settings() -> dict:
    """Validates the shared flags; returns them as settings.

    Raises:
      cli.UsageError: With a one-line reason.
    """
    cli.check(_TASK.value in TASKS, f"unknown --task {_TASK.value!r}; valid: {', '.join(TASKS)}")
    cli.check(_POPULATION.value >= 2, f"--population must be ≥ 2, got {_POPULATION.value}")
    cli.check(_ROUNDS.value >= 1, f"--rounds must be ≥ 1, got {_ROUNDS.value}")
    cli.check(_SEED.value >= 0, f"--seed must be ≥ 0, got {_SEED.value}")
    cli.check(_TRIAL_STEPS.value >= 1, f"--trial_steps must be ≥ 1, got {_TRIAL_STEPS.value}")
    cli.check(_EVAL_SEEDS.value >= 1, f"--eval_seeds must be ≥ 1, got {_EVAL_SEEDS.value}")
    cli.check(_FALL_PENALTY.value >= 0, f"--fall_penalty must be ≥ 0, got {_FALL_PENALTY.value}")
    cli.check(
        _LATERAL_PENALTY.value >= 0, f"--lateral_penalty must be ≥ 0, got {_LATERAL_PENALTY.value}"
    )
    cli.check(_THREADS.value >= 1, f"--threads must be ≥ 1, got {_THREADS.value}")
    cli.check(
        not (_RESUME.value and _OVERWRITE.value), "--resume and --overwrite exclude each other"
    )
    return {
        "task": _TASK.value,
        "population": _POPULATION.value,
        "rounds": _ROUNDS.value,
        "seed": _SEED.value,
        "trial_steps": _TRIAL_STEPS.value,
        "eval_seeds": _EVAL_SEEDS.value,
        "fall_penalty": _FALL_PENALTY.value,
        "lateral_penalty": _LATERAL_PENALTY.value,
        "output_dir": _OUTPUT_DIR.value,
        "run_name": _RUN_NAME.value,
    }


def run_optimizer(
    method: str,
    optimizer,
    settings: dict,
    own_keys: tuple,
    threads: int,
    resume: bool,
    overwrite: bool,
    log: Callable[[str], None] = print,
):
    """Creates (or reopens) the run directory and runs `optimizer` for its rounds.

    Args:
      method: Method name (the run directory's second level), e.g. "cem".
      optimizer: A fresh optimizer (replaced by the checkpoint's state on resume).
      settings: The run's settings (`common_settings()` plus the method's own).
      own_keys: The method's settings that must also match to resume.
      threads: Evaluator threads.
      resume: Continue from the checkpoint; return a finished run's summary as it is.
      overwrite: Replace an existing run directory.
      log: Receives progress lines.

    Returns:
      `(run_dir, summary)`.

    Raises:
      runs.RunDirectoryExists, CheckpointError.
    """
    run_dir = runs.run_directory(
        settings["output_dir"],
        method,
        settings["task"],
        settings["run_name"],
        overwrite=overwrite,
        resume=resume,
    )
    summary_path = os.path.join(run_dir, "summary.json")
    if resume and os.path.exists(summary_path):
        log(f"{run_dir}: already finished")
        return run_dir, runs.read_json(summary_path)
    identity = {k: settings[k] for k in _IDENTITY + tuple(own_keys)}
    if not (resume and os.path.exists(os.path.join(run_dir, "checkpoint.json"))):
        runs.write_config(run_dir, {**settings, "method": method, "threads": threads})
    with BatchEvaluator(settings["task"], settings["trial_steps"], threads) as evaluator:
        summary = run_rounds(
            optimizer,
            evaluator,
            run_dir,
            rounds=settings["rounds"],
            eval_seeds=list(range(settings["eval_seeds"])),
            fall_penalty=settings["fall_penalty"],
            lateral_penalty=settings["lateral_penalty"],
            identity=identity,
            resume=resume,
            log=log,
        )
    return run_dir, summary


def run_jobs(jobs: list[dict], run: Callable) -> None:
    """Runs each job's settings with `run(settings, threads, resume, overwrite, log)` and
    prints a summary line per run; reports a refused run directory as a usage error."""
    start = time.perf_counter()
    for i, settings in enumerate(jobs, 1):
        prefix = f"[{i}/{len(jobs)} {settings['run_name']}] " if len(jobs) > 1 else ""
        try:
            run_dir, summary = run(
                settings,
                _THREADS.value,
                _RESUME.value,
                _OVERWRITE.value,
                log=lambda line, p=prefix: print(p + line, flush=True),
            )
        except runs.RunDirectoryExists as e:
            raise cli.UsageError(f"{e} (or --resume to continue it)") from None
        except CheckpointError as e:
            raise cli.UsageError(str(e)) from None
        print(
            f"{prefix}{run_dir}: best {summary['best_distance_m']:+.3f} m in round "
            f"{summary['best_round']}, final mean {summary['final_mean_distance_m']:+.3f} m"
            f"{' (fell)' if summary['final_mean_fell'] else ''}, falls "
            f"{summary['falls_total']}/{summary['evaluations']}, {summary['wall_s']:.0f} s",
            flush=True,
        )
    if len(jobs) > 1:
        print(f"{len(jobs)} runs in {time.perf_counter() - start:.0f} s")
