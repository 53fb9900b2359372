"""The untrained PPO-on-MJX policy of each head, validated on the CPU task.

  python investigations/mjx_initial_policy.py

For `--policy_head` tanh_normal (Brax's default) and normal (SB3's Gaussian) and network
seeds 0-2: the `cpg` policy `baselines.ppo_mjx` starts from (normalizer at its initial
state), exported to NumPy and run in the CPU task `darwin_walk` on the first 10 validation
seeds, as `ppo_mjx.validate` runs it at env step 0.
"""

import jax
import jax.numpy as jnp
from brax.training.acme import running_statistics

from baselines import ppo_mjx
from cpg_suite.mjx import walk

env = walk.WalkEnv("darwin_walk", "cpg")
for head in ("tanh_normal", "normal"):
    for seed in range(3):
        s = ppo_mjx.PPOMJXSettings(action_space="cpg", policy_head=head, seed=seed)
        nets = ppo_mjx.brax_train_kwargs(s)["network_factory"](
            env.observation_size,
            env.action_size,
            preprocess_observations_fn=running_statistics.normalize,
        )
        shape = jax.ShapeDtypeStruct((env.observation_size,), jnp.float32)
        k_pi, k_v = jax.random.split(jax.random.key(seed))
        params = (
            running_statistics.init_state(shape),
            nets.policy_network.init(k_pi),
            nets.value_network.init(k_v),
        )
        m, f, _ = ppo_mjx.validate(ppo_mjx.export_policy(params, "cpg"), s)
        print(f"head={head} init seed {seed}: validation {m:+.3f} m, falls {f:.0%}", flush=True)
