r"""The study's NAC finding (thesis Sec. 5.5, claims NAC-*) and the reward-hypothesis test.

  python -m baselines.experiments.nac_experiments --output_dir=runs/nac --seeds=5 [--steps=20000]
  python -m baselines.experiments.nac_experiments --output_dir=runs/nac --sweep --resume
  python -m baselines.experiments.nac_experiments --output_dir=runs/nac --scaled

Three configurations of `baselines.nac`, `--seeds` seeds each:
  * `nofix`: no basis normalisation, no ridge (the study's first attempt: θ blew up);
  * `fixes`: normalisation by the running std and ridge δ = 0.01 (the study: stable-ish,
    but no improvement of the COP reward over the CPG alone);
  * `walk`: the fixed algorithm with a reward that can show improvement, forward distance
    per step on `darwin_walk` (the study suspected its COP reward, hypothesis 2b).
Writes `nac_experiments.md` with the mean reward per step before (θ = 0, CPG alone) and
after learning, the paired difference with a 95 % t-interval, max |θ| and divergences.
`--scaled` evaluates the fixes runs' θ scaled by 1-50 (claims NAC-4b, NAC-5, NAC-6;
`nac_scaled.json`). `--sweep` runs nofix and fixes at every point of α ∈ {1, 10, 100}
× ε_A ∈ {1e-6, 1e-2} instead (claims NAC-1, NAC-2a, NAC-7; `nac_sweep.md`). `--resume`
reuses finished runs.
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
from cpg_suite import cli, cpg, progress
from cpg_suite.protocol.stats import mean_std_ci95
from cpg_suite.runfiles import runs


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    flags.DEFINE_string("output_dir", "runs", "Root of the output tree.")
    flags.DEFINE_integer("seeds", 5, "Seeds per configuration.")
    flags.DEFINE_integer("steps", 20000, "Learning steps (16 ms each).")
    flags.DEFINE_integer("eval_seeds", 5, "Evaluation initial states (100..100+N-1).")
    flags.DEFINE_bool("resume", False, "Reuse runs that already have a summary.json.")
    flags.DEFINE_bool(
        "scaled", False, "Evaluate the fixes runs' learned θ scaled by SCALES instead."
    )
    flags.DEFINE_bool(
        "sweep", False, "Run the step-size sweep (nofix and fixes at every SWEEP point) instead."
    )
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
# The sensitivity sweep (claims NAC-1, NAC-2a, NAC-7): the thesis gives neither the actor's
# step size α nor A's initial value ε_A·I, so each pair of α ∈ {1, 10, 100} and
# ε_A ∈ {1e-6, 1e-2} is run, the other values as BASE. BASE's own point is the plain runs.
SWEEP = tuple((alpha, eps_a) for alpha in (1.0, 10.0, 100.0) for eps_a in (1e-6, 1e-2))
SWEPT = ("nofix", "fixes")


def point_name(name: str, alpha: float, eps_a: float) -> str:
    """The run-name stem of configuration `name` at sweep point (α, ε_A): the plain name
    at BASE's point, else e.g. `nofix_alpha10_epsA0.01`."""
    if (alpha, eps_a) == (BASE["alpha"], BASE["eps_a"]):
        return name
    return f"{name}_alpha{alpha:g}_epsA{eps_a:g}"


