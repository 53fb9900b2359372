"""The DARwIn-OP walking tiers in MJX: pure `reset(key)` and `step(state, action)` functions.

`WalkEnv(task_id, action_space)` runs `darwin_walk`, `darwin_walk_randomized` or
`darwin_walk_push` on MJX (MuJoCo in JAX) over the same MJCF as the CPU task
(`darwin.get_model_and_assets`), with the CPU task's

* observation, flattened in the order `OBSERVATION_KEYS` (40 numbers; the `cpg` action
  space appends `cpg_phase`, cos φ_L and sin φ_L);
* action: `joints`, 12 leg targets in [−1, 1] scaled onto the joint ranges, or `cpg`, the
  CPG-modulating space of `cpg_suite.residual` (`cpg_suite.mjx.modulated`);
* reward: the torso's forward (x) displacement during the control step, m;
* fall test `darwin.has_fallen` and the supply's brown-out (`cpg_suite.electrical`: the
  mean supply current over the last second above 10 A, from every physics step's servo
  forces and joint velocities; termination, discount 0), time limit of
  `darwin.DEFAULT_TIME_LIMIT` (1000 control steps of `darwin.CONTROL_TIMESTEP` = 8 physics
  steps of 2 ms);
* reset: the standing posture plus U(−noise, noise) per leg joint, the lowest sole corner
  on the floor, actuation off for the first forward pass (dm_control's `after_reset`);
* per-episode draws of the tiers: `perturbations.Randomization` (servo gain, torque limit,
  joint damping, friction, torso mass and centre of mass) and `perturbations.Pushes`, from
  the same distributions as the CPU tasks but drawn with JAX keys: the same distribution,
  not the same samples as a CPU seed.

Timing of the readings as on the CPU: dm_control finishes a control step with `mj_step1`,
so positions and velocities (joint angles, orientation, height, velocities, gyro) are those
of the new state, while the acceleration-stage sensors (accelerometer, touch) are those the
last physics step computed before it integrated. `mjx.step` leaves `sensordata` at the
state before integration, so the position and velocity readings are computed from
`qpos`/`qvel` (the torso is the free-joint body: its frame is the root's coordinates and the
gyro, at a site aligned with it, reads the root's angular velocity) and the other two are
MJX's `accelerometer` and `touch` sensors; `tests/test_mjx.py` checks all against the CPU
sensors. The physics steps are `cpg_suite.mjx.physics.step`: `mjx.step` with MuJoCo C's
box-plane contacts. `darwin_walk_rough` is not here: see docs/architecture.md#the-mjx-path.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import mjx

from cpg_suite import cpg, darwin, electrical, perturbations, residual
from cpg_suite.mjx import modulated, physics, setconst

TASKS = ("darwin_walk", "darwin_walk_randomized", "darwin_walk_push")
ACTION_SPACES = residual.ACTION_SPACES
# Contact pairs MJX computes: "model", every pair of the MJCF (the CPU reference's);
# "soles", only the pairs among the floor and the two soles (`sole_contacts_only`).
CONTACTS = ("model", "soles")
# MJX's backends: "jax" (MJX's own JAX code, any JAX device) and "warp" (MuJoCo Warp through
# JAX's FFI: an NVIDIA GPU, or the CPU through Warp's CPU device; float32 always).
IMPLS = ("jax", "warp")


class PhysicsSettings(NamedTuple):
    """A named set of physics choices of the MJX env (`PHYSICS`).

    Attributes:
      contacts: Contact pairs computed (`CONTACTS`).
      solver_iterations: `(iterations, line-search iterations)` caps of the constraint
        solver, or None for the model's own (100, 50).
      timestep: The physics step, s, or None for the model's own (2 ms); the control step
        stays `darwin.CONTROL_TIMESTEP`, which it must divide.
      float32: Whether the physics must run in float32 (JAX's default; x64 refused).
    """

    contacts: str
    solver_iterations: tuple[int, int] | None
    timestep: float | None
    float32: bool


# "reference": the CPU task's physics (every contact pair, the model's solver, 2 ms steps;
# float64 under `jax.enable_x64`, as the agreement tests run it). "training": what the GPU
# trainers step, chosen in docs/decisions.md#the-training-physics from the gaps measured in
# results/mjx/README.md#the-training-physics (feet-only contacts as MuJoCo Playground's OP3,
# the line search capped, float32). Scores always come from the CPU reference.
PHYSICS = {
    "reference": PhysicsSettings("model", None, None, False),
    "training": PhysicsSettings("soles", (100, 8), None, True),
}
# Contacts MuJoCo Warp may hold per robot, as a multiple of MJX-JAX's fixed slots for the
# same pairs (Warp's box-box routine can return up to 8 points where MJX keeps 4).
_WARP_CONTACTS_PER_SLOT = 2
OBSERVATION_KEYS = darwin.OBSERVATION_KEYS
OBSERVATION_SIZES = {k: n for k, n in zip(OBSERVATION_KEYS, (12, 12, 4, 1, 3, 3, 3, 2))}
PHASE_SIZE = 2  # cos φ_L, sin φ_L appended in the `cpg` action space.
EPISODE_STEPS = int(round(darwin.DEFAULT_TIME_LIMIT / darwin.CONTROL_TIMESTEP))  # 1000
_START_HEIGHT = 0.5  # m: torso height before the pose is lowered onto the floor.


class EpisodeParams(NamedTuple):
    """One episode's physical parameters (`perturbations.Randomization.sample`'s keys)."""

    servo_gain: jax.Array  # N·m/rad
    torque_limit: jax.Array  # N·m
    joint_damping: jax.Array  # N·m·s/rad
    friction: jax.Array
    torso_mass_scale: jax.Array
    torso_com_shift: jax.Array  # (2,) m


class PushSchedule(NamedTuple):
    """One episode's pushes: first control step (P,), duration in steps, force (P, 3) N."""

    start: jax.Array
    steps: jax.Array
    force: jax.Array


