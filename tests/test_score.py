"""The score card: seeds of the protocol, statistics, batched and step-by-step agreement."""

import json
import subprocess
import sys

import numpy as np
import pytest

from analysis import leaderboard
from cpg_suite import cpg, protocol
from cpg_suite.evaluation.gait import evaluate_gait
from cpg_suite.protocol import score


def test_seed_ranges_are_disjoint_and_training_refuses_the_others():
    assert max(protocol.TRAINING) < min(protocol.VALIDATION)
    assert max(protocol.VALIDATION) < min(protocol.TEST)
    assert len(protocol.held_out_seeds()) == 50
    assert protocol.check_training([0, 5, 999_999]) == [0, 5, 999_999]
    with pytest.raises(ValueError, match="validation seed"):
        protocol.check_training([3, protocol.VALIDATION.start])
    with pytest.raises(ValueError, match="test seed"):
        protocol.check_training([protocol.TEST.start + 7])


def test_summary_statistics_known_answers():
    distance = np.array([1.0, 2.0, 3.0, 4.0, -1.0, 10.0, 2.0, 2.0])
    fell = np.array([False, False, True, False, False, True, False, False])
    quality = {f: np.full(8, 0.5) for f in score.gait_quality.FIELDS}
    row = score.summarize(distance, fell, quality)
    success = [1.0, 2.0, 0.0, 4.0, -1.0, 0.0, 2.0, 2.0]
    assert row["success_weighted_distance_m"]["mean"] == pytest.approx(np.mean(success))
    low, high = row["success_weighted_distance_m"]["ci95"]
    assert low < np.mean(success) < high
    assert row["fall_rate"]["value"] == 0.25
    assert row["distance_m"]["median"] == 2.0
    assert row["distance_m"]["iqm"] == pytest.approx(np.mean([2.0, 2.0, 2.0, 3.0]))
    assert row["quality"]["flight_share"] == 0.5
    again = score.summarize(distance, fell, quality)
    assert again == row  # the bootstrap generator is fixed


@pytest.mark.parametrize("tier", protocol.TIERS)
def test_policy_stepping_equals_the_batched_gait_and_the_environment(tier):
    settings = score.ScoreSettings(tiers=(tier,), seeds=2, steps=250, threads=2)
    amps = cpg.amplitudes_from("hand_tuned") + np.linspace(-4, 4, 11)
    batched = score.score_gait(amps, settings)
    stepped = score.score_policy(score.OpenLoopPolicy(amps, 250), settings)
    assert json.dumps(batched["tiers"], sort_keys=True) == json.dumps(
        stepped["tiers"], sort_keys=True
    )
    trial = score.policy_trial(score.OpenLoopPolicy(amps, 250), tier, protocol.TEST.start, 250)
    reference = evaluate_gait(amps, protocol.TEST.start, task=tier, steps=250)
    assert trial["distance_m"] == reference["distance_m"]
    assert trial["fall_step"] == (reference["fall_step"] or 0)


class _OneByOne:
    """A policy without `act_batch`: scored trial by trial."""

    def __init__(self, policy):
        self.policy = policy

    def __call__(self, observation):
        return self.policy(observation)

    def reset(self):
        self.policy.reset()


@pytest.mark.parametrize("action_space", ["joints", "cpg"])
def test_a_policy_scored_in_batches_gets_the_card_of_trial_by_trial(action_space):
    from cpg_suite.runfiles import exported

    rng = np.random.default_rng(0)
    width = 40 + (2 if action_space == "cpg" else 0)
    sizes = (width, 32, 32, 24)
    arrays = {"mean": np.zeros(width), "std": np.ones(width)}
    for i, (n, m) in enumerate(zip(sizes[:-1], sizes[1:])):
        arrays[f"kernel_{i}"] = rng.standard_normal((n, m)) / np.sqrt(n)
        arrays[f"bias_{i}"] = 0.1 * rng.standard_normal(m)
    policy = exported.NumpyPolicy(arrays, action_space)
    # 10 seeds: more than the network's 8 rows per pass; a 50 ms supply window, over which
    # the random `joints` policy browns out in its third control step (the `cpg` one walks).
    settings = score.ScoreSettings(
        tiers=("darwin_walk", "darwin_walk_push"), seeds=10, steps=80, supply_window=0.05
    )
    batched, batched_trials = score.score_policy_trials(policy, settings)
    one_by_one, trials = score.score_policy_trials(_OneByOne(policy), settings)
    assert json.dumps(batched, sort_keys=True) == json.dumps(one_by_one, sort_keys=True)
    assert batched_trials == trials


