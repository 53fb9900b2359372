r"""Vectorized env vs Gymnasium's SyncVectorEnv over shimmy envs vs raw `mujoco.rollout`.

  python benchmarks/bench_vector_env.py [--num_envs=16] [--threads=2] [--steps=250] [--repeats=3]

All three walk the hand-tuned open-loop gait on `darwin_walk` from the same 16 starts for
`steps` control steps (no falls, so every environment simulates the whole time):

* sync: `gymnasium.make_vec(..., vectorization_mode="sync")`, one shimmy-wrapped
  dm_control environment per Python call;
* vector: `gymnasium.make_vec(...)`, i.e. `cpg_suite.vector.DarwinVectorEnv` with `threads`;
* rollout: `mujoco.rollout` with `threads` over the same initial states and controls (the
  physics alone: no observations, rewards or Python per step).

They run alternately `repeats` times. Prints control steps per second of sync and vector
and their ratio (goal ≥ 3), and the physics steps per second of vector and rollout and
their ratio (goal ≥ 0.8).
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import time

import gymnasium
import mujoco
import numpy as np
from absl import flags
from mujoco import rollout

import cpg_suite
import cpg_suite.gym  # registers the environments
from cpg_suite import cli, cpg

_ENV_ID, _SEED = "cpg_suite/darwin_walk-v0", 100


def _gait(steps: int):
    env = cpg_suite.load("darwin_walk")
    targets = cpg.trajectories(cpg.amplitudes_from("hand_tuned"), steps, env.control_timestep())
    return env.physics.targets_to_action(targets[0]), env.physics.controls_for(targets[0])


def _episode(envs, actions: np.ndarray) -> tuple[float, int]:
    """Seconds for `len(actions)` steps of every sub-environment (after a seeded reset)."""
    envs.reset(seed=_SEED)
    batch = np.repeat(actions[:, None, :], envs.num_envs, axis=1)
    start = time.perf_counter()
    for a in batch:
        _, _, terminated, _, _ = envs.step(a)
        assert not terminated.any(), "the gait fell: the comparison needs whole episodes"
    return time.perf_counter() - start, len(actions) * envs.num_envs


def _raw(vector_env, controls: np.ndarray, threads: int) -> tuple[float, int]:
    """Seconds for the same physics through `mujoco.rollout` (controls held per substep)."""
    vector_env.reset(seed=_SEED)
    models = [e.physics.model.ptr for e in vector_env.envs]
    state_kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
    states = np.empty((len(models), mujoco.mj_stateSize(models[0], state_kind)))
    for i, e in enumerate(vector_env.envs):
        mujoco.mj_getState(e.physics.model.ptr, e.physics.data.ptr, states[i], state_kind)
    control = np.repeat(controls, vector_env.n_sub, axis=0)
    control = np.broadcast_to(control, (len(models),) + control.shape).copy()
    datas = [mujoco.MjData(models[0]) for _ in range(threads)]
    with rollout.Rollout(nthread=threads) as runner:
        start = time.perf_counter()
        runner.rollout(models, datas, states, control)
        return time.perf_counter() - start, control.shape[0] * control.shape[1]


@dataclasses.dataclass(frozen=True)
class BenchVectorEnvSettings:
    """What the benchmark measures.

    Attributes:
      num_envs: Sub-environments (the same number of rollouts).
      threads: Threads of the vector env and of the rollout.
      steps: Control steps per episode.
      repeats: Alternating repetitions of the three.
    """

    num_envs: int = 16
    threads: int = 2
    steps: int = 250
    repeats: int = 3

    def __post_init__(self):
        cli.require(self.num_envs >= 1, f"--num_envs must be ≥ 1, got {self.num_envs}")
        cli.require(self.threads >= 1, f"--threads must be ≥ 1, got {self.threads}")
        cli.require(self.steps >= 1, f"--steps must be ≥ 1, got {self.steps}")
        cli.require(self.repeats >= 1, f"--repeats must be ≥ 1, got {self.repeats}")


def benchmark(settings: BenchVectorEnvSettings) -> None:
    """Times sync, vector and rollout alternately; prints their rates and ratios.

    Args:
      settings: Environments, threads, steps and repeats.
    """
    actions, controls = _gait(settings.steps)
    sync = gymnasium.make_vec(_ENV_ID, num_envs=settings.num_envs, vectorization_mode="sync")
    ours = gymnasium.make_vec(_ENV_ID, num_envs=settings.num_envs, threads=settings.threads)
    wall = dict.fromkeys(("sync", "vector", "rollout"), 0.0)
    count = dict.fromkeys(wall, 0)
    for _ in range(settings.repeats):
        for name, (seconds, n) in (
            ("sync", _episode(sync, actions)),
            ("vector", _episode(ours, actions)),
            ("rollout", _raw(ours, controls, settings.threads)),
        ):
            wall[name] += seconds
            count[name] += n
    control_rate = {k: count[k] / wall[k] for k in ("sync", "vector")}
    physics_rate = {
        "vector": control_rate["vector"] * ours.n_sub,
        "rollout": count["rollout"] / wall["rollout"],
    }
    print(
        f"N={settings.num_envs}, {settings.threads} threads, {settings.steps} control steps x "
        f"{settings.repeats}: sync {control_rate['sync']:,.0f} control steps/s, vector "
        f"{control_rate['vector']:,.0f}; vector/sync "
        f"{control_rate['vector'] / control_rate['sync']:.2f} (goal >= 3)"
    )
    print(
        f"physics steps/s: vector {physics_rate['vector']:,.0f}, raw mujoco.rollout "
        f"{physics_rate['rollout']:,.0f}; vector/rollout "
        f"{physics_rate['vector'] / physics_rate['rollout']:.2f} (goal >= 0.8)"
    )


def define_flags() -> None:
    """Defines this script's command-line flags (only when it runs as a program)."""
    d = BenchVectorEnvSettings()
    flags.DEFINE_integer("num_envs", d.num_envs, "Sub-environments.")
    flags.DEFINE_integer("threads", d.threads, "Threads of the vector env and the rollout.")
    flags.DEFINE_integer("steps", d.steps, "Control steps per episode.")
    flags.DEFINE_integer("repeats", d.repeats, "Alternating repetitions.")


def main(argv: list[str]) -> None:
    del argv
    benchmark(cli.settings_from_flags(BenchVectorEnvSettings))


if __name__ == "__main__":
    define_flags()
    cli.run(main)
