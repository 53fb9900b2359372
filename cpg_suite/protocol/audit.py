"""Held-out audit seeds: does a run's card say what it does on seeds nobody has seen?

The 50 test seeds of each tier are public (`protocol.TEST`): a method tuned on them — a
policy that recognises a test seed by its first observation and replays what works
there, a search that selected on them — scores better on its card than on the tier at
large, and the card alone cannot show it. `verify --audit` scores every run again on
seeds drawn at audit time, with fresh entropy, from each tier's seed distribution, outside
every published range (`AUDIT_SEEDS`: above the training, validation and test ranges),
and compares.

What it expects. A tier's episode is a function of its seed alone, and every seed draws
the tier's perturbations from the same distribution: the card's trials on the 50 test
seeds and the audit's on fresh ones are draws of one distribution, if the method never
saw the test seeds. So the card's success-weighted distance less the audit's, per tier
and run, has mean 0. A configuration's gap is that difference averaged over its runs and
tiers; its 99 % interval is a percentile bootstrap over trials, resampled within each run
and tier (both the card's and the audit's, `GAP_DRAWS` draws from a fixed generator, so a
given audit's numbers are reproducible). "card above audit" when the interval lies above
0: the card is better than the tier, as a method trained on the test seeds would be;
"card below audit" when it lies below (the test seeds were hard ones: no harm); else
"consistent". At 99 %, an honest configuration is flagged by chance once in 200 audits
(one side).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from cpg_suite import protocol

# Fresh seeds come from here: above every published range (training, validation, test).
AUDIT_SEEDS = range(protocol.TEST.stop + 1_000_000, 2**31 - 1)
GAP_DRAWS = 2000  # bootstrap draws for a gap's interval
LEVEL = 0.99  # the interval's level


def draw_seeds(n: int, entropy: int) -> list[int]:
    """n distinct audit seeds drawn from `AUDIT_SEEDS` with the audit's entropy."""
    rng = np.random.default_rng(np.random.SeedSequence(entropy))
    seeds: list[int] = []
    while len(seeds) < n:
        seed = int(rng.integers(AUDIT_SEEDS.start, AUDIT_SEEDS.stop))
        if seed not in seeds:
            seeds.append(seed)
    return seeds


def scores(trials: list[dict]) -> dict[str, np.ndarray]:
    """Per tier, each trial's success-weighted distance (0 for a failed trial), m."""
    out: dict[str, list[float]] = {}
    for t in trials:
        out.setdefault(t["tier"], []).append(0.0 if t["fell"] else float(t["distance_m"]))
    return {tier: np.array(v) for tier, v in out.items()}


@dataclasses.dataclass(frozen=True)
class Gap:
    """A configuration's card less its audit (`gap`).

    Attributes:
      card_m, audit_m: Their success-weighted distances, averaged over runs and tiers.
      gap_m: card_m − audit_m.
      low_m, high_m: The gap's `LEVEL` interval.
      verdict: "consistent", "card above audit" or "card below audit".
    """

    card_m: float
    audit_m: float
    gap_m: float
    low_m: float
    high_m: float
    verdict: str

    def text(self) -> str:
        """One phrase: the two scores, the gap with its interval, the verdict."""
        level = f"{LEVEL:.0%}"
        return (
            f"card {self.card_m:.2f} m, audit {self.audit_m:.2f} m: gap {self.gap_m:+.2f} "
            f"[{self.low_m:+.2f}, {self.high_m:+.2f}] ({level}): {self.verdict}"
        )


def gap(pairs: list[tuple[dict, dict]]) -> Gap:
    """The gap between cards and audits over a configuration's runs.

    Args:
      pairs: Per run, (card scores, audit scores), each {tier: array} (`scores`).

    Returns:
      The `Gap`.
    """
    cells = [(card[t], audit[t]) for card, audit in pairs for t in card if t in audit]
    point = float(np.mean([c.mean() - a.mean() for c, a in cells]))
    card_m = float(np.mean([c.mean() for c, _ in cells]))
    audit_m = float(np.mean([a.mean() for _, a in cells]))
    rng = np.random.default_rng(0)
    draws = np.zeros(GAP_DRAWS)
    for c, a in cells:
        draws += c[rng.integers(0, len(c), (GAP_DRAWS, len(c)))].mean(axis=1)
        draws -= a[rng.integers(0, len(a), (GAP_DRAWS, len(a)))].mean(axis=1)
    draws /= len(cells)
    low, high = np.quantile(draws, [(1 - LEVEL) / 2, (1 + LEVEL) / 2])
    verdict = "card above audit" if low > 0 else "card below audit" if high < 0 else "consistent"
    return Gap(card_m, audit_m, point, float(low), float(high), verdict)
