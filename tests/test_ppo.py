"""PPO (`baselines.ppo`) and its CPG action space (`cpg_suite.residual`): real SB3 and torch
in the slow tier (the rl extra); the CPG action space and the shipped policies as data
(`selected_policy.npz`) in the fast tier, without torch."""

import csv
import dataclasses
import importlib.util
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

import cpg_suite
from analysis import leaderboard, report
from cpg_suite import cpg, darwin, electrical, protocol, residual, vector
from cpg_suite.protocol import admission, score, verify
from cpg_suite.runfiles import exported, runs

RL = all(importlib.util.find_spec(m) for m in ("torch", "stable_baselines3"))
if RL:  # the rl extra
    from baselines import ppo
    from cpg_suite.harness import checkpoints, learner, sb3
    from cpg_suite.runfiles import sb3_policy

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHIPPED = os.path.join(ROOT, verify.ARTIFACTS, "ppo", "darwin_walk")
# The one shipped run that keeps its SB3 pickles beside its exported arrays (the tests
# that load SB3 itself); verify scores the arrays.
WITH_PICKLES = os.path.join(SHIPPED, "cpg_seed0")


def rl(test):
    """A test of Stable-Baselines3 and torch: the slow tier's (its README line installs
    the rl extra); skipped where they are not installed."""
    reason = "needs the rl extra (Stable-Baselines3, torch): pip install '.[rl]'"
    return pytest.mark.slow(pytest.mark.skipif(not RL, reason=reason)(test))


def _settings(**kw) -> "ppo.PPOSettings":
    base = dict(
        total_steps=512,
        num_envs=2,
        n_steps=64,
        batch_size=64,
        n_epochs=2,
        trial_steps=30,
        validation_every=256,
        validation_seeds=2,
        test_seeds=1,
        test_tiers=("darwin_walk",),
        net_arch=(16, 16),
    )
    base.update(kw)
    return ppo.PPOSettings(**base)


def _options(tmp_path, **kw) -> runs.RunOptions:
    return runs.RunOptions(output_dir=str(tmp_path), threads=1, **kw)


def _quiet(line: str) -> None:
    del line


# The CPG action space.
def test_zero_corrections_give_the_open_loop_cpg_bit_for_bit():
    reference = cpg.CPG("hand_tuned")
    modulated = residual.ModulatedCPG(3)
    for _ in range(120):  # past the 1.1 s start-up ramp
        expected = reference.step(darwin.CONTROL_TIMESTEP)
        modulated.modulate(np.zeros((3, residual.N_ACTIONS)))
        got = modulated.step(darwin.CONTROL_TIMESTEP)
        assert np.array_equal(got, np.tile(expected, (3, 1)))


def test_rows_are_independent_and_reset_alone():
    rng = np.random.default_rng(0)
    modulated = residual.ModulatedCPG(2)
    reference, fresh = cpg.CPG("hand_tuned"), cpg.CPG("hand_tuned")
    for t in range(40):
        if t == 25:
            modulated.reset_rows(np.array([False, True]))
        actions = np.zeros((2, residual.N_ACTIONS))
        actions[0] = rng.uniform(-1, 1, residual.N_ACTIONS)  # row 0 is modulated
        modulated.modulate(actions)
        got = modulated.step(darwin.CONTROL_TIMESTEP)
        expected = (reference if t < 25 else fresh).step(darwin.CONTROL_TIMESTEP)
        assert np.array_equal(got[1], expected)
    assert not np.array_equal(got[0], got[1])
    assert modulated.time[1] == pytest.approx(15 * darwin.CONTROL_TIMESTEP)
    assert modulated.time[0] == pytest.approx(40 * darwin.CONTROL_TIMESTEP)


