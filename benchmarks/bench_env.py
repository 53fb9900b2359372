r"""Per-task stepping throughput: `env.step` vs raw MuJoCo vs the closest dm_control task.

  python benchmarks/bench_env.py [--steps=20000] [--repeats=3] [--tasks=pole_balance,...]

For each task it measures, in one process and one run:
  * `env.step` control steps per second with random actions (episodes reset as needed);
  * raw physics: `mujoco.mj_step(model, data, n_sub_steps)` per control step on the same
    model, with the same controls, no Python task code — the floor of what any wrapper costs;
  * their ratio (env / raw): the share of raw speed a user's agent actually gets;
  * the `env.step` throughput of the closest dm_control suite task (the peer to beat):
    `cartpole/balance` for the pole tasks.
Each figure is the best of `--repeats` timings. Absolute rates are noisy on a shared
machine; the ratios, measured back to back, are the figures to compare.
"""

from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np
from dm_env import specs

import cpg_suite

# Closest dm_control suite task for each cpg_suite domain.
PEERS = {"pole": ("cartpole", "balance")}


def _actions(spec, n, rng):
    if isinstance(spec, specs.DiscreteArray):
        return rng.randint(spec.num_values, size=n)
    return rng.uniform(spec.minimum, spec.maximum, size=(n,) + spec.shape)


def time_env(env, steps: int, repeats: int, seed: int = 0) -> float:
    """Best-of-`repeats` control steps per second of `env.step` with random actions."""
    actions = _actions(env.action_spec(), steps, np.random.RandomState(seed))
    best = np.inf
    for _ in range(repeats):
        env.reset()
        start = time.perf_counter()
        for a in actions:
            if env.step(a).last():
                env.reset()
        best = min(best, time.perf_counter() - start)
    return steps / best


def time_raw(env, steps: int, repeats: int, seed: int = 0) -> float:
    """Best-of-`repeats` control steps per second of bare `mujoco.mj_step` on the same model.

    Controls are the ones the task produced for the same random actions (recorded once), so
    the simulated work is the same; the state is reset where the recorded episodes ended.
    """
    physics = env.physics
    n_sub = int(round(env.control_timestep() / physics.model.opt.timestep))
    actions = _actions(env.action_spec(), steps, np.random.RandomState(seed))
    ctrls = np.zeros((steps, physics.model.nu))
    resets = np.zeros(steps, dtype=bool)
    env.reset()
    for t, a in enumerate(actions):
        ts = env.step(a)
        ctrls[t] = physics.data.ctrl
        if ts.last():
            resets[t] = True
            env.reset()
    model = physics.model.ptr  # The same compiled mujoco.MjModel.
    data = mujoco.MjData(model)
    env.reset()
    qpos0, qvel0 = physics.data.qpos.copy(), physics.data.qvel.copy()
    best = np.inf
    for _ in range(repeats):
        data.qpos[:], data.qvel[:] = qpos0, qvel0
        mujoco.mj_forward(model, data)
        start = time.perf_counter()
        for t in range(steps):
            data.ctrl[:] = ctrls[t]
            mujoco.mj_step(model, data, n_sub)
            if resets[t]:
                data.qpos[:], data.qvel[:] = qpos0, qvel0
        best = min(best, time.perf_counter() - start)
    return steps / best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=20000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--tasks", default=",".join(cpg_suite.TASK_IDS))
    args = parser.parse_args()
    tasks = [t for t in args.tasks.split(",") if t]
    for t in tasks:
        cpg_suite.split_task_id(t)  # Raises with the valid ids.

    header = (
        f"{'task':28s} {'substeps':>8s} {'env steps/s':>12s} {'raw steps/s':>12s} "
        f"{'env/raw':>8s} {'peer':>18s} {'peer steps/s':>13s} {'env/peer':>9s}"
    )
    print(header)
    print("-" * len(header))
    peer_rates = {}
    for task_id in tasks:
        domain, _ = cpg_suite.split_task_id(task_id)
        env = cpg_suite.load(task_id, task_kwargs={"random": 0})
        n_sub = int(round(env.control_timestep() / env.physics.model.opt.timestep))
        raw = time_raw(env, args.steps, args.repeats)
        rate = time_env(env, args.steps, args.repeats)
        peer = PEERS.get(domain)
        peer_name, peer_rate = "-", float("nan")
        if peer is not None:
            peer_name = "/".join(peer)
            if peer not in peer_rates:
                from dm_control import suite  # After cpg_suite has chosen the GL backend.

                peer_env = suite.load(*peer, task_kwargs={"random": 0})
                peer_rates[peer] = time_env(peer_env, args.steps, args.repeats)
            peer_rate = peer_rates[peer]
        print(
            f"{task_id:28s} {n_sub:8d} {rate:12.0f} {raw:12.0f} {rate / raw:8.3f} "
            f"{peer_name:>18s} {peer_rate:13.0f} {rate / peer_rate:9.2f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
