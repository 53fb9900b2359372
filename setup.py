"""cpg-suite: dm_control-style benchmark of RL for central pattern generators."""

import os
import re

from setuptools import find_packages, setup

_HERE = os.path.dirname(os.path.abspath(__file__))


def _version() -> str:
    with open(os.path.join(_HERE, "cpg_suite", "__init__.py"), encoding="utf-8") as f:
        return re.search(r'^__version__ = "([^"]+)"', f.read(), re.M).group(1)


def _readme() -> str:
    with open(os.path.join(_HERE, "README.md"), encoding="utf-8") as f:
        return f.read()


# MJX must match MuJoCo's minor version (mujoco-mjx 3.17 with mujoco 3.17). JAX: tested with
# 0.9.2 (CPU) and 0.11.2 (CUDA 13, H100). Not 0.10.* nor 0.11.0: their jaxlib splits a
# batched LAPACK call (MJX's Cholesky under vmap) over XLA's CPU thread pool and waits for
# the pieces from inside that pool, which deadlocks on the CPU (tests/test_jax_cpu.py;
# docs/decisions.md#jax-versions). Brax 0.14.2's PPO needs jax.device_put_replicated, which
# JAX 0.10 removed, and gets it from cpg_suite.mjx.training.brax_on_this_jax.
_JAX = ">=0.9.2,!=0.10.*,!=0.11.0,<0.12"
_MJX_COMMON = [
    "mujoco==3.17.*",
    "mujoco-mjx[warp]==3.17.*",  # warp: MJX's MuJoCo Warp backend (warp-lang 1.18.0)
    "gymnasium>=1.0,<2",
    "shimmy[dm-control]>=2.0,<3",  # the CPU vector env that benchmarks/bench_mjx.py compares
    "brax>=0.14.2,<0.15",  # PPO on MJX (baselines.ppo_mjx)
]
_MJX = [*_MJX_COMMON, f"jax[cpu]{_JAX}"]


setup(
    name="cpg-suite",
    version=_version(),
    description=(
        "MuJoCo/dm_control benchmark from Duarte's study of reinforcement learning "
        "for central pattern generators: crawler, pole and DARwIn-OP tasks, the "
        "study's baselines and a leaderboard."
    ),
    long_description=_readme(),
    long_description_content_type="text/markdown",
    license="Apache-2.0",
    python_requires=">=3.10",
    packages=find_packages(
        include=["cpg_suite", "cpg_suite.*", "baselines", "baselines.*", "analysis", "analysis.*"]
    ),
    package_data={
        "cpg_suite": ["xml/*.xml", "xml/common/*.xml", "data/*.json", "data/*.md", "data/*.txt"],
        "analysis": ["*.csv"],
    },
    # Ranges we have tested. dm-control 1.0.50 breaks with mujoco 4.x (flex_vertedge).
    install_requires=[
        "dm-control==1.0.50",
        "mujoco>=3.17,<4",
        "dm-env>=1.6,<2",
        "numpy>=1.26,<3",
        "absl-py>=1.4,<3",
        "pandas>=2.0,<4",
        "tqdm>=4.60,<5",
        "scipy>=1.10,<2",
        # Gymnasium is the gym extra's: the core (the tasks, the baselines' main jobs,
        # submit, verify and the board) imports none of it (docs/decisions.md#gymnasium).
    ],
    extras_require={
        # The fast tier (README: pytest -m "not slow"): the tests also render a gait video
        # (Pillow for GIF/PNG, imageio + ffmpeg for MP4), run CMA-ES and check the Gymnasium
        # wrappers. No torch, JAX or Ray: the shipped PPO policies are NumPy arrays
        # (selected_policy.npz). The slow tier adds the rl, mjx and cluster extras (training
        # smoke runs with Stable-Baselines3 and Brax, real Ray clusters, MJX on JAX's CPU).
        "test": [
            "pytest>=7,<10",
            "mpmath>=1.3,<2",  # 60-digit references for cpg_suite.portable's functions
            "ruff>=0.5",
            "pillow>=10,<14",
            "imageio>=2.30,<3",
            "imageio-ffmpeg>=0.5,<1",
            "cma>=3.3,<5",
            "gymnasium>=1.0,<2",
            "shimmy[dm-control]>=2.0,<3",
            "matplotlib>=3.7,<4",
        ],
        "plots": [
            "matplotlib>=3.7,<4",
            "pillow>=10,<14",
            "imageio>=2.30,<3",
            "imageio-ffmpeg>=0.5,<1",
        ],
        "gym": ["gymnasium>=1.0,<2", "shimmy[dm-control]>=2.0,<3"],
        # pycma: checks our CMA-ES against it and runs as a bring-your-own optimizer.
        "optim": ["cma>=3.3,<5"],
        # The Ray backend: evaluation and grids of runs on a cluster (tested with 2.60).
        "cluster": ["ray>=2.9,<3"],
        # Deep RL agents (PyTorch; the wheels bring CUDA libraries of several GB).
        "rl": [
            "gymnasium>=1.0,<2",
            "shimmy[dm-control]>=2.0,<3",
            "torch>=2.3,<3",
            "stable-baselines3>=2.3,<3",
        ],
        # The walking tiers in MJX (cpg_suite.mjx) on JAX's CPU backend.
        "mjx": [*_MJX],
        # The same on NVIDIA GPUs (CUDA 12 wheels of JAX, several GB).
        "gpu": [*_MJX_COMMON, f"jax[cuda12]{_JAX}"],
    },
    classifiers=[
        "Programming Language :: Python :: 3",
        "Topic :: Scientific/Engineering :: Artificial Intelligence",
    ],
)
