"""Crawler domain: a 2-DOF arm that learns to pull a wheeled chassis forward (thesis Sec. 4.1).

After Tokic et al. (2009): passive wheels at the back, an arm at the front with joints
g_y (shoulder) and g_x (elbow); the arm's rubber tip pushes on the ground, lifts the front
of the body and drags it forward. The study built its own Webots model and gives no
dimensions; ours (`xml/crawler.xml`, planar: the chassis slides in x and z and pitches):

* chassis 0.16 × 0.10 × 0.04 m, 0.4 kg; two passive rear wheels (radius 0.03 m) and a
  low-friction skid under the front (friction 0.1); total 0.57 kg;
* upper arm 0.09 m from the chassis' front edge, forearm 0.08 m, rubber tip (friction 2.0);
* position servos (kp 20 N·m/rad, 2 N·m) with a 0.15 s first-order filter on the target,
  so that each move is smooth and has settled within the 0.6 s a move lasts.

The 5 × 5 grid (thesis Fig. 4.1b): row r sets g_y to `GY_ANGLES[r]`, column c sets g_x to
`GX_ANGLES[c]` (rad; positive turns a link downward). Rows 0-2 keep the tip at least
3 cm off the ground; rows 3 and 4 press it up to 3 and 6 cm below the level it would have
with the chassis level, so the tip pushes the ground and lifts the front of the body (the
study's "states' referential beneath the robot's one"); the elbow folding (moving right)
while the tip grips drags the body forward. The grid was chosen by measuring every move:
value iteration (γ = 0.9) on the measured rewards then finds the 6-state cycle
(3,2) → (3,3) → (3,4) → (2,4) → (2,3) → (2,2), +4.4 cm per cycle; with the tip on the ground
in row 2 it found only a one-joint jitter between rows 3 and 4 (+0.1 cm per cycle).

Task `walk` (one control step = one move of 0.6 s, physics step 2 ms):
  * action `DiscreteArray(4)`: 0 up (r − 1), 1 right (c + 1), 2 down (r + 1), 3 left (c − 1);
    each moves one joint to the neighbouring grid angle. A move off the grid leaves the
    arm where it is, earns reward 0 and sets the `blocked` observation;
  * reward: forward (x) displacement of the chassis during the move, m;
  * `stochastic=p`: with probability p the joint does not move (thesis Sec. 4.1.5);
  * episodes start at cell (0, 0) after the body has settled, and end at the time limit
    (200 moves by default); there is no failure state.
"""

from __future__ import annotations

import collections

import numpy as np
from dm_control.rl import control
from dm_control.utils import containers
from dm_env import specs

from cpg_suite import base
from cpg_suite._headless import mujoco

GRID = 5
GY_ANGLES = np.array([-1.2, -0.8, -0.5, 0.1, 0.4])  # rad, rows 0..4 (arm up .. down)
GX_ANGLES = np.linspace(-0.3, 1.5, GRID)  # rad, columns 0..4 (elbow open .. folded)
ACTIONS = ("up", "right", "down", "left")
MOVES = ((-1, 0), (0, 1), (1, 0), (0, -1))  # (dr, dc) per action

_MOVE_TIME = 0.6  # s: one move = one control step (300 physics steps of 2 ms).
_SETTLE_TIME = 0.5  # s: the body settles on its wheels before an episode starts.
_DEFAULT_MOVES = 200  # moves per episode.
_INIT_NOISE = 0.01  # rad: U(−x, x) on each arm joint at the start.
_VIZ_STEP = 0.02  # m per move shown as full reward colour.

SUITE = containers.TaggedTasks()


def get_model_and_assets() -> tuple[str, dict[str, bytes]]:
    """Returns the crawler model's XML string and its assets."""
    return base.model_and_assets("crawler.xml")


def cell_index(row: int, col: int) -> int:
    """State index of a grid cell (row-major, as the tabular models)."""
    return row * GRID + col


def cell_angles(row: int, col: int) -> np.ndarray:
    """The (g_y, g_x) joint angles, rad, of a grid cell."""
    return np.array([GY_ANGLES[row], GX_ANGLES[col]])


def move(row: int, col: int, action: int) -> tuple[int, int, bool]:
    """The cell an action leads to, and whether it was blocked by the grid's edge."""
    dr, dc = MOVES[action]
    r2, c2 = row + dr, col + dc
    if 0 <= r2 < GRID and 0 <= c2 < GRID:
        return r2, c2, False
    return row, col, True


@SUITE.add("benchmarking")
def walk(
    time_limit: float = _DEFAULT_MOVES * _MOVE_TIME,
    random=None,
    stochastic: float = 0.0,
    backward_penalty: float = 1.0,
    environment_kwargs: dict | None = None,
) -> control.Environment:
    """Returns the crawler task: reward = forward chassis displacement per move (m).

    Args:
      time_limit: Episode length in seconds (one move per 0.6 s; default 200 moves).
      random: Seed or `np.random.RandomState` for the initial state and slips.
      stochastic: Probability p in [0, 1) that a move does not happen.
      backward_penalty: Factor k ≥ 1 on a backward move's (negative) displacement in the
        reward: the study's "moving backwards punished heavily" (claim CR-10; 1: none).
      environment_kwargs: Passed to `control.Environment`.

    Returns:
      A `control.Environment`.
    """
    physics = Physics.from_xml_string(*get_model_and_assets())
    task = Walk(stochastic=stochastic, backward_penalty=backward_penalty, random=random)
    return base.make_environment(physics, task, time_limit, _MOVE_TIME, environment_kwargs)


