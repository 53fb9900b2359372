"""Small statistics shared by the experiment scripts and the analysis."""

from __future__ import annotations

import math

import numpy as np

# Two-sided 95 % Student t quantiles by degrees of freedom (1.96 beyond 10).
_T95 = {
    1: 12.706,
    2: 4.303,
    3: 3.182,
    4: 2.776,
    5: 2.571,
    6: 2.447,
    7: 2.365,
    8: 2.306,
    9: 2.262,
    10: 2.228,
}


def mean_std_ci95(values) -> tuple[float, float, float, float]:
    """Mean, sample standard deviation and the 95 % t-interval of the mean."""
    arr = np.asarray(values, dtype=float)
    mean = float(arr.mean())
    if len(arr) < 2:
        return mean, 0.0, mean, mean
    std = float(arr.std(ddof=1))
    half = _T95.get(len(arr) - 1, 1.96) * std / math.sqrt(len(arr))
    return mean, std, mean - half, mean + half
