r"""Where the DARwIn-OP's centre of pressure sits under the CPG alone (claim CPG-4, issue 53).

  python investigations/cop_baseline.py                      # every case, seed 0 (about 1 min)
  python investigations/cop_baseline.py --seeds=0,1,2 --cases=stand,cpg,flexank_opposes

The thesis (Sec. 5.5, seed L1032) says the CPG alone already kept the COP close to the
stance foot's centre. Issue 53's goal: the balance reward's distance (`darwin_balance`) within
a third of the sole's half-length of the centre. Each case steps `darwin_balance` for 1000
control steps (θ = 0: the CPG alone, or the standing targets held) and prints, per foot,
over the control steps where the foot is a stance foot (> 5 % of the weight, the task's
rule): the median and 25/75/90th percentiles of the horizontal COP-to-sole-centre
distance, where the COP lies in the sole's own frame (|x| along, |y| across; the half-sizes
are 5.25 and 3.3 cm, so a value at them is an edge), the share of those steps whose floor
contact has at most 2 points (a box sole flat on the floor has 4: 1-2 points is a corner or
an edge), the foot's mean pitch and roll (degrees; pitch + = toe up, roll + = the sole's
+y side down), and the torso's mean pitch (+ = leaning back). Then, per case, the task's
reward per step with the sign removed (the number CPG-4 is judged on: `reward_before` of
the NAC runs), the force-weighted distance over both feet, and whether the robot fell.

The cases change one thing each (the thesis gives none of these; docs/decisions.md,
"Chapter 5's balance baseline (CPG-4)"):

* `stand`: the CPG's offsets held (no primitive): the static COP;
* `cpg`: the hand-tuned CPG as shipped (ω = 2π/1.1 s, β = 8 /s, crouch 23°, upright torso);
* `flexank_opposes`: the flexKnee primitive's ankle term (Eq. 5.10) opposes the knee's
  (Eq. 5.9) instead of adding to it, so the stance knee flexion no longer tilts the torso
  against the flat stance foot (A_flexAnk = −2 with `cpg`'s signs);
* `lean5` / `stand_lean5` (and `lean3`): the legs inclined 5° (3°) forward at the ankles,
  the hips extended as much, torso upright: the standing COM over the sole centres (a
  choice: the sweep of 3° and 5° is its sensitivity);
* `walk_ready`: offsets O = the ROBOTIS walking engine's walk-ready stance
  (the ROBOTIS walking engine's: torso 13° forward, knee 53°);
* `beta1`: β = 1 /s ≪ ω, so the sway (hip and ankle roll) peaks at mid-swing, as the
  primitives' design has it (β = 8 > ω puts it 54.5° of phase before, at 0.58 of A);
* `kp100`: servo gain 100 N·m/rad instead of 40 (physics: stiffer joints);
* `best`: what the sweep of issue 53 found lowest without a fall: flexank_opposes + lean5
  + beta1 with a 0.8 s stride.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys

import numpy as np

import cpg_suite
from cpg_suite import cpg

try:  # the darwin package (issue 53's move) or the modules before it
    from cpg_suite.darwin import contacts
except ImportError:  # pragma: no cover - the layout before the move
    from cpg_suite import darwin_contacts as contacts

STEPS = 1000  # control steps: the task's episode (16 s), the NAC runs' evaluation length
# ROBOTIS walk-ready leg angles (its walking engine's stance), anatomical degrees per leg:
# hip yaw, hip roll, hip pitch, knee, ankle pitch, ankle roll.
WALK_READY = np.degrees([0.0, 0.0138, 0.6313, -0.9292, 0.5237, 0.0138])


@dataclasses.dataclass(frozen=True)
class Config(cpg.CPGConfig):
    """`cpg.CPGConfig` with the candidate offsets.

    Attributes:
      leg_lean: Degrees of ankle dorsiflexion added to O, the hip extended as much (torso
        upright, legs inclined forward).
      walk_ready: O = `WALK_READY` instead of the crouch.
    """

    leg_lean: float = 0.0
    walk_ready: bool = False

    def anatomical_offsets(self) -> np.ndarray:
        if self.walk_ready:
            return np.concatenate([WALK_READY, WALK_READY])
        offsets = super().anatomical_offsets().copy()
        for leg in (0, 6):
            offsets[leg + cpg.HPITCH] -= self.leg_lean
            offsets[leg + cpg.APITCH] += self.leg_lean
        return offsets


@dataclasses.dataclass(frozen=True)
class Case:
    """One measurement: the CPG's config, A_flexAnk, servo gain, and whether it steps."""

    config: Config = Config()
    flex_ankle: float = cpg.PRESETS["hand_tuned"][7]
    servo_gain: float | None = None
    stepping: bool = True


CASES = {
    "stand": Case(stepping=False),
    "cpg": Case(),
    "flexank_opposes": Case(flex_ankle=-2.0),
    "stand_lean5": Case(Config(leg_lean=5.0), stepping=False),
    "lean3": Case(Config(leg_lean=3.0)),
    "lean5": Case(Config(leg_lean=5.0)),
    "walk_ready": Case(Config(walk_ready=True)),
    "beta1": Case(Config(beta=1.0)),
    "kp100": Case(servo_gain=100.0),
    "flexank_lean5": Case(Config(leg_lean=5.0), flex_ankle=-2.0),
    "best": Case(Config(leg_lean=5.0, beta=1.0, stride_period=0.8), flex_ankle=-2.0),
}


