"""How the feet meet the floor: the score card's footing measures of one trial (issue 54).

Both evaluation paths record, after every physics step, each foot's footing sensors
(`darwin.robot.FOOTING_SENSORS`: its contacts with the floor and the tiles, the strongest
`FLOOR_CONTACT_SLOTS` first, each with its normal force and position, then its sole's
angular velocity, centre and axes), beside the soles' velocities that `quality.measures`
already reads; `measures` turns them into:

* contact slip per metre: for each stance foot (its floor contacts' normal forces summing
  to more than 5 % of the weight), the
  horizontal speed of the foot at each of its floor contacts, v + ω × (p − c) (v and ω the
  sole's linear and angular velocity, c its centre, p the contact), averaged over the
  contacts weighted by their normal forces, integrated over time, per metre walked (NaN
  under `quality.MIN_DISTANCE`). A foot rolling about an edge without sliding scores 0;
  the card's older `slip_per_m`, the sole centre's speed, counts the rolling too;
* flat-stance share: of the stance foot-steps (physics steps × stance feet), the share in
  which the sole is flat: its loaded contacts (normal force > 0) lie under both its front
  and back ends and under both its sides (`_flat`); on the plane, 3 or 4 of its corners
  (or 2 opposite ones);
* swing clearance, m: per swing (a run of physics steps out of stance between two stance
  phases, at least `MIN_SWING` long: shorter ones are a foot bouncing), the highest its
  sole's lowest corner rises above the floor plane (z = 0); the median over the trial's
  swings (NaN without one);
* toe- and heel-strike shares: of the touchdowns (the ends of swings in which the foot
  left the floor: a step with no loaded contact), the share whose first contact (the
  loaded contacts of the first step of the contact that led into stance) lies all in the
  sole's front part (a toe strike) or all in its back part (a heel strike); the others
  (flat, or along a side) are neither. NaN without a touchdown.

Choices (docs/protocol.md#score-card): a sole's ends and sides are its outer quarters:
x ≥ L/4 (front) and x ≤ −L/4 (back) along its length L = 0.105 m from its centre, y ≥ W/4
and y ≤ −W/4 across its width W = 0.066 m (`darwin.robot.SOLE_HALF_SIZE`), so a sole
resting on a tile's edge across its middle is not flat. The clearance is over the plane on
the rough tier too (its tiles rise at most 3 mm above it, so the clearance over the tile
below is at most 3 mm less): it is then a function of the sensors alone and compares a
gait's lift across tiers. The median over swings, not the mean, so that one stumble's high
swing does not make the trial's figure. A foot with more floor contacts than the sensor's
slots loses its weakest (`darwin.robot.FLOOR_CONTACT_SLOTS`). A foot's load is its floor
contacts' normal forces, not its touch sensor's reading, which misses the contacts on the
sensor site's boundary: a box sole's corners, where the floor meets it (the touch read
less than the contacts in 18-19 % of the foot-steps of a CMA-ES gait's trial). The
arithmetic is element-wise (`portable.hypot` for the speeds; the contact sums in slot
order), with NumPy's sum and median as in the other measures: the same bits on every
x86-64 CPU.
"""

from __future__ import annotations

import numpy as np

from cpg_suite import portable
from cpg_suite.darwin import robot

FIELDS = (
    "contact_slip_per_m",
    "flat_stance_share",
    "swing_clearance_m",
    "toe_strike_share",
    "heel_strike_share",
)
HALF_LENGTH, HALF_WIDTH = robot.SOLE_HALF_SIZE  # m
SLOTS, SLOT = robot.FLOOR_CONTACT_SLOTS, robot.CONTACT_DATA
FOOT_WIDTH = SLOTS * SLOT + 4 * 3  # per foot: its contact slots, then 4 vectors of its sole
# Of the half length (width): a contact this far from the sole's centre is under an end
# (a side) — its outer quarter (a choice: a corner is at 1, a tile's seam anywhere).
PART = 0.5
# A swing lasts at least this long, s (a choice: in the nominal trials of four ranked gaits
# (CMA-ES, CEM, CMA-ES randomized, feedback CPG; 2 test seeds each) a foot bouncing after
# its touchdown leaves stance for at most 0.04 s with its lowest corner < 0.5 mm up
# (median), while the open-loop gaits' strides swing for 0.1-0.3 s).
MIN_SWING = 0.05


