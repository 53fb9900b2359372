"""WalkEnv at B=8192 with fewer solver iterations than the CPU reference (100 / line search 50).

The script that produced h100_solver_iterations.log (run from the repository root); the same
steps are now `python benchmarks/bench_mjx.py --batches=8192 --steps=50 --iterations=N
--ls_iterations=N`.
"""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "benchmarks"))

import bench_mjx
import jax
from mujoco import mjx

from cpg_suite.mjx import walk

actions = bench_mjx.gait_actions(50)
for it, ls in [(4, 8), (1, 4)]:
    env = walk.WalkEnv("darwin_walk")
    env.mj_model.opt.iterations, env.mj_model.opt.ls_iterations = it, ls
    env.model = mjx.put_model(env.mj_model)
    rate, c = bench_mjx.mjx_rate(env, 8192, actions)
    print(
        f"iterations={it} ls_iterations={ls}: B=8192 {rate:,.0f} control steps/s "
        f"(compile {c:.0f} s) on {jax.devices()[0].device_kind}",
        flush=True,
    )
