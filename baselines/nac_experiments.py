r"""The study's NAC finding (thesis Sec. 5.5, claims NAC-*) and the reward-hypothesis test.

  python -m baselines.nac_experiments --output_dir=runs/nac --seeds=5 [--steps=20000]

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

import dataclasses
import os

import numpy as np
from absl import flags

from baselines import cli, nac, progress, runs
from baselines.stats import mean_std_ci95


# --output_dir and --steps are `baselines.nac`'s flags (imported above), shared here.
def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    nac.define_flags()  # --output_dir, --steps, --eval_seeds and NAC's other flags.
    flags.DEFINE_integer("seeds", 5, "Seeds per configuration.")
    flags.DEFINE_bool("resume", False, "Reuse runs that already have a summary.json.")


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


def ci95(values) -> tuple[float, float, float]:
    """Mean and the 95 % t-interval of the mean."""
    mean, _, low, high = mean_std_ci95(values)
    return mean, low, high


def run_configuration(
    name: str, seeds: int, steps: int, eval_seeds: int, output_dir: str, resume: bool
) -> list[dict]:
    """Runs (or, with `resume`, reuses) one configuration's NAC runs; returns summaries.

    Raises:
      runs.RunDirectoryExists: If a run exists and `resume` is off.
    """
    config, summaries = CONFIGS[name], []
    for seed in progress.track(range(seeds), desc=name, unit="run"):
        settings = {
            **BASE,
            **config,
            "steps": steps,
            "eval_seeds": eval_seeds,
            "seed": seed,
            "output_dir": output_dir,
            "run_name": f"{name}_seed{seed}",
        }
        path = os.path.join(output_dir, "nac", config["task"], settings["run_name"])
        if resume and os.path.exists(os.path.join(path, "summary.json")):
            summaries.append(runs.read_json(os.path.join(path, "summary.json")))
            continue
        _, summary = nac.run_nac(settings, log=lambda line: None)
        summaries.append(summary)
        progress.write(
            f"{name} seed {seed}: before {summary['reward_before']:+.5f} after "
            f"{summary['reward_after']} max|θ| {summary['theta_norm_max']:.3g} "
            f"diverged {summary['diverged']}"
        )
    return summaries


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


@dataclasses.dataclass(frozen=True)
class NACExperimentSettings:
    """The NAC experiments: seeds per configuration, learning steps, evaluation states."""

    output_dir: str = "runs"
    seeds: int = 5
    steps: int = 20000
    eval_seeds: int = 5
    resume: bool = False

    def __post_init__(self):
        cli.require(self.seeds >= 2, f"--seeds must be ≥ 2, got {self.seeds}")
        cli.require(self.steps >= 100, f"--steps must be ≥ 100, got {self.steps}")
        cli.require(self.eval_seeds >= 1, f"--eval_seeds must be ≥ 1, got {self.eval_seeds}")


def run_experiments(settings: NACExperimentSettings) -> list[str]:
    """Runs (or reuses) every configuration's runs; writes and returns the markdown table.

    Raises:
      runs.RunDirectoryExists: If a run exists and `resume` is off.
    """
    s = settings
    lines = [
        "# NAC on the DMP term: the study's finding and the reward hypothesis",
        "",
        f"{s.steps} learning steps per run; rewards are per control step, evaluated "
        f"with u = F over {s.eval_seeds} initial states (seeds 100 on); "
        "Δ = after − before, paired "
        "by run, 95 % t-interval over seeds.",
        "",
        "| configuration | task | reward before | reward after | Δ (95 % CI) | "
        "max |θ| (median) | diverged | actor updates (mean) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name in CONFIGS:
        summaries = run_configuration(name, s.seeds, s.steps, s.eval_seeds, s.output_dir, s.resume)
        lines.append(table_row(name, summaries))
    lines.append("")
    os.makedirs(s.output_dir, exist_ok=True)
    runs.write_text(os.path.join(s.output_dir, "nac_experiments.md"), "\n".join(lines) + "\n")
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
    cli.run(main)