@dataclasses.dataclass(frozen=True)
class NACExperimentSettings:
    """The NAC experiments (flags of `python -m baselines.experiments.nac_experiments`).

    Attributes:
      output_dir: Root of the output tree (runs under `nac/`, the table beside it).
      seeds: Seeds per configuration (0..N-1; ≥ 2 for an interval).
      steps: Learning steps per run.
      eval_seeds: Evaluation initial states per run (100..100+N-1).
      resume: Reuse runs that already have a summary.json.
      sweep: Run `SWEEP` (nofix and fixes at each point) instead of `CONFIGS`' runs.
      scaled: Evaluate the finished fixes runs' θ scaled (`scaled_evidence`) instead.
      backend: "local" (one run after another) or "ray" (every run a Ray task).
      ray_address: The Ray cluster for backend "ray" (host:port, "auto", or None).
    """

    output_dir: str = "runs"
    seeds: int = 5
    steps: int = 20000
    eval_seeds: int = 5
    resume: bool = False
    sweep: bool = False
    scaled: bool = False
    backend: str = "local"
    ray_address: str | None = None

    def __post_init__(self):
        cli.require(self.seeds >= 2, f"--seeds must be ≥ 2, got {self.seeds}")
        cli.require(self.steps >= 100, f"--steps must be ≥ 100, got {self.steps}")
        cli.require(self.eval_seeds >= 1, f"--eval_seeds must be ≥ 1, got {self.eval_seeds}")
        cli.require_backend(self.backend, self.ray_address)
        cli.require(not (self.sweep and self.scaled), "--sweep and --scaled exclude each other")


def ci95(values) -> tuple[float, float, float]:
    """Mean and the 95 % t-interval of the mean."""
    mean, _, low, high = mean_std_ci95(values)
    return mean, low, high


def run_settings(
    name: str, seed: int, settings: NACExperimentSettings, point: tuple[float, float] | None = None
) -> nac.NACSettings:
    """The settings of one NAC run: configuration `name`, seed `seed`, at sweep point
    `point` = (α, ε_A) (None: BASE's).

    Raises:
      KeyError: If `name` is not one of `CONFIGS`.
    """
    alpha, eps_a = point or (BASE["alpha"], BASE["eps_a"])
    return nac.NACSettings(
        **{**BASE, "alpha": alpha, "eps_a": eps_a},
        **CONFIGS[name],
        steps=settings.steps,
        eval_seeds=settings.eval_seeds,
        seed=seed,
        output_dir=settings.output_dir,
        run_name=f"{point_name(name, alpha, eps_a)}_seed{seed}",
    )


def run_one(
    name: str, seed: int, settings: NACExperimentSettings, point: tuple[float, float] | None = None
) -> dict:
    """Runs (or, with `settings.resume`, reuses) one NAC run; returns its summary.

    Raises:
      runs.RunDirectoryExists: If the run exists and `resume` is off.
    """
    run = run_settings(name, seed, settings, point)
    path = os.path.join(run.output_dir, "nac", run.task, run.run_name, "summary.json")
    if settings.resume and os.path.exists(path):
        return runs.read_json(path)
    _, summary = nac.run_nac(run, log=lambda line: None)
    progress.write(
        f"{run.run_name}: before {summary['reward_before']:+.5f} after "
        f"{summary['reward_after']} max|θ| {summary['theta_norm_max']:.3g} "
        f"diverged {summary['diverged']}"
    )
    return summary


Job = tuple[str, int, "tuple[float, float] | None"]  # configuration, seed, sweep point


def _run_on_ray(jobs: list[Job], settings: NACExperimentSettings) -> list[dict]:
    """Every run a Ray task. The driver checks the run directories first (one that holds
    files is an error unless it is a finished run and `resume` is on); a task redoes its
    unfinished run, so one that runs again after its worker died starts clean.

    Raises:
      runs.RunDirectoryExists: As `run_one`.
    """
    from cpg_suite.evaluation import ray_backend
    from cpg_suite.harness import ray_tasks

    with ray_backend.connected("ray", settings.ray_address):
        for name, seed, point in jobs:
            run = run_settings(name, seed, settings, point)
            path = os.path.join(run.output_dir, "nac", run.task, run.run_name)
            finished = os.path.exists(os.path.join(path, "summary.json"))
            if os.path.isdir(path) and os.listdir(path) and not (settings.resume and finished):
                raise runs.RunDirectoryExists(f"run directory {path} already exists")
        settings = ray_tasks.importable_settings(settings)
        task = ray_tasks.importable(_run_task)
        return ray_tasks.map_tasks(task, [(*job, settings) for job in jobs])


