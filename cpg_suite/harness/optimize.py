"""Running a gait optimizer through the benchmark: the entry points a method calls.

A method (`baselines.cem`, `baselines.cmaes`, or a user's own ask/tell optimizer through
`AskTell`) defines its flags with `define_flags`, starts from `start_vector`, and calls `run`:
it opens the run directory (`cpg_suite.runfiles.runs`), then the round loop
(`cpg_suite.harness.rounds`) trains, checkpoints, selects the reported gait on validation
seeds and scores it on the test tiers.

Beside it in `cpg_suite.harness`: `interface` (the settings every optimizer shares and the
`Optimizer` protocol), `checkpoints` (the state kept between rounds, `CheckpointError`),
`selection` (the reported gait and its test card) and `grids` (grids of runs, local or Ray).
"""

from __future__ import annotations

import base64
import dataclasses
import os
import pickle
from collections.abc import Callable

import numpy as np
from absl import flags

from cpg_suite import cli, cpg, evaluation, feedback, progress
from cpg_suite.evaluation import ray_backend
from cpg_suite.harness import rounds
from cpg_suite.harness.interface import TASKS, Optimizer, OptimizerSettings
from cpg_suite.runfiles import runs


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
    flags.DEFINE_integer(
        "benchmark_version",
        d.benchmark_version,
        "Train and score under this benchmark version (1: the study's unlimited physics).",
    )


def start_vector(settings: OptimizerSettings) -> np.ndarray:
    """Where an optimizer starts: the hand-tuned gait (with zero feedback gains)."""
    if settings.controller == "feedback":
        return feedback.start_params("hand_tuned")
    return cpg.amplitudes_from("hand_tuned")


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
        """The optimizer's current distribution mean."""
        return np.asarray(self._mean(self.optimizer), dtype=np.float64)

    @property
    def sigma(self) -> float:
        """The optimizer's average standard deviation."""
        return float(self._sigma(self.optimizer))

    def ask(self) -> np.ndarray:
        """The optimizer's candidates, one per row."""
        return np.asarray(self.optimizer.ask(), dtype=np.float64)

    def tell(self, samples: np.ndarray, costs: np.ndarray) -> None:
        """Gives the optimizer the candidates' costs (a failed trial's as the largest float)."""
        costs = np.where(np.isfinite(costs), costs, np.finfo(np.float64).max)
        self.optimizer.tell(list(samples), [float(c) for c in costs])

    def state_dict(self) -> dict:
        """The pickled optimizer (base64) and NumPy's global generator state, as JSON."""
        kind, keys, pos, has_gauss, cached = np.random.get_state()
        return {
            "optimizer": base64.b64encode(pickle.dumps(self.optimizer)).decode("ascii"),
            "np_random": [kind, keys.tolist(), int(pos), int(has_gauss), float(cached)],
        }

    def load_state_dict(self, state: dict) -> None:
        """Restores what `state_dict` returned."""
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
      runs.RunDirectoryExists, checkpoints.CheckpointError.
    """
    if not options.run_name:
        name = default_name or f"{method}_seed{settings.seed}"
        options = dataclasses.replace(options, run_name=name)
    return run_optimizer(method, optimizer, settings, options, log)


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
      runs.RunDirectoryExists, checkpoints.CheckpointError.
      ray_backend.ClusterUnreachable: With backend "ray", if no cluster answers.
    """
    if not options.run_name:
        raise ValueError("run_optimizer needs options.run_name")
    # Reach the cluster before anything is written (ClusterUnreachable leaves no run files).
    with ray_backend.connected(options.backend, options.ray_address):
        return _run_in_directory(method, optimizer, settings, options, log)


def open_run_directory(method: str, settings: OptimizerSettings, options: runs.RunOptions) -> str:
    """The run's directory, opened as `options.resume` and `options.overwrite` say.

    Args:
      method: The method's name (the run directory's second level).
      settings: The run's settings (its task is the third level).
      options: Output directory, run name, resume, overwrite.

    Returns:
      The run directory's path.

    Raises:
      runs.RunDirectoryExists: If it exists and neither resume nor overwrite is set.
    """
    return runs.run_directory(
        options.output_dir,
        method,
        settings.task,
        options.run_name,
        overwrite=options.overwrite,
        resume=options.resume,
    )


def _run_in_directory(method, optimizer, settings, options, log) -> tuple[str, dict]:
    """The run in its directory: the finished summary, or training from scratch or resumed."""
    run_dir = open_run_directory(method, settings, options)
    summary_path = os.path.join(run_dir, "summary.json")
    if options.resume and os.path.exists(summary_path):
        log(f"{run_dir}: already finished")
        return run_dir, runs.read_json(summary_path)
    if not (options.resume and os.path.exists(os.path.join(run_dir, "checkpoint.json"))):
        _write_config(run_dir, method, settings, options)
    with evaluation.open_evaluator(
        settings.task,
        settings.trial_steps,
        options.threads,
        options.backend,
        options.ray_address,
        settings.controller,
        task_kwargs=settings.task_kwargs(),
    ) as evaluator:
        summary = rounds.run_rounds(
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


def _write_config(run_dir, method, settings, options) -> None:
    """config.json of a new run (with the command that reruns it for CEM and CMA-ES)."""
    flags_of_run = {
        **dataclasses.asdict(settings),
        "output_dir": options.output_dir,
        "run_name": options.run_name,
    }
    builtin = method in ("cem", "cmaes")  # a user's optimizer runs from their own code
    command = runs.command_line(f"baselines.{method}", flags_of_run) if builtin else None
    runs.write_config(run_dir, settings, command)


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
