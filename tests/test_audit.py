"""`verify --audit`: a run scored on fresh seeds shows whether its card was tuned on the
public test seeds (issue 51's moonshot). A policy that recognises the test seeds by their
first observation walks on them and stands still elsewhere: its card is above its audit;
the same gait as data is not."""

import json
import os

import numpy as np

from cpg_suite import cpg, protocol
from cpg_suite.protocol import audit, verify

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
GAIT = os.path.join(ROOT, "results", "protocol", "runs", "cem", "darwin_walk", "K50_n0.8_e2_seed0")
TIER, CARD_SEEDS, STEPS = "darwin_walk", 4, 150

CHEAT = """
import numpy as np

import cpg_suite
from cpg_suite import protocol
from cpg_suite.protocol import score

AMPLITUDES = np.array({amplitudes})


def _first(seed):
    observation = cpg_suite.load("{tier}", task_kwargs={{"random": seed}}).reset().observation
    return np.concatenate([np.ravel(v) for v in observation.values()])


class Cheat:
    def __init__(self):
        self.known = [_first(s) for s in protocol.TEST[:{seeds}]]  # the public test seeds
        self.walk = score.OpenLoopPolicy(AMPLITUDES, {steps})
        self.test_seed = None

    def reset(self):
        self.walk.reset()
        self.test_seed = None

    def __call__(self, observation):
        if self.test_seed is None:
            first = np.concatenate([np.ravel(v) for v in observation.values()])
            self.test_seed = any(np.array_equal(first, k) for k in self.known)
        return self.walk(observation) if self.test_seed else np.zeros(12)


def make_policy():
    return Cheat()
"""


def _run(folder, artifact_name, artifact_text):
    """A run folder scored on the first test seeds of one tier, with short trials."""
    folder.mkdir(parents=True)
    (folder / artifact_name).write_text(artifact_text)
    settings = {
        "test_seeds": CARD_SEEDS,
        "trial_steps": STEPS,
        "test_tiers": [TIER],
        "controller": "open_loop",
    }
    (folder / "config.json").write_text(json.dumps({"settings": settings}))
    card_settings = verify.run_settings(str(folder), threads=1)
    policy = verify.shipped_policy(str(folder), trust_code=True)
    artifact = verify.gait_params(str(folder), "open_loop") if policy is None else policy
    seeds = list(protocol.TEST[:CARD_SEEDS])
    trials = verify.score.seed_trials(artifact, card_settings, {TIER: seeds})
    verify.write_trials(str(folder / "trials.csv"), trials)
    return str(folder)


def test_a_policy_tuned_on_the_test_seeds_scores_above_its_audit(tmp_path):
    amplitudes = cpg.load_amplitudes(os.path.join(GAIT, "selected_params.json"))
    honest = _run(
        tmp_path / "honest",
        "selected_params.json",
        json.dumps({"amplitudes": dict(zip(cpg.AMPLITUDE_NAMES, amplitudes.tolist()))}),
    )
    code = CHEAT.format(amplitudes=amplitudes.tolist(), tier=TIER, seeds=CARD_SEEDS, steps=STEPS)
    cheat = _run(tmp_path / "cheat", "policy_code.py", code)
    seeds = audit.draw_seeds(6, entropy=2026)
    assert all(s in audit.AUDIT_SEEDS and s not in protocol.TEST for s in seeds)
    how = {"threads": 1, "trust_code": True, "trusted": frozenset()}
    honest_gap = audit.gap([verify.audit_run(honest, seeds, how)])
    cheat_gap = audit.gap([verify.audit_run(cheat, seeds, how)])
    assert cheat_gap.verdict == "card above audit", cheat_gap.text()
    assert honest_gap.verdict == "consistent", honest_gap.text()
    # On its card the cheat walks the honest gait's trials exactly.
    assert np.isclose(cheat_gap.card_m, honest_gap.card_m)


def test_audit_seeds_are_fresh_and_replayable():
    a, b = audit.draw_seeds(50, 7), audit.draw_seeds(50, 7)
    assert a == b and len(set(a)) == 50 and a != audit.draw_seeds(50, 8)
    published = (protocol.TRAINING, protocol.VALIDATION, protocol.TEST)
    assert not any(s in r for s in a for r in published)


def test_the_gap_of_equal_distributions_is_consistent():
    rng = np.random.default_rng(1)
    pairs = [({"t": rng.normal(3, 1, 50)}, {"t": rng.normal(3, 1, 50)}) for _ in range(5)]
    assert audit.gap(pairs).verdict == "consistent"
    shifted = [({"t": c["t"] + 1.0}, a) for c, a in pairs]
    assert audit.gap(shifted).verdict == "card above audit"


def test_a_run_that_cannot_be_audited_is_one_line_and_the_others_are_audited(tmp_path):
    """A run whose policy fails while it is scored stopped the whole audit (a ValueError
    became verify's usage error); now it is its own DIFF line, counted in the result."""
    amplitudes = cpg.load_amplitudes(os.path.join(GAIT, "selected_params.json"))
    gait = json.dumps({"amplitudes": dict(zip(cpg.AMPLITUDE_NAMES, amplitudes.tolist()))})
    runs = tmp_path / "runs" / "mine" / "darwin_walk"
    _run(runs / "a_seed0", "selected_params.json", gait)
    broken = _run(runs / "b_seed0", "selected_params.json", gait)
    (tmp_path / "runs" / "mine" / "darwin_walk" / "b_seed0" / "selected_params.json").write_text(
        json.dumps({"amplitudes": {"nope": 1.0}})
    )
    how = {"threads": 1, "trust_code": False, "trusted": frozenset()}
    seeds = audit.draw_seeds(2, entropy=1)
    assert isinstance(verify._audited(broken, seeds, how), str)
    assert isinstance(verify._audited(str(runs / "a_seed0"), seeds, how), tuple)
    line = verify._audited(broken, seeds, how)
    assert line.startswith("could not be audited: ") and "\n" not in line, line
