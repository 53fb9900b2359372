r"""Reproduce the study's experiments in one command, then the leaderboards and report.

  python -m analysis.reproduce --quick --out=DIR     # every experiment, small (minutes)
  python -m analysis.reproduce --full --out=DIR      # the real thing (hours on 2 cores)

Runs, as separate processes, into `DIR/runs/`:
  1. value iteration on the Tokic model (thesis Tables A.2/A.3, CR-1);
  2. the pole-balancing claims experiment (`baselines.experiments.pole_claims`);
  3. the crawler experiments (`baselines.experiments.crawler_experiments`);
  4. the CEM settings of thesis Table 6.3 (`baselines.cem --grid=table6_3`), 5 seeds for
     K = 50 in `--full`, under the study's unlimited physics (`--benchmark_version=1`);
  5. CMA-ES at the K = 50 budget (`baselines.cmaes`);
  6. the NAC finding and reward-hypothesis test (`baselines.experiments.nac_experiments`);
then `analysis.leaderboard` and `analysis.report` into `DIR/` (with the rendered gaits in
`--full`, or with `--gaits`). Every step resumes
finished runs, so an interrupted `--full` continues where it stopped when run again.
`--quick` shrinks seeds, rounds, trial lengths and learning steps; its numbers show that
everything runs and how the outputs look, not the benchmark's results.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import functools
import os
import subprocess
import sys
import time
from collections.abc import Callable

from absl import flags

from analysis import leaderboard, report
from cpg_suite import cli

QUICK = {
    "pole": ["--seeds=2", "--steps=6000", "--force_steps=2000"],
    "crawler": ["--seeds=2", "--moves=300"],
    "cem": [
        "--seeds=1",
        "--rounds=3",
        "--trial_steps=300",
        "--validation_seeds=2",
        "--test_seeds=2",
    ],
    "cem_k50": None,
    "cmaes": [
        [
            "--seed=0",
            "--population=10",
            "--rounds=3",
            "--trial_steps=300",
            "--validation_seeds=2",
            "--test_seeds=2",
        ]
    ],
    "nac": ["--seeds=2", "--steps=500", "--eval_seeds=1"],
}
FULL = {
    "pole": ["--seeds=5"],
    "crawler": ["--seeds=5"],
    "cem": ["--seeds=3"],
    "cem_k50": ["--settings=K50_n0.8_e2", "--seeds=5"],
    "cmaes": [[f"--seed={s}"] for s in range(3)],
    "nac": ["--seeds=5"],
}


class StepFailed(RuntimeError):
    """An experiment's process exited with an error (its output is in the log)."""


@dataclasses.dataclass(frozen=True)
class ReproduceSettings:
    """What `python -m analysis.reproduce` runs and where.

    Attributes:
      quick: Small versions of every experiment (minutes); exactly one of quick and full.
      full: The real experiments (hours).
      out: The output folder: runs under `out/runs/`, the log, tables and report in it.
      threads: Evaluator threads of CEM/CMA-ES.
      backend: "local", or "ray": the runs of the CEM grid, the pole and NAC sweeps as Ray
        tasks, CMA-ES's trials on Ray actors (same results).
      ray_address: The Ray cluster for backend "ray" (host:port, "auto", or None).
      gaits: Render the hand-tuned and the best gait (None: with `full`).
    """

    quick: bool = False
    full: bool = False
    out: str | None = None
    threads: int = 2
    backend: str = "local"
    ray_address: str | None = None
    gaits: bool | None = None

    def __post_init__(self):
        cli.require(
            bool(self.quick) != bool(self.full),
            "give exactly one of --quick and --full (small versions in minutes, or the real "
            "experiments in hours)",
        )
        cli.require(bool(self.out), "--out is required: the folder the reproduction goes into")
        cli.require(self.threads >= 1, f"--threads must be ≥ 1, got {self.threads}")
        cli.require_backend(self.backend, self.ray_address)

    @property
    def render_gaits(self) -> bool:
        """Whether the report renders the gaits: `gaits`, or by default with `full`."""
        return bool(self.full) if self.gaits is None else bool(self.gaits)


def _run(args: list[str], log) -> None:
    command = [sys.executable, "-m", *args]
    log.write(f"$ {' '.join(command)}\n")
    log.flush()
    start = time.perf_counter()
    result = subprocess.run(command, stdout=log, stderr=subprocess.STDOUT, check=False)
    log.write(f"# exit {result.returncode} after {time.perf_counter() - start:.0f} s\n")
    log.flush()
    if result.returncode != 0:
        raise RuntimeError(f"{args[0]} failed with exit code {result.returncode}; see the log")


