"""DARwIn-OP domain: the humanoid of the study, walking or balancing on a CPG (thesis Ch. 5-6).

Model (`xml/darwin.xml`) from docs/darwin_op_model.md: 20 joints with the Webots axes, ranges,
masses, centres of mass and inertias (total 2.925 kg); box feet 0.105 × 0.066 m; torso IMU
(accelerometer, gyro, orientation) and a touch sensor under each sole. Decisions:

* **Torso centre of mass**: the Webots value (−0.050, 0, −0.080) m, not the CAD-derived
  (−0.019, −0.003, −0.039) (docs/darwin_op_model.md#masses). The study's numbers come from
  the Webots model, so we keep its mass distribution; the whole-robot centre of mass then sits 13 mm
  behind the foot centres, inside the 105 mm long support.
* **Servos** (MX-28, docs/darwin_op_model.md#servos-dynamixel-mx-28): MuJoCo position
  actuators with kp = 40 N·m/rad and a torque limit of 2.5 N·m (stall torque at 12 V);
  joint damping 0.43 N·m·s/rad, the slope of the MX-28 torque-speed line (2.5 N·m stall /
  5.76 rad/s no-load), i.e. the back-EMF braking of the motor; armature 0.005 kg·m² (a
  coreless rotor of about 1.3e-7 kg·m² reflected through the 193:1 gearbox). The sources
  give no SI stiffness; kp was chosen with `python -m baselines.experiments.calibrate_cpg`.
* **Contacts**: soft-ish rubber soles (friction 1.0, solref 0.008 s); the feet collide with
  each other and with the floor, every other robot geom only with the floor.
* **Timing**: physics step 2 ms (implicit-fast integrator), control step 16 ms (the Webots
  DARwIn-OP worlds' basic time step), 1000 control steps = 16 s per episode.
* **Pose**: arms hang 10° out from the body with the elbows bent 30°, head level; the
  task holds them with their servos (not part of the action). The legs start in the CPG's
  standing posture (its offsets O), feet flat on the floor, each leg joint perturbed by
  U(−0.01, 0.01) rad from the task's random generator.
* **Fall**: the torso origin (shoulder axis) below 0.22 m (0.34 m standing) or the torso
  tilted more than 50° from upright.

Tasks (control step 16 ms, 1000 steps; action = the 12 leg joint targets, each scaled
from [−1, 1] onto the joint's range, in the order `cpg.LEG_JOINTS`):

* `walk`: reward = forward (x) displacement of the torso during the step, m; the return is
  the distance walked. A fall ends the episode with discount 0.
* `balance`: reward = −(mean over stance feet of the horizontal distance from the foot's
  centre of pressure to its sole centre), m; a stance foot carries more than 5 % of the
  body weight; 0 when no foot does. A fall ends the episode with discount 0.
"""

from __future__ import annotations

import collections
import contextlib
import functools
import logging
import math

import mujoco as mj
import numpy as np
from dm_control import mujoco
from dm_control.rl import control
from dm_control.utils import containers
from dm_env import specs

from cpg_suite import base, cpg, electrical, perturbations, portable

CONTROL_TIMESTEP = 0.016  # s: Webots DARwIn-OP basicTimeStep (the one definition).
DEFAULT_TIME_LIMIT = 16.0  # s: 1000 control steps ("1000 timesteps" of the study).
_FALL_HEIGHT = 0.22  # m: torso origin height below which the robot has fallen.
_FALL_TILT_COS = float(portable.cos(np.deg2rad(50.0)))  # torso z-axis · world z below this: fallen.
INIT_NOISE = 0.01  # rad: U(−x, x) added to each leg joint of the initial posture.
_STANCE_FRACTION = 0.05  # of body weight: a foot carrying more is a stance foot.
_WALK_VIZ_SPEED = 0.2  # m/s shown as full reward colour.
_BALANCE_VIZ_DISTANCE = 0.05  # m of COP offset shown as zero reward colour.
# 1 and 1/2 as 0-d arrays (read-only): NumPy converts a Python float operand on every
# call, which costs more than the arithmetic on the hot path's 12-vectors.
_ONE, _HALF = (np.array(x) for x in (1.0, 0.5))
_ONE.flags.writeable = _HALF.flags.writeable = False

FOOT_GEOMS = ("foot_l", "foot_r")  # the soles' collision boxes, left then right
FLOOR_GEOM = "floor"
# The floor and the soles: every contact of the CPU reference's trials that did not fall
# (benchmarks/contact_census.py), the pairs `mjx.WalkEnv(contacts="soles")` keeps.
GROUND_GEOMS = (FLOOR_GEOM, *FOOT_GEOMS)
ARM_JOINTS = (
    "ShoulderL",
    "ArmUpperL",
    "ArmLowerL",
    "ShoulderR",
    "ArmUpperR",
    "ArmLowerR",
    "Neck",
    "Head",
)
# Arms 10° out from hanging vertical (±0.785), elbows bent 30° from straight (±1.571), head
# level (+0.70, the ROBOTIS walking engine's eye-tilt offset).
ARM_POSE = np.array([0.0, 0.61, 1.05, 0.0, -0.61, -1.05, 0.0, 0.70])

OBJECTIVES = ("walk", "balance")
# The task's observation, in the order `CPGTask.get_observation` returns it (the order a
# flat observation vector takes: the MJX env's, the SB3 adapter's, exported policies').
OBSERVATION_KEYS = (
    "joint_angles",
    "joint_velocities",
    "torso_orientation",
    "torso_height",
    "torso_velocity",
    "gyro",
    "accelerometer",
    "foot_touch",
)
SUITE = containers.TaggedTasks()


