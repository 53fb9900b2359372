"""The DARwIn-OP's standing pose: the arms' and head's held pose, and a robot put at rest
in a pose with its soles on the floor (every task's reset, `darwin.CPGTask`).
"""

from __future__ import annotations

import mujoco as mj
import numpy as np

from cpg_suite._headless import mujoco

# Arms 10° out from hanging vertical (±0.785), elbows bent 30° from straight (±1.571), head
# level (+0.70, the ROBOTIS walking engine's eye-tilt offset); `robot.ARM_JOINTS` order.
ARM_POSE = np.array([0.0, 0.61, 1.05, 0.0, -0.61, -1.05, 0.0, 0.70])


def set_standing_pose(
    physics: mujoco.Physics,
    leg_angles: np.ndarray,
    arm_angles: np.ndarray = ARM_POSE,
    clearance: float = 0.0,
) -> None:
    """Puts the robot at rest in a pose, torso upright at the origin, lowest sole corner
    `clearance` above the floor; servo targets set to the pose.

    Args:
      physics: A `darwin.Physics`.
      leg_angles: (12,) leg joint angles, rad, in `cpg.LEG_JOINTS` order.
      arm_angles: (8,) arm and head joint angles, rad, in `robot.ARM_JOINTS` order.
      clearance: Height of the lowest sole corner above the floor, m.
    """
    data, r = physics.data, physics._root_qpos
    data.qpos[:] = physics.model.qpos0
    data.qvel[:] = 0.0
    data.qpos[physics._leg_qpos] = leg_angles
    data.qpos[physics._arm_qpos] = arm_angles
    data.qpos[r : r + 3] = (0.0, 0.0, 0.5)
    data.qpos[r + 3 : r + 7] = (1.0, 0.0, 0.0, 0.0)
    mj.mj_kinematics(physics.model.ptr, data.ptr)
    lowest = min(lowest_corner(physics, g) for g in physics._feet)
    data.qpos[r + 2] += clearance - lowest
    physics.set_leg_targets(leg_angles)
    physics.set_arm_targets(arm_angles)
    physics.after_reset()


def lowest_corner(physics: mujoco.Physics, geom: int) -> float:
    """Height of a box geom's lowest corner, m.

    Written out element by element rather than as a matrix product: BLAS kernels differ
    between CPUs in their last bit, and this height places the robot at every reset.

    Args:
      physics: A `darwin.Physics` (or any dm_control physics).
      geom: The box geom's id.

    Returns:
      The height, m.
    """
    half = physics.model.geom_size[geom]
    rot = physics.data.geom_xmat[geom].reshape(3, 3)
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    local = corners * half
    z = physics.data.geom_xpos[geom, 2] + local[:, 0] * rot[2, 0]
    z = z + local[:, 1] * rot[2, 1]
    z = z + local[:, 2] * rot[2, 2]
    return float(z.min())
