"""The hand-tuned gait in MJX with the model's solver and capped ones: distance and falls.

The script that produced h100_capped_solver_gait.log (run from the repository root as
`python investigations/mjx_capped_solver_gait.py 512 1000`): B robots of `darwin_walk`, each
with its own reset draw, T control steps of the hand-tuned gait's actions; distance is the
summed reward (torso travel, m) until a fall. (On the H100 the caps were set by a helper
since replaced by `WalkEnv(solver_iterations=...)`, which sets the same two fields.)
"""

import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "benchmarks"))

import bench_mjx
import jax
import jax.numpy as jnp

from cpg_suite.mjx import walk

B, T = int(sys.argv[1]), int(sys.argv[2])
actions = jnp.asarray(bench_mjx.gait_actions(T))
for it, ls in [(0, 0), (4, 8), (1, 4)]:
    env = walk.WalkEnv("darwin_walk", solver_iterations=(it, ls) if it else None)

    def episode(key, env=env):
        def body(carry, a):
            state, alive, dist = carry
            state = env.step(state, a)
            dist = dist + alive * state.reward
            alive = alive * (1.0 - state.fell)
            return (state, alive, dist), None

        (state, alive, dist), _ = jax.lax.scan(body, (env.reset(key), 1.0, 0.0), actions)
        return dist, 1.0 - alive

    run = jax.jit(jax.vmap(episode))
    t = time.perf_counter()
    dist, fell = jax.block_until_ready(run(jax.random.split(jax.random.key(0), B)))
    print(
        f"solver {env.mj_model.opt.iterations}/{env.mj_model.opt.ls_iterations}: {B} robots x "
        f"{T} steps: distance mean {float(dist.mean()):.3f} m (min {float(dist.min()):.3f}, "
        f"max {float(dist.max()):.3f}), falls {float(fell.mean()):.1%}; "
        f"{time.perf_counter() - t:.0f} s with compile",
        flush=True,
    )
