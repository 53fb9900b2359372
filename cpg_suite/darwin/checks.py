"""Checks of a DARwIn-OP physics (`darwin.Physics`): the model when it is loaded, the state
after every step.

* `check_model`: what the code assumes of the model (contacts, actuator order, integrator).
* `check_invalid_state`, `raise_new_warnings`: dm_control's invalid-state check (a new
  MuJoCo warning raises `PhysicsError`, or is logged inside `suppress_physics_errors`),
  made cheap for the hot path: the warning counts' bytes are compared on every step, and
  only a difference is looked into. `darwin.Physics.check_invalid_state` is
  `check_invalid_state`; `darwin.Physics.step` makes the same comparison inline.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Iterator

import mujoco as mj
import numpy as np
from dm_control.rl import control

from cpg_suite import cpg
from cpg_suite._headless import mujoco
from cpg_suite.darwin import robot


def check_model(model: mujoco.wrapper.MjModel) -> None:
    """Checks what the DARwIn-OP code assumes of the model.

    The feet's floor contacts have condim 3 under a pyramidal cone (`contacts` sums
    four pyramid-edge forces per contact); the actuators are the legs' then the arms'
    servos (the `servo_forces` sensors and `cpg_suite.electrical` read them in that order);
    the integrator has one stage (`recording.substeps` finishes a step with
    `mj_step2`); the `servo_forces` sensors read the actuators' forces as they are.

    Args:
      model: The DARwIn-OP model.

    Raises:
      ValueError: If one of these does not hold.
    """
    names = (robot.FLOOR_GEOM, *robot.FOOT_GEOMS)
    geoms = robot.ids(model, names, "geom")
    if model.opt.cone != mj.mjtCone.mjCONE_PYRAMIDAL or np.any(model.geom_condim[geoms] != 3):
        raise ValueError("centres_of_pressure expects condim 3 contacts and a pyramidal cone")
    names = [model.id2name(int(i), "actuator") for i in range(model.nu)]
    if (
        names != [*cpg.LEG_JOINTS, *robot.ARM_JOINTS]
        or model.opt.integrator == mj.mjtIntegrator.mjINT_RK4
    ):
        raise ValueError("expects the legs' then the arms' servos and a one-stage integrator")
    _check_servo_force_sensors(model)


def _check_servo_force_sensors(model: mujoco.wrapper.MjModel) -> None:
    """The `servo_forces` readings are the actuators' forces, one each, in actuator order,
    as MuJoCo computed them (no cutoff, noise, delay or interval): the evaluators read the
    servos' forces after each physics step from a rollout's recorded sensors."""
    span = robot.sensor_slices(model)["servo_forces"]
    ids = np.flatnonzero((model.sensor_adr >= span.start) & (model.sensor_adr < span.stop))
    plain = not any(
        np.any(getattr(model, field)[ids])
        for field in ("sensor_cutoff", "sensor_noise", "sensor_delay", "sensor_interval")
    )
    if not (
        plain
        and np.all(model.sensor_type[ids] == mj.mjtSensor.mjSENS_ACTUATORFRC)
        and np.array_equal(model.sensor_objid[ids], np.arange(model.nu))
        and np.all(model.sensor_dim[ids] == 1)
        and span.stop - span.start == model.nu
    ):
        raise ValueError("expects one plain actuatorfrc sensor per servo, in actuator order")


@contextlib.contextmanager
def check_invalid_state(physics: mujoco.Physics) -> Iterator[None]:
    """dm_control's check around a block that steps `physics` (a new invalid-state warning
    raises `PhysicsError`, or is logged inside `suppress_physics_errors`); the counts'
    bytes are compared, and only a difference is looked into (`raise_new_warnings`).

    Args:
      physics: A `darwin.Physics` (dm_control's `_warnings` counts).

    Raises:
      control.PhysicsError: On a new invalid-state warning (outside
        `suppress_physics_errors`).
    """
    counts = physics._warnings.tobytes()
    yield
    if physics._warnings.tobytes() != counts:
        raise_new_warnings(physics, counts)


def raise_new_warnings(physics: mujoco.Physics, counts: bytes) -> None:
    """The end of `check_invalid_state`: a warning counted since the warning counts were
    `counts` (their bytes: comparing them is the cheap test on every step) raises
    `PhysicsError` (or is logged).

    Args:
      physics: A `darwin.Physics`.
      counts: `physics._warnings.tobytes()` before the step.

    Raises:
      control.PhysicsError: On a new warning, unless `suppress_physics_errors` is active.
    """
    before = np.frombuffer(counts, dtype=physics._warnings.dtype)
    np.greater(physics._warnings, before, out=physics._new_warnings)
    if physics._new_warnings.any():
        names = np.compress(physics._new_warnings, list(mj.mjtWarning.__members__))
        message = f"Physics state is invalid. Warning(s) raised: {', '.join(names)}"
        if physics._warnings_cause_exception:
            raise control.PhysicsError(message)
        logging.warning(message)
