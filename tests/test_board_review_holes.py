"""A second outside review of the board (2026-11-28): an in-sample best planted in a run
that did not train it, a round past its training, another run's in-sample gait, gains an
open-loop scorer never reads; each is refused."""

import json
import os
import shutil

import numpy as np

from cpg_suite import cpg, feedback
from cpg_suite.protocol import admission, copies

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RUNS = os.path.join(ROOT, "results", "protocol", "runs")
GAIT_RUN = os.path.join(RUNS, "cem", "darwin_walk", "K50_n0.8_e2_seed0")
PPO_RUN = os.path.join(RUNS, "ppo", "darwin_walk", "joints_seed0")


def _copy(tmp_path, source, method, name):
    dest = tmp_path / "runs" / method / "darwin_walk" / name
    shutil.copytree(source, dest)
    return dest


def _read(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def _write(path, value):
    path.write_text(json.dumps(value, indent=1))


def test_an_open_loop_gait_with_gains_the_scorer_never_reads_is_still_a_near_copy(tmp_path):
    """An open-loop run's scorer reads amplitudes only (`cpg.load_amplitudes`), but the
    copy check reads the file as a feedback gait (`feedback.load_params`): eleven junk gains
    (zero in the original) outvote the eleven amplitudes, so a copy with every amplitude
    times 1.03 (caught without the gains: all within ALL_RTOL) is no longer a copy."""
    run = _copy(tmp_path, GAIT_RUN, "cem", "K50_seed7")
    assert _read(run / "config.json")["settings"]["controller"] == "open_loop"
    amplitudes = {k: v * 1.03 for k, v in _read(run / "selected_params.json")["amplitudes"].items()}
    gains = {name: 90.0 for name in feedback.GAIN_NAMES}
    _write(run / "selected_params.json", {"amplitudes": amplitudes, "gains": gains})
    gait = ("selected_params.json",)
    # the scorer walks exactly the nudged gait: the gains are not read
    assert np.array_equal(
        cpg.load_amplitudes(str(run / "selected_params.json")), cpg.amplitudes_from(amplitudes)
    )
    original = copies.fingerprint(GAIT_RUN, gait, [])
    forged = copies.fingerprint(str(run), gait, [])
    # Fix: refuse gains in an open-loop run's gait file (gait_refusal with the controller),
    # or fingerprint a gait as its run's controller reads it (amplitudes only when open-loop).
    assert admission.gait_refusal(
        str(run / "selected_params.json")
    ) is not None or copies.same_artifact(forged, original)


def _plant_in_sample(run, best_params, distance_m):
    summary = _read(run / "summary.json")
    best = _read(best_params)
    best.update(distance_m=summary["best_distance_m"], fell=bool(summary.get("best_fell")), round=1)
    _write(run / "best_params.json", best)
    summary.update(
        best_round=1, best_fell=best["fell"], in_sample={"distance_m": distance_m, "fell": False}
    )
    _write(run / "summary.json", summary)


def test_a_policy_run_cannot_show_a_planted_gaits_in_sample_best(tmp_path):
    """A PPO run (its policy: selected_policy.npz) given a CEM gait as best_params.json and
    that gait's tried-again distance as in_sample: admitted, and verify's in_sample_trial
    reproduces it (it tries the gait with the run's config), so the PPO configuration's
    in-sample column shows a CEM gait's number. Measured on be66cb0: admission None;
    verify.in_sample_problems on the forged run agrees with 3.129133497444576."""
    run = _copy(tmp_path, PPO_RUN, "ppo", "joints_seed0")
    _plant_in_sample(run, os.path.join(GAIT_RUN, "best_params.json"), 3.129133497444576)
    assert admission.artifact_files(str(run)) == (admission.EXPORTED,)
    # A policy's run holds no in-sample gait: the board shows none, verify tries none.
    summary = _read(run / "summary.json")
    assert admission.verified_summary(str(run), summary)["in_sample"] is None
    assert not admission.has_in_sample(str(run))


def test_an_in_sample_round_past_the_runs_training_rounds_is_refused(tmp_path):
    """best_params.json's round picks the training seeds verify tries the gait on
    (`rounds.round_seeds`, per round with fresh_starts): a round the run never trained
    (10**9 of 50) lets a submitter choose among any number of seed sets."""
    run = _copy(tmp_path, GAIT_RUN, "cem", "K50_seed0")
    best = _read(run / "best_params.json")
    best["round"] = 10**9
    _write(run / "best_params.json", best)
    summary = _read(run / "summary.json")
    summary["best_round"] = 10**9
    _write(run / "summary.json", summary)
    assert summary["rounds"] == 50
    # Fix: 1 <= round <= settings["rounds"] (+ 1 if the final mean's trial may be the best).
    assert admission.run_refusal(str(run)) is not None


def test_best_params_json_is_fingerprinted_for_copies(tmp_path):
    """The in-sample column now shows best_params.json tried again, but the copy check never
    reads it: another run's best gait pasted in as best_params.json (summary's best_*
    updated to match) is admitted and not a copy."""
    run = _copy(tmp_path, GAIT_RUN.replace("seed0", "seed1"), "cem", "K50_seed1")
    _plant_in_sample(run, os.path.join(GAIT_RUN, "best_params.json"), 3.129133497444576)
    other = _copy(tmp_path, GAIT_RUN, "cem", "K50_seed0")
    refusals = admission.refusals([str(other), str(run)])
    # Fix: compare IN_SAMPLE gaits across runs too (copies.copy_of on best_params.json),
    # or refuse an in-sample gait equal to another run's.
    (reason,) = refusals.values()  # one of the two, the later by the ledger or start time
    assert "the same in-sample gait as values" in reason
