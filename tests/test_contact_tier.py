"""The contact tier (`darwin_walk_contact`, benchmark version 3) and what version 3 changes:
the card's tiers by version, the cards of an upgrade from one scoring, the board's ranking
of runs trained under version 2."""

import dataclasses
import json
import math
import os
import shutil

import numpy as np
import pytest

import cpg_suite
from analysis import leaderboard
from cpg_suite import cpg, perturbations, protocol
from cpg_suite.evaluation import gait
from cpg_suite.protocol import admission, card, score, verify

CONTACT = "darwin_walk_contact"


def _episode(seed, contact=None):
    kwargs = {"random": seed, **({"contact": contact} if contact else {})}
    env = cpg_suite.load(CONTACT, task_kwargs=kwargs)
    env.reset()
    return env


def test_each_episode_draws_friction_and_time_constant_within_the_sourced_ranges():
    draws = [_episode(seed).task.episode_parameters for seed in range(40)]
    friction = np.array([d["friction"] for d in draws])
    tau = np.array([d["time_constant"] for d in draws])
    assert 0.4 <= friction.min() and friction.max() <= 1.0 and np.ptp(friction) > 0.3
    assert 0.004 <= tau.min() and tau.max() <= 0.020
    # Log-uniform: about half the draws below the geometric mean of the range (8.9 ms).
    assert 10 <= int(np.sum(tau < math.sqrt(0.004 * 0.020))) <= 30


def test_the_draw_sets_floor_and_soles_so_their_contact_has_it():
    env = _episode(3)
    physics, drawn = env.physics, env.task.episode_parameters
    ground = [physics._floor, *physics._feet]
    np.testing.assert_array_equal(physics.model.geom_friction[ground, 0], drawn["friction"])
    np.testing.assert_array_equal(physics.model.geom_solref[ground, 0], drawn["time_constant"])
    stand = physics.targets_to_action(cpg.CPGConfig().offsets())
    for _ in range(30):  # standing: the soles touch the floor
        assert env.step(stand).discount == 1.0  # not fallen: the same episode
    assert env.task.episode_parameters is drawn
    feet = {int(g) for g in physics._feet}
    contacts = [c for c in physics.data.contact if {int(c.geom1), int(c.geom2)} & feet]
    assert contacts
    for c in contacts:  # MuJoCo's mix of two equal time constants and frictions is each
        assert c.solref[0] == pytest.approx(drawn["time_constant"], rel=1e-12)
        assert c.friction[0] == pytest.approx(drawn["friction"], rel=1e-12)


def test_same_seed_same_episode_and_the_posture_of_the_nominal_task():
    a, b = _episode(7), _episode(7)
    assert a.task.episode_parameters == b.task.episode_parameters
    nominal = cpg_suite.load("darwin_walk", task_kwargs={"random": 7})
    nominal.reset()
    np.testing.assert_array_equal(a.physics.data.qpos, nominal.physics.data.qpos)


def test_ranges_at_the_nominal_contact_walk_as_the_nominal_task():
    """A contact tier whose ranges are the model's own contact (friction 1, the floor's
    20 ms and soles' 8 ms mix to 14 ms, here set on both) is the nominal physics but for
    MuJoCo's mixing: the trials agree to the metre's first digits, not bit for bit."""
    nominal = gait.evaluate_gait(cpg.amplitudes_from("hand_tuned"), 5, steps=200)
    same = gait.evaluate_gait(
        cpg.amplitudes_from("hand_tuned"),
        5,
        task=CONTACT,
        steps=200,
        task_kwargs={"contact": perturbations.Contact((1.0, 1.0), (0.014, 0.014))},
    )
    assert same["distance_m"] == pytest.approx(nominal["distance_m"], abs=0.02)
    assert not same["fell"] and not nominal["fell"]


def test_bad_ranges_are_refused_in_words():
    with pytest.raises(ValueError, match="contact ranges"):
        perturbations.Contact(time_constant=(0.02, 0.004))
    with pytest.raises(ValueError, match="contact ranges"):
        perturbations.Contact(friction=(0.0, 1.0))


def test_the_log_uniform_draw_is_a_known_answer():
    """The draw does not depend on libm's last bit: its logarithm is rounded."""
    random = np.random.RandomState(0)
    drawn = perturbations.Contact().sample(random)
    random = np.random.RandomState(0)
    friction, u = random.uniform(0.4, 1.0), random.uniform(0.0, 1.0)
    assert drawn["friction"] == friction
    assert drawn["time_constant"] == pytest.approx(0.004 * 5.0**u, rel=1e-15)


