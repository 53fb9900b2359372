"""The benchmark protocol's seeds and tiers (docs/protocol.md).

A seed is the task's `random`: it fixes the initial posture and, on the perturbed tiers,
the episode's physical parameters, pushes or ground. Three disjoint ranges:

* training (0 .. 999,999): what optimizers and learners may draw from;
* validation (1,000,000 .. 1,999,999): selection of the gait a run reports, learning curves;
* test (2,000,000 .. 2,000,049): the score, the same 50 seeds on every tier.

Training code refuses validation and test seeds (`check_training`).

The benchmark has versions (`VERSIONS`); every score card records the one it was scored
under, and `verify` re-scores a shipped run under its card's version.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable

import numpy as np

from cpg_suite import electrical

# What each version of the benchmark asks of a gait, beyond walking without falling.
VERSIONS = {
    1: "the study's physics: no electrical limit (cards made before 2026-11-26)",
    2: "the DARwIn-OP's supply: a mean current over 10 A in the last second browns the "
    "servos out and ends the trial like a fall (cpg_suite.electrical)",
    3: "version 2 and a fifth test tier, darwin_walk_contact: the floor's friction and "
    "softness drawn per episode over what real floors and soles span (docs/contact.md)",
}
BENCHMARK_VERSION = 3  # the version new cards are scored under
# The version whose training physics each version has (its tasks, supply): a run trained
# under either trained alike. Version 3 adds a test tier only.
_TRAINED_AS = {1: 1, 2: 2, 3: 2}


def require_version(version: int) -> None:
    """Raises ValueError naming the flag unless `version` is a key of `VERSIONS`.

    Args:
      version: A `--benchmark_version` setting.

    Raises:
      ValueError: On an unknown version.
    """
    if version not in VERSIONS:
        raise ValueError(f"--benchmark_version must be one of {sorted(VERSIONS)}, got {version!r}")


def trained_alike(version: int) -> int:
    """The version whose training physics `version` has: two runs trained under versions
    with the same answer trained under the same tasks and supply (they are compared as
    copies, and ranked on each other's boards).

    Args:
      version: A key of `VERSIONS`.

    Raises:
      ValueError: On an unknown version.
    """
    require_version(version)
    return _TRAINED_AS[version]


def scored_alike(old: int, new: int) -> tuple[str, ...]:
    """The tiers whose trials a card under `old` and one under `new` score alike: those
    both versions have, where their physics is the same (`trained_alike`: the versions
    differ in the supply limit or only by a tier added). A run re-scored from `old` to
    `new` holds the same trials on these tiers in both tables (`verify.upgrade_run`).

    Args:
      old, new: Keys of `VERSIONS`.

    Raises:
      ValueError: On an unknown version.
    """
    if trained_alike(old) != trained_alike(new):
        return ()
    return tuple(t for t in tiers(old) if t in tiers(new))


def tiers(version: int = BENCHMARK_VERSION) -> tuple[str, ...]:
    """The test tiers of a benchmark version's score card, in the card's order.

    Args:
      version: A key of `VERSIONS`.

    Raises:
      ValueError: On an unknown version.
    """
    require_version(version)
    return TIERS if version >= 3 else TIERS[:4]


def card_tiers(run_tiers: Iterable[str] | None, version: int) -> tuple[str, ...]:
    """The tiers a run's card under `version` scores: the version's own where the run was
    set to score an earlier version's full list (or set nothing), else the run's setting
    (a deviation, kept as it is).

    Args:
      run_tiers: The run's `test_tiers` setting (None: not set).
      version: The card's benchmark version.
    """
    run_tiers = tuple(run_tiers) if run_tiers is not None else None
    if run_tiers is None or run_tiers in {tiers(v) for v in VERSIONS}:
        return tiers(version)
    return run_tiers


def supply_limit(version: int, window: float = electrical.SUPPLY_WINDOW):
    """The supply's limit of a benchmark version (None: version 1, no limit).

    Args:
      version: A key of `VERSIONS`.
      window: The averaging window, s (`electrical.SupplyLimit`; version ≥ 2).

    Raises:
      ValueError: On an unknown version or a bad window.
    """
    if version not in VERSIONS:
        raise ValueError(f"unknown benchmark version {version!r}; valid: {sorted(VERSIONS)}")
    if version == 1:
        return None
    return dataclasses.replace(electrical.DEFAULT_SUPPLY, window=float(window))


TRAINING = range(0, 1_000_000)
VALIDATION = range(1_000_000, 2_000_000)
TEST = range(2_000_000, 2_000_050)

# The test tiers: the nominal task and the perturbed ones (cpg_suite.perturbations), the
# current version's (`tiers(version)`: versions 1 and 2 have the first four).
TIERS = (
    "darwin_walk",
    "darwin_walk_randomized",
    "darwin_walk_push",
    "darwin_walk_rough",
    "darwin_walk_contact",
)


def validation_seeds(n: int) -> list[int]:
    """The first `n` validation seeds."""
    if not 1 <= n <= len(VALIDATION):
        raise ValueError(f"need 1 ≤ n ≤ {len(VALIDATION)} validation seeds, got {n}")
    return list(VALIDATION[:n])


def held_out_seeds(n: int = len(TEST)) -> list[int]:
    """The first `n` of the 50 test seeds (all of them by default)."""
    if not 1 <= n <= len(TEST):
        raise ValueError(f"need 1 ≤ n ≤ {len(TEST)} test seeds, got {n}")
    return list(TEST[:n])


def check_training(seeds: Iterable[int]) -> list[int]:
    """Returns the seeds as a list if all are training seeds.

    Raises:
      ValueError: Naming the first seed outside the training range.
    """
    seeds = [int(s) for s in seeds]
    for s in seeds:
        if s not in TRAINING:
            kind = "validation" if s in VALIDATION else "test" if s in TEST else "no"
            raise ValueError(
                f"seed {s} is a {kind} seed; training may use seeds "
                f"{TRAINING.start}..{TRAINING.stop - 1} only"
            )
    return seeds


def round_seeds(seed: int, round_number: int, eval_seeds: int, fresh_starts: bool) -> list[int]:
    """The training seeds of a run's round (1-based; `rounds + 1` for the final mean's
    trial): the study's setting reuses seeds 0..eval_seeds-1; with `fresh_starts` each
    round draws its own from the training range with a generator keyed by (seed, round).

    Args:
      seed: The run's seed.
      round_number: The round.
      eval_seeds: Training seeds per candidate.
      fresh_starts: Whether each round draws its own.
    """
    if not fresh_starts:
        return list(range(eval_seeds))
    rng = np.random.default_rng([seed, round_number])
    draws = rng.integers(TRAINING.start, TRAINING.stop, eval_seeds)
    return check_training(draws)