class State(NamedTuple):
    """The state of one episode; every field is a JAX array (a pytree for `vmap`).

    Attributes:
      data: The MJX physics state.
      obs: The observation (`observation_size`,).
      reward: Reward of the last control step, m.
      done: 1.0 when the episode has ended (fall, brown-out or time limit), else 0.0.
      fell: 1.0 when the last step ended the episode early, by a fall or a brown-out
        (discount 0).
      brownout: 1.0 when that was a brown-out of the supply (and not a fall).
      supply: The supply current's running total, A·steps, and the ring of the last
        window's totals (`electrical.SupplyMonitor`'s T_k).
      step: Control steps taken.
      params: The episode's physical parameters.
      invweights: The episode model's `body_invweight0` and `dof_invweight0`, computed
        once at reset (`setconst.invweights`).
      pushes: The episode's pushes.
      cpg: The CPG row of the `cpg` action space (unused by `joints`).
    """

    data: mjx.Data
    obs: jax.Array
    reward: jax.Array
    done: jax.Array
    fell: jax.Array
    brownout: jax.Array
    supply: tuple[jax.Array, jax.Array]
    step: jax.Array
    params: EpisodeParams
    invweights: tuple[jax.Array, jax.Array]
    pushes: PushSchedule
    cpg: modulated.CPGState


