"""The batched closed-loop evaluator equals stepping the environment, bit for bit."""

import numpy as np
import pytest

from cpg_suite import cpg, feedback
from cpg_suite.evaluation.closed_loop import FeedbackEvaluator, FeedbackPolicy
from cpg_suite.protocol import score


def _params(k=3):
    rng = np.random.default_rng(4)
    amplitudes = cpg.amplitudes_from("hand_tuned") + rng.normal(0, 2, (k, cpg.N_AMPLITUDES))
    gains = rng.normal(0, 10, (k, feedback.N_GAINS))
    gains[:, -1] = rng.uniform(0, 3, k)  # phase feedback
    return np.concatenate([amplitudes, gains], axis=1)


@pytest.mark.parametrize("tier", ["darwin_walk", "darwin_walk_randomized", "darwin_walk_push"])
def test_batched_trials_equal_env_stepping_with_the_policy(tier):
    params, seeds, steps = _params(), [0, 5], 250
    with FeedbackEvaluator(tier, steps, threads=2) as evaluator:
        batch = evaluator.evaluate(params, seeds, quality=True)
    for k in range(len(params)):
        for j, seed in enumerate(seeds):
            trial = score.policy_trial(FeedbackPolicy(params[k]), tier, seed, steps)
            assert batch.distance_m[k, j] == trial["distance_m"]
            assert batch.lateral_m[k, j] == trial["lateral_m"]
            assert batch.fall_step[k, j] == trial["fall_step"]
            for field, value in trial["quality"].items():
                assert np.array_equal(batch.quality[field][k, j], value, equal_nan=True), field


def test_results_do_not_depend_on_threads_or_batch():
    params = _params(4)
    with FeedbackEvaluator("darwin_walk_rough", 200, threads=1) as one:
        alone = one.evaluate(params[2], [7])
    with FeedbackEvaluator("darwin_walk_rough", 200, threads=2) as two:
        batch = two.evaluate(params, [3, 7])
    assert batch.distance_m[2, 1] == alone.distance_m[0, 0]
    assert batch.fall_step[2, 1] == alone.fall_step[0, 0]


@pytest.mark.parametrize("spin", [0.0, 1000.0, 1e5])  # none; a warning in step 6; in step 1
def test_a_trials_substeps_are_the_loops_warnings_included(spin):
    """A trial's substeps (`mj_step2`, then one rollout of `mj_step`s) leave its state,
    records and warning counts as `mj_step2` then a loop of `mj_step` does, also when a
    warning stops the rollout part-way (its steps are then taken again in the loop)."""
    import mujoco

    from cpg_suite.evaluation import closed_loop

    with FeedbackEvaluator("darwin_walk_push", 20) as evaluator:
        episode = evaluator._open.episode(3)
        trial = closed_loop._Trial(episode, evaluator._open._monitor(episode), evaluator._layout)
    model, data = trial.model, trial.data
    data.qvel[6:] = spin  # the servos' joints spinning: the acceleration diverges
    data.warning.number[mujoco.mjtWarning.mjWARN_INERTIA] = 2  # counts kept from before
    data.xfrc_applied[1, :3] = (3.0, -1.0, 0.0)  # an input a rollout must not clear
    mujoco.mj_forward(model, data)
    reference = mujoco.MjData(model)
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    mujoco.mj_setState(model, reference, state, spec)
    reference.qacc_warmstart[:] = data.qacc_warmstart
    reference.warning.number[:] = data.warning.number
    mujoco.mj_forward(model, reference)
    full = mujoco.mjtState.mjSTATE_FULLPHYSICS
    states, sensors = np.zeros_like(trial.states), np.zeros_like(trial.sensors)
    for i in range(len(states)):
        (mujoco.mj_step if i else mujoco.mj_step2)(model, reference)
        mujoco.mj_getState(model, reference, states[i], full)
        sensors[i] = reference.sensordata
    trial.substeps()
    assert np.array_equal(trial.states, states) and np.array_equal(trial.sensors, sensors)
    assert np.array_equal(data.warning.number, reference.warning.number)
    assert data.warning.number[mujoco.mjtWarning.mjWARN_BADQACC] == (spin > 0)
    for field in ("qpos", "qvel", "qacc_warmstart", "ctrl", "xfrc_applied"):
        assert np.array_equal(getattr(data, field), getattr(reference, field)), field


def test_bad_parameters_are_refused():
    with FeedbackEvaluator("darwin_walk", 10) as evaluator:
        with pytest.raises(ValueError, match="22 columns"):
            evaluator.evaluate(np.zeros((2, 11)))


@pytest.mark.slow  # a training run
def test_cmaes_tunes_the_feedback_cpg_and_its_card_is_reproducible(tmp_path):
    import json

    from baselines import cmaes
    from cpg_suite.runfiles import runs

    settings = cmaes.CMAESSettings(
        controller="feedback",
        population=6,
        rounds=2,
        trial_steps=150,
        validation_seeds=2,
        test_seeds=2,
    )
    run_dir, summary = cmaes.run_cmaes(settings, runs.RunOptions(output_dir=str(tmp_path)))
    assert run_dir.endswith("K6_s1_feedback_seed0")
    chosen = feedback.load_params(f"{run_dir}/selected_params.json")
    assert set(json.load(open(f"{run_dir}/selected_params.json"))["gains"]) == set(
        feedback.GAIN_NAMES
    )
    card = score.score_gait(chosen, score.ScoreSettings(seeds=2, steps=150, controller="feedback"))
    assert card["tiers"] == summary["test"]["tiers"]


@pytest.mark.slow  # a real local Ray
def test_feedback_on_ray_equals_local_bit_for_bit():
    """The Ray backend runs the closed-loop evaluator too (chunked over actors): the same
    trials as the local evaluator, bit for bit."""
    pytest.importorskip("ray")
    from cpg_suite import evaluation
    from cpg_suite.evaluation import ray_backend

    params, seeds = _params(3), [0, 1, 2]
    with evaluation.open_evaluator("darwin_walk_push", 80, 2, controller="feedback") as local:
        want = local.evaluate(params, seeds)
    with ray_backend.connected("ray", None):
        with evaluation.open_evaluator(
            "darwin_walk_push", 80, 2, backend="ray", controller="feedback"
        ) as remote:
            assert isinstance(remote, ray_backend.RayEvaluator)
            got = remote.evaluate(params, seeds)
    for field in ("distance_m", "lateral_m", "fall_step"):
        np.testing.assert_array_equal(getattr(got, field), getattr(want, field))


def test_score_cli_refuses_a_missing_feedback_params_file(tmp_path):
    import subprocess
    import sys

    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "cpg_suite.protocol.score",
            "--controller=feedback",
            f"--params={tmp_path / 'none.json'}",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    errors = [line for line in out.stderr.splitlines() if line.startswith("error")]
    assert out.returncode == 2 and len(errors) == 1 and "hand_tuned" in errors[0], out.stderr