def test_phase_rate_correction():
    modulated = residual.ModulatedCPG(2)
    actions = np.zeros((2, residual.N_ACTIONS))
    actions[0, -1], actions[1, -1] = 1.0, -1.0
    for _ in range(50):
        modulated.modulate(actions)
        modulated.step(darwin.CONTROL_TIMESTEP)
    advance = modulated.left_phase() - modulated.config.initial_phase
    nominal = modulated.config.omega * 50 * darwin.CONTROL_TIMESTEP
    assert advance == pytest.approx([1.5 * nominal, 0.5 * nominal])
    phase = modulated.left_phase()
    assert np.array_equal(modulated.phase_features(), np.stack([np.cos(phase), np.sin(phase)], 1))


@rl
def test_the_envs_hold_the_benchmark_versions_supply_limit():
    """Version 2 (the default) trains under the supply's limit; version 1, the study's
    unlimited supply, computes the current without enforcing it."""
    for version, limit in ((2, electrical.DEFAULT_SUPPLY), (1, None)):
        env = sb3.make_vector_env(_settings(benchmark_version=version), 1, threads=1)
        env.reset(seed=0)
        assert [e.task.supply_limit for e in env.envs] == [limit]
        assert env.envs[0].task.supply.enforce is (limit is not None)
    with pytest.raises(ValueError, match="--benchmark_version"):
        _settings(benchmark_version=7)


@rl
def test_cpg_wrapper_with_zero_actions_walks_the_hand_tuned_gait():
    settings = _settings(action_space="cpg", trial_steps=1000)
    env = sb3.make_vector_env(settings, 2, threads=1)
    plain = vector.DarwinVectorEnv("darwin_walk", 2, threads=1, autoreset_mode="SameStep")
    reference = cpg.CPG("hand_tuned")  # the open-loop gait, stepped
    physics = cpg_suite.load("darwin_walk").physics
    obs, _ = env.reset(seed=7)
    expected, _ = plain.reset(seed=7)
    assert np.allclose(obs[residual.PHASE_KEY], [[-1.0, 0.0]] * 2)  # φ_L(0) = π
    for t in range(40):
        obs, *_ = env.step(np.zeros((2, residual.N_ACTIONS)))
        action = physics.targets_to_action(reference.step(darwin.CONTROL_TIMESTEP))
        expected, *_ = plain.step(np.tile(action, (2, 1)))
        for key, value in expected.items():
            assert np.array_equal(obs[key], value), (t, key)


# The SB3 adapter.
@rl
def test_supply_cost_takes_the_charge_above_idle_from_the_reward_and_keeps_task_returns():
    """κ > 0: each step's reward loses κ·Σ_k (i_k − idle)·h, with the currents the tasks'
    supply monitors were given (their running totals); the episodes' returns stay the
    task's, and the episodes the same."""
    kappa = 0.5
    settings = _settings(trial_steps=20, supply_cost=kappa)
    shaped = sb3.FlatVecEnv(sb3.make_vector_env(settings, 2, threads=1), kappa)
    plain = sb3.FlatVecEnv(sb3.make_vector_env(settings, 2, threads=1))
    n_sub, h = shaped.env.unwrapped.n_sub, darwin.CONTROL_TIMESTEP / shaped.env.unwrapped.n_sub
    rng = np.random.default_rng(0)
    for env in (shaped, plain):
        env.seed(5)
        env.reset()
    monitors = [env.task.supply for env in shaped.env.unwrapped.envs]
    for _ in range(50):
        before = np.array([m.total for m in monitors])
        actions = np.clip(0.6 * rng.standard_normal((2, 12)), -1, 1)
        for env in (shaped, plain):
            env.step_async(actions)
        _, rewards, dones, _ = shaped.step_wait()
        _, task_rewards, plain_dones, _ = plain.step_wait()
        assert np.array_equal(dones, plain_dones)
        drawn = np.array([m.total for m in monitors]) - before  # A·physics steps
        charge = (drawn - n_sub * electrical.IDLE_CURRENT) * h
        for i in np.flatnonzero(~dones):  # a finished robot's monitor was reset
            assert charge[i] > 0
            assert rewards[i] == pytest.approx(task_rewards[i] - kappa * charge[i], abs=1e-12)
    assert shaped.drain_episodes() == plain.drain_episodes() != []
    with pytest.raises(ValueError, match="supply_cost"):
        sb3.FlatVecEnv(sb3.make_vector_env(settings, 2, threads=1), -0.1)