class WalkEnv:
    """A DARwIn-OP walking tier on MJX with pure, `jit`- and `vmap`-able reset and step."""

    def __init__(
        self,
        task_id: str = "darwin_walk",
        action_space: str = "joints",
        *,
        posture: np.ndarray | None = None,
        randomization: perturbations.Randomization | None = None,
        pushes: perturbations.Pushes | None = None,
        config: cpg.CPGConfig | None = None,
        physics: str = "reference",
        impl: str = "jax",
        solver_iterations: tuple[int, int] | None = None,
        contacts: str | None = None,
        timestep: float | None = None,
        max_robots: int = 8192,
        supply: electrical.SupplyLimit | None = electrical.DEFAULT_SUPPLY,
    ):
        """Builds the MJX model; call under `jax.enable_x64(True)` for float64 physics.

        Args:
          task_id: One of `TASKS`.
          action_space: `joints` or `cpg` (`ACTION_SPACES`).
          posture: Starting leg joint angles (12,), rad (default: the CPG standing posture).
          randomization: Ranges of `darwin_walk_randomized` (default
            `perturbations.Randomization()`); ignored by the other tiers.
          pushes: Pushes of `darwin_walk_push` (default `perturbations.Pushes()`).
          config: CPG constants of the `cpg` action space and of the default posture.
          physics: A named physics of `PHYSICS`: "reference" (the CPU task's) or
            "training" (what the GPU trainers step). The three arguments below override
            its parts one by one, for measurements.
          impl: MJX's backend (`IMPLS`): "jax" or "warp" (needs `warp-lang`, the `mjx`
            extra's; float32).
          solver_iterations: `(iterations, line-search iterations)` caps of MJX's
            constraint solver; None keeps the physics' own (the reference's: the model's
            100 / 50). Under
            `vmap` every robot pays for the full line search and for the slowest robot's
            iterations, so caps are much faster on a GPU (results/mjx); MuJoCo C on this
            model needs about 1.2-1.4 solver iterations per step and up to 7 line-search
            evaluations, sampled once per control step (`investigations/solver_stats.py`;
            not the same unit as MJX's line-search iterations).
            `investigations/mjx_agreement.py --solver_iterations` measures what a cap changes.
          contacts: None keeps the physics' own; "model" computes every contact pair of
            the MJCF, as the CPU reference does; "soles" only the pairs among the floor and
            the soles
            (`sole_contacts_only`): the same physics as long as nothing else touches
            (`investigations/contact_census.py` measures how long that is in the reference),
            and about a seventh of the constraint rows, which MJX computes for every
            pair whether it touches or not.
          timestep: The physics step, s (None: the physics' own); it must divide the
            16 ms control step.
          max_robots: On Warp, the most robots one batched call steps: Warp holds one list
            of contacts for the whole batch, sized for this many robots (a larger batch
            drops contacts). Unused by "jax".
          supply: The supply limit enforced (None: the study's unlimited supply).

        Raises:
          ValueError: On an unknown task, action space, physics, backend or contacts, a bad
            posture, solver caps, timestep or `max_robots`, or float32 physics under x64.
        """
        if task_id not in TASKS:
            raise ValueError(f"unknown MJX task {task_id!r}; valid: {', '.join(TASKS)}")
        if action_space not in ACTION_SPACES:
            raise ValueError(f"action_space must be one of {ACTION_SPACES}, got {action_space!r}")
        self.physics = physics_settings(physics, contacts, solver_iterations, timestep)
        if impl not in IMPLS:
            raise ValueError(f"impl must be one of {IMPLS}, got {impl!r}")
        if isinstance(max_robots, bool) or not isinstance(max_robots, int) or max_robots < 1:
            raise ValueError(f"max_robots must be an integer ≥ 1, got {max_robots!r}")
        if self.physics.float32 and jnp.zeros(()).dtype != jnp.float32:
            raise ValueError(f"the {physics!r} physics runs in float32: build it with x64 off")
        self.task_id, self.action_space, self.impl = task_id, action_space, impl
        self.contacts = self.physics.contacts
        self.config = config or cpg.CPGConfig()
        posture = self.config.offsets() if posture is None else np.asarray(posture, float)
        if posture.shape != (12,) or not np.all(np.isfinite(posture)):
            raise ValueError(f"posture must be 12 finite leg joint angles, got {posture!r}")
        self.posture = posture
        randomized = task_id == "darwin_walk_randomized"
        self.randomization = (
            (randomization or perturbations.Randomization()) if randomized else None
        )
        self.pushes = (pushes or perturbations.Pushes()) if task_id == "darwin_walk_push" else None
        self.init_noise = self.randomization.init_noise if randomized else darwin.INIT_NOISE
        self.mj_model = self._physics_model(self.physics)
        self._jax_model = mjx.put_model(self.mj_model)  # also `setconst`'s on Warp
        self.model = self._jax_model
        if impl == "warp":
            self.model = mjx.put_model(self.mj_model, impl="warp")
            self._warp_data = self._warp_template(max_robots)
        self._layout(self.mj_model)
        self.n_substeps = darwin.physics_steps_per_control_step(self.mj_model)
        self.supply = supply
        limit = supply or electrical.DEFAULT_SUPPLY
        self._window = limit.window_steps(float(self.mj_model.opt.timestep))
        self._limit = limit.current
        self.nominal_amplitudes = cpg.amplitudes_from("hand_tuned")
        self._data_shapes = None  # `mjx.step`'s output types, found on first use

    @staticmethod
    def _physics_model(settings: PhysicsSettings) -> mujoco.MjModel:
        """The DARwIn-OP model with a physics' contacts, solver caps and timestep."""
        xml, assets = darwin.get_model_and_assets()
        m = mujoco.MjModel.from_xml_string(darwin.robot.for_mjx(xml), assets)
        if settings.solver_iterations is not None:
            m.opt.iterations, m.opt.ls_iterations = settings.solver_iterations
        if settings.contacts == "soles":
            sole_contacts_only(m)
        if settings.timestep is not None:
            m.opt.timestep = settings.timestep
        return m

    def _warp_template(self, max_robots: int) -> mjx.Data:
        """A Warp data whose contact list holds `max_robots` robots' contacts.

        Each robot gets `_WARP_CONTACTS_PER_SLOT` times the contact slots MJX-JAX gives
        the same pairs, and as many times its constraint rows.
        """
        jax_data = mjx.make_data(self._jax_model)
        slots = jax_data._impl.contact.dist.shape[0]
        self.warp_contacts_per_robot = _WARP_CONTACTS_PER_SLOT * slots
        self.warp_naconmax = self.warp_contacts_per_robot * max_robots
        self.warp_njmax = _WARP_CONTACTS_PER_SLOT * jax_data._impl.efc_J.shape[0]
        return mjx.make_data(
            self.mj_model, impl="warp", naconmax=self.warp_naconmax, njmax=self.warp_njmax
        )

    def _layout(self, m: mujoco.MjModel) -> None:
        """Addresses looked up by name, as `darwin.Physics` does."""

        def joint(name):
            return m.joint(name).id

        self._leg_qpos = np.array([m.jnt_qposadr[joint(n)] for n in cpg.LEG_JOINTS])
        self._leg_dof = np.array([m.jnt_dofadr[joint(n)] for n in cpg.LEG_JOINTS])
        self._arm_qpos = np.array([m.jnt_qposadr[joint(n)] for n in darwin.ARM_JOINTS])
        self._leg_act = np.array([m.actuator(n).id for n in cpg.LEG_JOINTS])
        self._arm_act = np.array([m.actuator(n).id for n in darwin.ARM_JOINTS])
        self._leg_range = m.jnt_range[[joint(n) for n in cpg.LEG_JOINTS]]
        self._torso = m.body("torso").id
        root = joint("root")
        self._root_qpos, self._root_dof = int(m.jnt_qposadr[root]), int(m.jnt_dofadr[root])
        self._feet = np.array([m.geom(n).id for n in darwin.FOOT_GEOMS])
        self._ground = np.array([m.geom(n).id for n in darwin.GROUND_GEOMS])
        self._hinge_dofs = m.jnt_dofadr[m.jnt_type == mujoco.mjtJoint.mjJNT_HINGE]
        self._servo_dofs = m.jnt_dofadr[m.actuator_trnid[:, 0]]

        def sensor(name):
            i = m.sensor(name).id
            return np.arange(m.sensor_adr[i], m.sensor_adr[i] + m.sensor_dim[i])

        self._accelerometer = sensor("accelerometer")
        self._touch = np.concatenate([sensor("touch_l"), sensor("touch_r")])

    # Sizes.
    @property
    def observation_size(self) -> int:
        """Length of the observation vector."""
        extra = PHASE_SIZE if self.action_space == "cpg" else 0
        return sum(OBSERVATION_SIZES.values()) + extra

    @property
    def action_size(self) -> int:
        """Length of the action vector (12 in both action spaces)."""
        return 12 if self.action_space == "joints" else residual.N_ACTIONS

    # Actions.
    def action_to_targets(self, action: jax.Array) -> jax.Array:
        """`darwin.Physics.action_to_targets` (action clipped to [−1, 1]), rad."""
        low, high = self._leg_range[:, 0], self._leg_range[:, 1]
        return low + (jnp.clip(action, -1.0, 1.0) + 1.0) * 0.5 * (high - low)

    def targets_to_action(self, angles: jax.Array) -> jax.Array:
        """`darwin.Physics.targets_to_action`: rad -> [−1, 1] (clipped)."""
        low, high = self._leg_range[:, 0], self._leg_range[:, 1]
        return jnp.clip(2.0 * (angles - low) / (high - low) - 1.0, -1.0, 1.0)

    # Episode draws.
    def nominal_params(self) -> EpisodeParams:
        """The model's own parameters (`perturbations.NOMINAL_*`, unscaled torso)."""
        real = jnp.zeros(()).dtype  # float64 under x64; not weakly typed (one compiled step)
        return EpisodeParams(
            servo_gain=jnp.asarray(perturbations.NOMINAL_SERVO_GAIN, real),
            torque_limit=jnp.asarray(perturbations.NOMINAL_TORQUE_LIMIT, real),
            joint_damping=jnp.asarray(perturbations.NOMINAL_JOINT_DAMPING, real),
            friction=jnp.asarray(perturbations.NOMINAL_FRICTION, real),
            torso_mass_scale=jnp.ones((), real),
            torso_com_shift=jnp.zeros(2, real),
        )

    def sample_params(self, key: jax.Array) -> EpisodeParams:
        """One draw of `perturbations.Randomization` (the same ranges, JAX's generator)."""
        r = self.randomization
        k = jax.random.split(key, 6)

        def uniform(i, bounds, shape=()):
            return jax.random.uniform(k[i], shape, minval=bounds[0], maxval=bounds[1])

        shift = r.torso_com_shift
        return EpisodeParams(
            servo_gain=uniform(0, r.servo_gain),
            torque_limit=uniform(1, r.torque_limit),
            joint_damping=uniform(2, r.joint_damping),
            friction=uniform(3, r.friction),
            torso_mass_scale=uniform(4, r.torso_mass_scale),
            torso_com_shift=uniform(5, (-shift, shift), (2,)),
        )

    def sample_pushes(self, key: jax.Array) -> PushSchedule:
        """One draw of `perturbations.Pushes.sample` (same distribution, JAX's generator)."""
        p, dt = self.pushes, darwin.CONTROL_TIMESTEP
        n = len(p.times)
        k_jitter, k_angle, k_impulse = jax.random.split(key, 3)
        jitter = jax.random.uniform(k_jitter, (n,), minval=0.0, maxval=p.jitter)
        start = jnp.round((jnp.asarray(p.times) + jitter) / dt).astype(jnp.int32)
        angle = jax.random.uniform(k_angle, (n,), minval=-jnp.pi, maxval=jnp.pi)
        impulse = jax.random.uniform(k_impulse, (n,), minval=p.impulse[0], maxval=p.impulse[1])
        magnitude = impulse / (p.steps * dt)
        force = magnitude[:, None] * jnp.stack(
            [jnp.cos(angle), jnp.sin(angle), jnp.zeros(n)], axis=-1
        )
        return PushSchedule(start=start, steps=jnp.asarray(p.steps, jnp.int32), force=force)

    @staticmethod
    def no_pushes() -> PushSchedule:
        """A schedule without pushes, shaped as the push tier's (one `step` for all tiers)."""
        n = len(perturbations.Pushes().times)
        return PushSchedule(
            start=jnp.full((n,), -1, jnp.int32),
            steps=jnp.zeros((), jnp.int32),
            force=jnp.zeros((n, 3)),
        )

    def push_force(self, pushes: PushSchedule, step: jax.Array) -> jax.Array:
        """`perturbations.push_force`: the force during 0-based control step `step`, N."""
        active = (pushes.start <= step) & (step < pushes.start + pushes.steps)
        first = jnp.argmax(active)  # the first active push, as the CPU loop returns
        return jnp.where(active.any(), pushes.force[first], jnp.zeros(3, pushes.force.dtype))

    def episode_model(
        self, params: EpisodeParams, invweights: tuple[jax.Array, jax.Array] | None = None
    ) -> mjx.Model:
        """The MJX model with an episode's parameters, as `CPGTask._apply_parameters` sets
        them, followed by the part of `mj_setConst` MJX reads.

        Nominal parameters give the model itself (the same numbers), so one compiled `step`
        serves every tier.

        Args:
          params: The episode's parameters.
          invweights: The model's `(body_invweight0, dof_invweight0)` for these parameters,
            if known; None computes them (`setconst.invweights`).

        Returns:
          The episode's model.
        """
        m = self._with_params(self.model, params)
        if invweights is None:
            invweights = self.invweights(params)
        return m.replace(
            body_invweight0=invweights[0].astype(m.body_invweight0.dtype),
            dof_invweight0=invweights[1].astype(m.dof_invweight0.dtype),
        )

    def invweights(self, params: EpisodeParams) -> tuple[jax.Array, jax.Array]:
        """`(body_invweight0, dof_invweight0)` of the model with an episode's parameters.

        Computed by `setconst.invweights` on the JAX backend's model (on Warp too: the
        arrays are backend-independent).
        """
        m = setconst.invweights(self._with_params(self._jax_model, params))
        return m.body_invweight0, m.dof_invweight0

    def _with_params(self, m: mjx.Model, params: EpisodeParams) -> mjx.Model:
        """`m` with an episode's servo, joint, friction and torso parameters."""
        kp = params.servo_gain
        torso = self._torso
        com_shift = jnp.concatenate([params.torso_com_shift, jnp.zeros(1)])
        return m.replace(
            actuator_gainprm=m.actuator_gainprm.at[:, 0].set(kp),
            actuator_biasprm=m.actuator_biasprm.at[:, 1].set(-kp),
            actuator_forcerange=jnp.stack(
                [jnp.full(m.nu, -params.torque_limit), jnp.full(m.nu, params.torque_limit)],
                axis=-1,
            ),
            dof_damping=m.dof_damping.at[self._hinge_dofs].set(params.joint_damping),
            geom_friction=m.geom_friction.at[self._ground, 0].set(params.friction),
            body_mass=m.body_mass.at[torso].multiply(params.torso_mass_scale),
            body_inertia=m.body_inertia.at[torso].multiply(params.torso_mass_scale),
            body_ipos=m.body_ipos.at[torso].add(com_shift),
        )

    # Reset and step.
    def reset(self, key: jax.Array) -> State:
        """Starts an episode: draws the posture noise, then the tier's perturbation.

        Args:
          key: A JAX random key.

        Returns:
          The episode's first state (reward 0, not done).
        """
        k_noise, k_tier = jax.random.split(key)
        noise = jax.random.uniform(k_noise, (12,), minval=-self.init_noise, maxval=self.init_noise)
        params = self.sample_params(k_tier) if self.randomization else self.nominal_params()
        pushes = self.sample_pushes(k_tier) if self.pushes else self.no_pushes()
        model = self.episode_model(params)
        data = self.standing_pose(model, jnp.asarray(self.posture) + noise)
        row = modulated.initial_state(self.config)
        zero = jnp.zeros(())
        return State(
            data=data,
            obs=self._observation(data, row),
            reward=zero,
            done=zero,
            fell=zero,
            brownout=zero,
            supply=self.initial_supply(),
            step=jnp.zeros((), jnp.int32),
            params=params,
            invweights=(model.body_invweight0, model.dof_invweight0),
            pushes=pushes,
            cpg=row,
        )

    def standing_pose(self, model: mjx.Model, leg_angles: jax.Array) -> mjx.Data:
        """`darwin.pose.set_standing_pose` followed by dm_control's `after_reset`.

        Args:
          model: The episode's model.
          leg_angles: (12,) leg joint angles, rad (also the servo targets).

        Returns:
          The robot at rest, torso upright at the origin, lowest sole corner on the floor,
          after a forward pass with actuation off.
        """
        data = self._warp_data if self.impl == "warp" else mjx.make_data(model)
        q = jnp.asarray(model.qpos0)
        q = q.at[self._leg_qpos].set(leg_angles).at[self._arm_qpos].set(darwin.ARM_POSE)
        r = self._root_qpos
        q = q.at[r : r + 7].set(jnp.array([0.0, 0.0, _START_HEIGHT, 1.0, 0.0, 0.0, 0.0]))
        data = mjx.kinematics(model, data.replace(qpos=q))
        lowest = jnp.min(jnp.stack([self._lowest_corner(model, data, g) for g in self._feet]))
        ctrl = jnp.zeros(model.nu).at[self._leg_act].set(leg_angles)
        ctrl = ctrl.at[self._arm_act].set(darwin.ARM_POSE)
        data = data.replace(qpos=q.at[r + 2].add(-lowest), ctrl=ctrl)
        flags = model.opt.disableflags | mujoco.mjtDisableBit.mjDSBL_ACTUATION
        return physics.forward(model.replace(opt=model.opt.replace(disableflags=flags)), data)

    @staticmethod
    def _lowest_corner(model: mjx.Model, data: mjx.Data, geom: int) -> jax.Array:
        """Height of a box geom's lowest corner, m (`darwin.pose.lowest_corner`)."""
        signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        local = signs * model.geom_size[geom]
        rot = data.geom_xmat[geom]
        return jnp.min(data.geom_xpos[geom, 2] + local @ rot[2])

    def step(self, state: State, action: jax.Array) -> State:
        """One control step: 8 physics steps with the action's leg targets held.

        Args:
          state: The current state (not done).
          action: (12,) action of the env's action space, in [−1, 1] (clipped).

        Returns:
          The next state; `done` is set by a fall, a non-finite state or the time limit.
        """
        row = state.cpg
        if self.action_space == "cpg":
            row, targets = modulated.step(
                row, action, self.nominal_amplitudes, darwin.CONTROL_TIMESTEP, self.config
            )
            action = self.targets_to_action(targets)  # as `vector.CPGActions` does
        model = self.episode_model(state.params, state.invweights)
        data = state.data
        ctrl = data.ctrl.at[self._leg_act].set(self.action_to_targets(action))
        xfrc = data.xfrc_applied.at[self._torso, :3].set(self.push_force(state.pushes, state.step))
        data = data.replace(ctrl=ctrl, xfrc_applied=xfrc)
        x_before = data.qpos[self._root_qpos]

        def physics_step(carry, j):
            d, supply = carry
            d = physics.step(model, d)
            return (d, self._add_supply(model, d, supply, state.step * self.n_substeps + j)), None

        supply = (*state.supply, jnp.zeros(()))  # total, ring, crossed in this step
        (data, supply), _ = jax.lax.scan(physics_step, (data, supply), jnp.arange(self.n_substeps))
        root = data.qpos[self._root_qpos : self._root_qpos + 7]
        invalid = ~(jnp.all(jnp.isfinite(data.qpos)) & jnp.all(jnp.isfinite(data.qvel)))
        fell = darwin.has_fallen(root, jnp) | invalid
        brownout = (supply[2] > 0) & ~fell if self.supply is not None else jnp.zeros((), bool)
        step = state.step + 1
        done = fell | brownout | (step >= EPISODE_STEPS)
        return state._replace(
            data=data,
            obs=self._observation(data, row),
            reward=root[0] - x_before,
            done=done.astype(root.dtype),
            fell=(fell | brownout).astype(root.dtype),
            brownout=brownout.astype(root.dtype),
            supply=supply[:2],
            step=step,
            cpg=row,
        )

    def initial_supply(self) -> tuple[jax.Array, jax.Array]:
        """The supply's running total at t = 0 and its ring: the idle robot before the start."""
        w = self._window or 1
        ring = jnp.asarray(np.arange(1 - w, 1, dtype=np.float64) * electrical.IDLE_CURRENT)
        return jnp.zeros(()), ring

    def _add_supply(self, model, d, supply, k):
        """One physics step's supply current into the running total (`SupplyMonitor`).

        Returns:
          `(total, ring, crossed)`: crossed is 1 once a window mean has exceeded the limit
          during this control step.
        """
        total, ring, crossed = supply
        dofs = self._servo_dofs
        current = electrical.supply_current(
            d.actuator_force, d.qvel[dofs], model.dof_damping[dofs], xp=jnp
        )
        total = total + current
        if self._window is None:
            mean = total / (k + 1)
        else:
            position = k % self._window
            mean = (total - ring[position]) / self._window
            ring = ring.at[position].set(total)
        crossed = jnp.maximum(crossed, (mean > self._limit).astype(total.dtype))
        return total, ring, crossed

    def observation_dict(self, data: mjx.Data) -> dict[str, jax.Array]:
        """`CPGTask.get_observation` of a state reached by `reset` or `step`.

        Args:
          data: The MJX state after `reset` or `step`.

        Returns:
          The readings by name (`OBSERVATION_KEYS`).
        """
        r, v = self._root_qpos, self._root_dof
        quat = data.qpos[r + 3 : r + 7]
        return {
            "joint_angles": data.qpos[self._leg_qpos],
            "joint_velocities": data.qvel[self._leg_dof],
            "torso_orientation": quat / jnp.linalg.norm(quat),  # framequat of the torso
            "torso_height": data.qpos[r + 2 : r + 3],  # the torso origin is the root's
            "torso_velocity": data.qvel[v : v + 3],
            "gyro": data.qvel[v + 3 : v + 6],  # root angular velocity, in the torso frame
            "accelerometer": data.sensordata[self._accelerometer],
            "foot_touch": data.sensordata[self._touch],
        }

    def _observation(self, data: mjx.Data, row: modulated.CPGState) -> jax.Array:
        readings = self.observation_dict(data)
        parts = [readings[k] for k in OBSERVATION_KEYS]
        if self.action_space == "cpg":
            parts.append(modulated.phase_features(row, self.config))
        return jnp.concatenate(parts)

    def state_from_mujoco(self, data: mujoco.MjData, step: int = 0) -> State:
        """An MJX state holding a CPU state (nominal parameters, no pushes, CPG at t = 0).

        For comparisons with the CPU task: `data` after `env.reset()` or `env.step()` of
        `cpg_suite.load("darwin_walk")` (its `physics.data`) gives the MJX state those reach.

        Args:
          data: A MuJoCo state of this model after `mj_forward` or a dm_control step.
          step: Control steps the episode has taken.

        Returns:
          The state, with `obs` computed from it.
        """
        if self.impl == "warp":  # Warp's `put_data` runs `mj_kinematics` on what it is given
            own = mujoco.MjData(self.mj_model)
            mujoco.mj_copyData(own, self.mj_model, getattr(data, "ptr", data))  # dm_control's
            mjx_data = mjx.put_data(
                self.mj_model, own, impl="warp", naconmax=self.warp_naconmax, njmax=self.warp_njmax
            )
        else:
            mjx_data = mjx.put_data(self.mj_model, data)
        # `put_data` gives some integer fields another width than `mjx.step` returns.
        if self._data_shapes is None:
            self._data_shapes = jax.eval_shape(physics.step, self.model, mjx_data)
        mjx_data = jax.tree.map(lambda x, s: jnp.asarray(x, s.dtype), mjx_data, self._data_shapes)
        row = modulated.initial_state(self.config)
        zero = jnp.zeros(())
        return State(
            data=mjx_data,
            obs=self._observation(mjx_data, row),
            reward=zero,
            done=zero,
            fell=zero,
            brownout=zero,
            supply=self.initial_supply(),
            step=jnp.asarray(step, jnp.int32),
            params=self.nominal_params(),
            invweights=(self.model.body_invweight0, self.model.dof_invweight0),
            pushes=self.no_pushes(),
            cpg=row,
        )


