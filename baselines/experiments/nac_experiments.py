r"""The study's NAC finding (thesis Sec. 5.5, claims NAC-*) and the reward-hypothesis test.

  python -m baselines.experiments.nac_experiments --output_dir=runs/nac --seeds=5 [--steps=20000]

Three configurations of `baselines.nac`, `--seeds` seeds each:
  * `nofix`: no basis normalisation, no ridge (the study's first attempt: θ blew up);
  * `fixes`: normalisation by the running std and ridge δ = 0.01 (the study: stable-ish,
    but no improvement of the COP reward over the CPG alone);
  * `walk`: the fixed algorithm with a reward that can show improvement, forward distance
    per step on `darwin_walk` (the study suspected its COP reward, hypothesis 2b).
Writes `nac_experiments.md` with the mean reward per step before (θ = 0, CPG alone) and
after learning, the paired difference with a 95 % t-interval, max |θ| and divergences.
`--resume` reuses finished runs.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import os

import numpy as np
from absl import flags

from baselines import nac
from cpg_suite import cli, progress
from cpg_suite.harness import runs
from cpg_suite.protocol.stats import mean_std_ci95


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    flags.DEFINE_string("output_dir", "runs", "Root of the output tree.")
    flags.DEFINE_integer("seeds", 5, "Seeds per configuration.")
    flags.DEFINE_integer("steps", 20000, "Learning steps (16 ms each).")
    flags.DEFINE_integer("eval_seeds", 5, "Evaluation initial states (100..100+N-1).")
    flags.DEFINE_bool("resume", False, "Reuse runs that already have a summary.json.")
    cli.define_backend_flags()


CONFIGS = {
    "nofix": {"task": "darwin_balance", "normalize": False, "ridge": 0.0},
    "fixes": {"task": "darwin_balance", "normalize": True, "ridge": 1e-2},
    "walk": {"task": "darwin_walk", "normalize": True, "ridge": 1e-2},
}
BASE = {
    "alpha": 100.0,
    "beta": 0.9,
    "gamma": 0.95,
    "lam": 0.8,
    "sigma": 5.0,
    "constant_rule": "one",
    "eps_a": 1e-6,
    "accuracy_angle": 10.0,
    "check_every": 50,
    "fall_penalty": 1.0,
    "overwrite": False,
}


@dataclasses.dataclass(frozen=True)
class NACExperimentSettings:
    """The NAC experiments (flags of `python -m baselines.experiments.nac_experiments`).

    Attributes:
      output_dir: Root of the output tree (runs under `nac/`, the table beside it).
      seeds: Seeds per configuration (0..N-1; ≥ 2 for an interval).
      steps: Learning steps per run.
      eval_seeds: Evaluation initial states per run (100..100+N-1).
      resume: Reuse runs that already have a summary.json.
      backend: "local" (one run after another) or "ray" (every run a Ray task).
      ray_address: The Ray cluster for backend "ray" (host:port, "auto", or None).
    """

    output_dir: str = "runs"
    seeds: int = 5
    steps: int = 20000
    eval_seeds: int = 5
    resume: bool = False
    backend: str = "local"
    ray_address: str | None = None

    def __post_init__(self):
        cli.require(self.seeds >= 2, f"--seeds must be ≥ 2, got {self.seeds}")
        cli.require(self.steps >= 100, f"--steps must be ≥ 100, got {self.steps}")
        cli.require(self.eval_seeds >= 1, f"--eval_seeds must be ≥ 1, got {self.eval_seeds}")
        cli.require_backend(self.backend, self.ray_address)


def ci95(values) -> tuple[float, float, float]:
    """Mean and the 95 % t-interval of the mean."""
    mean, _, low, high = mean_std_ci95(values)
    return mean, low, high


def run_settings(name: str, seed: int, settings: NACExperimentSettings) -> nac.NACSettings:
    """The settings of one NAC run: configuration `name`, seed `seed`.

    Raises:
      KeyError: If `name` is not one of `CONFIGS`.
    """
    return nac.NACSettings(
        **BASE,
        **CONFIGS[name],
        steps=settings.steps,
        eval_seeds=settings.eval_seeds,
        seed=seed,
        output_dir=settings.output_dir,
        run_name=f"{name}_seed{seed}",
    )


def run_one(name: str, seed: int, settings: NACExperimentSettings) -> dict:
    """Runs (or, with `settings.resume`, reuses) one NAC run; returns its summary.

    Raises:
      runs.RunDirectoryExists: If the run exists and `resume` is off.
    """
    run = run_settings(name, seed, settings)
    path = os.path.join(run.output_dir, "nac", run.task, run.run_name, "summary.json")
    if settings.resume and os.path.exists(path):
        return runs.read_json(path)
    _, summary = nac.run_nac(run, log=lambda line: None)
    progress.write(
        f"{name} seed {seed}: before {summary['reward_before']:+.5f} after "
        f"{summary['reward_after']} max|θ| {summary['theta_norm_max']:.3g} "
        f"diverged {summary['diverged']}"
    )
    return summary


def _run_on_ray(jobs: list[tuple[str, int]], settings: NACExperimentSettings) -> list[dict]:
    """Every run a Ray task. The driver checks the run directories first (one that holds
    files is an error unless it is a finished run and `resume` is on); a task redoes its
    unfinished run, so one that runs again after its worker died starts clean.

    Raises:
      runs.RunDirectoryExists: As `run_one`.
    """
    from cpg_suite.evaluation import ray_backend
    from cpg_suite.harness import ray_tasks

    with ray_backend.connected("ray", settings.ray_address):
        for name, seed in jobs:
            run = run_settings(name, seed, settings)
            path = os.path.join(run.output_dir, "nac", run.task, run.run_name)
            finished = os.path.exists(os.path.join(path, "summary.json"))
            if os.path.isdir(path) and os.listdir(path) and not (settings.resume and finished):
                raise runs.RunDirectoryExists(f"run directory {path} already exists")
        settings = ray_tasks.importable_settings(settings)
        task = ray_tasks.importable(_run_task)
        return ray_tasks.map_tasks(task, [(n, s, settings) for n, s in jobs])


def _run_task(job: tuple[str, int, NACExperimentSettings]) -> dict:
    name, seed, settings = job
    run = run_settings(name, seed, settings)
    path = os.path.join(run.output_dir, "nac", run.task, run.run_name, "summary.json")
    if os.path.exists(path):
        return runs.read_json(path)
    return nac.run_nac(dataclasses.replace(run, overwrite=True), log=lambda line: None)[1]


def table_row(name: str, summaries: list[dict]) -> str:
    """The markdown row of a configuration: rewards before/after, Δ with its interval."""
    before = [s["reward_before"] for s in summaries]
    finished = [s for s in summaries if s["reward_after"] is not None]
    after = [s["reward_after"] for s in finished]
    delta = [s["reward_after"] - s["reward_before"] for s in finished]
    b, a = ci95(before), ci95(after) if after else (float("nan"),) * 3
    d = ci95(delta) if delta else (float("nan"),) * 3
    return (
        f"| {name} | {CONFIGS[name]['task']} | {b[0]:+.5f} | {a[0]:+.5f} | {d[0]:+.5f} "
        f"({d[1]:+.5f}, {d[2]:+.5f}) | "
        f"{np.median([s['theta_norm_max'] for s in summaries]):.3g} | "
        f"{sum(s['diverged'] for s in summaries)}/{len(summaries)} | "
        f"{np.mean([s['actor_updates'] for s in summaries]):.0f} |"
    )


def _header(settings: NACExperimentSettings) -> list[str]:
    return [
        "# NAC on the DMP term: the study's finding and the reward hypothesis",
        "",
        f"{settings.steps} learning steps per run; rewards are per control step, evaluated "
        f"with u = F over {settings.eval_seeds} initial states (seeds 100 on); "
        "Δ = after − before, paired "
        "by run, 95 % t-interval over seeds.",
        "",
        "| configuration | task | reward before | reward after | Δ (95 % CI) | "
        "max |θ| (median) | diverged | actor updates (mean) |",
        "|---|---|---|---|---|---|---|---|",
    ]


def run_experiments(settings: NACExperimentSettings) -> list[str]:
    """Runs (or reuses) every configuration's runs; writes and returns the markdown table.

    Writes `<output_dir>/nac_experiments.md`; the runs go to `<output_dir>/nac/<task>/`.

    Args:
      settings: Seeds per configuration, learning steps, evaluation states, resume.

    Returns:
      The lines of the markdown table.

    Raises:
      runs.RunDirectoryExists: If a run exists and `resume` is off.
    """
    jobs = [(name, seed) for name in CONFIGS for seed in range(settings.seeds)]
    summaries: dict[str, list[dict]] = {name: [] for name in CONFIGS}
    if settings.backend == "local":
        done = [run_one(n, s, settings) for n, s in progress.track(jobs, desc="NAC runs")]
    else:
        done = _run_on_ray(jobs, settings)
    for (name, _), summary in zip(jobs, done):
        summaries[name].append(summary)
    lines = _header(settings) + [table_row(name, summaries[name]) for name in CONFIGS] + [""]
    os.makedirs(settings.output_dir, exist_ok=True)
    path = os.path.join(settings.output_dir, "nac_experiments.md")
    runs.write_text(path, "\n".join(lines) + "\n")
    return lines


def main(argv):
    del argv
    settings = cli.settings_from_flags(NACExperimentSettings)
    try:
        lines = run_experiments(settings)
    except runs.RunDirectoryExists as e:
        raise cli.UsageError(f"{e}; pass --resume to reuse finished runs") from None
    print("\n".join(lines))


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_dirs=("output_dir",))
