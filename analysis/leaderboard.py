r"""The leaderboard of a run tree: the DARwIn-OP board (docs/protocol.md#ranking; entering
it: docs/submit.md) and the study's metrics.

  python -m analysis.leaderboard --runs=DIR --out=board/leaderboard.csv
  # writes board/leaderboard.csv, board/darwin_leaderboard.csv, board/darwin_not_admitted.csv

Reads every `<DIR>/**/<method>/<task>/<run_name>/summary.json` (run files only) and writes

* `leaderboard.csv`: one row per (task, method, configuration, metric) over all seeds —
  `n`, `mean`, `std`, 95 % t-interval, `best`, the published value and its source, the
  ratio to it and whether it is beaten. A configuration is the run name without its
  `_seed<k>` suffix.
* `darwin_leaderboard.csv` beside it: the DARwIn-OP board (docs/protocol.md#ranking) of the
  runs it admits (docs/protocol.md#admission: what verify needs to score a run again, a
  card made under the protocol's card settings that the run's trials produce, no copies),
  and `darwin_not_admitted.csv`: every other DARwIn-OP run with a one-line reason; the
  same pair `_v<n>` for each earlier benchmark version whose cards the runs keep.

Missing or malformed run files are skipped and listed on stderr, never a crash. A folder
under the tree that is a symbolic link is not followed: it is listed as not admitted
(`admission.LINK_REFUSAL`). A name from disk is printed escaped where it is not printable
text (`admission.shown_name`: a newline in a folder's name forges no line). The
study's claims are judged in one place, `python -m analysis.study` (results/study).
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli, protocol

    cli.without_rendering()

import csv
import dataclasses
import math
import os
import sys
from collections import defaultdict

import numpy as np
from absl import flags

from analysis import published
from cpg_suite import cli, protocol
from cpg_suite.protocol import admission, aggregate, files
from cpg_suite.protocol.stats import mean_std_ci95

_SEED = admission.SEED_NAME  # `<config>_seed<S>`, S in ASCII digits (one definition)
IN_SAMPLE_METRIC = "in_sample_best_m"  # the in-sample best tried again (`_metric_value`)
# task -> [(metric, unit, higher is better)]: a key of summary.json, but for the DARwIn-OP
# walk: runs the board admits only, by what verify re-makes (`_metric_value`); a training
# record (`best_distance_m`, `final_mean_distance_m`: the submitter's word) is not shown.
METRICS = {
    "darwin_walk": [(IN_SAMPLE_METRIC, "m", True)],
    "pole_balance": [
        ("balanced_last_5000", "fraction of runs", True),
        ("falls", "falls", False),
        ("rms_angle_last_5000", "rad", False),
    ],
    "crawler_walk": [("displacement_m", "m per 100 moves", True), ("cycle_length", "states", True)],
    "tokic": [("cycle_reward", "reward per cycle", True), ("cycle_length", "states", True)],
    "darwin_balance": [("reward_before", "m per step", True), ("reward_after", "m per step", True)],
}
LEADERBOARD_FIELDS = [
    "task",
    "method",
    "config",
    "metric",
    "unit",
    "n",
    "mean",
    "std",
    "ci95_low",
    "ci95_high",
    "best",
    "published",
    "published_source",
    "checked_by",
]
# Who vouches for a row of the study's metrics: verify, which re-makes the DARwIn walk's
# in-sample best from the run's gait; for the other tasks, nothing but the run's own
# summary.json (no re-scorer exists for them: re-run the config's command to check).
CHECKED_BY_VERIFY = "verify, which re-makes it (the board reads it as stored)"
UNCHECKED = "nothing: the run's own summary.json"


PRESET_METHOD = (
    "preset"  # an untrained open-loop gait's score card (`cpg_suite.protocol.score --out`)
)


def _add_score_card(dirpath: str, found: list[dict], skipped: list[str]) -> None:
    """A `score.json` written by `cpg_suite.protocol.score --out=DIR` becomes a leaderboard
    row named after DIR, with no training task and no simulation budget."""
    path = os.path.join(dirpath, "score.json")
    try:
        card = files.read_json(path)
        if not isinstance(card, dict) or not isinstance(card.get("tiers"), dict):
            raise ValueError("not a score card")
    except (OSError, ValueError) as e:
        skipped.append(f"{admission.shown_name(path)}: {type(e).__name__}")
        return
    summary = {"test": card, "evaluations": 0, "sim_steps": 0, "best_distance_m": None}
    name = os.path.basename(os.path.normpath(dirpath))
    found.append(
        {
            "method": PRESET_METHOD,
            "task": "none",
            "config": name,
            "seed": None,
            "summary": summary,
            "dir": dirpath,
            "trained_version": None,
        }
    )


# The run tree in name order, without recursion and at most `files.MAX_TREE_DEPTH` deep:
# the board's sums and bootstrap draws take the runs in an order that does not depend on
# the file system's listing order (one definition: `files.walk_sorted`, which verify uses).
walk_sorted = files.walk_sorted


def find_runs(root: str) -> tuple[list[dict], list[str]]:
    """Every readable run, in path order: method, task, config, seed, summary; and the
    skipped paths (escaped, `admission.shown_name`). A folder that is a symbolic link is
    not followed: it is found as a run that is not admitted (`_add_link`), whatever it
    points at.

    Args:
      root: The run tree.

    Returns:
      `(found, skipped)`: one dict per run or part of one; one line per file skipped.
    """
    found, skipped, too_deep = [], [], []
    for dirpath, dirnames, filenames in walk_sorted(root, too_deep):
        for name in dirnames:  # a link to a folder is listed here, and never entered
            if os.path.islink(os.path.join(dirpath, name)):
                _add_link(os.path.join(dirpath, name), root, found)
        if "summary.json" not in filenames:
            if "score.json" in filenames:
                _add_score_card(dirpath, found, skipped)
            elif admission.looks_like_run(dirpath, filenames):
                _add_incomplete(dirpath, found)
            continue
        path = os.path.join(dirpath, "summary.json")
        parts = os.path.normpath(os.path.abspath(dirpath)).split(os.sep)  # `.`, `..` named
        if len(parts) < 4:
            skipped.append(f"{admission.shown_name(path)}: not <method>/<task>/<run>")
            continue
        method, task, run_name = parts[-3], parts[-2], parts[-1]
        if admission.file_refusal(dirpath):  # nothing of it is read: the board says why
            _add_incomplete(dirpath, found)
            continue
        try:
            summary = files.read_json(path)
            if not isinstance(summary, dict):
                raise ValueError("not an object")
        except (OSError, ValueError) as e:
            skipped.append(f"{admission.shown_name(path)}: {type(e).__name__}")
            _add_incomplete(dirpath, found)  # the board lists it, with why (admission)
            continue
        config_path = os.path.join(dirpath, "config.json")
        summary = _with_given_budget(summary, config_path)
        match = _SEED.match(run_name)
        config = match["config"] if match else run_name
        seed = int(match["seed"]) if match else None
        found.append(
            {
                "method": method,
                "task": task,
                "config": config,
                "seed": seed,
                "summary": summary,
                "dir": dirpath,
                "trained_version": trained_version(config_path),
            }
        )
    skipped += [
        f"{admission.shown_name(path)}: deeper than {files.MAX_TREE_DEPTH} folders below the "
        "runs folder, not read"
        for path in too_deep
    ]
    path = ledger_path(root)
    try:
        ledger = admission.read_ledger(path)
    except (OSError, ValueError) as e:  # a ledger the board may not read vouches for none
        ledger = {}
        why = admission.shown_reason(f"{type(e).__name__}: {e}")
        skipped.append(f"{admission.shown_name(path)}: {why}; no run on record")
    for run in found:  # the tree's ledger, which `admit` judges every run by
        run["board_ledger"] = ledger
        run["misplaced"] = (
            not run.get("linked")
            and run["method"] != PRESET_METHOD
            and _depth(run["dir"], root) != 3
        )
        if run["summary"] and not run.get("incomplete"):
            run["rescored_on"] = admission.rescored_in_full(run["dir"], ledger)
    return found, skipped


def _depth(run_dir: str, root: str) -> int:
    """How many folders below `root` a run lies (0: `root` is the run)."""
    rel = os.path.relpath(run_dir, root)
    return 0 if rel == os.curdir else len(os.path.normpath(rel).split(os.sep))


def ledger_path(root: str) -> str:
    """The ledger of a run tree's checks: `rescored.csv` beside it (`verify --record`)."""
    return os.path.join(os.path.dirname(os.path.abspath(root)), admission.LEDGER)


