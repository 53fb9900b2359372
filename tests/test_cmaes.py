"""Our CPU-independent CMA-ES against the `cma` package (Hansen's pycma) on test functions."""

import numpy as np
import pytest

from baselines import cmaes


def _sphere(x):
    return float(np.sum(x * x))


def _ellipsoid(x):
    n = len(x)
    return float(np.sum(10 ** (4 * np.arange(n) / (n - 1)) * x * x))


def _evaluations_ours(f, seed, target=1e-8, budget=30000):
    opt = cmaes.CMAES(np.full(6, 3.0), population=10, sigma0=1.0, seed=seed)
    used = 0
    while used < budget:
        x = opt.ask()
        costs = np.array([f(v) for v in x])
        opt.tell(x, costs)
        used += len(x)
        if costs.min() < target:
            return used
    return budget


def _evaluations_pycma(f, seed, target=1e-8, budget=30000):
    cma = pytest.importorskip("cma")
    es = cma.CMAEvolutionStrategy(
        np.full(6, 3.0), 1.0, {"popsize": 10, "seed": seed + 1, "verbose": -9, "CMA_active": False}
    )
    used = 0
    while used < budget:
        x = es.ask()
        costs = [f(v) for v in x]
        es.tell(x, costs)
        used += len(x)
        if min(costs) < target:
            return used
    return budget


@pytest.mark.parametrize("f", [_sphere, _ellipsoid])
def test_converges_like_pycma(f):
    ours = np.mean([_evaluations_ours(f, s) for s in range(2)])
    theirs = np.mean([_evaluations_pycma(f, s) for s in range(2)])
    assert ours < 30000
    assert 0.75 * theirs < ours < 1.3 * theirs, (ours, theirs)


def test_state_round_trip_continues_identically():
    a = cmaes.CMAES(np.zeros(11), population=8, sigma0=1.0, seed=3)
    for _ in range(3):
        x = a.ask()
        a.tell(x, np.array([_sphere(v - 1) for v in x]))
    b = cmaes.CMAES(np.zeros(11), population=8, sigma0=1.0, seed=99)
    b.load_state_dict(a.state_dict())
    np.testing.assert_array_equal(a.ask(), b.ask())
