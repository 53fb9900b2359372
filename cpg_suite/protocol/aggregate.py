"""Aggregates over runs, as rliable defines them (Agarwal et al., NeurIPS 2021).

A configuration (a method with its settings and budget) is run with several seeds; each
run's test score card gives one score per test tier. The scores of a configuration are a
(runs × tiers) matrix, and:

  * the IQM is the mean of the middle 50 % of all its entries (25 % trimmed from each end),
    the mean is the plain mean;
  * their 95 % intervals come from the stratified bootstrap: each resample draws the runs
    with replacement separately for each tier, the percentile interval of the statistic
    over the resamples;
  * the probability of improvement of X over Y is, per tier, the chance that a run of X
    scores above a run of Y (ties count one half: the Mann-Whitney U statistic over all
    pairs, divided by their number), averaged over the tiers; its interval is bootstrapped
    the same way, X's and Y's runs drawn independently.

rliable itself (1.2.0) does not import beside pandas 3 (its `arch` dependency fails), so
these are its definitions written on NumPy and SciPy, with a fixed random seed so that an
aggregate is reproducible bit for bit (docs/protocol.md#ranking).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy import stats

RESAMPLES = 2000  # bootstrap resamples per interval
SEED = 0  # the bootstrap's generator seed: the same intervals every time
CONFIDENCE = 0.95


def iqm(scores: np.ndarray) -> float:
    """The interquartile mean of all entries of a (runs × tiers) matrix."""
    return float(stats.trim_mean(np.asarray(scores, float).ravel(), 0.25))


def mean(scores: np.ndarray) -> float:
    """The mean of all entries of a (runs × tiers) matrix."""
    return float(np.mean(scores))


def _check(scores: np.ndarray) -> np.ndarray:
    scores = np.asarray(scores, dtype=np.float64)
    if scores.ndim != 2 or scores.shape[0] < 1 or scores.shape[1] < 1:
        raise ValueError(f"scores must be a (runs × tiers) matrix, got shape {scores.shape}")
    if not np.all(np.isfinite(scores)):
        raise ValueError("scores must be finite")
    return scores


def _resample(scores: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One stratified bootstrap resample: runs drawn with replacement, per tier."""
    runs, tiers = scores.shape
    rows = rng.integers(0, runs, size=(runs, tiers))
    return scores[rows, np.arange(tiers)]


def _percentile_interval(values: np.ndarray) -> list[float]:
    tail = (1 - CONFIDENCE) / 2 * 100
    low, high = np.percentile(values, [tail, 100 - tail])
    return [float(low), float(high)]


def interval(
    scores: np.ndarray, statistic: Callable[[np.ndarray], float], resamples: int = RESAMPLES
) -> list[float]:
    """The stratified bootstrap 95 % interval of `statistic` over a (runs × tiers) matrix.

    Args:
      scores: Test scores, one row per run, one column per tier.
      statistic: Maps such a matrix to a number (e.g. `iqm`, `mean`).
      resamples: Bootstrap resamples.

    Returns:
      `[low, high]`.

    Raises:
      ValueError: If `scores` is not a finite 2-D matrix.
    """
    scores = _check(scores)
    rng = np.random.default_rng(SEED)
    values = np.array([statistic(_resample(scores, rng)) for _ in range(resamples)])
    return _percentile_interval(values)


def probability_of_improvement(x: np.ndarray, y: np.ndarray) -> float:
    """P(a run of X scores above a run of Y), ties counted one half, averaged over tiers.

    Args:
      x, y: (runs × tiers) matrices with the same tiers (columns).

    Raises:
      ValueError: On matrices that are not finite or whose tiers differ in number.
    """
    x, y = _check(x), _check(y)
    if x.shape[1] != y.shape[1]:
        raise ValueError(f"x and y need the same tiers, got {x.shape[1]} and {y.shape[1]}")
    per_tier = []
    for j in range(x.shape[1]):
        a, b = x[:, j, None], y[None, :, j]
        per_tier.append(np.mean((a > b) + 0.5 * (a == b)))
    return float(np.mean(per_tier))


def improvement_interval(x: np.ndarray, y: np.ndarray, resamples: int = RESAMPLES) -> list[float]:
    """The stratified bootstrap 95 % interval of `probability_of_improvement(x, y)`."""
    x, y = _check(x), _check(y)
    rng = np.random.default_rng(SEED)
    values = [
        probability_of_improvement(_resample(x, rng), _resample(y, rng)) for _ in range(resamples)
    ]
    return _percentile_interval(np.array(values))


def summary(scores: np.ndarray) -> dict:
    """IQM and mean of a configuration's runs with their intervals.

    Returns:
      `{"runs", "iqm", "iqm_ci95", "mean", "mean_ci95"}`.
    """
    scores = _check(scores)
    return {
        "runs": int(scores.shape[0]),
        "iqm": iqm(scores),
        "iqm_ci95": interval(scores, iqm),
        "mean": mean(scores),
        "mean_ci95": interval(scores, mean),
    }