def torso_upright(quaternion: np.ndarray, xp=np) -> np.ndarray:
    """z component of the torso's z axis from its orientation quaternion(s) (w, x, y, z).

    Args:
      quaternion: (..., 4) quaternions (w, x, y, z), not necessarily normalized.
      xp: The array module: `numpy` (float64), or `jax.numpy` for traced arrays
        (`cpg_suite.mjx`).

    Returns:
      (...,) z component of the body z axis in the world.
    """
    q = np.asarray(quaternion, dtype=np.float64) if xp is np else xp.asarray(quaternion)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return (w * w - x * x - y * y + z * z) / (w * w + x * x + y * y + z * z)


def has_fallen(root_qpos: np.ndarray, xp=np) -> np.ndarray:
    """The fall test of the tasks, from the free joint's 7 coordinates (x, y, z, quaternion).

    The torso origin below 0.22 m, or the torso tilted more than 50° from upright. Shared by
    `Physics.fallen`, the batched evaluators and the MJX tasks, so all give the same verdicts.

    Args:
      root_qpos: (..., 7) free-joint coordinates.
      xp: The array module: `numpy` (float64), or `jax.numpy` for traced arrays.

    Returns:
      (...,) bool, fallen.
    """
    q = np.asarray(root_qpos, dtype=np.float64) if xp is np else xp.asarray(root_qpos)
    upright = torso_upright(q[..., 3:7], xp)
    return (q[..., 2] < _FALL_HEIGHT) | (upright < _FALL_TILT_COS)


def get_model_and_assets(
    terrain: perturbations.Terrain | None = None,
) -> tuple[str, dict[str, bytes]]:
    """Returns the DARwIn-OP model's XML string and its assets.

    Args:
      terrain: Adds the tiles of this uneven ground (hidden below the plane until a task
        raises them).
    """
    xml, assets = base.model_and_assets("darwin.xml")
    if terrain is not None:
        xml = xml.replace("</worldbody>", f"  {perturbations.tile_xml(terrain)}\n  </worldbody>")
    return xml, assets


def physics_steps_per_control_step(model: mj.MjModel | None = None) -> int:
    """Physics steps in one control step: `CONTROL_TIMESTEP` over the model's timestep.

    Args:
      model: The compiled DARwIn-OP model (None: compiles `get_model_and_assets()`).

    Returns:
      The number of physics steps (8 for the shipped MJCF's 2 ms).
    """
    if model is None:
        xml, assets = get_model_and_assets()
        model = mj.MjModel.from_xml_string(xml, assets)
    return int(round(CONTROL_TIMESTEP / model.opt.timestep))


@SUITE.add("benchmarking")
def walk(
    time_limit: float = DEFAULT_TIME_LIMIT,
    random=None,
    posture: np.ndarray | None = None,
    init_noise: float = INIT_NOISE,
    servo_gain: float | None = None,
    torque_limit: float | None = None,
    supply: electrical.SupplyLimit | None = electrical.DEFAULT_SUPPLY,
    environment_kwargs: dict | None = None,
) -> control.Environment:
    """Returns the walking task: reward = forward torso displacement per step (m).

    Args:
      time_limit: Episode length in seconds (62.5 control steps per second).
      random: Seed or `np.random.RandomState` for the initial state.
      posture: The 12 leg joint angles to start from, rad (default: the standing posture of
        the default `cpg.CPGConfig`).
      init_noise: Half-width of the uniform perturbation of each leg joint, rad.
      servo_gain: Position gain kp of every servo, N·m/rad (default: the model's 40).
      torque_limit: Torque limit of every servo, N·m (default: the model's 2.5).
      supply: The supply's limit: a mean current over a window above it browns the servos
        out and ends the episode like a fall (`electrical.SupplyLimit`; default 10 A over
        1 s). None: the study's unlimited physics.
      environment_kwargs: Passed to `control.Environment`.

    Returns:
      A `control.Environment`.
    """
    servo = {"servo_gain": servo_gain, "torque_limit": torque_limit}
    return _environment(
        "walk", time_limit, random, posture, init_noise, servo, environment_kwargs, supply=supply
    )


@SUITE.add("benchmarking")
def balance(
    time_limit: float = DEFAULT_TIME_LIMIT,
    random=None,
    posture: np.ndarray | None = None,
    init_noise: float = INIT_NOISE,
    servo_gain: float | None = None,
    torque_limit: float | None = None,
    supply: electrical.SupplyLimit | None = electrical.DEFAULT_SUPPLY,
    environment_kwargs: dict | None = None,
) -> control.Environment:
    """Returns the balance task: reward = −(COP distance to the stance sole centre), m.

    Args: as for `walk`.

    Returns:
      A `control.Environment`.
    """
    servo = {"servo_gain": servo_gain, "torque_limit": torque_limit}
    return _environment(
        "balance", time_limit, random, posture, init_noise, servo, environment_kwargs, supply=supply
    )


@SUITE.add()
def walk_randomized(
    time_limit: float = DEFAULT_TIME_LIMIT,
    random=None,
    posture: np.ndarray | None = None,
    randomization: perturbations.Randomization | None = None,
    supply: electrical.SupplyLimit | None = electrical.DEFAULT_SUPPLY,
    environment_kwargs: dict | None = None,
) -> control.Environment:
    """Walking with the physical parameters drawn per episode (the randomized test tier).

    Args:
      time_limit, random, posture, supply, environment_kwargs: As for `walk`.
      randomization: The ranges (default `perturbations.Randomization()`); its
        `init_noise` replaces the nominal initial-posture noise.

    Returns:
      A `control.Environment`.
    """
    randomization = randomization or perturbations.Randomization()
    return _tier(
        time_limit,
        random,
        posture,
        environment_kwargs,
        randomization.init_noise,
        supply,
        randomization=randomization,
    )