def test_card_is_the_same_for_one_and_two_threads():
    amps = cpg.amplitudes_from("hand_tuned")
    one = score.score_gait(amps, score.ScoreSettings(seeds=3, steps=200, threads=1))
    two = score.score_gait(amps, score.ScoreSettings(seeds=3, steps=200, threads=2))
    assert one["tiers"] == two["tiers"] and one["all"] == two["all"]


def _cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "cpg_suite.protocol.score", *args],
        capture_output=True,
        text=True,
        timeout=600,
    )


def test_cli_writes_score_json_that_the_leaderboard_ranks(tmp_path):
    out_dir = tmp_path / "scores" / "hand_tuned"
    out = _cli(
        "--params=hand_tuned",
        "--seeds=2",
        "--steps=100",
        "--tiers=darwin_walk",
        f"--out={out_dir}",
    )
    assert out.returncode == 0, out.stderr
    card = json.loads((out_dir / "score.json").read_text())
    assert set(card["tiers"]) == {"darwin_walk"} and card["seeds"] == [2_000_000, 2_000_001]
    assert "darwin_walk" in out.stdout
    found, skipped = leaderboard.find_runs(str(tmp_path))
    (row,) = leaderboard.darwin_rows(found)
    assert not skipped and (row["method"], row["config"]) == ("preset", "hand_tuned")
    assert row["budget_sim_steps"] == 0 and row["in_sample_best_m"] == ""
    assert row["test_score_m"] == card["all"]["success_weighted_distance_m"]["mean"]


@pytest.mark.parametrize(
    "args, words",
    [
        (["--tiers=darwin_run"], "unknown --tiers"),
        (["--seeds=51"], "--seeds"),
        (["--params=nope"], "neither a preset"),
    ],
)
def test_cli_bad_input(args, words):
    out = _cli(*args)
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and words in lines[0]


@pytest.mark.parametrize("run", ["ppo/darwin_walk/cpg_v1_seed0", "ppo/darwin_walk/joints_v1_seed0"])
def test_a_shipped_sb3_policy_scored_in_batches_gets_the_card_of_trial_by_trial(run):
    """SB3 policies step their trials together too: the network row by row, the CPG rows
    and the physics of all trials at once (two threads); the same trials and card."""
    import os

    from cpg_suite.protocol import verify

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    run_dir = os.path.join(root, verify.ARTIFACTS, run)
    settings = score.ScoreSettings(tiers=("darwin_walk_push",), seeds=3, steps=60)
    with verify.policy_threads(run_dir):
        policy = verify.shipped_policy(run_dir)
        batched = score.score_policy_trials(policy, settings)
        one_by_one = score.score_policy_trials(_OneByOne(policy), settings)
    assert json.dumps(batched[0], sort_keys=True) == json.dumps(one_by_one[0], sort_keys=True)
    assert batched[1] == one_by_one[1]


@pytest.mark.parametrize("as_policy", [False, True])
def test_the_trial_table_holds_each_trials_measures_and_the_card_their_medians(as_policy):
    """Each row's gait-quality measures are the trial's, the card's medians are made from
    them, and a trial scored alone (a sampled re-score) is its row, measures included."""
    tiers = ("darwin_walk", "darwin_walk_push")
    settings = score.ScoreSettings(tiers=tiers, seeds=3, steps=200, threads=1)
    amps = cpg.amplitudes_from("hand_tuned") + np.linspace(-4, 4, 11)
    gait = score.OpenLoopPolicy(amps, 200) if as_policy else amps
    card, trials = score.cards_and_trials(gait, [settings])[0]
    assert all(list(t["quality"]) == list(score.gait_quality.FIELDS) for t in trials)
    assert all(v is None or np.isfinite(v) for t in trials for v in t["quality"].values())
    for name in (*tiers, "all"):
        rows = [t for t in trials if name in ("all", t["tier"])]
        arrays = {
            f: np.array([np.nan if t["quality"][f] is None else t["quality"][f] for t in rows])
            for f in score.gait_quality.FIELDS
        }
        row = card["all"] if name == "all" else card["tiers"][name]
        assert score.card_stats.medians(arrays) == row["quality"]
    seeds = protocol.held_out_seeds(3)
    alone = score.seed_trials(gait, settings, {"darwin_walk_push": [seeds[2]]})
    assert alone == [trials[-1]]