def experiment_steps(
    plan: dict, runs: str, threads: int, backend: list[str] = ()
) -> list[tuple[str, list[str]]]:
    """The experiments in order, as (title, `python -m` arguments): 1. value iteration on
    the Tokic model, 2. the pole claims, 3. the crawler experiments, 4. CEM's Table 6.3
    (5. its K = 50 seeds in --full), 6. CMA-ES, 7. NAC. Each resumes finished runs.
    `backend` (`--backend=...`, `--ray_address=...`) goes to the steps that take it
    (pole, CEM, CMA-ES, NAC; the crawler experiments run here)."""
    backend = list(backend)
    optimizer = [f"--output_dir={runs}", f"--threads={threads}", "--resume", *backend]
    study = ["--benchmark_version=1"]  # the thesis' tables: the study's unlimited physics
    steps = [
        (
            "tokic value iteration",
            ["baselines.tabular", "--model=tokic", "--algo=value_iteration"]
            + [f"--output_dir={runs}", "--overwrite"],
        ),
        (
            "pole claims",
            [
                "baselines.experiments.pole_claims",
                f"--output_dir={runs}/pole",
                "--resume",
                *backend,
            ],
        ),
        (
            "crawler experiments",
            [
                "baselines.experiments.crawler_experiments",
                f"--output_dir={runs}/crawler",
                "--resume",
            ],
        ),
        ("CEM, thesis Table 6.3", ["baselines.cem", "--grid=table6_3", *optimizer, *study]),
    ]
    steps[1][1].extend(plan["pole"])
    steps[2][1].extend(plan["crawler"])
    steps[3][1].extend(plan["cem"])
    if plan["cem_k50"]:
        steps.append(
            ("CEM, K = 50 seeds", ["baselines.cem", "--grid=table6_3", *optimizer, *study])
        )
        steps[-1][1].extend(plan["cem_k50"])
    for extra in plan["cmaes"]:
        steps.append(("CMA-ES", ["baselines.cmaes", *optimizer, *extra]))
    nac = [
        "baselines.experiments.nac_experiments",
        f"--output_dir={runs}/nac",
        "--resume",
        *backend,
    ]
    nac += plan["nac"]
    steps.append(("NAC", nac))
    return steps


def _run_steps(steps: list, log_path: str, log: Callable[[str], None]) -> None:
    """Runs the steps as separate processes, logging their output.

    Raises:
      StepFailed: When a step exits with an error.
    """
    start = time.perf_counter()
    with open(log_path, "a", encoding="utf-8") as log_file:
        for i, (title, command) in enumerate(steps, 1):
            elapsed = time.perf_counter() - start
            eta = f", about {elapsed / (i - 1) * (len(steps) - i + 1):.0f} s left" if i > 1 else ""
            log(f"[{i}/{len(steps)}] {title} ({elapsed:.0f} s elapsed{eta})")
            try:
                _run(command, log_file)
            except RuntimeError as e:
                raise StepFailed(f"{e} ({log_path})") from None


_print = functools.partial(print, flush=True)


def reproduce(settings: ReproduceSettings, log: Callable[[str], None] = _print) -> str:
    """Runs every experiment into `<out>/runs/`, then the leaderboard and the report.

    Each experiment runs as its own process (`experiment_steps`), its output appended to
    `<out>/reproduce.log`; finished runs are resumed. Then `leaderboard.write_tables` and
    `report.write_report` write into `<out>/`.

    Args:
      settings: Which size, where, and how the experiments run.
      log: Receives a line per step and the tables' and report's summary lines.

    Returns:
      The last line: the time it took and where the report is.

    Raises:
      StepFailed: If an experiment fails (nothing after it runs).
      ImportError: Without matplotlib, when the report is drawn.
      RuntimeError: If rendering the gaits fails.
    """
    plan = QUICK if settings.quick else FULL
    out = settings.out
    runs = os.path.join(out, "runs")
    os.makedirs(runs, exist_ok=True)
    start = time.perf_counter()
    backend = [f"--backend={settings.backend}"]
    if settings.ray_address:
        backend.append(f"--ray_address={settings.ray_address}")
    steps = experiment_steps(plan, runs, settings.threads, backend)
    _run_steps(steps, os.path.join(out, "reproduce.log"), log)
    log(leaderboard.write_tables(runs, os.path.join(out, "leaderboard.csv")))
    log(report.write_report(runs, out, gaits=settings.render_gaits))
    return f"done in {time.perf_counter() - start:.0f} s: {out}/report.md"


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    flags.DEFINE_bool("quick", False, "Small versions of every experiment (minutes).")
    flags.DEFINE_bool("full", False, "The real experiments (hours); give one of --quick, --full.")
    flags.DEFINE_string("out", None, "Output folder.")
    flags.DEFINE_integer("threads", 2, "Evaluator threads of CEM/CMA-ES.")
    flags.DEFINE_enum(
        "backend",
        "local",
        list(cli.BACKENDS),
        "ray: the runs of the CEM grid, the pole and NAC sweeps as Ray tasks, CMA-ES's "
        "trials on Ray actors (same results).",
    )
    flags.DEFINE_string("ray_address", None, "Ray cluster: host:port, or auto.")
    flags.DEFINE_bool(
        "gaits", None, "Render the hand-tuned and best gaits (default: with --full; --nogaits)."
    )


def main(argv: list[str]) -> None:
    del argv
    settings = cli.settings_from_flags(ReproduceSettings)
    report.check_matplotlib()
    try:
        print(reproduce(settings))
    except StepFailed as e:
        sys.stderr.write(f"error: {e}\n")
        raise SystemExit(1) from None


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_dirs=("out",))
