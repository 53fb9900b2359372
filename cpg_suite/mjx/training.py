"""The MJX walking tiers as Brax environments, for Brax's trainers (PPO, SAC, ...).

    from brax.training.agents.ppo import train as ppo
    from cpg_suite.mjx import training
    env = training.BraxWalkEnv(WalkEnv("darwin_walk", "cpg"))
    make_policy, params, _ = ppo.train(env, ..., wrap_env_fn=training.wrap_for_training)

Brax's own training wrapper restarts a finished environment from the state its first reset
drew, so each environment would replay one posture noise and, on the randomized tier, one
draw of the physical parameters for the whole run. `wrap_for_training` restarts it from a
fresh `WalkEnv.reset` instead, with a key of its own: every episode draws its noise,
parameters and pushes afresh, as the CPU tiers do (the same distributions, not the same
samples). The time limit is Brax's (`EpisodeWrapper`, a truncation, not a terminal state);
a fall is terminal.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from brax.envs import base as brax_base
from brax.envs.wrappers import training as brax_wrappers

from cpg_suite.mjx.walk import WalkEnv


def replicated_put(tree: Any, devices: Sequence[jax.Device]) -> Any:
    """One copy of each leaf per device, stacked on a new leading axis sharded over them.

    What `jax.device_put_replicated` did before JAX 0.10 removed it, written as the JAX
    documentation's replacement (a `NamedSharding` over a one-axis mesh of `devices`).

    Args:
      tree: A pytree of arrays.
      devices: The devices, e.g. `jax.local_devices()[:1]`.

    Returns:
      The pytree with leaves of shape `(len(devices), *leaf.shape)`.
    """
    sharding = jax.sharding.NamedSharding(
        jax.sharding.Mesh(np.array(devices), ("devices",)),
        jax.sharding.PartitionSpec("devices"),
    )
    return jax.tree.map(lambda x: jax.device_put(jnp.stack([x] * len(devices)), sharding), tree)


@contextlib.contextmanager
def brax_on_this_jax() -> Iterator[None]:
    """Lets Brax 0.14's trainers run on JAX 0.10 and newer, for the duration of the block.

    Brax 0.14.2 puts its training state on the devices with `jax.device_put_replicated`,
    which JAX 0.10 removed (google/brax#671, open). Where `jax` lacks it, the block lends
    it `replicated_put` under that name and takes it away on exit, so no process-wide state
    outlives the call; where `jax` still has its own, the block changes nothing.

    Yields:
      None, once: the body of the `with` block runs with the name in place.
    """
    if hasattr(jax, "device_put_replicated"):
        yield
        return
    jax.device_put_replicated = replicated_put
    try:
        yield
    finally:
        del jax.device_put_replicated


class BraxWalkEnv(brax_base.Env):
    """A `WalkEnv` behind Brax's `Env` interface (one environment; Brax vmaps it).

    `pipeline_state` is the `WalkEnv.State`; `done` is 1 on a fall, a brown-out or a
    non-finite state only (the time limit belongs to `EpisodeWrapper`); `metrics["fell"]`
    is that early end, `metrics["brownout"]` the brown-out alone.
    """

    def __init__(self, env: WalkEnv):
        """Args:
        env: The MJX walking tier.
        """
        self.env = env

    def reset(self, rng: jax.Array) -> brax_base.State:
        """Starts an episode (`WalkEnv.reset`)."""
        state = self.env.reset(rng)
        return brax_base.State(
            pipeline_state=state,
            obs=state.obs,
            reward=state.reward,
            done=state.fell,
            metrics={"fell": state.fell, "brownout": state.brownout},
        )

    def step(self, state: brax_base.State, action: jax.Array) -> brax_base.State:
        """One control step (`WalkEnv.step`); the reward is the torso's forward travel, m."""
        walk = self.env.step(state.pipeline_state, action)
        return state.replace(
            pipeline_state=walk,
            obs=walk.obs,
            reward=walk.reward,
            done=walk.fell,
            metrics={**state.metrics, "fell": walk.fell, "brownout": walk.brownout},
        )

    @property
    def observation_size(self) -> int:
        """Length of the observation vector."""
        return self.env.observation_size

    @property
    def action_size(self) -> int:
        """Length of the action vector."""
        return self.env.action_size

    @property
    def backend(self) -> str:
        """The physics backend's name."""
        return "mjx"


class FreshResetWrapper(brax_wrappers.Wrapper):
    """Restarts each finished environment from a fresh reset (batched; after `VmapWrapper`).

    Each environment carries a key of its own (`info["reset_key"]`), split at every step;
    the fresh reset is computed only on steps where some environment has finished.
    """

    def reset(self, rng: jax.Array) -> brax_base.State:
        """Resets every environment; `rng` holds one key per environment."""
        keys = jax.vmap(jax.random.split)(rng)
        state = self.env.reset(keys[:, 0])
        state.info["reset_key"] = keys[:, 1]
        return state

    def step(self, state: brax_base.State, action: jax.Array) -> brax_base.State:
        """Steps every environment, then replaces the finished ones by fresh episodes."""
        if "steps" in state.info:
            state.info["steps"] = jnp.where(state.done > 0, 0, state.info["steps"])
        state = self.env.step(state.replace(done=jnp.zeros_like(state.done)), action)
        keys = jax.vmap(jax.random.split)(state.info["reset_key"])
        state.info["reset_key"] = keys[:, 1]

        def restart(current):
            fresh = self.env.reset(keys[:, 0])
            return _where_done(state.done, (fresh.pipeline_state, fresh.obs), current)

        current = (state.pipeline_state, state.obs)
        pipeline_state, obs = jax.lax.cond(jnp.any(state.done > 0), restart, lambda c: c, current)
        return state.replace(pipeline_state=pipeline_state, obs=obs)


def _where_done(done: jax.Array, fresh, current):
    """Per environment, `fresh` where `done` else `current`.

    A leaf without the batch's leading axis is shared by the batch and kept from `current`:
    on MJX's Warp backend the contact list and its counters are one for all robots, and the
    next step recomputes them (`mjx.Data.where` keeps them the same way).
    """
    batch = done.shape[0]

    def pick(x, y):
        if x.ndim == 0 or x.shape[0] != batch:
            return y
        return jnp.where(jnp.reshape(done > 0, (-1,) + (1,) * (x.ndim - 1)), x, y)

    return jax.tree.map(pick, fresh, current)


def wrap_for_training(
    env: brax_base.Env,
    episode_length: int = 1000,
    action_repeat: int = 1,
    randomization_fn: Callable | None = None,
) -> brax_base.Env:
    """Brax's training wrappers with fresh per-episode draws (`wrap_env_fn` of Brax's PPO).

    Args:
      env: A `BraxWalkEnv`.
      episode_length: Control steps per episode (the time limit, a truncation).
      action_repeat: Control steps per action.
      randomization_fn: Must be None: the randomized tier draws its own parameters.

    Returns:
      The wrapped environment: `EpisodeWrapper`, `VmapWrapper`, `FreshResetWrapper`.

    Raises:
      ValueError: If a `randomization_fn` is given.
    """
    if randomization_fn is not None:
        raise ValueError("the walking tiers draw their own parameters; pass no randomization_fn")
    env = brax_wrappers.EpisodeWrapper(env, episode_length, action_repeat)
    return FreshResetWrapper(brax_wrappers.VmapWrapper(env))
