"""A DARwIn-OP sole on the rough tier's tiles: MuJoCo C's box-box contacts against MJX's.

  python investigations/box_box_contacts.py

The rough tier's ground is boxes (`perturbations.tile_xml`), so a sole on it is a box-box
pair, which MJX collides with its own routine (`collision_convex.box_box`). This builds a
small scene from the tier's pieces — the floor plane, two neighbouring tiles with tops 2 mm
and 1 mm above it (the tier draws U(0, 3 mm)), and a free box of the left sole's size —
and prints, for a few poses of the sole, the contacts MuJoCo C's `mj_forward` finds and
the active contacts of MJX's `forward` (float64, JAX on CPU), each as (geoms, distance,
position). A contact is active in MJX where its distance is negative.
"""

import jax
import mujoco
import numpy as np
from mujoco import mjx

from cpg_suite import darwin, perturbations

TOPS = (0.002, 0.001)  # m: the two tiles' tops above the plane.
EDGE = 0.1  # m: x of the edge between tile A (centred at 0) and tile B.
POSES = (  # (name, sole centre x, depth into tile A, roll deg, pitch deg)
    ("flat on tile A", 0.0, 1e-4, 0.0, 0.0),
    ("pitched 3 deg (heel strike) on tile A", 0.0, 2e-4, 0.0, -3.0),
    ("rolled 2 deg on tile A", 0.0, 2e-4, 2.0, 0.0),
    ("flat across the edge, over tile B", 0.07, 1e-4, 0.0, 0.0),
    ("toe down 0.5 deg across the edge: A's edge under the sole's face", 0.12, 1e-4, 0.0, 0.5),
)


def scene(foot, x: float, depth: float, roll: float, pitch: float) -> str:
    """The MJCF: the floor, two tiles and a box of the `foot` geom's size at the pose.

    The sole's lowest point over tile A (a corner, or the face above A's edge) lies `depth`
    below A's top.
    """
    half = perturbations.Terrain().tile / 2
    z = perturbations.tile_heights_to_z(np.array(TOPS))
    hz = foot.size[2]
    r, p = np.deg2rad(roll), np.deg2rad(pitch)
    # Height of the lowest corner under the centre, and of the bottom face's line at A's edge.
    corner = (
        abs(foot.size[0] * np.sin(p)) + abs(foot.size[1] * np.sin(r)) + hz * np.cos(r) * np.cos(p)
    )
    at_edge = hz / np.cos(p) + (EDGE - x) * np.tan(p)
    low = corner if x + foot.size[0] * np.cos(p) <= EDGE else at_edge
    zc = TOPS[0] - depth + low
    sx, sy, sz = (float(v) for v in foot.size)
    return f"""<mujoco><option timestep="0.002"/><worldbody>
  <geom name="floor" type="plane" size="5 5 0.1"/>
  <geom name="tileA" type="box" size="{half} {half} {perturbations.TILE_DEPTH}" pos="0 0 {z[0]}"/>
  <geom name="tileB" type="box" size="{half} {half} {perturbations.TILE_DEPTH}"
        pos="{2 * half} 0 {z[1]}"/>
  <body name="sole" pos="{x} 0.011 {zc}" euler="{roll} {pitch} 0">
    <freejoint/><geom name="sole" type="box" size="{sx} {sy} {sz}" mass="0.1"/>
  </body></worldbody></mujoco>"""


def rows(names, pairs, dists, positions) -> list[str]:
    """One printed line per contact, sorted by distance."""
    order = np.argsort(dists, kind="stable")
    return [
        f"{names[pairs[i][0]]:>5}-{names[pairs[i][1]]:<4} {dists[i] * 1e3:+8.4f} mm  "
        f"pos {np.array2string(np.asarray(positions[i]) * 1e3, precision=3)} mm"
        for i in order
    ]


def main() -> None:
    xml, assets = darwin.get_model_and_assets()
    foot = mujoco.MjModel.from_xml_string(xml, assets).geom("foot_l")
    with jax.enable_x64(True):
        for name, x, depth, roll, pitch in POSES:
            m = mujoco.MjModel.from_xml_string(scene(foot, x, depth, roll, pitch))
            d = mujoco.MjData(m)
            mujoco.mj_forward(m, d)
            names = [m.geom(i).name for i in range(m.ngeom)]
            c = d.contact[: d.ncon]
            print(f"{name}: MuJoCo C {d.ncon} contacts")
            for line in rows(names, c.geom, c.dist, c.pos):
                print("   C  ", line)
            con = mjx.forward(mjx.put_model(m), mjx.put_data(m, d))._impl.contact
            dist, geom, pos = (np.asarray(a) for a in (con.dist, con.geom, con.pos))
            act = np.flatnonzero(dist < 0)
            print(f"  MJX {len(act)} active of {len(dist)} slots")
            for line in rows(names, geom[act], dist[act], pos[act]):
                print("   MJX", line)


if __name__ == "__main__":
    main()
