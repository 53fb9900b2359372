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

import base64
import contextlib
import dataclasses
import os
import pickle
import time
from collections.abc import Callable
from typing import Protocol

import numpy as np
from absl import flags

from cpg_suite import cli, cpg, evaluation, feedback, progress, protocol
from cpg_suite.evaluation import ray_backend
from cpg_suite.evaluation.open_loop import BatchEvaluator, BatchResult
from cpg_suite.harness import ray_tasks, runs
from cpg_suite.protocol import score

TASKS = protocol.TIERS  # Optimizers may train on any tier.


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
      fresh_starts: Draw `eval_seeds` new training seeds every round (the same for all the
        round's candidates) instead of reusing seeds 0..N-1 (the study's setting).
      validation_seeds: Validation seeds the reported gait is selected on.
      validation_every: Rounds between validation scores of the mean (0: none).
      validation_top: In-sample best candidates re-scored on validation with the final mean.
      test_seeds: Test seeds per tier the selected gait is scored on at the end (0: none).
      controller: What is tuned: "open_loop" (the study's 11 CPG amplitudes) or
        "feedback" (the amplitudes and the feedback CPG's gains, `cpg_suite.feedback`).
    """

    task: str = "darwin_walk"
    population: int = 50
    rounds: int = 50
    seed: int = 0
    trial_steps: int = 1000
    eval_seeds: int = 1
    fall_penalty: float = 10.0
    lateral_penalty: float = 0.0
    fresh_starts: bool = False
    validation_seeds: int = 10
    validation_every: int = 10
    validation_top: int = 3
    test_seeds: int = len(protocol.TEST)
    controller: str = "open_loop"

    def __post_init__(self):
        require = cli.require
        cli.require_controller(self.controller)
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
        require(
            self.validation_seeds >= 1,
            f"--validation_seeds must be ≥ 1, got {self.validation_seeds}",
        )
        require(
            self.validation_every >= 0,
            f"--validation_every must be ≥ 0, got {self.validation_every}",
        )
        require(
            self.validation_top >= 0, f"--validation_top must be ≥ 0, got {self.validation_top}"
        )
        require(
            0 <= self.test_seeds <= len(protocol.TEST),
            f"--test_seeds must lie in [0, {len(protocol.TEST)}], got {self.test_seeds}",
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
    flags.DEFINE_bool(
        "fresh_starts", d.fresh_starts, "New training seeds every round (common to the round)."
    )
    flags.DEFINE_integer(
        "validation_seeds", d.validation_seeds, "Validation seeds for selecting the gait."
    )
    flags.DEFINE_integer(
        "validation_every", d.validation_every, "Rounds between validation scores (0: none)."
    )
    flags.DEFINE_integer(
        "validation_top", d.validation_top, "In-sample best candidates re-scored on validation."
    )
    flags.DEFINE_integer(
        "test_seeds", d.test_seeds, "Test seeds per tier for the final score (0: none)."
    )
    o = runs.RunOptions()
    flags.DEFINE_integer("threads", o.threads, "Evaluator threads (results do not depend on it).")
    flags.DEFINE_string("output_dir", o.output_dir, "Root of the output tree.")
    flags.DEFINE_string("run_name", o.run_name, "Run directory name (default from settings).")
    flags.DEFINE_bool("resume", o.resume, "Continue runs from their checkpoints.")
    flags.DEFINE_bool("overwrite", o.overwrite, "Replace existing run directories.")
    cli.define_backend_flags()
    flags.DEFINE_enum(
        "controller", d.controller, list(cli.CONTROLLERS), "open_loop amplitudes or feedback CPG."
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
    "validation_m",
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
    """The parameters by name: the amplitudes (and the feedback gains, if any)."""
    if len(vector) == feedback.N_PARAMS:
        return feedback.params_json(vector)
    return {"amplitudes": {n: float(v) for n, v in zip(cpg.AMPLITUDE_NAMES, vector)}}


def start_vector(settings: OptimizerSettings) -> np.ndarray:
    """Where an optimizer starts: the hand-tuned gait (with zero feedback gains)."""
    if settings.controller == "feedback":
        return feedback.start_params("hand_tuned")
    return cpg.amplitudes_from("hand_tuned")


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
    top: list = dataclasses.field(default_factory=list)  # in-sample best, for selection

    def to_json(self, identity: dict, optimizer: Optimizer) -> dict:
        return {
            "identity": identity,
            "totals": self.totals,
            "best": self.best,
            "rows": self.rows,
            "top": self.top,
            "optimizer": optimizer.state_dict(),
        }

    def keep_top(self, samples: np.ndarray, costs: np.ndarray, k: int) -> None:
        """Keeps the `k` cheapest distinct candidates seen so far (finite costs only)."""
        entries = self.top + [
            {"cost": float(c), "params": x.tolist()}
            for x, c in zip(samples, costs)
            if np.isfinite(c)
        ]
        entries.sort(key=lambda e: e["cost"])
        kept = []
        for entry in entries:
            if len(kept) < k and all(entry["params"] != e["params"] for e in kept):
                kept.append(entry)
        self.top = kept


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
    return _RunState(checkpoint["totals"], best, checkpoint["rows"], checkpoint["top"])


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
    return summary


def round_seeds(settings: OptimizerSettings, round_number: int) -> list[int]:
    """The training seeds of a round (1-based; `rounds + 1` for the final mean's trial).

    The study's setting reuses seeds 0..eval_seeds-1; with `fresh_starts` each round draws
    its own from the training range with a generator keyed by (seed, round).
    """
    if not settings.fresh_starts:
        return list(range(settings.eval_seeds))
    rng = np.random.default_rng([settings.seed, round_number])
    draws = rng.integers(protocol.TRAINING.start, protocol.TRAINING.stop, settings.eval_seeds)
    return protocol.check_training(draws)


def validation_score(
    evaluator: BatchEvaluator, candidates: np.ndarray, settings: OptimizerSettings
) -> tuple[np.ndarray, int]:
    """Mean success-weighted distance (a fall scores 0) of each candidate on the
    validation seeds; and the physics steps it took."""
    result = evaluator.evaluate(candidates, protocol.validation_seeds(settings.validation_seeds))
    return np.where(result.fell, 0.0, result.distance_m).mean(axis=1), result.sim_steps


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
        value, steps = validation_score(evaluator, optimizer.mean[None], settings)
        row["validation_m"] = float(value[0])
        state.totals["validation_sim_steps"] = state.totals.get("validation_sim_steps", 0) + steps


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
    state = _restore(checkpoint_path, identity, optimizer, resume)
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
    summary.update(_select_and_test(run_dir, state, optimizer, evaluator, settings, scoring, log))
    runs.write_json(os.path.join(run_dir, "summary.json"), summary)
    return summary


def _select_and_test(run_dir, state, optimizer, evaluator, settings, scoring, log) -> dict:
    """Selects the reported gait on validation seeds and scores it on the test tiers."""
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
        {**_amplitudes_json(candidates[k]), "source": names[k]},
    )
    out = {
        "selected": selected,
        "validation_sim_steps": state.totals.get("validation_sim_steps", 0) + steps,
    }
    if settings.test_seeds:
        card = score.score_gait(
            candidates[k],
            score.ScoreSettings(seeds=settings.test_seeds, steps=settings.trial_steps, **scoring),
        )
        out["test"] = {k2: card[k2] for k2 in ("tiers", "all", "scoring_sim_steps")}
        log(f"selected gait: {names[k]} (validation {values[k]:+.3f} m); test score card:")
        log(score.format_card(card))
    return out


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
      ray_backend.ClusterUnreachable: With backend "ray", if no cluster answers.
    """
    if not options.run_name:
        raise ValueError("run_optimizer needs options.run_name")
    # Reach the cluster before anything is written (ClusterUnreachable leaves no run files).
    with ray_backend.connected(options.backend, options.ray_address):
        return _run_in_directory(method, optimizer, settings, options, log)


def _open_run_directory(method: str, settings, options: runs.RunOptions) -> str:
    """The run's directory, opened as `options.resume` and `options.overwrite` say."""
    return runs.run_directory(
        options.output_dir,
        method,
        settings.task,
        options.run_name,
        overwrite=options.overwrite,
        resume=options.resume,
    )


def _run_in_directory(method, optimizer, settings, options, log) -> tuple[str, dict]:
    run_dir = _open_run_directory(method, settings, options)
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
        builtin = method in ("cem", "cmaes")  # a user's optimizer runs from their own code
        command = runs.command_line(f"baselines.{method}", flags_of_run) if builtin else None
        runs.write_config(run_dir, settings, command)
    with evaluation.open_evaluator(
        settings.task,
        settings.trial_steps,
        options.threads,
        options.backend,
        options.ray_address,
        settings.controller,
    ) as evaluator:
        summary = run_rounds(
            optimizer,
            evaluator,
            run_dir,
            settings,
            resume=options.resume,
            threads=options.threads,
            backend=options.backend,
            ray_address=options.ray_address,
            log=log,
        )
    return run_dir, summary


class AskTell:
    """Any ask/tell optimizer (pycma, Nevergrad through a shim, evosax, your own) in the
    round loop: it needs `ask()` → candidates and `tell(candidates, costs)`.

    The run's mean and spread come from the callables given (default: the optimizer's
    `mean` and `sigma` attributes, as pycma has them). Checkpoints pickle the optimizer and
    NumPy's global generator state (some libraries, pycma among them, sample from it), so a
    killed run resumes where it stopped.
    """

    def __init__(
        self,
        optimizer,
        mean: Callable[[object], np.ndarray] = lambda o: o.mean,
        sigma: Callable[[object], float] = lambda o: o.sigma,
    ):
        """Args:
        optimizer: The optimizer object.
        mean: Its current distribution mean (the candidate tried at the end).
        sigma: Its average standard deviation (logged in progress.csv).
        """
        self.optimizer = optimizer
        self._mean, self._sigma = mean, sigma

    @property
    def mean(self) -> np.ndarray:
        return np.asarray(self._mean(self.optimizer), dtype=np.float64)

    @property
    def sigma(self) -> float:
        return float(self._sigma(self.optimizer))

    def ask(self) -> np.ndarray:
        return np.asarray(self.optimizer.ask(), dtype=np.float64)

    def tell(self, samples: np.ndarray, costs: np.ndarray) -> None:
        costs = np.where(np.isfinite(costs), costs, np.finfo(np.float64).max)
        self.optimizer.tell(list(samples), [float(c) for c in costs])

    def state_dict(self) -> dict:
        kind, keys, pos, has_gauss, cached = np.random.get_state()
        return {
            "optimizer": base64.b64encode(pickle.dumps(self.optimizer)).decode("ascii"),
            "np_random": [kind, keys.tolist(), int(pos), int(has_gauss), float(cached)],
        }

    def load_state_dict(self, state: dict) -> None:
        self.optimizer = pickle.loads(base64.b64decode(state["optimizer"]))
        kind, keys, pos, has_gauss, cached = state["np_random"]
        np.random.set_state((kind, np.array(keys, dtype=np.uint32), pos, has_gauss, cached))


def run(
    optimizer: Optimizer,
    settings: OptimizerSettings,
    options: runs.RunOptions,
    method: str,
    log: Callable[[str], None] = progress.write,
    default_name: str | None = None,
) -> tuple[str, dict]:
    """Runs any optimizer through the benchmark's loop, run files, selection and scoring.

    Args:
      optimizer: An `Optimizer` (e.g. `AskTell(cma.CMAEvolutionStrategy(...))`).
      settings: Budget, task, cost and protocol settings.
      options: Output directory, run name (default `<method>_seed<seed>`), threads, resume.
      method: The method's name: the run directory's second level and its leaderboard row.
      log: Receives progress lines.
      default_name: The run name when `options` gives none (default `<method>_seed<seed>`).

    Returns:
      `(run_dir, summary)`; the summary holds the test score card.

    Raises:
      runs.RunDirectoryExists, CheckpointError.
    """
    if not options.run_name:
        name = default_name or f"{method}_seed{settings.seed}"
        options = dataclasses.replace(options, run_name=name)
    return run_optimizer(method, optimizer, settings, options, log)


def summary_line(run_dir: str, summary: dict) -> str:
    """One line describing a finished run."""
    fell = " (fell)" if summary["final_mean_fell"] else ""
    line = (
        f"{run_dir}: in-sample best {summary['best_distance_m']:+.3f} m in round "
        f"{summary['best_round']}, final mean {summary['final_mean_distance_m']:+.3f} m{fell}, "
        f"falls {summary['falls_total']}/{summary['evaluations']}, {summary['wall_s']:.0f} s"
    )
    if "test" in summary:
        test = summary["test"]["all"]
        swd = test["success_weighted_distance_m"]
        line += (
            f"; test score (all tiers, {summary['selected']['source']}) {swd['mean']:+.3f} m "
            f"[{swd['ci95'][0]:+.3f}, {swd['ci95'][1]:+.3f}], falls "
            f"{test['fall_rate']['value']:.1%}"
        )
    return line


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
        done = []
        for i, (settings, options) in enumerate(progress.track(jobs, desc="runs", unit="run"), 1):
            prefix = f"[{i}/{len(jobs)} {options.run_name}] " if len(jobs) > 1 else ""
            with _usage_errors():
                run_dir, summary = run(settings, options, log=lambda x, p=prefix: log(p + x))
            log(prefix + summary_line(run_dir, summary))
            done.append((run_dir, summary))
    if len(jobs) > 1:
        log(f"{len(jobs)} runs in {time.perf_counter() - start:.0f} s")
    return done


@contextlib.contextmanager
def _usage_errors():
    """A run directory that exists or a foreign checkpoint as a one-line usage error (also
    when raised in a Ray task: Ray's error is an instance of the task's exception)."""
    try:
        yield
    except runs.RunDirectoryExists as e:
        raise cli.UsageError(f"{getattr(e, 'cause', e)} (or --resume to continue it)") from None
    except CheckpointError as e:
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
                _open_run_directory(method, settings, options)
            local = dataclasses.replace(options, backend="local", resume=True, overwrite=False)
            settings = ray_tasks.importable_settings(settings)
            tasks.append((ray_tasks.importable(run), settings, local))

        def finished(i, result):
            log(f"[{i + 1}/{len(jobs)} {jobs[i][1].run_name}] " + summary_line(*result))

        with _usage_errors():
            return ray_tasks.map_tasks(
                _run_job, tasks, num_cpus=jobs[0][1].threads, on_result=finished
            )
