r"""Where a DARwIn-OP `env.step` spends its time, per control step: MuJoCo's and ours, by part.

  python benchmarks/bench_step_profile.py [--tasks=darwin_walk,darwin_balance] [--steps=2000]
      [--repeats=3] [--clock=wall]

For each task, in one process and one run (the hand-tuned CPG gait, as `bench_env.py`):
  * `env.step`: µs per control step, plain (best of `--repeats`);
  * the same steps with each part timed, in one more pass: MuJoCo's calls (`mj_step2`,
    `mj_step`, `mj_step1` in `Physics.step`; `mj_forwardSkip` before the balance reward's
    contact forces) and ours: the per-physics-step recording loop (`Physics.step` less its
    MuJoCo calls), the supply meter (`after_step`: the currents, then the monitor's
    running total and window), the reward (walk: the torso's travel;
    balance: the centres of pressure's Python loop, less its `mj_forwardSkip`), the
    observation's assembly, the action's scaling (`before_step`), the fall and brown-out
    test, and dm_control's `Environment.step` around them (the rest). Each part is less
    the timers' own cost (measured on an empty call), so the parts and the rest add up to
    the pass's total less the timers' cost; the shares are of that total;
  * the floor: the same physics steps as a bare Python loop of `mj_step` calls, and as a
    single-thread `mujoco.rollout` (C loop), from the task's initial state with the
    controls the task set.
The portable elementary functions (`cpg_suite.portable`) do not run in `env.step` (the CPG
that calls them runs in the caller, `bench_cpg.py` times it). Absolute times are noisy on
a shared machine; the shares and ratios of one run are the figures to compare, and
`--clock=cpu` times the process's CPU time instead of the wall clock (steadier when other
work shares the cores; each reading then costs a system call, which the timed total shows).
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import collections
import dataclasses
import os
import sys
import time

import mujoco
import numpy as np
from absl import flags

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import bench_env

import cpg_suite
from cpg_suite import cli
from cpg_suite.darwin import recording

MUJOCO_CALLS = ("mj_step", "mj_step2", "mj_step1", "mj_forwardSkip")
TASK_HOOKS = ("before_step", "after_step", "get_reward", "get_observation", "get_termination")


CLOCKS = {
    "wall": (time.perf_counter, time.perf_counter_ns),
    "cpu": (time.process_time, time.process_time_ns),
}


class Clock:
    """Nanoseconds spent in wrapped callables, by name, while `active`."""

    def __init__(self, now_ns):
        self.ns, self.calls = collections.Counter(), collections.Counter()
        self.active = False
        self.now_ns = now_ns

    def wrap(self, name: str, fn):
        def timed(*args, **kwargs):
            if not self.active:
                return fn(*args, **kwargs)
            start = self.now_ns()
            try:
                return fn(*args, **kwargs)
            finally:
                self.ns[name] += self.now_ns() - start
                self.calls[name] += 1

        return timed

    def costs(self, now, n: int = 20000) -> tuple[float, float]:
        """The timer's own cost per wrapped call, ns: `(inner, full)`, what a call's own
        reading holds beyond its callee and what it adds to an enclosing reading."""

        def noop():
            return None

        timed = self.wrap("_noop", noop)
        self.active = True
        start = now()
        for _ in range(n):
            timed()
        wrapped = now() - start
        start = now()
        for _ in range(n):
            noop()
        bare = now() - start
        self.active = False
        inner = self.ns.pop("_noop") / n
        del self.calls["_noop"]
        return inner, (wrapped - bare) * 1e9 / n


def _steps(env, actions, now, clock: Clock | None = None) -> float:
    """Seconds of `env.step` over `actions` (resets, when an episode ends, not counted)."""
    env.reset()
    total = 0.0
    for a in actions:
        if clock is not None:
            clock.active = True
        start = now()
        last = env.step(a).last()
        total += now() - start
        if clock is not None:
            clock.active = False
        if last:
            env.reset()
    return total


def bare_mj_step(env, actions, repeats: int, now) -> float:
    """Best-of-`repeats` seconds of the same physics steps as a Python loop of `mj_step`."""
    physics = env.physics
    n_sub = int(round(env.control_timestep() / physics.model.opt.timestep))
    env.reset()
    model = physics.model.ptr
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    initial = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, physics.data.ptr, initial, spec)
    ctrls = np.empty((len(actions), model.nu))
    for t, a in enumerate(actions):
        if env.step(a).last():
            env.reset()
        ctrls[t] = physics.data.ctrl
    data = mujoco.MjData(model)
    step = mujoco.mj_step
    best = np.inf
    for _ in range(repeats):
        mujoco.mj_setState(model, data, initial, spec)
        start = now()
        for c in ctrls:
            data.ctrl[:] = c
            for _ in range(n_sub):
                step(model, data)
        best = min(best, now() - start)
    return best


@dataclasses.dataclass(frozen=True)
class StepProfileSettings:
    """What the profile times.

    Attributes:
      steps: Control steps per timing.
      repeats: Timings of the plain and floor figures (the best is kept).
      tasks: DARwIn-OP task ids.
      clock: "wall" (the wall clock) or "cpu" (the process's CPU time).
    """

    steps: int = 2000
    repeats: int = 3
    tasks: tuple[str, ...] = ("darwin_walk", "darwin_balance")
    clock: str = "wall"

    def __post_init__(self):
        cli.require(self.steps >= 1, f"--steps must be ≥ 1, got {self.steps}")
        cli.require(self.repeats >= 1, f"--repeats must be ≥ 1, got {self.repeats}")
        tasks = tuple(t for t in self.tasks if t)
        cli.require(bool(tasks), "--tasks must name at least one task")
        cli.require(self.clock in CLOCKS, f"--clock must be wall or cpu, got {self.clock!r}")
        for t in tasks:
            cli.require(t.startswith("darwin_"), f"--tasks: {t!r} is not a DARwIn-OP task")
            try:
                cpg_suite.split_task_id(t)
            except ValueError as e:
                raise ValueError(f"--tasks: {e}") from None
        object.__setattr__(self, "tasks", tasks)


def profile(task_id: str, steps: int, repeats: int, clock: str) -> list[tuple[str, float]]:
    """(part, µs per control step) rows for one task; see the module's docstring."""
    now, now_ns = CLOCKS[clock]
    env = cpg_suite.load(task_id, task_kwargs={"random": 0})
    actions = bench_env.make_actions(env, "darwin", steps)
    n_sub = int(round(env.control_timestep() / env.physics.model.opt.timestep))
    per = 1e6 / steps
    plain = min(_steps(env, actions, now) for _ in range(repeats)) * per
    rollout = n_sub * 1e6 / bench_env.time_raw(env, actions, repeats, now)
    bare = bare_mj_step(env, actions, repeats, now) * per

    timer = Clock(now_ns)
    saved = {name: getattr(mujoco, name) for name in MUJOCO_CALLS}
    meter = recording.supply_sums
    task, physics = env.task, env.physics
    try:
        for name in MUJOCO_CALLS:
            setattr(mujoco, name, timer.wrap(name, saved[name]))
        recording.supply_sums = timer.wrap("supply_sums", meter)
        for hook in TASK_HOOKS:
            setattr(task, hook, timer.wrap(hook, getattr(task, hook)))
        physics.step = timer.wrap("Physics.step", physics.step)
        timed = _steps(env, actions, now, timer) * per
    finally:
        for name, fn in saved.items():
            setattr(mujoco, name, fn)
        recording.supply_sums = meter
        for hook in TASK_HOOKS:
            delattr(task, hook)
        del physics.step
    inner, full = timer.costs(now)

    def own(name: str, *children: str) -> float:
        """µs per control step in `name` itself: its readings less the timer's cost and
        less what its (timed) children took, with their timers."""
        ns = timer.ns[name] - timer.calls[name] * inner
        for child in children:
            ns -= timer.ns[child] + timer.calls[child] * (full - inner)
        return ns / 1e3 / steps

    mj_physics = sum(own(n) for n in ("mj_step", "mj_step2", "mj_step1"))
    mj_contacts = own("mj_forwardSkip")
    parts = [
        ("  MuJoCo: mj_step2 + mj_step + mj_step1", mj_physics),
        ("  MuJoCo: mj_forwardSkip (contact forces)", mj_contacts),
        (
            "  ours: recording loop (Physics.step less MuJoCo)",
            own("Physics.step", "mj_step", "mj_step2", "mj_step1"),
        ),
        ("  ours: supply meter: power sums (NumPy, 8 steps x 20 servos)", own("supply_sums")),
        ("  ours: supply meter: the monitor's update", own("after_step", "supply_sums")),
        ("  ours: reward less mj_forwardSkip", own("get_reward", "mj_forwardSkip")),
        ("  ours: observation assembly", own("get_observation")),
        ("  ours: action scaling (before_step)", own("before_step")),
        ("  ours: fall / brown-out test", own("get_termination")),
    ]
    # The timed pass less every timer's cost: the parts and the rest add up to it.
    untimed = timed - sum(timer.calls.values()) * full / 1e3 / steps
    rest = untimed - sum(value for _, value in parts)
    return [
        ("env.step, plain", plain),
        ("env.step, timed pass less the timers' cost", untimed),
        *parts,
        ("  dm_control Environment.step and Python between, the rest", rest),
        ("floor: bare Python loop of mj_step", bare),
        ("floor: mujoco.rollout, 1 thread", rollout),
    ]


def main(argv: list[str]) -> None:
    del argv
    settings = cli.settings_from_flags(StepProfileSettings)
    for task_id in settings.tasks:
        rows = profile(task_id, settings.steps, settings.repeats, settings.clock)
        plain, untimed = rows[0][1], rows[1][1]
        print(f"{task_id}: µs per control step ({settings.steps} steps, {settings.clock} clock)")
        for name, value in rows:
            share = f"{100 * value / untimed:5.1f} %" if name.startswith("  ") else ""
            print(f"  {name:58s} {value:8.1f} {share}")
        rollout = rows[-1][1]
        print(f"  env/raw (rollout µs / plain µs): {rollout / plain:.3f}", flush=True)


def define_flags() -> None:
    """Defines this script's command-line flags (only when it runs as a program)."""
    d = StepProfileSettings()
    flags.DEFINE_integer("steps", d.steps, "Control steps per timing.")
    flags.DEFINE_integer("repeats", d.repeats, "Timings per floor figure (the best is kept).")
    flags.DEFINE_list("tasks", list(d.tasks), "DARwIn-OP task ids, comma-separated.")
    flags.DEFINE_enum("clock", d.clock, list(CLOCKS), "wall: the wall clock; cpu: CPU time.")


if __name__ == "__main__":
    define_flags()
    cli.run(main)
