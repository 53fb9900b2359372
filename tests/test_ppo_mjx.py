"""PPO on MJX (baselines.ppo_mjx): the exported policy is Brax's, the training wrapper draws
each episode afresh, validation runs on the CPU task, bad input stops the CLI.

A full training run compiles Brax's update with the MJX walker (minutes on 2 CPU cores);
it is run by hand (README, "Training on a GPU"), not here.
"""

import dataclasses
import json
import os
import pickle
import subprocess
import sys

import numpy as np
import pytest

pytestmark = pytest.mark.slow  # JAX and Brax: the mjx extra, which the slow tier installs

jax = pytest.importorskip("jax")
pytest.importorskip("brax")

import jax.numpy as jnp  # noqa: E402
from brax.envs import base as brax_base  # noqa: E402
from brax.training.acme import running_statistics  # noqa: E402
from brax.training.agents.ppo import networks as ppo_networks  # noqa: E402

from baselines import ppo_mjx  # noqa: E402
from cpg_suite import cli, electrical  # noqa: E402
from cpg_suite.mjx import training  # noqa: E402
from cpg_suite.mjx import walk as mjx_walk  # noqa: E402


def _brax_params(obs_size: int, layers=(16, 16), seed: int = 0, head: str = "tanh_normal"):
    """Brax PPO networks and parameters as `ppo_mjx` builds them for a policy head, the
    normalizer fed with data of scale ≠ 1."""
    settings = _settings(policy_head=head, policy_layers=layers, value_layers=layers)
    factory = ppo_mjx.brax_train_kwargs(settings)["network_factory"]
    nets = factory(obs_size, 12, preprocess_observations_fn=running_statistics.normalize)
    key = jax.random.key(seed)
    k_pi, k_v, k_obs = jax.random.split(key, 3)
    normalizer = running_statistics.init_state(jax.ShapeDtypeStruct((obs_size,), jnp.float32))
    data = 3.0 + 2.0 * jax.random.normal(k_obs, (256, obs_size))
    normalizer = running_statistics.update(normalizer, data)
    params = (normalizer, nets.policy_network.init(k_pi), nets.value_network.init(k_v))
    return nets, params


@pytest.mark.parametrize("head", ["tanh_normal", "normal"])
def test_numpy_policy_is_brax_deterministic_policy(tmp_path, head):
    obs_size = 62
    nets, params = _brax_params(obs_size, head=head)
    if head == "normal":  # a mean that leaves [−1, 1] too: the task clips it
        params[1]["params"]["Dense_0"]["kernel"] *= 300.0
    brax_policy = ppo_networks.make_inference_fn(nets)(params, deterministic=True)
    obs = 3.0 + 2.0 * np.random.default_rng(1).standard_normal((32, obs_size))
    expected, _ = brax_policy(jnp.asarray(obs, jnp.float32), jax.random.key(0))
    expected = np.clip(np.asarray(expected), -1.0, 1.0)
    if head == "normal":
        assert 0.05 < np.mean(np.abs(expected) == 1.0) < 0.95
    policy = ppo_mjx.export_policy(params, "joints")
    assert policy.head == head
    np.testing.assert_allclose(policy.act(obs), expected, atol=2e-5)
    path = str(tmp_path / "policy.npz")
    policy.save(path)
    loaded = ppo_mjx.NumpyPolicy.load(path)
    assert loaded.action_space == "joints" and len(loaded.layers) == 3 and loaded.head == head
    np.testing.assert_array_equal(loaded.act(obs), policy.act(obs))


def test_normal_head_starts_near_the_zero_action_with_its_noise():
    """SB3's policy, which `baselines.ppo` trains: a mean near 0 (the `cpg` space's
    open-loop gait) and the standard deviation asked for."""
    nets, params = _brax_params(62, head="normal")
    obs = jnp.asarray(np.random.default_rng(2).standard_normal((64, 62)), jnp.float32)
    mean, std = nets.policy_network.apply(params[0], params[1], obs)
    assert np.max(np.abs(mean)) < 0.1
    np.testing.assert_allclose(std, ppo_mjx.PPOMJXSettings().init_noise_std, rtol=1e-6)
    # Brax's default head starts far from it (every validation trial of the H100 run fell)
    tanh_actions = ppo_mjx.export_policy(_brax_params(62)[1], "joints").act(np.asarray(obs))
    assert np.max(np.abs(tanh_actions)) > 0.3


