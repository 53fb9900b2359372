"""The DARwIn-OP model (`xml/darwin.xml`, docs/darwin_op_model.md): its MJCF and assets, the
names of its parts, and the fall test on its state.

The facts every path shares: `darwin.Physics` looks its addresses up by these names, and the
batched evaluators, the vector env and the MJX env read the same names and the same fall
test (`has_fallen`), so all give the same verdicts. `cpg_suite.darwin` re-exports the public
names (`darwin.ARM_JOINTS`, `darwin.has_fallen`, `darwin.get_model_and_assets`, ...).
"""

from __future__ import annotations

import functools

import numpy as np

from cpg_suite import base, cpg, perturbations, portable
from cpg_suite._headless import mujoco

FALL_HEIGHT = 0.22  # m: torso origin height below which the robot has fallen.
FALL_TILT_COS = float(portable.cos(np.deg2rad(50.0)))  # torso z-axis · world z below this: fallen.

FOOT_GEOMS = ("foot_l", "foot_r")  # the soles' collision boxes, left then right
SOLE_SITES = ("sole_l", "sole_r")  # the soles' centres, left then right
FLOOR_GEOM = "floor"
# The floor and the soles: every contact of the CPU reference's trials that did not fall
# (investigations/contact_census.py), the pairs `mjx.WalkEnv(contacts="soles")` keeps.
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
    return (q[..., 2] < FALL_HEIGHT) | (upright < FALL_TILT_COS)


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


@functools.lru_cache(maxsize=4)
def compiled(xml: str, assets: tuple) -> mujoco.wrapper.MjModel:
    """The model compiled from `xml` and its `(name, contents)` assets, once: each
    environment gets a copy (`mj_copyModel`, a sixth of a compile's time; the same
    model), so that scoring 200 trials does not compile it 200 times. Never to be handed
    out itself: a task's changes to its model stay in its copy."""
    return mujoco.wrapper.MjModel.from_xml_string(xml, assets=dict(assets))


def ids(model: mujoco.wrapper.MjModel, names: tuple[str, ...], kind: str) -> np.ndarray:
    """The ids of named parts of one kind (`"joint"`, `"actuator"`, `"geom"`, `"site"`)."""
    return np.array([model.name2id(n, kind) for n in names])


def tile_geoms(model: mujoco.wrapper.MjModel) -> np.ndarray:
    """The ids of the terrain's tiles (`perturbations.tile_xml`; none without a terrain)."""
    names = [model.id2name(i, "geom") or "" for i in range(model.ngeom)]
    return np.array([i for i, n in enumerate(names) if n.startswith("tile")], int)


def sensor_slices(model: mujoco.wrapper.MjModel) -> dict[str, slice]:
    """Where each reading of `darwin.Physics`'s accessors lies in `data.sensordata`.

    Returns:
      Slices under `torso_orientation`, `gyro`, `accelerometer`, `foot_touch` (left, right),
      `leg_torques` (`cpg.LEG_JOINTS` order), `sole_velocities` (left, right) and
      `servo_forces` (the 20 servos, actuator order).
    """

    def sensor(name):
        i = model.name2id(name, "sensor")
        adr, dim = int(model.sensor_adr[i]), int(model.sensor_dim[i])
        return slice(adr, adr + dim)

    return {
        "torso_orientation": sensor("torso_orientation"),
        "gyro": sensor("gyro"),
        "accelerometer": sensor("accelerometer"),
        "foot_touch": slice(sensor("touch_l").start, sensor("touch_r").stop),
        "leg_torques": slice(
            sensor(f"force_{cpg.LEG_JOINTS[0]}").start,
            sensor(f"force_{cpg.LEG_JOINTS[-1]}").stop,
        ),
        "sole_velocities": slice(sensor("sole_velocity_l").start, sensor("sole_velocity_r").stop),
        "servo_forces": slice(
            sensor(f"force_{cpg.LEG_JOINTS[0]}").start, sensor(f"force_{ARM_JOINTS[-1]}").stop
        ),
    }