def _pitch_roll(xmat: np.ndarray) -> tuple[float, float]:
    """A body's pitch (+ = its x axis up) and roll (+ = its y axis up), degrees."""
    rot = xmat.reshape(3, 3)
    return math.degrees(math.asin(rot[2, 0])), math.degrees(math.asin(rot[2, 1]))


def measure(case: Case, seed: int) -> dict:
    """Steps `darwin_balance` under `case` from `seed`; returns the per-step records."""
    kwargs = {"random": seed, "posture": case.config.offsets()}
    if case.servo_gain is not None:
        kwargs["servo_gain"] = case.servo_gain
    env = cpg_suite.load("darwin_balance", task_kwargs=kwargs)
    env.reset()
    physics = env.physics
    amplitudes = np.array(cpg.PRESETS["hand_tuned"])
    amplitudes[7] = case.flex_ankle
    pattern = cpg.CPG(amplitudes, case.config)
    standing = case.config.offsets()
    data = physics.data
    feet, soles, floor = physics._feet, physics._soles, physics._floor
    out = {"reward": [], "weighted": [], "torso_pitch": [], "fell": False}
    for foot in (0, 1):
        for key in ("d", "x", "y", "few", "pitch", "roll"):
            out[f"{key}{foot}"] = []
    for _ in range(STEPS):
        targets = pattern.step(env.control_timestep()) if case.stepping else standing
        step = env.step(physics.targets_to_action(targets))
        out["reward"].append(-step.reward)
        distance, stance = contacts.cop_offsets(physics)
        cop, force = contacts.centres_of_pressure(physics)
        pairs = [tuple(g) for g in data.contact.geom[: data.ncon].tolist()]
        out["torso_pitch"].append(_pitch_roll(data.xmat[physics._torso])[0])
        total = 0.0
        for foot in (0, 1):
            pitch, roll = _pitch_roll(data.geom_xmat[feet[foot]])
            out[f"pitch{foot}"].append(pitch)
            out[f"roll{foot}"].append(roll)
            if not stance[foot]:
                continue
            rot = data.geom_xmat[feet[foot]].reshape(3, 3)
            local = rot.T @ (cop[foot] - data.site_xpos[soles[foot]])
            points = sum(p in ((floor, feet[foot]), (feet[foot], floor)) for p in pairs)
            out[f"d{foot}"].append(distance[foot])
            out[f"x{foot}"].append(abs(local[0]))
            out[f"y{foot}"].append(abs(local[1]))
            out[f"few{foot}"].append(points <= 2)
            total += force[foot]
        if total > 0.0:
            loaded = [f for f in (0, 1) if stance[f]]
            out["weighted"].append(sum(force[f] * distance[f] for f in loaded) / total)
        if step.last():
            out["fell"] = step.discount == 0.0
            break
    out["steps"] = len(out["reward"])
    return out


def _cm(values, q) -> float:
    return 100.0 * float(np.percentile(values, q)) if len(values) else math.nan


def report(name: str, runs: list[dict], third: float) -> None:
    """Prints one case's numbers, pooled over its seeds."""

    def pooled(key):
        return [v for run in runs for v in run[key]]

    reward = [100.0 * float(np.mean(run["reward"])) for run in runs]
    print(f"{name}:")
    for foot, side in ((0, "left"), (1, "right")):
        d = pooled(f"d{foot}")
        print(
            f"  {side:5s} stance {len(d) / sum(r['steps'] for r in runs):.2f}  COP distance cm "
            f"median {_cm(d, 50):.2f} (p25 {_cm(d, 25):.2f} p75 {_cm(d, 75):.2f} "
            f"p90 {_cm(d, 90):.2f})  |x| {_cm(pooled(f'x{foot}'), 50):.2f} "
            f"|y| {_cm(pooled(f'y{foot}'), 50):.2f}  <=2 contact points "
            f"{np.mean(pooled(f'few{foot}')):.2f}  pitch {np.mean(pooled(f'pitch{foot}')):+.2f} "
            f"roll {np.mean(pooled(f'roll{foot}')):+.2f} deg"
        )
    mean = float(np.mean(reward))
    verdict = "within" if mean <= 100.0 * third else "beyond"
    print(
        f"  torso pitch {np.mean(pooled('torso_pitch')):+.2f} deg; task reward per step "
        f"(sign removed) {mean:.2f} cm per seed {', '.join(f'{r:.2f}' for r in reward)}; "
        f"force-weighted {100.0 * float(np.mean(pooled('weighted'))):.2f} cm; "
        f"{verdict} {100.0 * third:.2f} cm; falls {sum(r['fell'] for r in runs)}/{len(runs)}",
        flush=True,
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", default="0", help="Comma list of initial-state seeds.")
    parser.add_argument("--cases", default=",".join(CASES), help="Comma list of CASES.")
    args = parser.parse_args(argv)
    seeds = [int(s) for s in args.seeds.split(",") if s.strip()]
    names = [n for n in args.cases.split(",") if n.strip()]
    unknown = sorted(set(names) - set(CASES))
    if unknown or not seeds:
        print(f"error: unknown cases {unknown} (known: {', '.join(CASES)})", file=sys.stderr)
        return 2
    env = cpg_suite.load("darwin_balance")
    half_length = float(env.physics.model.geom_size[env.physics._feet[0], 0])  # the MJCF's sole
    third = half_length / 3.0  # issue 53's goal: within a third of the sole's half-length
    print(f"sole half-length {100 * half_length:.2f} cm; goal {100 * third:.2f} cm; seeds {seeds}")
    for name in names:
        report(name, [measure(CASES[name], seed) for seed in seeds], third)
    return 0


if __name__ == "__main__":
    sys.exit(main())
