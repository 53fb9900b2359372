"""What turns a leg joint faster than the MX-28's no-load speed: a diagnosis of one controller.

The score card counts the servo-steps over the no-load speed (`quality.over_speed`). This
module says, for each leg joint, when they happen and what drives them. Each physics step
splits the joint accelerations MuJoCo computes, q̈ = M⁻¹ Σ f, by the source of the force f
(all linear in f, so the parts add up to q̈):

* `own_motor`: the joint's own servo, its torque τ less its back-EMF braking c·q̇ (the
  joint's damping), M⁻¹ⱼⱼ (τ − c q̇). It is ≤ 0 along the motion whenever |q̇| > |τ| / c,
  and |τ| ≤ 2.5 N·m: no servo accelerates its own joint beyond 2.5 / 0.43 = 5.81 rad/s;
* `other_motors`: every other servo (torque and braking), through the body's inertial
  coupling (M⁻¹ is full: a knee's reaction turns the hip);
* `contacts`: contact and joint-limit constraint forces (impacts, the floor pushing back);
* `body_motion`: MuJoCo's bias force, −(Coriolis, centrifugal and gravity forces). Weight
  alone turns no joint of the floating robot (it falls as one body: the joints' part of
  M⁻¹ times the gravity force is zero, tested), so this is the body's own motion;
  gravity reaches the joints through the floor's reaction, in `contacts`;
* `push`: the push tier's force on the torso.

An over-speed event is a servo-step over the MX-28's no-load speed; its `delta` is each
source's acceleration along the motion integrated from the last step at or below that
speed: the parts of the speed gained beyond it (they add up to it, within the closure). The
step is in stance when the joint's own foot carries more than 5 % of the weight, and at a
touchdown when that foot went from swing to stance within the last `WINDOW` steps.

The split uses the accelerations the implicit-fast integrator applies, damping taken
implicitly; `closure` measures how far the parts' sum lies from the velocity each step
reaches.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import mujoco
import numpy as np

import cpg_suite
from cpg_suite import cpg
from cpg_suite.evaluation import quality
from cpg_suite.protocol import score

SOURCES = (
    "own_motor",
    "other_motors",
    "contacts",
    "body_motion",
    "push",
)
WINDOW = 15  # physics steps (30 ms) before an event in which a touchdown counts.
_STANCE_FRACTION = 0.05  # of the weight: a foot carrying more is in stance.
_LEFT = np.array([name.endswith("L") for name in cpg.LEG_JOINTS])


@dataclasses.dataclass
class Trace:
    """Per physics step: leg joint velocities (T, 12), servo torques (T, 12), sole touch
    forces (T, 2), each source's leg joint accelerations (T, 5, 12), MuJoCo's own leg
    accelerations (T, 12); the robot's weight, N, and the physics step, s."""

    velocity: np.ndarray
    torque: np.ndarray
    touch: np.ndarray
    sources: np.ndarray
    qacc: np.ndarray
    weight: float
    timestep: float


def drives(physics) -> np.ndarray:
    """The leg joint accelerations from each of `SOURCES` at the state of the last forward
    pass (after `mj_step`: the state the step started from), (5, 12), rad/s².

    The accelerations the integrator applies: (M + h D)⁻¹ f, with the joints' damping D
    taken implicitly as MuJoCo's implicit-fast and Euler integrators take it (h the physics
    step); M⁻¹ f when Euler's implicit damping is disabled (`mjDSBL_EULERDAMP`).

    Args:
      physics: A `cpg_suite.darwin.Physics`.
    """
    model, data = physics.model.ptr, physics.data.ptr
    legs = physics.leg_dofs()
    torso = physics.torso_body()
    push = np.zeros(model.nv)
    force = data.xfrc_applied[torso]
    if np.any(force):
        mujoco.mj_applyFT(model, data, force[:3], force[3:], data.xipos[torso], torso, push)
    motors = data.qfrc_actuator + data.qfrc_passive
    inertia = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, inertia)
    explicit = model.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER and (
        model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_EULERDAMP
    )
    if not explicit:
        inertia += np.diag(model.opt.timestep * model.dof_damping)
    forces = np.stack([motors, data.qfrc_constraint, -data.qfrc_bias, push], axis=1)
    solved = np.linalg.solve(inertia, forces)[legs]  # (12, 4)
    diagonal = np.linalg.inv(inertia)[legs, legs]
    own = diagonal * motors[legs]  # [(M + h D)⁻¹]ⱼⱼ (τⱼ − c q̇ⱼ)
    return np.stack([own, solved[:, 0] - own, *solved[:, 1:].T])