def _add_incomplete(dirpath: str, found: list[dict]) -> None:
    """A folder that holds part of a run (or is a submission's half-written folder) joins
    the runs found with no summary: the DARwIn-OP board lists it as not admitted, with
    what it lacks (`admission.run_refusal`), and no other table counts it."""
    parts = os.path.normpath(os.path.abspath(dirpath)).split(os.sep)
    if len(parts) < 4:
        return
    match = _SEED.match(parts[-1])
    found.append(
        {
            "method": parts[-3],
            "task": parts[-2],
            "config": match["config"] if match else parts[-1],
            "seed": int(match["seed"]) if match else None,
            "summary": {},
            "dir": dirpath,
            "trained_version": None,
            "incomplete": True,
        }
    )


def _add_link(path: str, root: str, found: list[dict]) -> None:
    """A folder under the tree that is a symbolic link (a run's, a method's, any): found as
    a run that is not admitted (`admission.path_refusal` says why), named by its place
    under `root` (its method, task and name as far as its depth tells); nothing through
    it is read.

    Args:
      path: The link.
      root: The run tree.
      found: The runs found (`find_runs`), appended to.
    """
    rel = os.path.normpath(os.path.relpath(path, root)).split(os.sep)
    # One level down: a method's folder; two: a task's; deeper: the last three.
    method, task, run_name = rel[-3:] if len(rel) >= 3 else [*rel, "", ""][:3]
    match = _SEED.match(run_name)
    found.append(
        {
            "method": method,
            "task": task,
            "config": match["config"] if match else run_name,
            "seed": int(match["seed"]) if match else None,
            "summary": {},
            "dir": path,
            "trained_version": None,
            "incomplete": True,
            "linked": True,
        }
    )