@SUITE.add()
def walk_push(
    time_limit: float = DEFAULT_TIME_LIMIT,
    random=None,
    posture: np.ndarray | None = None,
    pushes: perturbations.Pushes | None = None,
    supply: electrical.SupplyLimit | None = electrical.DEFAULT_SUPPLY,
    environment_kwargs: dict | None = None,
) -> control.Environment:
    """Walking with random horizontal pushes on the torso (the push test tier).

    Args:
      time_limit, random, posture, supply, environment_kwargs: As for `walk`.
      pushes: When, how hard and how long (default `perturbations.Pushes()`).

    Returns:
      A `control.Environment`.
    """
    pushes = pushes or perturbations.Pushes()
    return _tier(time_limit, random, posture, environment_kwargs, INIT_NOISE, supply, pushes=pushes)


@SUITE.add()
def walk_rough(
    time_limit: float = DEFAULT_TIME_LIMIT,
    random=None,
    posture: np.ndarray | None = None,
    terrain: perturbations.Terrain | None = None,
    supply: electrical.SupplyLimit | None = electrical.DEFAULT_SUPPLY,
    environment_kwargs: dict | None = None,
) -> control.Environment:
    """Walking on uneven ground: tiles raised at random per episode (the rough test tier).

    Args:
      time_limit, random, posture, supply, environment_kwargs: As for `walk`.
      terrain: The tiles (default `perturbations.Terrain()`); `max_height=0` is the plane.

    Returns:
      A `control.Environment`.
    """
    terrain = terrain or perturbations.Terrain()
    return _tier(
        time_limit, random, posture, environment_kwargs, INIT_NOISE, supply, terrain=terrain
    )


def _tier(time_limit, random, posture, environment_kwargs, init_noise, supply, **perturbation):
    """The walking task with one perturbation (nominal servos)."""
    servo = {"servo_gain": None, "torque_limit": None}
    return _environment(
        "walk",
        time_limit,
        random,
        posture,
        init_noise,
        servo,
        environment_kwargs,
        perturbation,
        supply=supply,
    )


def _environment(
    objective,
    time_limit,
    random,
    posture,
    init_noise,
    servo,
    environment_kwargs,
    perturbation: dict | None = None,
    supply: electrical.SupplyLimit | None = electrical.DEFAULT_SUPPLY,
):
    perturbation = perturbation or {}
    xml, assets = get_model_and_assets(perturbation.get("terrain"))
    physics = Physics.from_model(_compiled(xml, tuple(sorted(assets.items()))).copy())
    if servo["servo_gain"] is not None:
        physics.set_servo_gain(servo["servo_gain"])
    if servo["torque_limit"] is not None:
        physics.set_torque_limit(servo["torque_limit"])
    task = CPGTask(
        objective,
        posture=posture,
        init_noise=init_noise,
        random=random,
        supply=supply,
        **perturbation,
    )
    return base.make_environment(physics, task, time_limit, CONTROL_TIMESTEP, environment_kwargs)


@functools.lru_cache(maxsize=4)
def _compiled(xml: str, assets: tuple) -> mujoco.wrapper.MjModel:
    """The model compiled from `xml` and its `(name, contents)` assets, once: each
    environment gets a copy (`mj_copyModel`, a sixth of a compile's time; the same
    model), so that scoring 200 trials does not compile it 200 times. Never handed out
    itself: a task's changes to its model stay in its copy."""
    return mujoco.wrapper.MjModel.from_xml_string(xml, assets=dict(assets))