def sole_contacts_only(m: mujoco.MjModel) -> None:
    """Turns off the collisions of every geom but the floor and the soles, in place.

    What remains are the pairs floor-left sole, floor-right sole and left sole-right sole
    (`darwin.GROUND_GEOMS`): 12 of the model's 114 contact slots.

    Args:
      m: A DARwIn-OP model (`darwin.get_model_and_assets`).
    """
    kept = [m.geom(n).id for n in darwin.GROUND_GEOMS]
    others = np.setdiff1d(np.arange(m.ngeom), kept)
    m.geom_contype[others] = 0
    m.geom_conaffinity[others] = 0


def rollout(env: WalkEnv, state: State, actions: jax.Array) -> dict[str, jax.Array]:
    """Steps one episode through a sequence of actions (`jit` it with `env` static).

    The steps after the episode ends are taken too; `trial_result` cuts them off.

    Args:
      env: The environment.
      state: The start state.
      actions: (T, action_size) actions.

    Returns:
      Per step (T,): `reward`, `fell`, `done`, and the torso's `x` and `y`, m.
    """

    def one(s, a):
        s = env.step(s, a)
        root = s.data.qpos[env._root_qpos : env._root_qpos + 2]
        return s, {"reward": s.reward, "fell": s.fell, "done": s.done, "x": root[0], "y": root[1]}

    _, out = jax.lax.scan(one, state, actions)
    return out


