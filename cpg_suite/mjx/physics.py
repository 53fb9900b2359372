"""MJX's forward dynamics and step with MuJoCo C's box-plane contacts.

MJX collides a box with a plane through its convex routine, which keeps only the corners
within 1 mm of the deepest one (a "skin depth"); MuJoCo C (`mjc_PlaneBox`) keeps every
corner below the plane and below the box's centre, up to four, in corner order. A sole
that lands tilted by more than about 1 mm over its 105 mm length (heel strike, toe-off)
therefore has fewer contacts in MJX than on the CPU, and walking trials part within a few
dozen control steps (docs/architecture.md#the-mjx-path). `forward` and `step` here are
`mjx.forward` and `mjx.step`, built from MJX's public stages in MJX's order, with the
box-plane contacts recomputed as MuJoCo C computes them after `mjx.collision`. Everything
else is MJX's own.

On MJX's Warp backend (`mjx.put_model(..., impl="warp")`), `forward` and `step` are MJX's
own: MuJoCo Warp's box-plane routine keeps every corner within the margin, as MuJoCo C's
does for a sole resting on the floor, and its contacts are a list that grows with the
corners found, not fixed slots (`tests/test_mjx_warp.py` compares its steps with the CPU's).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import mjx

_INACTIVE_DIST = 1.0  # m: the distance MJX gives an unused contact slot (never active).


def _box_corner_signs() -> np.ndarray:
    """(8, 3) corner signs in `mjc_PlaneBox`'s order: bit 0 → x, bit 1 → y, bit 2 → z."""
    return np.array([[1 if i & b else -1 for b in (1, 2, 4)] for i in range(8)], dtype=float)


def plane_box_contacts(m: mjx.Model, d: mjx.Data) -> mjx.Data:
    """Recomputes the box-plane contact slots as MuJoCo C's `mjc_PlaneBox` fills them.

    MJX gives each geom pair a fixed run of slots (four for a box and a plane); the k-th
    slot of a pair gets the k-th corner that lies within the margin of the plane and below
    the box's centre (along the plane normal), or stays unused.

    Args:
      m: The MJX model.
      d: The MJX data after `mjx.collision`.

    Returns:
      `d` with those slots' distances and positions replaced (MJX's frames are already
      MuJoCo C's: the plane's normal and the same tangents).
    """
    contact = d._impl.contact
    geom = contact.geom
    types = jnp.asarray(m.geom_type)
    plane, box = geom[:, 0], geom[:, 1]
    is_plane_box = (types[plane] == int(mujoco.mjtGeom.mjGEOM_PLANE)) & (
        types[box] == int(mujoco.mjtGeom.mjGEOM_BOX)
    )
    n = geom.shape[0]
    same = jnp.all(geom[:, None, :] == geom[None, :, :], axis=-1)
    rank = jnp.sum(same & (jnp.arange(n)[None, :] < jnp.arange(n)[:, None]), axis=1)

    def one(p, b, k):
        normal = d.geom_xmat[p][:, 2]
        dist = jnp.dot(d.geom_xpos[b] - d.geom_xpos[p], normal)
        corners = (_box_corner_signs() * m.geom_size[b]) @ d.geom_xmat[b].T  # (8, 3)
        ldist = corners @ normal
        margin = m.geom_margin[p] + m.geom_margin[b]
        valid = (dist + ldist <= margin) & (ldist <= 0)
        order = jnp.cumsum(valid) - 1
        chosen = valid & (order == k)
        i = jnp.argmax(chosen)
        depth = dist + ldist[i]
        pos = d.geom_xpos[b] + corners[i] - 0.5 * depth * normal
        found = chosen.any()
        return jnp.where(found, depth, _INACTIVE_DIST), pos

    dist, pos = jax.vmap(one)(plane, box, rank)
    contact = contact.replace(
        dist=jnp.where(is_plane_box, dist, contact.dist),
        pos=jnp.where(is_plane_box[:, None], pos, contact.pos),
    )
    return d.tree_replace({"_impl.contact": contact})


def fwd_position(m: mjx.Model, d: mjx.Data) -> mjx.Data:
    """`mjx.fwd_position` with `plane_box_contacts` after the collision."""
    d = mjx.kinematics(m, d)
    d = mjx.com_pos(m, d)
    d = mjx.camlight(m, d)
    d = mjx.tendon(m, d)
    d = mjx.crb(m, d)
    d = mjx.tendon_armature(m, d)
    d = mjx.factor_m(m, d)
    d = mjx.collision(m, d)
    d = plane_box_contacts(m, d)
    d = mjx.make_constraint(m, d)
    return mjx.transmission(m, d)


def is_warp(m: mjx.Model) -> bool:
    """Whether `m` was put on MJX's Warp backend (`mjx.put_model(..., impl="warp")`)."""
    return m.impl == mjx.Impl.WARP


def forward(m: mjx.Model, d: mjx.Data) -> mjx.Data:
    """`mjx.forward` with MuJoCo C's box-plane contacts (on Warp: `mjx.forward`).

    Args:
      m: The MJX model.
      d: The MJX data.

    Returns:
      The data with positions, velocities, accelerations and sensors computed.
    """
    if is_warp(m):
        return mjx.forward(m, d)
    d = fwd_position(m, d)
    d = mjx.sensor_pos(m, d)
    d = mjx.fwd_velocity(m, d)
    d = mjx.sensor_vel(m, d)
    d = mjx.fwd_actuation(m, d)
    d = mjx.fwd_acceleration(m, d)
    if d._impl.efc_J.size == 0:
        return d.replace(qacc=d.qacc_smooth)
    d = mjx.solve(m, d)
    return mjx.sensor_acc(m, d)


def step(m: mjx.Model, d: mjx.Data) -> mjx.Data:
    """`mjx.step` with MuJoCo C's box-plane contacts (implicit-fast; on Warp: `mjx.step`).

    Args:
      m: The MJX model (its integrator must be implicit-fast, the DARwIn-OP model's).
      d: The MJX data.

    Returns:
      The data one physics step later.

    Raises:
      NotImplementedError: For another integrator.
    """
    if is_warp(m):
        return mjx.step(m, d)
    if m.opt.integrator != mjx.IntegratorType.IMPLICITFAST:
        raise NotImplementedError(f"only the implicit-fast integrator, got {m.opt.integrator}")
    return mjx.implicit(m, forward(m, d))
