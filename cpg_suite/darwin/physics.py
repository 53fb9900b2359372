"""`Physics`: the DARwIn-OP model's named accessors (`darwin.Physics`).

Addresses are looked up by name (`robot`) when the model is loaded, and the
accessors read views of the state made then: the tasks call them on every control step.
What is not an accessor lives with what owns it, each a function of the physics:
recording the physics steps and the supply current (`recording`), the model's and
the state's checks (`checks`), the standing pose (`pose`), the feet's loads
and the balance reward (`contacts`), and the physical parameters the test tiers
perturb (`perturb`).
"""

from __future__ import annotations

import mujoco as mj
import numpy as np

from cpg_suite import cpg
from cpg_suite._headless import mujoco
from cpg_suite.darwin import checks, recording, robot
from cpg_suite.darwin.pose import ARM_POSE
from cpg_suite.darwin.robot import (
    ARM_JOINTS,
    FALL_HEIGHT,
    FALL_TILT_COS,
    FLOOR_GEOM,
    FOOT_GEOMS,
    SOLE_SITES,
    ids,
    torso_upright,
)

# 1 and 1/2 as 0-d arrays (read-only): NumPy converts a Python float operand on every
# call, which costs more than the arithmetic on the hot path's 12-vectors.
_ONE, _HALF = (np.array(x) for x in (1.0, 0.5))
_ONE.flags.writeable = _HALF.flags.writeable = False