def contacts(feet: np.ndarray) -> dict[str, np.ndarray]:
    """The parts of a footing record (`darwin.robot.sensor_slices`' "footing").

    Args:
      feet: (T, 2, `FOOT_WIDTH`) the (left, right) feet's footing sensors after each
        physics step.

    Returns:
      `normal` (T, 2, SLOTS) normal forces, N (0 in an empty slot or a contact pulling
      nothing); `position` (T, 2, SLOTS, 3) contact positions, m; `angvel`, `centre`,
      `xaxis`, `yaxis` (T, 2, 3): the sole's angular velocity (rad/s), centre (m) and axes.
    """
    slots = feet[..., : SLOTS * SLOT].reshape(*feet.shape[:-1], SLOTS, SLOT)
    found = slots[..., 0] > 0.0
    sole = feet[..., SLOTS * SLOT :]
    return {
        "normal": np.where(found, np.maximum(slots[..., 1], 0.0), 0.0),
        "position": slots[..., 4:7],
        "angvel": sole[..., 0:3],
        "centre": sole[..., 3:6],
        "xaxis": sole[..., 6:9],
        "yaxis": sole[..., 9:12],
    }


def contact_speeds(sole_velocity: np.ndarray, parts: dict) -> np.ndarray:
    """Horizontal speed of each foot at each of its contact points, v + ω × (p − c).

    Args:
      sole_velocity: (T, 2, 3) the soles' centres' linear velocities in the world, m/s.
      parts: `contacts`' arrays.

    Returns:
      (T, 2, SLOTS) speeds, m/s.
    """
    rx, ry, rz = _offsets(parts)
    wx, wy, wz = _components(parts["angvel"])
    v = _components(sole_velocity)
    vx = v[0] + (wy * rz - wz * ry)
    vy = v[1] + (wz * rx - wx * rz)
    return portable.hypot(vx, vy)


def sole_coordinates(parts: dict) -> tuple[np.ndarray, np.ndarray]:
    """Each contact's position along the sole's length (x, forward) and across it (y, to
    the foot's left), from the sole's centre, m.

    Args:
      parts: `contacts`' arrays.

    Returns:
      `(x, y)`, (T, 2, SLOTS) each.
    """
    r = _offsets(parts)
    return _dot(r, _components(parts["xaxis"])), _dot(r, _components(parts["yaxis"]))


def lowest_corner(parts: dict) -> np.ndarray:
    """Height of each sole's lowest corner above the plane z = 0, m.

    The sole's centre (its site, on the bottom face) plus the corner ±L/2 x̂ ± W/2 ŷ lowest
    in z: c_z − L/2 |x̂_z| − W/2 |ŷ_z|.

    Args:
      parts: `contacts`' arrays.

    Returns:
      (T, 2) heights, m.
    """
    return (
        parts["centre"][..., 2]
        - HALF_LENGTH * np.abs(parts["xaxis"][..., 2])
        - HALF_WIDTH * np.abs(parts["yaxis"][..., 2])
    )


def swings(stance: np.ndarray, min_steps: int = 1) -> list[tuple[int, int]]:
    """The whole swings of one foot: runs of at least `min_steps` steps out of stance with
    stance on both sides (shorter runs are bounces, part of the stance around them).

    Args:
      stance: (T,) bool, the foot in stance after each physics step.
      min_steps: The shortest swing, physics steps.

    Returns:
      `(first, end)` step indices of each swing (end: the touchdown's first stance step).
    """
    change = np.diff(np.concatenate([[0], np.asarray(stance, np.int8), [0]]))
    land = np.flatnonzero(change == 1)  # the first step of each stance phase
    lift = np.flatnonzero(change == -1)  # the first step after each (T after the last)
    return [(int(a), int(b)) for a, b in zip(lift, land[1:]) if b - a >= min_steps]


def strikes(
    loaded: np.ndarray, x: np.ndarray, stance: np.ndarray, min_steps: int = 1
) -> tuple[int, int, int]:
    """One foot's touchdowns and how many were toe and heel strikes.

    A touchdown ends a swing (`swings`) in which the foot had no loaded contact at some
    step; its first contact is the first step of the run of steps with a loaded contact
    that leads into stance. A toe strike: that step's loaded contacts all lie in the front
    part (x ≥ `PART` · L/2); a heel strike: all in the back part (x ≤ −`PART` · L/2).

    Args:
      loaded: (T, SLOTS) bool, the foot's contacts carrying a normal force.
      x: (T, SLOTS) their positions along the sole from its centre, m.
      stance: (T,) bool, the foot in stance.
      min_steps: The shortest swing, physics steps (`swings`).

    Returns:
      `(touchdowns, toe, heel)`.
    """
    touching = loaded.any(axis=1)
    front = touching & np.all(~loaded | (x >= PART * HALF_LENGTH), axis=1)
    back = touching & np.all(~loaded | (x <= -PART * HALF_LENGTH), axis=1)
    touchdowns = toe = heel = 0
    for first, end in swings(stance, min_steps):
        airborne = np.flatnonzero(~touching[first:end])
        if not len(airborne):
            continue  # the foot never left the floor: no touchdown
        contact = first + int(airborne[-1]) + 1  # the first step of the last contact run
        touchdowns += 1
        toe += bool(front[contact])
        heel += bool(back[contact])
    return touchdowns, toe, heel


