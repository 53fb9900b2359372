"""The part of `mj_setConst` that MJX reads, in JAX: the bodies' and dofs' inverse weights.

`darwin.perturb.set_torso_inertial` calls `mj_setConst` after changing the torso's mass,
inertia and centre of mass, so that the constraint solver's regularization (which scales
with `body_invweight0` for contacts and `dof_invweight0` for joint limits) sees the new
mass distribution. MJX has no `mj_setConst`; `invweights` recomputes these two arrays at
`qpos0` the way MuJoCo does (`tests/test_mjx.py` compares them with `mj_setConst`).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import mjx


def invweights(m: mjx.Model) -> mjx.Model:
    """Returns `m` with `body_invweight0` and `dof_invweight0` recomputed at `qpos0`.

    For each movable body, A = J M⁻¹ Jᵀ with J the 6 × nv Jacobian of its centre of mass:
    the translational weight is the mean of A's first three diagonal entries, the rotational
    one that of the last three. A hinge or slide dof's weight is (M⁻¹)ᵢᵢ; a free joint's
    three translational and three rotational dofs take the mean of their diagonal entries,
    a ball joint's three dofs theirs.

    Args:
      m: An MJX model (e.g. with a body's mass or centre of mass changed).

    Returns:
      The model with the two arrays replaced.
    """
    d = mjx.make_data(m)
    d = mjx.kinematics(m, d.replace(qpos=jnp.asarray(m.qpos0)))
    d = mjx.com_pos(m, d)
    d = mjx.crb(m, d)
    minv = jnp.linalg.inv(mjx.full_m(m, d))

    def body_weights(body):
        jacp, jacr = mjx.jac(m, d, d.xipos[body], body)  # (nv, 3) each
        jac = jnp.concatenate([jacp, jacr], axis=1).T  # (6, nv)
        diag = jnp.diagonal(jac @ minv @ jac.T)
        return jnp.stack([diag[:3].mean(), diag[3:].mean()])

    movable = np.asarray(m.body_weldid) != 0
    bodies = np.arange(m.nbody)
    weights = jax.vmap(body_weights)(jnp.asarray(bodies))
    body_invweight0 = jnp.where(movable[:, None], weights, 0.0)
    return m.replace(
        body_invweight0=body_invweight0, dof_invweight0=_dof_weights(m, jnp.diagonal(minv))
    )


def _dof_weights(m: mjx.Model, minv_diag: jax.Array) -> jax.Array:
    """Per-dof weights from the diagonal of M⁻¹, averaged over free and ball joints' groups."""
    out = minv_diag
    for jnt_type, adr in zip(np.asarray(m.jnt_type), np.asarray(m.jnt_dofadr)):
        if jnt_type == mujoco.mjtJoint.mjJNT_FREE:
            groups = ((adr, adr + 3), (adr + 3, adr + 6))
        elif jnt_type == mujoco.mjtJoint.mjJNT_BALL:
            groups = ((adr, adr + 3),)
        else:
            continue
        for lo, hi in groups:
            out = out.at[lo:hi].set(minv_diag[lo:hi].mean())
    return out
