"""Value and policy iteration on the `tokic` model reproduce the study's appendix."""

import numpy as np
import pytest

from baselines.tabular import models, planning

# Thesis Appendix, Table A.2 (after sweep 1) and Table A.3 (after sweep 2), γ = 0.9.
TABLE_A2 = np.array(
    [
        [0.000000, 0.000000, 0.000000, 0.000000, 0.000000],
        [0.000000, 0.000000, 0.000000, 0.000000, 0.000000],
        [1.000000, 10.000000, 9.000000, 8.100000, 7.290000],
        [46.000000, 59.400000, 85.460000, 105.914000, 96.322600],
        [-14.600000, -7.140000, 28.914000, 72.022600, 107.820340],
    ]
)
TABLE_A3 = np.array(
    [
        [0.000000, 0.000000, 0.000000, 0.000000, 0.000000],
        [0.000000, 9.000000, 8.100000, 7.290000, 6.561000],
        [42.400000, 63.460000, 82.914000, 94.322600, 86.690340],
        [35.160000, 49.644000, 76.679600, 104.820340, 113.038306],
        [-24.356000, -1.977400, 26.220340, 69.598306, 105.638475],
    ]
)
SIX_CYCLE = [(2, 1), (2, 2), (3, 2), (3, 1), (3, 0), (2, 0)]


@pytest.fixture(scope="module")
def tokic():
    return models.tokic_model()


def test_tokic_model_shape(tokic):
    assert tokic.n_states == 25 and tokic.n_actions == 4
    assert tokic.allowed.sum() == 80  # 4 corners × 2 + 12 edges × 3 + 9 interior × 4
    np.testing.assert_allclose(tokic.transitions[tokic.allowed].sum(axis=1), 1.0)
    # The thesis example: the move (2,2) -> (3,2) earns 6 (thesis Sec. 4.1.1).
    assert tokic.rewards[12, 2, 17] == 6


def test_value_iteration_reproduces_tables_a2_a3(tokic):
    result = planning.value_iteration(tokic, 0.9, sweeps=2)
    np.testing.assert_allclose(result.history[1].reshape(5, 5), TABLE_A2, atol=5e-7)
    np.testing.assert_allclose(result.history[2].reshape(5, 5), TABLE_A3, atol=5e-7)


def test_sweep_order_matters(tokic):
    """Reverse order does not reproduce A.2: the appendix sweeps in place, row-major."""
    result = planning.value_iteration(tokic, 0.9, sweeps=1, order=np.arange(25)[::-1])
    assert not np.allclose(result.history[1].reshape(5, 5), TABLE_A2, atol=1e-3)


def test_converged_greedy_cycle_has_six_states_and_reward_53(tokic):
    result = planning.value_iteration(tokic, 0.9)
    assert result.converged
    cycle = planning.policy_cycle(tokic, result.policy)
    assert cycle.length == 6
    assert cycle.reward == 53
    assert [tokic.label(s) for s in cycle.states] == SIX_CYCLE
    assert sorted(cycle.rewards) == sorted([0, 0, 6, 32, 18, -3])
    # Converged values of the cycle states (docs/decisions.md#tabular-methods).
    expected = {
        (2, 0): 81.5827,
        (2, 1): 90.6475,
        (2, 2): 100.7194,
        (3, 2): 105.2438,
        (3, 1): 81.3820,
        (3, 0): 70.4245,
    }
    for (r, c), v in expected.items():
        assert result.values[r * 5 + c] == pytest.approx(v, abs=5e-4)


def test_from_any_start_the_robot_enters_the_cycle(tokic):
    """Claim CR-3."""
    policy = planning.value_iteration(tokic, 0.9).policy
    for start in range(25):
        labels = [tokic.label(s) for s in planning.policy_cycle(tokic, policy, start).states]
        k = labels.index(SIX_CYCLE[0])
        assert labels[k:] + labels[:k] == SIX_CYCLE  # The same cycle, entered anywhere.


def test_policy_iteration_reaches_the_same_optimum(tokic):
    vi = planning.value_iteration(tokic, 0.9)
    for seed in range(3):
        pi = planning.policy_iteration(tokic, 0.9, np.random.RandomState(seed))
        assert pi.converged
        np.testing.assert_allclose(pi.values, vi.values, atol=1e-6)
        assert planning.policy_cycle(tokic, pi.policy).reward == 53


