"""Verdicts of the study's claims and the statistics they rest on.

A verdict is one of `VERDICTS`: a claim holds, fails (tested in the thesis' setting, it
does not hold), is not reproduced here (it does not hold here, and the outcome turns on
something the thesis does not give or on a named, measured difference between our model
and the thesis': `readings.NOT_REPRODUCED` says which; or it rests on a precondition our runs
do not meet, whatever its rule gives: `readings.PRECONDITION`), is mixed (its parts differ),
inconclusive (the intervals do not decide), or is not testable here (with the reason).
Comparisons over seeds use the bootstrap of `cpg_suite.protocol.aggregate` (a fixed
generator seed, so a verdict is the same bits every time).
"""

from __future__ import annotations

import dataclasses
from collections import Counter
from collections.abc import Sequence

import numpy as np

from cpg_suite.protocol import aggregate

HOLDS, FAILS, NOT_REPRODUCED, MIXED, INCONCLUSIVE, UNTESTABLE = (
    "holds",
    "fails",
    "not reproduced here",
    "mixed",
    "inconclusive",
    "not testable here",
)
VERDICTS = (HOLDS, FAILS, NOT_REPRODUCED, MIXED, INCONCLUSIVE, UNTESTABLE)
UNTESTED = "untested"  # a testable claim without a rule yet (the goal: none)


@dataclasses.dataclass(frozen=True)
class Verdict:
    """A claim's verdict, the evidence it rests on (one line), and why it failed or could
    not be tested (one line, empty where it holds)."""

    verdict: str
    evidence: str
    why: str = ""

    def __post_init__(self):
        if self.verdict not in VERDICTS:
            raise ValueError(f"unknown verdict {self.verdict!r}; valid: {', '.join(VERDICTS)}")


def untestable(reason: str) -> Verdict:
    """A claim this project cannot test, with the reason."""
    return Verdict(UNTESTABLE, "", reason)


def mean_interval(values: Sequence[float]) -> tuple[float, float, float]:
    """The mean of per-seed values and its bootstrap 95 % interval."""
    x = np.asarray(values, dtype=np.float64)[:, None]
    low, high = aggregate.interval(x, aggregate.mean)
    return float(x.mean()), low, high


def difference_interval(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float]:
    """mean(a) − mean(b) over independent seeds and its bootstrap 95 % interval (a's and
    b's seeds resampled independently, the generator seeded as `aggregate`'s)."""
    x, y = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    rng = np.random.default_rng(aggregate.SEED)
    diffs = np.empty(aggregate.RESAMPLES)
    for i in range(aggregate.RESAMPLES):
        diffs[i] = rng.choice(x, x.size).mean() - rng.choice(y, y.size).mean()
    low, high = np.percentile(diffs, [2.5, 97.5])
    return float(x.mean() - y.mean()), float(low), float(high)


def _above_zero(text: str, low: float, high: float) -> Verdict:
    """Holds if [low, high] lies above 0, fails if below, else inconclusive."""
    if low > 0:
        return Verdict(HOLDS, text)
    if high < 0:
        return Verdict(FAILS, text, "the reverse in our runs")
    return Verdict(INCONCLUSIVE, text, "the interval contains 0")


def greater(a: Sequence[float], b: Sequence[float], label: str) -> Verdict:
    """Holds if the interval of mean(a) − mean(b) lies above 0, fails if below, else
    inconclusive."""
    d, low, high = difference_interval(a, b)
    text = f"{label}: difference {d:+.4g} [{low:+.4g}, {high:+.4g}] (n = {len(a)}, {len(b)})"
    return _above_zero(text, low, high)


def not_greater(a: Sequence[float], b: Sequence[float], label: str) -> Verdict:
    """Holds unless mean(a) is above mean(b) with its interval above 0 (a "does not pay
    off" claim: it fails only when a is clearly better)."""
    d, low, high = difference_interval(a, b)
    text = f"{label}: difference {d:+.4g} [{low:+.4g}, {high:+.4g}] (n = {len(a)}, {len(b)})"
    if low > 0:
        return Verdict(FAILS, text, "clearly better in our runs")
    return Verdict(HOLDS, text)


def similar(a: Sequence[float], b: Sequence[float], label: str, tolerance: float) -> Verdict:
    """Holds if the interval of mean(a) − mean(b) lies within ±tolerance, fails if it
    excludes 0, else inconclusive."""
    d, low, high = difference_interval(a, b)
    text = (
        f"{label}: difference {d:+.4g} [{low:+.4g}, {high:+.4g}], tolerance ±{tolerance:.4g} "
        f"(n = {len(a)}, {len(b)})"
    )
    if -tolerance <= low and high <= tolerance:
        return Verdict(HOLDS, text)
    if low > 0 or high < 0:
        return Verdict(FAILS, text, "the two differ in our runs")
    return Verdict(INCONCLUSIVE, text, "the interval is wider than the tolerance")


def majority(flags: Sequence[bool], label: str) -> Verdict:
    """Holds if at least 4 in 5 seeds show it, fails if at most 1 in 5 do, else
    inconclusive (over n seeds: ≥ 0.8 n and ≤ 0.2 n)."""
    k, n = int(sum(bool(f) for f in flags)), len(flags)
    return split(
        flags,
        [not f for f in flags],
        f"{label}: {k} of {n} seeds",
        "it does not happen in our runs",
    )


