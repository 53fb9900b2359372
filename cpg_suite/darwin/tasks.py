"""The DARwIn-OP tasks: the suite (`SUITE`), each task's environment and `CPGTask`.

Tasks (control step 16 ms, 1000 steps; action = the 12 leg joint targets, each scaled
from [−1, 1] onto the joint's range, in the order `cpg.LEG_JOINTS`):

* `walk`: reward = forward (x) displacement of the torso during the step, m; the return is
  the distance walked. A fall ends the episode with discount 0.
* `balance`: reward = −(mean over stance feet of the horizontal distance from the foot's
  centre of pressure to its sole centre), m; a stance foot carries more than 5 % of the
  body weight; 0 when no foot does. A fall ends the episode with discount 0.

The model and its decisions are described in the package's docstring (`cpg_suite.darwin`);
the physics this module's tasks act on is `physics.Physics`.
"""

from __future__ import annotations

import collections

import mujoco as mj
import numpy as np
from dm_control.rl import control
from dm_control.utils import containers
from dm_env import specs

from cpg_suite import base, cpg, electrical, perturbations
from cpg_suite.darwin import contacts, perturb, pose, recording, robot
from cpg_suite.darwin.physics import Physics

CONTROL_TIMESTEP = 0.016  # s: Webots DARwIn-OP basicTimeStep (the one definition).
DEFAULT_TIME_LIMIT = 16.0  # s: 1000 control steps ("1000 timesteps" of the study).
INIT_NOISE = 0.01  # rad: U(−x, x) added to each leg joint of the initial posture.
_WALK_VIZ_SPEED = 0.2  # m/s shown as full reward colour.
_BALANCE_VIZ_DISTANCE = 0.05  # m of COP offset shown as zero reward colour.

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