def _run_task(job: tuple[str, int, tuple[float, float] | None, NACExperimentSettings]) -> dict:
    name, seed, point, settings = job
    run = run_settings(name, seed, settings, point)
    path = os.path.join(run.output_dir, "nac", run.task, run.run_name, "summary.json")
    if os.path.exists(path):
        return runs.read_json(path)
    return nac.run_nac(dataclasses.replace(run, overwrite=True), log=lambda line: None)[1]


def table_row(label: str, task: str, summaries: list[dict]) -> str:
    """The markdown row of a configuration: rewards before/after, Δ with its interval."""
    before = [s["reward_before"] for s in summaries]
    finished = [s for s in summaries if s["reward_after"] is not None]
    after = [s["reward_after"] for s in finished]
    delta = [s["reward_after"] - s["reward_before"] for s in finished]
    b, a = ci95(before), ci95(after) if after else (float("nan"),) * 3
    d = ci95(delta) if delta else (float("nan"),) * 3
    return (
        f"| {label} | {task} | {b[0]:+.5f} | {a[0]:+.5f} | {d[0]:+.5f} "
        f"({d[1]:+.5f}, {d[2]:+.5f}) | "
        f"{np.median([s['theta_norm_max'] for s in summaries]):.3g} | "
        f"{sum(s['diverged'] for s in summaries)}/{len(summaries)} | "
        f"{np.mean([s['actor_updates'] for s in summaries]):.0f} |"
    )


