r"""Which bodies touch the floor in the CPU reference trials: the soles, or more?

  python investigations/contact_census.py [--runs=results/protocol/runs] [--seeds=5]
      [--tiers=darwin_walk,darwin_walk_randomized,darwin_walk_push] [--out=FILE]

`cpg_suite.mjx.WalkEnv(contacts="soles")` keeps only the contact pairs among the floor and
the two soles (`darwin.GROUND_GEOMS`). MJX computes every pair of the
model at every physics step whether it touches or not: 114 contact slots and 476
constraint rows per robot (with the 20 joint limits), against 12 slots and 68 rows for the
soles' pairs. That is the CPU reference's physics as long as no other geom touches
anything. This script
measures how long that is: it runs the hand-tuned gait and the selected gait or policy of
every shipped run (`cpg_suite.protocol.verify.shipped_runs`) on the first `--seeds` test
seeds of each tier, stepping the trial as the score card does (`score.step_policy`), and
after every physics step lists the active contacts (`MjData.contact`, those of the step's
own forward pass) whose pair is not among the kept ones.

Prints, per configuration and tier: trials; falls; trials with any other contact, split
into those that did not fall and those that did; the share of physics steps with one; and
for the falling trials, how many control steps before the fall the first one came. `--out`
writes the per-trial rows as CSV.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import collections
import csv
import dataclasses
import os

import numpy as np
from absl import flags

from cpg_suite import cli, cpg, darwin, protocol
from cpg_suite.evaluation import closed_loop
from cpg_suite.protocol import score, verify

MJX_TIERS = ("darwin_walk", "darwin_walk_randomized", "darwin_walk_push")
FIELDS = (
    "config",
    "run",
    "tier",
    "seed",
    "fell",
    "fall_step",
    "physics_steps",
    "other_contact_steps",
    "first_other_contact_step",
    "other_geoms",
)


@dataclasses.dataclass(frozen=True)
class CensusSettings:
    """What to run.

    Attributes:
      runs: Root of the shipped runs (`verify.shipped_runs`); empty: the hand-tuned gait only.
      seeds: Test seeds per tier.
      tiers: Tiers, comma-separated.
      steps: Control steps per trial.
      out: CSV file for the per-trial rows (empty: none).
    """

    runs: str = verify.ARTIFACTS
    seeds: int = 5
    tiers: str = ",".join(MJX_TIERS)
    steps: int = 1000
    out: str = ""

    def __post_init__(self):
        cli.require(
            1 <= self.seeds <= len(protocol.TEST),
            f"--seeds must lie in [1, {len(protocol.TEST)}], got {self.seeds}",
        )
        unknown = [t for t in self.tiers.split(",") if t not in protocol.TIERS]
        cli.require(not unknown, f"unknown --tiers {unknown}; valid: {', '.join(protocol.TIERS)}")
        cli.require(self.steps >= 1, f"--steps must be ≥ 1, got {self.steps}")


def kept_geoms(model) -> set[int]:
    """Ids of the geoms whose pairs `WalkEnv(contacts="soles")` keeps: floor and soles."""
    return {model.name2id(n, "geom") for n in darwin.GROUND_GEOMS}


def other_contacts(physics, kept: set[int]) -> tuple[int, ...]:
    """The geoms of the active contacts outside the kept pairs (the robot's side)."""
    contact = physics.data.contact
    return tuple(
        int(g1 if g2 in kept else g2)
        for g1, g2 in zip(contact.geom1, contact.geom2)
        if not (g1 in kept and g2 in kept)
    )


def census_trial(policy, tier: str, seed: int, steps: int) -> dict:
    """One trial as the score card steps it, recording the other contacts of each step.

    Returns:
      `fell`, `fall_step` (1-based, 0: none), `physics_steps`, `other_contact_steps`
      (physics steps with one), `first_other_contact_step` (control step, 1-based, 0:
      none) and `other_geoms` (their names, ';'-joined).
    """
    env, observation, n_sub = score.start_trial(policy, tier, seed)
    physics = env.physics
    kept = kept_geoms(physics.model)
    _, (fall_step, _), records = score.step_policy(
        policy,
        env.task,
        physics,
        observation,
        steps,
        n_sub,
        record=lambda p: other_contacts(p, kept),
    )
    hit = [i for i, geoms in enumerate(records) if geoms]
    names = sorted({physics.model.id2name(g, "geom") for i in hit for g in records[i]})
    return {
        "fell": bool(fall_step),
        "fall_step": fall_step,
        "physics_steps": len(records),
        "other_contact_steps": len(hit),
        "first_other_contact_step": hit[0] // n_sub + 1 if hit else 0,
        "other_geoms": ";".join(names),
    }


def configurations(root: str) -> list[tuple[str, str, object]]:
    """`(configuration, run, policy)`: the hand-tuned gait, then every shipped run's.

    A configuration is a shipped run's `<method>/<task>/<name without _seedN>`.
    """
    found = [("hand_tuned", "hand_tuned", score.OpenLoopPolicy(cpg.amplitudes_from("hand_tuned")))]
    for run_dir in verify.shipped_runs(root) if root else []:
        rel = os.path.relpath(run_dir, root)
        config = rel.rsplit("_seed", 1)[0]
        policy = verify.shipped_policy(run_dir)
        if policy is None:
            policy = gait_policy(run_dir)
        found.append((config, rel, policy))
    return found


def gait_policy(run_dir: str):
    """A gait run's selected gait as a policy, read for its controller as the scorer reads it
    (`verify.gait_params`): the feedback CPG's amplitudes with their gains, else the CPG's."""
    controller = verify.run_settings(run_dir).controller
    params = verify.gait_params(run_dir, controller)
    if controller == "feedback":
        return closed_loop.FeedbackPolicy(params)
    return score.OpenLoopPolicy(params)


def summarize(rows: list[dict]) -> list[dict]:
    """One row per configuration and tier (see the module docstring)."""
    groups = collections.defaultdict(list)
    for r in rows:
        groups[(r["config"], r["tier"])].append(r)
    table = []
    for (config, tier), group in groups.items():
        fell = [r for r in group if r["fell"]]
        touched = [r for r in group if r["other_contact_steps"]]
        lead = [r["fall_step"] - r["first_other_contact_step"] for r in fell]
        lead = [v for v, r in zip(lead, fell) if r["first_other_contact_step"]]
        table.append(
            {
                "config": config,
                "tier": tier,
                "trials": len(group),
                "falls": len(fell),
                "other_no_fall": sum(1 for r in touched if not r["fell"]),
                "other_fall": sum(1 for r in touched if r["fell"]),
                "step_share": sum(r["other_contact_steps"] for r in group)
                / max(1, sum(r["physics_steps"] for r in group)),
                "lead_median": float(np.median(lead)) if lead else None,
                "lead_max": max(lead) if lead else None,
            }
        )
    return table


def format_table(table: list[dict]) -> str:
    """The summary as aligned text."""
    lines = [
        f"{'configuration':<42} {'tier':<23} trials falls  other contacts: no fall / fall"
        "  share of physics steps  control steps before the fall: median, max"
    ]
    for t in table:
        lead = "-" if t["lead_median"] is None else f"{t['lead_median']:.0f}, {t['lead_max']}"
        lines.append(
            f"{t['config']:<42} {t['tier']:<23} {t['trials']:>6} {t['falls']:>5}  "
            f"{t['other_no_fall']:>14} / {t['other_fall']:<4}  {t['step_share']:>22.2e}  {lead}"
        )
    return "\n".join(lines)


def census(settings: CensusSettings) -> list[dict]:
    """The per-trial rows of every configuration, tier and seed."""
    rows = []
    seeds = protocol.held_out_seeds(settings.seeds)
    for config, run, policy in configurations(settings.runs):
        for tier in settings.tiers.split(","):
            for seed in seeds:
                trial = census_trial(policy, tier, seed, settings.steps)
                rows.append({"config": config, "run": run, "tier": tier, "seed": seed, **trial})
    return rows


def define_flags() -> None:
    """Defines the flags (only when run as a program)."""
    d = CensusSettings()
    flags.DEFINE_string("runs", d.runs, "Root of the shipped runs ('' : hand-tuned gait only).")
    flags.DEFINE_integer("seeds", d.seeds, "Test seeds per tier.")
    flags.DEFINE_string("tiers", d.tiers, "Tiers, comma-separated.")
    flags.DEFINE_integer("steps", d.steps, "Control steps per trial.")
    flags.DEFINE_string("out", d.out, "CSV file for the per-trial rows.")


def main(argv):
    """Runs the census and prints its table."""
    del argv
    settings = cli.settings_from_flags(CensusSettings)
    runs_ok = not settings.runs or os.path.isdir(settings.runs)
    cli.check(runs_ok, f"--runs={settings.runs} is not a directory")
    rows = census(settings)
    print(format_table(summarize(rows)))
    if settings.out:
        with open(settings.out, "w", newline="", encoding="utf-8") as f:
            writer = csv.DictWriter(f, fieldnames=FIELDS)
            writer.writeheader()
            writer.writerows({k: r[k] for k in writer.fieldnames} for r in rows)


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_files=("out",))