def split(holds: Sequence[bool], fails: Sequence[bool], text: str, why: str) -> Verdict:
    """A claim judged seed by seed against two thresholds: holds if at least 4 in 5 seeds
    meet the claim's (`holds`), fails if at least 4 in 5 meet the opposite one (`fails`,
    with `why`), else inconclusive: the seeds split."""
    if sum(bool(h) for h in holds) >= 0.8 * len(holds):
        return Verdict(HOLDS, text)
    if sum(bool(f) for f in fails) >= 0.8 * len(fails):
        return Verdict(FAILS, text, why)
    return Verdict(INCONCLUSIVE, text, "the seeds split")


def combine(parts: Sequence[Verdict]) -> str:
    """A compound claim's verdict from its parts' (the untestable parts left out): holds,
    fails or not reproduced here if all agree; fails where some parts fail and the others
    are not reproduced here (a failure in the thesis' setting decides); mixed if some hold
    and others fail or are not reproduced here; inconclusive otherwise."""
    tested = {p.verdict for p in parts if p.verdict != UNTESTABLE}
    if not tested:
        return UNTESTABLE
    if len(tested) == 1 and tested <= {HOLDS, FAILS, NOT_REPRODUCED}:
        return next(iter(tested))
    if tested == {FAILS, NOT_REPRODUCED}:
        return FAILS
    if HOLDS in tested and tested & {FAILS, NOT_REPRODUCED}:
        return MIXED
    if MIXED in tested:
        return MIXED
    return INCONCLUSIVE


def all_of(parts: Sequence[Verdict]) -> str:
    """One criterion made of several comparisons: holds if every one holds, fails if any
    fails, inconclusive otherwise."""
    found = {p.verdict for p in parts}
    if found == {HOLDS}:
        return HOLDS
    if FAILS in found:
        return FAILS
    return INCONCLUSIVE


def paired_interval(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float]:
    """The mean of the per-seed differences a − b (runs paired by seed) and its bootstrap
    95 % interval."""
    d = np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)
    return mean_interval(d)


def paired_greater(a: Sequence[float], b: Sequence[float], label: str) -> Verdict:
    """Holds if the interval of the mean paired difference a − b lies above 0, fails if
    below, else inconclusive."""
    d, low, high = paired_interval(a, b)
    return _above_zero(f"{label}: {d:+.4g} [{low:+.4g}, {high:+.4g}] (n = {len(a)})", low, high)


def paired_similar(a: Sequence[float], b: Sequence[float], label: str, tolerance: float) -> Verdict:
    """Holds if the interval of the mean paired difference lies within ±tolerance, fails if
    it lies entirely outside, else inconclusive."""
    d, low, high = paired_interval(a, b)
    text = f"{label}: {d:+.4g} [{low:+.4g}, {high:+.4g}] within ±{tolerance:.4g}? (n = {len(a)})"
    if -tolerance <= low and high <= tolerance:
        return Verdict(HOLDS, text)
    if low > tolerance or high < -tolerance:
        return Verdict(FAILS, text, "the two differ in our runs")
    return Verdict(INCONCLUSIVE, text, "the interval reaches past the tolerance")


def within(low: float, high: float, lo: float, hi: float, label: str) -> Verdict:
    """Holds if the interval [low, high] lies inside [lo, hi], fails if it lies entirely
    outside, else inconclusive."""
    text = f"{label} [{low:.4g}, {high:.4g}], stated range [{lo:g}, {hi:g}]"
    if lo <= low and high <= hi:
        return Verdict(HOLDS, text)
    if high < lo or low > hi:
        return Verdict(FAILS, text, "outside the stated range in our runs")
    return Verdict(INCONCLUSIVE, text, "the interval reaches past the stated range")


def joined(parts: Sequence[Verdict], label: str = "") -> Verdict:
    """One verdict from the comparisons of one criterion (`all_of`), their evidence and
    reasons joined."""
    why = "; ".join(p.why for p in parts if p.why and p.verdict != HOLDS)
    text = "; ".join(p.evidence for p in parts)
    return Verdict(all_of(parts), f"{label}: {text}" if label else text, why)


# --- counting a study's verdicts (claims.csv rows) ----------------------------------------


def counts(claims: list[dict]) -> Counter:
    """Verdicts of the whole claims (parts counted through their whole)."""
    return Counter(c["verdict"] for c in claims if not c["parent"])


def leaves(claims: list[dict]) -> Counter:
    """Verdicts of what a rule judges: the parts, and the claims without parts."""
    wholes = {c["parent"] for c in claims if c["parent"]}
    return Counter(c["verdict"] for c in claims if c["id"] not in wholes)


def tally(found: Counter) -> str:
    """'8 fails, 38 holds, ...' in the order of `VERDICTS` (then any other)."""
    order = [*VERDICTS, UNTESTED]
    return ", ".join(f"{found[k]} {k}" for k in sorted(found, key=order.index) if found[k])
