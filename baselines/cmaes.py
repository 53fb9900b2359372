r"""CMA-ES on the 11 CPG amplitudes: a stronger optimizer than the study's CEM.

  python -m baselines.cmaes --task=darwin_walk        # K 50, 50 rounds: CEM's budget

Covariance Matrix Adaptation, the standard (μ/μ_w, λ)-CMA-ES with the default parameters of
Hansen's tutorial (arXiv:1604.00772, Table 1 and Fig. 6), started where the study's CEM
starts: mean = the hand-tuned amplitudes, step size σ₀ = 1 degree, C = I (CEM's Σ = I).
Same cost, trials, evaluation budget (population × rounds), run directory
(`<output_dir>/cmaes/<task>/<run_name>/`) and resume as `baselines.cem`. Unlike CEM, the
current mean is not one of the samples; the final mean is evaluated once at the end.

One generation g (n = 11 amplitudes, λ = population, μ = λ/2):

  sample   zₖ ~ N(0, I),  yₖ = B D zₖ,  xₖ = m + σ yₖ             (C = B D² Bᵀ)
  select   sort by cost;  y_w = Σᵢ wᵢ y_{i:λ}  (i ≤ μ)
  mean     m ← m + σ y_w
  σ-path   p_σ ← (1 − c_σ) p_σ + √(c_σ(2 − c_σ) μ_eff) B D⁻¹ Bᵀ y_w
  step     σ ← σ exp(c_σ/d_σ (‖p_σ‖ / E‖N(0, I)‖ − 1))
  C-path   p_c ← (1 − c_c) p_c + h_σ √(c_c(2 − c_c) μ_eff) y_w
  C        C ← (1 − c₁ − c_μ) C + c₁ (p_c p_cᵀ + δ(h_σ) C) + c_μ Σᵢ wᵢ y_{i:λ} y_{i:λ}ᵀ

Why not the `cma` package for the runs: its sampling and updates go through NumPy's BLAS and
LAPACK (`dot`, `eigh`), whose OpenBLAS kernel is chosen per CPU, so the same seed gave
different gaits on different machines. This implementation does its linear algebra with
`cpg_suite.portable` (element-wise operations in a fixed order, Jacobi eigendecomposition)
and is bit-identical on any x86-64 CPU; `tests/test_cmaes.py` checks it against `cma` on
benchmark functions.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import math
from collections.abc import Callable

import numpy as np
from absl import flags

from cpg_suite import cli, portable, progress
from cpg_suite.harness import grids, interface, optimize
from cpg_suite.runfiles import runs

METHOD = "cmaes"  # its run directories' second level and its leaderboard rows


class CMAES:
    """The (μ/μ_w, λ)-CMA-ES behind the optimizer interface of `cpg_suite.harness.interface`."""

    def __init__(self, mean: np.ndarray, population: int, sigma0: float, seed: int):
        """Args:
          mean: Initial mean m.
          population: λ ≥ 2 samples per generation.
          sigma0: Initial step size σ₀ > 0.
          seed: Seed of the sampling generator.

        Raises:
          ValueError: On a population < 2 or σ₀ ≤ 0.
        """
        if population < 2 or not sigma0 > 0:
            raise ValueError(f"need population ≥ 2 and sigma0 > 0, got {population}, {sigma0}")
        self.mean = np.array(mean, dtype=np.float64)
        n = len(self.mean)
        self.population, self.step = population, float(sigma0)
        self.cov = np.eye(n)
        self.path_sigma, self.path_c = np.zeros(n), np.zeros(n)
        self.generation = 0
        self.rng = np.random.default_rng(seed)
        self._set_constants(n, population)
        self._decompose()

    def _set_constants(self, n: int, lam: int) -> None:
        """Default strategy parameters (Hansen's tutorial, Table 1; positive weights only)."""
        mu = lam // 2
        raw = [math.log((lam + 1) / 2) - math.log(i + 1) for i in range(mu)]
        self.weights = np.array([w / math.fsum(raw) for w in raw])
        self.mu_eff = 1.0 / math.fsum(w * w for w in self.weights)
        self.c_sigma = (self.mu_eff + 2) / (n + self.mu_eff + 5)
        self.d_sigma = 1 + 2 * max(0.0, math.sqrt((self.mu_eff - 1) / (n + 1)) - 1) + self.c_sigma
        self.c_c = (4 + self.mu_eff / n) / (n + 4 + 2 * self.mu_eff / n)
        self.c_1 = 2 / ((n + 1.3) ** 2 + self.mu_eff)
        self.c_mu = min(
            1 - self.c_1, 2 * (self.mu_eff - 2 + 1 / self.mu_eff) / ((n + 2) ** 2 + self.mu_eff)
        )
        self.chi_n = math.sqrt(n) * (1 - 1 / (4 * n) + 1 / (21 * n * n))

    def _decompose(self) -> None:
        """C = B D² Bᵀ (eigenvalues clipped at 0)."""
        values, self.basis = portable.symmetric_eig(self.cov)
        self.scales = np.sqrt(np.maximum(values, 0.0))

    @property
    def sigma(self) -> float:
        """Root mean variance of the sampling distribution, degrees."""
        diag = math.fsum(float(c) for c in np.diag(self.cov)) / len(self.mean)
        return float(self.step * math.sqrt(diag))

    def ask(self) -> np.ndarray:
        """Samples λ candidates xₖ = m + σ B D zₖ."""
        z = self.rng.standard_normal((self.population, len(self.mean)))
        y = portable.matmul(z * self.scales, self.basis.T)
        return self.mean + self.step * y

    def tell(self, samples: np.ndarray, costs: np.ndarray) -> None:
        """Updates m, the paths, σ and C from the μ best samples (NaN/inf costs sort last)."""
        costs = np.where(np.isfinite(costs), costs, np.inf)
        order = np.argsort(costs, kind="stable")[: len(self.weights)]
        y = (np.asarray(samples, dtype=np.float64)[order] - self.mean) / self.step
        y_w = portable.weighted_sum(self.weights, y)
        self.mean = self.mean + self.step * y_w
        self._update_step(y_w)
        self._update_covariance(y, y_w)
        self.generation += 1
        self._decompose()

    def _update_step(self, y_w: np.ndarray) -> None:
        whitened = portable.matmul(
            self.basis, (portable.matmul(self.basis.T, y_w[:, None])[:, 0] / self.scales)[:, None]
        )[:, 0]
        self.path_sigma = (1 - self.c_sigma) * self.path_sigma + math.sqrt(
            self.c_sigma * (2 - self.c_sigma) * self.mu_eff
        ) * whitened
        ratio = portable.norm(self.path_sigma) / self.chi_n
        self.step *= math.exp(self.c_sigma / self.d_sigma * (ratio - 1))

    def _update_covariance(self, y: np.ndarray, y_w: np.ndarray) -> None:
        n = len(self.mean)
        decay = 1 - (1 - self.c_sigma) ** (2 * (self.generation + 1))
        stalled = (
            portable.norm(self.path_sigma) / math.sqrt(decay) >= (1.4 + 2 / (n + 1)) * self.chi_n
        )
        h_sigma = 0.0 if stalled else 1.0
        self.path_c = (1 - self.c_c) * self.path_c + h_sigma * math.sqrt(
            self.c_c * (2 - self.c_c) * self.mu_eff
        ) * y_w
        delta = (1 - h_sigma) * self.c_c * (2 - self.c_c)
        rank_one = portable.weighted_outer_sum([1.0], self.path_c[None]) + delta * self.cov
        rank_mu = portable.weighted_outer_sum(self.weights, y)
        cov = (1 - self.c_1 - self.c_mu) * self.cov + self.c_1 * rank_one + self.c_mu * rank_mu
        self.cov = (cov + cov.T) / 2

    def state_dict(self) -> dict:
        return {
            "mean": self.mean.tolist(),
            "step": self.step,
            "cov": self.cov.tolist(),
            "path_sigma": self.path_sigma.tolist(),
            "path_c": self.path_c.tolist(),
            "generation": self.generation,
            "rng": self.rng.bit_generator.state,
        }

    def load_state_dict(self, state: dict) -> None:
        self.mean = np.array(state["mean"], dtype=np.float64)
        self.step = float(state["step"])
        self.cov = np.array(state["cov"], dtype=np.float64)
        self.path_sigma = np.array(state["path_sigma"], dtype=np.float64)
        self.path_c = np.array(state["path_c"], dtype=np.float64)
        self.generation = int(state["generation"])
        self.rng.bit_generator.state = state["rng"]
        self._decompose()


# The largest --sigma0, degrees (a choice: wider than every leg joint's range).
MAX_SIGMA0 = 100.0


@dataclasses.dataclass(frozen=True)
class CMAESSettings(interface.OptimizerSettings):
    """The settings of a CMA-ES run (the shared ones plus the initial step size).

    Attributes:
      sigma0: Initial step size σ₀, degrees.
    """

    sigma0: float = 1.0

    def __post_init__(self):
        super().__post_init__()
        cli.require_number("sigma0", self.sigma0, 0, MAX_SIGMA0, low_open=True)


def default_run_name(settings: CMAESSettings) -> str:
    """`K<population>_s<sigma0>[_lateral][_feedback]_seed<seed>`."""
    lateral = "_lateral" if settings.lateral_penalty else ""
    feedback = "_feedback" if settings.controller == "feedback" else ""
    return f"K{settings.population}_s{settings.sigma0:g}{lateral}{feedback}_seed{settings.seed}"


def run_cmaes(
    settings: CMAESSettings,
    options: runs.RunOptions | None = None,
    log: Callable[[str], None] = progress.write,
) -> tuple[str, dict]:
    """Runs one CMA-ES configuration and writes `<output_dir>/cmaes/<task>/<run_name>/`.

    Args:
      settings: The run's settings.
      options: Where and how to run (run name default: `default_run_name(settings)`).
      log: Receives a line per round.

    Returns:
      `(run_dir, summary)`.

    Raises:
      runs.RunDirectoryExists, cpg_suite.harness.checkpoints.CheckpointError.
    """
    optimizer = CMAES(
        optimize.start_vector(settings), settings.population, settings.sigma0, settings.seed
    )
    options = options or runs.RunOptions()
    return optimize.run(optimizer, settings, options, METHOD, log, default_run_name(settings))


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    optimize.define_flags()
    flags.DEFINE_float("sigma0", CMAESSettings().sigma0, "Initial step size σ₀, degrees.")


def main(argv):
    del argv
    settings = cli.settings_from_flags(CMAESSettings)
    options = cli.settings_from_flags(runs.RunOptions)
    grids.run_jobs([(settings, options)], run_cmaes, method=METHOD)


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_dirs=("output_dir",))
