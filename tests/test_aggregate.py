"""rliable's aggregates on known answers: IQM, stratified bootstrap, P(improvement)."""

import numpy as np
import pytest

from cpg_suite.protocol import aggregate


def test_iqm_is_the_mean_of_the_middle_half():
    scores = np.arange(8.0).reshape(4, 2)  # entries 0..7: the middle half is 2, 3, 4, 5
    assert aggregate.iqm(scores) == 3.5
    assert aggregate.mean(scores) == 3.5
    outliers = np.array([[0.0], [1.0], [1.0], [100.0]])
    assert aggregate.iqm(outliers) == 1.0  # the outliers are trimmed, the mean is not
    assert aggregate.mean(outliers) == 25.5


def test_probability_of_improvement_known_answers():
    low, high = np.zeros((5, 4)), np.ones((5, 4))
    assert aggregate.probability_of_improvement(high, low) == 1.0
    assert aggregate.probability_of_improvement(low, high) == 0.0
    assert aggregate.probability_of_improvement(low, low) == 0.5  # all ties
    # One tier: X = {1, 3}, Y = {2}: one pair above, one below.
    assert aggregate.probability_of_improvement([[1.0], [3.0]], [[2.0]]) == 0.5
    # Averaged over tiers: tier 0 always better, tier 1 always worse.
    x, y = np.array([[1.0, 0.0]]), np.array([[0.0, 1.0]])
    assert aggregate.probability_of_improvement(x, y) == 0.5


def test_interval_is_stratified_and_reproducible():
    rng = np.random.default_rng(1)
    scores = rng.normal(size=(10, 4)) + np.array([0.0, 1.0, 2.0, 3.0])
    first = aggregate.interval(scores, aggregate.mean)
    assert first == aggregate.interval(scores, aggregate.mean)  # fixed seed: bit for bit
    assert first[0] < aggregate.mean(scores) < first[1]
    # Stratified: every resample keeps each tier's own runs, so a matrix whose runs agree
    # within each tier has no spread at all, though the tiers differ.
    constant = np.tile([0.0, 1.0, 2.0, 3.0], (6, 1))
    assert aggregate.interval(constant, aggregate.mean) == [1.5, 1.5]


def test_improvement_interval_separates_clear_differences_only():
    rng = np.random.default_rng(2)
    a = rng.normal(5.0, 0.3, size=(10, 4))
    b = rng.normal(3.0, 0.3, size=(10, 4))
    c = rng.normal(5.0, 0.3, size=(10, 4))
    assert aggregate.improvement_interval(a, b)[0] > 0.5
    low, high = aggregate.improvement_interval(a, c)
    assert low < 0.5 < high


def test_bad_input_is_rejected():
    with pytest.raises(ValueError, match="runs × tiers"):
        aggregate.summary(np.zeros(3))
    with pytest.raises(ValueError, match="finite"):
        aggregate.summary(np.array([[np.nan]]))
    with pytest.raises(ValueError, match="same tiers"):
        aggregate.probability_of_improvement(np.zeros((2, 3)), np.zeros((2, 4)))