def trial_result(out: dict, start: np.ndarray) -> dict:
    """A `rollout` as `evaluation.gait.evaluate_gait` reports a trial.

    Args:
      out: `rollout`'s output (NumPy or JAX arrays).
      start: (2,) torso x, y at the start, m.

    Returns:
      `distance_m`, `lateral_m`, `fell`, `fall_step` (1-based, or None), `return`.
    """
    fell = np.asarray(out["fell"]) > 0
    last = int(np.argmax(fell)) if fell.any() else len(fell) - 1
    return {
        "distance_m": float(np.asarray(out["x"])[last] - start[0]),
        "lateral_m": float(np.asarray(out["y"])[last] - start[1]),
        "fell": bool(fell.any()),
        "fall_step": last + 1 if fell.any() else None,
        "return": float(np.sum(np.asarray(out["reward"])[: last + 1])),
    }


def physics_settings(
    name: str,
    contacts: str | None = None,
    solver_iterations: tuple[int, int] | None = None,
    timestep: float | None = None,
) -> PhysicsSettings:
    """`PHYSICS[name]` with the given parts replaced (None keeps its own).

    Args:
      name: A key of `PHYSICS`.
      contacts: One of `CONTACTS`, or None.
      solver_iterations: Two integers ≥ 1, or None.
      timestep: A physics step that divides the 16 ms control step, s, or None.

    Returns:
      The settings `WalkEnv` builds with.

    Raises:
      ValueError: On an unknown name or contacts, bad solver caps or timestep.
    """
    if name not in PHYSICS:
        raise ValueError(f"physics must be one of {tuple(PHYSICS)}, got {name!r}")
    settings = PHYSICS[name]
    if contacts is not None:
        if contacts not in CONTACTS:
            raise ValueError(f"contacts must be one of {CONTACTS}, got {contacts!r}")
        settings = settings._replace(contacts=contacts)
    if solver_iterations is not None:
        settings = settings._replace(solver_iterations=_solver_caps(solver_iterations))
    if timestep is not None:
        steps = darwin.CONTROL_TIMESTEP / timestep if timestep > 0 else 0.0
        if not (steps >= 1 and abs(steps - round(steps)) < 1e-9):
            control = darwin.CONTROL_TIMESTEP
            raise ValueError(f"timestep must divide the {control} s control step, got {timestep!r}")
        settings = settings._replace(timestep=float(timestep))
    return settings


def _solver_caps(value) -> tuple[int, int]:
    """`(iterations, line-search iterations)` as two integers ≥ 1, or ValueError."""
    message = f"solver_iterations must be two integers ≥ 1, got {value!r}"
    try:
        caps = tuple(value)
    except TypeError:
        raise ValueError(message) from None
    if len(caps) != 2 or not all(
        isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= 1 for v in caps
    ):
        raise ValueError(message)
    return int(caps[0]), int(caps[1])