def trained_version(config_path: str) -> int:
    """The benchmark version a run trained under: its config's `benchmark_version` setting;
    1 (the study's unlimited physics) for a run made before the setting existed, or with no
    readable config (a score card)."""
    return admission.trained_version(os.path.dirname(config_path))


def _with_given_budget(summary: dict, config_path: str) -> dict:
    """The summary with `budget_control_steps`, a policy learner's training budget as it
    was given (config.json's `total_steps`): the learner trains whole rollouts, so its
    `env_steps` may pass it by less than one rollout."""
    if "env_steps" not in summary or not os.path.exists(config_path):
        return summary
    try:
        given = files.read_json(config_path)["settings"]["total_steps"]
    except (OSError, ValueError, KeyError, TypeError):
        return summary
    return {**summary, "budget_control_steps": given}


def _stats(values: list[float]) -> tuple[float, float, float, float]:
    return mean_std_ci95(values)


def _published(task: str, method: str, config: str, metric: str):
    """(value, source) of the study for this row, if it reports one."""
    if task == "darwin_walk" and method == "cem" and metric == IN_SAMPLE_METRIC:
        entry = published.TABLE6_3.get(config)
        if entry:  # The study's best trial of one Webots run: like our in-sample best.
            return entry[0], f"Webots, one run: {published.SOURCE} ({entry[2]}; u.d.)"
    if task == "crawler_walk" and metric == "displacement_m" and method in published.CRAWLER:
        value, source = published.CRAWLER[method]
        return value, source
    if task == "tokic" and metric == "cycle_length":
        return 6, "thesis Sec. 4.1.7, Fig. 4.3 (CR-1)"
    return None, ""


def _metric_value(summary: dict, metric: str):
    """A run's value of a study metric: its in-sample best tried again (`summary.json`'s
    `in_sample`, which verify re-makes) for `IN_SAMPLE_METRIC`, else the summary's key."""
    if metric == IN_SAMPLE_METRIC:
        return (summary.get("in_sample") or {}).get("distance_m")
    return summary.get(metric)


def leaderboard_rows(found: list[dict], admitted: list[dict] | None = None) -> list[dict]:
    """The study's metrics (`METRICS`), a row per task, method, configuration and metric.
    A DARwIn-OP run counts only if the board admits it: a copy is no seed, and a summary's
    training record that nothing re-makes is shown nowhere.

    Args:
      found: The runs (`find_runs`).
      admitted: The DARwIn-OP runs the board admits (`admit(found)`; None: worked out).

    Returns:
      The rows (`LEADERBOARD_FIELDS`).
    """
    if admitted is None:
        admitted, _ = admit(found)
    checked = {run["dir"]: run for run in admitted}
    groups = defaultdict(list)
    for run in found:
        if is_darwin_run(run):
            run = checked.get(run["dir"])
        if run is not None and not run.get("incomplete"):  # the study's own runs nest deeper
            groups[(run["task"], run["method"], run["config"])].append(run["summary"])
    rows = []
    for (task, method, config), summaries in sorted(groups.items()):
        for metric, unit, higher in METRICS.get(task, []):
            values = [_metric_value(s, metric) for s in summaries]
            values = [v for v in values if isinstance(v, (int, float, bool))]
            values = [float(v) for v in values if not isinstance(v, float) or math.isfinite(v)]
            if not values:
                continue
            mean, std, low, high = _stats(values)
            pub, source = _published(task, method, config, metric)
            rows.append(
                {  # names from disk, escaped where not printable
                    "task": task,
                    "method": admission.shown_name(method),
                    "config": admission.shown_name(config),
                    "metric": metric,
                    "unit": unit,
                    "n": len(values),
                    "mean": mean,
                    "std": std,
                    "ci95_low": low,
                    "ci95_high": high,
                    "best": max(values) if higher else min(values),
                    "published": "" if pub is None else pub,
                    "published_source": source,
                    "checked_by": CHECKED_BY_VERIFY if metric == IN_SAMPLE_METRIC else UNCHECKED,
                }
            )
    return rows