def _header(settings: NACExperimentSettings) -> list[str]:
    title = (
        "the step-size sweep" if settings.sweep else "the study's finding and the reward hypothesis"
    )
    return [
        f"# NAC on the DMP term: {title}",
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


def experiment_jobs(settings: NACExperimentSettings) -> list[Job]:
    """The runs of `settings`: each of `CONFIGS` at BASE's point, or with `sweep` nofix at
    every `SWEEP` point and then fixes at every point (the divergence claim's runs first)."""
    if not settings.sweep:
        return [(name, seed, None) for name in CONFIGS for seed in range(settings.seeds)]
    return [
        (name, seed, point) for name in SWEPT for point in SWEEP for seed in range(settings.seeds)
    ]


def run_experiments(settings: NACExperimentSettings) -> list[str]:
    """Runs (or reuses) every configuration's runs; writes and returns the markdown table.

    Writes `<output_dir>/nac_experiments.md` (`nac_sweep.md` with `sweep`); the runs go to
    `<output_dir>/nac/<task>/`.

    Args:
      settings: Seeds per configuration, learning steps, evaluation states, resume, sweep.

    Returns:
      The lines of the markdown table.

    Raises:
      runs.RunDirectoryExists: If a run exists and `resume` is off.
    """
    jobs = experiment_jobs(settings)
    if settings.backend == "local":
        done = [run_one(n, s, settings, p) for n, s, p in progress.track(jobs, desc="NAC runs")]
    else:
        done = _run_on_ray(jobs, settings)
    groups: dict[tuple[str, str], list[dict]] = {}
    for (name, seed, point), summary in zip(jobs, done):
        stem = run_settings(name, seed, settings, point).run_name.rsplit("_seed", 1)[0]
        groups.setdefault((stem, CONFIGS[name]["task"]), []).append(summary)
    rows = [table_row(stem, task, summaries) for (stem, task), summaries in groups.items()]
    lines = _header(settings) + rows + [""]
    os.makedirs(settings.output_dir, exist_ok=True)
    name = "nac_sweep.md" if settings.sweep else "nac_experiments.md"
    runs.write_text(os.path.join(settings.output_dir, name), "\n".join(lines) + "\n")
    return lines


# Claims NAC-4b, NAC-5 and NAC-6: the learned θ of each fixes run (at each α of the
# sweep) scaled by c, its gait judged by the COP reward and falls, and how far it moves
# the left hip-roll rate.
SCALES = (1.0, 2.0, 5.0, 10.0, 20.0, 50.0)
PER_CYCLE = 200  # phases a cycle at which the hip-roll rates are compared


def hip_roll_change(theta: np.ndarray) -> float:
    """How far θ moves the left hip-roll rate: the RMS over one cycle of the DMP term
    F(φ_L) (the only change to that rate, Eq. 5.21) over the RMS of the CPG's own left
    hip-roll rate (the hand-tuned gait, after its start-up ramp). Linear in θ."""
    config = cpg.CPGConfig()
    left = config.initial_phase + np.linspace(0.0, 2 * np.pi, PER_CYCLE, endpoint=False)
    phases = np.stack([left, left - np.pi], axis=-1)
    amplitudes = np.asarray(cpg.PRESETS["hand_tuned"], dtype=np.float64)[None]
    values = cpg.primitive_values(phases, config.omega, config)
    own = cpg.combine(amplitudes, values)[:, cpg.HROLL]
    term = np.array([nac.dmp_policy(theta, p, 0.0)[0][0] for p in phases])
    return float(np.sqrt(np.mean(term**2)) / np.sqrt(np.mean(own**2)))


def scaled_evidence(settings: NACExperimentSettings) -> dict:
    """The fixes runs' θ scaled by each of `SCALES`, evaluated as `nac.evaluate_policy` does
    after learning (its initial states, its fall penalty), beside θ = 0, at each step size
    α of the sweep (ε_A as BASE's): the thesis gives no α, and how far θ moves the gait
    depends on it.

    Writes `<output_dir>/nac_scaled.json`.

    Returns:
      {"scales", "theta_zero": evaluation, "points": [{alpha, eps_a, "runs": [{seed,
      hip_roll_change, learned_falls, "scaled": [{c, **evaluation}]}]}]}, an evaluation
      being {reward_per_step, task_reward_per_step, falls}.

    Raises:
      FileNotFoundError: If a fixes run has no theta.json.
    """
    base = run_settings("fixes", 0, settings)
    seeds, penalty = base.evaluation_seeds(), base.fall_penalty

    def evaluate(theta):
        found = nac.evaluate_policy(base.task, theta, seeds, fall_penalty=penalty)
        keys = ("reward_per_step", "task_reward_per_step", "falls")
        return {k: found[k] for k in keys}

    out = {"scales": list(SCALES), "theta_zero": evaluate(np.zeros(cpg.N_KERNELS)), "points": []}
    points = [(alpha, BASE["eps_a"]) for alpha in sorted({a for a, _ in SWEEP})]
    jobs = [(point, seed) for point in points for seed in range(settings.seeds)]
    found: dict = {}
    for point, seed in progress.track(jobs, desc="scaled θ", unit="run"):
        run = run_settings("fixes", seed, settings, point)
        folder = os.path.join(run.output_dir, "nac", run.task, run.run_name)
        theta = np.asarray(runs.read_json(os.path.join(folder, "theta.json"))["theta"])
        learned = runs.read_json(os.path.join(folder, "summary.json"))
        found.setdefault(point, []).append(
            {
                "seed": seed,
                "hip_roll_change": hip_roll_change(theta),
                "learned_falls": learned["falls_after"],
                "scaled": [{"c": c, **evaluate(c * theta)} for c in SCALES],
            }
        )
    for (alpha, eps_a), done in found.items():
        out["points"].append({"alpha": alpha, "eps_a": eps_a, "runs": done})
    runs.write_json(os.path.join(settings.output_dir, "nac_scaled.json"), out)
    return out


def main(argv):
    del argv
    settings = cli.settings_from_flags(NACExperimentSettings)
    if settings.scaled:
        found = scaled_evidence(settings)
        count = sum(len(p["runs"]) for p in found["points"])
        print(f"θ scaled by {SCALES} in {count} runs -> nac_scaled.json")
        return
    try:
        lines = run_experiments(settings)
    except runs.RunDirectoryExists as e:
        raise cli.UsageError(f"{e}; pass --resume to reuse finished runs") from None
    print("\n".join(lines))


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_dirs=("output_dir",))