def _record(physics) -> tuple:
    return (
        physics.leg_joint_velocities(),
        physics.leg_torques(),
        physics.foot_touch(),
        drives(physics),
        physics.data.qacc[physics.leg_dofs()].copy(),
    )


def trace(policy: Callable[[dict], np.ndarray], tier: str, seed: int, steps: int = 1000) -> Trace:
    """Steps one trial of a policy as the score card does, recording the drives.

    Args:
      policy: Maps the task's observation to a (12,) action (`score.policy_trial`).
      tier: A test tier's task id.
      seed: The episode's seed.
      steps: Control steps.

    Returns:
      The trial's `Trace`, up to its end or fall.
    """
    env = cpg_suite.load(tier, task_kwargs={"random": seed, "time_limit": float("inf")})
    return trace_environment(policy, env, steps)


def trace_environment(policy: Callable[[dict], np.ndarray], env, steps: int) -> Trace:
    """`trace` in a given DARwIn-OP walking environment (reset here)."""
    if hasattr(policy, "reset"):
        policy.reset()
    observation = env.reset().observation
    physics = env.physics
    n_sub = int(round(env.control_timestep() / physics.model.opt.timestep))
    _, _, records = score.step_policy(
        policy, env.task, physics, observation, steps, n_sub, record=_record
    )
    columns = [np.array(c) for c in zip(*records)]
    weight = physics.total_mass() * -float(physics.model.opt.gravity[2])
    return Trace(*columns, weight=weight, timestep=float(physics.model.opt.timestep))


def events(t: Trace, window: int = WINDOW) -> list[dict]:
    """Every over-speed servo-step of a trace: joint, speed, drive, phase, source shares.

    Args:
      t: A trace.
      window: Physics steps before an event in which its foot's landing counts.

    Returns:
      One dict per event: `joint` (name), `speed` (rad/s), `motor` (the servo's torque
      along the motion), `stance`, `touchdown`, and `delta` ({source: Δq̇ along the
      motion since the last step at or below the no-load speed, rad/s}).
    """
    motor, external = quality.over_speed(t.torque, t.velocity)
    fast = motor | external
    stance = t.touch > _STANCE_FRACTION * t.weight
    found = []
    for step, joint in zip(*np.nonzero(fast)):
        foot = 0 if _LEFT[joint] else 1
        start = step
        while start > 0 and fast[start - 1, joint]:
            start -= 1
        direction = np.sign(t.velocity[step, joint])
        delta = direction * t.sources[start : step + 1, :, joint].sum(axis=0) * t.timestep
        landing = stance[max(0, step - window + 1) : step + 1, foot]
        found.append(
            {
                "joint": cpg.LEG_JOINTS[joint],
                "speed": float(abs(t.velocity[step, joint])),
                "motor": bool(motor[step, joint]),
                "stance": bool(stance[step, foot]),
                "touchdown": bool(landing[-1] and not landing.all()),
                "delta": dict(zip(SOURCES, map(float, delta))),
            }
        )
    return found


def closure(t: Trace) -> float:
    """How well the split explains the velocities: the largest |Σ sources · h − Δq̇| over
    the trace, relative to the largest |Δq̇| (Δq̇ between consecutive physics steps)."""
    if len(t.velocity) < 2:
        return 0.0
    change = np.diff(t.velocity, axis=0)
    gap = np.abs(t.sources[1:].sum(axis=1) * t.timestep - change).max()
    return float(gap / max(np.abs(change).max(), 1e-12))


def summarize(found: list[dict], servo_steps: int) -> dict:
    """Per joint: share of servo-steps over the no-load speed, peak, motor-driven, stance
    and touchdown shares of its events, each source's mean Δq̇ and how often it is the
    largest.

    Args:
      found: `events` of one or more traces.
      servo_steps: Physics steps of those traces (each joint's servo-steps).

    Returns:
      {joint: {...}} for the joints with events, in `cpg.LEG_JOINTS` order.
    """
    table = {}
    for joint in cpg.LEG_JOINTS:
        mine = [e for e in found if e["joint"] == joint]
        if not mine:
            continue
        delta = np.array([[e["delta"][s] for s in SOURCES] for e in mine])
        largest = np.bincount(delta.argmax(axis=1), minlength=len(SOURCES)) / len(mine)
        table[joint] = {
            "events": len(mine),
            "share": len(mine) / servo_steps,
            "peak": max(e["speed"] for e in mine),
            "motor": float(np.mean([e["motor"] for e in mine])),
            "stance": float(np.mean([e["stance"] for e in mine])),
            "touchdown": float(np.mean([e["touchdown"] for e in mine])),
            "mean_delta": dict(zip(SOURCES, map(float, delta.mean(axis=0)))),
            "largest": dict(zip(SOURCES, map(float, largest))),
        }
    return table