@rl
@pytest.mark.parametrize("value", [-0.01, float("nan"), float("inf")])
def test_supply_cost_must_be_a_finite_number_at_least_zero(value):
    with pytest.raises(ValueError, match="--supply_cost"):
        _settings(supply_cost=value)


@rl
def test_a_supply_shaped_run_is_named_by_its_cost():
    assert ppo.default_run_name(_settings(seed=2)) == "joints_seed2"
    assert ppo.default_run_name(_settings(seed=2, supply_cost=0.03)) == "joints_c0.03_seed2"


@rl
@pytest.mark.parametrize("action_space, size", [("joints", 40), ("cpg", 42)])
def test_flat_vec_env_terminal_observation_and_truncation(action_space, size):
    settings = _settings(action_space=action_space, trial_steps=5)
    flat = sb3.FlatVecEnv(sb3.make_vector_env(settings, 2, threads=1))
    reference = sb3.make_vector_env(settings, 2, threads=1)  # the same env, dicts unflattened
    assert flat.observation_space.shape == (size,)
    flat.seed(3)
    obs = flat.reset()
    ref_obs, _ = reference.reset(seed=3)
    keys = sb3.observation_keys(reference.single_observation_space)
    assert np.array_equal(obs, sb3.flatten(ref_obs, keys))
    assert np.array_equal(obs[0], sb3.flatten_one({k: v[0] for k, v in ref_obs.items()}, keys))
    actions = np.zeros((2, flat.action_space.shape[0]))
    for t in range(5):
        flat.step_async(actions)
        obs, rewards, dones, infos = flat.step_wait()
        ref_obs, ref_rewards, terminated, truncated, extra = reference.step(actions)
        assert np.array_equal(rewards, ref_rewards)
        assert np.array_equal(obs, sb3.flatten(ref_obs, keys))
        if t < 4:
            assert not dones.any() and infos == [{}, {}]
    assert dones.all() and truncated.all() and not terminated.any()
    for i, info in enumerate(infos):
        assert info["TimeLimit.truncated"] and not info["fell"]
        assert np.array_equal(
            info["terminal_observation"], sb3.flatten_one(extra["final_obs"][i], keys)
        )
        assert not np.array_equal(info["terminal_observation"], obs[i])  # obs: the next episode
        assert info["episode"]["l"] == 5
    episodes = flat.drain_episodes()
    assert len(episodes) == 2 and flat.drain_episodes() == []
    assert flat.physics_steps == 2 * 5 * 8


