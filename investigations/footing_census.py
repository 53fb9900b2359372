r"""How shipped gaits' feet meet the floor: the card's footing measures per trial, and the
count of loaded contacts per stance foot-step.

  python investigations/footing_census.py [--runs=RUN,...] [--tier=darwin_walk] [--seeds=4]

Its findings: docs/contact.md#deliverable-1-how-the-feet-meet-the-floor-on-the-card (C8).
Each run's selected open-loop gait is stepped as the card steps a policy
(`score.policy_trial`'s control steps) on the tier's first `--seeds` test seeds; per trial
it prints the distance, the older `slip_per_m` and the footing measures
(`cpg_suite.evaluation.footing.FIELDS`), then, over the trials, the share of stance
foot-steps (a foot whose floor contacts carry over 5 % of the weight) with 1, 2, 3, 4 and
more loaded contacts, and the contact slip in metres.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import numpy as np
from absl import app, flags

from cpg_suite import cpg, protocol
from cpg_suite.evaluation import footing, quality
from cpg_suite.protocol import score

RUNS = ("cmaes/darwin_walk_randomized/K50_s1_seed0", "cem/darwin_walk/K50_n0.8_e2_seed0")
SHIPPED = "results/protocol/runs"
STEPS = 1000  # control steps: the card's trials


def census(run: str, tier: str, seeds: int) -> None:
    """Prints one run's trials and its stance contact census.

    Args:
      run: A shipped run under `SHIPPED` whose gait is open-loop amplitudes.
      tier: The tier to step.
      seeds: How many of the first test seeds.
    """
    amplitudes = cpg.load_amplitudes(f"{SHIPPED}/{run}/selected_params.json")
    counts = np.zeros(footing.SLOTS + 1)
    print(run, tier)
    for seed in protocol.held_out_seeds(seeds):
        policy = score.OpenLoopPolicy(amplitudes, STEPS)
        trial = score._Trial(
            *score.start_trial(policy, tier, seed, score.ScoreSettings().task_kwargs())
        )
        for t in range(STEPS):
            if trial.step(policy(trial.observation), t):
                break
        result = trial.result()
        feet = np.concatenate([chunk[4] for chunk in trial.records])
        parts = footing.contacts(feet.reshape(len(feet), 2, -1))
        weight = trial.env.physics.total_mass() * quality.GRAVITY
        stance = parts["normal"].sum(axis=-1) > quality._STANCE_FRACTION * weight
        loaded = (parts["normal"] > 0.0).sum(axis=-1)[stance]
        counts += np.bincount(loaded, minlength=footing.SLOTS + 1)
        q, d = result["quality"], result["distance_m"]
        measures = " ".join(f"{f} {q[f]:.4f}" for f in ("slip_per_m", *footing.FIELDS))
        slip = q["contact_slip_per_m"] * d
        print(
            f"  seed {seed}: {d:.2f} m, fell {result['fell']}, "
            f"contact slip {slip:.2f} m; {measures}"
        )
    share = 100 * counts / counts.sum()
    print(
        f"  loaded contacts per stance foot-step: 1 {share[1]:.1f} %, 2 {share[2]:.1f} %, "
        f"3 {share[3]:.1f} %, 4 {share[4]:.1f} %, more {share[5:].sum():.1f} %"
    )


def main(argv):
    del argv
    for run in flags.FLAGS.runs:
        census(run, flags.FLAGS.tier, flags.FLAGS.seeds)


if __name__ == "__main__":
    flags.DEFINE_list("runs", list(RUNS), "Shipped runs (open-loop gaits) under " + SHIPPED)
    flags.DEFINE_string("tier", "darwin_walk", "The tier to step.")
    flags.DEFINE_integer("seeds", 4, "How many of the first test seeds.")
    app.run(main)
