"""Natural Actor-Critic (thesis Alg. 5.1): critic, natural gradient, DMP policy, determinism."""

import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest

from baselines import nac
from baselines.experiments import nac_experiments
from cpg_suite import cpg


def test_lstd_lambda_recovers_a_known_value_function():
    """A 3-state cycle with rewards (1, 0, 2), γ = 0.9, one-hot features: v → V."""
    gamma, rewards = 0.9, np.array([1.0, 0.0, 2.0])
    transition = np.roll(np.eye(3), 1, axis=1)  # s -> s + 1 (mod 3)
    expected = np.linalg.solve(np.eye(3) - gamma * transition, rewards)
    for lam in (0.0, 0.7):
        critic = nac.NaturalActorCritic(
            3, 1, alpha=0.0, beta=1.0, gamma=gamma, lam=lam, check_every=10**9
        )
        s = 0
        for _ in range(3000):
            critic.step(np.eye(3)[s], np.zeros(1), rewards[s], np.eye(3)[(s + 1) % 3])
            s = (s + 1) % 3
        np.testing.assert_allclose(critic.v, expected, rtol=1e-3)


@pytest.mark.parametrize("target", [2.0, -2.0])
def test_natural_gradient_points_toward_the_optimum(target):
    """1-D linear-Gaussian bandit: u ~ N(θ, σ²), r = −(u − u*)²; w has the sign of u* − θ,
    and following it moves θ to u*."""
    rng = np.random.default_rng(0)
    sigma = 0.5
    agent = nac.NaturalActorCritic(
        1, 1, alpha=0.2, beta=0.0, gamma=0.0, lam=0.0, accuracy_angle=30.0, check_every=20
    )
    first_w = None
    for _ in range(4000):
        u = agent.theta[0] + sigma * rng.standard_normal()
        score = np.array([(u - agent.theta[0]) / sigma**2])
        agent.step(np.ones(1), score, -((u - target) ** 2), np.ones(1), terminal=True)
        if first_w is None and agent.steps == 20:
            first_w = agent.w[0]
    assert np.sign(first_w) == np.sign(target)
    assert agent.theta[0] == pytest.approx(target, abs=0.3)


def test_dmp_policy_score_is_the_gradient_of_the_log_density():
    rng = np.random.default_rng(1)
    theta = rng.normal(size=cpg.N_KERNELS)
    phases = np.array([0.3, 0.3 - np.pi])
    mean, u, score = nac.dmp_policy(theta, phases, 2.0, np.random.default_rng(2))

    def log_density(th):
        m, _, _ = nac.dmp_policy(th, phases, 2.0)
        return -np.sum((u - m) ** 2) / (2 * 2.0**2)

    eps = 1e-6
    numeric = np.array(
        [
            (log_density(theta + eps * e) - log_density(theta - eps * e)) / (2 * eps)
            for e in np.eye(cpg.N_KERNELS)
        ]
    )
    np.testing.assert_allclose(score, numeric, atol=1e-6)
    # Deterministic policy: u = F and no score.
    m2, u2, s2 = nac.dmp_policy(theta, phases, 2.0)
    np.testing.assert_array_equal(m2, u2)
    assert not s2.any()


def test_features_and_normalisation():
    pattern = cpg.CPG("hand_tuned")
    pattern.step(0.5)
    raw = nac.Features(False)(pattern)
    assert raw.shape == (15,) and raw[0] == 1.0
    assert 0 <= raw[13] < 2 * np.pi and 0 <= raw[14] < 2 * np.pi
    norm = nac.Features(True, "samples")
    for _ in range(5):
        pattern.step(0.1)
        x = norm(pattern)
    assert x[0] == pytest.approx(1 / 5)


def _settings(tmp_path, **kw):
    return {
        "task": "darwin_balance",
        "steps": 300,
        "alpha": 0.05,
        "beta": 0.9,
        "gamma": 0.95,
        "lam": 0.8,
        "sigma": 5.0,
        "ridge": 1e-2,
        "normalize": True,
        "constant_rule": "one",
        "eps_a": 1e-6,
        "accuracy_angle": 10.0,
        "check_every": 50,
        "fall_penalty": 1.0,
        "eval_seeds": 1,
        "seed": 0,
        "output_dir": str(tmp_path),
        "run_name": "r",
        "overwrite": False,
        **kw,
    }


def test_training_is_deterministic(tmp_path):
    a = nac.train(_settings(tmp_path), log=lambda line: None)
    b = nac.train(_settings(tmp_path), log=lambda line: None)
    np.testing.assert_array_equal(a["theta"], b["theta"])
    assert a["rows"] == b["rows"]


def test_run_writes_the_summary(tmp_path):
    run_dir, summary = nac.run_nac(_settings(tmp_path, steps=200), log=lambda line: None)
    for key in ("reward_before", "reward_after", "theta_norm_max", "diverged"):
        assert key in summary
    assert summary["reward_before"] < 0 and not summary["diverged"]
    assert (tmp_path / "nac" / "darwin_balance" / "r" / "theta.json").exists()
    # config.json holds the settings and the command that re-runs exactly this run.
    config = json.loads((tmp_path / "nac" / "darwin_balance" / "r" / "config.json").read_text())
    settings = nac.NACSettings(**_settings(tmp_path, steps=200))
    assert config["settings"] == json.loads(json.dumps(dataclasses.asdict(settings)))
    command = config["command"]
    assert command.startswith("python -m baselines.nac ") and "--steps=200" in command
    assert "--run_name=r" in command and "--overwrite" not in command


def test_train_takes_the_settings_object(tmp_path):
    as_dict = nac.train(_settings(tmp_path, steps=100), log=lambda line: None)
    as_object = nac.train(nac.NACSettings(**_settings(tmp_path, steps=100)), log=lambda _: None)
    np.testing.assert_array_equal(as_dict["theta"], as_object["theta"])
    assert as_dict["rows"] == as_object["rows"]


def test_experiment_runs_are_valid_nac_settings(tmp_path):
    experiments = nac_experiments.NACExperimentSettings(
        output_dir=str(tmp_path), seeds=2, steps=500, eval_seeds=1
    )
    for name, config in nac_experiments.CONFIGS.items():
        run = nac_experiments.run_settings(name, 1, experiments)
        assert isinstance(run, nac.NACSettings) and run.run_name == f"{name}_seed1"
        assert (run.task, run.normalize, run.ridge) == tuple(config.values())
        assert (run.steps, run.eval_seeds, run.seed) == (500, 1, 1)


@pytest.mark.parametrize(
    "args, words",
    [
        (["--task=pole_balance"], "unknown --task"),
        (["--gamma=1"], "--gamma"),
        (["--sigma=0"], "--sigma"),
        (["--beta=2"], "--beta"),
    ],
)
def test_cli_bad_flags(tmp_path, args, words):
    out = subprocess.run(
        [sys.executable, "-m", "baselines.nac", *args, f"--output_dir={tmp_path}"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 2 and words in out.stderr


def test_experiments_cli_bad_flags(tmp_path):
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "baselines.experiments.nac_experiments",
            "--seeds=1",
            f"--output_dir={tmp_path}",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 2 and "--seeds" in out.stderr
