"""The DARwIn-OP walking tiers on MJX (MuJoCo in JAX), for training on accelerators.

Needs the `mjx` extra (`pip install "cpg-suite[mjx]"`; `gpu` for CUDA). Importing
`cpg_suite` does not import this subpackage or JAX; importing it changes no JAX setting
(float64 physics: build and run the env under `jax.enable_x64(True)`). It imports JAX,
which sets TF_CPP_MIN_LOG_LEVEL and TPU_SKIP_MDS_QUERY in `os.environ` (jax 0.9.2 and
0.10.2); the draw JAX makes from numpy's global generator on import is undone here.

    import jax
    from cpg_suite import mjx as cpg_mjx
    env = cpg_mjx.WalkEnv("darwin_walk_randomized", action_space="joints")
    state = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.key(0), 1024))
    state = jax.jit(jax.vmap(env.step))(state, actions)  # actions (1024, 12)

Scores come from the CPU reference (`cpg_suite.protocol.score`), which a policy trained
here runs in; docs/architecture.md#the-mjx-path says how far the two physics agree.
"""

import numpy as _np


def _import_jax_keeping_numpy_rng() -> None:
    """Imports JAX and MJX and puts numpy's global generator back as it was.

    jax (0.9.2 and 0.10.2) draws five numbers from `np.random` when it is first imported
    (a retry jitter in jax/_src/clusters/k8s_cluster.py); without this, importing this
    subpackage would move every later `np.random` draw of the user's process.
    """
    state = _np.random.get_state()
    import jax  # noqa: F401
    from mujoco import mjx  # noqa: F401

    _np.random.set_state(state)


_import_jax_keeping_numpy_rng()

from cpg_suite.mjx.walk import (  # noqa: E402
    ACTION_SPACES,
    EPISODE_STEPS,
    OBSERVATION_KEYS,
    OBSERVATION_SIZES,
    TASKS,
    EpisodeParams,
    PushSchedule,
    State,
    WalkEnv,
)

__all__ = [
    "ACTION_SPACES",
    "EPISODE_STEPS",
    "OBSERVATION_KEYS",
    "OBSERVATION_SIZES",
    "TASKS",
    "EpisodeParams",
    "PushSchedule",
    "State",
    "WalkEnv",
]