def test_the_cards_tiers_follow_the_version():
    assert protocol.tiers(2) == protocol.tiers(1) == protocol.TIERS[:4]
    assert protocol.tiers(3) == protocol.TIERS and protocol.TIERS[-1] == CONTACT
    assert protocol.card_tiers(None, 3) == protocol.card_tiers(protocol.tiers(2), 3)
    assert protocol.card_tiers(protocol.TIERS, 2) == protocol.tiers(2)
    assert protocol.card_tiers(["darwin_walk"], 3) == ("darwin_walk",)  # a deviation stays
    assert score.ScoreSettings(benchmark_version=2).tiers == protocol.tiers(2)
    assert score.ScoreSettings().tiers == protocol.TIERS
    assert card.deviations(protocol.tiers(2), 50, 1000, 2) == []
    assert card.deviations(protocol.tiers(2), 50, 1000, 3) == [
        "tiers left out: darwin_walk_contact"
    ]
    assert protocol.trained_alike(2) == protocol.trained_alike(3) != protocol.trained_alike(1)
    with pytest.raises(ValueError, match="benchmark_version"):
        protocol.tiers(4)


@pytest.mark.parametrize("as_policy", [False, True], ids=["gait", "policy"])
def test_cards_of_two_versions_from_one_scoring_equal_each_version_scored_alone(as_policy):
    params = cpg.amplitudes_from("hand_tuned")
    artifact = score.OpenLoopPolicy(params, 60) if as_policy else params
    v2 = score.ScoreSettings(seeds=2, steps=60, threads=1, benchmark_version=2)
    v3 = dataclasses.replace(v2, benchmark_version=3, tiers=None)
    both = score.cards_and_trials(artifact, [v2, v3])
    alone = [score.cards_and_trials(artifact, [s])[0] for s in (v2, v3)]
    assert both == alone
    assert [t["tier"] for t in both[1][1]][-2:] == [CONTACT, CONTACT]
    with pytest.raises(ValueError, match="more than tiers and version"):
        score.cards_and_trials(artifact, [dataclasses.replace(v2, steps=61), v3])


SHIPPED = os.path.join("results", "protocol", "runs", "cem", "darwin_walk", "K50_n0.8_e2_seed0")


def _as_version_2(tmp_path):
    """A shipped run as it stood before version 3: its version-2 card and trials."""
    run = tmp_path / "cem" / "darwin_walk" / "K50_n0.8_e2_seed0"
    shutil.copytree(SHIPPED, run)
    summary = json.loads((run / "summary.json").read_text())
    history = summary.pop("history")
    summary["test"] = history.pop("v2")
    if history:
        summary["history"] = history
    (run / "summary.json").write_text(json.dumps(summary, indent=2))
    (run / "trials_v2.csv").replace(run / "trials.csv")
    return run


@pytest.mark.slow
def test_an_upgrade_to_version_3_gives_the_shipped_card_bit_for_bit(tmp_path):
    """Scores one run on five tiers (~1 min): the card, trials and history it writes are
    the shipped run's, and the ledger row says what was reproduced."""
    run = _as_version_2(tmp_path)
    assert verify.upgrade_run(str(run), 3, threads=2)
    for name in ("summary.json", "trials.csv", "trials_v2.csv"):
        assert (run / name).read_bytes() == open(os.path.join(SHIPPED, name), "rb").read(), name
    ledger = str(tmp_path / "rescored.csv")
    verify.write_ledger(ledger, {str(run): []}, upgrade=(2, 3))
    row = admission.read_ledger(ledger)[admission.run_key(str(run))]
    assert (row["check"], row["trials"], row["result"]) == ("upgrade 2->3", "200", "reproduced")
    assert admission.rescored_in_full(str(run), admission.read_ledger(ledger)) is None
    assert not verify.upgrade_run(str(run), 3)  # resumable: done is done


def test_an_upgrade_refuses_an_earlier_version_before_scoring(tmp_path):
    run = tmp_path / "cem" / "darwin_walk" / "K50_n0.8_e2_seed0"
    shutil.copytree(SHIPPED, run)
    before = (run / "summary.json").read_bytes()
    with pytest.raises(ValueError, match="card is of version 3; cannot upgrade to 2"):
        verify.upgrade_run(str(run), 2, threads=1)
    assert (run / "summary.json").read_bytes() == before


def test_verify_scores_the_tiers_the_card_holds():
    config = json.loads(open(os.path.join(SHIPPED, "config.json")).read())
    card = verify.stored_card(SHIPPED)
    assert verify.card_settings(config, card=card).tiers == protocol.TIERS
    four = {**card, "tiers": {t: card["tiers"][t] for t in protocol.tiers(2)}}
    assert verify.card_settings(config, card=four).tiers == protocol.tiers(2)


def test_runs_trained_under_versions_2_and_3_form_one_row():
    """Seeds trained under either version train alike: one configuration, one row (not two
    chances at a rank)."""
    found, _ = leaderboard.find_runs(os.path.join("results", "protocol", "runs"))
    cem = [r for r in found if r["dir"].endswith(tuple(f"K50_n0.8_e2_seed{s}" for s in range(10)))]
    cem = [r for r in cem if "/cem/darwin_walk/" in r["dir"].replace(os.sep, "/")]
    assert len(cem) == 10
    for run in cem[:5]:
        run["trained_version"] = 3
    rows = leaderboard.darwin_rows(cem)
    assert [(r["n_seeds"], r["status"], r["trained_version"]) for r in rows] == [(10, "ranked", 2)]
