"""The DARwIn-OP model (`xml/darwin.xml`, docs/darwin_op_model.md): its MJCF and assets, the
names of its parts, and the fall test on its state.

The facts every path shares: `darwin.Physics` looks its addresses up by these names, and the
batched evaluators, the vector env and the MJX env read the same names and the same fall
test (`has_fallen`), so all give the same verdicts. `cpg_suite.darwin` re-exports the public
names (`darwin.ARM_JOINTS`, `darwin.has_fallen`, `darwin.get_model_and_assets`, ...).
"""

from __future__ import annotations

import functools
import re

import mujoco as mj
import numpy as np

from cpg_suite import base, cpg, perturbations, portable
from cpg_suite._headless import mujoco

FALL_HEIGHT = 0.22  # m: torso origin height below which the robot has fallen.
FALL_TILT_COS = float(portable.cos(np.deg2rad(50.0)))  # torso z-axis · world z below this: fallen.

FOOT_GEOMS = ("foot_l", "foot_r")  # the soles' collision boxes, left then right
SOLE_SITES = ("sole_l", "sole_r")  # the soles' centres, left then right
# The soles' boxes: half length (along the foot's x axis, forward) and half width, m. The
# sole is 0.105 × 0.066 m (docs/darwin_op_model.md#dimensions: the Webots collision box);
# `xml/darwin.xml`'s geoms foot_l and foot_r (tests/test_footing.py checks they agree).
SOLE_HALF_SIZE = (0.0525, 0.033)
# The footing sensors of each foot, in the model's order (`sensor_slices`' "footing"): its
# floor contacts (`FLOOR_CONTACT_SLOTS` slots of `CONTACT_DATA` numbers: found, the force in
# the contact frame, the position), then its sole's angular velocity, position, x and y axes.
FOOTING_SENSORS = ("floor_contacts", "sole_angvel", "sole_pos", "sole_xaxis", "sole_yaxis")
# Contacts recorded per foot, the strongest first (a choice: the plane gives a box sole at
# most 4; on the rough tier's tiles, 8 hold every contact of 99.6 % of the foot-steps on
# the ground of three ranked open-loop gaits, 3 test seeds each, the others losing their
# weakest, up to 7 of 15; docs/protocol.md#score-card).
FLOOR_CONTACT_SLOTS = 8
CONTACT_DATA = 7  # numbers per contact slot: found (0: empty), force (3), position (3)
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


def for_mjx(xml: str) -> str:
    """The model for MJX: its soles' `floor_contacts_*` sensors match the floor plane only.

    MJX has no contact sensor that matches a body's geoms (the world's: the floor and the
    tiles). Their data keep their size and place, so a CPU state fits the MJX model
    (`mjx.WalkEnv.state_from_mujoco`); no MJX task reads them, and sensors do not change
    the dynamics.

    Args:
      xml: The model's XML (`get_model_and_assets`).

    Returns:
      The XML with those sensors' `body2="world"` replaced by `geom2="floor"`.
    """
    return re.sub(
        r'(<contact name="floor_contacts_[lr]"[^>]*?)body2="world"', r'\1geom2="floor"', xml
    )


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


def _footing_slice(model: mujoco.wrapper.MjModel, sensor) -> dict[str, slice]:
    """`sensor_slices`' "footing" entry (none in a model without contact sensors)."""
    names = [f"{part}_{side}" for side in "lr" for part in FOOTING_SENSORS]
    ptr = getattr(model, "ptr", model)
    if mj.mj_name2id(ptr, mj.mjtObj.mjOBJ_SENSOR, names[0]) < 0:
        return {}
    slices = [sensor(n) for n in names]
    widths = [FLOOR_CONTACT_SLOTS * CONTACT_DATA, 3, 3, 3, 3] * 2
    if [s.stop - s.start for s in slices] != widths or any(
        a.stop != b.start for a, b in zip(slices[:-1], slices[1:])
    ):
        raise ValueError(f"the footing sensors must be {names} one after another")
    return {"footing": slice(slices[0].start, slices[-1].stop)}


def sensor_slices(model: mujoco.wrapper.MjModel) -> dict[str, slice]:
    """Where each reading of `darwin.Physics`'s accessors lies in `data.sensordata`.

    Returns:
      Slices under `torso_orientation`, `gyro`, `accelerometer`, `foot_touch` (left, right),
      `leg_torques` (`cpg.LEG_JOINTS` order), `sole_velocities` (left, right),
      `servo_forces` (the 20 servos, actuator order) and, in a model with the soles'
      contact sensors, `footing` (`FOOTING_SENSORS` of the left foot, then the right's).

    Raises:
      ValueError: If the footing sensors are not laid out as `FOOTING_SENSORS` says.
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
        **_footing_slice(model, sensor),
    }
