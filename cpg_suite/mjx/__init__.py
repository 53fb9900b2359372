"""The DARwIn-OP walking tiers on MJX (MuJoCo in JAX), for training on accelerators.

Needs the `mjx` extra (`pip install "cpg-suite[mjx]"`; `gpu` for CUDA). Importing
`cpg_suite` does not import this subpackage or JAX; importing it changes no JAX setting
(float64 physics: build and run the env under `jax.enable_x64(True)`).

    import jax
    from cpg_suite import mjx as cpg_mjx
    env = cpg_mjx.WalkEnv("darwin_walk_randomized", action_space="joints")
    state = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.key(0), 1024))
    state = jax.jit(jax.vmap(env.step))(state, actions)  # actions (1024, 12)

Scores come from the CPU reference (`cpg_suite.protocol.score`), which a policy trained
here runs in; docs/architecture.md#the-mjx-path says how far the two physics agree.
"""

from cpg_suite.mjx.walk import (
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
