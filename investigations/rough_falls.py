r"""Why the rough tier fells the ranked gaits: the last second before each fall, and which
change of the ground removes the falls.

  python investigations/rough_falls.py [--runs=RUN,RUN,...] [--anatomy=4] [--seeds=10]
      [--variants=nominal,rough,rough_2mm,rough_1mm,no_plane,flat_tiles,rough_elliptic,
      box_floor] [--out=FILE]

Its findings and the commands behind them: docs/contact.md.

The rough tier's ground is the floor plane and a grid of 0.2 m box tiles, each raised
U(0, 3 mm) above it (`perturbations.Terrain`; a tile of height 0, the start pad, lies
hidden below the plane). A sole is a box, so on a tile it is a box-box pair.

Part 1, **anatomy** (`--anatomy` failing rough trials per run, from its `trials.csv`,
stepped as the score card steps them, `score.step_policy`; the fall step is checked against
the file). After every physics step it records the torso's pitch and roll and every contact
of a sole: with the plane, on a tile's top face (interior, or within `RIM` of the tile's
boundary: the sole rests on the tile's edge), or on a tile's side face (normal more than
45° from vertical: a sole's edge or corner against the tile's side, a trip); where on the
sole (toe, heel, inner or outer edge, a corner, or inside the sole's outline: a tile's rim
under it); the normal force (`mj_contactForce`) and the contact point's slip speed (the sole
body's velocity at the point, tangential part). Then, over the last second before the fall:
the fall's direction and the torso's attitude at -1, -0.5, -0.25 s and at the fall; the
onset (the last step with the torso within 15 deg of upright); the side contacts (trips:
which foot, where on the sole, whether the foot was in swing, how long before the fall);
each stance foot's share of stance resting on a tile's rim or straddling two tiles, the
tile-height step under it, and its contact-point slip (m, force-weighted); the load the
plane carries under raised tiles (a tile thinner than the contacts' penetration lets the
sole touch the plane beneath it too). The same seed's nominal trial gives the same numbers
over the same control steps, and the first control step where the two trials' torso
attitudes differ by more than 5 deg.

Part 2, **variants** (the first `--seeds` rough-tier seeds of `trials.csv` per run, failing or
not): falls per ground:
  nominal         darwin_walk (the plane), read from trials.csv
  rough           darwin_walk_rough as scored (tiles up to 3 mm), read from trials.csv
  rough_2mm/_1mm  the same tiles at 2/3 and 1/3 of their heights
  no_plane        the same tiles, the plane lowered 10 mm and the start pad's tiles raised to
                  height 0 (tops at z = 0): no sole ever touches the plane under a thin tile
  flat_tiles      every tile's top at z = 0, the plane lowered 10 mm: a flat floor of box
                  tiles with seams every 0.2 m (box-box contacts where darwin_walk has
                  box-plane ones)
  rough_elliptic  the rough tier with an elliptic friction cone and impratio 10
  box_floor       darwin_walk with the floor plane replaced by one box (50 m square, its
                  top at z = 0): box-box contacts without seams (a model built for it)

The variants change a copy of the trial's model after its reset (before the first step),
never the benchmark's model or task. Prints a block per trial, a summary line per run (the
falls' directions; at the onset, how many had every sole contact under the heel, under the
toe, one on a tile's rim; the means and medians above), then the falls per ground.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import collections
import contextlib
import csv
import dataclasses
import math
import os

import mujoco
import numpy as np
from absl import flags

from cpg_suite import base, cli, darwin, perturbations
from cpg_suite.darwin import tasks as darwin_tasks
from cpg_suite.evaluation.closed_loop import FeedbackPolicy
from cpg_suite.protocol import score, verify

ROOT = verify.ARTIFACTS
# One or two runs of each ranked configuration (issue 54): the main job's CEM gait, CMA-ES
# on the nominal task, CMA-ES on the randomized task (the 4x track's first), its feedback
# CPG, PPO with the CPG head, PPO on MJX with the CPG head.
RUNS = (
    "cem/darwin_walk/K50_n0.8_e2_seed0",
    "cmaes/darwin_walk/K50_s1_seed0",
    "cmaes/darwin_walk_randomized/K50_s1_seed1",
    "cmaes/darwin_walk_randomized/K50_s1_feedback_seed1",
    "ppo/darwin_walk/cpg_seed0",
    "ppo_mjx/darwin_walk/cpg_seed0",
)
VARIANTS = (
    "nominal",
    "rough",
    "rough_2mm",
    "rough_1mm",
    "no_plane",
    "flat_tiles",
    "rough_elliptic",
    "box_floor",
)
ROUGH = "darwin_walk_rough"
NOMINAL = "darwin_walk"
RIM = 0.001  # m: a top-face contact this close to the tile's boundary rests on its edge
SIDE_NZ = math.cos(math.radians(45.0))  # |normal z| below this: a tile's side face
EDGE_FRACTION = 0.9  # of the sole's half-length/width: a contact point on the sole's edge
ONSET_TILT = 15.0  # deg: the onset of the fall is the last step with the torso tilt below
DIVERGE = 5.0  # deg: the rough and nominal trials' attitudes differ from here on
LOWERED_PLANE = -0.01  # m: the plane's height in the no_plane and flat_tiles variants
STANCE = 0.05  # of body weight: a foot carrying more is in stance

# Contact kinds.
PLANE, PLANE_UNDER_TILE, TOP, RIM_TOP, SIDE = range(5)
KIND_NAMES = ("plane", "plane under a raised tile", "tile top", "tile rim", "tile side")


@dataclasses.dataclass(frozen=True)
class Settings:
    """What to run.

    Attributes:
      runs: Shipped runs under `verify.ARTIFACTS`, comma-separated.
      anatomy: Failing rough trials dissected per run (0: none).
      seeds: First rough-tier seeds of each run's trials.csv for the variants (0: none).
      variants: The grounds, comma-separated (`VARIANTS`).
      out: CSV file for the variants' per-trial rows (empty: none).
    """

    runs: str = ",".join(RUNS)
    anatomy: int = 4
    seeds: int = 10
    variants: str = ",".join(VARIANTS)
    out: str = ""

    def __post_init__(self):
        cli.require(self.anatomy >= 0, f"--anatomy must be ≥ 0, got {self.anatomy}")
        cli.require(self.seeds >= 0, f"--seeds must be ≥ 0, got {self.seeds}")
        unknown = [v for v in self.variants.split(",") if v not in VARIANTS]
        cli.require(not unknown, f"unknown --variants {unknown}; valid: {', '.join(VARIANTS)}")


def load_policy(run_dir: str):
    """The run's selected policy, or its gait as a policy (open loop or feedback CPG)."""
    policy = verify.shipped_policy(run_dir)
    if policy is not None:
        return policy
    controller = verify.run_settings(run_dir).controller
    params = verify.gait_params(run_dir, controller)
    if controller == "feedback":
        return FeedbackPolicy(params)
    return score.OpenLoopPolicy(params)


