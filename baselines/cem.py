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

Run directory `<output_dir>/cem/<task>/<run_name>/` (docs/architecture.md#run-directories):
config.json,
progress.csv (a row per round), checkpoint.json (atomic, every round; `--resume`
continues bit-identically), best_params.json, mean_params.json, summary.json.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
from collections.abc import Callable

import numpy as np
from absl import flags

from cpg_suite import cli, portable, progress
from cpg_suite.harness import grids, interface, optimize, rounds
from cpg_suite.runfiles import runs

# Thesis Table 6.3 (K, noise, elite), plus the variants of Sec. 6.3: the lateral penalty,
# noise 0.2 / 1.0 (K 10, elite 2) and K = 70 / 100 (elite 2, noise 0.8; "not as good", no
# number given). Names are run-name prefixes.
TABLE6_3 = {
    **{f"K10_n0_e{e}": dict(population=10, noise=0.0, elite=e) for e in (1, 2, 3, 4)},
    **{f"K10_n0.8_e{e}": dict(population=10, noise=0.8, elite=e) for e in (1, 2, 3, 4)},
    "K20_n0.8_e2": dict(population=20, noise=0.8, elite=2),
    "K50_n0.8_e2": dict(population=50, noise=0.8, elite=2),
    "K70_n0.8_e2": dict(population=70, noise=0.8, elite=2),
    "K100_n0.8_e2": dict(population=100, noise=0.8, elite=2),
    "K10_n0.8_e2_lateral": dict(population=10, noise=0.8, elite=2, lateral_penalty=1.0),
    "K10_n0.2_e2": dict(population=10, noise=0.2, elite=2),
    "K10_n1_e2": dict(population=10, noise=1.0, elite=2),
}

METHOD = "cem"  # its run directories' second level and its leaderboard rows


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
        """1. Sample: the mean, then K − 1 draws θ + L z from N(θ, Σ), Σ = L Lᵀ.

        The factor L and the product L z use `cpg_suite.portable`, not LAPACK/BLAS, so the
        samples are the same bits on every CPU (see that module).
        """
        factor = portable.cholesky_psd(self.cov)
        z = self.rng.standard_normal((self.population - 1, len(self.mean)))
        draws = self.mean + portable.matmul(z, factor.T)
        return np.vstack([self.mean, draws])

    def tell(self, samples: np.ndarray, costs: np.ndarray) -> None:
        """3-4. Select the elite by cost and refit θ and Σ (+ noise on the diagonal).

        A NaN or infinite cost is a failed trial: it sorts after every finite cost.
        """
        order = rounds.ranking(costs)
        elite = np.asarray(samples, dtype=np.float64)[order[: self.elite]]
        weights = np.full(self.elite, 1.0 / self.elite)
        self.mean = portable.weighted_sum(weights, elite)
        centred = elite - self.mean
        self.cov = portable.weighted_outer_sum(weights, centred) + self.noise * np.eye(
            len(self.mean)
        )

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


# The largest --noise, deg² (a choice: σ = 100°, wider than every leg joint's range).
MAX_NOISE = 1e4


@dataclasses.dataclass(frozen=True)
class CEMSettings(interface.OptimizerSettings):
    """The settings of a CEM run (the shared ones plus elite and noise).

    Attributes:
      elite: Elite samples kept per round.
      noise: Variance added to the covariance diagonal each round, deg².
    """

    elite: int = 2
    noise: float = 0.8

    def __post_init__(self):
        super().__post_init__()
        cli.require(
            1 <= self.elite <= self.population,
            f"--elite must lie in [1, --population={self.population}], got {self.elite}",
        )
        cli.require_number("noise", self.noise, 0, MAX_NOISE)


def default_run_name(settings: CEMSettings) -> str:
    """`K<population>_n<noise>_e<elite>[_lateral][_feedback]_seed<seed>`."""
    lateral = "_lateral" if settings.lateral_penalty else ""
    feedback = "_feedback" if settings.controller == "feedback" else ""
    name = f"K{settings.population}_n{settings.noise:g}_e{settings.elite}{lateral}{feedback}"
    return f"{name}_seed{settings.seed}"


def grid_jobs(
    base: CEMSettings, options: runs.RunOptions, names: list[str], seeds: int
) -> list[tuple[CEMSettings, runs.RunOptions]]:
    """The runs of a Table 6.3 grid: each named setting × seeds 0..seeds-1.

    Raises:
      ValueError: On an unknown setting name (the message lists the valid ones).
    """
    unknown = [n for n in names if n not in TABLE6_3]
    cli.require(not unknown, f"unknown --settings {unknown}; valid: {', '.join(TABLE6_3)}")
    jobs = []
    for name in names:
        for seed in range(seeds):
            fields = {"lateral_penalty": 0.0, **TABLE6_3[name], "seed": seed}
            settings = dataclasses.replace(base, **fields)
            jobs.append((settings, dataclasses.replace(options, run_name=f"{name}_seed{seed}")))
    return jobs


def run_cem(
    settings: CEMSettings,
    options: runs.RunOptions | None = None,
    log: Callable[[str], None] = progress.write,
) -> tuple[str, dict]:
    """Runs one CEM configuration and writes `<output_dir>/cem/<task>/<run_name>/`.

    Args:
      settings: The run's settings.
      options: Where and how to run (run name default: `default_run_name(settings)`).
      log: Receives a line per round.

    Returns:
      `(run_dir, summary)`.

    Raises:
      runs.RunDirectoryExists, cpg_suite.harness.checkpoints.CheckpointError.
    """
    optimizer = CEM(
        optimize.start_vector(settings),
        settings.population,
        settings.elite,
        settings.noise,
        settings.seed,
    )
    options = options or runs.RunOptions()
    return optimize.run(optimizer, settings, options, METHOD, log, default_run_name(settings))


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    optimize.define_flags()
    d = CEMSettings()
    flags.DEFINE_integer("elite", d.elite, "Elite samples kept per round.")
    flags.DEFINE_float("noise", d.noise, "Variance added to the covariance diagonal, deg².")
    flags.DEFINE_enum(
        "grid",
        None,
        ["table6_3"],
        "Run a whole table of settings (default: one run, of the flags' settings).",
    )
    flags.DEFINE_integer("seeds", 3, "--grid: seeds per setting (0..N-1).")
    flags.DEFINE_string(
        "settings", None, "none: all of the grid's. --grid: only these settings (comma list)."
    )


def main(argv):
    del argv
    settings = cli.settings_from_flags(CEMSettings)
    options = cli.settings_from_flags(runs.RunOptions)
    values = flags.FLAGS
    cli.check(values.seeds >= 1, f"--seeds must be ≥ 1, got {values.seeds}")
    cli.check(
        values.grid is not None or values.settings is None,
        f"--settings={values.settings} needs --grid (it picks settings of a grid)",
    )
    if values.grid is None:
        jobs = [(settings, options)]
    else:
        names = list(TABLE6_3)
        if values.settings:
            names = [n.strip() for n in values.settings.split(",") if n.strip()]
        try:
            jobs = grid_jobs(settings, options, names, values.seeds)
        except ValueError as e:
            raise cli.UsageError(str(e)) from None
    grids.run_jobs(jobs, run_cem, method=METHOD)


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_dirs=("output_dir",))