TIERS = protocol.TIERS  # every version's tiers; a board of version v ranks `protocol.tiers(v)`
# The card's gait-quality fields shown on the board (`admission.BOARD_MEASURES`: a table
# that holds measures holds these; tests/test_leaderboard.py checks them against
# cpg_suite.evaluation.quality.FIELDS).
QUALITY = admission.BOARD_MEASURES
# Budget tracks (docs/protocol.md#ranking): the study's budget is at most 2,501 training
# trials (K = 50 for 50 rounds, plus the start) or 2.5 M training control steps (PPO).
STUDY_TRIALS, STUDY_CONTROL_STEPS = 2501, 2_500_000
# How far a learner's `env_steps` may pass its config's `total_steps` and still count as
# that budget (it trains whole rollouts): a choice; the shipped runs pass it by at most
# 1.6 % (MJX PPO: 2,539,520 of 2.5 M), and a run past it counts by its `env_steps`.
LAST_ROLLOUT = 0.02
# A run's training physics steps (`sim_steps`) count too, as control steps of the DARwIn-OP
# model (`admission.PHYSICS_STEPS_PER_CONTROL_STEP`): a run that simulated more than its
# declared budget allows counts by what it simulated.
PHYSICS_STEPS = admission.PHYSICS_STEPS_PER_CONTROL_STEP
# Physics steps a run may simulate choosing what it reports (validation) beside its
# training budget: a tenth of the study's training simulation (2,500,000 control steps × 8).
# A choice: the protocol's own validation takes at most this (PPO's 10 seeds every 100,000
# training steps: 2,000,000; a gait search's 4 candidates on 10 seeds: 320,000); what a
# run simulates beyond it counts toward its track.
VALIDATION_ALLOWANCE = STUDY_CONTROL_STEPS * PHYSICS_STEPS // 10
TRACKS = ("study", "4x", "over_4x")
MIN_SEEDS = 5  # fewer seeds: provisional, not ranked
DARWIN_FIELDS = [
    "benchmark_version",
    "trained_version",
    "track",
    "rank",
    "status",
    "training_task",
    "method",
    "config",
    "n_seeds",
    "test_score_m",
    "test_ci95_low",
    "test_ci95_high",
    "test_fall_rate",
    "test_brownout_rate",
    "speed_m_s",
    "iqm_m",
    "iqm_ci95_low",
    "iqm_ci95_high",
    "p_improvement_next",
    "p_improvement_ci95_low",
    "p_improvement_ci95_high",
    "tied_with_next",
    *[f"{tier}_{x}" for tier in TIERS for x in ("score_m", "ci95_low", "ci95_high", "fall_rate")],
    *QUALITY,
    "budget_trials",
    "budget_sim_steps",
    "in_sample_best_m",
    "published_best_trial",
    "published_source",
    "rescored_full_runs",
    "rescored_full_on",
]


def _mean(values) -> float | str:
    values = [v for v in values if isinstance(v, (int, float)) and math.isfinite(v)]
    return float(np.mean(values)) if values else ""


def _mean_of_all(values) -> float | str:
    """`_mean` of values every seed has ("" if one has none)."""
    return _mean(values) if all(v is not None for v in values) else ""


def _test_score(tests: list[dict], tier: str | None = None) -> dict:
    """Mean test score over seeds (all common tiers, or one) with its interval — the run's
    bootstrap interval for one seed, the stratified bootstrap interval over the runs for
    more — and, for more, the IQM with its interval (`aggregate.summary`)."""
    if len(tests) == 1:
        card = tests[0]["all"] if tier is None else tests[0]["tiers"][tier]
        swd = card["success_weighted_distance_m"]
        return {"mean": swd["mean"], "mean_ci95": swd["ci95"]}
    tiers = (tier,) if tier else tuple(t for t in TIERS if all(t in c["tiers"] for c in tests))
    return aggregate.summary(score_matrix(tests, tiers))


def score_matrix(tests: list[dict], tiers: tuple[str, ...] = TIERS) -> np.ndarray:
    """(runs × tiers) success-weighted distances of a configuration's test cards.

    Args:
      tests: The runs' test cards (`summary["test"]`), each with `tiers`.
      tiers: The tiers (columns).
    """
    return np.array(
        [[t["tiers"][tier]["success_weighted_distance_m"]["mean"] for tier in tiers] for t in tests]
    )


def budget_track(summaries: list[dict]) -> str:
    """The budget track of a configuration's runs: "study" (at most 2,501 training trials,
    or 2.5 M training control steps given to a policy learner, `budget_control_steps` when
    known), "4x" (four times that) or "over_4x"; "" for presets (no training)."""
    if not any("evaluations" in s or "env_steps" in s for s in summaries):
        return ""
    ratio = max(_budget_ratio(s) for s in summaries)
    return "study" if ratio <= 1 else "4x" if ratio <= 4 else "over_4x"


