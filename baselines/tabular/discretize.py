"""Uniform grid discretizers from continuous observations to tabular states."""

from __future__ import annotations

import math
import re

import numpy as np

# The study's ranges for the pole (thesis Sec. 4.2.1): angle in [−π/2, π/2] rad,
# angular velocity in [−40, 40] rad/s (found by experiment).
POLE_ANGLE_RANGE = (-math.pi / 2, math.pi / 2)
POLE_VELOCITY_RANGE = (-40.0, 40.0)


class Discretizer:
    """Uniform, non-overlapping bins over one or more scalar observation entries.

    Values outside a range fall into its end bins (the study does not say how it treated
    angular velocities beyond ±40 rad/s; clipping is our choice). The state index is the
    row-major index over the bins, first key slowest.
    """

    def __init__(self, keys, ranges, bins):
        """Args:
          keys: Observation names, e.g. `("angle", "angular_velocity")`.
          ranges: `(low, high)` per key.
          bins: Number of bins per key (≥ 1).

        Raises:
          ValueError: If the lengths disagree, a range is empty or a bin count < 1.
        """
        self.keys = tuple(keys)
        self.bins = tuple(int(b) for b in bins)
        if not (len(self.keys) == len(ranges) == len(self.bins)) or not self.keys:
            raise ValueError("keys, ranges and bins must have the same non-zero length")
        if any(b < 1 for b in self.bins):
            raise ValueError(f"bin counts must be ≥ 1, got {self.bins}")
        self.low = np.array([float(lo) for lo, _ in ranges])
        self.high = np.array([float(hi) for _, hi in ranges])
        if np.any(self.high <= self.low):
            raise ValueError(f"each range needs low < high, got {list(ranges)}")
        self._width = (self.high - self.low) / np.array(self.bins)
        self._stride = np.array([int(np.prod(self.bins[i + 1 :])) for i in range(len(self.bins))])

    @property
    def n_states(self) -> int:
        return int(np.prod(self.bins))

    def bin_indices(self, observation) -> np.ndarray:
        """Per-key bin indices of an observation (mapping of key → array)."""
        values = np.array([float(np.asarray(observation[k]).reshape(-1)[0]) for k in self.keys])
        idx = np.floor((values - self.low) / self._width).astype(np.int64)
        return np.clip(idx, 0, np.array(self.bins) - 1)

    def __call__(self, observation) -> int:
        """The state index of an observation."""
        return int(self.bin_indices(observation) @ self._stride)

    def bin_centers(self, key_index: int) -> np.ndarray:
        """Centres of the bins of the `key_index`-th key."""
        centers = np.arange(self.bins[key_index]) + 0.5
        return self.low[key_index] + centers * self._width[key_index]


def parse_bins(text: str) -> tuple[int, ...]:
    """Parses `"20x20"` (angle × angular-velocity bins) or `"100"` (angle only).

    Raises:
      ValueError: If the text is not one or two positive integers joined by 'x'.
    """
    if not re.fullmatch(r"\s*\d+\s*(x\s*\d+\s*)?", str(text)):
        raise ValueError(
            f"malformed bins {text!r}; use ANGLExVELOCITY like 20x20, or ANGLE like 100"
        )
    bins = tuple(int(b) for b in str(text).split("x"))
    if any(b < 1 for b in bins):
        raise ValueError(f"bin counts must be ≥ 1, got {text!r}")
    return bins


def pole_discretizer(
    bins: tuple[int, ...], angle_range=POLE_ANGLE_RANGE, velocity_range=POLE_VELOCITY_RANGE
) -> Discretizer:
    """The study's pole discretizer: angle bins, and optionally angular-velocity bins.

    Args:
      bins: `(n_angle,)` or `(n_angle, n_velocity)`; "4x20" means 4 angle bins × 20
        velocity bins (the literal reading of the study's "4 position states and 20
        angular states").
      angle_range: Angle range, rad.
      velocity_range: Angular-velocity range, rad/s.

    Returns:
      A `Discretizer` over the pole task's `angle` (and `angular_velocity`) observations.
    """
    if len(bins) == 1:
        return Discretizer(("angle",), (angle_range,), bins)
    if len(bins) == 2:
        return Discretizer(("angle", "angular_velocity"), (angle_range, velocity_range), bins)
    raise ValueError(f"the pole takes 1 or 2 bin counts, got {bins}")
