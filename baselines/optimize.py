"""The round loop shared by the gait optimizers (CEM, CMA-ES): cost, bookkeeping, checkpoints.

An optimizer proposes a batch of amplitude vectors (`ask`), learns from their costs
(`tell`), and can save and restore its whole state (`state_dict` / `load_state_dict`,
JSON-serializable). `run_rounds` evaluates each batch with the batched rollout evaluator,
keeps the best vector seen, appends a row to `progress.csv`, writes `checkpoint.json`
atomically after every round, and on resume continues from it bit-identically.

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
from typing import Protocol

import numpy as np
from absl import flags

from baselines import cli, progress, runs
from baselines.batch_eval import BatchEvaluator, BatchResult
from cpg_suite import cpg

TASKS = ("darwin_walk",)


@dataclasses.dataclass(frozen=True)
class OptimizerSettings:
    """Settings every gait optimizer shares; all of them decide the result.

    Attributes:
      task: The DARwIn-OP task.
      population: Samples per round K (the study: 10-50).
      rounds: Rounds.
      seed: Sampling seed.
      trial_steps: Control steps per trial (the study: 1000).
      eval_seeds: Initial states each candidate is scored on (seeds 0..N-1), every round.
      fall_penalty: Cost of a fall, m.
      lateral_penalty: Cost per metre of lateral displacement.
    """

    task: str = "darwin_walk"
    population: int = 50
    rounds: int = 50
    seed: int = 0
    trial_steps: int = 1000
    eval_seeds: int = 1
    fall_penalty: float = 10.0
    lateral_penalty: float = 0.0

    def __post_init__(self):
        require = cli.require
        require(self.task in TASKS, f"unknown --task {self.task!r}; valid: {', '.join(TASKS)}")
        require(self.population >= 2, f"--population must be ≥ 2, got {self.population}")
        require(self.rounds >= 1, f"--rounds must be ≥ 1, got {self.rounds}")
        require(self.seed >= 0, f"--seed must be ≥ 0, got {self.seed}")
        require(self.trial_steps >= 1, f"--trial_steps must be ≥ 1, got {self.trial_steps}")
        require(self.eval_seeds >= 1, f"--eval_seeds must be ≥ 1, got {self.eval_seeds}")
        require(self.fall_penalty >= 0, f"--fall_penalty must be ≥ 0, got {self.fall_penalty}")
        require(
            self.lateral_penalty >= 0, f"--lateral_penalty must be ≥ 0, got {self.lateral_penalty}"
        )


class Optimizer(Protocol):
    """What `run_rounds` needs of an optimizer (CEM, CMA-ES, or a user's own)."""

    mean: np.ndarray  # The current distribution mean.

    @property
    def sigma(self) -> float: ...  # Its average standard deviation (for the progress file).

    def ask(self) -> np.ndarray: ...

    def tell(self, samples: np.ndarray, costs: np.ndarray) -> None: ...

    def state_dict(self) -> dict: ...

    def load_state_dict(self, state: dict) -> None: ...


def define_flags() -> None:
    """Defines the flags every gait optimizer shares (only when one runs as a program)."""
    d = OptimizerSettings()
    flags.DEFINE_string("task", d.task, f"Task: {', '.join(TASKS)}.")
    flags.DEFINE_integer("population", d.population, "Samples per round K (the study: 10-50).")
    flags.DEFINE_integer("rounds", d.rounds, "Rounds.")
    flags.DEFINE_integer("seed", d.seed, "Sampling seed.")
    flags.DEFINE_integer("trial_steps", d.trial_steps, "Control steps per trial (the study: 1000).")
    flags.DEFINE_integer(
        "eval_seeds", d.eval_seeds, "Initial states each candidate is scored on (seeds 0..N-1)."
    )
    flags.DEFINE_float(
        "fall_penalty", d.fall_penalty, "Cost of a fall (m): high, so falls never make the elite."
    )
    flags.DEFINE_float(
        "lateral_penalty", d.lateral_penalty, "Cost per metre of lateral displacement."
    )
    o = runs.RunOptions()
    flags.DEFINE_integer("threads", o.threads, "Evaluator threads (results do not depend on it).")
    flags.DEFINE_string("output_dir", o.output_dir, "Root of the output tree.")
    flags.DEFINE_string("run_name", o.run_name, "Run directory name (default from settings).")
    flags.DEFINE_bool("resume", o.resume, "Continue runs from their checkpoints.")
    flags.DEFINE_bool("overwrite", o.overwrite, "Replace existing run directories.")


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


def _amplitudes_json(vector) -> dict:
    return {"amplitudes": {n: float(v) for n, v in zip(cpg.AMPLITUDE_NAMES, vector)}}


@dataclasses.dataclass
class _RunState:
    """What a checkpoint holds besides the optimizer."""

    totals: dict = dataclasses.field(
        default_factory=lambda: {
            "round": 0,
            "falls_total": 0,
            "evaluations": 0,
            "sim_steps": 0,
            "wall_s": 0.0,
        }
    )
    best: dict = dataclasses.field(default_factory=lambda: {"cost": np.inf})
    rows: list = dataclasses.field(default_factory=list)

    def to_json(self, identity: dict, optimizer: Optimizer) -> dict:
        return {
            "identity": identity,
            "totals": self.totals,
            "best": self.best,
            "rows": self.rows,
            "optimizer": optimizer.state_dict(),
        }


def _read_checkpoint(path: str, identity: dict) -> dict:
    try:
        checkpoint = runs.read_json(path)
    except (OSError, ValueError) as e:
        raise CheckpointError(f"cannot read checkpoint {path}: {e}") from None
    if not isinstance(checkpoint, dict) or checkpoint.get("identity") != identity:
        raise CheckpointError(
            f"checkpoint {path} belongs to another configuration; use another --run_name "
            "or --overwrite"
        )
    return checkpoint


def _restore(path: str, identity: dict, optimizer: Optimizer, resume: bool) -> _RunState:
    """The state of a fresh run, or the checkpoint's (loading the optimizer's state too)."""
    if not (resume and os.path.exists(path)):
        return _RunState()
    checkpoint = _read_checkpoint(path, identity)
    optimizer.load_state_dict(checkpoint["optimizer"])
    best = checkpoint["best"]
    best["cost"] = float(best["cost"])
    return _RunState(checkpoint["totals"], best, checkpoint["rows"])


def _record_round(
    state: _RunState,
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
    }


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
    run_dir: str, state: _RunState, optimizer: Optimizer, final: BatchResult, wall_s: float
) -> dict:
    """Writes best_params.json, mean_params.json and summary.json; returns the summary."""
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
    best_json = {"round": best["round"], "distance_m": best["distance_m"], "fell": best["fell"]}
    runs.write_json(
        os.path.join(run_dir, "best_params.json"), {**_amplitudes_json(best["params"]), **best_json}
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


def run_rounds(
    optimizer: Optimizer,
    evaluator: BatchEvaluator,
    run_dir: str,
    settings: OptimizerSettings,
    *,
    resume: bool = False,
    log: Callable[[str], None] = progress.write,
) -> dict:
    """Runs the optimizer for `settings.rounds` rounds and writes the run files.

    Each round: ask → evaluate every candidate from the same initial states → cost →
    tell → record the best → progress row → checkpoint. Then the final mean is tried once.

    Args:
      optimizer: See `Optimizer`; `first_sample_is_mean = True` when `ask()` puts the
        current mean first (then its trial is logged as the mean vector's).
      evaluator: The batched evaluator.
      run_dir: The run directory (already created, with config.json).
      settings: The run's settings; all of them must match to resume.
      resume: Continue from `checkpoint.json` if present.
      log: Receives one line per round.

    Returns:
      The summary (also written to `summary.json`).

    Raises:
      CheckpointError: On a corrupt or foreign checkpoint when resuming.
    """
    identity = dataclasses.asdict(settings)
    checkpoint_path = os.path.join(run_dir, "checkpoint.json")
    state = _restore(checkpoint_path, identity, optimizer, resume)
    eval_seeds = list(range(settings.eval_seeds))
    has_mean = bool(getattr(optimizer, "first_sample_is_mean", False))
    # progress.csv is rewritten from the checkpoint's rows: a row written after the last
    # checkpoint (a kill between the two writes) is dropped and recomputed.
    with runs.ProgressCSV(os.path.join(run_dir, "progress.csv"), PROGRESS_FIELDS) as rows_file:
        for row in state.rows:
            rows_file.append(row)
        pending = range(state.totals["round"], settings.rounds)
        for _ in progress.track(pending, desc=os.path.basename(run_dir), unit="round"):
            start = time.perf_counter()
            samples = optimizer.ask()
            result = evaluator.evaluate(samples, eval_seeds)
            costs = trial_costs(result, settings.fall_penalty, settings.lateral_penalty)
            optimizer.tell(samples, costs)
            elapsed = time.perf_counter() - start
            row = _record_round(state, samples, result, costs, optimizer.sigma, has_mean, elapsed)
            state.rows.append(row)
            rows_file.append(row)
            runs.write_json(checkpoint_path, state.to_json(identity, optimizer))
            log(round_line(row, len(samples) * len(eval_seeds)))
    # The final mean has not been tried by the algorithm itself (thesis Sec. 6.3): try it.
    start = time.perf_counter()
    final = evaluator.evaluate(optimizer.mean, eval_seeds)
    return _finish(run_dir, state, optimizer, final, time.perf_counter() - start)


def run_optimizer(
    method: str,
    optimizer: Optimizer,
    settings: OptimizerSettings,
    options: runs.RunOptions,
    log: Callable[[str], None] = progress.write,
) -> tuple[str, dict]:
    """Creates (or reopens) the run directory and runs `optimizer` for its rounds.

    Args:
      method: Method name (the run directory's second level), e.g. "cem"; also the CLI
        module `baselines.<method>` recorded in config.json's command.
      optimizer: A fresh optimizer (replaced by the checkpoint's state on resume).
      settings: The run's settings.
      options: Output directory, run name (required here), threads, resume, overwrite.
      log: Receives progress lines.

    Returns:
      `(run_dir, summary)`.

    Raises:
      ValueError: If `options.run_name` is not set.
      runs.RunDirectoryExists, CheckpointError.
    """
    if not options.run_name:
        raise ValueError("run_optimizer needs options.run_name")
    run_dir = runs.run_directory(
        options.output_dir,
        method,
        settings.task,
        options.run_name,
        overwrite=options.overwrite,
        resume=options.resume,
    )
    summary_path = os.path.join(run_dir, "summary.json")
    if options.resume and os.path.exists(summary_path):
        log(f"{run_dir}: already finished")
        return run_dir, runs.read_json(summary_path)
    if not (options.resume and os.path.exists(os.path.join(run_dir, "checkpoint.json"))):
        flags_of_run = {
            **dataclasses.asdict(settings),
            "output_dir": options.output_dir,
            "run_name": options.run_name,
        }
        command = runs.command_line(f"baselines.{method}", flags_of_run)
        runs.write_config(run_dir, settings, command)
    with BatchEvaluator(settings.task, settings.trial_steps, options.threads) as evaluator:
        summary = run_rounds(
            optimizer, evaluator, run_dir, settings, resume=options.resume, log=log
        )
    return run_dir, summary


def summary_line(run_dir: str, summary: dict) -> str:
    """One line describing a finished run."""
    fell = " (fell)" if summary["final_mean_fell"] else ""
    return (
        f"{run_dir}: best {summary['best_distance_m']:+.3f} m in round "
        f"{summary['best_round']}, final mean {summary['final_mean_distance_m']:+.3f} m{fell}, "
        f"falls {summary['falls_total']}/{summary['evaluations']}, {summary['wall_s']:.0f} s"
    )


def run_jobs(
    jobs: list[tuple[OptimizerSettings, runs.RunOptions]],
    run: Callable[..., tuple[str, dict]],
    log: Callable[[str], None] = progress.write,
) -> list[tuple[str, dict]]:
    """Runs each job with `run(settings, options, log=...)`, printing a summary line per run.

    Args:
      jobs: (settings, options) per run, options with their run names set.
      run: The method's run function (e.g. `baselines.cem.run_cem`).
      log: Receives progress and summary lines.

    Returns:
      `(run_dir, summary)` per job.

    Raises:
      cli.UsageError: For a run directory that exists or a foreign/corrupt checkpoint.
    """
    start = time.perf_counter()
    done = []
    for i, (settings, options) in enumerate(progress.track(jobs, desc="runs", unit="run"), 1):
        prefix = f"[{i}/{len(jobs)} {options.run_name}] " if len(jobs) > 1 else ""
        try:
            run_dir, summary = run(settings, options, log=lambda line, p=prefix: log(p + line))
        except runs.RunDirectoryExists as e:
            raise cli.UsageError(f"{e} (or --resume to continue it)") from None
        except CheckpointError as e:
            raise cli.UsageError(str(e)) from None
        log(prefix + summary_line(run_dir, summary))
        done.append((run_dir, summary))
    if len(jobs) > 1:
        log(f"{len(jobs)} runs in {time.perf_counter() - start:.0f} s")
    return done
