"""Pole domain: balance a pole hinged on a cart that runs on an infinite track.

Thesis Sec. 4.2 (after Barto, Sutton & Anderson 1983). The study ran this in Webots and gives
no physical parameters; ours (`xml/pole.xml`) are:

  * cart 0.2 kg on a frictionless slider with no limits (the "infinite track"; the cart's
    position is ignored by the task, as in the study);
  * pole 0.5 m long, 0.05 kg, hinged on top of the cart, angle 0 = upright, positive when the
    pole leans toward +x (to the right); a positive force pushes the cart to +x;
  * physics step 5 ms (RK4, no contacts), control step 20 ms (the force is held 4 substeps).

With these, a bang-bang force of 0.5 N accelerates cart and pole at about 2 m/s^2, so a
static estimate, atan(a/g), says it can hold the pole only within about ±11° of upright;
4 N (16 m/s^2) holds it from about ±58° but over-corrects (the contrast of the study's
Fig. 4.9). `tests/test_pole.py` checks that a simple bang-bang rule balances the pole with
either force for 60 s, and that 0.5 N cannot catch a 0.5 rad tilt.

Tasks (reward per control step, units rad^2):
  * `balance`: actions {−F, 0, +F} (`DiscreteArray(3)`; index 0, 1, 2), F = 0.5 N by
    default; reward −θ²; |θ| > π/2 terminates the episode with discount 0 (a fall).
  * `balance_continuous`: a force in [−1, 1] × F; same reward and termination.
"""

from __future__ import annotations

import collections

import numpy as np
from dm_control.rl import control
from dm_control.utils import containers
from dm_env import specs

from cpg_suite import base
from cpg_suite._headless import mujoco

_DEFAULT_TIME_LIMIT = 20.0  # s: 1000 control steps.
_CONTROL_TIMESTEP = 0.02  # s: 4 physics steps of 5 ms.
_DEFAULT_FORCE = 0.5  # N: the study's lower force (Fig. 4.9).
_FALL_ANGLE = np.pi / 2  # rad: leaving [−π/2, π/2] is a fall (thesis Sec. 4.2.1).
_INIT_ANGLE_RANGE = 0.02  # rad: initial angle ~ U(−0.02, 0.02); the study starts at 0.
_APPROACH_BONUS = 0.05  # rad^2: bonus/penalty of the "approach/away" reward variant.
_REWARDS = ("angle", "approach")

SUITE = containers.TaggedTasks()


def get_model_and_assets() -> tuple[str, dict[str, bytes]]:
    """Returns the pole model's XML string and its assets."""
    return base.model_and_assets("pole.xml")


@SUITE.add("benchmarking")
def balance(
    time_limit: float = _DEFAULT_TIME_LIMIT,
    random=None,
    force: float = _DEFAULT_FORCE,
    num_actions: int = 3,
    reward: str = "angle",
    environment_kwargs: dict | None = None,
) -> control.Environment:
    """Returns the discrete pole balance task (thesis Sec. 4.2).

    Args:
      time_limit: Episode length in seconds (50 control steps per second); `float('inf')`
        runs until the pole falls, as in the study's continuing experiments.
      random: Seed or `np.random.RandomState` for the initial state.
      force: Magnitude F of the pushes, in N.
      num_actions: 3 for {−F, 0, +F} or 2 for {−F, +F} (the study's two variants).
      reward: `"angle"` for −θ², or `"approach"` for −θ² ± a bonus when the pole moves
        toward / away from upright (the study's variant; its exact form is not given).
      environment_kwargs: Passed to `control.Environment`.

    Returns:
      A `control.Environment`.
    """
    physics = Physics.from_xml_string(*get_model_and_assets())
    task = Balance(
        discrete=True, force=force, num_actions=num_actions, reward=reward, random=random
    )
    return _environment(physics, task, time_limit, environment_kwargs)


@SUITE.add("benchmarking")
def balance_continuous(
    time_limit: float = _DEFAULT_TIME_LIMIT,
    random=None,
    force: float = _DEFAULT_FORCE,
    reward: str = "angle",
    environment_kwargs: dict | None = None,
) -> control.Environment:
    """Returns the continuous pole balance task: action in [−1, 1] scales the force `force`.

    Args:
      time_limit: Episode length in seconds.
      random: Seed or `np.random.RandomState` for the initial state.
      force: Maximum force magnitude F_max, in N.
      reward: `"angle"` or `"approach"`, as for `balance`.
      environment_kwargs: Passed to `control.Environment`.

    Returns:
      A `control.Environment`.
    """
    physics = Physics.from_xml_string(*get_model_and_assets())
    task = Balance(discrete=False, force=force, reward=reward, random=random)
    return _environment(physics, task, time_limit, environment_kwargs)


def _environment(physics, task, time_limit, environment_kwargs) -> control.Environment:
    return base.make_environment(physics, task, time_limit, _CONTROL_TIMESTEP, environment_kwargs)