def rough_trials(run_dir: str) -> list[dict]:
    """The run's rough-tier rows of trials.csv, in file order."""
    with open(os.path.join(run_dir, "trials.csv"), encoding="utf-8") as f:
        return [r for r in csv.DictReader(f) if r["tier"] == ROUGH]


def scored_trials(run_dir: str) -> dict:
    """The run's scored trials of the nominal and rough tiers: {variant: {seed: row}}."""
    with open(os.path.join(run_dir, "trials.csv"), encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    return {
        variant: {int(r["seed"]): r for r in rows if r["tier"] == tier}
        for variant, tier in (("nominal", NOMINAL), ("rough", ROUGH))
    }


def roll_pitch(q: np.ndarray) -> tuple[float, float]:
    """Torso roll (+: leaning to its right side down... about +x) and pitch (+: nose down),
    deg, from the (w, x, y, z) quaternion."""
    w, x, y, z = q
    roll = math.degrees(math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y)))
    pitch = math.degrees(math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x)))))
    return roll, pitch


def tilt(q: np.ndarray) -> float:
    """Angle of the torso's z axis from vertical, deg."""
    return math.degrees(math.acos(max(-1.0, min(1.0, float(darwin.torso_upright(q))))))


class Ground:
    """The tiles' grid of a physics: which tile holds a point, and its top's height."""

    def __init__(self, physics):
        self.terrain = perturbations.Terrain()
        self.tiles = physics._tiles
        self.first = int(self.tiles[0]) if len(self.tiles) else -1
        xs = np.arange(
            self.terrain.x_range[0] + self.terrain.tile / 2, self.terrain.x_range[1], 0.2
        )
        ys = np.arange(
            self.terrain.y_range[0] + self.terrain.tile / 2, self.terrain.y_range[1], 0.2
        )
        self.nx, self.ny = len(xs), len(ys)
        self.update(physics)

    def update(self, physics) -> None:
        """Reads the tiles' tops (a tile below the plane has height 0)."""
        tops = physics.model.geom_pos[self.tiles, 2] + perturbations.TILE_DEPTH
        self.tops = np.where(tops > -0.01, tops, 0.0)
        self.raised = tops > 0.0

    def tile_at(self, x: float, y: float) -> int:
        """Index (0-based among the tiles) of the tile under (x, y), -1 outside the grid."""
        t = self.terrain
        ix = math.floor((x - t.x_range[0]) / t.tile)
        iy = math.floor((y - t.y_range[0]) / t.tile)
        if len(self.tiles) and 0 <= ix < self.nx and 0 <= iy < self.ny:
            return ix * self.ny + iy
        return -1


