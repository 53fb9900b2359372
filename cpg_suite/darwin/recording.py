"""What a DARwIn-OP physics (`darwin.Physics`) records after each physics step, and the
supply current computed from it.

The electrical model (`cpg_suite.electrical`) needs every physics step's servo forces and
joint velocities, and the score card's gait-quality measures every step's sensors, where
dm_control's `Physics.step` keeps only the last state. `substeps` takes the physics steps
(the same MuJoCo calls as dm_control's stepping, so the same trajectory) and records into
buffers kept between calls (`Recording`, one per physics); `servo_steps`, `sensor_steps`
and `supply_currents` read them. `darwin.Physics.step`, the scorer
(`cpg_suite.protocol.score.control_step`) and the vector env (`cpg_suite.vector`, which
has each robot record into its row of one array: `record_steps_into`) step through
`substeps`; the task adds `supply_currents` to its `electrical.SupplyMonitor` after each
control step.
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco as mj
import numpy as np

from cpg_suite import electrical
from cpg_suite._headless import mujoco


class Recording:
    """One physics's records of the physics steps of its last `substeps`, and the views of
    its state they copy (made once: cheaper than looking them up on every step).

    Attributes:
      force: (steps, nu) actuator forces after each step, N·m.
      qvel: (steps, nv) joint velocities after each step, rad/s.
      rows: `(force[i], qvel[i])` views, one per step.
      sensors: (steps, nsensordata) sensor readings after each step (`sensors=True`).
      actuator_force, qvel_now, sensordata: Views of the physics's `data` they copy (the
        first two memoryviews, as `rows`: assigning through one costs less).
    """

    def __init__(self, physics: mujoco.Physics):
        """Args:
        physics: A `darwin.Physics` (its `servo_dofs` and `sensor_slices`).
        """
        model, data = physics.model.ptr, physics.data.ptr
        self.pointers = (model, data)  # what `mj_step` takes
        self.actuator_force, self.qvel_now = memoryview(data.actuator_force), memoryview(data.qvel)
        self.sensordata, self.nsensordata = data.sensordata, model.nsensordata
        self.servo_dofs = physics.servo_dofs()  # the joint each servo turns, actuator order
        self.slices = physics.sensor_slices()
        self.record_into(np.zeros((0, model.nu)), np.zeros((0, model.nv)))
        self.dof_damping = model.dof_damping  # a view: the tiers draw it per episode
        self.meter: electrical.SupplyMeter | None = None  # `supply_sums`' buffers
        self.meter_shape: tuple[int, ...] = ()  # the `qvel` shape they are for
        self.servo_index = np.zeros(0, dtype=np.intp)  # `SupplyMeter.power_sums`' index

    def record_into(self, force: np.ndarray, qvel: np.ndarray) -> None:
        """Records into these arrays from now on (through a view of each of their rows),
        and into new sensor rows.

        Args:
          force: (steps, nu) array for the actuator forces.
          qvel: (steps, nv) array for the joint velocities.
        """
        self.force, self.qvel = force, qvel
        # Memoryviews: assigning a row through one costs less than NumPy's `row[...] =`.
        self.rows = list(zip(map(memoryview, force), map(memoryview, qvel)))
        self.sensors = np.zeros((len(force), self.nsensordata))


def substeps(
    physics: mujoco.Physics,
    nstep: int,
    finish: bool = False,
    record: Callable | None = None,
    sensors: bool = False,
) -> list:
    """Takes `nstep` physics steps, recording after each the servos' forces and the joint
    velocities (`servo_steps`), and with `sensors` the sensor readings (`sensor_steps`).

    Args:
      physics: A `darwin.Physics`.
      nstep: Physics steps.
      finish: The first step is `mj_step2` (`mj_step1` already ran), else `mj_step`.
      record: Called with the physics after each step; its values are returned.
      sensors: Also record `data.sensordata` after each step.

    Returns:
      The values `record` returned (empty without one).
    """
    r = physics._recording
    model, data = r.pointers
    if len(r.force) != nstep:
        r.record_into(np.zeros((nstep, model.nu)), np.zeros((nstep, model.nv)))
    records = []
    actuator_force, velocity, sensordata = r.actuator_force, r.qvel_now, r.sensordata
    step, first = mj.mj_step, mj.mj_step2 if finish else mj.mj_step
    if nstep and not sensors and record is None:  # the tasks' hot path: nothing else
        rows = iter(r.rows)
        force_row, qvel_row = next(rows)
        first(model, data)
        force_row[:] = actuator_force  # into views made once: cheaper than `force[i]`
        qvel_row[:] = velocity
        for force_row, qvel_row in rows:
            step(model, data)
            force_row[:] = actuator_force
            qvel_row[:] = velocity
        return records
    readings = r.sensors if sensors else None
    for i, (force_row, qvel_row) in enumerate(r.rows):
        (step if i else first)(model, data)
        force_row[:] = actuator_force
        qvel_row[:] = velocity
        if readings is not None:
            readings[i] = sensordata
        if record is not None:
            records.append(record(physics))
    return records


def record_steps_into(physics: mujoco.Physics, force: np.ndarray, qvel: np.ndarray) -> None:
    """Makes `substeps` of `len(force)` steps record into these arrays: views of a caller's
    larger buffers (`vector.DarwinVectorEnv` keeps all its robots' records in one array).

    Args:
      physics: A `darwin.Physics`.
      force: (steps, nu) array for the actuator forces.
      qvel: (steps, nv) array for the joint velocities.
    """
    physics._recording.record_into(force, qvel)


def sensor_steps(physics: mujoco.Physics) -> tuple[np.ndarray, ...]:
    """What the score card's gait-quality measures read after each physics step of the last
    `substeps(..., sensors=True)`, as the accessors read it after a step.

    Args:
      physics: A `darwin.Physics`.

    Returns:
      Copies: the servos' joint velocities and forces (n, 20), the soles' touch (n, 2) and
      velocities (n, 6), and the feet's footing sensors (n, 2 × `footing.FOOT_WIDTH`).
    """
    r = physics._recording
    readings, s = r.sensors, r.slices
    return (
        r.qvel[:, r.servo_dofs],
        readings[:, s["servo_forces"]].copy(),
        readings[:, s["foot_touch"]].copy(),
        readings[:, s["sole_velocities"]].copy(),
        readings[:, s["footing"]].copy(),
    )


def servo_steps(physics: mujoco.Physics) -> tuple[np.ndarray, np.ndarray]:
    """The 20 servos' forces (N·m) and their joints' velocities (rad/s) after each physics
    step of the last `step`.

    Args:
      physics: A `darwin.Physics`.

    Returns:
      `(force, velocity)`, (n, 20) arrays in actuator order (force: the recording itself).
    """
    r = physics._recording
    return r.force, r.qvel[:, r.servo_dofs]


def supply_currents(physics: mujoco.Physics, copy: bool = True) -> np.ndarray:
    """The robot's supply current after each physics step of the last `step`, A
    (`electrical.supply_current`, computed by an `electrical.SupplyMeter`).

    Args:
      physics: A `darwin.Physics`.
      copy: False: the meter's buffer, which the next call overwrites.

    Returns:
      (n,) supply currents, A.
    """
    r = physics._recording
    currents = r.meter.currents(supply_sums(physics))
    return currents.copy() if copy else currents


def supply_sums(physics: mujoco.Physics) -> np.ndarray:
    """Σ max(0, P) over the servos after each physics step of the last `step`, W: the supply
    currents before their division by the supply voltage and the idle draw
    (`electrical.SupplyMeter.power_sums`; the tasks' hot path adds them to their monitor
    with `electrical.SupplyMonitor.update_sums`). The meter's buffer, which the next call
    overwrites.

    Args:
      physics: A `darwin.Physics`.

    Returns:
      (n,) sums, W.
    """
    r = physics._recording
    force, qvel = r.force, r.qvel
    if r.meter is None or r.meter_shape != qvel.shape:
        r.meter = electrical.SupplyMeter(len(force), len(r.servo_dofs))
        r.meter_shape = qvel.shape
        r.servo_index = electrical.servo_index(len(force), r.servo_dofs, qvel.shape[1])
    return r.meter.power_sums(force, qvel, r.dof_damping, r.servo_index)
