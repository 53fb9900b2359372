"""Evaluating open-loop CPG gaits on the DARwIn-OP tasks by stepping the environment.

The command line is `python -m cpg_suite.evaluation.evaluate`.

`evaluate_gait` steps the dm_control environment control step by control step: it is the
reference that faster evaluators are checked against.
"""

from __future__ import annotations

import json
import os

import numpy as np
from dm_control.rl import control as rl_control

import cpg_suite
from cpg_suite import cpg, darwin

# The DARwIn-OP tasks a CPG gait runs on: the walking tiers and balancing.
DARWIN_TASKS = (
    "darwin_walk",
    "darwin_balance",
    "darwin_walk_randomized",
    "darwin_walk_push",
    "darwin_walk_rough",
    "darwin_walk_contact",
)


def evaluate_gait(
    amplitudes: np.ndarray,
    seed: int,
    task: str = "darwin_walk",
    steps: int = 1000,
    config: cpg.CPGConfig | None = None,
    task_kwargs: dict | None = None,
) -> dict:
    """One trial of an open-loop CPG gait, stepping the environment.

    Args:
      amplitudes: The 11 amplitudes, degrees.
      seed: The task's random seed (initial-state perturbation).
      task: `darwin_walk` or `darwin_balance`.
      steps: Control steps.
      config: CPG constants (the task starts in the CPG's standing posture).
      task_kwargs: Further task arguments (e.g. `servo_gain`).

    Returns:
      `seed`, `distance_m` (torso x displacement), `lateral_m` (torso y displacement),
      `fell`, `fall_step` (1-based control step of the fall, or null), `return`, and
      `error` (a physics error's message, which counts as a fall) when one occurred.
    """
    config = config or cpg.CPGConfig()
    # The CPG's open-loop trajectory (`cpg.trajectories`, checked against stepping `cpg.CPG`
    # in the tests): the same targets the batched evaluators use, bit for bit.
    targets = cpg.trajectories(amplitudes, steps, darwin.CONTROL_TIMESTEP, config)[0]
    kwargs = {"random": seed, "posture": config.offsets(), "time_limit": float("inf")}
    env = cpg_suite.load(task, task_kwargs={**kwargs, **(task_kwargs or {})})
    physics = env.physics
    if env.control_timestep() != darwin.CONTROL_TIMESTEP:
        raise ValueError(
            f"{task} has a control step of {env.control_timestep()} s, "
            f"expected {darwin.CONTROL_TIMESTEP}"
        )
    env.reset()
    start = end = physics.torso_position()
    fall_step, total, error = None, 0.0, None
    for t in range(steps):
        action = physics.targets_to_action(targets[t])
        try:
            ts = env.step(action)
        except rl_control.PhysicsError as e:
            # A divergent state is a fall; MuJoCo has reset the model, so the displacement
            # is the one after the last valid control step.
            fall_step, error = t + 1, str(e)
            break
        end = physics.torso_position()
        total += ts.reward
        if ts.last():
            fall_step = t + 1
            break
    result = {
        "seed": int(seed),
        "distance_m": float(end[0] - start[0]),
        "lateral_m": float(end[1] - start[1]),
        "fell": fall_step is not None,
        "fall_step": fall_step,
        "return": float(total),
    }
    if error is not None:
        result["error"] = error
    return result


def parse_params(text: str) -> np.ndarray:
    """A preset name or a JSON file of amplitudes -> (11,) degrees.

    Raises:
      ValueError: Naming the valid presets, or what is wrong with the file.
    """
    if text in cpg.PRESETS:
        return cpg.amplitudes_from(text)
    if not os.path.isfile(text):
        raise ValueError(
            f"--params {text!r} is neither a preset ({', '.join(cpg.PRESETS)}) "
            "nor an existing JSON file"
        )
    try:
        return cpg.load_amplitudes(text)
    except (ValueError, json.JSONDecodeError) as e:
        raise ValueError(f"--params file {text}: {e}") from None


def summarize(results: list[dict]) -> dict:
    """Mean/std distance and lateral displacement, fall count, over trials."""
    d = np.array([r["distance_m"] for r in results])
    lat = np.array([r["lateral_m"] for r in results])
    return {
        "summary": True,
        "n": len(results),
        "distance_mean_m": float(d.mean()),
        "distance_std_m": float(d.std(ddof=1)) if len(d) > 1 else 0.0,
        "lateral_mean_m": float(lat.mean()),
        "falls": int(sum(r["fell"] for r in results)),
        "fall_rate": float(np.mean([r["fell"] for r in results])),
    }
