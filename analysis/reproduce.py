r"""Reproduce the study's experiments in one command, then the leaderboard, claims and report.

  python -m analysis.reproduce --quick --out=DIR     # every experiment, small (minutes)
  python -m analysis.reproduce --full --out=DIR      # the real thing (hours on 2 cores)

Runs, as separate processes, into `DIR/runs/`:
  1. value iteration on the Tokic model (thesis Tables A.2/A.3, CR-1);
  2. the pole-balancing claims experiment (`baselines.pole_claims`);
  3. the crawler experiments (`baselines.crawler_experiments`);
  4. the CEM settings of thesis Table 6.3 (`baselines.cem --grid=table6_3`), 5 seeds for
     K = 50 in `--full`;
  5. CMA-ES at the K = 50 budget (`baselines.cmaes`);
  6. the NAC finding and reward-hypothesis test (`baselines.nac_experiments`);
then `analysis.leaderboard` and `analysis.report` into `DIR/` (with the rendered gaits in
`--full`, or with `--gaits`). Every step resumes
finished runs, so an interrupted `--full` continues where it stopped when run again.
`--quick` shrinks seeds, rounds, trial lengths and learning steps; its numbers show that
everything runs and how the outputs look, not the benchmark's results.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

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


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    size = parser.add_mutually_exclusive_group(required=True)
    size.add_argument("--quick", action="store_true", help="small versions (minutes)")
    size.add_argument("--full", action="store_true", help="the real experiments (hours)")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--threads", type=int, default=2, help="evaluator threads of CEM/CMA-ES")
    parser.add_argument(
        "--backend",
        choices=["local", "ray"],
        default="local",
        help="ray: the runs of the CEM grid, the pole and NAC sweeps as Ray tasks, CMA-ES's "
        "trials on Ray actors (same results)",
    )
    parser.add_argument("--ray_address", default=None, help="Ray cluster: host:port, or auto")
    parser.add_argument(
        "--gaits",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="render the hand-tuned and best gaits (default: with --full)",
    )
    return parser


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
    steps = [
        (
            "tokic value iteration",
            ["baselines.tabular", "--model=tokic", "--algo=value_iteration"]
            + [f"--output_dir={runs}", "--overwrite"],
        ),
        (
            "pole claims",
            ["baselines.pole_claims", f"--output_dir={runs}/pole", "--resume", *backend],
        ),
        (
            "crawler experiments",
            ["baselines.crawler_experiments", f"--output_dir={runs}/crawler", "--resume"],
        ),
        ("CEM, thesis Table 6.3", ["baselines.cem", "--grid=table6_3", *optimizer]),
    ]
    steps[1][1].extend(plan["pole"])
    steps[2][1].extend(plan["crawler"])
    steps[3][1].extend(plan["cem"])
    if plan["cem_k50"]:
        steps.append(("CEM, K = 50 seeds", ["baselines.cem", "--grid=table6_3", *optimizer]))
        steps[-1][1].extend(plan["cem_k50"])
    for extra in plan["cmaes"]:
        steps.append(("CMA-ES", ["baselines.cmaes", *optimizer, *extra]))
    nac = ["baselines.nac_experiments", f"--output_dir={runs}/nac", "--resume", *backend]
    nac += plan["nac"]
    steps.append(("NAC", nac))
    return steps


def _run_steps(steps: list, log_path: str) -> bool:
    """Runs the steps as separate processes, logging their output; False on a failure."""
    start = time.perf_counter()
    with open(log_path, "a", encoding="utf-8") as log:
        for i, (title, command) in enumerate(steps, 1):
            elapsed = time.perf_counter() - start
            eta = f", about {elapsed / (i - 1) * (len(steps) - i + 1):.0f} s left" if i > 1 else ""
            print(f"[{i}/{len(steps)}] {title} ({elapsed:.0f} s elapsed{eta})", flush=True)
            try:
                _run(command, log)
            except RuntimeError as e:
                print(f"error: {e} ({log_path})", file=sys.stderr)
                return False
    return True


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    if args.threads < 1:
        print(f"error: --threads must be ≥ 1, got {args.threads}", file=sys.stderr)
        return 2
    plan = QUICK if args.quick else FULL
    runs = os.path.join(args.out, "runs")
    os.makedirs(runs, exist_ok=True)
    start = time.perf_counter()
    backend = [f"--backend={args.backend}"]
    if args.ray_address:
        backend.append(f"--ray_address={args.ray_address}")
    steps = experiment_steps(plan, runs, args.threads, backend)
    if not _run_steps(steps, os.path.join(args.out, "reproduce.log")):
        return 1
    from analysis import leaderboard, report

    leaderboard.main(["--runs", runs, "--out", os.path.join(args.out, "leaderboard.csv")])
    gaits = args.full if args.gaits is None else args.gaits
    code = report.main(["--runs", runs, "--out", args.out] + (["--gaits"] if gaits else []))
    print(f"done in {time.perf_counter() - start:.0f} s: {args.out}/report.md")
    return code


if __name__ == "__main__":
    sys.exit(main())
