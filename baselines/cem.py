r"""Cross-Entropy Method on the 11 CPG amplitudes, as the study ran it (thesis Alg. 6.1).

  python -m baselines.cem --task=darwin_walk                      # K 50, elite 2, noise 0.8
  python -m baselines.cem --grid=table6_3 --seeds=3               # every Table 6.3 setting

Algorithm 6.1 (after Stulp & Sigaud 2012), one round:

  1. Sample    θ₁ = θ (the current mean, "for evaluation", thesis 6.2);
               θₖ ~ N(θ, Σ), k = 2..K
  2. Evaluate  one trial of 1000 control steps per θₖ (per initial state):
               cost = −distance + fall penalty · [fell] + lateral penalty · |lateral|
  3. Select    sort by cost; the `elite` cheapest form E (the mean sample may be one)
  4. Update    θ ← Σ_{E} θₖ / elite                                  (uniform weights)
               Σ ← Σ_{E} (θₖ − θ)(θₖ − θ)ᵀ / elite + noise · I        (Fig. 6.1 stage 5)

Start: θ = the hand-tuned amplitudes (Table 6.1), Σ = I (degrees²). The covariance is taken
about the new mean with weights 1/elite, so that with elite = 1 and no noise it collapses
to 0, as the thesis says; noise is a variance added to the diagonal every round.
The best vector of the run and the final mean (evaluated once at the end: the algorithm
never tests a mean before adopting it, thesis Sec. 6.3) are both reported.

Run directory `<output_dir>/cem/<task>/<run_name>/` (DESIGN Sec. 6): config.json,
progress.csv (a row per round), checkpoint.json (atomic, every round; `--resume`
continues bit-identically), best_params.json, mean_params.json, summary.json.
"""

from __future__ import annotations

import os
import time

import numpy as np
from absl import flags

from baselines import cli, runs
from baselines.batch_eval import BatchEvaluator
from baselines.optimize import CheckpointError, run_rounds
from cpg_suite import cpg

TASKS = ("darwin_walk",)

_TASK = flags.DEFINE_string("task", "darwin_walk", f"Task: {', '.join(TASKS)}.")
_POPULATION = flags.DEFINE_integer("population", 50, "Samples per round K (the study: 10-50).")
_ELITE = flags.DEFINE_integer("elite", 2, "Elite samples kept per round.")
_NOISE = flags.DEFINE_float("noise", 0.8, "Variance added to the covariance diagonal, deg².")
_ROUNDS = flags.DEFINE_integer("rounds", 50, "Rounds.")
_SEED = flags.DEFINE_integer("seed", 0, "Sampling seed.")
_TRIAL_STEPS = flags.DEFINE_integer(
    "trial_steps", 1000, "Control steps per trial (the study: 1000)."
)
_EVAL_SEEDS = flags.DEFINE_integer(
    "eval_seeds", 1, "Initial states each candidate is scored on (seeds 0..N-1), every round."
)
_FALL_PENALTY = flags.DEFINE_float("fall_penalty", 1.0, "Cost of a fall (m of distance).")
_LATERAL_PENALTY = flags.DEFINE_float(
    "lateral_penalty", 0.0, "Cost per metre of lateral displacement (the study's variant)."
)
_THREADS = flags.DEFINE_integer("threads", 2, "Evaluator threads (results do not depend on it).")
_OUTPUT_DIR = flags.DEFINE_string("output_dir", "runs", "Root of the output tree.")
_RUN_NAME = flags.DEFINE_string("run_name", None, "Run directory name (default from settings).")
_RESUME = flags.DEFINE_bool("resume", False, "Continue runs from their checkpoints.")
_OVERWRITE = flags.DEFINE_bool("overwrite", False, "Replace existing run directories.")
_GRID = flags.DEFINE_enum("grid", None, ["table6_3"], "Run a whole table of settings.")
_SEEDS = flags.DEFINE_integer("seeds", 3, "--grid: seeds per setting (0..N-1).")
_SETTINGS = flags.DEFINE_string("settings", None, "--grid: only these settings (comma list).")

# Thesis Table 6.3 (K, noise, elite), plus the variants of Sec. 6.3: the lateral penalty
# and noise 0.2 / 1.0 (K 10, elite 2). Names are run-name prefixes.
TABLE6_3 = {
    **{f"K10_n0_e{e}": dict(population=10, noise=0.0, elite=e) for e in (1, 2, 3, 4)},
    **{f"K10_n0.8_e{e}": dict(population=10, noise=0.8, elite=e) for e in (1, 2, 3, 4)},
    "K20_n0.8_e2": dict(population=20, noise=0.8, elite=2),
    "K50_n0.8_e2": dict(population=50, noise=0.8, elite=2),
    "K10_n0.8_e2_lateral": dict(population=10, noise=0.8, elite=2, lateral_penalty=1.0),
    "K10_n0.2_e2": dict(population=10, noise=0.2, elite=2),
    "K10_n1_e2": dict(population=10, noise=1.0, elite=2),
}