def sole_region(local: np.ndarray, half: np.ndarray, foot: int) -> str:
    """Where on the sole a contact lies: toe/heel, inner/outer edge, a corner, or inside."""
    ex = abs(local[0]) > EDGE_FRACTION * half[0]
    ey = abs(local[1]) > EDGE_FRACTION * half[1]
    along = "toe" if local[0] > 0 else "heel"
    outer = (local[1] > 0) == (foot == 0)  # the left foot's outer edge is at +y
    across = "outer" if outer else "inner"
    if ex and ey:
        return f"{along}-{across} corner"
    if ex:
        return f"{along} edge"
    if ey:
        return f"{across} edge"
    return "inside"


class Recorder:
    """The per-physics-step record of `score.step_policy`: torso attitude, feet, contacts."""

    def __init__(self, physics, ground: Ground):
        self.physics, self.ground = physics, ground
        model = physics.model
        self.feet = [int(g) for g in physics._feet]
        self.half = [model.geom_size[g][:2].copy() for g in self.feet]
        self.floor = int(physics._floor)
        self.tiles = set(int(t) for t in ground.tiles)
        self.weight = physics._weight
        self._force = np.zeros(6)
        self._vel = np.zeros(6)

    def __call__(self, physics) -> tuple:
        m, d = physics.model.ptr, physics.data.ptr
        contacts = []
        for i in range(d.ncon):
            c = d.contact[i]
            g1, g2 = int(c.geom[0]), int(c.geom[1])
            if g1 in self.feet and (g2 == self.floor or g2 in self.tiles):
                foot, other = self.feet.index(g1), g2
            elif g2 in self.feet and (g1 == self.floor or g1 in self.tiles):
                foot, other = self.feet.index(g2), g1
            else:
                continue
            mujoco.mj_contactForce(m, d, i, self._force)
            fn = float(self._force[0])
            if fn <= 0.0:
                continue
            pos, normal = c.pos.copy(), c.frame[:3].copy()
            geom = self.feet[foot]
            mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_GEOM, geom, self._vel, 0)
            v = self._vel[3:] + np.cross(self._vel[:3], pos - d.geom_xpos[geom])
            slip = float(np.linalg.norm(v - np.dot(v, normal) * normal))
            rot = d.geom_xmat[geom].reshape(3, 3)
            local = rot.T @ (pos - d.geom_xpos[geom])
            region = sole_region(local, self.half[foot], foot)
            tile = self.ground.tile_at(pos[0], pos[1])
            if other == self.floor:
                under_raised = tile >= 0 and self.ground.raised[tile]
                kind, top = (PLANE_UNDER_TILE if under_raised else PLANE), 0.0
            else:
                t = other - self.ground.first
                centre = m.geom_pos[other]
                top = float(self.ground.tops[t])
                rim = 0.1 - max(abs(pos[0] - centre[0]), abs(pos[1] - centre[1]))
                if abs(normal[2]) < SIDE_NZ:
                    kind = SIDE
                else:
                    kind = RIM_TOP if rim < RIM else TOP
                tile = t
            contacts.append((foot, kind, tile, top, fn, slip, region))
        q = d.qpos[3:7].copy()
        return q, float(d.qpos[2]), contacts


def foot_loads(contacts) -> list[float]:
    """Each foot's total normal force, N."""
    load = [0.0, 0.0]
    for foot, _, _, _, fn, _, _ in contacts:
        load[foot] += fn
    return load