@pytest.mark.parametrize("action_space", ["joints", "cpg"])
def test_exported_policy_reads_the_cpu_task_as_the_mjx_env_is_read(action_space):
    env = mjx_walk.WalkEnv("darwin_walk", action_space)
    _, params = _brax_params(env.observation_size)
    policy = ppo_mjx.export_policy(params, action_space)
    assert policy.mean.shape == (env.observation_size,)
    trial = ppo_mjx.score.policy_trial(policy, "darwin_walk", seed=2_000_000, steps=5)
    assert trial["sim_steps"] == 5 * env.n_substeps and np.isfinite(trial["distance_m"])


class _Draws(brax_base.Env):
    """Each episode draws u ~ U(0, 1) and a length k in {1, 2, 3}; obs = (u, t)."""

    def reset(self, rng):
        k_u, k_len = jax.random.split(rng)
        u = jax.random.uniform(k_u)
        k = jax.random.randint(k_len, (), 1, 4)
        return brax_base.State(
            pipeline_state={"u": u, "k": k, "t": jnp.zeros((), jnp.int32)},
            obs=jnp.stack([u, 0.0]),
            reward=jnp.zeros(()),
            done=jnp.zeros(()),
        )

    def step(self, state, action):
        s = dict(state.pipeline_state, t=state.pipeline_state["t"] + 1)
        done = (s["t"] >= s["k"]).astype(jnp.float32)
        return state.replace(pipeline_state=s, obs=jnp.stack([s["u"], s["t"] * 1.0]), done=done)

    observation_size = 2
    action_size = 1
    backend = "toy"


def test_fresh_reset_wrapper_draws_each_episode_afresh():
    env = training.wrap_for_training(_Draws(), episode_length=100)
    keys = jax.random.split(jax.random.key(0), 64)
    state = jax.jit(env.reset)(jax.random.key_data(keys))
    first_u, k = np.asarray(state.pipeline_state["u"]), np.asarray(state.pipeline_state["k"])
    step = jax.jit(env.step)
    state = step(state, jnp.zeros((64, 1)))
    done = np.asarray(state.done) > 0
    assert done.any() and not done.all()
    np.testing.assert_array_equal(done, k == 1)
    u, t = np.asarray(state.pipeline_state["u"]), np.asarray(state.pipeline_state["t"])
    assert np.all(u[done] != first_u[done]) and np.all(t[done] == 0)  # a new episode
    assert np.all(u[~done] == first_u[~done]) and np.all(t[~done] == 1)  # the same one
    np.testing.assert_array_equal(np.asarray(state.obs)[:, 0], u)
    np.testing.assert_array_equal(np.asarray(state.info["steps"])[~done], 1)


def test_time_limit_is_a_truncation():
    env = training.wrap_for_training(_Draws(), episode_length=1)
    state = env.reset(jax.random.key_data(jax.random.split(jax.random.key(1), 16)))
    k = np.asarray(state.pipeline_state["k"])
    state = env.step(state, jnp.zeros((16, 1)))
    assert np.all(np.asarray(state.done) == 1)
    np.testing.assert_array_equal(np.asarray(state.info["truncation"]), (k > 1).astype(float))


def _settings(**kw):
    base = dict(
        num_envs=4,
        batch_size=4,
        num_minibatches=2,
        unroll_length=5,
        total_steps=80,
        validation_every=40,
        validation_seeds=2,
        trial_steps=10,
        test_seeds=1,
        test_tiers=("darwin_walk",),
        policy_layers=(8,),
        value_layers=(8,),
    )
    return ppo_mjx.PPOMJXSettings(**{**base, **kw})


