r"""Does the model's contact creep, and do the ranked gaits depend on its contact model?

  python investigations/creep.py [--parts=box,stand,gaits] [--seeds=4] [--out=FILE]

Its findings and the commands behind them: docs/contact.md.

MuJoCo's contacts are soft: a friction force is bought with a small slip velocity, so a body
held below its friction limit can creep. The benchmark's contact is MuJoCo's default
pyramidal cone, condim 3, impratio 1, friction 1.0, the robot's solref 0.008 s against the
floor's default 0.02 s (mixed: 0.014 s), docs/darwin_op_model.md#contacts-timing-sensors.
Three parts, each printing a table:

* `box`: a free box of the sole's size and friction (`foot_l`) carrying the whole robot's
  weight (2.925 kg) on the floor plane, the floor tilted by 5-40 deg (gravity rotated; the
  friction limit is 45 deg at friction 1.0): its creep speed down the slope, mm/s, from 0.5 s
  to 5.5 s, with the benchmark's cone and with an elliptic cone at impratio 1, 10 and 100.
* `stand`: first the robot standing 1 s on the level floor (contacts per sole, their
  penetration), then the robot standing in the task's starting posture, servos holding it, the floor
  tilted 2-8 deg forward (toes down) or sideways: each sole's drift from 1 s to 5 s, mm/s
  (a sole that creeps moves; a tilted one that tips over is reported as a fall).
* `gaits`: the selected gaits of the CEM main job's run and the 4x track's first CMA-ES
  run on the first `--seeds` nominal test seeds under contact variants: the benchmark's,
  an elliptic cone at impratio 10 and 100, friction 0.6 and 0.8, and contact time constants
  of 0.004 s and 0.02 s (robot and floor alike): falls, distance and the stance feet's
  contact-point slip (the sole's velocity at each floor contact, tangential, weighted by
  the contact's share of the foot's normal force, summed over the physics steps of
  feet carrying more than 5 % of the weight), m per metre walked.

Every variant changes a copy of a model (the trial's, after its reset); the benchmark's
model and tasks are not changed.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import csv
import dataclasses
import math
import os

import mujoco
import numpy as np
from absl import flags

import cpg_suite
from cpg_suite import cli, darwin, protocol
from cpg_suite.darwin import perturb
from cpg_suite.protocol import score, verify

PARTS = ("box", "stand", "gaits")
CONES = (  # (name, cone, impratio)
    ("pyramidal, impratio 1 (benchmark)", mujoco.mjtCone.mjCONE_PYRAMIDAL, 1.0),
    ("elliptic, impratio 1", mujoco.mjtCone.mjCONE_ELLIPTIC, 1.0),
    ("elliptic, impratio 10", mujoco.mjtCone.mjCONE_ELLIPTIC, 10.0),
    ("elliptic, impratio 100", mujoco.mjtCone.mjCONE_ELLIPTIC, 100.0),
)
BOX_SLOPES = (5.0, 10.0, 20.0, 30.0, 40.0)  # deg
STAND_SLOPES = (2.0, 4.0, 6.0, 8.0)  # deg
ROBOT_MASS = 2.925  # kg (docs/darwin_op_model.md)
GAIT_RUNS = (
    "cem/darwin_walk/K50_n0.8_e2_seed0",
    "cmaes/darwin_walk_randomized/K50_s1_seed0",
)
GAIT_VARIANTS = (
    "benchmark",
    "elliptic_impratio10",
    "elliptic_impratio100",
    "friction0.6",
    "friction0.8",
    "timeconst0.004",
    "timeconst0.02",
)
STANCE = 0.05  # of body weight: a foot carrying more is in stance


@dataclasses.dataclass(frozen=True)
class Settings:
    """What to run.

    Attributes:
      parts: The parts, comma-separated (`PARTS`).
      seeds: Nominal test seeds per gait in the `gaits` part.
      out: CSV file for the `gaits` part's per-trial rows (empty: none).
    """

    parts: str = ",".join(PARTS)
    seeds: int = 4
    out: str = ""

    def __post_init__(self):
        unknown = [p for p in self.parts.split(",") if p not in PARTS]
        cli.require(not unknown, f"unknown --parts {unknown}; valid: {', '.join(PARTS)}")
        cli.require(1 <= self.seeds <= len(protocol.TEST), f"--seeds out of range: {self.seeds}")


def set_cone(model, cone, impratio: float) -> None:
    """The friction cone and impratio of a model (`mjModel` or dm_control's wrapper)."""
    model.opt.cone = cone
    model.opt.impratio = impratio


def box_xml(slope_deg: float) -> str:
    """The floor plane and a sole-sized box, gravity tilted by `slope_deg` along +x."""
    xml, assets = darwin.get_model_and_assets()
    foot = mujoco.MjModel.from_xml_string(xml, assets).geom("foot_l")
    sx, sy, sz = (float(v) for v in foot.size)
    mu = " ".join(str(float(v)) for v in foot.friction)
    solref = " ".join(str(float(v)) for v in foot.solref)
    g = 9.81
    gx, gz = g * math.sin(math.radians(slope_deg)), -g * math.cos(math.radians(slope_deg))
    return f"""<mujoco><option timestep="0.002" integrator="implicitfast" gravity="{gx} 0 {gz}"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1" friction="1.0 0.005 0.0001"/>
    <body name="sole" pos="0 0 {sz}"><freejoint/>
      <geom type="box" size="{sx} {sy} {sz}" mass="{ROBOT_MASS}" friction="{mu}"
            solref="{solref}"/>
    </body>
  </worldbody></mujoco>"""


def box_creep(slope_deg: float, cone, impratio: float) -> float:
    """The box's mean speed down the slope from 0.5 s to 5.5 s, mm/s."""
    model = mujoco.MjModel.from_xml_string(box_xml(slope_deg))
    set_cone(model, cone, impratio)
    data = mujoco.MjData(model)
    for _ in range(250):
        mujoco.mj_step(model, data)
    x0 = data.qpos[0]
    for _ in range(2500):
        mujoco.mj_step(model, data)
    return 1e3 * (data.qpos[0] - x0) / 5.0


def box_part() -> list[str]:
    lines = [
        "box of the sole's size, 2.925 kg, on the plane tilted (friction limit 45 deg):"
        " creep down the slope, mm/s (0.5-5.5 s)",
        f"{'cone':<36}" + "".join(f"{f'{s:.0f} deg':>12}" for s in BOX_SLOPES),
        f"{'  tangential / friction limit':<36}"
        + "".join(f"{math.tan(math.radians(s)):>12.2f}" for s in BOX_SLOPES),
    ]
    for name, cone, impratio in CONES:
        speeds = [box_creep(s, cone, impratio) for s in BOX_SLOPES]
        lines.append(f"{name:<36}" + "".join(f"{v:>12.4f}" for v in speeds))
    return lines


def stand_drift(direction: str, slope_deg: float, cone, impratio: float) -> tuple:
    """The standing robot on the tilted floor: (fell, left sole mm/s, right sole mm/s)."""
    env = cpg_suite.load("darwin_walk", task_kwargs={"random": 0})
    env.reset()
    physics = env.physics
    model, data = physics.model.ptr, physics.data.ptr
    set_cone(model, cone, impratio)
    s, c = math.sin(math.radians(slope_deg)), math.cos(math.radians(slope_deg))
    model.opt.gravity[:] = (
        (9.81 * s, 0.0, -9.81 * c) if direction == "x" else (0.0, 9.81 * s, -9.81 * c)
    )
    mujoco.mj_forward(model, data)
    soles = physics._soles
    fell = False
    for _ in range(500):
        mujoco.mj_step(model, data)
    start = data.site_xpos[soles, :2].copy()
    for _ in range(2000):
        mujoco.mj_step(model, data)
        fell = fell or bool(darwin.has_fallen(data.qpos[:7]))
    moved = np.linalg.norm(data.site_xpos[soles, :2] - start, axis=1) * 1e3 / 4.0
    return fell, float(moved[0]), float(moved[1])


def level_contacts() -> tuple[list[int], float, float]:
    """The robot standing 1 s on the level floor: contacts per foot, the deepest and the
    shallowest penetration, mm."""
    env = cpg_suite.load("darwin_walk", task_kwargs={"random": 0})
    env.reset()
    physics = env.physics
    model, data = physics.model.ptr, physics.data.ptr
    for _ in range(500):
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    feet = [int(g) for g in physics._feet]
    counts, depths = [0, 0], []
    for i in range(data.ncon):
        g1, g2 = (int(g) for g in data.contact[i].geom)
        for foot, geom in enumerate(feet):
            if geom in (g1, g2):
                counts[foot] += 1
                depths.append(-1e3 * float(data.contact[i].dist))
    return counts, max(depths), min(depths)


def stand_part() -> list[str]:
    counts, deepest, shallowest = level_contacts()
    lines = [
        f"the robot standing 1 s on the level floor: contacts left/right {counts[0]}/"
        f"{counts[1]}, penetration {shallowest:.3f}-{deepest:.3f} mm",
        "the robot standing on the tilted floor (starting posture held): sole drift, mm/s"
        " (1-5 s), left/right; 'fell' if it tipped over",
        f"{'cone':<36}{'tilt':>20}" + "".join(f"{f'{s:.0f} deg':>16}" for s in STAND_SLOPES),
    ]
    for name, cone, impratio in CONES:
        for direction, label in (("x", "forward (toes down)"), ("y", "sideways")):
            cells = []
            for slope in STAND_SLOPES:
                fell, left, right = stand_drift(direction, slope, cone, impratio)
                cells.append("fell" if fell else f"{left:.3f}/{right:.3f}")
            lines.append(f"{name:<36}{label:>20}" + "".join(f"{c:>16}" for c in cells))
    return lines


def apply(physics, variant: str) -> None:
    """A gait variant's contact, on the trial's model copy."""
    model = physics.model
    if variant.startswith("elliptic_impratio"):
        set_cone(
            model, mujoco.mjtCone.mjCONE_ELLIPTIC, float(variant.removeprefix("elliptic_impratio"))
        )
    elif variant.startswith("friction"):
        perturb.set_ground_friction(physics, float(variant.removeprefix("friction")))
    elif variant.startswith("timeconst"):
        ground = np.array([physics._floor, *physics._feet], int)
        model.geom_solref[ground, 0] = float(variant.removeprefix("timeconst"))
    mujoco.mj_forward(model.ptr, physics.data.ptr)


class SlipRecorder:
    """Per physics step: the stance feet's contact-point slip speeds, force-weighted, m/s."""

    def __init__(self, physics):
        self.feet = [int(g) for g in physics._feet]
        self.floor = int(physics._floor)
        self.threshold = STANCE * physics._weight
        self._f = np.zeros(6)
        self._v = np.zeros(6)

    def __call__(self, physics) -> float:
        m, d = physics.model.ptr, physics.data.ptr
        load, weighted = [0.0, 0.0], [0.0, 0.0]
        for i in range(d.ncon):
            c = d.contact[i]
            g1, g2 = int(c.geom[0]), int(c.geom[1])
            if g1 == self.floor and g2 in self.feet:
                foot = self.feet.index(g2)
            elif g2 == self.floor and g1 in self.feet:
                foot = self.feet.index(g1)
            else:
                continue
            mujoco.mj_contactForce(m, d, i, self._f)
            if self._f[0] <= 0.0:
                continue
            geom = self.feet[foot]
            mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_GEOM, geom, self._v, 0)
            v = self._v[3:] + np.cross(self._v[:3], c.pos - d.geom_xpos[geom])
            n = c.frame[:3]
            load[foot] += self._f[0]
            weighted[foot] += self._f[0] * float(np.linalg.norm(v - np.dot(v, n) * n))
        return sum(w / f for w, f in zip(weighted, load) if f > self.threshold)


