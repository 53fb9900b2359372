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

import numpy as np
from absl import flags

from baselines import cli, optimize
from cpg_suite import cpg


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    global _ELITE, _NOISE, _GRID, _SEEDS, _SETTINGS
    _ELITE = flags.DEFINE_integer("elite", 2, "Elite samples kept per round.")
    _NOISE = flags.DEFINE_float("noise", 0.8, "Variance added to the covariance diagonal, deg².")
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

    first_sample_is_mean = True

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
    """Runs one CEM configuration and writes `<output_dir>/cem/<task>/<run_name>/`.

    Returns:
      `(run_dir, summary)`.

    Raises:
      runs.RunDirectoryExists, optimize.CheckpointError.
    """
    optimizer = CEM(
        cpg.amplitudes_from("hand_tuned"),
        settings["population"],
        settings["elite"],
        settings["noise"],
        settings["seed"],
    )
    return optimize.run_optimizer(
        "cem", optimizer, settings, ("elite", "noise"), threads, resume, overwrite, log
    )


def _validate() -> dict:
    settings = optimize.common_settings()
    cli.check(
        1 <= _ELITE.value <= settings["population"],
        f"--elite must lie in [1, --population={settings['population']}], got {_ELITE.value}",
    )
    cli.check(_NOISE.value >= 0, f"--noise must be ≥ 0, got {_NOISE.value}")
    cli.check(_SEEDS.value >= 1, f"--seeds must be ≥ 1, got {_SEEDS.value}")
    return {**settings, "elite": _ELITE.value, "noise": _NOISE.value}


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
    optimize.run_jobs(jobs, run_cem)


if __name__ == "__main__":
    optimize.define_flags()
    define_flags()
    cli.run(main)