class Physics(mujoco.Physics):
    """DARwIn-OP physics with named accessors (addresses looked up by name at load)."""

    def _reload_from_data(self, data) -> None:
        super()._reload_from_data(data)
        model = self.model
        # Views of the state the accessors read (the arrays' memory stays where it is).
        state = self.data.ptr
        self._qpos, self._qvel, self._xpos = state.qpos, state.qvel, state.xpos
        self._sensordata, self._ctrl = state.sensordata, state.ctrl
        self._actuator_force = state.actuator_force
        self._dof_damping = self.model.ptr.dof_damping
        self._pointers = (self.model.ptr, state)  # what `mj_step` takes
        self._leg_qpos = np.array(
            [model.jnt_qposadr[model.name2id(n, "joint")] for n in cpg.LEG_JOINTS]
        )
        self._leg_dof = np.array(
            [model.jnt_dofadr[model.name2id(n, "joint")] for n in cpg.LEG_JOINTS]
        )
        self._arm_qpos = np.array(
            [model.jnt_qposadr[model.name2id(n, "joint")] for n in ARM_JOINTS]
        )
        self._leg_act = np.array([model.name2id(n, "actuator") for n in cpg.LEG_JOINTS])
        self._arm_act = np.array([model.name2id(n, "actuator") for n in ARM_JOINTS])
        self._torso = model.name2id("torso", "body")
        root = model.name2id("root", "joint")
        self._root_qpos = int(model.jnt_qposadr[root])
        self._root_dof = int(model.jnt_dofadr[root])
        self._feet = np.array([model.name2id(n, "geom") for n in FOOT_GEOMS])
        self._floor = model.name2id(FLOOR_GEOM, "geom")
        self._foot_index = {int(self._feet[0]): 0, int(self._feet[1]): 1}
        if model.opt.cone != mj.mjtCone.mjCONE_PYRAMIDAL or np.any(
            model.geom_condim[[self._floor, *self._feet]] != 3
        ):
            raise ValueError("centres_of_pressure expects condim 3 contacts and a pyramidal cone")
        self._soles = np.array([model.name2id("sole_l", "site"), model.name2id("sole_r", "site")])

        def sensor(name):
            i = model.name2id(name, "sensor")
            adr, dim = int(model.sensor_adr[i]), int(model.sensor_dim[i])
            return slice(adr, adr + dim)

        # Where each reading lies in `data.sensordata` (`sensor_slices`).
        self._sensors = {
            "torso_orientation": sensor("torso_orientation"),
            "gyro": sensor("gyro"),
            "accelerometer": sensor("accelerometer"),
            "foot_touch": slice(sensor("touch_l").start, sensor("touch_r").stop),
            "leg_torques": slice(
                sensor(f"force_{cpg.LEG_JOINTS[0]}").start,
                sensor(f"force_{cpg.LEG_JOINTS[-1]}").stop,
            ),
            "sole_velocities": slice(
                sensor("sole_velocity_l").start, sensor("sole_velocity_r").stop
            ),
            "servo_forces": slice(
                sensor(f"force_{cpg.LEG_JOINTS[0]}").start, sensor(f"force_{ARM_JOINTS[-1]}").stop
            ),
        }
        # The joint each servo turns, in actuator order (`cpg_suite.electrical`).
        self._servo_dofs = model.jnt_dofadr[model.actuator_trnid[:, 0]].copy()
        names = [model.id2name(int(i), "actuator") for i in range(model.nu)]
        if (
            names != [*cpg.LEG_JOINTS, *ARM_JOINTS]
            or model.opt.integrator == mj.mjtIntegrator.mjINT_RK4
        ):
            raise ValueError("expects the legs' then the arms' servos and a one-stage integrator")
        # Per physics step of the last `substeps`: servo forces, velocities, sensors.
        self._record_into(np.zeros((0, model.nu)), np.zeros((0, model.nv)))
        self._step_velocity = np.zeros((0, model.nu))  # the servos' part of `_step_qvel`
        self._meter: electrical.SupplyMeter | None = None  # `supply_currents`' buffers
        self._leg_range = model.jnt_range[[model.name2id(n, "joint") for n in cpg.LEG_JOINTS]]
        self._leg_low = self._leg_range[:, 0].copy()  # `action_to_targets`' constants
        self._leg_span = self._leg_range[:, 1] - self._leg_range[:, 0]
        self._weight = float(model.body_subtreemass[self._torso] * -model.opt.gravity[2])
        names = [model.id2name(i, "geom") or "" for i in range(model.ngeom)]
        self._tiles = np.array([i for i, n in enumerate(names) if n.startswith("tile")], int)
        self._ground = np.array([self._floor, *self._feet, *self._tiles], int)

    # Stepping, recording what the electrical model needs.
    def step(self, nstep: int = 1) -> None:
        """dm_control's step, recording each physics step's servo forces and joint velocities.

        As `dm_control.mujoco.Physics.step` (legacy stepping): `mj_step2` finishes the step
        whose `mj_step1` ran for the last observation, `mj_step` takes the others, then
        `mj_step1` brings positions and velocities up to date; a new invalid-state warning
        raises `PhysicsError`. The same MuJoCo calls, so the same trajectory.

        Args:
          nstep: Physics steps.
        """
        counts = self._warnings.tobytes()  # `check_invalid_state`, inline
        self.substeps(nstep, finish=True)
        mj.mj_step1(*self._pointers)
        if self._warnings.tobytes() != counts:
            self._raise_new_warnings(counts)

    def substeps(
        self, nstep: int, finish: bool = False, record=None, sensors: bool = False
    ) -> list:
        """Takes `nstep` physics steps, recording after each the servos' forces and the
        joint velocities (`servo_steps`), and with `sensors` the sensor readings
        (`sensor_steps`).

        Args:
          nstep: Physics steps.
          finish: The first step is `mj_step2` (`mj_step1` already ran), else `mj_step`.
          record: Called with the physics after each step; its values are returned.
          sensors: Also record `data.sensordata` after each step.

        Returns:
          The values `record` returned (empty without one).
        """
        model, data = self._pointers
        if len(self._step_force) != nstep:
            self._record_into(np.zeros((nstep, model.nu)), np.zeros((nstep, model.nv)))
        records = []
        readings = self._step_sensors if sensors else None
        actuator_force, velocity, sensordata = self._actuator_force, self._qvel, self._sensordata
        step = mj.mj_step
        for i, (force_row, qvel_row) in enumerate(self._step_rows):
            if finish and i == 0:
                mj.mj_step2(model, data)
            else:
                step(model, data)
            force_row[...] = actuator_force  # into views made once: cheaper than `force[i]`
            qvel_row[...] = velocity
            if readings is not None:
                readings[i] = sensordata
            if record is not None:
                records.append(record(self))
        return records

    def record_steps_into(self, force: np.ndarray, qvel: np.ndarray) -> None:
        """Makes `substeps` of `len(force)` steps record into these (steps, nu) and
        (steps, nv) arrays: views of a caller's larger buffers (`vector.DarwinVectorEnv`
        keeps all its robots' records in one array)."""
        self._record_into(force, qvel)

    def _record_into(self, force: np.ndarray, qvel: np.ndarray) -> None:
        """`substeps`' records: these arrays, a view of each of their rows, sensor rows."""
        self._step_force, self._step_qvel = force, qvel
        self._step_rows = list(zip(force, qvel))
        self._step_sensors = np.zeros((len(force), self.model.nsensordata))

    def sensor_steps(self) -> tuple[np.ndarray, ...]:
        """What the score card's gait-quality measures read after each physics step of the
        last `substeps(..., sensors=True)`, as the accessors read it after a step: the
        servos' joint velocities and forces (n, 20), the soles' touch (n, 2) and
        velocities (n, 6); copies."""
        readings, s = self._step_sensors, self._sensors
        return (
            self._step_qvel[:, self._servo_dofs],
            readings[:, s["servo_forces"]].copy(),
            readings[:, s["foot_touch"]].copy(),
            readings[:, s["sole_velocities"]].copy(),
        )

    @contextlib.contextmanager
    def check_invalid_state(self):
        """dm_control's check (a new invalid-state warning raises `PhysicsError`, or is
        logged inside `suppress_physics_errors`); the counts' bytes are compared on every
        step, and only a difference is looked into (`_raise_new_warnings`)."""
        counts = self._warnings.tobytes()
        yield
        if self._warnings.tobytes() != counts:
            self._raise_new_warnings(counts)

    def _raise_new_warnings(self, counts: bytes) -> None:
        """The end of `check_invalid_state`: a warning counted since the warning counts
        were `counts` (their bytes: comparing them is the cheap test on every step)
        raises `PhysicsError` (or is logged)."""
        before = np.frombuffer(counts, dtype=self._warnings.dtype)
        np.greater(self._warnings, before, out=self._new_warnings)
        if self._new_warnings.any():
            names = np.compress(self._new_warnings, list(mj.mjtWarning.__members__))
            message = f"Physics state is invalid. Warning(s) raised: {', '.join(names)}"
            if self._warnings_cause_exception:
                raise control.PhysicsError(message)
            logging.warning(message)

    def servo_steps(self) -> tuple[np.ndarray, np.ndarray]:
        """The 20 servos' forces (N·m) and their joints' velocities (rad/s) after each physics
        step of the last `step`, as (n, 20) arrays in actuator order."""
        return self._step_force, self._step_qvel[:, self._servo_dofs]

    def servo_damping(self) -> np.ndarray:
        """The damping of the 20 servos' joints, N·m·s/rad: their back-EMF braking."""
        return self._dof_damping[self._servo_dofs]

    def supply_currents(self) -> np.ndarray:
        """The robot's supply current after each physics step of the last `step`, A
        (`electrical.supply_current`)."""
        return self._supply_currents().copy()

    def _supply_currents(self) -> np.ndarray:
        """`supply_currents` in a buffer the next call overwrites (the tasks' hot path)."""
        force, qvel = self._step_force, self._step_qvel
        if self._meter is None or len(self._step_velocity) != len(force):
            self._meter = electrical.SupplyMeter(len(force), len(self._servo_dofs))
            self._step_velocity = np.zeros_like(force)
        velocity = np.take(qvel, self._servo_dofs, axis=1, out=self._step_velocity)
        return self._meter(force, velocity, self.servo_damping())

    def servo_forces(self) -> np.ndarray:
        """The 20 servos' forces, N·m, in actuator order (`actuatorfrc` sensors)."""
        return self._sensordata[self._sensors["servo_forces"]].copy()

    def servo_velocities(self) -> np.ndarray:
        """The 20 servos' joint velocities, rad/s, in actuator order."""
        return self._qvel[self._servo_dofs]

    def servo_dofs(self) -> np.ndarray:
        """The 20 servos' joint addresses in `qvel`, in actuator order."""
        return self._servo_dofs.copy()

    # Joints and servos.
    def set_servo_gain(self, kp: float) -> None:
        """Sets the position gain of every servo, N·m/rad.

        Raises:
          ValueError: If kp is not a positive number.
        """
        if not (np.isfinite(kp) and kp > 0):
            raise ValueError(f"servo gain must be a positive number of N·m/rad, got {kp!r}")
        self.model.actuator_gainprm[:, 0] = kp
        self.model.actuator_biasprm[:, 1] = -kp

    def set_torque_limit(self, limit: float) -> None:
        """Sets the torque limit of every servo, N·m.

        Raises:
          ValueError: If the limit is not a positive number.
        """
        if not (np.isfinite(limit) and limit > 0):
            raise ValueError(f"torque limit must be a positive number of N·m, got {limit!r}")
        self.model.actuator_forcerange[:] = [-limit, limit]

    def set_joint_damping(self, damping: float) -> None:
        """Sets the damping of every hinge joint (arms, head and legs), N·m·s/rad.

        Raises:
          ValueError: If the damping is negative or not finite.
        """
        if not (np.isfinite(damping) and damping >= 0):
            raise ValueError(f"joint damping must be ≥ 0 N·m·s/rad, got {damping!r}")
        hinges = self.model.jnt_type == mj.mjtJoint.mjJNT_HINGE
        self.model.dof_damping[self.model.jnt_dofadr[hinges]] = damping

    def set_ground_friction(self, friction: float) -> None:
        """Sets the sliding friction of the floor, the terrain tiles and the soles.

        MuJoCo takes the larger coefficient of two touching geoms, so both sides change.

        Raises:
          ValueError: If the friction is not a positive number.
        """
        if not (np.isfinite(friction) and friction > 0):
            raise ValueError(f"friction must be a positive number, got {friction!r}")
        self.model.geom_friction[self._ground, 0] = friction

    def set_torso_inertial(self, mass: float, inertia: np.ndarray, com: np.ndarray) -> None:
        """Sets the torso's mass (kg), principal inertia (kg·m²) and centre of mass (m).

        Recomputes the model's derived constants (`mj_setConst`) so the solver sees them.
        """
        self.model.body_mass[self._torso] = mass
        self.model.body_inertia[self._torso] = inertia
        self.model.body_ipos[self._torso] = com
        mj.mj_setConst(self.model.ptr, self.data.ptr)

    def torso_inertial(self) -> tuple[float, np.ndarray, np.ndarray]:
        """The torso's mass (kg), principal inertia (kg·m²) and centre of mass (m)."""
        torso = self._torso
        model = self.model
        return (
            float(model.body_mass[torso]),
            model.body_inertia[torso].copy(),
            model.body_ipos[torso].copy(),
        )

    def set_tile_heights(self, heights: np.ndarray) -> None:
        """Raises the terrain tiles' tops to `heights` above the plane, m (0: hidden).

        Raises:
          ValueError: If the model has no tiles or the heights do not match them.
        """
        heights = np.asarray(heights, dtype=np.float64)
        if heights.shape != self._tiles.shape or not len(self._tiles):
            raise ValueError(f"need {len(self._tiles)} tile heights, got shape {heights.shape}")
        self.model.geom_pos[self._tiles, 2] = perturbations.tile_heights_to_z(heights)

    def set_torso_push(self, force: np.ndarray) -> None:
        """Applies a force (N, world frame) at the torso's centre of mass until changed."""
        self.data.xfrc_applied[self._torso, :3] = force

    def torso_body(self) -> int:
        """The torso's body id (the row of `xfrc_applied` a push acts on)."""
        return int(self._torso)

    def servo_gain(self) -> float:
        """The position gain of the servos, N·m/rad."""
        return float(self.model.actuator_gainprm[0, 0])

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

    def set_leg_targets(self, angles: np.ndarray) -> None:
        """Sets the leg servo targets, rad (clipped to the joint ranges by MuJoCo)."""
        self._ctrl[self._leg_act] = angles

    def set_arm_targets(self, angles: np.ndarray) -> None:
        """Sets the arm and head servo targets, rad (`ARM_JOINTS` order)."""
        self._ctrl[self._arm_act] = angles

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

    def sensor_slices(self) -> dict[str, slice]:
        """Where the readings of the accessors below lie in `data.sensordata`, for code that
        reads many robots' sensor arrays at once: keys `torso_orientation`, `gyro`,
        `accelerometer`, `foot_touch`, `leg_torques`, `sole_velocities`."""
        return dict(self._sensors)

    def torso_orientation(self) -> np.ndarray:
        """Torso orientation quaternion (w, x, y, z) from the IMU."""
        return self._sensordata[self._sensors["torso_orientation"]].copy()

    def root_qpos(self) -> np.ndarray:
        """The free joint's coordinates: torso position (3) and quaternion (4)."""
        return self._qpos[self._root_qpos : self._root_qpos + 7].copy()

    def torso_upright(self) -> float:
        """z component of the torso's z axis (1 upright, 0 lying)."""
        return float(torso_upright(self._qpos[self._root_qpos + 3 : self._root_qpos + 7]))

    def torso_velocity(self) -> np.ndarray:
        """Linear velocity of the torso origin in the world frame, m/s."""
        return self._qvel[self._root_dof : self._root_dof + 3].copy()

    def gyro(self) -> np.ndarray:
        """IMU angular velocity in the torso frame, rad/s."""
        return self._sensordata[self._sensors["gyro"]].copy()

    def accelerometer(self) -> np.ndarray:
        """IMU specific force in the torso frame, m/s²."""
        return self._sensordata[self._sensors["accelerometer"]].copy()

    def fallen(self) -> bool:
        """The torso is below 0.22 m or tilted more than 50° (`has_fallen`, in Python floats:
        the same IEEE operations in the same order, without NumPy's per-call cost)."""
        r = self._root_qpos
        _, _, z, w, x, y, qz = self._qpos[r : r + 7].tolist()
        upright = (w * w - x * x - y * y + qz * qz) / (w * w + x * x + y * y + qz * qz)
        return z < _FALL_HEIGHT or upright < _FALL_TILT_COS

    # Feet.
    def foot_touch(self) -> np.ndarray:
        """Normal force on the (left, right) sole touch sensors, N."""
        return self._sensordata[self._sensors["foot_touch"]].copy()

    def leg_torques(self) -> np.ndarray:
        """Torques of the 12 leg servos, N·m (`cpg.LEG_JOINTS` order)."""
        return self._sensordata[self._sensors["leg_torques"]].copy()

    def sole_velocities(self) -> np.ndarray:
        """(2, 3) linear velocities of the (left, right) sole centres in the world, m/s."""
        return self._sensordata[self._sensors["sole_velocities"]].reshape(2, 3).copy()

    def torque_limit(self) -> float:
        """The servos' torque limit, N·m."""
        return float(self.model.actuator_forcerange[0, 1])

    def total_mass(self) -> float:
        """The robot's mass, kg."""
        return float(self.model.body_subtreemass[self._torso])

    def sole_centres(self) -> np.ndarray:
        """(2, 3) centres of the (left, right) soles in the world, m."""
        return self.data.site_xpos[self._soles]

    def _foot_loads(self) -> tuple[list[float], list[list[float]]]:
        """Normal force of each foot and the force-weighted sum of its contact points.

        The normal force of a contact is the sum of its four pyramid-edge forces (condim 3,
        pyramidal cone: checked when the model is loaded), as `mj_contactForce` computes
        it; a plain loop over the few contacts is the fastest way on this hot path.

        dm_control ends each step with `mj_step1`, which finds the contacts of the new state
        but does not solve for their forces: `efc_force` then holds whatever the arena held
        (it differed between processes). So the forces are solved here first
        (`mj_forwardSkip` from the velocity stage, sensors skipped); the next step solves
        them again from scratch, so the trajectory does not change (tests/test_darwin.py).
        """
        data = self.data.ptr
        mj.mj_forwardSkip(self.model.ptr, data, mj.mjtStage.mjSTAGE_VEL, 1)
        force = [0.0, 0.0]
        weighted = [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
        if data.ncon:
            contacts = data.contact
            efc = data.efc_force.tolist()
            floor, feet = self._floor, self._foot_index
            for (g0, g1), adr, pos in zip(
                contacts.geom.tolist(), contacts.efc_address.tolist(), contacts.pos.tolist()
            ):
                foot = feet.get(g1) if g0 == floor else feet.get(g0) if g1 == floor else None
                if foot is None or adr < 0:
                    continue
                normal = efc[adr] + efc[adr + 1] + efc[adr + 2] + efc[adr + 3]
                if normal > 0.0:
                    force[foot] += normal
                    w = weighted[foot]
                    w[0] += normal * pos[0]
                    w[1] += normal * pos[1]
                    w[2] += normal * pos[2]
        return force, weighted

    def centres_of_pressure(self) -> tuple[np.ndarray, np.ndarray]:
        """Centre of pressure and normal force of each foot, from its floor contacts.

        Returns:
          `(cop, force)`: cop (2, 3), m, NaN for a foot without contact; force (2,), N.
        """
        force, weighted = self._foot_loads()
        cop = np.full((2, 3), np.nan)
        for foot in (0, 1):
            if force[foot] > 0.0:
                cop[foot] = np.array(weighted[foot]) / force[foot]
        return cop, np.array(force)

    def cop_offsets(self) -> tuple[np.ndarray, np.ndarray]:
        """Horizontal distance from each foot's COP to its sole centre, and the stance mask.

        Returns:
          `(distance, stance)`: distance (2,), m (NaN without contact); stance (2,) bool, a
          foot carrying more than 5 % of the body weight.
        """
        distance, stance = self._cop_offsets()
        return np.array(distance), np.array(stance)

    def _cop_offsets(self) -> tuple[list[float], list[bool]]:
        force, weighted = self._foot_loads()
        soles = self.data.site_xpos[self._soles].tolist()
        threshold = _STANCE_FRACTION * self._weight
        distance, stance = [math.nan, math.nan], [False, False]
        for foot in (0, 1):
            f = force[foot]
            if f > 0.0:
                distance[foot] = math.hypot(
                    weighted[foot][0] / f - soles[foot][0], weighted[foot][1] / f - soles[foot][1]
                )
                stance[foot] = f > threshold
        return distance, stance

    def balance_reward(self) -> float:
        """−(mean over stance feet of the COP distance to the sole centre), m; 0 without."""
        distance, stance = self._cop_offsets()
        offsets = [d for d, s in zip(distance, stance) if s]
        return -sum(offsets) / len(offsets) if offsets else 0.0

    # Poses.
    def set_standing_pose(
        self, leg_angles: np.ndarray, arm_angles: np.ndarray = ARM_POSE, clearance: float = 0.0
    ) -> None:
        """Puts the robot at rest in a pose, torso upright at the origin, lowest sole corner
        `clearance` above the floor; servo targets set to the pose."""
        data = self.data
        data.qpos[:] = self.model.qpos0
        data.qvel[:] = 0.0
        data.qpos[self._leg_qpos] = leg_angles
        data.qpos[self._arm_qpos] = arm_angles
        data.qpos[self._root_qpos : self._root_qpos + 3] = (0.0, 0.0, 0.5)
        data.qpos[self._root_qpos + 3 : self._root_qpos + 7] = (1.0, 0.0, 0.0, 0.0)
        mj.mj_kinematics(self.model.ptr, data.ptr)
        lowest = min(self._lowest_corner(g) for g in self._feet)
        data.qpos[self._root_qpos + 2] += clearance - lowest
        self.set_leg_targets(leg_angles)
        self.set_arm_targets(arm_angles)
        self.after_reset()

    def _lowest_corner(self, geom: int) -> float:
        """Height of a box geom's lowest corner, m.

        Written out element by element rather than as a matrix product: BLAS kernels differ
        between CPUs in their last bit, and this height places the robot at every reset.
        """
        half = self.model.geom_size[geom]
        rot = self.data.geom_xmat[geom].reshape(3, 3)
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        local = corners * half
        z = self.data.geom_xpos[geom, 2] + local[:, 0] * rot[2, 0]
        z = z + local[:, 1] * rot[2, 1]
        z = z + local[:, 2] * rot[2, 2]
        return float(z.min())

    # Actions.
    def targets_to_action(self, angles: np.ndarray) -> np.ndarray:
        """Leg joint angles (rad) -> normalized action in [−1, 1] (clipped)."""
        low, high = self._leg_range[:, 0], self._leg_range[:, 1]
        return np.clip(2.0 * (np.asarray(angles) - low) / (high - low) - 1.0, -1.0, 1.0)

    def action_to_targets(self, action: np.ndarray) -> np.ndarray:
        """Normalized action in [−1, 1] -> leg joint angles, rad."""
        return self._leg_low + (np.asarray(action) + _ONE) * _HALF * self._leg_span


class CPGTask(base.Task):
    """Walk or balance with 12 leg joint targets (thesis Ch. 5-6)."""

    def __init__(
        self,
        objective: str,
        posture: np.ndarray | None = None,
        init_noise: float = INIT_NOISE,
        random=None,
        randomization: perturbations.Randomization | None = None,
        pushes: perturbations.Pushes | None = None,
        terrain: perturbations.Terrain | None = None,
        supply: electrical.SupplyLimit | None = electrical.DEFAULT_SUPPLY,
    ):
        """Initializes the task.

        Args:
          objective: `"walk"` or `"balance"`.
          posture: Starting leg joint angles (12,), rad (default: the CPG standing posture).
          init_noise: Half-width of the uniform joint perturbation at reset, rad (≥ 0).
          random: Seed or `np.random.RandomState`.
          randomization: Draw the physical parameters per episode from these ranges.
          pushes: Push the torso as these describe, drawn per episode.
          terrain: Raise the model's tiles (it must have them) per episode.
          supply: The supply's limit (a brown-out ends the episode like a fall); None: the
            study's unlimited physics. The supply current is measured either way.

        Raises:
          ValueError: On an unknown objective, a posture of the wrong shape, or negative
            noise.
        """
        if objective not in OBJECTIVES:
            raise ValueError(f"objective must be one of {OBJECTIVES}, got {objective!r}")
        posture = cpg.CPGConfig().offsets() if posture is None else np.asarray(posture, float)
        if posture.shape != (12,) or not np.all(np.isfinite(posture)):
            raise ValueError(f"posture must be 12 finite leg joint angles, got {posture!r}")
        if not init_noise >= 0:
            raise ValueError(f"init_noise must be ≥ 0, got {init_noise!r}")
        if supply is not None and not isinstance(supply, electrical.SupplyLimit):
            raise ValueError(f"supply must be an electrical.SupplyLimit or None, got {supply!r}")
        self.objective = objective
        self.posture = posture
        self.init_noise = float(init_noise)
        self._action_spec = specs.BoundedArray((12,), np.float64, -1.0, 1.0, name="leg_targets")
        self.randomization, self.pushes, self.terrain = randomization, pushes, terrain
        self.supply_limit = supply
        self.supply: electrical.SupplyMonitor | None = None  # this episode's supply current
        self.failure: str | None = None  # why the episode ended early (`electrical.CAUSES`)
        self.episode_parameters: dict = {}
        self.push_schedule: list[tuple] = []
        self._nominal_torso = None
        self.start_position = np.zeros(3)
        self._x_before = 0.0
        super().__init__(random=random)

    def initialize_episode(self, physics: Physics) -> None:
        """Draws the initial posture, then the episode's perturbations, in a fixed order.

        The posture's draw comes first, so a tier whose perturbation is switched off (e.g.
        zero-height terrain) starts from the nominal task's state for the same seed.
        """
        noise = self.random.uniform(-self.init_noise, self.init_noise, size=12)
        if self.randomization is not None:
            self.episode_parameters = self.randomization.sample(self.random)
            self._apply_parameters(physics, self.episode_parameters)
        if self.terrain is not None:
            physics.set_tile_heights(self.terrain.sample(self.random))
        if self.pushes is not None:
            self.push_schedule = self.pushes.sample(self.random, CONTROL_TIMESTEP)
            physics.set_torso_push(np.zeros(3))
        physics.set_standing_pose(self.posture + noise)
        if self.supply is None:
            limit = self.supply_limit or electrical.SupplyLimit()
            enforce = self.supply_limit is not None
            self.supply = electrical.SupplyMonitor(limit, physics.timestep(), enforce)
        self.supply.reset()
        self.failure = None
        self.start_position = physics.torso_position()
        self._x_before = self.start_position[0]
        super().initialize_episode(physics)

    def _apply_parameters(self, physics: Physics, params: dict) -> None:
        if self._nominal_torso is None:
            self._nominal_torso = physics.torso_inertial()
        mass, inertia, com = self._nominal_torso
        physics.set_servo_gain(params["servo_gain"])
        physics.set_torque_limit(params["torque_limit"])
        physics.set_joint_damping(params["joint_damping"])
        physics.set_ground_friction(params["friction"])
        shift = np.array([params["torso_com_shift"][0], params["torso_com_shift"][1], 0.0])
        scale = params["torso_mass_scale"]
        physics.set_torso_inertial(mass * scale, inertia * scale, com + shift)

    def push_forces(self, n_steps: int) -> np.ndarray:
        """(n_steps, 3) push force on the torso during each control step of the episode, N."""
        return perturbations.push_forces(self.push_schedule, n_steps)

    def before_step(self, action, physics: Physics) -> None:
        action = base.check_continuous_action(action, self._action_spec)
        physics.set_leg_targets(physics.action_to_targets(action))
        if self.pushes is not None:
            step = int(round(physics.data.time / CONTROL_TIMESTEP))  # 0-based control step
            physics.set_torso_push(perturbations.push_force(self.push_schedule, step))
        self._x_before = physics.forward_position()

    def get_observation(self, physics: Physics) -> collections.OrderedDict:
        """Leg joint angles and velocities, torso orientation, height and velocity, IMU, touch."""
        obs = collections.OrderedDict()
        obs["joint_angles"] = physics.leg_joint_angles()
        obs["joint_velocities"] = physics.leg_joint_velocities()
        obs["torso_orientation"] = physics.torso_orientation()
        obs["torso_height"] = np.array([physics.torso_height()])
        obs["torso_velocity"] = physics.torso_velocity()
        obs["gyro"] = physics.gyro()
        obs["accelerometer"] = physics.accelerometer()
        obs["foot_touch"] = physics.foot_touch()
        return obs

    def get_reward(self, physics: Physics) -> float:
        if self.objective == "walk":
            return physics.forward_position() - self._x_before
        return physics.balance_reward()

    def after_step(self, physics: Physics) -> None:
        """Adds the step's supply currents to the episode's (`electrical.SupplyMonitor`)."""
        self.supply.update(physics._supply_currents())
        super().after_step(physics)

    def get_termination(self, physics: Physics):
        """A fall or a brown-out ends the episode (discount 0); `failure` says which."""
        if physics.fallen():
            self.failure = "fall"
        elif self.supply.browned_out:
            self.failure = "brownout"
        return 0.0 if self.failure else None

    def reward_to_unit(self, reward: float) -> float:
        if self.objective == "walk":
            return 0.5 + 0.5 * reward / (_WALK_VIZ_SPEED * CONTROL_TIMESTEP)
        return 1.0 + reward / _BALANCE_VIZ_DISTANCE