class Physics(mujoco.Physics):
    """Physics with named accessors for the pole domain.

    Joint and actuator addresses are looked up by name once, when the model is loaded:
    the accessors sit on the per-step hot path.
    """

    def _reload_from_data(self, data) -> None:
        super()._reload_from_data(data)
        model = self.model
        hinge = model.name2id("hinge", "joint")
        slider = model.name2id("slider", "joint")
        self._hinge_qpos = int(model.jnt_qposadr[hinge])
        self._hinge_dof = int(model.jnt_dofadr[hinge])
        self._slider_qpos = int(model.jnt_qposadr[slider])
        self._slider_dof = int(model.jnt_dofadr[slider])
        self._push = int(model.name2id("push", "actuator"))

    def pole_angle(self) -> float:
        """Pole angle from upright, rad (positive: leaning toward +x)."""
        return float(self.data.qpos[self._hinge_qpos])

    def set_pole_angle(self, angle: float) -> None:
        """Sets the pole angle, rad."""
        self.data.qpos[self._hinge_qpos] = angle

    def pole_angular_velocity(self) -> float:
        """Pole angular velocity, rad/s."""
        return float(self.data.qvel[self._hinge_dof])

    def cart_position(self) -> float:
        """Cart position along the track, m."""
        return float(self.data.qpos[self._slider_qpos])

    def cart_velocity(self) -> float:
        """Cart velocity along the track, m/s."""
        return float(self.data.qvel[self._slider_dof])

    def set_push(self, force: float) -> None:
        """Sets the force on the cart, N."""
        self.data.ctrl[self._push] = force


class Balance(base.Task):
    """Keep the pole upright; reward −θ² per control step (thesis Sec. 4.2.1)."""

    def __init__(
        self,
        discrete: bool,
        force: float = _DEFAULT_FORCE,
        num_actions: int = 3,
        reward: str = "angle",
        random=None,
    ):
        """Initializes the task.

        Args:
          discrete: Discrete forces {−F, (0,) +F} if True, a continuous force otherwise.
          force: F (discrete) or F_max (continuous), in N; must be positive and finite.
          num_actions: 2 or 3 (discrete only).
          reward: `"angle"` or `"approach"`.
          random: Seed or `np.random.RandomState`.

        Raises:
          ValueError: On an invalid force, number of actions or reward name.
        """
        if not (np.isfinite(force) and force > 0):
            raise ValueError(f"force must be a positive number of newtons, got {force!r}")
        if num_actions not in (2, 3):
            raise ValueError(f"num_actions must be 2 or 3, got {num_actions!r}")
        if reward not in _REWARDS:
            raise ValueError(f"reward must be one of {_REWARDS}, got {reward!r}")
        self._discrete = discrete
        self._force = float(force)
        self._reward = reward
        if discrete:
            self._forces = (
                np.array([-1.0, 0.0, 1.0]) if num_actions == 3 else np.array([-1.0, 1.0])
            ) * self._force
            self._action_spec = specs.DiscreteArray(num_actions, dtype=np.int64, name="push")
        else:
            self._action_spec = specs.BoundedArray((1,), np.float64, -1.0, 1.0, name="push")
        super().__init__(random=random)

    @property
    def forces(self) -> np.ndarray | None:
        """The force of each discrete action, N (None for the continuous task)."""
        return self._forces.copy() if self._discrete else None

    def initialize_episode(self, physics: Physics) -> None:
        """Starts near upright at rest: θ ~ U(−0.02, 0.02) rad, cart at 0."""
        physics.reset()
        angle = self.random.uniform(-_INIT_ANGLE_RANGE, _INIT_ANGLE_RANGE)
        physics.set_pole_angle(angle)
        super().initialize_episode(physics)

    def before_step(self, action, physics: Physics) -> None:
        if self._discrete:
            force = self._forces[base.check_discrete_action(action, self._action_spec)]
        else:
            force = base.check_continuous_action(action, self._action_spec)[0] * self._force
        physics.set_push(force)

    def get_observation(self, physics: Physics) -> collections.OrderedDict:
        """Pole angle (rad), its angular velocity (rad/s), cart velocity (m/s)."""
        obs = collections.OrderedDict()
        obs["angle"] = np.array([physics.pole_angle()])
        obs["angular_velocity"] = np.array([physics.pole_angular_velocity()])
        obs["cart_velocity"] = np.array([physics.cart_velocity()])
        return obs

    def get_reward(self, physics: Physics) -> float:
        """−θ² (rad^2); the approach variant adds ±0.05 when |θ| decreases / grows."""
        angle = physics.pole_angle()
        reward = -angle * angle
        if self._reward == "approach":
            toward = angle * physics.pole_angular_velocity()
            reward += _APPROACH_BONUS * (-np.sign(toward))
        return float(reward)

    def get_termination(self, physics: Physics):
        """Discount 0 once the pole leaves [−π/2, π/2] (a fall)."""
        if abs(physics.pole_angle()) > _FALL_ANGLE:
            return 0.0
        return None

    def reward_to_unit(self, reward: float) -> float:
        return 1.0 + reward / (_FALL_ANGLE**2)
