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
  7. the study's computed evidence from these runs (`baselines.experiments.study_evidence`);
then `analysis.leaderboard` and `analysis.report` into `DIR/` (with the rendered gaits in
`--full`, or with `--gaits`), and last the study's verdicts (`analysis.study`'s rules)
judged from these runs only, beside the shipped ones (`results/study/claims.csv`):
`DIR/claims.csv` and `DIR/verdicts.md`, the table printed. Every step resumes finished
runs, so an interrupted `--full` continues where it stopped when run again.

`--quick` shrinks seeds, rounds, trial lengths and learning steps (the crawler: 5 seeds,
300 moves, its main configurations); its numbers show that everything runs and how the
outputs look, not the benchmark's results. A rule needs 5 seeds of its runs: where the
quick runs have fewer (CEM, pole, NAC), its verdict is "inconclusive" and says which runs
are missing. The study's full evidence took, by its run files' own records, the time
`recorded_time` states (printed at the end).
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import csv
import dataclasses
import functools
import glob
import json
import os
import resource
import subprocess
import sys
import time
from collections.abc import Callable

from absl import flags

from analysis import leaderboard, report
from cpg_suite import cli

QUICK = {
    "pole": ["--seeds=2", "--steps=6000", "--force_steps=2000"],
    "crawler": ["--seeds=5", "--moves=300", "--quick"],
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


def _cpu_of_children() -> float:
    """CPU seconds (user + system) of the finished child processes so far."""
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    return used.ru_utime + used.ru_stime


def _run(args: list[str], log) -> None:
    command = [sys.executable, "-m", *args]
    log.write(f"$ {' '.join(command)}\n")
    log.flush()
    start, cpu = time.perf_counter(), _cpu_of_children()
    result = subprocess.run(command, stdout=log, stderr=subprocess.STDOUT, check=False)
    log.write(
        f"# exit {result.returncode} after {time.perf_counter() - start:.0f} s "
        f"({_cpu_of_children() - cpu:.0f} s of CPU)\n"
    )
    log.flush()
    if result.returncode != 0:
        raise RuntimeError(f"{args[0]} failed with exit code {result.returncode}; see the log")


def experiment_steps(
    plan: dict, runs: str, threads: int, backend: list[str] = (), evidence: str | None = None
) -> list[tuple[str, list[str]]]:
    """The experiments in order, as (title, `python -m` arguments): 1. value iteration on
    the Tokic model, 2. the pole claims, 3. the crawler experiments, 4. CEM's Table 6.3
    (5. its K = 50 seeds in --full), 6. CMA-ES, 7. NAC, and with `evidence` (the folder
    `evidence_of` lays out) 8. the study's computed evidence from these runs. Each resumes
    finished runs. `backend` (`--backend=...`, `--ray_address=...`) goes to the steps that
    take it (pole, CEM, CMA-ES, NAC; the crawler experiments run here)."""
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
    if evidence:
        steps.append(
            (
                "the study's computed evidence",
                [
                    "baselines.experiments.study_evidence",
                    f"--out={os.path.join(evidence, 'study', 'computed.json')}",
                    f"--study={runs}",
                    f"--protocol_runs={os.path.join(evidence, NO_RUNS)}",
                ],
            )
        )
    return steps


# --- the study's verdicts from the runs made here ------------------------------------------

NO_RUNS = "no_shipped_runs"  # an empty folder: the judge must not fall back on shipped runs
SHIPPED = os.path.join("results", "study", "claims.csv")


def evidence_of(out: str, runs: str) -> str:
    """Lays the runs out as `analysis.study.Evidence` reads them (`<out>/evidence/study/`:
    links to the crawler, pole and NAC runs; computed.json written there by its step) and
    returns the folder."""
    root = os.path.join(out, "evidence")
    os.makedirs(os.path.join(root, "study"), exist_ok=True)
    os.makedirs(os.path.join(root, NO_RUNS), exist_ok=True)
    for name in ("crawler", "pole", "nac"):
        link = os.path.join(root, "study", name)
        if not os.path.lexists(link):
            os.symlink(os.path.abspath(os.path.join(runs, name)), link)
    return root


def judge(out: str, runs: str, evidence: str, shipped: str = SHIPPED) -> list[str]:
    """The study's rules on the runs made here, beside the shipped verdicts.

    Writes `<out>/claims.csv` (as `analysis.study`'s, judged from these runs) and
    `<out>/verdicts.md` (each claim and part: here, shipped), and returns the lines of the
    printed table: the whole claims, then the tallies.
    """
    from analysis.study import build, catalog
    from analysis.study.evidence import Evidence

    ev = Evidence(study=runs, protocol=os.path.join(evidence, NO_RUNS), results=evidence)
    here = build.judge(catalog.load(), ev)
    build.write_csv(os.path.join(out, "claims.csv"), here, build.CLAIM_FIELDS)
    with open(shipped, encoding="utf-8") as f:
        before = {r["id"]: r for r in csv.DictReader(f)}
    same = sum(before.get(c["id"], {}).get("verdict") == c["verdict"] for c in here)
    lines = [
        "| claim | here | shipped | evidence here (or why not judged) |",
        "|---|---|---|---|",
    ]
    table = []
    for c in here:
        why = c["evidence"] or c["why"]
        shown = why if len(why) <= 90 else why[:87] + "..."
        row = f"| {c['id']} | {c['verdict']} | {before.get(c['id'], {}).get('verdict', '-')} |"
        table.append(f"{row} {shown.replace('|', '/')} |")
        if not c["parent"]:
            lines.append(table[-1])
    tallies = [
        "",
        f"here (the same verdict as shipped in {same} of {len(here)} claims and parts): whole "
        "claims "
        f"{build.tally(build.counts(here))}; parts and single claims "
        f"{build.tally(build.leaves(here))}",
        f"shipped: whole claims {build.tally(build.counts(list(before.values())))}; parts and "
        f"single claims {build.tally(build.leaves(list(before.values())))}",
    ]
    head = [
        "# The study's verdicts judged from this reproduction's runs",
        "",
        "Made by `python -m analysis.reproduce`: `analysis.study`'s rules on the runs in "
        "`runs/` only (no shipped run stands in), beside the verdicts of the shipped runs "
        f"(`{shipped}`). A rule needs 5 seeds: with fewer its verdict is inconclusive and "
        "says which runs are missing.",
        "",
    ]
    with open(os.path.join(out, "verdicts.md"), "w", encoding="utf-8") as f:
        f.write("\n".join(head + lines[:2] + table + tallies) + "\n")
    return lines + tallies


def recorded_time(results: str = "results") -> str:
    """The study's full evidence's run time as its shipped run files record it (each run's
    `wall_s`: the CEM grid and the shipped K = 50 runs, the NAC runs, the sweep's included,
    the crawler's runs); one line."""

    def hours(pattern: str) -> tuple[float, int]:
        found = glob.glob(os.path.join(results, pattern))
        total = 0.0
        for path in found:
            with open(path, encoding="utf-8") as f:
                total += float(json.load(f).get("wall_s", 0.0))
        return total / 3600, len(found)

    cem, n_cem = hours(os.path.join("study", "runs", "cem", "darwin_walk", "*", "summary.json"))
    k50, n_k50 = hours(
        os.path.join(
            "protocol", "runs", "cem", "darwin_walk", "K50_n0.8_e2_v1_seed*", "summary.json"
        )
    )
    nac, n_nac = hours(os.path.join("study", "nac", "nac", "*", "*", "summary.json"))
    crawler = os.path.join(results, "study", "crawler", "crawler_realtime.csv")
    with open(crawler, encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    crawler_h = sum(float(r.get("wall_s") or 0.0) for r in rows) / 3600
    total = cem + k50 + nac + crawler_h
    return (
        f"the study's full evidence took {total:.2f} h of run time by its run files: CEM grid "
        f"{cem:.2f} h ({n_cem} runs) + the shipped K = 50 {k50:.2f} h ({n_k50}), NAC "
        f"{nac:.2f} h ({n_nac} runs, the sweep's included), crawler {crawler_h * 60:.1f} min "
        f"({len(rows)} runs); one thread a run (the CEM grid two runs at a time on 2 cores); "
        "the pole runs and the computed evidence record none (minutes each)"
    )


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
    evidence = evidence_of(out, runs)
    steps = experiment_steps(plan, runs, settings.threads, backend, evidence)
    cpu = _cpu_of_children()
    _run_steps(steps, os.path.join(out, "reproduce.log"), log)
    log(leaderboard.write_tables(runs, os.path.join(out, "leaderboard.csv")))
    log(report.write_report(runs, out, gaits=settings.render_gaits))
    for line in judge(out, runs, evidence):
        log(line)
    log(recorded_time())
    used = time.perf_counter() - start
    return (
        f"done in {used / 60:.1f} min ({(_cpu_of_children() - cpu) / 60:.1f} min of CPU in "
        f"its experiments): {out}/report.md, the verdicts {out}/verdicts.md"
    )


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    flags.DEFINE_bool("quick", False, "Small versions of every experiment (minutes).")
    flags.DEFINE_bool("full", False, "The real experiments (hours); give one of --quick, --full.")
    flags.DEFINE_string("out", None, "none: required. Output folder.")
    flags.DEFINE_integer("threads", 2, "Evaluator threads of CEM/CMA-ES.")
    flags.DEFINE_enum(
        "backend",
        "local",
        list(cli.BACKENDS),
        "ray: the runs of the CEM grid, the pole and NAC sweeps as Ray tasks, CMA-ES's "
        "trials on Ray actors (same results).",
    )
    flags.DEFINE_string(
        "ray_address",
        None,
        "none: a private local Ray instance per step. Ray cluster: host:port, or auto.",
    )
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
