"""cpg_suite is a library: importing it changes no process-wide state, every module imports
together with every other, and a PyTorch agent runs beside it on a headless machine."""

import json
import os
import subprocess
import sys

import pytest

_PACKAGES = ("cpg_suite", "baselines", "analysis")

# Imports every module of the package in one process and reports what changed.
_IMPORT_ALL = r"""
import json, logging, os, pkgutil, random, sys, warnings
import numpy as np
from absl import flags, logging as absl_logging
# Third-party packages have import-time effects of their own (gymnasium sets
# PYGAME_HIDE_SUPPORT_PROMPT, scipy and torch warnings filters): import them first, so that
# what changes below is ours.
import dm_control.suite, gymnasium, mujoco, pandas, scipy.stats, shimmy, tqdm  # noqa
import torch, stable_baselines3  # noqa  (baselines.ppo imports them)
# jax sets TF_CPP_MIN_LOG_LEVEL and TPU_SKIP_MDS_QUERY and draws from np.random when first
# imported (cpg_suite.mjx imports it; test_importing_mjx_keeps_numpy_global_draws covers
# the draw, which cpg_suite.mjx undoes).
import jax, mujoco.mjx  # noqa
# Brax (cpg_suite.mjx.training) brings orbax, which defines absl flags of its own.
import brax.envs, brax.training.agents.ppo.train  # noqa

def snapshot():
    return {
        "environ": dict(os.environ),
        "flags": sorted(flags.FLAGS),
        "np_random": repr(np.random.get_state()[1][:8].tolist() + [np.random.get_state()[2]]),
        "random": repr(random.getstate()[1][:8]),
        "root_handlers": [repr(h) for h in logging.getLogger().handlers],
        "root_level": logging.getLogger().level,
        "absl_verbosity": absl_logging.get_verbosity(),
        "warning_filters": len(warnings.filters),
    }

before = snapshot()
names = []
for package in PACKAGES:
    module = __import__(package)
    names.append(package)
    for info in pkgutil.walk_packages(module.__path__, package + "."):
        __import__(info.name)
        names.append(info.name)
after = snapshot()
changed = {k: (before[k], after[k]) for k in before if before[k] != after[k]}
print(json.dumps({"modules": names, "changed": changed}, default=str))
"""


def _clean_env():
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "DISPLAY")}
    return env


@pytest.mark.slow  # every module: torch (rl), JAX and Brax (mjx), Ray (cluster) too
def test_importing_every_module_together_changes_no_process_state():
    for extra in ("torch", "stable_baselines3", "jax", "brax", "ray"):
        pytest.importorskip(extra)
    code = f"PACKAGES = {_PACKAGES!r}\n" + _IMPORT_ALL
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=_clean_env(), timeout=300
    )
    assert out.returncode == 0, out.stderr[-3000:]
    report = json.loads(out.stdout.strip().splitlines()[-1])
    assert "baselines.cem" in report["modules"] and "cpg_suite.explore" in report["modules"]
    assert len(report["modules"]) > 30
    assert report["changed"] == {}


def test_import_leaves_os_environ_unchanged():
    code = (
        "import json, os, gymnasium, shimmy\nbefore = dict(os.environ)\n"
        "import cpg_suite, cpg_suite.gym\n"
        "env = cpg_suite.load('pole_balance'); env.reset()\n"
        "print(json.dumps(before == dict(os.environ)))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=_clean_env(), timeout=300
    )
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.strip().splitlines()[-1] == "true"


# A PyTorch agent in the same headless process, cpg_suite imported first (as the README's
# examples do): a torch model's optimizer step next to an environment, then SB3 PPO through
# shimmy on a pole and a DARwIn-OP task. With the old import-time MUJOCO_GL=egl this crashed
# with a segmentation fault inside torch.optim.Adam.
_TORCH_AGENT = r"""
import numpy as np
import cpg_suite
import cpg_suite.gym
import gymnasium
import torch
from stable_baselines3 import PPO

env = cpg_suite.load("darwin_walk")
step = env.reset()
model = torch.nn.Linear(3, 12)
optimizer = torch.optim.Adam(model.parameters(), lr=1e-3)
for _ in range(3):
    action = torch.tanh(model(torch.ones(3)))
    loss = (action**2).sum()
    optimizer.zero_grad()
    loss.backward()
    optimizer.step()
    step = env.step(action.detach().numpy().astype(np.float64))
for task in ("pole_balance", "darwin_walk"):
    gym_env = gymnasium.make(f"cpg_suite/{task}-v0")
    agent = PPO("MultiInputPolicy", gym_env, n_steps=32, batch_size=16, n_epochs=1,
                device="cpu", seed=0)
    agent.learn(64)
    gym_env.close()
print("trained")
"""


@pytest.mark.slow  # trains a torch agent
def test_pytorch_agent_runs_beside_cpg_suite_headless():
    pytest.importorskip("torch")
    pytest.importorskip("stable_baselines3")
    out = subprocess.run(
        [sys.executable, "-c", _TORCH_AGENT],
        capture_output=True,
        text=True,
        env=_clean_env(),
        timeout=600,
    )
    assert out.returncode == 0, f"exit {out.returncode}: {out.stderr[-3000:]}"
    assert out.stdout.strip().splitlines()[-1] == "trained"


@pytest.mark.slow  # JAX: the mjx extra, which the slow tier installs
def test_importing_mjx_keeps_numpy_global_draws():
    """jax draws from numpy's global generator on import; cpg_suite.mjx puts it back."""
    pytest.importorskip("jax")
    code = (
        "import numpy as np\nnp.random.seed(7)\n"
        "import cpg_suite.mjx, sys\nassert 'jax' in sys.modules\n"
        "print(np.random.randint(0, 2**31, size=3).tolist())"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=_clean_env(), timeout=300
    )
    assert out.returncode == 0, out.stderr[-3000:]
    rng = __import__("numpy").random.RandomState(7)
    assert out.stdout.strip().splitlines()[-1] == str(rng.randint(0, 2**31, size=3).tolist())