def gait_trial(policy, variant: str, seed: int, task_kwargs: dict) -> dict:
    env, observation, n_sub = score.start_trial(policy, "darwin_walk", seed, task_kwargs)
    physics = env.physics
    if variant != "benchmark":
        apply(physics, variant)
    start = physics.torso_position().copy()
    last, (fall_step, _), speeds = score.step_policy(
        policy, env.task, physics, observation, 1000, n_sub, record=SlipRecorder(physics)
    )
    distance = 0.0 if last is None else float(last[0] - start[0])
    slip = float(np.sum(speeds)) * float(physics.model.opt.timestep)
    return {"fall_step": fall_step, "distance_m": distance, "slip_m": slip}


def gaits_part(seeds: int, rows: list) -> list[str]:
    lines = [
        f"gaits on the nominal tier, first {seeds} test seeds: falls, mean distance m,"
        " contact-point slip of the stance feet per metre walked (walking trials)",
        f"{'run':<44}" + "".join(f"{v:>24}" for v in GAIT_VARIANTS),
    ]
    for run in GAIT_RUNS:
        run_dir = os.path.join(verify.ARTIFACTS, run)
        settings = verify.run_settings(run_dir)
        policy = score.OpenLoopPolicy(verify.gait_params(run_dir, settings.controller))
        cells = []
        for variant in GAIT_VARIANTS:
            trials = []
            for seed in protocol.held_out_seeds(seeds):
                t = gait_trial(policy, variant, seed, settings.task_kwargs())
                trials.append(t)
                rows.append({"run": run, "variant": variant, "seed": seed, **t})
            falls = sum(bool(t["fall_step"]) for t in trials)
            walked = [t for t in trials if not t["fall_step"] and t["distance_m"] > 0]
            per_m = np.mean([t["slip_m"] / t["distance_m"] for t in walked]) if walked else math.nan
            mean_d = np.mean([t["distance_m"] for t in trials])
            cells.append(f"{falls}/{seeds} {mean_d:.2f} m {per_m:.2f}/m")
        lines.append(f"{run:<44}" + "".join(f"{c:>24}" for c in cells))
    return lines


def define_flags() -> None:
    """Defines the flags (only when run as a program)."""
    d = Settings()
    flags.DEFINE_string("parts", d.parts, "Parts, comma-separated: box, stand, gaits.")
    flags.DEFINE_integer("seeds", d.seeds, "Nominal test seeds per gait (gaits part).")
    flags.DEFINE_string("out", d.out, "CSV file for the gaits part's per-trial rows.")


def main(argv):
    """Runs the parts and prints their tables."""
    del argv
    settings = cli.settings_from_flags(Settings)
    parts = settings.parts.split(",")
    rows: list[dict] = []
    if "box" in parts:
        print("\n".join(box_part()), flush=True)
    if "stand" in parts:
        print("\n".join(stand_part()), flush=True)
    if "gaits" in parts:
        print("\n".join(gaits_part(settings.seeds, rows)), flush=True)
    if settings.out:
        with open(settings.out, "w", newline="", encoding="utf-8") as f:
            writer = csv.DictWriter(
                f, fieldnames=("run", "variant", "seed", "fall_step", "distance_m", "slip_m")
            )
            writer.writeheader()
            writer.writerows(rows)


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_files=("out",))