def window_summary(records: list, start: int, stop: int, weight: float, dt: float) -> dict:
    """The contact measures over the physics steps [start, stop)."""
    out = {
        "slip_m": [0.0, 0.0],
        "stance_steps": [0, 0],
        "rim_stance": [0, 0],
        "straddle_stance": [0, 0],
        "step_mm": [0.0, 0.0],
        "plane_under_tile_N": 0.0,
        "ground_N": 0.0,
        "side": [],
        "single_support": 0,
    }
    for k in range(start, stop):
        _, _, contacts = records[k]
        load = foot_loads(contacts)
        stance = [f > STANCE * weight for f in load]
        out["single_support"] += sum(stance) == 1
        for foot in (0, 1):
            mine = [c for c in contacts if c[0] == foot]
            if stance[foot]:
                out["stance_steps"][foot] += 1
                out["slip_m"][foot] += dt * sum(c[4] * c[5] for c in mine) / load[foot]
                top_force = sum(c[4] for c in mine if c[1] in (TOP, RIM_TOP))
                rim_force = sum(c[4] for c in mine if c[1] == RIM_TOP)
                if rim_force > 0.5 * max(top_force, 1e-12) and top_force > 0:
                    out["rim_stance"][foot] += 1
                tiles = {c[2] for c in mine if c[1] in (TOP, RIM_TOP, SIDE)}
                if len(tiles) > 1:
                    out["straddle_stance"][foot] += 1
                tops = [c[3] for c in mine]
                out["step_mm"][foot] = max(out["step_mm"][foot], 1e3 * (max(tops) - min(tops)))
            for c in mine:
                out["ground_N"] += c[4]
                if c[1] == PLANE_UNDER_TILE:
                    out["plane_under_tile_N"] += c[4]
                if c[1] == SIDE:
                    before = records[max(start, k - 10) : k]
                    swing = all(foot_loads(r[2])[foot] < STANCE * weight for r in before)
                    out["side"].append((k, foot, c[6], swing, c[4]))
    return out


def attitude(records: list, k: int) -> tuple[float, float]:
    return roll_pitch(records[k][0])


def record_trial(policy, tier: str, seed: int, task_kwargs: dict) -> tuple:
    """A trial stepped as the score card steps it, with the `Recorder`'s per-step record."""
    env, observation, n_sub = score.start_trial(policy, tier, seed, task_kwargs)
    ground = Ground(env.physics)
    recorder = Recorder(env.physics, ground)
    _, (fall_step, cause), records = score.step_policy(
        policy, env.task, env.physics, observation, 1000, n_sub, record=recorder
    )
    return fall_step, cause, records, n_sub, env.physics