def _budget_ratio(summary: dict) -> float:
    """A run's training budget over the study's (inf where it does not say it as a count:
    a refused run's summary, which a report of unadmitted cards still reads). What it
    simulated choosing its gait or policy beyond `VALIDATION_ALLOWANCE` counts with what it
    simulated training (`validation_sim_steps`, `sim_steps`: helper-51 chose among 2,500
    candidates on 50 seeds, 70 times the study's simulation, on the study's track)."""
    training, choosing = (summary.get(k, 0) for k in ("sim_steps", "validation_sim_steps"))
    if _is_count(training) and _is_count(choosing):
        physics = (training + max(0, choosing - VALIDATION_ALLOWANCE)) / PHYSICS_STEPS
    else:
        physics = math.inf  # control steps
    if "env_steps" in summary:
        steps, given = summary["env_steps"], summary.get("budget_control_steps")
        if not _is_count(steps):
            return math.inf
        steps = max(steps, physics)  # what it simulated counts, whatever it says it took
        if _is_count(given) and steps <= given * (1 + LAST_ROLLOUT):
            steps = given  # the learner's last whole rollout passed its budget
        return steps / STUDY_CONTROL_STEPS
    trials = summary.get("evaluations")
    if not _is_count(trials):
        return math.inf
    return max(trials / STUDY_TRIALS, physics / (STUDY_TRIALS * admission.TRIAL_STEPS))


def _is_count(value) -> bool:
    return type(value) is int and value >= 0


def _trained_as(version: int | None) -> int | None:
    """The version whose training physics `version` has (`protocol.trained_alike`): runs
    trained under versions 2 and 3 form one row, shown as trained under 2; an unknown
    version stands for itself (its runs are listed, never ranked)."""
    if version is None or version not in protocol.VERSIONS:
        return version
    return protocol.trained_alike(version)


# A configuration whose policy is code the project has not vetted (`admission.unvetted_code`):
# listed, not ranked (its card on the public test seeds may be a replay of them).
CODE_STATUS = "code"


# A configuration whose seeds are not 0, 1, ..., N−1: listed, not ranked. Its seeds may be
# the best N of more (helper-51 ranked CEM's best 5 of its 10 seeds 20 % above all 10).
GAPPED_STATUS = "gapped_seeds"


def _seeds_from_zero(summaries: list[dict]) -> bool:
    """Whether a configuration's runs are its seeds 0, 1, ..., N−1 (`find_runs`' seeds)."""
    seeds = [s.get("_seed") for s in summaries]
    return all(type(x) is int for x in seeds) and sorted(seeds) == list(range(len(seeds)))


def _status(track: str, trained: int | None, version: int, complete: bool) -> str:
    """A configuration's standing on the board of `version` (docs/protocol.md#ranking):
    "reference" (a preset: no training), "trained_v<n>" (trained under an earlier version
    of other training physics, `protocol.trained_alike`: listed, not ranked), "ranked" (at
    least `MIN_SEEDS` seeds, every tier), "provisional"."""
    if not track:
        return "reference"
    if trained is not None and _trained_as(trained) != _trained_as(version):
        return f"trained_v{trained}"
    return "ranked" if complete else "provisional"


def _rescored(summaries: list[dict]) -> dict:
    """What re-scored a configuration's runs in full: how many of its runs the ledger says
    reproduced with the files they hold now, and the latest such date (`verify --record`)."""
    dates = [s["_rescored_on"] for s in summaries if s.get("_rescored_on")]
    return {
        "rescored_full_runs": len(dates),
        "rescored_full_on": max(dates) if dates else "",
    }


