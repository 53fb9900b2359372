"""The DARwIn-OP's feet on the floor: each foot's load and centre of pressure, and the
balance task's reward from them (`darwin.Physics`'s floor and feet addresses).

A stance foot carries more than 5 % of the body weight (`STANCE_FRACTION`); the balance
reward is −(mean over stance feet of the horizontal distance from the foot's centre of
pressure to its sole centre), m, 0 when no foot is in stance.
"""

from __future__ import annotations

import math

import mujoco as mj
import numpy as np

from cpg_suite._headless import mujoco

STANCE_FRACTION = 0.05  # of body weight: a foot carrying more is a stance foot.
_VELOCITY_STAGE = mj.mjtStage.mjSTAGE_VEL


def foot_loads(physics: mujoco.Physics) -> tuple[list[float], list[list[float]]]:
    """Normal force of each foot and the force-weighted sum of its contact points.

    The normal force of a contact is the sum of its four pyramid-edge forces (condim 3,
    pyramidal cone: checked when the model is loaded, `checks.check_model`), as
    `mj_contactForce` computes it; a plain loop over the few contacts is the fastest way on
    this hot path.

    dm_control ends each step with `mj_step1`, which finds the contacts of the new state
    but does not solve for their forces: `efc_force` then holds whatever the arena held
    (it differed between processes). So the forces are solved here first
    (`mj_forwardSkip` from the velocity stage, sensors skipped); the next step solves
    them again from scratch, so the trajectory does not change (tests/test_darwin.py).

    Args:
      physics: A `darwin.Physics`.

    Returns:
      `(force, weighted)`: the (left, right) normal forces, N, and their force-weighted
      sums of contact positions, N·m, as Python lists.
    """
    f0, f1, w0, w1 = _loads(physics)
    return [f0, f1], [w0, w1]


def _loads(physics: mujoco.Physics) -> tuple[float, float, list[float], list[float]]:
    """`foot_loads` as the left and right forces and weighted sums (the reward's hot path:
    no lists of lists to build and unpack)."""
    model, data = physics._pointers
    mj.mj_forwardSkip(model, data, _VELOCITY_STAGE, 1)
    f0 = f1 = x0 = y0 = z0 = x1 = y1 = z1 = 0.0
    if data.ncon:
        contacts = data.contact
        efc = data.efc_force.tolist()
        floor, feet = physics._floor, physics._foot_index
        for (g0, g1), adr, (px, py, pz) in zip(
            contacts.geom.tolist(), contacts.efc_address.tolist(), contacts.pos.tolist()
        ):
            foot = feet.get(g1) if g0 == floor else feet.get(g0) if g1 == floor else None
            if foot is None or adr < 0:
                continue
            normal = efc[adr] + efc[adr + 1] + efc[adr + 2] + efc[adr + 3]
            if normal > 0.0:
                if foot:
                    f1 += normal
                    x1, y1, z1 = x1 + normal * px, y1 + normal * py, z1 + normal * pz
                else:
                    f0 += normal
                    x0, y0, z0 = x0 + normal * px, y0 + normal * py, z0 + normal * pz
    return f0, f1, [x0, y0, z0], [x1, y1, z1]


def centres_of_pressure(physics: mujoco.Physics) -> tuple[np.ndarray, np.ndarray]:
    """Centre of pressure and normal force of each foot, from its floor contacts.

    Args:
      physics: A `darwin.Physics`.

    Returns:
      `(cop, force)`: cop (2, 3), m, NaN for a foot without contact; force (2,), N.
    """
    force, weighted = foot_loads(physics)
    cop = np.full((2, 3), np.nan)
    for foot in (0, 1):
        if force[foot] > 0.0:
            cop[foot] = np.array(weighted[foot]) / force[foot]
    return cop, np.array(force)


def cop_offsets(physics: mujoco.Physics) -> tuple[np.ndarray, np.ndarray]:
    """Horizontal distance from each foot's COP to its sole centre, and the stance mask.

    Args:
      physics: A `darwin.Physics`.

    Returns:
      `(distance, stance)`: distance (2,), m (NaN without contact); stance (2,) bool, a
      foot carrying more than 5 % of the body weight.
    """
    distance, stance = _cop_offsets(physics)
    return np.array(distance), np.array(stance)


def _cop_offsets(physics: mujoco.Physics) -> tuple[list[float], list[bool]]:
    """`cop_offsets` as Python lists."""
    f0, f1, w0, w1 = _loads(physics)
    soles = physics._sole_xpos[physics._sole_rows].tolist()
    threshold = STANCE_FRACTION * physics._weight
    distance, stance = [math.nan, math.nan], [False, False]
    for foot, (f, w) in enumerate(((f0, w0), (f1, w1))):
        if f > 0.0:
            distance[foot] = math.hypot(w[0] / f - soles[foot][0], w[1] / f - soles[foot][1])
            stance[foot] = f > threshold
    return distance, stance


def balance_reward(physics: mujoco.Physics) -> float:
    """The balance task's reward (`cop_offsets`' distances of the stance feet, in one pass:
    the tasks' hot path; the same operations, tests/test_darwin.py).

    Args:
      physics: A `darwin.Physics`.

    Returns:
      −(mean over stance feet of the COP distance to the sole centre), m; 0 without.
    """
    f0, f1, (x0, y0, _), (x1, y1, _) = _loads(physics)
    threshold = STANCE_FRACTION * physics._weight
    if not (f0 > threshold or f1 > threshold):
        return 0.0
    (s0x, s0y, _), (s1x, s1y, _) = physics._sole_xpos[physics._sole_rows].tolist()
    total, n = 0, 0  # `sum` of the stance feet's distances, left first
    if f0 > threshold:
        total, n = total + math.hypot(x0 / f0 - s0x, y0 / f0 - s0y), 1
    if f1 > threshold:
        total, n = total + math.hypot(x1 / f1 - s1x, y1 / f1 - s1y), n + 1
    return -total / n
