"""Perturbations of the DARwIn-OP walking task: the benchmark's test tiers.

Each tier is the nominal `darwin_walk` with one kind of condition a gait never saw while it
was tuned on the nominal model (docs/protocol.md gives every range and its reason):

* `Randomization` — the physical parameters of the episode, drawn per episode: servo gain,
  torque limit, joint damping, ground friction, torso mass and centre of mass, and a larger
  perturbation of the initial posture.
* `Pushes` — horizontal pushes on the torso at random moments and in random directions.
* `Contact` — the floor contact: the friction of floor and soles and the contact's time
  constant (its softness), drawn per episode over ranges real floors and soles span.
* `Terrain` — uneven ground: square tiles raised by random heights above the floor plane.
  With `max_height = 0` the tiles lie below the plane and never touch the robot, so the
  zero-height control is the plane itself, bit for bit (tested).

Every draw comes from the task's `random` (a `np.random.RandomState`), once per episode.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from cpg_suite import portable

# Nominal values these perturbations scale or replace, and where they come from: the MX-28
# servo (stall torque 2.5 N·m at 12 V, no-load speed 5.76 rad/s) and the calibrated model
# (kp 40 N·m/rad), see docs/darwin_op_model.md.
NOMINAL_SERVO_GAIN = 40.0  # N·m/rad
NOMINAL_TORQUE_LIMIT = 2.5  # N·m
NOMINAL_JOINT_DAMPING = 0.43  # N·m·s/rad
NOMINAL_FRICTION = 1.0


@dataclasses.dataclass(frozen=True)
class Randomization:
    """Uniform ranges of the randomized tier, drawn once per episode.

    Attributes:
      servo_gain: Position gain kp of every servo, N·m/rad (nominal 40, ±~12 %). A softer
        servo lets the torso sag backward: with 32-37 N·m/rad the hand-tuned gait fell in
        combination with a heavier torso and a backward centre of mass.
      torque_limit: Torque limit of every servo, N·m: the MX-28's stall torque scales with
        the supply voltage, from about 2.2 N·m (3-cell battery at 10.5 V) to 2.6 N·m (full,
        12.6 V); nominal 2.5 N·m at 12 V.
      joint_damping: Damping of every joint, N·m·s/rad (nominal 0.43 = stall torque /
        no-load speed; ±15 % for the motor constant's spread and temperature).
      friction: Sliding friction of the ground and the soles (nominal 1.0; from a smooth
        floor to a rubber mat).
      torso_mass_scale: Factor on the torso's mass and inertia (±5 %: battery, payload).
      torso_com_shift: Half-width of the uniform shift of the torso's centre of mass in x
        and y, m (±4 mm: where the battery and cables sit).
      init_noise: Half-width of the uniform perturbation of each leg joint at reset, rad
        (nominal 0.01).

    Calibrated (`docs/protocol.md`): with these ranges the hand-tuned gait falls in 0 of
    200 episodes (seeds 1000-1199); each range alone at its wider first choice (gain 32-50,
    ±20 % damping, torque 2.1-2.6, friction 0.7-1.2, mass ±10 %, CoM ±10 mm, noise 0.03)
    was survived, but their combination toppled it in 7 of 50.
    """

    servo_gain: tuple[float, float] = (38.0, 48.0)
    torque_limit: tuple[float, float] = (2.2, 2.6)
    joint_damping: tuple[float, float] = (0.37, 0.50)
    friction: tuple[float, float] = (0.8, 1.2)
    torso_mass_scale: tuple[float, float] = (0.95, 1.05)
    torso_com_shift: float = 0.004
    init_noise: float = 0.02

    def sample(self, random: np.random.RandomState) -> dict:
        """One episode's parameters, in a fixed order of draws."""
        return {
            "servo_gain": random.uniform(*self.servo_gain),
            "torque_limit": random.uniform(*self.torque_limit),
            "joint_damping": random.uniform(*self.joint_damping),
            "friction": random.uniform(*self.friction),
            "torso_mass_scale": random.uniform(*self.torso_mass_scale),
            "torso_com_shift": random.uniform(-self.torso_com_shift, self.torso_com_shift, 2),
        }


@dataclasses.dataclass(frozen=True)
class Contact:
    """Ranges of the contact tier (`darwin_walk_contact`, benchmark version 3), drawn once
    per episode; docs/contact.md#the-contact-tier gives the sources.

    Attributes:
      friction: Sliding friction of the floor and the soles, uniform: 0.4-1.0 is MuJoCo
        Playground's sim-to-real range for the ROBOTIS OP3 (DARwIn-OP's successor); measured
        indoor floors' means lie at 0.80-0.97 (s.d. to 0.15), grass at 0.53. The model's
        nominal is 1.0.
      time_constant: The floor contact's time constant (MuJoCo `solref[0]` of floor and
        soles, so of their contact), s, log-uniform: from 4 ms (MuJoCo Menagerie's OP3) to
        20 ms (MuJoCo's default); the model's nominal contact mixes the soles' 8 ms with
        the floor's 20 ms into 14 ms. Stiffer than 4 ms is not possible at the 2 ms step:
        MuJoCo's `refsafe` (on by default) raises a time constant to twice the timestep.
    """

    friction: tuple[float, float] = (0.4, 1.0)
    time_constant: tuple[float, float] = (0.004, 0.020)

    def __post_init__(self):
        low, high = self.time_constant
        if not 0.0 < low <= high or not 0.0 < self.friction[0] <= self.friction[1]:
            raise ValueError(
                f"contact ranges must be positive and ordered, got friction {self.friction}, "
                f"time_constant {self.time_constant}"
            )

    def sample(self, random: np.random.RandomState) -> dict:
        """One episode's contact: `friction` and `time_constant` (s), in that order of draws.

        The time constant is `low · exp(u · ln(high/low))`, u ~ U(0, 1), with `portable.exp`
        and the logarithm rounded to 12 significant digits (libm's last bit may depend on
        the CPU; the draw may not).
        """
        friction = random.uniform(*self.friction)
        low, high = self.time_constant
        log_ratio = float(f"{math.log(high / low):.12g}")
        time_constant = low * float(portable.exp(random.uniform(0.0, 1.0) * log_ratio))
        return {"friction": friction, "time_constant": time_constant}


@dataclasses.dataclass(frozen=True)
class Pushes:
    """Horizontal pushes on the torso: one near each of `times`, in a random direction.

    Attributes:
      times: Nominal start of each push, s.
      jitter: A push starts U(0, jitter) s after its nominal time.
      impulse: Range of the impulse of a push, N·s (force × duration).
      steps: Duration of a push in control steps (6 × 16 ms = 96 ms).
    """

    times: tuple[float, ...] = (3.0, 6.0, 9.0, 12.0)
    jitter: float = 1.0
    impulse: tuple[float, float] = (0.1, 0.25)
    steps: int = 6

    def sample(self, random: np.random.RandomState, control_timestep: float) -> list[tuple]:
        """The episode's pushes: `(first control step, number of steps, force (3,) N)`."""
        pushes = []
        for t in self.times:
            start = int(round((t + random.uniform(0.0, self.jitter)) / control_timestep))
            angle = random.uniform(-np.pi, np.pi)
            force = random.uniform(*self.impulse) / (self.steps * control_timestep)
            sin_a, cos_a = portable.sincos(angle)
            pushes.append((start, self.steps, force * np.array([cos_a, sin_a, 0.0])))
        return pushes


def push_force(pushes: list[tuple], step: int) -> np.ndarray:
    """The force on the torso during control step `step` (0-based), N (world frame)."""
    for start, steps, force in pushes:
        if start <= step < start + steps:
            return force
    return np.zeros(3)


def push_forces(pushes: list[tuple], n_steps: int) -> np.ndarray:
    """(n_steps, 3) force on the torso during each control step, N (world frame)."""
    forces = np.zeros((n_steps, 3))
    for start, steps, force in pushes:
        forces[start : start + steps] = force
    return forces


@dataclasses.dataclass(frozen=True)
class Terrain:
    """Uneven ground: a grid of square tiles, each raised U(0, max_height) above the plane.

    Attributes:
      tile: Side of a tile, m (about two foot lengths).
      max_height: Largest height of a tile's top above the floor plane, m: 3 mm, about a
        third of the hand-tuned gait's foot lift (~8 mm). Open-loop gaits tuned on the plane
        are sensitive to it: CMA-ES's best seed-0 gait fell in 2/20 episodes at 2 mm, 6/20
        at 4 mm and 16/20 at 6 mm.
      x_range: Extent of the tiled area along the walking direction, m.
      y_range: Extent across it, m.
      start_pad: Tiles whose centre lies within this distance of the origin stay flat
        (height 0), so the robot starts standing on level ground, m.
    """

    tile: float = 0.2
    max_height: float = 0.003
    x_range: tuple[float, float] = (-1.0, 9.0)
    y_range: tuple[float, float] = (-2.6, 2.6)
    start_pad: float = 0.25

    def centres(self) -> np.ndarray:
        """(n, 2) centres of the tiles, m."""
        xs = np.arange(self.x_range[0] + self.tile / 2, self.x_range[1], self.tile)
        ys = np.arange(self.y_range[0] + self.tile / 2, self.y_range[1], self.tile)
        return np.array([(x, y) for x in xs for y in ys])

    def sample(self, random: np.random.RandomState) -> np.ndarray:
        """The heights of the tiles' tops above the plane, m (one draw per tile)."""
        centres = self.centres()
        heights = random.uniform(0.0, self.max_height, len(centres))
        heights[portable.hypot(centres[:, 0], centres[:, 1]) < self.start_pad] = 0.0
        return heights


TILE_DEPTH = 0.02  # m: half-height of a tile box.
HIDDEN_TOP = -0.05  # m: top of a tile of zero height, well below the plane: it never touches.


def tile_xml(terrain: Terrain) -> str:
    """MJCF geoms of the tiles, compiled at the highest height a tile can take.

    MuJoCo's collision midphase keeps the bounding boxes of the world body's geoms from
    compile time; a tile moved at run time stays detectable only while it lies inside its
    compiled box. So each tile is compiled with its top at `max_height` and the task lowers
    it (never raises it above) each episode.
    """
    half = terrain.tile / 2
    z = tile_heights_to_z(np.array([terrain.max_height]))[0]
    lines = []
    for i, (x, y) in enumerate(terrain.centres()):
        lines.append(
            f'<geom name="tile{i}" type="box" size="{half} {half} {TILE_DEPTH}" '
            f'pos="{x:.4f} {y:.4f} {float(z)!r}" material="tile" contype="1" '
            'conaffinity="1" condim="3" friction="1.0 0.005 0.0001" group="0"/>'
        )
    return "\n    ".join(lines)


def tile_heights_to_z(heights: np.ndarray) -> np.ndarray:
    """Centre z of each tile box for tops at `heights` (0 → hidden below the plane)."""
    tops = np.where(heights > 0.0, heights, HIDDEN_TOP)
    return tops - TILE_DEPTH
