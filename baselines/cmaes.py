r"""CMA-ES on the 11 CPG amplitudes: a stronger optimizer than the study's CEM.

  python -m baselines.cmaes --task=darwin_walk        # K 50, 50 rounds: CEM's budget

Covariance Matrix Adaptation (Hansen), through the `cma` package (`pip install
'cpg-suite[optim]'`), started where the study's CEM starts: mean = the hand-tuned
amplitudes, initial step size σ₀ = 1 degree with identity covariance (CEM's Σ = I). Same
cost, same trials, same evaluation budget (population × rounds), same run directory
(`<output_dir>/cmaes/<task>/<run_name>/`) and resume as `baselines.cem`. Unlike CEM, the
current mean is not one of the samples; the final mean is evaluated once at the end.
"""

from __future__ import annotations

import base64
import pickle

import numpy as np
from absl import flags

from baselines import cli, optimize
from cpg_suite import cpg


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    global _SIGMA0
    _SIGMA0 = flags.DEFINE_float("sigma0", 1.0, "Initial step size σ₀, degrees.")


class CMAES:
    """`cma.CMAEvolutionStrategy` behind the optimizer interface of `baselines.optimize`."""

    def __init__(self, mean: np.ndarray, population: int, sigma0: float, seed: int):
        """Args:
          mean: Initial mean.
          population: Samples per round (≥ 2).
          sigma0: Initial step size (> 0).
          seed: Seed (the `cma` package and the NumPy generator it samples with).

        Raises:
          ImportError: If the `cma` package is not installed.
          ValueError: On a population < 2 or σ₀ ≤ 0.
        """
        try:
            import cma
        except ImportError as e:
            raise ImportError("CMA-ES needs the cma package: pip install 'cpg-suite[optim]'") from e
        if population < 2 or not sigma0 > 0:
            raise ValueError(f"need population ≥ 2 and sigma0 > 0, got {population}, {sigma0}")
        # `cma` draws from NumPy's global generator: seed it, and checkpoint its state.
        np.random.seed(seed)
        self.es = cma.CMAEvolutionStrategy(
            np.asarray(mean, dtype=np.float64),
            sigma0,
            {
                "popsize": population,
                "seed": seed + 1,
                "verbose": -9,
                "maxiter": np.inf,
                "tolfun": 0,
                "tolx": 0,
                "tolstagnation": np.inf,
                "tolflatfitness": np.inf,
            },
        )

    @property
    def mean(self) -> np.ndarray:
        return np.array(self.es.mean)

    @property
    def sigma(self) -> float:
        """Root mean variance of the sampling distribution, degrees."""
        return float(self.es.sigma * np.sqrt(np.mean(np.diag(self.es.C))))

    def ask(self) -> np.ndarray:
        return np.array(self.es.ask())

    def tell(self, samples: np.ndarray, costs: np.ndarray) -> None:
        self.es.tell(list(samples), [float(c) for c in costs])

    def state_dict(self) -> dict:
        kind, keys, pos, has_gauss, cached = np.random.get_state()
        return {
            "es": base64.b64encode(pickle.dumps(self.es)).decode("ascii"),
            "np_random": [kind, keys.tolist(), int(pos), int(has_gauss), float(cached)],
        }

    def load_state_dict(self, state: dict) -> None:
        self.es = pickle.loads(base64.b64decode(state["es"]))
        kind, keys, pos, has_gauss, cached = state["np_random"]
        np.random.set_state((kind, np.array(keys, dtype=np.uint32), pos, has_gauss, cached))


def run_cmaes(
    settings: dict, threads: int = 2, resume: bool = False, overwrite: bool = False, log=print
) -> tuple[str, dict]:
    """Runs one CMA-ES configuration and writes `<output_dir>/cmaes/<task>/<run_name>/`."""
    optimizer = CMAES(
        cpg.amplitudes_from("hand_tuned"),
        settings["population"],
        settings["sigma0"],
        settings["seed"],
    )
    return optimize.run_optimizer(
        "cmaes", optimizer, settings, ("sigma0",), threads, resume, overwrite, log
    )


def main(argv):
    del argv
    settings = optimize.common_settings()
    cli.check(_SIGMA0.value > 0, f"--sigma0 must be > 0, got {_SIGMA0.value}")
    try:
        import cma  # noqa: F401
    except ImportError:
        raise cli.UsageError(
            "CMA-ES needs the cma package: pip install 'cpg-suite[optim]'"
        ) from None
    settings["sigma0"] = _SIGMA0.value
    lateral = "_lateral" if settings["lateral_penalty"] else ""
    settings["run_name"] = settings["run_name"] or (
        f"K{settings['population']}_s{settings['sigma0']:g}{lateral}_seed{settings['seed']}"
    )
    optimize.run_jobs([settings], run_cmaes)


if __name__ == "__main__":
    optimize.define_flags()
    define_flags()
    cli.run(main)