class Physics(mujoco.Physics):
    """DARwIn-OP physics with named accessors (addresses looked up by name at load)."""

    def _reload_from_data(self, data) -> None:
        super()._reload_from_data(data)
        model, state = self.model, self.data.ptr
        checks.check_model(model)
        self._qpos, self._qvel, self._xpos = state.qpos, state.qvel, state.xpos  # views, kept
        self._sensordata, self._ctrl = state.sensordata, state.ctrl
        self._dof_damping = model.ptr.dof_damping
        self._pointers = (model.ptr, state)  # what `mj_step` takes
        legs, arms = (ids(model, names, "joint") for names in (cpg.LEG_JOINTS, ARM_JOINTS))
        self._leg_qpos, self._leg_dof = model.jnt_qposadr[legs], model.jnt_dofadr[legs]
        self._arm_qpos = model.jnt_qposadr[arms]
        self._leg_act = ids(model, cpg.LEG_JOINTS, "actuator")
        self._arm_act = ids(model, ARM_JOINTS, "actuator")
        self._servo_dofs = model.jnt_dofadr[model.actuator_trnid[:, 0]]  # actuator order
        self._torso, root = model.name2id("torso", "body"), model.name2id("root", "joint")
        self._root_qpos, self._root_dof = int(model.jnt_qposadr[root]), int(model.jnt_dofadr[root])
        self._feet, self._floor = ids(model, FOOT_GEOMS, "geom"), model.name2id(FLOOR_GEOM, "geom")
        self._foot_index = {int(self._feet[0]): 0, int(self._feet[1]): 1}
        self._soles = ids(model, SOLE_SITES, "site")
        self._sole_xpos, self._sole_rows = state.site_xpos, _span(self._soles)  # `contacts`'
        self._tiles = robot.tile_geoms(model)
        self._sensors = robot.sensor_slices(model)  # `sensor_slices`
        self._leg_range = model.jnt_range[legs]
        self._leg_low = self._leg_range[:, 0].copy()  # `action_to_targets`' constants
        self._leg_span = self._leg_range[:, 1] - self._leg_range[:, 0]
        # Half the span, for `set_leg_action`: ((a + 1)·½)·span = (a + 1)·(½·span) bit for
        # bit, as both halvings are exact and each side then rounds one exact product.
        self._leg_half_span = self._leg_span * _HALF
        self._torso_push = state.xfrc_applied[self._torso, :3]  # a view: `tasks`' pushes
        self._weight = float(model.body_subtreemass[self._torso] * -model.opt.gravity[2])
        self._recording = recording.Recording(self)  # what `step` records
        # `set_leg_action`'s and `observation`'s plans: slices where the addresses run on
        # (basic slicing: cheaper than an index array), else the addresses.
        legs = _span(self._leg_act)  # 0-11: `checks.check_model`
        if not isinstance(legs, slice):
            raise ValueError("expects the leg servos' actuators one after another")
        self._leg_ctrl = self._ctrl[legs]  # a view: `set_leg_action` writes it
        self._action_scratch = np.zeros(len(self._leg_act))
        self._obs_leg_qpos, self._obs_leg_dof = _span(self._leg_qpos), _span(self._leg_dof)
        parts = ("torso_orientation", "gyro", "accelerometer", "foot_touch")
        start = min(self._sensors[p].start for p in parts)
        stop = max(self._sensors[p].stop for p in parts)
        self._obs_sensors = slice(start, stop)
        self._obs_parts = tuple(
            slice(self._sensors[p].start - start, self._sensors[p].stop - start) for p in parts
        )

    def step(self, nstep: int = 1) -> None:
        """dm_control's step (legacy stepping: `mj_step2` finishes the step whose `mj_step1`
        ran for the last observation, `mj_step` takes the others, then `mj_step1`; a new
        invalid-state warning raises `PhysicsError`): the same MuJoCo calls, so the same
        trajectory, each physics step recorded (`recording.substeps`).

        Args:
          nstep: Physics steps.
        """
        counts = self._warnings.tobytes()  # `check_invalid_state`, inline
        recording.substeps(self, nstep, finish=True)
        mj.mj_step1(*self._pointers)
        if self._warnings.tobytes() != counts:
            checks.raise_new_warnings(self, counts)

    check_invalid_state = checks.check_invalid_state  # dm_control's, on the counts' bytes

    # Servos.
    def servo_dofs(self) -> np.ndarray:
        """The 20 servos' joint addresses in `qvel`, in actuator order."""
        return self._servo_dofs.copy()

    def servo_forces(self) -> np.ndarray:
        """The 20 servos' forces, N·m, in actuator order (`actuatorfrc` sensors)."""
        return self._sensordata[self._sensors["servo_forces"]].copy()

    def servo_velocities(self) -> np.ndarray:
        """The 20 servos' joint velocities, rad/s, in actuator order."""
        return self._qvel[self._servo_dofs]

    def servo_damping(self) -> np.ndarray:
        """The damping of the 20 servos' joints, N·m·s/rad: their back-EMF braking."""
        return self._dof_damping[self._servo_dofs]

    def servo_gain(self) -> float:
        """The position gain of the servos, N·m/rad."""
        return float(self.model.actuator_gainprm[0, 0])

    def torque_limit(self) -> float:
        """The servos' torque limit, N·m."""
        return float(self.model.actuator_forcerange[0, 1])

    # Legs and arms.
    def leg_joint_angles(self) -> np.ndarray:
        """The 12 leg joint angles, rad, in `cpg.LEG_JOINTS` order."""
        return self._qpos[self._leg_qpos]  # Fancy indexing returns a copy.

    def leg_joint_velocities(self) -> np.ndarray:
        """The 12 leg joint velocities, rad/s."""
        return self._qvel[self._leg_dof]

    def leg_dofs(self) -> np.ndarray:
        """The 12 leg joints' addresses in `qvel`."""
        return self._leg_dof.copy()

    def leg_joint_range(self) -> np.ndarray:
        """(12, 2) joint ranges, rad."""
        return self._leg_range.copy()

    def leg_torques(self) -> np.ndarray:
        """Torques of the 12 leg servos, N·m (`cpg.LEG_JOINTS` order)."""
        return self._sensordata[self._sensors["leg_torques"]].copy()

    def set_leg_targets(self, angles: np.ndarray) -> None:
        """Sets the leg servo targets, rad (clipped to the joint ranges by MuJoCo)."""
        self._ctrl[self._leg_act] = angles

    def set_arm_targets(self, angles: np.ndarray) -> None:
        """Sets the arm and head servo targets, rad (`ARM_JOINTS` order)."""
        self._ctrl[self._arm_act] = angles

    def targets_to_action(self, angles: np.ndarray) -> np.ndarray:
        """Leg joint angles (rad) -> normalized action in [−1, 1] (clipped)."""
        low, high = self._leg_range[:, 0], self._leg_range[:, 1]
        return np.clip(2.0 * (np.asarray(angles) - low) / (high - low) - 1.0, -1.0, 1.0)

    def action_to_targets(self, action: np.ndarray) -> np.ndarray:
        """Normalized action in [−1, 1] -> leg joint angles, rad."""
        return self._leg_low + (np.asarray(action) + _ONE) * _HALF * self._leg_span

    def set_leg_action(self, action: np.ndarray) -> None:
        """`set_leg_targets(action_to_targets(action))` for a float64 (12,) action in
        [−1, 1]: the same bits (the halving folded into the span: both are exact), written
        into `data.ctrl` without temporaries (the tasks' hot path)."""
        t = np.add(action, _ONE, out=self._action_scratch)
        np.multiply(t, self._leg_half_span, out=t)  # ((a + 1)·½)·span, one rounding
        np.add(self._leg_low, t, out=self._leg_ctrl)

    def controls_for(self, leg_targets: np.ndarray) -> np.ndarray:
        """Actuator controls for leg servo targets, with the arms and head held in `ARM_POSE`.

        Args:
          leg_targets: (..., 12) leg targets, rad, in `cpg.LEG_JOINTS` order.

        Returns:
          (..., nu) controls, the values the task writes into `data.ctrl`.
        """
        leg_targets = np.asarray(leg_targets, dtype=np.float64)
        ctrl = np.empty(leg_targets.shape[:-1] + (self.model.nu,))
        ctrl[..., self._leg_act] = leg_targets
        ctrl[..., self._arm_act] = ARM_POSE
        return ctrl

    # Torso.
    def torso_body(self) -> int:
        """The torso's body id (the row of `xfrc_applied` a push acts on)."""
        return int(self._torso)

    def total_mass(self) -> float:
        """The robot's mass, kg."""
        return float(self.model.body_subtreemass[self._torso])

    def torso_position(self) -> np.ndarray:
        """Torso origin (mid-point of the shoulder axes) in the world, m."""
        return self._xpos[self._torso].copy()

    def torso_height(self) -> float:
        """Height of the torso origin above the floor, m."""
        return float(self._xpos[self._torso, 2])

    def forward_position(self) -> float:
        """x of the torso origin, m (the robot faces +x at the start)."""
        return float(self._xpos[self._torso, 0])

    def lateral_position(self) -> float:
        """y of the torso origin, m."""
        return float(self._xpos[self._torso, 1])

    def root_qpos(self) -> np.ndarray:
        """The free joint's coordinates: torso position (3) and quaternion (4)."""
        return self._qpos[self._root_qpos : self._root_qpos + 7].copy()

    def torso_upright(self) -> float:
        """z component of the torso's z axis (1 upright, 0 lying)."""
        return float(torso_upright(self._qpos[self._root_qpos + 3 : self._root_qpos + 7]))

    def torso_velocity(self) -> np.ndarray:
        """Linear velocity of the torso origin in the world frame, m/s."""
        return self._qvel[self._root_dof : self._root_dof + 3].copy()

    def fallen(self) -> bool:
        """The torso is below 0.22 m or tilted more than 50° (`has_fallen`, in Python floats:
        the same IEEE operations in the same order, without NumPy's per-call cost)."""
        r = self._root_qpos
        _, _, z, w, x, y, qz = self._qpos[r : r + 7].tolist()
        upright = (w * w - x * x - y * y + qz * qz) / (w * w + x * x + y * y + qz * qz)
        return z < FALL_HEIGHT or upright < FALL_TILT_COS

    def observation(self) -> tuple[np.ndarray, ...]:
        """The tasks' observation (`tasks.OBSERVATION_KEYS` order): the values of
        `leg_joint_angles`, `leg_joint_velocities`, `torso_orientation`, `[torso_height]`,
        `torso_velocity`, `gyro`, `accelerometer` and `foot_touch`, each its own array (views
        of four fresh copies: the joint angles, all joint velocities, the sensors' span and
        the torso's height), cheaper than the eight accessors."""
        qvel = self._qvel.copy()
        sensors = self._sensordata[self._obs_sensors].copy()
        orientation, gyro, accelerometer, touch = self._obs_parts
        r = self._root_dof
        return (
            self._qpos[self._obs_leg_qpos].copy(),
            qvel[self._obs_leg_dof],
            sensors[orientation],
            self._xpos[self._torso, 2:3].copy(),
            qvel[r : r + 3],
            sensors[gyro],
            sensors[accelerometer],
            sensors[touch],
        )

    # Sensors.
    def sensor_slices(self) -> dict[str, slice]:
        """Where the sensor accessors' readings lie in `data.sensordata` (for many robots)."""
        return dict(self._sensors)

    def torso_orientation(self) -> np.ndarray:
        """Torso orientation quaternion (w, x, y, z) from the IMU."""
        return self._sensordata[self._sensors["torso_orientation"]].copy()

    def gyro(self) -> np.ndarray:
        """IMU angular velocity in the torso frame, rad/s."""
        return self._sensordata[self._sensors["gyro"]].copy()

    def accelerometer(self) -> np.ndarray:
        """IMU specific force in the torso frame, m/s²."""
        return self._sensordata[self._sensors["accelerometer"]].copy()

    # Feet.
    def foot_touch(self) -> np.ndarray:
        """Normal force on the (left, right) sole touch sensors, N."""
        return self._sensordata[self._sensors["foot_touch"]].copy()

    def footing_sensors(self) -> np.ndarray:
        """The feet's footing sensors (`robot.FOOTING_SENSORS`: each foot's floor contacts,
        then its sole's angular velocity, centre and axes), as one row, left foot first."""
        return self._sensordata[self._sensors["footing"]].copy()

    def sole_velocities(self) -> np.ndarray:
        """(2, 3) linear velocities of the (left, right) sole centres in the world, m/s."""
        return self._sensordata[self._sensors["sole_velocities"]].reshape(2, 3).copy()

    def sole_centres(self) -> np.ndarray:
        """(2, 3) centres of the (left, right) soles in the world, m."""
        return self.data.site_xpos[self._soles]


def _span(addresses: np.ndarray) -> slice | np.ndarray:
    """A slice for addresses that run on by one (basic slicing: a view), else the addresses."""
    a = np.asarray(addresses)
    if len(a) and np.array_equal(a, np.arange(a[0], a[0] + len(a))):
        return slice(int(a[0]), int(a[0]) + len(a))
    return a.copy()
