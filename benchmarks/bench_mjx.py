r"""Control steps per second of the MJX walking env under `vmap` + `jit`, against the CPU.

  python benchmarks/bench_mjx.py [--batches=1024,8192,32768] [--steps=20] [--cpu_envs=16]
      [--impl=jax,warp] [--physics=reference,training] [--ppo_envs=8192 --ppo_steps=N]
      [--iterations=N --ls_iterations=N] [--contacts=soles] [--timestep=0.004]

For each MJX backend (`--impl`: "jax", MJX's JAX code; "warp", MuJoCo Warp) and named
physics (`--physics`: "reference", the CPU task's; "training", what the GPU trainers step,
`cpg_suite.mjx.PHYSICS`), and each batch size B, B robots are reset
(`jax.vmap(WalkEnv.reset)`) and stepped `steps` control steps with the hand-tuned gait's
actions by one jitted `jax.vmap(WalkEnv.step)` (compilation timed apart, after one warm-up
step). In the same run, the CPU vector env (`cpg_suite.vector.make_vector_env`,
`--threads` threads, `--cpu_envs` robots) steps the same actions. Prints control steps/s of
each and their ratio MJX / CPU. With `--ppo_steps`, Brax's PPO (`baselines.ppo_mjx`'s
trainer and settings, `--ppo_envs` environments) then trains that many env steps on each
backend and physics, and its env steps/s while training are printed (Brax's
`training/sps` of the second half of the steps: collection and updates, compilation
excluded) with the wall time including compilation. JAX runs on its default device (CPU
here unless a GPU build and device are present; float32 unless `--x64`, which only the
JAX reference physics accepts).
`--iterations` / `--ls_iterations`, `--contacts` and `--timestep` override those parts of
every physics measured (results/mjx: the solver's iterations are the main cost under
`vmap`, where every robot waits for the slowest).
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
      impl: MJX backends, comma-separated (`walk.IMPLS`).
      physics: Named physics, comma-separated (`walk.PHYSICS`).
      x64: float64 MJX physics (default float32, the precision of GPU training).
      iterations: MJX solver iterations (0, with `ls_iterations` 0: the physics' own).
      ls_iterations: MJX line-search iterations (0: the physics' own).
      contacts: `WalkEnv`'s contact pairs ("": the physics' own).
      timestep: The physics step, s (0: the physics' own).
      ppo_steps: Env steps of the PPO throughput run (0: none).
      ppo_envs: Environments of the PPO throughput run.
    """

    batches: str = "1024,8192,32768"
    steps: int = 20
    cpu_envs: int = 16
    threads: int = 2
    task: str = "darwin_walk"
    impl: str = "jax,warp"
    physics: str = "reference,training"
    x64: bool = False
    iterations: int = 0
    ls_iterations: int = 0
    contacts: str = ""
    timestep: float = 0.0
    ppo_steps: int = 0
    ppo_envs: int = 8192

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
            all(i in walk.IMPLS for i in self.impl.split(",")),
            f"--impl must be a comma list of {', '.join(walk.IMPLS)}, got {self.impl!r}",
        )
        cli.require(
            all(p in walk.PHYSICS for p in self.physics.split(",")),
            f"--physics must be a comma list of {', '.join(walk.PHYSICS)}, got {self.physics!r}",
        )
        cli.require(
            not self.x64 or (self.impl == "jax" and self.physics == "reference"),
            "--x64 runs only --impl=jax --physics=reference (the others are float32)",
        )
        cli.require(
            (self.iterations >= 1 and self.ls_iterations >= 1)
            or (self.iterations == 0 and self.ls_iterations == 0),
            "--iterations and --ls_iterations must both be ≥ 1, or both 0 (the physics' own), "
            f"got {self.iterations} and {self.ls_iterations}",
        )
        cli.require(
            self.contacts in ("", *walk.CONTACTS),
            f"--contacts must be one of {', '.join(walk.CONTACTS)} or empty, got {self.contacts!r}",
        )
        if self.timestep != 0:  # 0: the physics' own
            walk.physics_settings("reference", timestep=self.timestep)
        cli.require(self.ppo_steps >= 0, f"--ppo_steps must be ≥ 0, got {self.ppo_steps}")
        cli.require(
            self.ppo_envs >= 8 and self.ppo_envs % 8 == 0,
            f"--ppo_envs must be a multiple of 8 (PPO's minibatches), got {self.ppo_envs}",
        )

    def env_kwargs(self, impl: str, physics: str) -> dict:
        """`WalkEnv`'s physics arguments for one backend and named physics."""
        caps = (self.iterations, self.ls_iterations) if self.iterations else None
        return {
            "physics": physics,
            "impl": impl,
            "solver_iterations": caps,
            "contacts": self.contacts or None,
            "timestep": self.timestep or None,
        }

    def batch_list(self) -> list[int]:
        """The batch sizes, parsed."""
        return [int(b) for b in self.batches.split(",")]

    def cases(self) -> list[tuple[str, str]]:
        """`(impl, physics)` pairs measured, in order."""
        return [(i, p) for i in self.impl.split(",") for p in self.physics.split(",")]


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

    Raises:
      RuntimeError: On Warp, if the robots' contacts overflowed the env's contact list.
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
    rate = batch * len(actions) / (time.perf_counter() - start)
    if env.impl == "warp" and int(np.max(state.data._impl.nacon)) > env.warp_naconmax:
        raise RuntimeError(f"Warp's contacts overflowed {env.warp_naconmax} slots at B={batch}")
    return rate, compile_s


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
    """Measures the CPU vector env, then MJX for each case and batch size; prints a line each.

    Args:
      settings: Batch sizes, steps, the CPU env's size and threads, task, backends, physics.

    Returns:
      One row per backend, physics and batch size: `impl`, `physics`, `batch`,
      `mjx_steps_per_s`, `compile_s`, `ratio`; then, with `ppo_steps`, one per backend and
      physics with `ppo_steps_per_s` and `ppo_wall_s`.
    """
    actions = gait_actions(settings.steps)
    cpu = cpu_rate(settings, actions)
    device = jax.devices()[0]
    print(
        f"CPU vector env ({settings.task}, {settings.cpu_envs} robots, {settings.threads} "
        f"threads): {cpu:,.0f} control steps/s; MJX on {device.platform} "
        f"({device.device_kind}), {settings.steps} steps",
        flush=True,
    )
    rows = []
    with jax.enable_x64(settings.x64):
        for impl, physics in settings.cases():
            kwargs = settings.env_kwargs(impl, physics)
            env = walk.WalkEnv(settings.task, max_robots=max(settings.batch_list()), **kwargs)
            print(f"impl={impl} physics={physics}: {describe(env)}", flush=True)
            for batch in settings.batch_list():
                rate, compile_s = mjx_rate(env, batch, actions)
                row = {"impl": impl, "physics": physics, "batch": batch}
                row.update(mjx_steps_per_s=rate, compile_s=compile_s, ratio=rate / cpu)
                rows.append(row)
                print(
                    f"B={batch:>5}: {rate:>10,.0f} control steps/s (compile {compile_s:.0f} s); "
                    f"MJX / CPU = {rate / cpu:.2f}",
                    flush=True,
                )
    for impl, physics in settings.cases() if settings.ppo_steps else ():
        sps, wall = ppo_rate(settings, impl, physics)
        rows.append({"impl": impl, "physics": physics, "ppo_steps_per_s": sps, "ppo_wall_s": wall})
        print(
            f"PPO impl={impl} physics={physics}, {settings.ppo_envs} envs: {sps:,.0f} env "
            f"steps/s while training; {settings.ppo_steps:,} steps in {wall:.0f} s with "
            f"compilation; PPO / CPU vector env = {sps / cpu:.2f}",
            flush=True,
        )
    return rows