def test_policy_iteration_with_sweeps_and_fixed_iterations(tokic):
    pi = planning.policy_iteration(
        tokic, 0.9, np.random.RandomState(0), eval_sweeps=5, iterations=30
    )
    assert pi.iterations == 30 and len(pi.history) == 31 and len(pi.policies) == 30
    assert planning.policy_cycle(tokic, pi.policy).reward == 53


@pytest.mark.parametrize("gamma, walks", [(0.79, False), (0.80, True), (0.9, True)])
def test_gamma_threshold_for_forward_walking(tokic, gamma, walks):
    """Claim CR-4: below γ ≈ 0.8 value iteration finds no forward walking."""
    policy = planning.value_iteration(tokic, gamma).policy
    assert (planning.policy_cycle(tokic, policy).reward > 0) == walks


def test_greedy_ties_follow_the_appendix_order(tokic):
    """With V = 0 at (0,0) down and right tie; the appendix picks down."""
    policy = planning.greedy_policy(tokic, np.zeros(25), 0.9)
    assert models.GRID_ACTIONS[policy[0]] == "down"


def test_stochastic_variant_is_a_proper_model():
    model = models.tokic_model(slip=0.2)
    np.testing.assert_allclose(model.transitions[model.allowed].sum(axis=1), 1.0)
    assert model.transitions[0, 2, 0] == pytest.approx(0.2)
    result = planning.value_iteration(model, 0.9)
    assert result.converged and planning.policy_cycle(model, result.policy).reward > 0


def test_bad_arguments(tokic):
    with pytest.raises(ValueError):
        planning.value_iteration(tokic, 1.5)
    with pytest.raises(ValueError):
        planning.value_iteration(tokic, 0.9, sweeps=-1)
    with pytest.raises(ValueError):
        models.tokic_model(slip=1.0)
    with pytest.raises(ValueError):
        models.grid_model({((0, 0), (2, 2)): 1.0})


def _alg41_by_hand(model, gamma, start, rng, moves):
    """Alg. 4.1 as the thesis writes it: a greedy move, then one in-place sweep over every
    state, V starting at 0 (the reference `study_evidence.alg41_walk` must equal)."""
    from baselines.tabular.exploration import argmax_ties

    values, path = np.zeros(model.n_states), [start]
    for _ in range(moves):
        q = planning.action_values(model, values, gamma)[path[-1]]
        a = argmax_ties(q, rng, None if rng is not None else model.tie_order)
        path.append(model.intended_successor(path[-1], a))
        for s in range(model.n_states):
            values[s] = planning.action_values(model, values, gamma)[s].max()
    return path


def test_the_alg41_walk_is_the_move_then_sweep_loop(tokic):
    """CR-1a's and CR-3's measure: the walk read off value iteration's history equals the
    loop that sweeps after each move, with fixed and with seeded tie-breaking."""
    from baselines.experiments import study_evidence as se

    history = planning.value_iteration(tokic, 0.9, sweeps=60).history
    for start in (0, 7, 24):
        for seed in (None, 3):
            rng = (
                None if seed is None else (np.random.RandomState(seed), np.random.RandomState(seed))
            )
            walk = se.alg41_walk(tokic, history, 0.9, start, rng and rng[0])
            assert walk == _alg41_by_hand(tokic, 0.9, start, rng and rng[1], 60)


def test_a_walk_s_final_cycle_and_its_entry():
    from baselines.experiments import study_evidence as se

    assert se.final_cycle([5, 4, 1, 2, 3, 1, 2, 3, 1]) == (frozenset({1, 2, 3}), 2)
    assert se.final_cycle([0, 1, 0, 1, 0]) == (frozenset({0, 1}), 0)
    assert se.final_cycle([9, 8, 7, 7, 7]) == (frozenset({7}), 2)
    # a walk that left a cycle and entered another: the entry is into the last one
    assert se.final_cycle([1, 2, 1, 2, 3, 4, 3, 4, 3]) == (frozenset({3, 4}), 4)


def test_alg41_from_every_cell_ends_in_the_six_cycle_soon():
    """CR-3's evidence, per tie-breaking seed (known answer: all 25 cells within 9 moves)."""
    from baselines.experiments import study_evidence as se

    for found in se.tokic_alg41():
        assert [tuple(c) for c in found["cycle"]] == sorted(SIX_CYCLE)
        assert found["starts_in_cycle_within"] == 25 and found["latest_entry"] <= 20
