r"""Would MuJoCo's `dcmotor` actuator keep the DARwIn-OP's physics? A measurement.

  python investigations/dcmotor_equivalence.py [--steps=1000]

The model's servos are `position` actuators (kp = 40 N·m/rad, force clamped at ±2.5 N·m)
with the back-EMF braking as joint damping (0.43 N·m·s/rad). MuJoCo ≥ 3.7 has a `dcmotor`
actuator with the electrical model built in; configured as a position servo (`input="pos"`,
its controller's kp = 40, torque saturation 2.5 N·m, the MX-28's winding resistance and
torque constant) it should apply the same forces. This script rolls out the hand-tuned CPG
gait from the task's reset state under both actuators and prints where they first differ
(actuator forces, then the trajectory) and the torso's distance apart at the end; then it
asks MJX (JAX) to take the `dcmotor` model. What it printed is cited in
docs/decisions.md#the-electrical-model-outside-the-actuator.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import re

import mujoco
import numpy as np
from absl import flags
from mujoco import rollout

import cpg_suite
from cpg_suite import cli, cpg, darwin, electrical

MAX_STEPS = 100_000  # control steps (27 min of walking)


def dcmotor_xml(xml: str) -> str:
    """The model with every servo a `dcmotor` position servo of the MX-28's constants."""
    k = electrical.TORQUE_CONSTANT
    motor = (
        f'<dcmotor name="\\1" joint="\\1" input="pos" resistance="{electrical.RESISTANCE!r}" '
        f'motorconst="{k!r} {k!r}" controller="40 0 0 0 0 0" '
        f'saturation="{electrical.STALL_TORQUE!r} 0 0"/>'
    )
    return re.sub(r'<position name="(\w+)" joint="\w+" class="darwin"/>', motor, xml)


def trajectories(model: mujoco.MjModel, state: np.ndarray, controls: np.ndarray):
    """(states, sensordata) of one rollout of `controls` from `state`."""
    data = mujoco.MjData(model)
    return rollout.rollout(model, data, state[None], controls[None])


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    flags.DEFINE_integer("steps", 1000, "Control steps of the hand-tuned gait.")


def main(argv) -> None:
    del argv
    steps = flags.FLAGS.steps
    cli.check(1 <= steps <= MAX_STEPS, f"--steps must be in [1, {MAX_STEPS}], got {steps}")
    env = cpg_suite.load("darwin_walk", task_kwargs={"random": 0})
    env.reset()
    physics = env.physics
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(physics.model.ptr, spec))
    mujoco.mj_getState(physics.model.ptr, physics.data.ptr, state, spec)
    targets = cpg.trajectories(cpg.amplitudes_from("hand_tuned"), steps, 0.016)[0]
    n_sub = darwin.physics_steps_per_control_step(physics.model.ptr)
    controls = physics.controls_for(targets).repeat(n_sub, axis=0)
    xml, assets = darwin.get_model_and_assets()
    position = mujoco.MjModel.from_xml_string(xml, assets)
    dc = mujoco.MjModel.from_xml_string(dcmotor_xml(xml), assets)
    print(
        f"servos as dcmotor: {int(np.sum(dc.actuator_gaintype == mujoco.mjtGain.mjGAIN_DCMOTOR))}"
    )
    (s0, f0), (s1, f1) = trajectories(position, state, controls), trajectories(dc, state, controls)
    forces = physics.sensor_slices()["servo_forces"]
    force_diff = np.abs(f0[0][:, forces] - f1[0][:, forces])
    differing = np.flatnonzero(force_diff.max(axis=1) > 0)
    state_diff = np.flatnonzero(np.any(s0[0] != s1[0], axis=1))
    print(f"physics steps: {len(controls)}")
    print(
        f"steps whose servo forces differ: {len(differing)}, first {differing[:1]}, "
        f"largest difference {force_diff.max():.3g} N·m"
    )
    print(f"first physics step whose state differs: {state_diff[:1]}")
    root = position.jnt_qposadr[position.joint("root").id]
    x0, x1 = s0[0][-1, 1 + root], s1[0][-1, 1 + root]
    print(
        f"torso x at the end: position {x0:.6f} m, dcmotor {x1:.6f} m, apart {abs(x0 - x1):.3g} m"
    )
    try:
        from mujoco import mjx

        mjx.put_model(dc)
        print("MJX took the dcmotor model")
    except ImportError:
        print("MJX not installed (the mjx extra)")
    except NotImplementedError as e:
        print(f"MJX refused the dcmotor model: {e}")


if __name__ == "__main__":
    define_flags()
    cli.run(main)
