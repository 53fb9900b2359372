r"""Per-task stepping throughput: `env.step` vs raw MuJoCo vs the closest dm_control task.

  python benchmarks/bench_env.py [--steps=10000] [--repeats=3] [--tasks=pole_balance,...]

For each task, in one process and one run:
  * `env.step`: control steps per second, and physics steps per second (× substeps);
  * raw physics: a single-thread `mujoco.rollout` of the same model from the same initial
    state with the same controls (each held for the substeps of its control step) — the
    floor of what any Python wrapper costs;
  * their ratio (env / raw, in physics steps per second): the share of raw speed an
    agent stepping the environment gets;
  * the `env.step` rate of the closest dm_control suite task as a peer to beat
    (`cartpole/balance` for the pole, `humanoid/walk` for the DARwIn-OP).
Controls: uniformly random actions for the pole; for the DARwIn-OP the hand-tuned CPG gait
(random joint targets would make the robot fall at once and lie on the floor, which is not
the work the benchmark's optimizers pay for). Each figure is the best of `--repeats`
timings; absolute rates are noisy on a shared machine, the ratios are the figures to
compare.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import time

import mujoco
import numpy as np
from absl import flags
from dm_env import specs
from mujoco import rollout

import cpg_suite
from cpg_suite import cli, cpg

PEERS = {"pole": ("cartpole", "balance"), "darwin": ("humanoid", "walk")}


def make_actions(env, domain: str, steps: int, seed: int = 0) -> np.ndarray:
    """The action sequence the task is timed with."""
    spec = env.action_spec()
    if domain == "darwin":
        episode = 1000  # control steps of one darwin episode
        targets = cpg.trajectories(
            cpg.amplitudes_from("hand_tuned"), episode, env.control_timestep()
        )[0]
        actions = env.physics.targets_to_action(targets)
        return np.resize(actions, (steps, actions.shape[1]))
    rng = np.random.RandomState(seed)
    if isinstance(spec, specs.DiscreteArray):
        return rng.randint(spec.num_values, size=steps)
    return rng.uniform(spec.minimum, spec.maximum, size=(steps,) + spec.shape)


def time_env(env, actions, repeats: int) -> float:
    """Best-of-`repeats` control steps per second of `env.step`."""
    best = np.inf
    for _ in range(repeats):
        env.reset()
        start = time.perf_counter()
        for a in actions:
            if env.step(a).last():
                env.reset()
        best = min(best, time.perf_counter() - start)
    return len(actions) / best


def time_raw(env, actions, repeats: int, now=time.perf_counter) -> float:
    """Best-of-`repeats` physics steps per second of a single-thread `mujoco.rollout`.

    The controls are those the task set for `actions` (recorded once), each repeated for
    the substeps of its control step; the rollout starts from the task's initial state.
    `now` is the clock (seconds), the wall clock unless given.
    """
    physics = env.physics
    n_sub = int(round(env.control_timestep() / physics.model.opt.timestep))
    env.reset()
    model = physics.model.ptr
    state_spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    initial = np.empty(mujoco.mj_stateSize(model, state_spec))
    mujoco.mj_getState(model, physics.data.ptr, initial, state_spec)
    ctrls = np.empty((len(actions), model.nu))
    for t, a in enumerate(actions):
        if env.step(a).last():
            env.reset()
        ctrls[t] = physics.data.ctrl
    controls = np.repeat(ctrls, n_sub, axis=0)[None]
    data = mujoco.MjData(model)
    best = np.inf
    for _ in range(repeats):
        start = now()
        rollout.rollout(model, data, initial[None], controls)
        best = min(best, now() - start)
    return controls.shape[1] / best


@dataclasses.dataclass(frozen=True)
class BenchEnvSettings:
    """What the benchmark times.

    Attributes:
      steps: Control steps per timing.
      repeats: Timings per figure (the best is kept).
      tasks: Task ids (None: every task of `cpg_suite.TASK_IDS`).
    """

    steps: int = 10000
    repeats: int = 3
    tasks: tuple[str, ...] | None = None

    def __post_init__(self):
        cli.require(self.steps >= 1, f"--steps must be ≥ 1, got {self.steps}")
        cli.require(self.repeats >= 1, f"--repeats must be ≥ 1, got {self.repeats}")
        tasks = cpg_suite.TASK_IDS if self.tasks is None else self.tasks
        tasks = tuple(t for t in tasks if t)
        cli.require(bool(tasks), "--tasks must name at least one task")
        for t in tasks:
            try:
                cpg_suite.split_task_id(t)
            except ValueError as e:
                raise ValueError(f"--tasks: {e}") from None
        object.__setattr__(self, "tasks", tasks)


def benchmark(settings: BenchEnvSettings) -> None:
    """Times each task and prints a table row per task as it is measured.

    Args:
      settings: Steps, repeats and tasks.
    """
    tasks, steps, repeats = settings.tasks, settings.steps, settings.repeats
    header = (
        f"{'task':24s} {'sub':>3s} {'env ctrl/s':>10s} {'env phys/s':>10s} "
        f"{'raw phys/s':>10s} {'env/raw':>7s} {'peer':>17s} {'peer ctrl/s':>11s} "
        f"{'env/peer':>8s}"
    )
    print(header)
    print("-" * len(header))
    peer_rates = {}
    for task_id in tasks:
        domain, _ = cpg_suite.split_task_id(task_id)
        env = cpg_suite.load(task_id, task_kwargs={"random": 0})
        n_sub = int(round(env.control_timestep() / env.physics.model.opt.timestep))
        actions = make_actions(env, domain, steps)
        raw = time_raw(env, actions, repeats)
        rate = time_env(env, actions, repeats)
        peer = PEERS.get(domain)
        peer_name, peer_rate = "-", float("nan")
        if peer is not None:
            peer_name = "/".join(peer)
            if peer not in peer_rates:
                from dm_control import suite  # After cpg_suite has chosen the GL backend.

                peer_env = suite.load(*peer, task_kwargs={"random": 0})
                peer_actions = make_actions(peer_env, "peer", steps)
                peer_rates[peer] = time_env(peer_env, peer_actions, repeats)
            peer_rate = peer_rates[peer]
        print(
            f"{task_id:24s} {n_sub:3d} {rate:10.0f} {rate * n_sub:10.0f} {raw:10.0f} "
            f"{rate * n_sub / raw:7.3f} {peer_name:>17s} {peer_rate:11.0f} "
            f"{rate / peer_rate:8.2f}",
            flush=True,
        )


def define_flags() -> None:
    """Defines this script's command-line flags (only when it runs as a program)."""
    d = BenchEnvSettings()
    flags.DEFINE_integer("steps", d.steps, "Control steps per timing.")
    flags.DEFINE_integer("repeats", d.repeats, "Timings per figure (the best is kept).")
    flags.DEFINE_list("tasks", list(d.tasks), "Task ids, comma-separated.")


def main(argv: list[str]) -> None:
    del argv
    benchmark(cli.settings_from_flags(BenchEnvSettings))


if __name__ == "__main__":
    define_flags()
    cli.run(main)
