r"""Which leg joints of a gait or a PPO policy turn faster than the MX-28's no-load speed,
when in the step, and what drives them (`cpg_suite.protocol.overspeed`).

  python -m baselines.experiments.overspeed --ppo_run=runs/ppo/darwin_walk/joints_v1_seed0
  python -m baselines.experiments.overspeed --params=hand_tuned --out=overspeed.json

Runs `--seeds` held-out test seeds of `--tier` step by step, as the score card does, and
prints one row per leg joint with over-speed servo-steps: their share, the peak, the
motor-driven share (the servo's torque along the motion), the share in stance and at a
touchdown of the joint's own foot, and each force source's mean Δq̇ along the motion over
the 30 ms before (rad/s). `--out` writes the table and the trials' distances as JSON.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import os

from absl import flags

from cpg_suite import cli, protocol
from cpg_suite.evaluation import gait
from cpg_suite.protocol import overspeed, score
from cpg_suite.runfiles import runs


@dataclasses.dataclass(frozen=True)
class OverspeedSettings:
    """What to diagnose.

    Attributes:
      params: A gait preset or JSON file (ignored with `ppo_run`).
      ppo_run: A PPO run directory; its selected policy is diagnosed.
      tier: The test tier.
      seeds: How many held-out test seeds.
      steps: Control steps per trial.
    """

    params: str = "hand_tuned"
    ppo_run: str | None = None
    tier: str = "darwin_walk"
    seeds: int = 5
    steps: int = 1000

    def __post_init__(self):
        cli.require(
            self.tier in protocol.TIERS,
            f"unknown --tier {self.tier!r}; valid: {', '.join(protocol.TIERS)}",
        )
        cli.require(
            1 <= self.seeds <= len(protocol.TEST),
            f"--seeds must lie in [1, {len(protocol.TEST)}], got {self.seeds}",
        )
        cli.require(self.steps >= 1, f"--steps must be ≥ 1, got {self.steps}")
        cli.require(
            self.ppo_run is None or os.path.isfile(os.path.join(self.ppo_run, "config.json")),
            f"--ppo_run={self.ppo_run} is not a PPO run directory (no config.json)",
        )


def load_policy(settings: OverspeedSettings):
    """The PPO run's selected policy, or the gait as an open-loop policy.

    Raises:
      ValueError, OSError: On a gait or run that cannot be read.
    """
    if settings.ppo_run is not None:
        from baselines import ppo  # the rl extra (torch): only a PPO run needs it

        return ppo.load_policy(settings.ppo_run)
    return score.OpenLoopPolicy(gait.parse_params(settings.params), settings.steps)


def diagnose(settings: OverspeedSettings, policy) -> dict:
    """The per-joint over-speed table of a policy on held-out seeds.

    Args:
      settings: What to diagnose.
      policy: `load_policy(settings)`.

    Returns:
      `{"joints": overspeed.summarize(...), "trials": [{seed, physics_steps, closure}],
      "settings": ...}`.
    """
    found, trials, servo_steps = [], [], 0
    for seed in protocol.held_out_seeds(settings.seeds):
        t = overspeed.trace(policy, settings.tier, seed, settings.steps)
        found += overspeed.events(t)
        servo_steps += len(t.velocity)
        closure = overspeed.closure(t)
        trials.append({"seed": seed, "physics_steps": len(t.velocity), "closure": closure})
    return {
        "settings": dataclasses.asdict(settings),
        "joints": overspeed.summarize(found, servo_steps),
        "trials": trials,
    }


def format_table(table: dict) -> str:
    """The per-joint table as fixed-width text."""
    sources = overspeed.SOURCES
    head = f"{'joint':<10} {'share':>7} {'peak':>6} {'motor':>6} {'stance':>6} {'landing':>7}"
    lines = [head + "".join(f" {s[:12]:>12}" for s in sources)]
    for joint, row in table.items():
        lines.append(
            f"{joint:<10} {row['share']:>7.2%} {row['peak']:>6.2f} {row['motor']:>6.0%} "
            f"{row['stance']:>6.0%} {row['touchdown']:>7.0%}"
            + "".join(f" {row['mean_delta'][s]:>12.2f}" for s in sources)
        )
    return "\n".join(lines)


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    d = OverspeedSettings()
    flags.DEFINE_string("params", d.params, "Gait preset or JSON (ignored with --ppo_run).")
    flags.DEFINE_string(
        "ppo_run",
        None,
        "none: the gait of --params. PPO run directory (its selected policy; the rl extra).",
    )
    flags.DEFINE_string("tier", d.tier, f"Test tier: {', '.join(protocol.TIERS)}.")
    flags.DEFINE_integer("seeds", d.seeds, "Held-out test seeds.")
    flags.DEFINE_integer("steps", d.steps, "Control steps per trial.")
    flags.DEFINE_string("out", None, "JSON file for the table (default: print only).")


def main(argv):
    del argv
    settings = cli.settings_from_flags(OverspeedSettings)
    try:
        policy = load_policy(settings)
    except (ValueError, OSError) as e:
        raise cli.UsageError(f"--params {settings.params}: {e}") from None
    result = diagnose(settings, policy)
    print(format_table(result["joints"]))
    if flags.FLAGS.out:
        runs.write_json(flags.FLAGS.out, result)
        print(f"wrote {flags.FLAGS.out}")


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_files=("out",))