class CEM:
    """The Cross-Entropy Method of thesis Alg. 6.1 on a Gaussian N(θ, Σ)."""

    def __init__(
        self,
        mean: np.ndarray,
        population: int,
        elite: int,
        noise: float,
        seed: int,
        covariance: np.ndarray | None = None,
    ):
        """Args:
          mean: Initial mean θ.
          population: K ≥ 2 samples per round, the first being the mean.
          elite: 1 ≤ elite ≤ K.
          noise: Variance added to the diagonal after each update (≥ 0).
          seed: Seed of the sampling generator.
          covariance: Initial Σ (default: identity).

        Raises:
          ValueError: On invalid sizes or a negative noise.
        """
        if population < 2 or not 1 <= elite <= population or noise < 0:
            raise ValueError(
                f"need K ≥ 2, 1 ≤ elite ≤ K and noise ≥ 0; got K={population}, "
                f"elite={elite}, noise={noise}"
            )
        self.mean = np.array(mean, dtype=np.float64)
        n = len(self.mean)
        self.cov = np.eye(n) if covariance is None else np.array(covariance, dtype=np.float64)
        self.population, self.elite, self.noise = population, elite, noise
        self.rng = np.random.default_rng(seed)

    @property
    def sigma(self) -> float:
        """Root mean variance of the sampling distribution."""
        return float(np.sqrt(np.mean(np.diag(self.cov))))

    def ask(self) -> np.ndarray:
        """1. Sample: the mean, then K − 1 draws from N(θ, Σ)."""
        draws = self.rng.multivariate_normal(
            self.mean, self.cov, size=self.population - 1, method="eigh"
        )
        return np.vstack([self.mean, draws])

    def tell(self, samples: np.ndarray, costs: np.ndarray) -> None:
        """3-4. Select the elite by cost and refit θ and Σ (+ noise on the diagonal)."""
        order = np.argsort(costs, kind="stable")
        elite = samples[order[: self.elite]]
        self.mean = elite.mean(axis=0)
        centred = elite - self.mean
        self.cov = centred.T @ centred / self.elite + self.noise * np.eye(len(self.mean))

    def state_dict(self) -> dict:
        return {
            "mean": self.mean.tolist(),
            "cov": self.cov.tolist(),
            "rng": self.rng.bit_generator.state,
        }

    def load_state_dict(self, state: dict) -> None:
        self.mean = np.array(state["mean"])
        self.cov = np.array(state["cov"])
        self.rng.bit_generator.state = state["rng"]


def default_run_name(settings: dict) -> str:
    lateral = "_lateral" if settings["lateral_penalty"] else ""
    return (
        f"K{settings['population']}_n{settings['noise']:g}_e{settings['elite']}{lateral}"
        f"_seed{settings['seed']}"
    )


def run_cem(
    settings: dict, threads: int = 2, resume: bool = False, overwrite: bool = False, log=print
) -> tuple[str, dict]:
    """Runs one CEM configuration and writes its run directory.

    Returns:
      `(run_dir, summary)`.

    Raises:
      runs.RunDirectoryExists, CheckpointError.
    """
    run_dir = runs.run_directory(
        settings["output_dir"],
        "cem",
        settings["task"],
        settings["run_name"],
        overwrite=overwrite,
        resume=resume,
    )
    summary_path = os.path.join(run_dir, "summary.json")
    if resume and os.path.exists(summary_path):
        log(f"{run_dir}: already finished")
        return run_dir, runs.read_json(summary_path)
    identity = {
        k: settings[k]
        for k in (
            "task",
            "population",
            "elite",
            "noise",
            "rounds",
            "seed",
            "trial_steps",
            "eval_seeds",
            "fall_penalty",
            "lateral_penalty",
        )
    }
    if not (resume and os.path.exists(os.path.join(run_dir, "checkpoint.json"))):
        runs.write_config(run_dir, {**settings, "threads": threads})
    optimizer = CEM(
        cpg.amplitudes_from("hand_tuned"),
        settings["population"],
        settings["elite"],
        settings["noise"],
        settings["seed"],
    )
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


def _validate() -> dict:
    cli.check(_TASK.value in TASKS, f"unknown --task {_TASK.value!r}; valid: {', '.join(TASKS)}")
    cli.check(_POPULATION.value >= 2, f"--population must be ≥ 2, got {_POPULATION.value}")
    cli.check(
        1 <= _ELITE.value <= _POPULATION.value,
        f"--elite must lie in [1, --population={_POPULATION.value}], got {_ELITE.value}",
    )
    cli.check(_NOISE.value >= 0, f"--noise must be ≥ 0, got {_NOISE.value}")
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
    cli.check(_SEEDS.value >= 1, f"--seeds must be ≥ 1, got {_SEEDS.value}")
    return {
        "trial_steps": _TRIAL_STEPS.value,
        "task": _TASK.value,
        "population": _POPULATION.value,
        "elite": _ELITE.value,
        "noise": _NOISE.value,
        "rounds": _ROUNDS.value,
        "seed": _SEED.value,
        "eval_seeds": _EVAL_SEEDS.value,
        "fall_penalty": _FALL_PENALTY.value,
        "lateral_penalty": _LATERAL_PENALTY.value,
        "output_dir": _OUTPUT_DIR.value,
        "run_name": _RUN_NAME.value,
    }


def main(argv):
    del argv
    base = _validate()
    if _GRID.value is None:
        jobs = [{**base, "run_name": base["run_name"] or default_run_name(base)}]
    else:
        names = list(TABLE6_3)
        if _SETTINGS.value:
            names = [n.strip() for n in _SETTINGS.value.split(",") if n.strip()]
            unknown = [n for n in names if n not in TABLE6_3]
            cli.check(not unknown, f"unknown --settings {unknown}; valid: {', '.join(TABLE6_3)}")
        jobs = []
        for name in names:
            for seed in range(_SEEDS.value):
                setting = {**base, "lateral_penalty": 0.0, **TABLE6_3[name], "seed": seed}
                jobs.append({**setting, "run_name": f"{name}_seed{seed}"})
    start = time.perf_counter()
    for i, settings in enumerate(jobs, 1):
        prefix = f"[{i}/{len(jobs)} {settings['run_name']}] " if len(jobs) > 1 else ""
        try:
            run_dir, summary = run_cem(
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


if __name__ == "__main__":
    cli.run(main)
