"""Re-scoring trials drawn at the time of checking: what catches an edited trial table.

The board admits a run whose trial table produces its card (`admission`), so a forger who
edits trials and rebuilds the card with the board's own arithmetic passes the board; only
scoring the gait or policy again finds it. `verify --sample=K` re-scores K trials of every
run, drawn uniformly without replacement from its card's tiers × test seeds with fresh
entropy (the operating system's, not derived from the run's files or the commit; logged,
so that a failure can be replayed with `--entropy`), and compares each with the table.

How likely a forgery is caught. A run's card pools N trials (4 tiers × 50 seeds = 200).
Its score, the success-weighted distance, is their mean, and admission refuses a trial
that claims more than `MAX_TRIAL_DISTANCE_M`; so moving the card by δ metres takes at
least m = ⌈δ N / MAX_TRIAL_DISTANCE_M⌉ edited trials, and one check of K trials misses
every one of them with probability C(N − m, K) / C(N, K) (`detection_probability`). At
K = 20: δ = 0.5 m (m ≥ 4) is caught with probability ≥ 0.34 per check, δ = 1 m (m ≥ 7)
≥ 0.52, δ = 2 m (m ≥ 13) ≥ 0.75 (K = 10, CI's: ≥ 0.18, 0.30, 0.49); the forgery
that added 0.5 m to every trial that did not fail (m ≈ 150) with probability > 1 − 1e-13.
Each check draws anew, so r checks miss with the r-th power of that: CI checks every
admitted run this way on every run.
"""

from __future__ import annotations

import math

import numpy as np

# m: the farthest a 16 s protocol trial may claim to walk (a choice, labelled as such: 2
# m/s for 16 s, 1.7 times the farthest trial any shipped run walked in the simulator, 18.8
# m, a version-1 joints policy exploiting the model, and 9 times the real robot's 0.214
# m/s, docs/darwin_op_model.md). Admission refuses a trial beyond it.
MAX_TRIAL_DISTANCE_M = 32.0
DEFAULT_TRIALS = 20  # trials per run in a sampled check (`verify --sample`'s; CI's: 10)


def fresh_entropy() -> int:
    """128 bits from the operating system (`numpy.random.SeedSequence()`)."""
    return int(np.random.SeedSequence().entropy)


def draw(keys: list[tuple[str, int]], k: int, entropy: int, run: str) -> dict[str, list[int]]:
    """K trials of a run drawn without replacement: {tier: [seed, ...]} in table order.

    Args:
      keys: The run's trials as (tier, seed), in its table's order.
      k: How many (all if more than there are).
      entropy: The check's entropy (`fresh_entropy`).
      run: The run's name; each run draws apart from the others (from `entropy` and its
        name), so the draw does not depend on which runs are checked or in what order.
    """
    words = [int(b) for b in run.encode()]
    rng = np.random.default_rng(np.random.SeedSequence([entropy, *words]))
    picked = sorted(rng.choice(len(keys), size=min(k, len(keys)), replace=False).tolist())
    chosen: dict[str, list[int]] = {}
    for i in picked:
        tier, seed = keys[i]
        chosen.setdefault(tier, []).append(seed)
    return chosen


def trials_to_move(delta_m: float, n: int = 200) -> int:
    """The fewest edited trials that move an n-trial card's score by `delta_m` metres."""
    return max(1, math.ceil(delta_m * n / MAX_TRIAL_DISTANCE_M - 1e-12))


def detection_probability(edited: int, k: int = DEFAULT_TRIALS, n: int = 200) -> float:
    """The chance that k trials drawn from n include at least one of `edited`."""
    if edited <= 0:
        return 0.0
    if k >= n or edited > n - k:
        return 1.0
    return 1.0 - math.comb(n - edited, k) / math.comb(n, k)


def caught_by_delta(delta_m: float, k: int = DEFAULT_TRIALS, n: int = 200) -> float:
    """The lower bound on catching a forgery that moves a card by `delta_m` (one check)."""
    return detection_probability(trials_to_move(delta_m, n), k, n)


def compare(fresh: list[dict], stored: list[dict]) -> list[str]:
    """The sampled trials that differ from the table: one line each (empty: none). A trial
    is compared with its row as `same_trial` says: its outcome, and each gait-quality
    measure the table holds (the card's medians are made from those)."""
    table = {(t["tier"], t["seed"]): t for t in stored}
    return [
        f"{t['tier']} seed {t['seed']} differs from trials.csv"
        for t in fresh
        if (t["tier"], t["seed"]) not in table or not same_trial(t, table[t["tier"], t["seed"]])
    ]


def same_trial(fresh: dict, stored: dict) -> bool:
    """Whether a trial scored again is the one a table holds: the same outcome, and, where
    the table holds gait-quality measures, the same value of each (a table made before
    tables held them vouches for the outcome only: the board shows no medians of it,
    `admission.verified_summary`)."""
    if _outcome(fresh) != _outcome(stored):
        return False
    if "quality" not in stored:
        return True
    made = fresh.get("quality") or {}
    return all(name in made and made[name] == v for name, v in stored["quality"].items())


def _outcome(trial: dict) -> dict:
    return {k: v for k, v in trial.items() if k != "quality"}