def describe(env: walk.WalkEnv) -> str:
    """The env's physics in words: contacts, solver caps, timestep, float width."""
    opt = env.mj_model.opt
    width = env.model.qpos0.dtype
    return (
        f"contacts {env.contacts}, {opt.iterations} solver / {opt.ls_iterations} line-search "
        f"iterations, {opt.timestep * 1e3:g} ms physics step, {width}"
    )


def ppo_rate(settings: BenchMJXSettings, impl: str, physics: str) -> tuple[float, float]:
    """Brax PPO's env steps/s while training on MJX (`baselines.ppo_mjx`'s trainer).

    `baselines.ppo_mjx`'s settings with `ppo_envs` environments (minibatches of an eighth),
    trained `ppo_steps` env steps in two of Brax's training epochs with no validation; the
    physics as `WalkEnv` gets it here. The first epoch compiles; the rate is the second's.

    Returns:
      `(env steps/s, Brax's training/sps of the second epoch; wall time, s, compilation
      included)`.
    """
    from brax.training.agents.ppo import train as brax_ppo

    from baselines import ppo_mjx
    from cpg_suite.mjx import training

    ppo = ppo_mjx.PPOMJXSettings(
        task=settings.task,
        action_space="cpg",
        total_steps=settings.ppo_steps,
        num_envs=settings.ppo_envs,
        validation_every=max(1, settings.ppo_steps // 2),  # two epochs: Brax times each
        batch_size=settings.ppo_envs // 8,
        test_seeds=0,
        impl=impl,
    )
    kwargs = ppo_mjx.brax_train_kwargs(ppo)
    walk_env = walk.WalkEnv(
        settings.task, "cpg", max_robots=settings.ppo_envs, **settings.env_kwargs(impl, physics)
    )
    metrics = []
    start = time.perf_counter()
    with training.brax_on_this_jax():
        brax_ppo.train(
            training.BraxWalkEnv(walk_env), progress_fn=lambda _, m: metrics.append(m), **kwargs
        )
    return float(metrics[-1]["training/sps"]), time.perf_counter() - start


def define_flags() -> None:
    """Defines this script's command-line flags (only when it runs as a program)."""
    d = BenchMJXSettings()
    flags.DEFINE_string("batches", d.batches, "MJX batch sizes, comma-separated.")
    flags.DEFINE_integer("steps", d.steps, "Timed control steps per batch size.")
    flags.DEFINE_integer("cpu_envs", d.cpu_envs, "Robots of the CPU vector env.")
    flags.DEFINE_integer("threads", d.threads, "Threads of the CPU vector env.")
    flags.DEFINE_string("task", d.task, f"One of {', '.join(walk.TASKS)}.")
    flags.DEFINE_string("impl", d.impl, f"MJX backends, comma list of {', '.join(walk.IMPLS)}.")
    flags.DEFINE_string(
        "physics", d.physics, f"Named physics, comma list of {', '.join(walk.PHYSICS)}."
    )
    flags.DEFINE_bool("x64", d.x64, "float64 MJX physics (default float32).")
    flags.DEFINE_integer("iterations", d.iterations, "MJX solver iterations (0: the physics').")
    flags.DEFINE_integer(
        "ls_iterations", d.ls_iterations, "MJX line-search iterations (0: the physics')."
    )
    flags.DEFINE_string("contacts", d.contacts, "Contact pairs: model, soles (default: physics').")
    flags.DEFINE_float("timestep", d.timestep, "Physics step, s (0: the physics').")
    flags.DEFINE_integer("ppo_steps", d.ppo_steps, "Env steps of the PPO throughput run (0: none).")
    flags.DEFINE_integer("ppo_envs", d.ppo_envs, "Environments of the PPO throughput run.")


def main(argv: list[str]) -> None:
    del argv
    benchmark(cli.settings_from_flags(BenchMJXSettings))


if __name__ == "__main__":
    define_flags()
    cli.run(main)