class Physics(mujoco.Physics):
    """Crawler physics with named accessors (addresses looked up by name at load)."""

    def _reload_from_data(self, data) -> None:
        super()._reload_from_data(data)
        model = self.model
        self._x = int(model.jnt_qposadr[model.name2id("root_x", "joint")])
        self._z = int(model.jnt_qposadr[model.name2id("root_z", "joint")])
        self._pitch = int(model.jnt_qposadr[model.name2id("root_pitch", "joint")])
        self._vx = int(model.jnt_dofadr[model.name2id("root_x", "joint")])
        self._vz = int(model.jnt_dofadr[model.name2id("root_z", "joint")])
        self._arm = np.array([model.jnt_qposadr[model.name2id(n, "joint")] for n in ("g_y", "g_x")])
        self._act = np.array([model.name2id(n, "actuator") for n in ("g_y", "g_x")])
        self._tip = model.name2id("tip", "site")
        touch = model.name2id("tip_touch", "sensor")
        self._touch = int(model.sensor_adr[touch])

    def chassis_x(self) -> float:
        """Forward position of the chassis, m."""
        return float(self.data.qpos[self._x])

    def chassis_pitch(self) -> float:
        """Pitch of the chassis, rad (positive: nose down)."""
        return float(self.data.qpos[self._pitch])

    def chassis_velocity(self) -> np.ndarray:
        """(x, z) velocity of the chassis, m/s."""
        return np.array([self.data.qvel[self._vx], self.data.qvel[self._vz]])

    def arm_angles(self) -> np.ndarray:
        """(g_y, g_x) joint angles, rad."""
        return self.data.qpos[self._arm]

    def set_arm_angles(self, angles) -> None:
        """Sets the (g_y, g_x) joint angles, rad (positions only; call before a step)."""
        self.data.qpos[self._arm] = angles

    def set_arm_targets(self, angles) -> None:
        """Sets the (g_y, g_x) servo targets, rad."""
        self.data.ctrl[self._act] = angles

    def tip_position(self) -> np.ndarray:
        """World position of the arm tip, m."""
        return self.data.site_xpos[self._tip].copy()

    def tip_force(self) -> float:
        """Normal force on the tip, N."""
        return float(self.data.sensordata[self._touch])


class Walk(base.Task):
    """Move the arm around the 5 × 5 grid so that the chassis advances (thesis Sec. 4.1)."""

    def __init__(self, stochastic: float = 0.0, backward_penalty: float = 1.0, random=None):
        """Args:
          stochastic: Probability that a move does not happen, in [0, 1).
          backward_penalty: Factor k ≥ 1 on a backward move's displacement in the reward.
          random: Seed or `np.random.RandomState`.

        Raises:
          ValueError: If `stochastic` is outside [0, 1) or `backward_penalty` below 1.
        """
        if not 0.0 <= stochastic < 1.0:
            raise ValueError(f"stochastic must lie in [0, 1), got {stochastic!r}")
        if not (np.isfinite(backward_penalty) and backward_penalty >= 1.0):
            raise ValueError(f"backward_penalty must be a number ≥ 1, got {backward_penalty!r}")
        self.stochastic = float(stochastic)
        self.backward_penalty = float(backward_penalty)
        self._action_spec = specs.DiscreteArray(len(ACTIONS), dtype=np.int64, name="move")
        self.cell = (0, 0)
        self.blocked = False
        self.slipped = False
        self._x_before = 0.0
        super().__init__(random=random)

    def initialize_episode(self, physics: Physics) -> None:
        self.cell = (0, 0)
        self.blocked = self.slipped = False
        angles = cell_angles(*self.cell)
        angles += self.random.uniform(-_INIT_NOISE, _INIT_NOISE, size=2)
        physics.set_arm_angles(angles)
        physics.data.act[:] = angles  # The servo filters start at the pose.
        physics.set_arm_targets(cell_angles(*self.cell))
        physics.step(int(round(_SETTLE_TIME / physics.model.opt.timestep)))
        physics.data.time = 0.0
        self._x_before = physics.chassis_x()
        super().initialize_episode(physics)

    def before_step(self, action, physics: Physics) -> None:
        a = base.check_discrete_action(action, self._action_spec)
        r, c, self.blocked = move(*self.cell, a)
        self.slipped = (
            not self.blocked and self.stochastic > 0.0 and self.random.uniform() < self.stochastic
        )
        if not self.blocked and not self.slipped:
            self.cell = (r, c)
        physics.set_arm_targets(cell_angles(*self.cell))
        self._x_before = physics.chassis_x()

    def get_observation(self, physics: Physics) -> collections.OrderedDict:
        """Grid cell (row, column), arm joint angles, chassis velocity, blocked flag."""
        obs = collections.OrderedDict()
        obs["grid_cell"] = np.array(self.cell, dtype=np.float64)
        obs["joint_angles"] = physics.arm_angles()
        obs["chassis_velocity"] = physics.chassis_velocity()
        obs["blocked"] = np.array([float(self.blocked)])
        return obs

    def move_displacement(self, physics: Physics) -> float:
        """Chassis x displacement during the last move, m; exactly 0 for a blocked move."""
        if self.blocked:
            return 0.0
        return physics.chassis_x() - self._x_before

    def get_reward(self, physics: Physics) -> float:
        """The move's displacement, m, a backward one times `backward_penalty`."""
        d = self.move_displacement(physics)
        return d if d >= 0.0 else self.backward_penalty * d

    def reward_to_unit(self, reward: float) -> float:
        return 0.5 + 0.5 * reward / _VIZ_STEP
