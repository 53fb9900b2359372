r"""Control steps per second of the MJX walking env under `vmap` + `jit`, against the CPU.

  python benchmarks/bench_mjx.py [--batches=1,64,1024,8192] [--steps=20] [--cpu_envs=16]
      [--iterations=N --ls_iterations=N] [--contacts=model,soles]

For each batch size B, B robots are reset (`jax.vmap(WalkEnv.reset)`) and stepped `steps`
control steps with the hand-tuned gait's actions by one jitted `jax.vmap(WalkEnv.step)`
(compilation timed apart, after one warm-up step). In the same run, the CPU vector env
(`cpg_suite.vector.make_vector_env`, `--threads` threads, `--cpu_envs` robots) steps the
same actions. Prints control steps/s of each and their ratio MJX / CPU. JAX runs on its
default device (CPU here unless a GPU build and device are present; float32 unless
`--x64`). `--iterations` / `--ls_iterations` cap MJX's constraint solver below the
model's own 100 / 50 (results/mjx: the main cost under `vmap`, where every robot waits for
the slowest); capped, the MJX physics is no longer the CPU reference's. `--contacts` lists
the contact pairs to measure, each at every batch size in the same run (`WalkEnv(contacts=
...)`: "model", every pair, or "soles", the floor's and soles' only).
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import time

import jax
import jax.numpy as jnp
import numpy as np
from absl import flags

from cpg_suite import cli, cpg, darwin
from cpg_suite.mjx import walk


@dataclasses.dataclass(frozen=True)
class BenchMJXSettings:
    """What the benchmark measures.

    Attributes:
      batches: MJX batch sizes, comma-separated.
      steps: Timed control steps per batch size (and on the CPU).
      cpu_envs: Robots of the CPU vector env.
      threads: Threads of the CPU vector env.
      task: One of `cpg_suite.mjx.TASKS`.
      x64: float64 MJX physics (default float32, the precision of GPU training).
      iterations: MJX solver iterations (0, with `ls_iterations` 0: the model's own, 100).
      ls_iterations: MJX line-search iterations (0: the model's own, 50).
      contacts: `WalkEnv`'s contact pairs, comma-separated (each measured in turn).
    """

    batches: str = "1,64,1024,8192"
    steps: int = 20
    cpu_envs: int = 16
    threads: int = 2
    task: str = "darwin_walk"
    x64: bool = False
    iterations: int = 0
    ls_iterations: int = 0
    contacts: str = "model"

    def __post_init__(self):
        cli.require(
            all(b.strip().isdigit() and int(b) >= 1 for b in self.batches.split(",")),
            f"--batches must be positive integers, got {self.batches!r}",
        )
        cli.require(self.steps >= 1, f"--steps must be ≥ 1, got {self.steps}")
        cli.require(self.cpu_envs >= 1, f"--cpu_envs must be ≥ 1, got {self.cpu_envs}")
        cli.require(self.threads >= 1, f"--threads must be ≥ 1, got {self.threads}")
        cli.require(self.task in walk.TASKS, f"--task must be one of {walk.TASKS}")
        cli.require(
            (self.iterations >= 1 and self.ls_iterations >= 1)
            or (self.iterations == 0 and self.ls_iterations == 0),
            "--iterations and --ls_iterations must both be ≥ 1, or both 0 (the model's own), "
            f"got {self.iterations} and {self.ls_iterations}",
        )
        cli.require(
            all(c in walk.CONTACTS for c in self.contacts.split(",")),
            f"--contacts must be a comma list of {', '.join(walk.CONTACTS)}, got {self.contacts!r}",
        )

    def solver_iterations(self) -> tuple[int, int] | None:
        """`WalkEnv`'s solver caps, or None for the model's own."""
        return (self.iterations, self.ls_iterations) if self.iterations else None

    def batch_list(self) -> list[int]:
        """The batch sizes, parsed."""
        return [int(b) for b in self.batches.split(",")]


def gait_actions(steps: int) -> np.ndarray:
    """(steps, 12) normalized actions of the hand-tuned gait (the robots walk, not fall)."""
    targets = cpg.trajectories(cpg.amplitudes_from("hand_tuned"), steps, darwin.CONTROL_TIMESTEP)
    env = walk.WalkEnv("darwin_walk")
    return np.asarray(env.targets_to_action(jnp.asarray(targets[0])))


def mjx_rate(env: walk.WalkEnv, batch: int, actions: np.ndarray) -> tuple[float, float]:
    """Control steps/s of B robots, and the compile time (s) of reset and step.

    Args:
      env: The MJX env.
      batch: B.
      actions: (steps, 12) actions, the same for every robot.

    Returns:
      `(steps_per_second, compile_seconds)`.
    """
    start = time.perf_counter()
    reset = jax.jit(jax.vmap(env.reset))
    step = jax.jit(jax.vmap(env.step))
    state = reset(jax.random.split(jax.random.key(0), batch))
    batched = jnp.broadcast_to(jnp.asarray(actions[0]), (batch, 12))
    state = jax.block_until_ready(step(state, batched))
    compile_s = time.perf_counter() - start
    start = time.perf_counter()
    for a in actions:
        state = step(state, jnp.broadcast_to(jnp.asarray(a), (batch, 12)))
    jax.block_until_ready(state)
    return batch * len(actions) / (time.perf_counter() - start), compile_s


def cpu_rate(settings: BenchMJXSettings, actions: np.ndarray) -> float:
    """Control steps/s of the CPU vector env stepping the same actions."""
    from cpg_suite import vector

    envs = vector.make_vector_env(settings.cpu_envs, settings.task, threads=settings.threads)
    try:
        envs.reset(seed=0)
        start = time.perf_counter()
        for a in actions:
            envs.step(np.broadcast_to(a, (settings.cpu_envs, 12)).astype(np.float64))
        return settings.cpu_envs * len(actions) / (time.perf_counter() - start)
    finally:
        envs.close()


def benchmark(settings: BenchMJXSettings) -> list[dict]:
    """Measures the CPU vector env, then MJX at each batch size; prints one line each.

    Args:
      settings: Batch sizes, steps, the CPU env's size and threads, task, precision.

    Returns:
      One row per contact pairs and batch size: `contacts`, `batch`, `mjx_steps_per_s`,
      `compile_s`, `ratio`.
    """
    actions = gait_actions(settings.steps)
    cpu = cpu_rate(settings, actions)
    device = jax.devices()[0]
    print(
        f"CPU vector env ({settings.task}, {settings.cpu_envs} robots, {settings.threads} "
        f"threads): {cpu:,.0f} control steps/s; MJX on {device.platform} "
        f"({device.device_kind}), float{64 if settings.x64 else 32}, {settings.steps} steps",
        flush=True,
    )
    rows = []
    with jax.enable_x64(settings.x64):
        for contacts in settings.contacts.split(","):
            env = walk.WalkEnv(
                settings.task, solver_iterations=settings.solver_iterations(), contacts=contacts
            )
            print(
                f"contacts: {contacts} ({env.mj_model.opt.iterations} solver iterations, "
                f"{env.mj_model.opt.ls_iterations} line-search iterations)",
                flush=True,
            )
            for batch in settings.batch_list():
                rate, compile_s = mjx_rate(env, batch, actions)
                rows.append(
                    {
                        "contacts": contacts,
                        "batch": batch,
                        "mjx_steps_per_s": rate,
                        "compile_s": compile_s,
                        "ratio": rate / cpu,
                    }
                )
                print(
                    f"B={batch:>5}: {rate:>10,.0f} control steps/s (compile {compile_s:.0f} s); "
                    f"MJX / CPU = {rate / cpu:.2f}",
                    flush=True,
                )
    return rows


def define_flags() -> None:
    """Defines this script's command-line flags (only when it runs as a program)."""
    d = BenchMJXSettings()
    flags.DEFINE_string("batches", d.batches, "MJX batch sizes, comma-separated.")
    flags.DEFINE_integer("steps", d.steps, "Timed control steps per batch size.")
    flags.DEFINE_integer("cpu_envs", d.cpu_envs, "Robots of the CPU vector env.")
    flags.DEFINE_integer("threads", d.threads, "Threads of the CPU vector env.")
    flags.DEFINE_string("task", d.task, f"One of {', '.join(walk.TASKS)}.")
    flags.DEFINE_bool("x64", d.x64, "float64 MJX physics (default float32).")
    flags.DEFINE_integer("iterations", d.iterations, "MJX solver iterations (0: the model's).")
    flags.DEFINE_integer(
        "ls_iterations", d.ls_iterations, "MJX line-search iterations (0: the model's)."
    )
    flags.DEFINE_string("contacts", d.contacts, "Contact pairs to measure: model, soles.")


def main(argv: list[str]) -> None:
    del argv
    benchmark(cli.settings_from_flags(BenchMJXSettings))


if __name__ == "__main__":
    define_flags()
    cli.run(main)
