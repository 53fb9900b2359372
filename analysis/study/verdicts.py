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
import math
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


# Values within this of 0 are 0: a mean of per-seed differences that are all 0 or of one
# sign can land a bootstrap end at ±1e-15 by float rounding (CR-9a's +3.2e-15; the second
# reading of 2026-11-27).
ZERO = 1e-12


def _snap(*values: float) -> tuple[float, ...]:
    return tuple(0.0 if abs(x) < ZERO else float(x) for x in values)


def mean_interval(values: Sequence[float]) -> tuple[float, float, float]:
    """The mean of per-seed values and its bootstrap 95 % interval (within `ZERO` of 0: 0)."""
    x = np.asarray(values, dtype=np.float64)[:, None]
    low, high = aggregate.interval(x, aggregate.mean)
    return _snap(float(x.mean()), low, high)


def difference_interval(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float]:
    """mean(a) − mean(b) over independent seeds and its bootstrap 95 % interval (a's and
    b's seeds resampled independently, the generator seeded as `aggregate`'s; within `ZERO`
    of 0: 0)."""
    x, y = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    rng = np.random.default_rng(aggregate.SEED)
    diffs = np.empty(aggregate.RESAMPLES)
    for i in range(aggregate.RESAMPLES):
        diffs[i] = rng.choice(x, x.size).mean() - rng.choice(y, y.size).mean()
    low, high = np.percentile(diffs, [2.5, 97.5])
    return _snap(float(x.mean() - y.mean()), float(low), float(high))


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


def one_run(flags: Sequence[bool], label: str) -> Verdict:
    """An event the thesis reports of its one run ("a quiet spell around iteration 12 000",
    "the mean falls in round 3"), not of its setting: holds if at least 4 in 5 seeds show
    it; else inconclusive, since seeds without it do not show that one run could not: the
    95 % upper bound of its rate from k of n seeds is said (the second reading of
    2026-11-27)."""
    k, n = int(sum(bool(f) for f in flags)), len(flags)
    text = f"{label}: {k} of {n} seeds"
    if k >= 0.8 * n:
        return Verdict(HOLDS, text)
    bound = _rate_bound(k, n)
    return Verdict(
        INCONCLUSIVE,
        text,
        f"one run's event: {k} of {n} seeds put its rate below {bound * 100:.0f} % (95 %), "
        "which the thesis' single run showing it does not contradict",
    )


def fisher_greater(k_a: int, n_a: int, k_b: int, n_b: int) -> float:
    """One-sided Fisher exact test that group a's rate exceeds group b's: the chance, with
    the k_a + k_b events shared out at random over the n_a + n_b runs, that a gets at least
    k_a of them (the hypergeometric upper tail)."""
    events, runs = k_a + k_b, n_a + n_b
    tail = sum(
        math.comb(events, i) * math.comb(runs - events, n_a - i)
        for i in range(k_a, min(events, n_a) + 1)
    )
    return tail / math.comb(runs, n_a)


def pooled_event(flags: Sequence[bool], theirs: int, their_runs: int, label: str) -> Verdict:
    """An event the thesis saw in `theirs` of its `their_runs` runs, against our runs
    (`flags`): holds if at least 4 in 5 of ours show it; fails if the thesis' count is
    beyond what our rate explains (`fisher_greater` below 0.05); else inconclusive (added
    after the seventh reading of 2026-11-29: one run's event pooled over the runs the
    thesis reports it of)."""
    k, n = int(sum(bool(f) for f in flags)), len(flags)
    p = fisher_greater(theirs, their_runs, k, n)
    text = f"{label}: ours {k} of {n} runs, the thesis' {theirs} of {their_runs} (Fisher p {p:.3f})"
    if k >= 0.8 * n:
        return Verdict(HOLDS, text)
    if p < 0.05:
        return Verdict(FAILS, text, f"the thesis' {theirs} of {their_runs} is unlikely at our rate")
    return Verdict(INCONCLUSIVE, text, "our runs' rate does not rule out the thesis' count")


def _rate_bound(k: int, n: int) -> float:
    """The exact (Clopper-Pearson) one-sided 95 % upper bound of a rate seen k of n times."""
    if k >= n:
        return 1.0
    lo, hi = k / n, 1.0
    for _ in range(60):  # bisection on P(X ≤ k | rate) = 0.05
        mid = (lo + hi) / 2
        tail = sum(_binom(n, i) * mid**i * (1 - mid) ** (n - i) for i in range(k + 1))
        lo, hi = (mid, hi) if tail > 0.05 else (lo, mid)
    return hi


def _binom(n: int, k: int) -> int:
    from math import comb

    return comb(n, k)


def split(holds: Sequence[bool], fails: Sequence[bool], text: str, why: str) -> Verdict:
    """A claim judged seed by seed against two thresholds: holds if at least 4 in 5 seeds
    meet the claim's (`holds`), fails if at least 4 in 5 meet the opposite one (`fails`,
    with `why`), else inconclusive: the seeds split."""
    if sum(bool(h) for h in holds) >= 0.8 * len(holds):
        return Verdict(HOLDS, text)
    if sum(bool(f) for f in fails) >= 0.8 * len(fails):
        return Verdict(FAILS, text, why)
    return Verdict(INCONCLUSIVE, text, "the seeds split")


# The whole claims' criterion, as `combine` applies it (the catalog's wholes say it; revised
# after the second reading of 2026-11-27, where their text said "holds if every part holds,
# fails if every part fails, mixed otherwise" and a part that failed beside an inconclusive
# one left the whole inconclusive).
COMBINED = (
    "from its parts, the parts not testable here left out (a whole that holds without them "
    "holds in part, naming them): holds, fails or not reproduced here if every part does; "
    "fails if some part fails and none holds (the others inconclusive or not reproduced "
    "here); mixed if some parts hold and others fail or are not reproduced here; "
    "inconclusive otherwise"
)


def combine(parts: Sequence[Verdict]) -> str:
    """A compound claim's verdict from its parts' (`COMBINED`): the untestable parts left
    out; holds, fails or not reproduced here if all agree; fails where some part fails and
    none holds (a failure in the thesis' setting decides; the others are inconclusive or
    not reproduced here); mixed if some hold and others fail or are not reproduced here;
    inconclusive otherwise."""
    tested = {p.verdict for p in parts if p.verdict != UNTESTABLE}
    if not tested:
        return UNTESTABLE
    if len(tested) == 1 and tested <= {HOLDS, FAILS, NOT_REPRODUCED}:
        return next(iter(tested))
    if HOLDS in tested and tested & {FAILS, NOT_REPRODUCED}:
        return MIXED
    if MIXED in tested:
        return MIXED
    if FAILS in tested:
        return FAILS
    return INCONCLUSIVE


def combine_as_first_written(parts: Sequence[Verdict]) -> str:
    """`combine` before the second reading of 2026-11-27: a part that failed beside
    inconclusive ones (and no part that held) left the whole inconclusive."""
    tested = {p.verdict for p in parts if p.verdict != UNTESTABLE}
    if FAILS in tested and not tested & {HOLDS, MIXED} and INCONCLUSIVE in tested:
        return INCONCLUSIVE
    return combine(parts)


def in_part(parts: dict[str, Verdict]) -> str:
    """'holds in part (X not testable here)' for a whole that holds with its untestable
    parts left out, else ''."""
    left = [k for k, p in parts.items() if p.verdict == UNTESTABLE]
    if not left or combine(list(parts.values())) != HOLDS:
        return ""
    return f"{HOLDS} in part ({', '.join(left)} not testable here)"


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