def test_validation_keeps_the_best_policy_and_checkpoints(tmp_path):
    settings = _settings()
    env = mjx_walk.WalkEnv("darwin_walk", "joints")
    record = ppo_mjx._Run(str(tmp_path), settings, lambda line: None, 0, None, [])
    _, better = _brax_params(env.observation_size, layers=(8,), seed=0)
    _, other = _brax_params(env.observation_size, layers=(8,), seed=1)
    scores = [
        ppo_mjx.validate(ppo_mjx.export_policy(p, "joints"), settings) for p in (better, other)
    ]
    if scores[1][0] > scores[0][0]:
        better, other = other, better
    record.on_params(0, None, better)
    record.on_params(40, None, other)
    best = ppo_mjx.NumpyPolicy.load(str(tmp_path / "selected_policy.npz"))
    np.testing.assert_array_equal(
        best.layers[0][0], ppo_mjx.export_policy(better, "joints").layers[0][0]
    )
    assert record.best["env_steps"] == 0 and [r["env_steps"] for r in record.rows] == [0, 40]
    with open(tmp_path / "checkpoint.pkl", "rb") as f:
        checkpoint = pickle.load(f)
    assert checkpoint["env_steps"] == 40 and checkpoint["settings"] == dataclasses.asdict(settings)
    assert checkpoint["validation_sim_steps"] == record.validation_sim_steps > 0
    assert os.path.exists(tmp_path / "progress.csv")
    assert ppo_mjx.resume_state(str(tmp_path), settings)["env_steps"] == 40
    resumed = ppo_mjx._Run(str(tmp_path), settings, lambda line: None, 40, None, [], resumed=True)
    resumed.on_params(0, None, other)  # Brax hands back the checkpoint's parameters first
    assert resumed.rows == [] and resumed.best is None
    with pytest.raises(cli.UsageError, match="other settings"):
        ppo_mjx.resume_state(str(tmp_path), _settings(seed=1))


@pytest.mark.parametrize(
    "kw, words",
    [
        (dict(task="darwin_walk_rough"), "--task"),
        (dict(action_space="torques"), "--action_space"),
        (dict(num_envs=3), "must divide"),
        (dict(policy_layers=("a",)), "--policy_layers"),
        (dict(discounting=0.0), "--discounting"),
        (dict(test_tiers=("nowhere",)), "--test_tiers"),
        (dict(solver_iterations=(0, 8)), "--solver_iterations"),
        (dict(solver_iterations=("a", "b")), "--solver_iterations"),
        (dict(solver_iterations=(4,)), "--solver_iterations"),
        (dict(contacts="feet"), "--contacts"),
        (dict(policy_head="beta"), "--policy_head"),
        (dict(init_noise_std=0.0), "--init_noise_std"),
        (dict(impl="cuda"), "--impl"),
        (dict(benchmark_version=9), "--benchmark_version"),
    ],
)
def test_settings_reject_bad_values(kw, words):
    with pytest.raises(ValueError, match=words):
        _settings(**kw)