def _darwin_row(key: tuple, summaries: list[dict]) -> dict:
    task, method, config, version, trained = key
    tests = [s["test"] for s in summaries]
    overall = _test_score(tests)
    track = budget_track(summaries)
    tiers = protocol.tiers(version)
    complete = len(summaries) >= MIN_SEEDS and all(set(tiers) <= set(t["tiers"]) for t in tests)
    status = _status(track, trained, version, complete)
    if status == "ranked" and not _seeds_from_zero(summaries):
        status = GAPPED_STATUS
    if status in ("ranked", "provisional") and any(s.get("_unvetted_code") for s in summaries):
        status = CODE_STATUS
    ranked = status == "ranked"
    row = {
        "benchmark_version": version,
        "trained_version": "" if trained is None else trained,
        "track": track,
        "status": status,
        "_scores": score_matrix(tests, tiers) if ranked else None,
        "training_task": task,
        "method": method,
        "config": config,
        "n_seeds": len(summaries),
        "test_score_m": overall["mean"],
        "test_ci95_low": overall["mean_ci95"][0],
        "test_ci95_high": overall["mean_ci95"][1],
        "test_fall_rate": _mean([t["all"]["fall_rate"]["value"] for t in tests]),
        "test_brownout_rate": _mean(
            [(t["all"].get("failures_by_cause") or {}).get("brownout") for t in tests]
        ),
        "speed_m_s": _mean([t["all"].get("speed_m_s") for t in tests]),
        "budget_trials": _mean([s.get("evaluations") for s in summaries]),
        "budget_sim_steps": _mean(
            [s.get("sim_steps", 0) + s.get("validation_sim_steps", 0) for s in summaries]
        ),
        # As tried again (`admission.verified_summary`): a seed without it blanks it.
        "in_sample_best_m": _mean_of_all(
            [(s.get("in_sample") or {}).get("distance_m") for s in summaries]
        ),
        **_rescored(summaries),
    }
    if ranked:
        row["iqm_m"] = overall["iqm"]
        row["iqm_ci95_low"], row["iqm_ci95_high"] = overall["iqm_ci95"]
    for tier in TIERS:
        if all(tier in t["tiers"] for t in tests):
            score = _test_score(tests, tier)
            mean, (low, high) = score["mean"], score["mean_ci95"]
            falls = _mean([t["tiers"][tier]["fall_rate"]["value"] for t in tests])
        else:
            mean = low = high = falls = ""
        row[f"{tier}_score_m"], row[f"{tier}_fall_rate"] = mean, falls
        row[f"{tier}_ci95_low"], row[f"{tier}_ci95_high"] = low, high
    for q in QUALITY:  # a seed whose card's medians are not checked blanks it (they are
        # absent: `verified_summary`); a median that is None (no trial of the seed had a
        # finite value) is left out of the mean, as before
        checked = all(q in t["all"]["quality"] for t in tests)
        row[q] = _mean([t["all"]["quality"][q] for t in tests]) if checked else ""
    pub, source = _published("darwin_walk", method, config, IN_SAMPLE_METRIC)
    row["published_best_trial"] = "" if pub is None else pub
    row["published_source"] = source
    return row


def darwin_rows(found: list[dict], version: int | None = None) -> list[dict]:
    """DARwIn-OP runs ranked by their test score (success-weighted distance over their
    version's test tiers), one row per (training task, method, configuration, benchmark
    version of the cards, training physics: `_trained_as` the version trained under) over
    its seeds. A configuration trained under other training physics than its cards'
    version is listed, not ranked (`_status`).

    These are the rows of the runs given, whatever they hold: the board ranks only the
    runs it admits (`darwin_board`, `admit`).

    The in-sample best stays a column; the study's number sits beside it only (the best
    trial of one Webots run in its own unit), never as a ratio or a verdict.

    Args:
      found: The runs (`find_runs`).
      version: Rank the cards under this benchmark version (kept as history where a run was
        re-scored since); None: each run's card as it stands.
    """
    groups = defaultdict(list)
    for run in found:
        darwin = run["task"].startswith("darwin_walk") or run["method"] == PRESET_METHOD
        card = admission.card_under(run["summary"], version)
        if darwin and card is not None:
            version_of_card = card.get("benchmark_version", 1)
            trained = _trained_as(run.get("trained_version"))
            key = (run["task"], run["method"], run["config"], version_of_card, trained)
            groups[key].append(
                {
                    **run["summary"],
                    "test": card,
                    "_rescored_on": run.get("rescored_on"),
                    "_seed": run.get("seed"),
                }
            )
    return _ranked([_darwin_row(key, summaries) for key, summaries in groups.items()])


# The board's list of the runs it refuses (`darwin_board`), one row per run.
NOT_ADMITTED_FIELDS = [
    "benchmark_version",
    "training_task",
    "method",
    "config",
    "seed",
    "run",
    "reason",
]
PRESET_REFUSAL = "a score card alone (score.json): no run that verify can score again"


def is_darwin_run(run: dict) -> bool:
    """Whether a run found by `find_runs` belongs on the DARwIn-OP board: a walking run, a
    preset's score card, or a folder that is a symbolic link (its task unknown: what it
    holds is not read, and the board lists it as not admitted rather than drop it)."""
    return (
        run["task"].startswith("darwin_walk")
        or not run["task"].isascii()  # a lookalike of a DARwIn task: listed, never dropped
        or run["method"] == PRESET_METHOD
        or bool(run.get("linked"))  # what it holds is not read: listed, never dropped
    )


