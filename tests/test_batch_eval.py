"""The batched rollout evaluator equals stepping the environment.

See docs/architecture.md#the-batched-evaluator.
"""

import numpy as np
import pytest

from cpg_suite import cpg
from cpg_suite.evaluation.gait import evaluate_gait
from cpg_suite.evaluation.open_loop import BatchEvaluator


@pytest.fixture(scope="module")
def candidates():
    rng = np.random.RandomState(0)
    hand = cpg.amplitudes_from("hand_tuned")
    return np.vstack(
        [hand, cpg.amplitudes_from("table6_2"), hand + rng.normal(0.0, 3.0, size=(3, 11))]
    )


def test_same_distances_and_falls_as_the_environment(candidates):
    seeds = [0, 5]
    with BatchEvaluator(steps=400, threads=2, segment=50) as evaluator:
        result = evaluator.evaluate(candidates, seeds)
    assert result.distance_m.shape == (5, 2)
    assert result.fell.any() and not result.fell.all()  # both kinds are covered
    for k in range(len(candidates)):
        for j, seed in enumerate(seeds):
            ref = evaluate_gait(candidates[k], seed, steps=400)
            assert abs(ref["distance_m"] - result.distance_m[k, j]) <= 1e-6
            assert abs(ref["lateral_m"] - result.lateral_m[k, j]) <= 1e-6
            assert (ref["fall_step"] or 0) == result.fall_step[k, j]


def test_thread_count_does_not_change_results(candidates):
    results = []
    for threads in (1, 2):
        with BatchEvaluator(steps=300, threads=threads, segment=64) as evaluator:
            results.append(evaluator.evaluate(candidates, [1]))
    a, b = results
    np.testing.assert_array_equal(a.distance_m, b.distance_m)
    np.testing.assert_array_equal(a.fall_step, b.fall_step)
    assert a.sim_steps == b.sim_steps


def test_segmenting_does_not_change_results(candidates):
    out = []
    for segment in (300, 37):
        with BatchEvaluator(steps=300, segment=segment) as evaluator:
            out.append(evaluator.evaluate(candidates[:3], [2]))
    np.testing.assert_array_equal(out[0].distance_m, out[1].distance_m)


def test_fallen_candidates_stop_early(candidates):
    with BatchEvaluator(steps=400, segment=50) as evaluator:
        result = evaluator.evaluate(candidates[1], [0])  # table6_2 falls at step 79
    assert result.fall_step[0, 0] == 79
    assert result.sim_steps == 100 * 8  # two 50-step segments of 8 substeps


def test_bad_input():
    with pytest.raises(ValueError):
        BatchEvaluator(task="pole_balance")
    with BatchEvaluator(steps=10) as evaluator:
        with pytest.raises(ValueError):
            evaluator.evaluate(np.zeros((2, 5)))
        with pytest.raises(ValueError):
            evaluator.evaluate(np.full(11, np.nan))


def test_a_divergent_simulation_is_a_fall_in_both_evaluators():
    """Stiff servos without a torque limit make MuJoCo's state blow up (mjWARN_BADQACC,
    then MuJoCo resets the model): both evaluators report a fall at the same control step
    with the displacement before it, never the reset pose as a trial that kept walking."""
    amps = cpg.amplitudes_from("hand_tuned")
    unstable = {"servo_gain": 1.5e4, "torque_limit": 1e6}
    reference = [evaluate_gait(amps, s, steps=200, task_kwargs=unstable) for s in (0, 1)]
    assert all(r["fell"] and "error" in r for r in reference)
    with BatchEvaluator(steps=200, task_kwargs=unstable, segment=50) as evaluator:
        batch = evaluator.evaluate(np.stack([amps, amps]), [0, 1])
    np.testing.assert_array_equal(batch.fall_step, [[r["fall_step"] for r in reference]] * 2)
    np.testing.assert_array_equal(batch.distance_m[0], [r["distance_m"] for r in reference])
    assert np.all(np.isfinite(batch.distance_m))


def test_nan_costs_are_failed_trials_never_the_best():
    from baselines import cem, cmaes
    from cpg_suite.harness import rounds

    costs = np.array([np.nan, 3.0, -np.inf, 1.0, np.inf])
    assert rounds.best_index(costs) == 3
    assert rounds.best_index(np.array([np.nan, np.inf])) is None
    samples = np.arange(25.0).reshape(5, 5)
    for opt in (
        cem.CEM(np.zeros(5), population=5, elite=1, noise=0.0, seed=0),
        cmaes.CMAES(np.zeros(5), population=5, sigma0=1.0, seed=0),
    ):
        opt.tell(samples, costs)
        assert np.all(np.isfinite(opt.mean))
    # CEM with elite 1 adopts the single best finite sample.
    elite_one = cem.CEM(np.zeros(5), population=5, elite=1, noise=0.0, seed=0)
    elite_one.tell(samples, costs)
    np.testing.assert_array_equal(elite_one.mean, samples[3])