def measures(
    sole_velocity: np.ndarray,
    feet: np.ndarray,
    *,
    stance_force: float,
    timestep: float,
    distance: float,
    min_distance: float,
) -> dict:
    """The footing measures of one trial (`FIELDS`).

    Args:
      sole_velocity: (T, 2, 3) the soles' centres' velocities in the world, m/s.
      feet: (T, 2, `FOOT_WIDTH`) the feet's footing sensors (`contacts`).
      stance_force: A foot whose floor contacts' normal forces sum to more is in stance, N.
      timestep: Physics step, s.
      distance: Forward distance of the trial, m.
      min_distance: Below this distance the per-metre slip is NaN, m.

    Returns:
      A dict with `FIELDS`.
    """
    parts = contacts(feet)
    normal = parts["normal"]
    speed = contact_speeds(sole_velocity, parts)
    force = weighted = np.zeros(normal.shape[:-1])
    for k in range(SLOTS):  # a fixed order of summation
        force = force + normal[..., k]
        weighted = weighted + normal[..., k] * speed[..., k]
    stance = force > stance_force
    rate = np.where(stance, weighted / np.where(stance, force, 1.0), 0.0)
    slip = float(np.sum(rate) * timestep)
    x, y = sole_coordinates(parts)
    loaded = normal > 0.0
    stance_steps = int(stance.sum())
    flat = _flat(loaded, x, y) & stance
    clearance, touchdowns, toe, heel = [], 0, 0, 0
    height, shortest = lowest_corner(parts), int(round(MIN_SWING / timestep))
    for foot in (0, 1):
        lifts = swings(stance[:, foot], shortest)
        clearance += [float(np.max(height[a:b, foot])) for a, b in lifts]
        n, t, h = strikes(loaded[:, foot], x[:, foot], stance[:, foot], shortest)
        touchdowns, toe, heel = touchdowns + n, toe + t, heel + h
    nan = float("nan")
    return {
        "contact_slip_per_m": slip / distance if distance >= min_distance else nan,
        "flat_stance_share": float(flat.sum()) / stance_steps if stance_steps else nan,
        "swing_clearance_m": float(np.median(clearance)) if clearance else nan,
        "toe_strike_share": toe / touchdowns if touchdowns else nan,
        "heel_strike_share": heel / touchdowns if touchdowns else nan,
    }


def _flat(loaded: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Whether each foot-step's loaded contacts lie under both ends and both sides of the
    sole (its outer quarters, `PART`)."""
    ends = PART * HALF_LENGTH, PART * HALF_WIDTH
    front = np.any(loaded & (x >= ends[0]), axis=-1)
    back = np.any(loaded & (x <= -ends[0]), axis=-1)
    left = np.any(loaded & (y >= ends[1]), axis=-1)
    right = np.any(loaded & (y <= -ends[1]), axis=-1)
    return front & back & left & right


def _offsets(parts: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The x, y and z components of each contact's position from its sole's centre,
    (T, 2, SLOTS) each."""
    position = np.moveaxis(parts["position"], -1, 0)
    centre = np.moveaxis(parts["centre"], -1, 0)[..., None]
    return tuple(np.subtract(position[i], centre[i]) for i in range(3))


def _components(vectors: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The x, y and z components of (T, 2, 3) vectors as contiguous (T, 2, 1) arrays, to
    broadcast against a foot's contacts. Element-wise arithmetic on whole contiguous
    components gives the bits it gives on the interleaved vectors, in fewer, longer loops."""
    return tuple(np.ascontiguousarray(vectors[..., i, None]) for i in range(3))


def _dot(a: tuple, b: tuple) -> np.ndarray:
    """Dot products of vectors given by their (x, y, z) components, summed in that order."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