def admit(
    found: list[dict], version: int | None = None, ledger: dict[str, dict] | None = None
) -> tuple[list[dict], list[dict]]:
    """The DARwIn-OP runs the board of `version` admits, and those it refuses, each with
    its one-line reason (`cpg_suite.protocol.admission`: the files verify needs, a card
    made under the protocol's card settings that its trial table produces, no copies).
    Reads JSON and CSV files only: nothing from a run folder is unpickled or imported.

    Args:
      found: The runs (`find_runs`), in path order.
      version: The board's benchmark version (None: `admission.BOARD_VERSION`).
      ledger: The ledger beside the runs' root (`ledger_path`; None: the one `find_runs`
        gave the runs, else each run's own).

    Returns:
      `(admitted, refused)`: the admitted runs (as in `found`) and one row per refused run
      (`NOT_ADMITTED_FIELDS`), both in path order; runs of other tasks are in neither.
    """
    board = admission.BOARD_VERSION if version is None else version
    if ledger is None:  # runs found under one root (`find_runs`) carry its ledger
        ledger = next((run["board_ledger"] for run in found if "board_ledger" in run), None)
    darwin = [run for run in found if is_darwin_run(run)]
    judged = [run["dir"] for run in darwin if not _score_card(run) and not run.get("misplaced")]
    reasons = admission.refusals(judged, board, ledger)
    admitted, refused = [], []
    dirs = [os.path.abspath(run["dir"]) for run in darwin if not _score_card(run)]
    base = os.path.commonpath(dirs) if dirs else ""
    for run in darwin:
        reason = (
            PRESET_REFUSAL
            if _score_card(run)
            else admission.DEPTH_REFUSAL
            if run.get("misplaced")
            else reasons.get(run["dir"])
        )
        if reason is None:
            admitted.append(_checked(run))
            continue
        parts = os.path.normpath(run["dir"]).split(os.sep)
        refused.append(
            {  # names from disk, escaped where not printable
                "benchmark_version": board,
                "training_task": admission.shown_name(run["task"]),
                "method": admission.shown_name(run["method"]),
                "config": admission.shown_name(run["config"]),
                "seed": "" if run["seed"] is None else run["seed"],
                "run": admission.shown_name(parts[-1])
                if _score_card(run)
                else admission.shown(run["dir"], base).replace(os.sep, "/"),
                "reason": reason,
            }
        )
    return admitted, refused


def _score_card(run: dict) -> bool:
    """Whether a run found is a preset's score card (`_add_score_card`), not a run folder."""
    return run["method"] == PRESET_METHOD and not run.get("linked")


def _checked(run: dict) -> dict:
    """An admitted run as the board shows it: a card's gait-quality medians only where its
    trial table holds the trials' measures (`admission.verified_summary`)."""
    if run["method"] == PRESET_METHOD:
        return run
    summary = admission.verified_summary(run["dir"], run["summary"])
    return {**run, "summary": {**summary, "_unvetted_code": admission.unvetted_code(run["dir"])}}


def darwin_board(found: list[dict], version: int | None = None) -> tuple[list[dict], list[dict]]:
    """The DARwIn-OP board of a benchmark version: the rows of the admitted runs
    (`darwin_rows`) and the refused runs with their reasons (`admit`).

    Args:
      found: The runs (`find_runs`).
      version: The board's benchmark version; None: the current one
        (`admission.BOARD_VERSION`).

    Returns:
      `(rows, not_admitted)`: the rows show the cards admission checked, those under the
      board's version.
    """
    board = admission.BOARD_VERSION if version is None else version
    admitted, refused = admit(found, board)
    return darwin_rows(admitted, board), refused


def history_versions(found: list[dict]) -> list[int]:
    """The benchmark versions of the cards kept as history in `found`, ascending."""
    versions = set()
    for run in found:
        cards = admission.cards_of(run["summary"]) if run["summary"] else {}
        if not isinstance(cards, str):  # a run whose cards do not hold together: refused
            versions.update(v for v in cards if v != max(cards))
    return sorted(versions)


def _ranked(rows: list[dict]) -> list[dict]:
    """The rows by track; in each, the ranked configurations by IQM (best first) with the
    probability of improvement of each over the next, then the provisional ones by mean
    test score; the presets last. Neighbours whose P(improvement) interval holds 0.5 are
    tied (docs/protocol.md#ranking)."""

    def order(row):
        track = TRACKS.index(row["track"]) if row["track"] in TRACKS else len(TRACKS)
        ranked = row.get("status") == "ranked"
        return (track, not ranked, -(row["iqm_m"] if ranked else row["test_score_m"]))

    rows.sort(key=order)
    for track in TRACKS:
        ranked = [r for r in rows if r["track"] == track and r.get("status") == "ranked"]
        for rank, row in enumerate(ranked, 1):
            row["rank"] = rank
        for upper, lower in zip(ranked, ranked[1:]):
            _compare(upper, lower)
    for row in rows:
        row.pop("_scores", None)
        if row.get("status") != "ranked":
            row["rank"] = ""
    return rows


def _compare(upper: dict, lower: dict) -> None:
    """Sets `upper`'s probability of improvement over `lower`, its interval, and the tie."""
    x, y = upper["_scores"], lower["_scores"]
    low, high = aggregate.improvement_interval(x, y)
    upper["p_improvement_next"] = aggregate.probability_of_improvement(x, y)
    upper["p_improvement_ci95_low"], upper["p_improvement_ci95_high"] = low, high
    upper["tied_with_next"] = bool(low <= 0.5 <= high)


