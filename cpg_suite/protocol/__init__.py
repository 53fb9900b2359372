"""The benchmark protocol's seeds and tiers (docs/protocol.md).

A seed is the task's `random`: it fixes the initial posture and, on the perturbed tiers,
the episode's physical parameters, pushes or ground. Three disjoint ranges:

* training (0 .. 999,999): what optimizers and learners may draw from;
* validation (1,000,000 .. 1,999,999): selection of the gait a run reports, learning curves;
* test (2,000,000 .. 2,000,049): the score, the same 50 seeds on every tier.

Training code refuses validation and test seeds (`check_training`).
"""

from __future__ import annotations

from collections.abc import Iterable

TRAINING = range(0, 1_000_000)
VALIDATION = range(1_000_000, 2_000_000)
TEST = range(2_000_000, 2_000_050)

# The test tiers: the nominal task and the three perturbed ones (cpg_suite.perturbations).
TIERS = ("darwin_walk", "darwin_walk_randomized", "darwin_walk_push", "darwin_walk_rough")


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