def test_cli_bad_input_is_one_line_exit_2(tmp_path):
    out = subprocess.run(
        [sys.executable, "-m", "baselines.ppo_mjx", "--num_envs=3", f"--output_dir={tmp_path}"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "--num_envs" in lines[0]
    assert not os.listdir(tmp_path)


def _time_to_target(*args):
    script = os.path.join(
        os.path.dirname(__file__), "..", "benchmarks", "ppo_mjx_time_to_target.py"
    )
    return subprocess.run(
        [sys.executable, script, *args], capture_output=True, text=True, timeout=300
    )


def test_time_to_target_reads_the_first_validation_at_the_target(tmp_path):
    rows = [
        (0, -0.1, 40.0),
        (500_000, 2.5, 300.0),
        (1_000_000, 4.0, 560.0),
        (1_500_000, 3.0, 800.0),
    ]
    lines = ["env_steps,validation_m,train_wall_s"] + [f"{a},{b},{c}" for a, b, c in rows]
    (tmp_path / "progress.csv").write_text("\n".join(lines) + "\n")
    (tmp_path / "summary.json").write_text('{"device": "gpu (NVIDIA H100)"}')
    reference = tmp_path / "cpu"
    reference.mkdir()
    (reference / "summary.json").write_text('{"selected": {"validation_success_weighted_m": 3.2}}')
    out = _time_to_target(f"--run={tmp_path}", f"--reference={reference}")
    assert out.returncode == 0, out.stderr
    assert "reached at 1,000,000 env steps after 560 s" in out.stdout
    assert "gpu (NVIDIA H100)" in out.stdout
    out = _time_to_target(f"--run={tmp_path}", "--target=4.5")
    assert "not reached (best validation +4.000 m)" in out.stdout
    out = _time_to_target(f"--run={tmp_path / 'nowhere'}", "--target=1")
    assert out.returncode == 2 and out.stderr.strip().startswith("error: ")


def test_an_exported_policy_run_ships_and_verifies(tmp_path):
    """A run with `selected_policy.npz` ships and re-scores bit for bit, like an SB3 run."""
    from cpg_suite.protocol import score, verify
    from cpg_suite.runfiles import runs

    settings = _settings(test_seeds=2, trial_steps=10)
    run_dir = tmp_path / "runs" / "ppo_mjx" / "darwin_walk" / "joints_seed0"
    run_dir.mkdir(parents=True)
    env = mjx_walk.WalkEnv("darwin_walk", "joints")
    _, params = _brax_params(env.observation_size, layers=(8,))
    policy = ppo_mjx.export_policy(params, "joints")
    policy.save(str(run_dir / "selected_policy.npz"))
    (run_dir / "progress.csv").write_text("env_steps,validation_m\n0,0.0\n")
    runs.write_config(str(run_dir), settings, "python -m baselines.ppo_mjx")
    card, _ = score.score_policy_trials(
        policy, score.ScoreSettings(tiers=("darwin_walk",), seeds=2, steps=10)
    )
    runs.write_json(str(run_dir / "summary.json"), {"test": score.stored_card(card)})
    shipped = tmp_path / "shipped"
    assert verify.ship_all(str(tmp_path / "runs"), str(shipped), log=lambda line: None) == 1
    dest = shipped / "ppo_mjx" / "darwin_walk" / "joints_seed0"
    assert sorted(os.listdir(dest)) == [
        "config.json",
        "progress.csv",
        "selected_policy.npz",
        "summary.json",
        "trials.csv",
        "versions.json",
    ]
    assert verify.verify_run(str(dest)) == []  # reproduced bit for bit
    logged = []  # but 2 seeds of 10 steps on one tier: not a card the board admits
    assert verify.verify(str(shipped), log=logged.append) == 1
    assert logged[0].startswith("REFUSED") and "protocol's card settings" in logged[0]
    other = ppo_mjx.export_policy(_brax_params(env.observation_size, (8,), seed=3)[1], "joints")
    other.save(str(dest / "selected_policy.npz"))  # a different policy: verify must see it
    assert verify.verify_run(str(dest)) != []


def test_a_zero_cpg_policy_walks_the_hand_tuned_gait_on_the_cpu():
    """Known answer: in the `cpg` space a policy that outputs 0 is the hand-tuned gait."""
    from cpg_suite import cpg
    from cpg_suite.protocol import score
    from cpg_suite.runfiles.exported import NumpyPolicy

    size = mjx_walk.WalkEnv("darwin_walk", "cpg").observation_size
    zero = NumpyPolicy(
        {
            "mean": np.zeros(size),
            "std": np.ones(size),
            "kernel_0": np.zeros((size, 24)),
            "bias_0": np.zeros(24),
        },
        "cpg",
    )
    hand_tuned = score.OpenLoopPolicy(cpg.amplitudes_from("hand_tuned"), steps=200)
    for seed in (1_000_000, 2_000_003):
        ours = score.policy_trial(zero, "darwin_walk", seed, steps=200)
        theirs = score.policy_trial(hand_tuned, "darwin_walk", seed, steps=200)
        # The CPG rows step where the open-loop gait's targets are precomputed: equal to
        # round-off, which the contacts do not amplify over 200 steps.
        assert abs(ours["distance_m"] - theirs["distance_m"]) < 1e-9 and not ours["fell"]


def test_a_run_trained_elsewhere_is_scored_on_resume(tmp_path):
    """Trained with `test_seeds=0` (the GPU machine), then `--resume` with the scoring flags
    (the CPU one): no training is left, the card is made and the training device is named."""
    trained = _settings(total_steps=40, validation_every=40, test_seeds=0)
    env = mjx_walk.WalkEnv("darwin_walk", "joints")
    run_dir = tmp_path / "ppo_mjx" / "darwin_walk" / "joints_seed0"
    run_dir.mkdir(parents=True)
    record = ppo_mjx._Run(str(run_dir), trained, lambda line: None, 0, None, [])
    record.device = "gpu (a test device)"
    record.environment = {"host": "the GPU machine"}
    for steps, seed in ((0, 0), (40, 1)):
        record.on_params(steps, None, _brax_params(env.observation_size, (8,), seed)[1])
    scoring = dataclasses.replace(trained, test_seeds=2, test_tiers=("darwin_walk",))
    with pytest.raises(cli.UsageError, match="other settings"):  # training settings still bind
        ppo_mjx.resume_state(str(run_dir), dataclasses.replace(scoring, seed=1))
    checkpoint = run_dir / "checkpoint.pkl"
    finished = checkpoint.read_bytes()
    cut_short = pickle.loads(finished)
    cut_short["env_steps"] = 0  # as if the GPU machine had stopped before the budget
    checkpoint.write_bytes(pickle.dumps(cut_short))
    with pytest.raises(cli.UsageError, match="trained on gpu and has 40 env steps left"):
        ppo_mjx.resume_state(str(run_dir), scoring)
    checkpoint.write_bytes(finished)
    options = ppo_mjx.runs.RunOptions(output_dir=str(tmp_path), resume=True)
    _, summary = ppo_mjx.run(scoring, options, log=lambda line: None)
    assert summary["device"] == "gpu (a test device)" and summary["env_steps"] == 40
    assert summary["test"]["tiers"]["darwin_walk"]["n"] == 2
    config = json.loads((run_dir / "config.json").read_text())
    assert config["training_environment"] == {"host": "the GPU machine"}
    assert config["settings"]["test_seeds"] == 2


def test_a_checkpoint_from_before_a_setting_existed_resumes_with_what_it_trained_on(tmp_path):
    """A checkpoint written before a setting existed trained on what the code did then
    (`BEFORE_ADDED`), not on today's default: it resumes under the former only."""
    trained = _settings(**ppo_mjx.BEFORE_ADDED)
    record = ppo_mjx._Run(str(tmp_path), trained, lambda line: None, 0, None, [])
    env = mjx_walk.WalkEnv("darwin_walk", "joints")
    record.on_params(0, None, _brax_params(env.observation_size, (8,))[1])
    path = tmp_path / "checkpoint.pkl"
    state = pickle.loads(path.read_bytes())
    for name in ppo_mjx.BEFORE_ADDED:
        del state["settings"][name]
    del state["device"], state["environment"]
    path.write_bytes(pickle.dumps(state))
    assert ppo_mjx.resume_state(str(tmp_path), trained)["env_steps"] == 0
    assert _settings() != trained  # today's defaults train on other physics and another head
    with pytest.raises(cli.UsageError, match="other settings"):
        ppo_mjx.resume_state(str(tmp_path), _settings())


def test_solver_caps_are_parsed():
    assert _settings().solver_iterations == (100, 8)
    assert _settings(solver_iterations=[]).solver_iterations == ()  # the model's own
    assert _settings(solver_iterations=["4", "8"]).solver_iterations == (4, 8)


def test_training_env_has_the_training_physics_and_the_versions_supply():
    """PPO trains on `PHYSICS["training"]` by default, with its benchmark version's supply
    limit in the MJX env; version 1 (the study's unlimited supply) has none."""
    env = ppo_mjx.make_env(_settings()).env
    training_physics = mjx_walk.PHYSICS["training"]
    assert env.physics == training_physics and env.impl == "jax"
    assert env.supply == electrical.DEFAULT_SUPPLY
    assert ppo_mjx.make_env(_settings(benchmark_version=1)).env.supply is None
    reference_solver = ppo_mjx.make_env(_settings(solver_iterations=[])).env.mj_model.opt
    assert (reference_solver.iterations, reference_solver.ls_iterations) == (100, 50)


def test_brax_gets_device_put_replicated_for_the_call_only():
    """Brax 0.14.2 replicates its state with `jax.device_put_replicated` (removed in JAX 0.10):
    inside `brax_on_this_jax` Brax's own helper works, and `jax` is as before afterwards."""
    from brax.training import pmap as brax_pmap

    before = getattr(jax, "device_put_replicated", None)
    tree = {"w": jnp.arange(6.0).reshape(2, 3), "n": jnp.int32(7)}
    with training.brax_on_this_jax():
        out = brax_pmap.bcast_local_devices(tree, 1)
    assert getattr(jax, "device_put_replicated", None) is before
    np.testing.assert_array_equal(out["w"], np.arange(6.0).reshape(1, 2, 3))
    assert out["n"].shape == (1,) and int(out["n"][0]) == 7
    np.testing.assert_array_equal(
        training.replicated_put(tree, jax.local_devices()[:1])["w"][0], tree["w"]
    )


def test_the_training_environment_names_the_jax_stack():
    record = ppo_mjx.training_environment()
    assert record["jax_version"] == jax.__version__
    assert record["brax_version"] and record["mujoco_mjx_version"].startswith("3.17")
    assert record["mujoco_version"] == record["mujoco_mjx_version"]  # MJX matches MuJoCo