def anatomy(policy, seed: int, expected_fall: int, task_kwargs: dict) -> dict:
    """The failing rough trial's last second, and the same seed's nominal trial."""
    fall_step, cause, records, n_sub, physics = record_trial(policy, ROUGH, seed, task_kwargs)
    assert fall_step == expected_fall, (seed, fall_step, expected_fall)  # as the card scored it
    dt = float(physics.model.opt.timestep)
    weight = physics._weight
    n = len(records)
    second = int(round(1.0 / dt))
    start = max(0, n - second)
    tilts = [tilt(r[0]) for r in records]
    onset = max((k for k in range(n) if tilts[k] < ONSET_TILT), default=0)
    at = {}
    for label, back in (("-1s", second), ("-0.5s", second // 2), ("-0.25s", second // 4)):
        at[label] = attitude(records, max(0, n - back))
    at["fall"] = attitude(records, n - 1)
    at["onset"] = attitude(records, onset)
    roll, pitch = at["fall"]
    if abs(pitch) >= abs(roll):
        direction = "backward" if pitch < 0 else "forward"
    else:
        direction = "to its right" if roll > 0 else "to its left"
    rough = window_summary(records, start, n, weight, dt)
    last_load = foot_loads(records[onset][2])
    stance_at_onset = [f > STANCE * weight for f in last_load]
    onset_contacts = [c for c in records[onset][2]]

    nominal_fall, _, nominal_records, _, _ = record_trial(policy, NOMINAL, seed, task_kwargs)
    m = min(n, len(nominal_records))
    nominal = window_summary(nominal_records, max(0, m - second), m, weight, dt)
    diverge = next(
        (
            k
            for k in range(m)
            if max(abs(a - b) for a, b in zip(attitude(records, k), attitude(nominal_records, k)))
            > DIVERGE
        ),
        None,
    )
    nominal_att = [attitude(nominal_records, k) for k in range(max(0, m - second), m)]
    return {
        "seed": seed,
        "fall_step": fall_step,
        "direction": direction,
        "at": at,
        "onset_before_fall_s": (n - 1 - onset) * dt,
        "stance_at_onset": stance_at_onset,
        "load_at_onset": last_load,
        "onset_contacts": onset_contacts,
        "rough": rough,
        "nominal": nominal,
        "nominal_fell": nominal_fall,
        "nominal_max_roll": max(abs(a[0]) for a in nominal_att),
        "nominal_max_pitch": max(abs(a[1]) for a in nominal_att),
        "diverge_s": None if diverge is None else diverge * dt,
        "fall_s": n * dt,
        "dt": dt,
        "n_sub": n_sub,
    }


def format_anatomy(run: str, a: dict) -> str:
    """One failing trial's block."""
    feet = "LR"
    lines = [
        f"{run} seed {a['seed']}: fell at control step {a['fall_step']} "
        f"({a['fall_s']:.2f} s), {a['direction']}; onset (tilt < {ONSET_TILT:.0f} deg last) "
        f"{a['onset_before_fall_s']:.2f} s before the fall; nominal same seed: "
        + (f"fell at step {a['nominal_fell']}" if a["nominal_fell"] else "walked")
        + (
            f"; attitudes part (> {DIVERGE:.0f} deg) at {a['diverge_s']:.2f} s"
            if a["diverge_s"] is not None
            else "; attitudes never part"
        )
    ]
    lines.append(
        "  roll/pitch deg: "
        + ", ".join(f"{k} {r:+.1f}/{p:+.1f}" for k, (r, p) in a["at"].items())
        + f"; nominal's last second max |roll| {a['nominal_max_roll']:.1f}, "
        f"|pitch| {a['nominal_max_pitch']:.1f}"
    )
    stance = "+".join(feet[f] for f in (0, 1) if a["stance_at_onset"][f]) or "none"
    where = collections.Counter(
        f"{feet[c[0]]} {KIND_NAMES[c[1]]} @ {c[6]}" for c in a["onset_contacts"]
    )
    lines.append(
        f"  at the onset: stance {stance} (loads L {a['load_at_onset'][0]:.1f} N, "
        f"R {a['load_at_onset'][1]:.1f} N); contacts: "
        + (", ".join(f"{k} x{v}" for k, v in sorted(where.items())) or "none")
    )
    for label in ("rough", "nominal"):
        w = a[label]
        side = w["side"]
        trips = sorted({(feet[f], region, swing) for _, f, region, swing, _ in side})
        first = (a["fall_s"] - min(k for k, *_ in side) * a["dt"]) if side else None
        plane = w["plane_under_tile_N"] / max(w["ground_N"], 1e-12)
        lines.append(
            f"  {label:<7} last 1 s: stance steps L/R {w['stance_steps'][0]}/"
            f"{w['stance_steps'][1]}, single support {w['single_support']}; "
            f"slip L/R {w['slip_m'][0] * 1e3:.1f}/{w['slip_m'][1] * 1e3:.1f} mm; "
            f"on a rim L/R {w['rim_stance'][0]}/{w['rim_stance'][1]}; "
            f"straddling L/R {w['straddle_stance'][0]}/{w['straddle_stance'][1]}; "
            f"step under a foot L/R {w['step_mm'][0]:.2f}/{w['step_mm'][1]:.2f} mm; "
            f"plane under raised tiles {100 * plane:.1f} % of the load; "
            f"side contacts {len(side)} steps"
            + (
                f" (first {first:.2f} s before the fall: "
                + ", ".join(f"{f} {r}{' in swing' if s else ''}" for f, r, s in trips)
                + ")"
                if side
                else ""
            )
        )
    return "\n".join(lines)


def summarize_anatomy(run: str, dissected: list[dict]) -> str:
    """A run's failing trials together: directions, onsets, trips, rims, slip, attitude."""
    n = len(dissected)
    directions = collections.Counter(a["direction"] for a in dissected)
    trips = sum(bool(a["rough"]["side"]) for a in dissected)
    swing_trips = sum(any(s for *_, s, _ in a["rough"]["side"]) for a in dissected)

    def share(a, key):
        stance = sum(a["rough"]["stance_steps"])
        return sum(a["rough"][key]) / max(stance, 1)

    def slip(a, label):
        return sum(a[label]["slip_m"]) * 1e3

    def plane(a):
        return a["rough"]["plane_under_tile_N"] / max(a["rough"]["ground_N"], 1e-12)

    onset_att = [a["at"]["onset"] for a in dissected]
    rim = 100 * np.mean([share(a, "rim_stance") for a in dissected])
    straddle = 100 * np.mean([share(a, "straddle_stance") for a in dissected])
    under = 100 * np.mean([plane(a) for a in dissected])
    lead = [a["fall_s"] - a["diverge_s"] for a in dissected if a["diverge_s"] is not None]
    nominal_falls = sum(bool(a["nominal_fell"]) for a in dissected)
    regions = [[c[6] for c in a["onset_contacts"]] for a in dissected]
    heel = sum(bool(r) and all(x.startswith("heel") for x in r) for r in regions)
    toe = sum(bool(r) and all(x.startswith("toe") for x in r) for r in regions)
    rim_onset = sum(any(c[1] == RIM_TOP for c in a["onset_contacts"]) for a in dissected)
    return (
        f"{run}: {n} falls dissected: "
        + ", ".join(f"{k} {v}" for k, v in directions.most_common())
        + f"; at the onset every sole contact under the heel in {heel}, under the toe in {toe},"
        f" one on a tile's rim in {rim_onset}"
        f"; onset {np.median([a['onset_before_fall_s'] for a in dissected]):.2f} s (median)"
        f" before the fall; trials with a tile-side contact in the last 1 s {trips}"
        f" (by a swinging foot {swing_trips}); stance on a rim {rim:.0f} %,"
        f" straddling two tiles {straddle:.0f} %; plane under raised tiles {under:.1f} %"
        f"; slip (both feet) {np.mean([slip(a, 'rough') for a in dissected]):.1f} mm rough vs "
        f"{np.mean([slip(a, 'nominal') for a in dissected]):.1f} mm nominal"
        f"; at the onset |roll| {np.median([abs(r) for r, _ in onset_att]):.1f},"
        f" |pitch| {np.median([abs(p) for _, p in onset_att]):.1f} deg (median); nominal's last"
        f" 1 s max |roll| {np.median([a['nominal_max_roll'] for a in dissected]):.1f},"
        f" |pitch| {np.median([a['nominal_max_pitch'] for a in dissected]):.1f} deg (median)"
        f"; attitudes part from nominal {np.median(lead) if lead else float('nan'):.2f} s"
        f" (median) before the fall; nominal same seeds fell {nominal_falls}/{n}"
    )


def apply_variant(env, variant: str) -> None:
    """Changes the trial's model copy after its reset (see the module docstring)."""
    physics = env.physics
    model = physics.model
    tiles = physics._tiles
    if variant in ("rough_2mm", "rough_1mm"):
        scale = {"rough_2mm": 2.0 / 3.0, "rough_1mm": 1.0 / 3.0}[variant]
        tops = model.geom_pos[tiles, 2] + perturbations.TILE_DEPTH
        heights = np.where(tops > 0.0, tops, 0.0) * scale
        model.geom_pos[tiles, 2] = perturbations.tile_heights_to_z(heights)
    elif variant in ("no_plane", "flat_tiles"):
        floor = physics._floor
        model.geom_sameframe[floor] = 0  # else MuJoCo keeps the plane at its body's frame
        model.geom_pos[floor, 2] = LOWERED_PLANE
        tops = model.geom_pos[tiles, 2] + perturbations.TILE_DEPTH
        if variant == "flat_tiles":
            tops[:] = 0.0
        tops = np.where(tops > 0.0, tops, 0.0)
        model.geom_pos[tiles, 2] = tops - perturbations.TILE_DEPTH
    elif variant == "rough_elliptic":
        model.opt.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
        model.opt.impratio = 10.0
    mujoco.mj_forward(model.ptr, physics.data.ptr)


def box_floor_start(policy, seed: int, task_kwargs: dict) -> tuple:
    """`score.start_trial` of darwin_walk on a model whose floor is one box, not a plane."""
    xml, assets = darwin.get_model_and_assets()
    plane = 'name="floor" type="plane" size="25 25 0.1"'
    assert plane in xml, "the floor's MJCF changed"
    xml = xml.replace(plane, 'name="floor" type="box" size="25 25 0.1" pos="0 0 -0.1"')
    physics = darwin_tasks.Physics.from_xml_string(xml, assets)
    task = darwin_tasks.CPGTask("walk", random=seed, **task_kwargs)
    env = base.make_environment(physics, task, float("inf"), darwin.CONTROL_TIMESTEP)
    if hasattr(policy, "reset"):
        policy.reset()
    observation = env.reset().observation
    n_sub = int(round(env.control_timestep() / physics.model.opt.timestep))
    return env, observation, n_sub


def variant_trial(policy, variant: str, seed: int, task_kwargs: dict) -> tuple[int, float]:
    """(fall step or 0, distance m) of one trial on one variant's ground."""
    if variant == "box_floor":
        env, observation, n_sub = box_floor_start(policy, seed, task_kwargs)
    else:
        tier = NOMINAL if variant == "nominal" else ROUGH
        env, observation, n_sub = score.start_trial(policy, tier, seed, task_kwargs)
    if variant not in ("nominal", "rough", "box_floor"):
        apply_variant(env, variant)
    start = env.physics.torso_position().copy()
    last, (fall_step, _), _ = score.step_policy(
        policy, env.task, env.physics, observation, 1000, n_sub, record=lambda p: None
    )
    distance = 0.0 if last is None else float(last[0] - start[0])
    return fall_step, distance


def define_flags() -> None:
    """Defines the flags (only when run as a program)."""
    d = Settings()
    flags.DEFINE_string("runs", d.runs, "Shipped runs under results/protocol/runs.")
    flags.DEFINE_integer("anatomy", d.anatomy, "Failing rough trials dissected per run.")
    flags.DEFINE_integer("seeds", d.seeds, "First rough-tier seeds per run for the variants.")
    flags.DEFINE_string("variants", d.variants, "Grounds, comma-separated.")
    flags.DEFINE_string("out", d.out, "CSV file for the variants' per-trial rows.")


def main(argv):
    """Runs both parts and prints them."""
    del argv
    settings = cli.settings_from_flags(Settings)
    variants = settings.variants.split(",")
    rows, table, summaries = [], [], []
    for run in settings.runs.split(","):
        run_dir = os.path.join(ROOT, run)
        cli.check(os.path.isdir(run_dir), f"no run {run_dir}")
        task_kwargs = verify.run_settings(run_dir).task_kwargs()
        policy = load_policy(run_dir)
        threads = (
            verify.policy_threads(run_dir)
            if verify.shipped_policy(run_dir) is not None
            else contextlib.nullcontext()
        )
        trials = rough_trials(run_dir)
        with threads:
            failing = [r for r in trials if r["fell"] == "True"][: settings.anatomy]
            dissected = []
            for r in failing:
                a = anatomy(policy, int(r["seed"]), int(r["fall_step"]), task_kwargs)
                print(format_anatomy(run, a), flush=True)
                dissected.append(a)
            if dissected:
                summaries.append(summarize_anatomy(run, dissected))
            falls = collections.Counter()
            distance = collections.defaultdict(list)
            scored = scored_trials(run_dir)
            for r in trials[: settings.seeds]:
                seed = int(r["seed"])
                for variant in variants:
                    if variant in scored:  # the card's own trial
                        row = scored[variant][seed]
                        fall_step, d = int(row["fall_step"]), float(row["distance_m"])
                    else:
                        fall_step, d = variant_trial(policy, variant, seed, task_kwargs)
                    falls[variant] += bool(fall_step)
                    distance[variant].append(d)
                    rows.append(
                        {
                            "run": run,
                            "seed": seed,
                            "variant": variant,
                            "fall_step": fall_step,
                            "distance_m": d,
                        }
                    )
        if settings.seeds:
            n = min(settings.seeds, len(trials))
            table.append(
                f"{run:<52}"
                + "".join(f"{f'{falls[v]}/{n} {np.mean(distance[v]):.2f}':>16}" for v in variants)
            )
    if summaries:
        print("\nthe last second before the fall, per run (failing rough trials dissected)")
        for line in summaries:
            print(line)
    if table:
        print(f"\nfalls / trials, mean distance m (first {settings.seeds} rough-tier seeds)")
        print(f"{'run':<52}" + "".join(f"{v:>16}" for v in variants))
        for line in table:
            print(line)
    if settings.out:
        with open(settings.out, "w", newline="", encoding="utf-8") as f:
            writer = csv.DictWriter(
                f, fieldnames=("run", "seed", "variant", "fall_step", "distance_m")
            )
            writer.writeheader()
            writer.writerows(rows)


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_files=("out",))