def write_csv(path: str, rows: list[dict], fields: list[str]) -> None:
    tmp = path + ".tmp"
    with open(tmp, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    os.replace(tmp, path)


def check_runs_dir(runs: str | None) -> None:
    """Checks the `--runs` of an analysis command: an existing directory.

    Args:
      runs: The root of the run directories (None: not given).

    Raises:
      ValueError: With a one-line reason naming `--runs`.
    """
    cli.require(runs is not None, "--runs is required: the root of the run directories")
    cli.require(os.path.isdir(runs), f"--runs={runs} is not a directory")


@dataclasses.dataclass(frozen=True)
class LeaderboardSettings:
    """What `python -m analysis.leaderboard` reads and writes.

    Attributes:
      runs: The root of the run directories; must be an existing directory.
      out: The leaderboard CSV; `darwin_leaderboard.csv` goes beside it.
    """

    runs: str | None = None
    out: str = "leaderboard.csv"

    def __post_init__(self):
        check_runs_dir(self.runs)
        cli.require(bool(self.out), "--out must name a CSV file, got an empty path")


def write_tables(runs: str, out: str) -> str:
    """Writes the leaderboard and the DARwIn test-score table of a run tree.

    Writes `out`, and `darwin_leaderboard.csv` and `darwin_not_admitted.csv`
    (the runs the board refuses, with the reason) in the same folder (created if missing),
    and the boards of earlier benchmark versions (`darwin_tables`). Run files that cannot be
    read are skipped and listed on stderr.

    Args:
      runs: The root of the run directories.
      out: The leaderboard CSV path.

    Returns:
      One line saying how many runs and rows went where.

    Raises:
      ValueError: If `runs` is not a directory.
      OSError: If an output file cannot be written.
    """
    check_runs_dir(runs)
    found, skipped = find_runs(runs)
    current = admit(found)
    rows = leaderboard_rows(found, current[0])
    out_dir = os.path.dirname(os.path.abspath(out))
    os.makedirs(out_dir, exist_ok=True)
    write_csv(out, rows, LEADERBOARD_FIELDS)
    boards = darwin_tables(found, current=current)
    for name, table, fields in boards:
        write_csv(os.path.join(out_dir, name), table, fields)
    for line in skipped:
        print(f"skipped: {line}", file=sys.stderr)
    darwin, refused = boards[0][1], boards[1][1]
    # Each file with the folder it went to, as the user named it.
    beside = [os.path.join(os.path.dirname(out), name) for name, _, _ in boards]
    earlier = f"; earlier versions' boards -> {', '.join(beside[2:])}" if beside[2:] else ""
    return (
        f"{len(found)} runs: {len(rows)} rows of the study's metrics -> {out}; "
        f"{len(darwin)} DARwIn-OP board rows -> {beside[0]} ({len(refused)} runs not admitted "
        f"-> {beside[1]}){earlier}"
    )


def darwin_tables(
    found: list[dict],
    versions: tuple[int | None, ...] | None = None,
    current: tuple[list[dict], list[dict]] | None = None,
) -> list[tuple[str, list[dict], list[str]]]:
    """The DARwIn-OP boards' files: `darwin_leaderboard.csv` and `darwin_not_admitted.csv`
    (the current version), then `darwin_leaderboard_v<n>.csv` and
    `darwin_not_admitted_v<n>.csv` for each version whose cards runs keep as history.

    Args:
      found: The runs (`find_runs`).
      versions: The boards (None for the current one); default: the current one and
        every version of `history_versions`.
      current: The current board's `admit(found)`, where worked out already.

    Returns:
      `(file name, rows, fields)` per file, two per board, in that order.
    """
    tables = []
    for version in (None, *history_versions(found)) if versions is None else versions:
        suffix = "" if version is None else f"_v{version}"
        if version is None and current is not None:
            rows, refused = darwin_rows(current[0], admission.BOARD_VERSION), current[1]
        else:
            rows, refused = darwin_board(found, version)
        tables.append((f"darwin_leaderboard{suffix}.csv", rows, DARWIN_FIELDS))
        tables.append((f"darwin_not_admitted{suffix}.csv", refused, NOT_ADMITTED_FIELDS))
    return tables


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    flags.DEFINE_string(
        "runs", None, "none: required. Root of the run directories (an existing directory)."
    )
    flags.DEFINE_string(
        "out",
        LeaderboardSettings.out,
        "The study's metrics CSV; the DARwIn-OP board, darwin_leaderboard.csv, and "
        "darwin_not_admitted.csv go in its folder.",
    )


def main(argv: list[str]) -> None:
    del argv
    settings = cli.settings_from_flags(LeaderboardSettings)
    print(write_tables(settings.runs, settings.out))


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_files=("out",))