def physics_steps_per_control_step(model: mj.MjModel | None = None) -> int:
    """Physics steps in one control step: `CONTROL_TIMESTEP` over the model's timestep.

    Args:
      model: The compiled DARwIn-OP model (None: compiles `robot.get_model_and_assets()`).

    Returns:
      The number of physics steps (8 for the shipped MJCF's 2 ms).
    """
    if model is None:
        xml, assets = robot.get_model_and_assets()
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
    servo = (servo_gain, torque_limit)
    return _environment(
        "walk", time_limit, random, posture, init_noise, supply, environment_kwargs, servo
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
    servo = (servo_gain, torque_limit)
    return _environment(
        "balance", time_limit, random, posture, init_noise, supply, environment_kwargs, servo
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
    args = (time_limit, random, posture, randomization.init_noise, supply, environment_kwargs)
    return _environment("walk", *args, randomization=randomization)


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
    return _environment(
        "walk", time_limit, random, posture, INIT_NOISE, supply, environment_kwargs, pushes=pushes
    )


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
    return _environment(
        "walk", time_limit, random, posture, INIT_NOISE, supply, environment_kwargs, terrain=terrain
    )


@SUITE.add()
def walk_contact(
    time_limit: float = DEFAULT_TIME_LIMIT,
    random=None,
    posture: np.ndarray | None = None,
    contact: perturbations.Contact | None = None,
    supply: electrical.SupplyLimit | None = electrical.DEFAULT_SUPPLY,
    environment_kwargs: dict | None = None,
) -> control.Environment:
    """Walking on a floor whose friction and softness are drawn per episode (the contact
    test tier of benchmark version 3).

    Args:
      time_limit, random, posture, supply, environment_kwargs: As for `walk`.
      contact: The ranges (default `perturbations.Contact()`).

    Returns:
      A `control.Environment`.
    """
    contact = contact or perturbations.Contact()
    return _environment(
        "walk", time_limit, random, posture, INIT_NOISE, supply, environment_kwargs, contact=contact
    )


def _environment(
    objective: str,
    time_limit: float,
    random,
    posture: np.ndarray | None,
    init_noise: float,
    supply: electrical.SupplyLimit | None,
    environment_kwargs: dict | None,
    servo: tuple[float | None, float | None] = (None, None),
    **perturbation,
) -> control.Environment:
    """A task's environment: the model compiled once and copied, the servos' gain and
    torque limit where not None, the task with at most one perturbation."""
    xml, assets = robot.get_model_and_assets(perturbation.get("terrain"))
    physics = Physics.from_model(robot.compiled(xml, tuple(sorted(assets.items()))).copy())
    servo_gain, torque_limit = servo
    if servo_gain is not None:
        perturb.set_servo_gain(physics, servo_gain)
    if torque_limit is not None:
        perturb.set_torque_limit(physics, torque_limit)
    task = CPGTask(objective, posture, init_noise, random=random, supply=supply, **perturbation)
    return base.make_environment(physics, task, time_limit, CONTROL_TIMESTEP, environment_kwargs)


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
        contact: perturbations.Contact | None = None,
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
          contact: Draw the floor contact's friction and time constant per episode.
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
        self.objective, self.posture = objective, posture
        self.init_noise = float(init_noise)
        self._action_spec = specs.BoundedArray((12,), np.float64, -1.0, 1.0, name="leg_targets")
        self._action = np.zeros(12)  # the clipped action (`before_step`'s buffer)
        self.randomization, self.pushes, self.terrain = randomization, pushes, terrain
        self.contact = contact
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
        if self.contact is not None:
            self.episode_parameters = self.contact.sample(self.random)
            perturb.set_ground_friction(physics, self.episode_parameters["friction"])
            perturb.set_contact_time_constant(physics, self.episode_parameters["time_constant"])
        if self.terrain is not None:
            perturb.set_tile_heights(physics, self.terrain.sample(self.random))
        if self.pushes is not None:
            self.push_schedule = self.pushes.sample(self.random, CONTROL_TIMESTEP)
            perturb.set_torso_push(physics, np.zeros(3))
        pose.set_standing_pose(physics, self.posture + noise)
        if self.supply is None:
            limit = self.supply_limit or electrical.SupplyLimit()
            enforce = self.supply_limit is not None
            self.supply = electrical.SupplyMonitor(limit, physics.timestep(), enforce)
        self.supply.reset()
        self.failure = None
        self.start_position = physics.torso_position()
        self._x_before = self.start_position[0]
        super().initialize_episode(physics)

    @property
    def changes_model(self) -> bool:
        """Whether an episode changes the model (its parameters, contact or tiles): a
        batched evaluator then keeps a model per episode."""
        return any(p is not None for p in (self.randomization, self.contact, self.terrain))

    def _apply_parameters(self, physics: Physics, params: dict) -> None:
        """Sets an episode's draw (`perturb.apply_parameters`) around the nominal torso."""
        if self._nominal_torso is None:
            self._nominal_torso = perturb.torso_inertial(physics)
        perturb.apply_parameters(physics, params, self._nominal_torso)

    def push_forces(self, n_steps: int) -> np.ndarray:
        """(n_steps, 3) push force on the torso during each control step of the episode, N."""
        return perturbations.push_forces(self.push_schedule, n_steps)

    def before_step(self, action, physics: Physics) -> None:
        action = base.check_continuous_action(action, self._action_spec, self._action)
        physics.set_leg_action(action)  # `set_leg_targets(action_to_targets(action))`
        if self.pushes is not None:
            step = int(round(physics._pointers[1].time / CONTROL_TIMESTEP))  # 0-based
            force = perturbations.push_force(self.push_schedule, step)
            physics._torso_push[...] = force  # `perturb.set_torso_push`, through a view
        self._x_before = physics.forward_position()

    def get_observation(self, physics: Physics) -> collections.OrderedDict:
        """Leg joint angles and velocities, torso orientation, height and velocity, IMU, touch."""
        # The accessors' values (`Physics.observation`: one read for all eight).
        return collections.OrderedDict(zip(OBSERVATION_KEYS, physics.observation()))

    def get_reward(self, physics: Physics) -> float:
        if self.objective == "walk":
            return physics.forward_position() - self._x_before
        return contacts.balance_reward(physics)

    def after_step(self, physics: Physics) -> None:
        """Adds the step's supply currents to the episode's (`electrical.SupplyMonitor`; as
        their sums before the idle draw, `recording.supply_sums`: the same bits)."""
        self.supply.update_sums(recording.supply_sums(physics))
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