# Runs.
def _rows(run_dir):
    with open(os.path.join(run_dir, "progress.csv"), encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    return [{k: v for k, v in r.items() if k not in ("steps_per_s", "wall_s")} for r in rows]


def _without_wall(summary):
    return {k: v for k, v in summary.items() if k != "wall_s"}


@rl
def test_joints_run_files_leaderboard_row_and_policy(tmp_path):
    import torch

    settings = _settings(action_space="joints")
    threads = torch.get_num_threads()
    run_dir, summary = ppo.run(settings, _options(tmp_path), log=_quiet)
    assert torch.get_num_threads() == threads  # one thread inside the run only
    assert run_dir == os.path.join(str(tmp_path), "ppo", "darwin_walk", "joints_seed0")
    for name in (
        "config.json",
        "progress.csv",
        "checkpoint.pkl",
        "summary.json",
        "selected_model.zip",
        "selected_vecnormalize.pkl",
        "final_model.zip",
    ):
        assert os.path.isfile(os.path.join(run_dir, name)), name
    rows = _rows(run_dir)
    assert [int(r["env_steps"]) for r in rows] == [256, 512]
    assert summary["env_steps"] == 512 and summary["sim_steps"] == 512 * 8
    assert summary["validation_sim_steps"] > 0
    assert set(summary["test"]["tiers"]) == {"darwin_walk"}
    assert runs.read_json(os.path.join(run_dir, "summary.json"))["test"] == summary["test"]
    found, skipped = leaderboard.find_runs(str(tmp_path))
    rows = leaderboard.darwin_rows(found)
    assert not skipped and len(rows) == 1
    row = rows[0]
    assert (row["method"], row["config"], row["training_task"]) == ("ppo", "joints", "darwin_walk")
    assert row["budget_sim_steps"] == summary["sim_steps"] + summary["validation_sim_steps"]
    # Its validation curve is a line of the report's score-vs-budget figure.
    (tmp_path / "report").mkdir()
    assert report.score_vs_budget(found, str(tmp_path / "report")).endswith("score_vs_budget.png")
    assert report.learning_curves(found, str(tmp_path / "report")).endswith("learning_curves.png")
    # The saved policy scores what the run's validation measured (step by step vs vectorized).
    policy = ppo.load_policy(run_dir)
    trial = score.policy_trial(policy, "darwin_walk", protocol.VALIDATION.start, 30)
    env = sb3.make_vector_env(settings, 1, threads=1)
    value, _, _ = learner.validate(
        policy.model, policy.normalizer, env, dataclasses.replace(settings, validation_seeds=1)
    )
    assert trial["distance_m"] * (not trial["fell"]) == pytest.approx(value, abs=1e-9)


@rl
def test_a_policy_run_ships_and_verifies_bit_for_bit(tmp_path):
    """The policy, its normalizer and learning curve ship; `verify` re-scores them."""
    settings = _settings(action_space="cpg", test_tiers=("darwin_walk", "darwin_walk_push"))
    run_dir, summary = ppo.run(settings, _options(tmp_path / "runs"), log=_quiet)
    dest = str(tmp_path / "shipped" / "ppo" / "darwin_walk" / "cpg_seed0")
    with pytest.raises(verify.UntrustedCode, match="not in cpg_suite/data/trusted_pickles"):
        verify.ship(run_dir, dest)  # its pickles are no shipped run's: loaded only if asked
    assert not os.path.exists(dest)
    verify.ship(run_dir, dest, trust_code=True)
    assert {"selected_model.zip", "selected_vecnormalize.pkl", "progress.csv"} <= set(
        os.listdir(dest)
    )
    assert verify.shipped_runs(str(tmp_path / "shipped")) == [dest]
    trials = verify.read_trials(os.path.join(dest, "trials.csv"))
    assert [t["tier"] for t in trials] == ["darwin_walk", "darwin_walk_push"]
    assert verify.verify_run(dest, trust_code=True) == []
    assert verify.verify_run(dest, quick=True, trust_code=True) == []
    stored = runs.read_json(os.path.join(dest, "summary.json"))["test"]
    assert stored == summary["test"]
    # Exported as data, it ships without its pickles and verifies without trust or torch's
    # arithmetic: the same trials.
    assert sb3.export_run(run_dir) == (os.path.join(run_dir, exported.FILE), "wrote")
    assert sb3.export_run(run_dir)[1] == "same"
    as_data = str(tmp_path / "as_data" / "ppo" / "darwin_walk" / "cpg_seed0")
    verify.ship(run_dir, as_data)
    assert sorted(os.listdir(as_data)) == sorted(
        [
            exported.FILE,
            "progress.csv",
            "config.json",
            "summary.json",
            "trials.csv",
            "versions.json",
        ]
    )
    assert verify.verify_run(as_data) == []


@rl
def test_cpg_run_killed_after_a_checkpoint_resumes_to_the_same_result(tmp_path):
    settings = _settings(action_space="cpg")
    straight_dir, straight = ppo.run(settings, _options(tmp_path / "a"), log=_quiet)

    class Killed(Exception):
        pass

    def kill(totals):
        raise Killed(totals["env_steps"])

    with pytest.raises(Killed):
        ppo.run(settings, _options(tmp_path / "b"), log=_quiet, on_checkpoint=kill)
    run_dir = os.path.join(str(tmp_path / "b"), "ppo", "darwin_walk", "cpg_seed0")
    assert not os.path.exists(os.path.join(run_dir, "summary.json"))
    assert [int(r["env_steps"]) for r in _rows(run_dir)] == [256]
    with pytest.raises(runs.RunDirectoryExists):
        ppo.run(settings, _options(tmp_path / "b"), log=_quiet)
    resumed_dir, resumed = ppo.run(settings, _options(tmp_path / "b", resume=True), log=_quiet)
    assert _rows(resumed_dir) == _rows(straight_dir)
    assert [int(r["env_steps"]) for r in _rows(resumed_dir)] == [256, 512]
    assert _without_wall(resumed) == _without_wall(straight)
    assert resumed["env_steps"] == 512 and resumed["sim_steps"] == 512 * 8
    # Another configuration cannot resume from this checkpoint.
    with open(os.path.join(run_dir, "summary.json"), "rb") as f:
        summary_bytes = f.read()
    os.remove(os.path.join(run_dir, "summary.json"))
    foreign = dataclasses.replace(settings, learning_rate=1e-3)
    with pytest.raises(checkpoints.CheckpointError, match="another configuration"):
        ppo.run(foreign, _options(tmp_path / "b", resume=True, run_name="cpg_seed0"), log=_quiet)
    assert summary_bytes


# The shipped policies as data.
@rl
def test_the_export_is_the_torch_policy_to_float32_rounding():
    """The test protocol's policy (NumPy, portable arithmetic) against SB3's own predict
    (torch, float32) on the shipped run that keeps its pickles: the same function; and
    each row's action does not depend on the rows beside it."""
    config = runs.read_json(os.path.join(WITH_PICKLES, "config.json"))
    policy = sb3_policy.load_shipped_policy(WITH_PICKLES, "ppo", config["settings"])
    flat = 3 * np.random.default_rng(5).standard_normal((20, 42))
    with sb3_policy.single_threaded():
        reference = np.concatenate(
            [sb3.predict(policy.model, policy.normalizer, r[None]) for r in flat]
        )
    actions = policy.actor(flat)
    assert actions.shape == (20, 12) and np.abs(actions).max() <= 1.0
    np.testing.assert_allclose(actions, reference, atol=2e-6)
    assert np.array_equal(np.concatenate([policy.actor(r[None]) for r in flat]), actions)


@rl
def test_the_shipped_arrays_are_the_pickles_export_bit_for_bit(tmp_path):
    """The converter (`python -m cpg_suite.harness.sb3 --export`) on a copy of the run that
    keeps its pickles finds the arrays it would write already there, value for value;
    another policy's file is kept unless --overwrite."""
    run = tmp_path / "ppo" / "darwin_walk" / "cpg_seed0"
    shutil.copytree(WITH_PICKLES, run)
    command = [sys.executable, "-m", "cpg_suite.harness.sb3", f"--export={tmp_path}"]
    out = subprocess.run(command, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines() == [
        f"same     {run / exported.FILE}",
        f"1 runs' policies exported as {exported.FILE}",
    ]
    other = exported.NumpyPolicy.load(os.path.join(SHIPPED, "cpg_seed1", exported.FILE))
    other.save(str(run / exported.FILE))
    with pytest.raises(FileExistsError, match="another policy"):
        sb3.export_run(str(run))
    assert sb3.export_run(str(run), overwrite=True)[1] == "replaced"
    assert sb3.export_run(str(run))[1] == "same"
    out = subprocess.run(command[:-1] + ["--export=no_such_folder"], capture_output=True, text=True)
    assert out.returncode == 2 and out.stderr.strip().splitlines() == [
        "error: --export=no_such_folder: no such folder"
    ]


@rl
def test_the_export_refuses_a_policy_it_does_not_compute():
    import torch
    from stable_baselines3 import PPO

    env = sb3.normalized(sb3.FlatVecEnv(sb3.make_vector_env(_settings(), 1, threads=1)), 0.99)
    model = PPO("MlpPolicy", env, policy_kwargs={"activation_fn": torch.nn.ReLU}, n_steps=64)
    with pytest.raises(ValueError, match="Tanh"):
        sb3_policy.export_policy(model, env, _settings())


@pytest.mark.parametrize("name", ["cpg_v1_seed1", "joints_seed1"])
def test_a_shipped_ppo_run_replays_its_trials_from_its_arrays(name):
    """Without torch: verify scores a shipped PPO run from its arrays (data, no pickle),
    and a trial equals its trial table bit for bit."""
    run = os.path.join(SHIPPED, name)
    assert admission.artifact_files(run) == (admission.EXPORTED,)
    assert verify.code_refusal(run, trusted=frozenset()) is None
    assert verify.sample_run(run, {"darwin_walk_push": [protocol.TEST.start + 7]}) == []


@pytest.mark.parametrize("name", ["cpg_seed0", "joints_seed1"])
def test_a_shipped_ppo_policy_is_vecnormalize_then_a_tanh_mlp_clipped_to_its_box(name):
    """Without torch: a shipped PPO policy's arrays (no pickle) compute SB3's deterministic
    action: (x − mean)/√(var + ε) clipped at ±clip_obs, rounded to float32, the tanh MLP,
    the mean clipped to the action box (here against BLAS, to 1e-12); row by row; saved
    and loaded again, the same arrays."""
    path = os.path.join(SHIPPED, name, exported.FILE)
    with np.load(path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    policy = exported.NumpyPolicy.load(path)
    assert (policy.activation, policy.head, policy.input_dtype) == ("tanh", "normal", "float32")
    assert policy.action_space == str(arrays["action_space"]) == name.split("_")[0]
    assert policy.scales == ({"amplitude_scale": 10.0, "rate_scale": 0.5} if "cpg" in name else {})
    assert [k.shape for k, _ in policy.layers][1:] == [(256, 256), (256, 12)]
    flat = 3 * np.random.default_rng(5).standard_normal((20, len(policy.mean)))
    flat[0, :3] = 1e6  # clipped
    x = np.clip((flat - arrays["mean"]) / np.sqrt(arrays["var"] + arrays["epsilon"]), -10, 10)
    x = x.astype(np.float32).astype(np.float64)
    for i in range(3):
        x = x @ arrays[f"kernel_{i}"] + arrays[f"bias_{i}"]
        x = np.tanh(x) if i < 2 else x
    expected = np.clip(x, arrays["action_low"], arrays["action_high"])
    actions = policy.act(flat)
    np.testing.assert_allclose(actions, expected, rtol=0, atol=1e-12)
    assert np.array_equal(np.concatenate([policy.act(r[None]) for r in flat]), actions)
    assert policy.clip_obs == 10.0 and np.array_equal(policy.box[0], -np.ones(12))
    again = exported.NumpyPolicy(policy.arrays(), policy.action_space)
    assert np.array_equal(again.act(flat), actions)


@rl
def test_settings_are_checked():
    for kw, words in [
        ({"action_space": "torques"}, "--action_space"),
        ({"task": "darwin_run"}, "unknown --task"),
        ({"total_steps": 0}, "--total_steps"),
        ({"test_tiers": ("darwin_fly",)}, "--test_tiers"),
        ({"rate_scale": 1.0}, "--rate_scale"),
        ({"net_arch": ("a",)}, "--net_arch"),
    ]:
        with pytest.raises(ValueError, match=words):
            _settings(**kw)


def _cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "baselines.ppo", *args], capture_output=True, text=True, timeout=300
    )


@rl
def test_cli_bad_input_is_one_line_exit_2(tmp_path):
    out = _cli("--action_space=torques", f"--output_dir={tmp_path}")
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "--action_space" in lines[0]
    existing = tmp_path / "ppo" / "darwin_walk" / "cpg_seed0"
    existing.mkdir(parents=True)
    (existing / "config.json").write_text("{}")
    out = _cli("--action_space=cpg", f"--output_dir={tmp_path}")
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "--overwrite" in lines[0] and "--resume" in lines[0]


@rl
def test_import_changes_no_torch_threads():
    code = (
        "import torch; n = torch.get_num_threads(); import baselines.ppo; "
        "assert torch.get_num_threads() == n; print('ok')"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0 and "ok" in out.stdout, out.stderr
