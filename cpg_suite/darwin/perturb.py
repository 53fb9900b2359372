"""Setting a DARwIn-OP physics's (`darwin.Physics`) physical parameters: the test tiers'
perturbations (`cpg_suite.perturbations` draws them) and the tasks' servo settings.

Each setter changes the model (or, for a push, the applied force) of one physics, in place,
until it is set again; `apply_parameters` sets an episode's draw of the randomized tier.
"""

from __future__ import annotations

import mujoco as mj
import numpy as np

from cpg_suite import perturbations
from cpg_suite._headless import mujoco


def set_servo_gain(physics: mujoco.Physics, kp: float) -> None:
    """Sets the position gain of every servo, N·m/rad.

    Args:
      physics: A `darwin.Physics`.
      kp: The gain, N·m/rad.

    Raises:
      ValueError: If kp is not a positive number.
    """
    if not (np.isfinite(kp) and kp > 0):
        raise ValueError(f"servo gain must be a positive number of N·m/rad, got {kp!r}")
    physics.model.actuator_gainprm[:, 0] = kp
    physics.model.actuator_biasprm[:, 1] = -kp


def set_torque_limit(physics: mujoco.Physics, limit: float) -> None:
    """Sets the torque limit of every servo, N·m.

    Args:
      physics: A `darwin.Physics`.
      limit: The limit, N·m.

    Raises:
      ValueError: If the limit is not a positive number.
    """
    if not (np.isfinite(limit) and limit > 0):
        raise ValueError(f"torque limit must be a positive number of N·m, got {limit!r}")
    physics.model.actuator_forcerange[:] = [-limit, limit]


def set_joint_damping(physics: mujoco.Physics, damping: float) -> None:
    """Sets the damping of every hinge joint (arms, head and legs), N·m·s/rad.

    Args:
      physics: A `darwin.Physics`.
      damping: The damping, N·m·s/rad.

    Raises:
      ValueError: If the damping is negative or not finite.
    """
    if not (np.isfinite(damping) and damping >= 0):
        raise ValueError(f"joint damping must be ≥ 0 N·m·s/rad, got {damping!r}")
    model = physics.model
    hinges = model.jnt_type == mj.mjtJoint.mjJNT_HINGE
    model.dof_damping[model.jnt_dofadr[hinges]] = damping


def set_ground_friction(physics: mujoco.Physics, friction: float) -> None:
    """Sets the sliding friction of the floor, the terrain tiles and the soles.

    MuJoCo takes the larger coefficient of two touching geoms, so both sides change.

    Args:
      physics: A `darwin.Physics`.
      friction: The coefficient.

    Raises:
      ValueError: If the friction is not a positive number.
    """
    if not (np.isfinite(friction) and friction > 0):
        raise ValueError(f"friction must be a positive number, got {friction!r}")
    physics.model.geom_friction[_ground_geoms(physics), 0] = friction


def set_contact_time_constant(physics: mujoco.Physics, time_constant: float) -> None:
    """Sets the contact time constant (`solref[0]`) of the floor, the tiles and the soles.

    MuJoCo mixes two geoms' `solref` by their `solmix` (equal here), so with both sides set
    their contact has this time constant; the damping ratio stays the model's.

    Args:
      physics: A `darwin.Physics`.
      time_constant: The time constant, s.

    Raises:
      ValueError: If it is not a positive number.
    """
    if not (np.isfinite(time_constant) and time_constant > 0):
        raise ValueError(f"time_constant must be a positive number, got {time_constant!r}")
    physics.model.geom_solref[_ground_geoms(physics), 0] = time_constant


def _ground_geoms(physics: mujoco.Physics) -> np.ndarray:
    """The floor's, the soles' and the tiles' geom ids: both sides of every floor contact."""
    return np.array([physics._floor, *physics._feet, *physics._tiles], int)


def set_torso_inertial(
    physics: mujoco.Physics, mass: float, inertia: np.ndarray, com: np.ndarray
) -> None:
    """Sets the torso's mass (kg), principal inertia (kg·m²) and centre of mass (m).

    Recomputes the model's derived constants (`mj_setConst`) so the solver sees them.

    Args:
      physics: A `darwin.Physics`.
      mass: The mass, kg.
      inertia: (3,) principal inertia, kg·m².
      com: (3,) centre of mass in the torso frame, m.
    """
    torso, model = physics._torso, physics.model
    model.body_mass[torso] = mass
    model.body_inertia[torso] = inertia
    model.body_ipos[torso] = com
    mj.mj_setConst(model.ptr, physics.data.ptr)


def torso_inertial(physics: mujoco.Physics) -> tuple[float, np.ndarray, np.ndarray]:
    """The torso's mass (kg), principal inertia (kg·m²) and centre of mass (m).

    Args:
      physics: A `darwin.Physics`.

    Returns:
      `(mass, inertia, com)`: copies, as `set_torso_inertial` takes them.
    """
    torso, model = physics._torso, physics.model
    return (
        float(model.body_mass[torso]),
        model.body_inertia[torso].copy(),
        model.body_ipos[torso].copy(),
    )


def set_tile_heights(physics: mujoco.Physics, heights: np.ndarray) -> None:
    """Raises the terrain tiles' tops to `heights` above the plane, m (0: hidden).

    Args:
      physics: A `darwin.Physics` of a model with tiles (`robot.get_model_and_assets`
        with a terrain).
      heights: One height per tile, m.

    Raises:
      ValueError: If the model has no tiles or the heights do not match them.
    """
    tiles = physics._tiles
    heights = np.asarray(heights, dtype=np.float64)
    if heights.shape != tiles.shape or not len(tiles):
        raise ValueError(f"need {len(tiles)} tile heights, got shape {heights.shape}")
    physics.model.geom_pos[tiles, 2] = perturbations.tile_heights_to_z(heights)


def set_torso_push(physics: mujoco.Physics, force: np.ndarray) -> None:
    """Applies a force (N, world frame) at the torso's centre of mass until changed.

    Args:
      physics: A `darwin.Physics`.
      force: (3,) the force, N.
    """
    physics.data.xfrc_applied[physics._torso, :3] = force


def apply_parameters(
    physics: mujoco.Physics, params: dict, nominal_torso: tuple[float, np.ndarray, np.ndarray]
) -> None:
    """Sets an episode's physical parameters (`perturbations.Randomization.sample`).

    Args:
      physics: A `darwin.Physics`.
      params: The draw: `servo_gain`, `torque_limit`, `joint_damping`, `friction`,
        `torso_mass_scale` and `torso_com_shift` (x, y).
      nominal_torso: The torso's nominal `torso_inertial`, which the draw scales and shifts.
    """
    mass, inertia, com = nominal_torso
    set_servo_gain(physics, params["servo_gain"])
    set_torque_limit(physics, params["torque_limit"])
    set_joint_damping(physics, params["joint_damping"])
    set_ground_friction(physics, params["friction"])
    shift = np.array([params["torso_com_shift"][0], params["torso_com_shift"][1], 0.0])
    scale = params["torso_mass_scale"]
    set_torso_inertial(physics, mass * scale, inertia * scale, com + shift)
