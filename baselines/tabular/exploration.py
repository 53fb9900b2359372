"""ε-greedy action selection and ε schedules (thesis Sec. 4.1.4, 4.1.7)."""

from __future__ import annotations

import numpy as np


class EpsilonSchedule:
    """ε as a piecewise-linear function of the step count.

    `EpsilonSchedule([(0, 0.9), (100, 0.9), (300, 0.0)])` is the study's real-time
    schedule: 0.9 for the first 100 steps, falling linearly to 0 at step 300 (the shape
    between 100 and 300 is not given by the study; linear is our reading). Before the first
    point ε is the first value, after the last point the last value.
    """

    def __init__(self, points):
        """Args:
          points: Sequence of `(step, epsilon)` with strictly increasing steps and each
            epsilon in [0, 1].

        Raises:
          ValueError: On an empty list, unordered steps or an ε outside [0, 1].
        """
        pts = [(float(s), float(e)) for s, e in points]
        if not pts:
            raise ValueError("an ε schedule needs at least one (step, epsilon) point")
        steps = [s for s, _ in pts]
        if any(b <= a for a, b in zip(steps, steps[1:])):
            raise ValueError(f"ε schedule steps must increase strictly, got {steps}")
        if any(not 0.0 <= e <= 1.0 for _, e in pts):
            raise ValueError(f"ε values must lie in [0, 1], got {[e for _, e in pts]}")
        self._steps = np.array(steps)
        self._values = np.array([e for _, e in pts])

    @classmethod
    def constant(cls, epsilon: float) -> EpsilonSchedule:
        """A constant ε."""
        return cls([(0, epsilon)])

    @classmethod
    def parse(cls, text: str) -> EpsilonSchedule:
        """Parses `"0.1"` (constant) or `"0:0.9,100:0.9,300:0"` (step:epsilon points).

        Raises:
          ValueError: If the text is malformed.
        """
        text = str(text).strip()
        try:
            if ":" not in text:
                return cls.constant(float(text))
            points = []
            for item in text.split(","):
                step, eps = item.split(":")
                points.append((float(step), float(eps)))
        except ValueError as e:
            if "ε" in str(e):
                raise
            raise ValueError(
                f"malformed ε schedule {text!r}; use a number like 0.1 or "
                "step:epsilon points like 0:0.9,100:0.9,300:0"
            ) from None
        return cls(points)

    def __call__(self, step: int) -> float:
        return float(np.interp(step, self._steps, self._values))

    def __repr__(self) -> str:
        pts = ",".join(f"{s:g}:{v:g}" for s, v in zip(self._steps, self._values))
        return f"EpsilonSchedule({pts})"


def argmax_ties(values: np.ndarray, rng: np.random.RandomState | None = None, order=None) -> int:
    """Index of a maximum of `values` (−inf marks disallowed entries).

    Args:
      values: 1-D array.
      rng: If given, ties are broken uniformly at random with it.
      order: Otherwise, ties go to the first maximiser in this index order (default:
        ascending index).

    Returns:
      The chosen index.
    """
    best = values.max()
    if rng is not None:
        candidates = np.flatnonzero(values == best)
        if len(candidates) == 1:
            return int(candidates[0])
        return int(candidates[rng.randint(len(candidates))])
    if order is None:
        return int(np.argmax(values))
    for a in order:
        if values[a] == best:
            return int(a)
    raise ValueError("order does not cover the maximising index")


def epsilon_greedy(
    values: np.ndarray,
    epsilon: float,
    rng: np.random.RandomState,
    allowed: np.ndarray | None = None,
    order=None,
    random_ties: bool = True,
) -> int:
    """ε-greedy choice over `values` (thesis Sec. 4.1.4).

    With probability ε a uniformly random allowed action, otherwise a greedy one.

    Args:
      values: Action values for the current state.
      epsilon: Exploration probability in [0, 1].
      rng: Random generator (the only source of randomness).
      allowed: Boolean mask of allowed actions (default: all).
      order: Tie order when `random_ties` is False.
      random_ties: Break greedy ties at random (default) or by `order`.

    Returns:
      The action index.
    """
    if allowed is not None:
        values = np.where(allowed, values, -np.inf)
    if epsilon > 0.0 and rng.uniform() < epsilon:
        choices = np.flatnonzero(allowed) if allowed is not None else np.arange(len(values))
        return int(choices[rng.randint(len(choices))])
    return argmax_ties(values, rng if random_ties else None, order)
