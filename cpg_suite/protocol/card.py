"""A score card's statistics, and what makes a card the protocol's — no simulation here.

`summarize` turns a tier's trials (distances, failures, causes, gait-quality arrays) into
the card's row; `cpg_suite.protocol.score` makes cards with it, and the leaderboard's
admission (`cpg_suite.protocol.admission`) makes a stored card's rows again from its
`trials.csv` with the same arithmetic, to check that the trials still produce the card.

A card is the protocol's (docs/protocol.md#score-card) when it was scored on every test
tier in the protocol's order, on all 50 test seeds, with 1000-step trials, and (from
version 2) with the supply limit's 1 s window. `deviations` says what else a card was
made with; `score` marks such a card (`PROTOCOL_KEY`, `DEVIATIONS_KEY`) and prints it on
the card's first line.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from cpg_suite import electrical, protocol

TRIAL_STEPS = 1000  # control steps of a protocol trial (16 s)
# s: `cpg_suite.darwin.CONTROL_TIMESTEP`, the one definition; this module imports no
# simulation code, and tests/test_admission.py checks that the two agree.
CONTROL_TIMESTEP = 0.016
PHYSICS_STEPS_PER_CONTROL_STEP = 8  # the DARwIn-OP model's 2 ms physics step (checked too)
# The keys a non-protocol card gains (a protocol card has neither: cards made before the
# marking stay as they were): `False`, and the list of what differs from the protocol.
PROTOCOL_KEY, DEVIATIONS_KEY = "protocol", "not_protocol"
_BOOTSTRAP_RESAMPLES = 2000
_BOOTSTRAP_SEED = 0


def _interval(values: np.ndarray, statistic) -> list[float]:
    if len(values) < 2 or np.all(values == values[0]):
        value = float(statistic(values)) if len(values) else float("nan")
        return [value, value]
    result = stats.bootstrap(
        (values,),
        statistic,
        confidence_level=0.95,
        n_resamples=_BOOTSTRAP_RESAMPLES,
        method="percentile",
        random_state=np.random.default_rng(_BOOTSTRAP_SEED),
    )
    return [float(result.confidence_interval.low), float(result.confidence_interval.high)]


def _iqm(values, axis=-1):
    return stats.trim_mean(values, 0.25, axis=axis)


def summarize(
    distance: np.ndarray, fell: np.ndarray, quality: dict, cause: np.ndarray | None = None
) -> dict:
    """The statistics of one tier's (or the pooled) trials.

    Args:
      distance: (n,) forward distances, m.
      fell: (n,) failure flags (a fall or, from version 2, a brown-out).
      quality: (n,) arrays of `cpg_suite.evaluation.quality.FIELDS` (may be empty).
      cause: (n,) why each trial ended early (`open_loop.FALL`, `BROWNOUT`; 0: it did not).

    Returns:
      `success_weighted_distance_m`, `fall_rate` (the failures, whatever their cause),
      `failures_by_cause` (the share of trials per cause), `distance_m` (mean, median,
      iqm) with 95 % intervals, `quality` medians, and `n`. (`score` adds `speed_m_s`.)
    """
    distance, fell = np.asarray(distance, float), np.asarray(fell, bool)
    success = np.where(fell, 0.0, distance)
    falls = int(fell.sum())
    wilson = stats.binomtest(falls, len(fell)).proportion_ci(0.95, method="wilson")
    return {
        "n": len(distance),
        "success_weighted_distance_m": {
            "mean": float(success.mean()),
            "ci95": _interval(success, np.mean),
        },
        "fall_rate": {"value": falls / len(fell), "ci95": [wilson.low, wilson.high]},
        "failures_by_cause": {
            c: float(np.mean(cause == i + 1)) if cause is not None else None
            for i, c in enumerate(electrical.CAUSES)
        },
        "distance_m": {
            "mean": float(distance.mean()),
            "ci95": _interval(distance, np.mean),
            "median": float(np.median(distance)),
            "iqm": float(_iqm(distance)),
            "iqm_ci95": _interval(distance, _iqm),
        },
        "quality": medians(quality),
    }


def medians(quality: dict) -> dict:
    """The card's gait-quality medians: each measure's median over the trials that have it
    (NaN: a trial without), None where no trial has a finite value.

    Args:
      quality: (n,) arrays of `cpg_suite.evaluation.quality.FIELDS` (may be empty).

    Returns:
      {measure: float or None}, in the order given.
    """
    return {f: float(np.nanmedian(v)) if np.isfinite(v).any() else None for f, v in quality.items()}


def row(
    distance: np.ndarray,
    fell: np.ndarray,
    quality: dict,
    cause: np.ndarray | None,
    steps: int,
) -> dict:
    """A card's row: `summarize` and the speed, the success-weighted distance over the
    trial's duration.

    Args:
      distance, fell, quality, cause: As `summarize`.
      steps: Control steps per trial.

    Returns:
      The row, with `speed_m_s`.
    """
    summary = summarize(distance, fell, quality, cause)
    summary["speed_m_s"] = summary["success_weighted_distance_m"]["mean"] / (
        steps * CONTROL_TIMESTEP
    )
    return summary


def deviations(
    tiers: tuple[str, ...],
    seeds: int,
    steps: int,
    benchmark_version: int,
    supply_window: float = electrical.SUPPLY_WINDOW,
) -> list[str]:
    """What makes score settings other than the protocol's card settings.

    Args:
      tiers: The test tiers scored, in order (the version's: `protocol.tiers`).
      seeds: Test seeds per tier.
      steps: Control steps per trial.
      benchmark_version: The version scored under (its supply limit).
      supply_window: The supply limit's averaging window, s (version ≥ 2).

    Returns:
      One phrase per difference, in a fixed order; empty for the protocol's settings.
    """
    found = []
    tiers = tuple(tiers)
    known = benchmark_version in protocol.VERSIONS
    expected = protocol.tiers(benchmark_version) if known else protocol.TIERS
    missing = [t for t in expected if t not in tiers]
    extra = [t for t in tiers if t not in expected]
    if missing:
        found.append(f"tiers left out: {', '.join(missing)}")
    elif extra:
        found.append(f"tiers not of version {benchmark_version}: {', '.join(extra)}")
    elif tiers != expected:
        found.append(f"tiers not in the protocol's order ({', '.join(expected)})")
    if seeds != len(protocol.TEST):
        found.append(f"{seeds} of the {len(protocol.TEST)} test seeds")
    if steps != TRIAL_STEPS:
        found.append(f"{steps}-step trials (the protocol's: {TRIAL_STEPS})")
    if benchmark_version not in protocol.VERSIONS:
        found.append(f"unknown benchmark version {benchmark_version!r}")
    elif benchmark_version >= 2 and float(supply_window) != electrical.SUPPLY_WINDOW:
        found.append(
            f"supply window {supply_window:g} s (version {benchmark_version}'s: "
            f"{electrical.SUPPLY_WINDOW:g} s)"
        )
    return found


def card_deviations(card: dict, infer_steps: bool = True) -> list[str]:
    """What makes a card (made by `score`, or stored by a run) other than the protocol's.

    A card's own marking (`DEVIATIONS_KEY`) if it has one; else its settings, if it keeps
    them (a `score --out` card); else what the card shows of itself: its tiers, the trials
    per tier, and the trial length its speed implies (success-weighted distance over
    speed; where both are 0 it says nothing).

    Args:
      card: A score card.
      infer_steps: Whether to infer the trial length from the speed (else it is taken as
        the protocol's: the admission checks the speed against the trials instead).

    Returns:
      One phrase per difference; empty for a protocol card.
    """
    if card.get(DEVIATIONS_KEY):
        return [str(d) for d in card[DEVIATIONS_KEY]]
    if card.get(PROTOCOL_KEY) is False:
        return ["marked as not the protocol's card"]
    version = card.get("benchmark_version", 1)
    settings = card.get("settings")
    if isinstance(settings, dict):
        return deviations(
            tuple(settings.get("tiers", ())),
            settings.get("seeds"),
            settings.get("steps"),
            version,
            settings.get("supply_window", electrical.SUPPLY_WINDOW),
        )
    tiers = tuple(card.get("tiers") or ())
    counts = {t.get("n") for t in (card.get("tiers") or {}).values() if isinstance(t, dict)}
    if len(counts) != 1:
        return ["tiers of unequal numbers of trials"]
    steps = implied_steps(card) if infer_steps else TRIAL_STEPS
    return deviations(tiers, counts.pop(), steps, version)


def implied_steps(card: dict) -> int:
    """The trial length a card's pooled speed implies (`TRIAL_STEPS` where it cannot tell).

    Args:
      card: A score card (or a row of one: its `all` is used if it has one).
    """
    pooled = card.get("all") or card
    speed = pooled.get("speed_m_s")
    mean = (pooled.get("success_weighted_distance_m") or {}).get("mean")
    if not isinstance(speed, (int, float)) or not isinstance(mean, (int, float)) or not speed:
        return TRIAL_STEPS
    return int(round(mean / speed / CONTROL_TIMESTEP))


def is_protocol(card: dict) -> bool:
    """Whether a card was made under the protocol's card settings (`card_deviations`)."""
    return not card_deviations(card)


def extends(fresh, stored) -> bool:
    """Whether a fresh card (or part of one) holds every value of a stored one, equal: it
    may add keys (a measure the card gained since), never change one.

    Args:
      fresh, stored: Cards, their rows, or values.
    """
    if isinstance(stored, dict):
        return isinstance(fresh, dict) and all(
            k in fresh and extends(fresh[k], v) for k, v in stored.items()
        )
    return fresh == stored
