r"""A CPG gait (default hand-tuned) in the MJX env and in the CPU reference, from one state.

  python investigations/mjx_agreement.py [--params=hand_tuned] [--seeds=0-4] [--steps=1000] \
      [--precisions=64,32] [--physics=reference] [--impl=jax] [--solver_iterations=4,8] \
      [--contacts=soles] [--timestep=0.004]

For each seed, the CPU task `darwin_walk` is reset with it (`evaluation.gait.evaluate_gait`
runs the trial); its reset state is put into MJX (`WalkEnv.state_from_mujoco`) and the same
joint-target actions are stepped there, in float64 and in float32 (the precision of GPU
training). Prints each trial's distance, lateral drift and fall in both, and the largest
differences; for scale, also the CPU trial from a start moved by 1e-9 rad per leg joint.
`--physics` names the MJX physics (`walk.PHYSICS`: "reference" or "training", which runs in
float32 only) and `--impl` MJX's backend ("jax" or "warp", float32 only); the three flags
after them override the physics' parts: `--solver_iterations=I,L` caps MJX's constraint
solver, `--contacts=soles` computes only the floor's and soles' contact pairs and
`--timestep` sets the physics step (s; the control step stays 16 ms). Needs the `mjx`
extra; runs on whatever device JAX picks.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import functools
import json
import time

import jax
import numpy as np
from absl import flags

import cpg_suite
from cpg_suite import cli, cpg, darwin
from cpg_suite.darwin import pose as darwin_pose
from cpg_suite.evaluation.gait import evaluate_gait, parse_params
from cpg_suite.mjx import walk

_PRECISIONS = (64, 32)
_EPS = 1e-9  # rad: the change of the start posture in the CPU's own sensitivity trial.


@dataclasses.dataclass(frozen=True)
class AgreementSettings:
    """What the comparison runs.

    Attributes:
      params: A preset (`cpg.PRESETS`) or a JSON file of the 11 amplitudes.
      seeds: Initial-state seeds of the CPU task: `N`, `A-B` or a comma list.
      steps: Control steps per trial.
      precisions: MJX float widths to run, comma-separated (64 and/or 32).
      physics: The MJX physics (`walk.PHYSICS`).
      impl: MJX's backend (`walk.IMPLS`).
      solver_iterations: `I,L`: MJX's solver and line-search iteration caps ("": the
        physics' own).
      contacts: MJX's contact pairs (`walk.CONTACTS`; "": the physics' own).
      timestep: The physics step, s ("": the physics' own).
    """

    params: str = "hand_tuned"
    seeds: str = "0-4"
    steps: int = 1000
    precisions: str = "64,32"
    physics: str = "reference"
    impl: str = "jax"
    solver_iterations: str = ""
    contacts: str = ""
    timestep: str = ""

    def __post_init__(self):
        parse_params(self.params)  # a preset or a readable file of amplitudes
        cli.parse_seeds(self.seeds)
        cli.require(
            self.physics in walk.PHYSICS,
            f"--physics must be one of {', '.join(walk.PHYSICS)}, got {self.physics!r}",
        )
        cli.require(
            self.impl in walk.IMPLS,
            f"--impl must be one of {', '.join(walk.IMPLS)}, got {self.impl!r}",
        )
        cli.require(
            self.contacts in ("", *walk.CONTACTS),
            f"--contacts must be one of {', '.join(walk.CONTACTS)} or empty, got {self.contacts!r}",
        )
        self.solver_caps()
        self.physics_step()
        cli.require(self.steps >= 1, f"--steps must be ≥ 1, got {self.steps}")
        cli.require(
            set(self.precision_list()) <= set(_PRECISIONS) and self.precision_list(),
            f"--precisions must name 64 and/or 32, got {self.precisions!r}",
        )
        cli.require(
            self.precision_list() == [32] or (self.impl == "jax" and self.physics == "reference"),
            f"--impl={self.impl} --physics={self.physics} runs in float32 only: --precisions=32",
        )

    def solver_caps(self) -> tuple[int, int] | None:
        """The solver caps, parsed.

        Returns:
          `(iterations, line-search iterations)`, or None for the model's own.

        Raises:
          ValueError: Unless `solver_iterations` is empty or two integers ≥ 1 (`I,L`).
        """
        if not self.solver_iterations:
            return None
        parts = self.solver_iterations.split(",")
        cli.require(
            len(parts) == 2 and all(p.strip().isdigit() and int(p) >= 1 for p in parts),
            f"--solver_iterations must be two integers ≥ 1 (I,L), got {self.solver_iterations!r}",
        )
        return int(parts[0]), int(parts[1])

    def physics_step(self) -> float | None:
        """The physics step, s, parsed (None: the physics' own).

        Raises:
          ValueError: Unless `timestep` is empty or a number that divides the control step.
        """
        if not self.timestep:
            return None
        try:
            value = float(self.timestep)
        except ValueError:
            raise ValueError(f"--timestep must be a number of s, got {self.timestep!r}") from None
        walk.physics_settings("reference", timestep=value)  # ValueError unless it divides 16 ms
        return value

    def env_kwargs(self) -> dict:
        """`walk.WalkEnv`'s physics arguments."""
        return {
            "physics": self.physics,
            "impl": self.impl,
            "solver_iterations": self.solver_caps(),
            "contacts": self.contacts or None,
            "timestep": self.physics_step(),
        }

    def precision_list(self) -> list[int]:
        """The float widths, parsed (unparseable entries become 0, which fails the check)."""
        return [int(p) if p.strip().isdigit() else 0 for p in self.precisions.split(",")]


def mjx_trials(
    amplitudes: np.ndarray, seeds: list[int], steps: int, x64: bool, env_kwargs: dict
) -> list[dict]:
    """A gait in MJX from the CPU task's reset state for each seed.

    Args:
      amplitudes: The gait's 11 amplitudes, degrees.
      seeds: The CPU task's seeds.
      steps: Control steps.
      x64: float64 physics (else float32).
      env_kwargs: `walk.WalkEnv`'s physics arguments (`AgreementSettings.env_kwargs`).

    Returns:
      Per seed, as `walk.trial_result`, plus `seconds` (wall time; the first trial's
      includes the compilation).
    """
    targets = cpg.trajectories(amplitudes, steps, darwin.CONTROL_TIMESTEP)
    results = []
    with jax.enable_x64(x64):
        env = walk.WalkEnv("darwin_walk", max_robots=1, **env_kwargs)
        run = jax.jit(functools.partial(walk.rollout, env))
        for seed in seeds:
            start = time.perf_counter()
            cpu = cpg_suite.load("darwin_walk", task_kwargs={"random": seed})
            cpu.reset()
            state = env.state_from_mujoco(cpu.physics.data)
            out = jax.device_get(run(state, cpu.physics.targets_to_action(targets[0])))
            result = walk.trial_result(out, cpu.physics.torso_position()[:2])
            results.append({**result, "seconds": round(time.perf_counter() - start, 1)})
    return results


def cpu_perturbed_trial(amplitudes: np.ndarray, seed: int, steps: int, eps: float = _EPS) -> dict:
    """The CPU trial of `seed` with every leg joint's start angle moved by `eps` rad.

    How far the reference's own trials move for a roundoff-sized change of the start: the
    scale against which the MJX-CPU gap is judged.

    Args:
      amplitudes: The gait's 11 amplitudes, degrees.
      seed: The CPU task's seed.
      steps: Control steps.
      eps: The change of each leg joint angle, rad.

    Returns:
      `distance_m`, `lateral_m`, `fall_step`.
    """
    env = cpg_suite.load("darwin_walk", task_kwargs={"random": seed, "time_limit": float("inf")})
    env.reset()
    physics = env.physics
    legs = physics.leg_joint_angles() + eps
    with physics.reset_context():
        darwin_pose.set_standing_pose(physics, legs)
    targets = cpg.trajectories(amplitudes, steps, darwin.CONTROL_TIMESTEP)
    start = physics.torso_position()
    fall_step = None
    for t, action in enumerate(physics.targets_to_action(targets[0])):
        if env.step(action).last():
            fall_step = t + 1
            break
    end = physics.torso_position()
    return {
        "distance_m": float(end[0] - start[0]),
        "lateral_m": float(end[1] - start[1]),
        "fall_step": fall_step,
    }


def compare(settings: AgreementSettings) -> list[dict]:
    """Runs every seed on the CPU and in MJX; prints one JSON line per trial and a summary.

    Args:
      settings: Seeds, trial length and precisions.

    Returns:
      The rows printed (one per seed).
    """
    seeds = cli.parse_seeds(settings.seeds)
    amplitudes = parse_params(settings.params)
    mjx = {
        bits: mjx_trials(amplitudes, seeds, settings.steps, bits == 64, settings.env_kwargs())
        for bits in settings.precision_list()
    }
    keys = ("distance_m", "lateral_m", "fall_step")
    rows = []
    for i, seed in enumerate(seeds):
        cpu = evaluate_gait(amplitudes, seed, "darwin_walk", settings.steps)
        row = {"seed": seed, "cpu": {k: cpu[k] for k in keys}}
        row["cpu_perturbed"] = cpu_perturbed_trial(amplitudes, seed, settings.steps)
        for bits, results in mjx.items():
            row[f"mjx_f{bits}"] = {k: results[i][k] for k in (*keys, "seconds")}
        rows.append(row)
        print(json.dumps(row), flush=True)
    cpu_falls = sum(r["cpu"]["fall_step"] is not None for r in rows)
    for name in (*(f"mjx_f{bits}" for bits in mjx), "cpu_perturbed"):
        gap = [abs(r[name]["distance_m"] - r["cpu"]["distance_m"]) for r in rows]
        side = [abs(r[name]["lateral_m"] - r["cpu"]["lateral_m"]) for r in rows]
        falls = sum(r[name]["fall_step"] is not None for r in rows)
        print(
            f"{name}: max |distance - CPU| {max(gap):.2e} m, max |lateral - CPU| "
            f"{max(side):.2e} m over {len(rows)} seeds; falls {falls} (CPU {cpu_falls})"
        )
    return rows


def define_flags() -> None:
    """Defines this script's command-line flags (only when it runs as a program)."""
    d = AgreementSettings()
    flags.DEFINE_string("params", d.params, "Preset or JSON file of the 11 amplitudes.")
    flags.DEFINE_string("seeds", d.seeds, "Seeds of the CPU task: N, A-B or a comma list.")
    flags.DEFINE_integer("steps", d.steps, "Control steps per trial.")
    flags.DEFINE_string("precisions", d.precisions, "MJX float widths: 64 and/or 32.")
    flags.DEFINE_string("physics", d.physics, f"MJX physics: {', '.join(walk.PHYSICS)}.")
    flags.DEFINE_string("impl", d.impl, f"MJX backend: {', '.join(walk.IMPLS)}.")
    flags.DEFINE_string(
        "solver_iterations", d.solver_iterations, "I,L: MJX solver caps (default the physics')."
    )
    flags.DEFINE_string(
        "contacts",
        d.contacts,
        f"MJX contact pairs: {', '.join(walk.CONTACTS)} (default: the physics').",
    )
    flags.DEFINE_string("timestep", d.timestep, "Physics step, s (default the physics').")


def main(argv: list[str]) -> None:
    del argv
    compare(cli.settings_from_flags(AgreementSettings))


if __name__ == "__main__":
    define_flags()
    cli.run(main)
