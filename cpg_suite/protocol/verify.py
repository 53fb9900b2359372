r"""Shipped leaderboard artifacts: make them from run directories, and re-score them.

  python -m cpg_suite.protocol.verify                      # every shipped run, bit for bit
  python -m cpg_suite.protocol.verify --quick              # the code's check, about 3 minutes
  python -m cpg_suite.protocol.verify --sample=20          # 20 trials a run, drawn afresh (CI: 10)
  python -m cpg_suite.protocol.verify --audit=10           # every run on 10 fresh seeds a tier
  python -m cpg_suite.protocol.verify --record=results/protocol/rescored.csv  # the ledger
  python -m cpg_suite.protocol.verify --jobs=4             # four runs at a time (default 2)
  python -m cpg_suite.protocol.verify --ship_from=runs     # copy finished runs in first
  python -m cpg_suite.protocol.verify --update_cards       # after the card gains a measure
  python -m cpg_suite.protocol.verify --rescore=ppo_mjx    # after a policy's arithmetic changed
  python -m cpg_suite.protocol.verify --artifacts=runs --trust_code  # runs that are code too

Every run folder is first checked as the leaderboard admits runs
(`cpg_suite.protocol.admission`); a folder it would refuse — a file missing, a card made
under other settings than the protocol's, a trial table that does not produce the card, a
copy of another seed — is reported `REFUSED` with the reason and counts as a difference.

A shipped run is a folder `<artifacts>/<method>/<task>/<run_name>/` holding what stands
behind its leaderboard row (docs/protocol.md#shipped-artifacts):

  * `config.json`: the run's settings, the command that re-runs it (output directory
    written as `runs`) and the package versions it was made with;
  * `summary.json`: its results and the selected gait's test score card;
  * `selected_params.json`: the gait the run reports (amplitudes, or feedback parameters),
    with `best_params.json` (its best training trial's gait, in-sample) and `progress.csv`
    (its rounds); or, for a policy learner, `selected_model.zip` and
    `selected_vecnormalize.pkl` (the SB3 model and its observation normalizer), or
    `selected_policy.npz` (a policy exported to NumPy, `cpg_suite.runfiles.exported`), and
    `progress.csv` (its learning curve); or, for a submission (`cpg_suite.protocol.submit`),
    `selected_actions.npy` (an open-loop table of actions, `exported.ActionTable`) or
    `policy_code.py` (a Python file whose `make_policy()` returns the policy);
  * `trials.csv`: the card's trials, one row per tier and test seed (`score.TRIAL_FIELDS`);
  * `versions.json`: the versions it was made with and those it was scored with here.

`verify` re-scores every shipped gait on the test protocol and compares the card and each
trial with what is stored: the same bits on the same package versions
(`results/protocol/constraints.txt` pins those of the reference results). Exit code 1 on
any difference. `--quick` re-scores the first 5 test seeds of every tier for the first run
of each configuration and compares those trials only.

Code runs only when asked (docs/protocol.md#data-and-code). The gait, an exported policy and
an action table are data: JSON, and NumPy arrays read without unpickling. A run whose
policy is code — `policy_code.py`, or an SB3 policy's pickles, which run code when loaded —
is scored only with `--trust_code` (`trust_code=True`), or, for SB3 pickles, when the
SHA-256 of each is listed in the package's `cpg_suite/data/trusted_pickles.txt` (the
shipped runs': `trusted_artifacts_text`, `--write_trusted`) or in a list given with
`--trusted_list` — never in a file found in the working directory; otherwise it is
`REFUSED` with the reason and nothing of it is loaded (`code_refusal`).

When the score card gains a measure, `--update_cards` re-scores every shipped run, checks
that every trial is unchanged (the gait does what it did), and only then rewrites the
card in `summary.json`, its trial tables (each trial's gait-quality measures beside its
outcome, which the card's medians are made from), a gait run's in-sample best tried again
(`in_sample`), and records the versions it was scored with. When the code that
runs a shipped policy changes its arithmetic (not the policy), `--rescore=SUBFOLDER`
re-scores the shipped runs under that part of the artifacts and stores their new cards
and trials (`rescore_run`); the learning curves and validation scores stay as trained.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import concurrent.futures
import contextlib
import dataclasses
import json
import multiprocessing
import os
import shutil
from collections.abc import Callable

import numpy as np
from absl import flags

from cpg_suite import cli, cpg, evaluation, feedback, progress, protocol
from cpg_suite.protocol import admission, audit, sample, sandbox, score
from cpg_suite.protocol import card as card_stats
from cpg_suite.protocol.files import refusal as file_problem
from cpg_suite.protocol.files import walk_sorted
from cpg_suite.runfiles import exported, runs

ARTIFACTS = os.path.join("results", "protocol", "runs")  # the reference results' artifacts
# Copied as they are (config.json is relocated, summary.json gets the fresh card): a gait
# run's, and a policy learner's.
COPIED = ("selected_params.json", "best_params.json", "progress.csv")
COPIED_POLICY = ("selected_model.zip", "selected_vecnormalize.pkl", "progress.csv")
COPIED_EXPORTED = (exported.FILE, "progress.csv")
COPIED_ACTIONS = (admission.ACTIONS,)  # a submitted action table
COPIED_CODE = (admission.CODE,)  # a submitted policy's code
_GAIT, _POLICY, _EXPORTED = COPIED[0], COPIED_POLICY[0], COPIED_EXPORTED[0]
_ARTIFACT_NAMES = {files[0] for files in admission.ARTIFACTS}
QUICK_SEEDS = 5  # test seeds per tier in a quick verification
# The project's list of trusted pickles, shipped inside the package (never read from the
# working directory): the SHA-256 and path of every Stable-Baselines3 file under
# `ARTIFACTS`, as `sha256sum` writes them (in a checkout, `sha256sum -c
# cpg_suite/data/trusted_pickles.txt` checks it). `--trusted_list=PATH` names another.
TRUSTED_LIST = admission.TRUSTED_LIST
TRUSTED_NAME = "cpg_suite/data/trusted_pickles.txt"  # how messages name it
_CHECKOUT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def one_line(text: str) -> str:
    """`text` as verify prints it: control and other unprintable characters (a newline in
    a folder's name or a policy's message) escaped, so that nothing read from a run or said
    by a policy can start a line of verify's report of its own."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def repository() -> str:
    """The checkout this module sits in (its shipped runs' paths in the trusted list are
    relative to it). Never the working directory: nothing found there is trusted."""
    return _CHECKOUT


SB3_FILES = (admission.SB3_MODEL, admission.SB3_NORMALIZER)


class UntrustedCode(ValueError):
    """A run's policy is code that was not trusted (`code_refusal`): it was not loaded."""


class NotAdmitted(ValueError):
    """A maintenance call was given a run the board refuses: nothing was changed."""


def shipped_runs(root: str) -> list[str]:
    """The run folders under `root` (a summary and a selected gait or policy), sorted."""
    found = []
    for dirpath, _, names in walk_sorted(root):
        if "summary.json" in names and _ARTIFACT_NAMES & set(names):
            found.append(dirpath)
    return sorted(found)


def run_folders(root: str) -> list[str]:
    """The folders under `root` that look like runs (a summary, a trial table, or a gait or
    policy file), sorted: the shipped runs and those that lack a file (`admission`)."""
    marks = {"summary.json", "trials.csv", *_ARTIFACT_NAMES}
    return sorted(dirpath for dirpath, _, names in walk_sorted(root) if marks & set(names))


file_digest = admission.file_digest
trusted_digests = admission.trusted_digests


def trusted_artifacts_text(artifacts: str | None = None, root: str | None = None) -> str:
    """The trusted list of the pickles shipped under `artifacts`: a line `<sha256>  <path>`
    for every Stable-Baselines3 file (`SB3_FILES`) of a run, sorted by path, the path
    relative to the repository (what `TRUSTED_LIST` holds).

    Args:
      artifacts: A folder of shipped runs (None: the project's, `ARTIFACTS` under `root`).
      root: The checkout the paths are relative to (None: the one this module sits in;
        an installed package sits in none, so its tests name their checkout).
    """
    root = repository() if root is None else root
    artifacts = os.path.join(root, ARTIFACTS) if artifacts is None else artifacts
    lines = []
    for dirpath, _, names in os.walk(artifacts):
        for name in sorted(set(names) & set(SB3_FILES)):
            path = os.path.join(dirpath, name)
            relative = os.path.relpath(path, root).replace(os.sep, "/")
            lines.append((relative, f"{file_digest(path)}  {relative}"))
    return "".join(f"{line}\n" for _, line in sorted(lines))


def code_refusal(
    run_dir: str, trust_code: bool = False, trusted: frozenset[str] | None = None
) -> str | None:
    """Why verify does not load a run's policy without being asked to (None: it may).

    A run's `policy_code.py` is executed only with `trust_code`; its Stable-Baselines3
    pickles are loaded with `trust_code` or when the SHA-256 of each is trusted. Data
    (a gait, an exported policy, an action table) is always loaded. Nothing is loaded here.

    Args:
      run_dir: A run folder.
      trust_code: Whether its code may run whatever it is (`--trust_code`).
      trusted: The trusted digests (None: `trusted_digests()`).

    Returns:
      A one-line reason, or None.
    """
    files = admission.artifact_files(run_dir)
    if trust_code or not files or files[0] not in admission.CODE_FILES:
        return None
    if files == (admission.CODE,):
        return f"its {admission.CODE} runs code: re-run with --trust_code to execute it"
    trusted = trusted_digests() if trusted is None else trusted
    untrusted = [n for n in files if file_digest(os.path.join(run_dir, n)) not in trusted]
    if not untrusted:
        return None
    return (
        f"its {' and '.join(untrusted)} (pickles: loading runs code) "
        f"{'is' if len(untrusted) == 1 else 'are'} not in {TRUSTED_NAME}: re-run with "
        "--trust_code to load them"
    )


def card_settings(
    config: dict, seeds: int | None = None, threads: int = 2, card: dict | None = None
) -> score.ScoreSettings:
    """The score settings a run's card was made with.

    Args:
      config: The run's config.json.
      seeds: Test seeds per tier (None: the run's own).
      threads: Evaluator threads (the results do not depend on it).
      card: The run's stored card, whose tiers, benchmark version and supply window it
        takes (None or a card without them: the run's tiers for version 1).

    Returns:
      The settings `score.score_gait_trials` and `score.score_policy_trials` take.
    """
    s = config["settings"]
    card = card or {}
    version = card.get("benchmark_version", 1)
    stored_tiers = card.get("tiers")
    if isinstance(stored_tiers, dict) and stored_tiers:
        tiers = tuple(stored_tiers)  # what the card scored (admission checks they are right)
    else:
        tiers = protocol.card_tiers(s.get("test_tiers"), version)
    return score.ScoreSettings(
        tiers=tiers,
        seeds=s["test_seeds"] if seeds is None else seeds,
        steps=s["trial_steps"],
        threads=threads,
        controller=s.get("controller", "open_loop"),
        benchmark_version=version,
        supply_window=card.get("settings", {}).get(
            "supply_window", score.ScoreSettings.supply_window
        ),
    )


def stored_card(run_dir: str) -> dict | None:
    """The test card a run's summary.json holds (None: none yet)."""
    path = os.path.join(run_dir, "summary.json")
    return runs.read_json(path).get("test") if os.path.exists(path) else None


def gait_params(run_dir: str, controller: str, name: str = "selected_params.json") -> np.ndarray:
    """A gait run's selected parameters (`selected_params.json`, or another gait file it
    holds): the CPG's amplitudes, or the feedback CPG's amplitudes and gains (`controller`
    "feedback")."""
    path = os.path.join(run_dir, name)
    if controller == "feedback":
        return feedback.load_params(path)
    return cpg.load_amplitudes(path)


def rescore(
    run_dir: str,
    seeds: int | None = None,
    threads: int = 2,
    trust_code: bool = False,
    trusted: frozenset[str] | None = None,
) -> tuple[dict, list[dict]]:
    """Scores a run's selected gait or policy again: `(card, trials)` as
    `score.score_gait_trials`.

    Args:
      run_dir: A run directory or a shipped run.
      seeds: Test seeds per tier (None: as many as the run's card has).
      threads: Evaluator threads (the results do not depend on it).
      trust_code: Whether a policy that is code may run (`code_refusal`).
      trusted: The trusted pickles' digests (None: the package's list).

    Raises:
      OSError, KeyError, ValueError: On a run without a readable config or gait.
      UntrustedCode: If its policy is code not trusted (nothing of it is loaded).
    """
    return score_run(run_dir, run_settings(run_dir, seeds, threads), trust_code, trusted)


def run_settings(run_dir: str, seeds: int | None = None, threads: int = 2) -> score.ScoreSettings:
    """`card_settings` of a run directory: its config.json and its stored card."""
    config = runs.read_json(os.path.join(run_dir, "config.json"))
    return card_settings(config, seeds, threads, stored_card(run_dir))


def score_run(
    run_dir: str,
    settings: score.ScoreSettings,
    trust_code: bool = False,
    trusted: frozenset[str] | None = None,
) -> tuple[dict, list[dict]]:
    """Scores a run's selected gait or policy under `settings`: `(card, trials)` as
    `score.score_gait_trials` (an SB3 policy with single-threaded torch).

    Raises:
      UntrustedCode: If its policy is code not trusted (`code_refusal`; not loaded).
    """
    policy = shipped_policy(run_dir, trust_code, trusted)
    if policy is None:
        return score.score_gait_trials(gait_params(run_dir, settings.controller), settings)
    with policy_threads(run_dir), _closed_after(policy):
        return score.score_policy_trials(policy, settings)


@contextlib.contextmanager
def _closed_after(policy):
    """Closes a policy that has a process of its own (`sandbox.IsolatedPolicy`) when its
    scoring ends, however it ends: its process does not outlive the run's check."""
    try:
        yield
    finally:
        close = getattr(policy, "close", None)
        if callable(close):
            close()


def shipped_policy(
    run_dir: str, trust_code: bool = False, trusted: frozenset[str] | None = None
) -> Callable[[dict], np.ndarray] | None:
    """A run's selected policy, or None if the run selected a gait.

    Args:
      run_dir: A run directory or a shipped run.
      trust_code: Whether a policy that is code may run whatever it is (`code_refusal`).
      trusted: The trusted pickles' digests (None: the package's list).

    Returns:
      The exported (`selected_policy.npz`), action-table (`selected_actions.npy`), coded
      (`policy_code.py`) or Stable-Baselines3 (`selected_model.zip`) policy, as
      `score.policy_trial` runs it; None for a gait run (`selected_params.json`).

    Raises:
      OSError, KeyError, ValueError: On a run without a readable config or policy.
      UntrustedCode: If its policy is code not trusted (nothing of it is loaded).
    """
    files = admission.artifact_files(run_dir)
    if files in ((), (_GAIT,)):
        return None
    reason = code_refusal(run_dir, trust_code, trusted)
    if reason:
        raise UntrustedCode(f"{run_dir}: {reason}")
    path = os.path.join(run_dir, files[0])
    if files[0] == _EXPORTED:
        return exported.NumpyPolicy.load(path)
    if files[0] == admission.ACTIONS:
        return exported.ActionTable.load(path)
    if files[0] == admission.CODE:
        return sandbox.IsolatedPolicy(path)  # its own process: it sees observations only
    from cpg_suite.runfiles import sb3_policy  # the `rl` extra: only runs of policy learners

    config = runs.read_json(os.path.join(run_dir, "config.json"))
    method = os.path.basename(os.path.dirname(os.path.dirname(os.path.abspath(run_dir))))
    return sb3_policy.load_shipped_policy(run_dir, method, config["settings"])


def policy_threads(run_dir: str) -> contextlib.AbstractContextManager:
    """Single-threaded torch while a run's Stable-Baselines3 policy acts (its results then do
    not depend on threads); nothing for other runs."""
    if admission.artifact_files(run_dir) == SB3_FILES:
        from cpg_suite.runfiles import sb3_policy

        return sb3_policy.single_threaded()
    return contextlib.nullcontext()


def _jsonable(value):
    """`value` as it reads back from JSON (so that a fresh card compares with a stored one)."""
    return json.loads(json.dumps(runs.to_jsonable(value)))


def write_trials(path: str, trials: list[dict]) -> None:
    """Writes the trial table (`admission.trial_cells`: the outcome, then a column per
    gait-quality measure); floats with all their digits (they read back exactly)."""
    runs.write_text(path, admission.table_text(trials))


read_trials = admission.read_trials  # the trial table as `score.score_gait_trials` returns it


def _relocated(config: dict) -> dict:
    """The config with the run's output directory written as `runs` (no machine's path)."""
    command = config.get("command") or ""
    words = [
        "--output_dir=runs" if w.startswith("--output_dir=") else w for w in command.split(" ")
    ]
    return {**config, "command": " ".join(words)}


extends = card_stats.extends  # a fresh card holds every value of a stored one


def ship(run_dir: str, dest: str, threads: int = 2, trust_code: bool = False) -> str:
    """Copies a finished run's artifacts into `dest` and adds its trials and versions.

    The gait or policy is scored again; its card must equal the run's own, or extend it
    with measures added to the card since the run (`extends`); else nothing is written.
    The shipped summary holds the fresh card, and a gait run's in-sample best tried again
    (`store_in_sample`).

    Args:
      run_dir: A finished run directory (summary with a test card, selected gait).
      dest: The shipped run's folder (created).
      threads: Evaluator threads.
      trust_code: Whether a policy that is code may run (`code_refusal`).

    Returns:
      `dest`.

    Raises:
      ValueError: If the run has no test card, or the fresh card differs from it.
      UntrustedCode: If its policy is code not trusted (nothing is loaded or written).
    """
    copied = [os.path.join(run_dir, name) for name in _copied(run_dir)]
    reason = admission.file_refusal(run_dir) or next(filter(None, map(file_problem, copied)), None)
    if reason:
        raise ValueError(f"{run_dir}: {reason}")
    summary = runs.read_json(os.path.join(run_dir, "summary.json"))
    if "test" not in summary:
        raise ValueError(f"{run_dir} has no test score card")
    card, trials = rescore(run_dir, threads=threads, trust_code=trust_code)
    fresh = _jsonable(score.stored_card(card))
    if not extends(fresh, summary["test"]):
        raise ValueError(f"{run_dir}: scored again, its card differs from the run's")
    config = runs.read_json(os.path.join(run_dir, "config.json"))
    os.makedirs(dest, exist_ok=True)
    for path in copied:
        shutil.copyfile(path, os.path.join(dest, os.path.basename(path)))
    _write_summary(os.path.join(dest, "summary.json"), {**summary, "test": fresh})
    runs.write_json(os.path.join(dest, "config.json"), _relocated(config))
    write_trials(os.path.join(dest, "trials.csv"), trials)
    versions = {"made_with": config.get("environment"), "scored_with": runs.environment_record()}
    runs.write_json(os.path.join(dest, "versions.json"), versions)
    store_in_sample(dest, threads)  # a gait run's in-sample best, tried again
    return dest


def _copied(run_dir: str) -> tuple[str, ...]:
    """The artifacts of a run copied as they are: an exported policy's, an SB3 policy's, an
    action table's, a coded policy's or a gait's (`admission.artifact_files`' choice)."""
    first = (admission.artifact_files(run_dir) or (_GAIT,))[0]
    by_first = {
        _EXPORTED: COPIED_EXPORTED,
        _POLICY: COPIED_POLICY,
        admission.ACTIONS: COPIED_ACTIONS,
        admission.CODE: COPIED_CODE,
    }
    return by_first.get(first, COPIED)


def unshippable(run_dir: str) -> list[str]:
    """What a finished run folder lacks of what `ship` copies (empty: nothing).

    Args:
      run_dir: A run directory.

    Returns:
      The missing file names; the gait or policy as one phrase when there is none.
    """
    missing = [n for n in ("summary.json", "config.json") if not _isfile(run_dir, n)]
    if not admission.artifact_files(run_dir):
        return [*missing, f"the gait or policy ({admission.artifact_phrase()})"]
    return missing + [n for n in _copied(run_dir) if not _isfile(run_dir, n)]


def _isfile(run_dir: str, name: str) -> bool:
    return os.path.isfile(os.path.join(run_dir, name))


def ship_all(
    root: str,
    artifacts: str,
    log: Callable[[str], None] = progress.write,
    trust_code: bool = False,
) -> int:
    """Ships every finished DARwIn-OP run under `root` into `artifacts` (same layout),
    except those shipped before.

    A folder that lacks a file `ship` copies is named with what it lacks, one line each; so
    is a run whose policy is code not trusted (`code_refusal`; nothing of it is loaded); a
    shipped run the leaderboard would not admit (`admission.run_refusal`: a card under
    other settings than the protocol's, say) is shipped and named with the reason.

    Args:
      root: The finished runs.
      artifacts: The folder of shipped runs.
      log: Given a line per run named.
      trust_code: Whether a policy that is code may run (`--trust_code`).

    Returns:
      How many runs were shipped.
    """
    shipped = 0
    for run_dir in run_folders(root):
        dest = os.path.join(artifacts, os.path.relpath(run_dir, root))
        try:
            line = _ship_one(run_dir, dest, trust_code)
        except (OSError, ValueError) as e:  # this run's files or card: the others go on
            line = f"not shipped {run_dir}: {e}"
        if line:
            log(one_line(line))
            shipped += line.startswith("shipped ")
    return shipped


def _ship_one(run_dir: str, dest: str, trust_code: bool) -> str | None:
    """`ship_all`'s work on one run: its line (None: shipped before, nothing to say)."""
    reason = admission.file_refusal(run_dir)  # links, devices, oversized files: not read
    if reason:
        return f"not shipped {run_dir}: {reason}"
    missing = unshippable(run_dir)
    if missing:
        return f"not shippable {run_dir}: missing {', '.join(missing)}"
    summary = runs.read_json(os.path.join(run_dir, "summary.json"))
    if "test" not in summary:
        return f"skipped {run_dir}: no test score card"
    if os.path.exists(os.path.join(dest, "trials.csv")):
        return None  # shipped before (`verify` checks it)
    reason = code_refusal(run_dir, trust_code)
    if reason:
        return f"not shipped {run_dir}: {reason}"
    ship(run_dir, dest, trust_code=trust_code)
    reason = admission.run_refusal(dest)
    return f"shipped {dest}" + (f"; the board will not admit it: {reason}" if reason else "")


def fresh_scoring(
    run_dir: str,
    threads: int = 2,
    trust_code: bool = False,
    trusted: frozenset[str] | None = None,
) -> tuple[tuple[dict, list[dict]], list[tuple[int, dict, list[dict]]]]:
    """A shipped run scored again, its card made anew with the trials behind it, and each
    card it keeps as history made again with its trials, if its trials are unchanged and
    those cards reproduce (as `verify_run` checks them: a full check):
    `((card, trials), [(version, card, trials), ...])`.

    Raises:
      ValueError: If a trial differs from `trials.csv`, or a history card differs.
      UntrustedCode: If its policy is code not trusted (nothing is loaded).
    """
    summary = runs.read_json(os.path.join(run_dir, "summary.json"))
    how = (threads, trust_code, trusted)
    (card, trials), alike = score_with_history(run_dir, summary, None, *how)
    problems = _compare(run_dir, summary, trials, None, alike, quick=False)
    others, more = _history_scored(run_dir, summary, None, *how)
    problems += more
    if problems:
        what = "; ".join(problems)
        raise ValueError(f"{run_dir}: its trials changed ({what}); ship the run again instead")
    return (card, trials), alike + others


def update_card(
    run_dir: str,
    threads: int = 2,
    trust_code: bool = False,
    trusted: frozenset[str] | None = None,
) -> None:
    """Re-scores a shipped run and stores the new card, if its trials are unchanged, with
    its trial tables made again: each trial's gait-quality measures beside its outcome
    (a card kept as history keeps its card, and its table gains the measures it holds).

    Args:
      run_dir: A shipped run.
      threads: Evaluator threads.
      trust_code: Whether a policy that is code may run (`code_refusal`).
      trusted: The trusted pickles' digests (None: the package's list).

    Raises:
      ValueError: If a trial differs from `trials.csv` (nothing is written then).
      UntrustedCode: If its policy is code not trusted (nothing is loaded or written).
    """
    _store_scoring(run_dir, *fresh_scoring(run_dir, threads, trust_code, trusted))
    store_in_sample(run_dir, threads)


def _store_scoring(run_dir: str, test: tuple[dict, list[dict]], history: list) -> None:
    """Stores `fresh_scoring`'s card and tables (history cards as they are kept)."""
    summary = runs.read_json(os.path.join(run_dir, "summary.json"))
    for version, _, trials in history:
        kept = summary["history"][f"v{version}"]
        write_trials(os.path.join(run_dir, history_trials_file(version)), _measured(trials, kept))
    write_trials(os.path.join(run_dir, "trials.csv"), test[1])
    _store_card(run_dir, test[0])


def _measured(trials: list[dict], card: dict) -> list[dict]:
    """Trials with the gait-quality measures a card holds (none if it holds one that they
    lack: a measure since renamed or dropped)."""
    names = list(card["all"].get("quality") or {})
    if not all(name in (t.get("quality") or {}) for t in trials for name in names):
        return [{k: v for k, v in t.items() if k != "quality"} for t in trials]
    return [{**t, "quality": {name: t["quality"][name] for name in names}} for t in trials]


SCORED_KEYS = ("test", "history", "in_sample")
"""What scoring adds to a run's summary, written last and in this order, so a summary's bytes
depend on what it holds, not on the order in which its parts were made."""


def _write_summary(path: str, summary: dict) -> None:
    """Writes a shipped run's summary: its training record, then `SCORED_KEYS`."""
    trained = {k: v for k, v in summary.items() if k not in SCORED_KEYS}
    runs.write_json(path, {**trained, **{k: summary[k] for k in SCORED_KEYS if k in summary}})


def _store_card(run_dir: str, card: dict) -> None:
    """Writes a fresh card into a shipped run's summary and the versions it was scored with."""
    summary_path = os.path.join(run_dir, "summary.json")
    summary = runs.read_json(summary_path)
    _write_summary(summary_path, {**summary, "test": _jsonable(score.stored_card(card))})
    _record_scoring(run_dir)


def _record_scoring(run_dir: str) -> None:
    """Records in a shipped run's versions.json the versions its cards were scored with."""
    versions_path = os.path.join(run_dir, "versions.json")
    versions = runs.read_json(versions_path)
    versions["scored_with"] = runs.environment_record()
    runs.write_json(versions_path, versions)


def rescore_run(
    run_dir: str,
    threads: int = 2,
    trust_code: bool = False,
    trusted: frozenset[str] | None = None,
) -> None:
    """Re-scores a shipped run and stores its cards and trials, whatever they were.

    For a change to the code that runs a shipped policy, not to the policy: its test card,
    with the cards it keeps as history that the test card's version scores alike
    (`score_with_history`), and those it keeps of other physics (`rescore_history`) are
    made again; each that changed is stored with its trials and the versions it was scored
    with. A run whose cards all reproduce keeps its files, byte for byte (and its ledger
    row).

    Args:
      run_dir: A shipped run.
      threads: Evaluator threads.
      trust_code: Whether a policy that is code may run (`code_refusal`).
      trusted: The trusted pickles' digests (None: the package's list).

    Raises:
      OSError, KeyError, ValueError: On a run without a readable config or policy.
      UntrustedCode: If its policy is code not trusted (nothing is loaded or written).
    """
    summary = runs.read_json(os.path.join(run_dir, "summary.json"))
    (card, trials), alike = score_with_history(run_dir, summary, None, threads, trust_code, trusted)
    if trials != read_trials(os.path.join(run_dir, "trials.csv")) or summary["test"] != (
        _jsonable(score.stored_card(card))
    ):
        write_trials(os.path.join(run_dir, "trials.csv"), trials)
        _store_card(run_dir, card)
    for version, kept_card, kept_trials in alike:
        _store_history_if_changed(run_dir, version, kept_card, kept_trials)
    rescore_history(run_dir, threads, trust_code, trusted)


def _store_history_if_changed(run_dir: str, version: int, card: dict, trials: list[dict]) -> None:
    """Stores a history card and its trials made again, unless they reproduce what the run
    keeps (every value of the kept card made again, equal: `extends`)."""
    summary_path = os.path.join(run_dir, "summary.json")
    summary = runs.read_json(summary_path)
    path = os.path.join(run_dir, history_trials_file(version))
    kept = summary["history"][f"v{version}"]
    stored = read_trials(path)
    if admission.same_trials(trials, stored) and extends(_jsonable(score.stored_card(card)), kept):
        table = _measured(trials, kept)  # the kept card stays; its table holds its measures
        if table != stored:
            write_trials(path, table)
        return
    fresh = _jsonable(score.stored_card(card))
    write_trials(path, trials)
    history = {**summary["history"], f"v{version}": fresh}
    _write_summary(summary_path, {**summary, "history": history})
    _record_scoring(run_dir)


def rescore_history(
    run_dir: str,
    threads: int = 2,
    trust_code: bool = False,
    trusted: frozenset[str] | None = None,
) -> None:
    """`rescore_run` for the cards a run keeps as history that its test trials do not vouch
    for (`admission.unvouched_history`) only: each that no longer reproduces is stored.

    Args:
      run_dir: A shipped run.
      threads: Evaluator threads.
      trust_code: Whether a policy that is code may run (`code_refusal`).
      trusted: The trusted pickles' digests (None: the package's list).

    Raises:
      OSError, KeyError, ValueError: On a run without a readable config or policy.
      UntrustedCode: If its policy is code not trusted (nothing is loaded or written).
    """
    summary = runs.read_json(os.path.join(run_dir, "summary.json"))
    config = runs.read_json(os.path.join(run_dir, "config.json"))
    for version, kept in admission.unvouched_history(summary):
        card, trials = score_run(
            run_dir, card_settings(config, None, threads, kept), trust_code, trusted
        )
        _store_history_if_changed(run_dir, version, card, trials)


def verify_run(
    run_dir: str,
    quick: bool = False,
    threads: int = 2,
    trust_code: bool = False,
    trusted: frozenset[str] | None = None,
) -> list[str]:
    """Re-scores one shipped run, its test card and the cards it keeps as history that its
    test trials do not vouch for (`history_problems`); the differences from what it stores
    (empty: none).

    Args:
      run_dir: A shipped run.
      quick: Only the first `QUICK_SEEDS` test seeds per tier, compared trial by trial.
      threads: Evaluator threads.
      trust_code: Whether a policy that is code may run (`code_refusal`).
      trusted: The trusted pickles' digests (None: the package's list).

    Raises:
      UntrustedCode: If its policy is code not trusted (nothing of it is loaded).
    """
    stored_seeds = len({t["seed"] for t in read_trials(os.path.join(run_dir, "trials.csv"))})
    seeds = min(QUICK_SEEDS, stored_seeds) if quick else None
    summary = runs.read_json(os.path.join(run_dir, "summary.json"))
    how = (threads, trust_code, trusted)
    (card, trials), alike = score_with_history(run_dir, summary, seeds, *how)
    problems = _compare(run_dir, summary, trials, card, alike, quick)
    problems += history_problems(run_dir, summary, seeds, *how)
    return problems + in_sample_problems(run_dir, threads)


def score_with_history(
    run_dir: str,
    summary: dict,
    seeds: int | None = None,
    threads: int = 2,
    trust_code: bool = False,
    trusted: frozenset[str] | None = None,
) -> tuple[tuple[dict, list[dict]], list[tuple[int, dict, list[dict]]]]:
    """A run's test card scored again, and in the same pass each card it keeps as history
    whose tiers the test card's version scores alike (`score.cards_and_trials`: each tier
    once; the gait-quality medians of the history card's `all` row need its own tiers).

    Args:
      run_dir: A shipped run.
      summary: Its summary.
      seeds: Test seeds per tier (None: the run's own).
      threads, trust_code, trusted: As for `verify_run`.

    Returns:
      `((card, trials), [(version, card, trials), ...])`.
    """
    config = runs.read_json(os.path.join(run_dir, "config.json"))
    test = card_settings(config, seeds, threads, summary["test"])
    unvouched = {version for version, _ in admission.unvouched_history(summary)}
    alike = [
        (version, card_settings(config, seeds, threads, kept))
        for version, kept in sorted(admission.cards_of(summary).items())
        if version != test.benchmark_version and version not in unvouched
    ]
    scored = _score_run_under(run_dir, [s for _, s in alike] + [test], trust_code, trusted)
    history = [(version, *made) for (version, _), made in zip(alike, scored)]
    return scored[-1], history


def _compare(
    run_dir: str, summary: dict, trials: list[dict], card: dict | None, alike: list, quick: bool
) -> list[str]:
    """What differs between what `score_with_history` made and what the run stores (a card:
    only where `card` is given and not `quick`)."""
    problems = []
    scored = [(None, summary["test"], card, trials)]
    scored += [(v, summary["history"][f"v{v}"], c, t) for v, c, t in alike]
    for version, stored_card, fresh_card, fresh in scored:
        name = "trials.csv" if version is None else history_trials_file(version)
        stored = read_trials(os.path.join(run_dir, name))
        wanted = {(t["tier"], t["seed"]) for t in fresh}
        stored = [t for t in stored if (t["tier"], t["seed"]) in wanted] if quick else stored
        if not admission.same_trials(fresh, stored):
            differ = admission.differing_trials(fresh, stored)
            problems.append(f"{differ} trials differ from {name}")
        if quick or fresh_card is None:
            continue
        made = _jsonable(score.stored_card(fresh_card))
        if version is None and made != stored_card:
            problems.append("the score card differs from summary.json")
        elif version is not None and not extends(made, stored_card):
            problems.append(f"the version-{version} card differs from summary.json's history")
    return problems


def in_sample_trial(run_dir: str, threads: int = 2) -> dict | None:
    """A gait run's in-sample best tried again by this code: its gait
    (`admission.IN_SAMPLE`) on the training seeds of the round that found it
    (`protocol.round_seeds`), on its training task and physics (the supply limit of the
    version it trained under, `OptimizerSettings.task_kwargs`), as training tried it.

    Args:
      run_dir: A run folder.
      threads: Evaluator threads.

    Returns:
      `{"distance_m": its mean distance, "fell": whether it fell}` (as `summary.json`'s
      `in_sample` stores it, the board's in-sample column), or None for a run without it.
    """
    path = os.path.join(run_dir, admission.IN_SAMPLE)
    if not admission.has_in_sample(run_dir):
        return None
    given = runs.read_json(os.path.join(run_dir, "config.json"))["settings"]
    controller = given.get("controller", "open_loop")
    vector = gait_params(run_dir, controller, admission.IN_SAMPLE)
    seeds = protocol.round_seeds(
        given["seed"],
        runs.read_json(path)["round"],
        given.get("eval_seeds", 1),
        given.get("fresh_starts", False),
    )
    with evaluation.open_evaluator(
        given["task"],
        given["trial_steps"],
        threads,
        controller=controller,
        task_kwargs={"supply": protocol.supply_limit(given.get("benchmark_version", 1))},
    ) as evaluator:
        result = evaluator.evaluate(vector[None], seeds)
    return {"distance_m": float(result.distance_m.mean(axis=1)[0]), "fell": bool(result.fell.any())}


def in_sample_problems(run_dir: str, threads: int = 2) -> list[str]:
    """The in-sample best a run stores for the board (`summary.json`'s `in_sample`) tried
    again (`in_sample_trial`), bit for bit; [] if it reproduces or the run stores none.

    Raises:
      OSError, KeyError, ValueError: On a run without a readable config or gait.
    """
    stored = runs.read_json(os.path.join(run_dir, "summary.json")).get("in_sample")
    if stored is None or not admission.has_in_sample(run_dir):
        return []  # none shown on the board (`admission.verified_summary`)
    made = in_sample_trial(run_dir, threads)
    if made == stored:
        return []
    return [f"its in-sample best tried again walks {made}, not the {stored} summary.json stores"]


def store_in_sample(run_dir: str, threads: int = 2) -> None:
    """Stores a gait run's in-sample best tried again (`in_sample_trial`) as its summary's
    `in_sample`: what the board shows as its in-sample best, and verify tries again. Its
    training record (`best_distance_m`, `best_params.json`) stays as trained: a run
    trained by earlier code may differ from it in the last digits, or more where the
    physics changed since."""
    made = in_sample_trial(run_dir, threads)
    if made is None:
        return
    summary_path = os.path.join(run_dir, "summary.json")
    _write_summary(summary_path, {**runs.read_json(summary_path), "in_sample": made})


def history_problems(
    run_dir: str,
    summary: dict,
    seeds: int | None = None,
    threads: int = 2,
    trust_code: bool = False,
    trusted: frozenset[str] | None = None,
) -> list[str]:
    """Re-scores the cards a run keeps as history that its test trials do not vouch for:
    those of a version whose physics differs from the test card's on some tier
    (`protocol.scored_alike`; a version-1 card, made without the supply limit). A card of
    tiers all scored alike needs no simulation: the board holds its table to the test
    card's (`admission`), which `verify_run` re-scores.

    Args:
      run_dir: A shipped run.
      summary: Its summary.
      seeds: Test seeds per tier, compared trial by trial (None: all, and the card).
      threads, trust_code, trusted: As for `verify_run`.

    Returns:
      The differences from what it stores (empty: none).
    """
    return _history_scored(run_dir, summary, seeds, threads, trust_code, trusted)[1]


def _history_scored(
    run_dir: str,
    summary: dict,
    seeds: int | None,
    threads: int,
    trust_code: bool,
    trusted: frozenset[str] | None,
) -> tuple[list[tuple[int, dict, list[dict]]], list[str]]:
    """`history_problems`, with the cards and trials it made: `([(version, card,
    trials), ...], problems)`."""
    config = runs.read_json(os.path.join(run_dir, "config.json"))
    made, problems = [], []
    for version, kept in admission.unvouched_history(summary):
        card, trials = score_run(
            run_dir, card_settings(config, seeds, threads, kept), trust_code, trusted
        )
        made.append((version, card, trials))
        name = history_trials_file(version)
        stored = read_trials(os.path.join(run_dir, name))
        if seeds is not None:
            wanted = {(t["tier"], t["seed"]) for t in trials}
            stored = [t for t in stored if (t["tier"], t["seed"]) in wanted]
        if not admission.same_trials(trials, stored):
            differ = admission.differing_trials(trials, stored)
            problems.append(f"{differ} trials differ from {name}")
        # A history card is not updated when the card gains a measure (`update_cards`):
        # every value it holds must be made again, equal.
        if seeds is None and not extends(_jsonable(score.stored_card(card)), kept):
            problems.append(f"the version-{version} card differs from summary.json's history")
    return made, problems


def sample_run(
    run_dir: str,
    chosen: dict[str, list[int]],
    threads: int = 2,
    trust_code: bool = False,
    trusted: frozenset[str] | None = None,
) -> list[str]:
    """Re-scores chosen trials of a shipped run (`sample.draw`); the ones that differ from
    its trial table (empty: none).

    Raises:
      UntrustedCode: If its policy is code not trusted (nothing of it is loaded).
    """
    fresh = seed_trials(run_dir, lambda tiers: chosen, threads, trust_code, trusted)
    return sample.compare(fresh, read_trials(os.path.join(run_dir, "trials.csv")))


def sample_history(run_dir: str, how: dict, name: str) -> list[str]:
    """`sample_run` on the history cards a board ranks that the test trials do not vouch
    for (`admission.unvouched_history`: a version-1 card, made without the supply limit):
    as many trials drawn from each one's table as from the test card's, scored under that
    card's settings (empty: none differ).

    Args:
      run_dir: A shipped run.
      how: `_check_run`'s settings (`sample`, `entropy`, `threads`, `trust_code`, `trusted`).
      name: The run's name in the draw (`sample.draw`); each card draws apart.
    """
    summary = runs.read_json(os.path.join(run_dir, "summary.json"))
    config = runs.read_json(os.path.join(run_dir, "config.json"))
    problems = []
    for version, kept in admission.unvouched_history(summary):
        table = history_trials_file(version)
        stored = read_trials(os.path.join(run_dir, table))
        keys = [(t["tier"], t["seed"]) for t in stored]
        chosen = sample.draw(keys, how["sample"], how["entropy"], f"{name}/v{version}")
        settings = card_settings(config, None, how["threads"], kept)
        fresh = seed_trials(
            run_dir, lambda tiers, chosen=chosen: chosen, trust_code=how["trust_code"],
            trusted=how["trusted"], settings=settings,
        )  # fmt: skip
        differ = sample.compare(fresh, stored)
        problems += [line.replace("trials.csv", table) for line in differ]
    return problems


def seed_trials(
    run_dir: str,
    choose: Callable[[tuple[str, ...]], dict[str, list[int]]],
    threads: int = 2,
    trust_code: bool = False,
    trusted: frozenset[str] | None = None,
    settings: score.ScoreSettings | None = None,
) -> list[dict]:
    """A shipped run's gait or policy scored on seeds of its own choosing
    (`score.seed_trials`): `choose` maps the run's tiers to {tier: [seed, ...]}.

    Args:
      run_dir: A shipped run.
      choose: Its tiers → {tier: [seed, ...]}.
      threads: Threads of the scoring (unused when `settings` is given).
      trust_code: Whether a policy that is code may be loaded (with `trusted`).
      trusted: The digests of code policies trusted to run.
      settings: The scorer's settings (None: the run's test card's, `run_settings`; a
        history card's, `card_settings`, for `sample_history`).

    Returns:
      The fresh trial rows.

    Raises:
      UntrustedCode: If its policy is code not trusted (nothing of it is loaded).
    """
    if settings is None:
        settings = run_settings(run_dir, threads=threads)
    policy = shipped_policy(run_dir, trust_code, trusted)
    artifact = gait_params(run_dir, settings.controller) if policy is None else policy
    with policy_threads(run_dir), _closed_after(policy):
        return score.seed_trials(artifact, settings, choose(settings.tiers))


def _check_run(run_dir: str, how: dict) -> tuple[list[str], str | None]:
    """`verify_run` or, with `how["sample"]`, `sample_run` on trials drawn for this run;
    with the digest of the run's files as they were checked (`admission.run_digest`, taken
    before and compared after: a run whose files changed meanwhile, as a policy that is
    code could change them, is not reproduced)."""
    before = admission.run_digest(run_dir)
    try:
        problems = _checked(run_dir, how)
    except (UntrustedCode, NotAdmitted):
        raise
    except Exception as e:  # the run's own failure (its policy, its files): this run only
        problems = [f"could not be scored: {exported.one_line(f'{type(e).__name__}: {e}', 300)}"]
    try:
        after = admission.run_digest(run_dir)
    except (OSError, ValueError):
        after = None  # a file gone or no longer readable
    if after != before:
        problems = [*problems, "its files changed while it was being checked"]
    return problems, before


def _checked(run_dir: str, how: dict) -> list[str]:
    """`_check_run`'s scoring: the differences found (empty: none)."""
    if not how["sample"]:
        return verify_run(run_dir, how["quick"], how["threads"], how["trust_code"], how["trusted"])
    keys = [(t["tier"], t["seed"]) for t in read_trials(os.path.join(run_dir, "trials.csv"))]
    name = "/".join(os.path.normpath(os.path.abspath(run_dir)).split(os.sep)[-3:])
    chosen = sample.draw(keys, how["sample"], how["entropy"], name)
    problems = sample_run(run_dir, chosen, how["threads"], how["trust_code"], how["trusted"])
    problems += sample_history(run_dir, how, name)
    return problems + in_sample_problems(run_dir, how["threads"])


def audit_run(run_dir: str, seeds: list[int], how: dict) -> tuple[dict, dict]:
    """A run's card scores and its scores on audit seeds (`audit.scores`), per tier.

    Raises:
      UntrustedCode: If its policy is code not trusted (nothing of it is loaded).
    """
    fresh = seed_trials(
        run_dir,
        lambda tiers: {t: seeds for t in tiers},
        how["threads"],
        how["trust_code"],
        how["trusted"],
    )
    card = audit.scores(read_trials(os.path.join(run_dir, "trials.csv")))
    return card, audit.scores(fresh)


def _audited(run_dir: str, seeds: list[int], how: dict) -> tuple[dict, dict] | str:
    """`audit_run`, or why the run could not be audited (one line: its policy failed, a
    file could not be read): one run's failure does not stop the audit of the others."""
    try:
        return audit_run(run_dir, seeds, how)
    except UntrustedCode:
        raise
    except Exception as e:
        return f"could not be audited: {exported.one_line(f'{type(e).__name__}: {e}', 300)}"


def audit_runs(
    artifacts: str,
    seeds: int,
    log: Callable[[str], None] = print,
    entropy: int | None = None,
    jobs: int = 1,
    threads: int = 2,
    trust_code: bool = False,
    trusted_list: str | None = None,
    quick: bool = False,
) -> int:
    """Audits every admitted run on fresh seeds (`cpg_suite.protocol.audit`): one line per
    configuration (method, training task, configuration, version trained under).

    Args:
      artifacts: The folder of runs.
      seeds: Audit seeds per tier (the same for every run of an audit).
      log: Given the entropy's line, a line per configuration, and a last line.
      entropy: The draw's entropy (None: fresh; logged, so that an audit can be replayed).
      jobs, threads, trust_code, trusted_list: As `verify`'s.
      quick: Only the first run of each configuration (`_quick_sample`).

    Returns:
      How many configurations score better on their card than on the audit, plus how many
      runs could not be audited (each its own line, `DIFF`).

    Raises:
      ValueError: If `artifacts` holds no run folder.
    """
    folders = run_folders(artifacts)
    if not folders:
        raise ValueError(f"no shipped runs under {artifacts}")
    refused = admission.refusals(folders, ledger=admission.ledger_beside(artifacts))
    trusted = trusted_digests(trusted_list)
    chosen = [
        d for d in folders if d not in refused and code_refusal(d, trust_code, trusted) is None
    ]
    chosen = _quick_sample(chosen) if quick else chosen
    entropy = sample.fresh_entropy() if entropy is None else entropy
    drawn = audit.draw_seeds(seeds, entropy)
    log(f"audit: {seeds} seeds a tier, drawn with --entropy={entropy}; {len(chosen)} runs")
    how = {"threads": threads, "trust_code": trust_code, "trusted": trusted}
    with contextlib.ExitStack() as stack:
        if jobs > 1:
            pool = stack.enter_context(_pool(jobs, chosen, trust_code))
            futures = {d: pool.submit(_audited, d, drawn, how) for d in chosen}
            results = {d: futures[d].result() for d in chosen}
        else:
            results = {d: _audited(d, drawn, how) for d in chosen}
    failed = {d: r for d, r in results.items() if isinstance(r, str)}
    for run_dir, why in failed.items():
        log(one_line(f"DIFF {run_dir}; {why}"))
    groups: dict[tuple, list] = {}
    for run_dir in (d for d in chosen if d not in failed):
        key = (*admission.run_identity(run_dir), admission.trained_version(run_dir))
        groups.setdefault(key, []).append(results[run_dir])
    flagged = 0
    for (method, task, config, version), pairs in sorted(groups.items()):
        found = audit.gap(pairs)
        flagged += found.verdict == "card above audit"
        log(f"{method}/{task}/{config} (trained v{version}, {len(pairs)} runs): {found.text()}")
    unaudited = f"; {len(failed)} runs could not be audited (DIFF above)" if failed else ""
    log(
        f"{flagged} of {len(groups)} configurations score better on their card than on the "
        f"audit{unaudited}"
    )
    return flagged + len(failed)


def write_ledger(
    path: str,
    outcomes: dict[str, list[str]],
    sample_trials: int = 0,
    upgrade: tuple[int, int] | None = None,
    digests: dict[str, str] | None = None,
) -> None:
    """Records the runs just checked in a ledger (`admission.LEDGER_FIELDS`), a row per
    run, replacing that run's earlier row: its files' digest, full or sampled, how many
    trials, whether they reproduced, when and at which commit. A `--quick` check is not
    recorded (it checks the code, not the runs).

    Args:
      path: The ledger (CSV).
      outcomes: {run: its problems (empty: reproduced)}.
      sample_trials: Trials sampled per run (0: a full check).
      upgrade: `(old, new)` versions for runs `upgrade_run` just upgraded: the check is
        "upgrade <old>-><new>", its trials those of the old card, reproduced; the new card's
        other trials were scored for the first time, so it is no full re-score (the board
        counts only "full" rows).
      digests: {run: the digest of its files as they were checked} (default: as they are
        now); a row names the files its check read, so a run changed since is not on record.
    """
    ledger = admission.read_ledger(path)
    environment = runs.environment_record()
    for run_dir, problems in outcomes.items():
        trials = len(read_trials(os.path.join(run_dir, "trials.csv")))
        if not sample_trials:
            trials = admission.full_check_trials(
                runs.read_json(os.path.join(run_dir, "summary.json"))
            )
        check = f"sample {sample_trials}" if sample_trials else "full"
        if upgrade is not None:
            check = f"upgrade {upgrade[0]}->{upgrade[1]}"
            trials = len(read_trials(os.path.join(run_dir, history_trials_file(upgrade[0]))))
        ledger[admission.run_key(run_dir)] = {
            "run": admission.run_key(run_dir),
            "files_sha256": (digests or {}).get(run_dir) or admission.run_digest(run_dir),
            "check": check,
            "trials": min(sample_trials, trials) if sample_trials else trials,
            "result": "differs" if problems else "reproduced",
            "date_utc": environment["started_utc"][:10],
            "commit": environment.get("git_commit") or "",
        }
    runs.write_rows_csv(path, [ledger[k] for k in sorted(ledger)])


def history_trials_file(version: int) -> str:
    """The trial table of a run's card under an earlier benchmark version."""
    return f"trials_v{version}.csv"


def upgrade_run(
    run_dir: str,
    version: int = protocol.BENCHMARK_VERSION,
    threads: int = 2,
    trust_code: bool = False,
    trusted: frozenset[str] | None = None,
) -> bool:
    """Re-scores a shipped run under a new benchmark version, keeping its card as history.

    Its card under its own version is made again (its trials must be unchanged: the run
    does what it did) and stored with its trials as `summary.json["history"]["v<n>"]` and
    `trials_v<n>.csv`; the run scored under `version` becomes its test card and
    `trials.csv`. Where the two versions have the same task physics
    (`protocol.trained_alike`: version 3 only adds a tier to version 2) both cards come
    from one scoring (`score.cards_and_trials`), else from two. A run already under
    `version` is left as it is (resumable).

    Args:
      run_dir: A shipped run.
      version: The benchmark version to score under.
      threads: Evaluator threads.
      trust_code: Whether a policy that is code may run (`code_refusal`).
      trusted: The trusted pickles' digests (None: the package's list).

    Returns:
      Whether the run was upgraded.

    Raises:
      NotAdmitted: If the board refuses the run (nothing is scored or written).
      ValueError: If `version` is earlier than its card's, or the run's trials under its own
        version changed (nothing is written).
      UntrustedCode: If its policy is code not trusted (nothing is loaded or written).
    """
    require_admitted([run_dir])
    protocol.require_version(version)
    summary_path = os.path.join(run_dir, "summary.json")
    old = runs.read_json(summary_path)["test"].get("benchmark_version", 1)
    if old == version:
        return False
    if version < old:
        raise ValueError(f"{run_dir}: its card is of version {old}; cannot upgrade to {version}")
    config = runs.read_json(os.path.join(run_dir, "config.json"))
    before = run_settings(run_dir, threads=threads)
    after = dataclasses.replace(
        before,
        benchmark_version=version,
        tiers=protocol.card_tiers(config["settings"].get("test_tiers"), version),
    )
    if protocol.trained_alike(old) == protocol.trained_alike(version):
        (old_card, old_trials), (card, trials) = _score_run_under(
            run_dir, [before, after], trust_code, trusted
        )
    else:
        old_card, old_trials = score_run(run_dir, before, trust_code, trusted)
        card, trials = score_run(run_dir, after, trust_code, trusted)
    if not admission.same_trials(old_trials, read_trials(os.path.join(run_dir, "trials.csv"))):
        raise ValueError(f"{run_dir}: its trials under version {old} changed")
    write_trials(os.path.join(run_dir, history_trials_file(old)), old_trials)
    summary = runs.read_json(summary_path)
    history = {**summary.get("history", {}), f"v{old}": _jsonable(score.stored_card(old_card))}
    _write_summary(summary_path, {**summary, "history": history})
    write_trials(os.path.join(run_dir, "trials.csv"), trials)
    _store_card(run_dir, card)
    return True


def _score_run_under(
    run_dir: str,
    settings_list: list[score.ScoreSettings],
    trust_code: bool = False,
    trusted: frozenset[str] | None = None,
) -> list[tuple[dict, list[dict]]]:
    """`score_run` under settings that differ only in tiers and version, each tier once."""
    policy = shipped_policy(run_dir, trust_code, trusted)
    if policy is None:
        params = gait_params(run_dir, settings_list[0].controller)
        return score.cards_and_trials(params, settings_list)
    with policy_threads(run_dir), _closed_after(policy):
        return score.cards_and_trials(policy, settings_list)


def _quick_sample(shipped: list[str]) -> list[str]:
    """The first run of each configuration (its folder name less the seed)."""
    chosen, seen = [], set()
    for run_dir in shipped:
        config = os.path.join(os.path.dirname(run_dir), os.path.basename(run_dir).split("seed")[0])
        if config not in seen:
            seen.add(config)
            chosen.append(run_dir)
    return chosen


def _expected_cost(run_dir: str) -> float:
    """A rough cost of re-scoring a shipped run, to order the work only: its card's
    simulated physics steps, four times over for a policy or a feedback CPG (they compute
    in Python at every control step; about 4x per step in `verify --quick`'s profile), plus
    a fixed 0.2 M steps for loading the run."""
    steps = (stored_card(run_dir) or {}).get("scoring_sim_steps", 0)
    python_per_step = _copied(run_dir) != COPIED or run_settings(run_dir).controller == "feedback"
    return steps * (4.0 if python_per_step else 1.0) + 2e5


def _pool(jobs: int, run_dirs: list[str], trust_code: bool) -> concurrent.futures.Executor:
    """The worker processes of a check (spawned: no forked threads or torch state). Where
    code is trusted to run and some run's policy is code, this process and every worker
    are made non-dumpable first (`sandbox.keep_memory_private`): a policy's process may
    not read or rewrite the memory of the process that gathers and records the results,
    nor of another worker's."""
    spawn = multiprocessing.get_context("spawn")
    if not (trust_code and any(admission.unvetted_code(d) for d in run_dirs)):
        return concurrent.futures.ProcessPoolExecutor(jobs, mp_context=spawn)
    sandbox.keep_memory_private()
    return concurrent.futures.ProcessPoolExecutor(
        jobs, mp_context=spawn, initializer=sandbox.keep_memory_private
    )


def verify(
    artifacts: str,
    quick: bool = False,
    threads: int = 2,
    log: Callable[[str], None] = print,
    jobs: int = 1,
    trust_code: bool = False,
    sample_trials: int = 0,
    entropy: int | None = None,
    trusted_list: str | None = None,
    record: str | None = None,
) -> int:
    """Re-scores the shipped runs under `artifacts`.

    Args:
      artifacts: The folder of shipped runs.
      quick: The first `QUICK_SEEDS` test seeds of every tier (25 of a card's 250 trials)
        of the first run of each configuration only, compared trial by trial: a check of
        the code on this machine, not of the runs (`_quick_sample`).
      threads: Evaluator threads of each run.
      log: Given a line per run, in the order of the runs, and a last line.
      jobs: Runs re-scored at once, each in its own process (1: in this one). The runs are
        independent: the outcome does not depend on it.
      trust_code: Whether policies that are code may run whatever they are
        (`code_refusal`; `--trust_code`).
      sample_trials: If > 0, instead: this many trials of every run, drawn at random
        (`cpg_suite.protocol.sample`), compared with its trial table.
      entropy: The draw's entropy (None: fresh from the operating system; logged first).
      trusted_list: A list of trusted pickles' digests (None: the package's).
      record: A ledger to record each run's check in (`write_ledger`; None: none).

    Every run folder is first checked as the leaderboard checks it (`admission.refusals`:
    the files verify needs, a card made under the protocol's card settings that its
    trials produce, no copies), then whether its policy may be loaded (`code_refusal`: a
    policy that is code runs only with `trust_code`, SB3 pickles also when trusted); a
    folder refused is logged `REFUSED` with the reason, counts as differing, and is not
    scored again (nothing of it is loaded).

    Returns:
      The number of runs that differ or are refused (0: every card and trial checked
      reproduced bit for bit).

    Raises:
      ValueError: If `artifacts` holds no run folder.
    """
    folders = run_folders(artifacts)
    if not folders:
        raise ValueError(f"no shipped runs under {artifacts}")
    ledger = admission.ledger_beside(artifacts)
    refused = admission.refusals(folders, ledger=ledger)
    trusted = trusted_digests(trusted_list)
    for run_dir in folders:
        reason = None if run_dir in refused else code_refusal(run_dir, trust_code, trusted)
        if reason:
            refused[run_dir] = reason
    shipped = [run_dir for run_dir in folders if run_dir not in refused]
    chosen = _quick_sample(shipped) if quick and not sample_trials else shipped
    if sample_trials:
        entropy = sample.fresh_entropy() if entropy is None else entropy
        log(f"sample: {sample_trials} trials a run, drawn with --entropy={entropy}")
    how = {
        "quick": quick,
        "threads": threads,
        "trust_code": trust_code,
        "trusted": trusted,
        "sample": sample_trials,
        "entropy": entropy,
    }
    failed, on_record = len(refused), 0
    with contextlib.ExitStack() as stack:
        if jobs > 1:
            pool = stack.enter_context(_pool(jobs, chosen, trust_code))
            futures = {  # the dearest first, so that no long run starts last
                run_dir: pool.submit(_check_run, run_dir, how)
                for run_dir in sorted(chosen, key=_expected_cost, reverse=True)
            }
            if record:  # as each run is done, whatever its place: a stop keeps what it checked
                _record_as_done(record, futures, sample_trials)
            outcome = lambda run_dir: futures[run_dir].result()  # noqa: E731
        else:
            outcome = lambda run_dir: _check_run(run_dir, how)  # noqa: E731
        for run_dir in sorted([*chosen, *refused]):
            if run_dir in refused:
                log(one_line(f"REFUSED {run_dir}; {refused[run_dir]}"))
                continue
            problems, digest = outcome(run_dir)
            if quick and not sample_trials:
                full = _full_check_problems(run_dir, digest, ledger)
                on_record += full is None
                problems = problems + (full or [])
            if record and jobs <= 1:  # as each run is done: a stop keeps what it checked
                write_ledger(record, {run_dir: problems}, sample_trials, digests={run_dir: digest})
            failed += bool(problems)
            status = "DIFF" if problems else "ok  "
            log(one_line(f"{status} {run_dir}" + "".join(f"; {p}" for p in problems)))
    total = len(chosen) + len(refused)
    if quick and not sample_trials:
        others = _quick_others([d for d in shipped if d not in chosen], ledger, log)
        log(
            f"{total - failed} of {total} shipped runs reproduced bit for bit on --quick's "
            f"trials (the first {QUICK_SEEDS} test seeds a tier), {on_record} of them on "
            f"record as re-scored in full{others[0]}"
        )
        return failed + others[1]
    what = f", {sample_trials} random trials each," if sample_trials else ""
    log(f"{total - failed} of {total} shipped runs{what} reproduced bit for bit")
    return failed


def _quick_others(others: list[str], ledger: dict, log: Callable[[str], None]) -> tuple[str, int]:
    """The runs --quick does not re-score (not the first of their configuration), each
    compared with the ledger's full check only: a `DIFF` line for each whose files are not
    those the ledger's full check re-scored; the final line's words on them, and how many
    differ."""
    if not others:
        return "", 0
    found = {}
    for run_dir in sorted(others):
        try:
            digest = admission.run_digest(run_dir)
        except (OSError, ValueError):
            digest = None
        found[run_dir] = _full_check_problems(run_dir, digest, ledger)
        if found[run_dir]:
            log(one_line(f"DIFF {run_dir}; not re-scored by --quick; {found[run_dir][0]}"))
    differ = sum(bool(p) for p in found.values())
    on_record = sum(p is None for p in found.values())
    words = (
        f"; {len(others)} other runs, not the first of their configuration, not re-scored by "
        f"--quick ({on_record} on record in full with these files"
        + (f", {differ} whose files differ: DIFF above)" if differ else ")")
    )
    return words, differ


def _full_check_problems(run_dir: str, digest: str | None, ledger: dict) -> list[str] | None:
    """What a quick check adds about a run from the ledger beside its tree: nothing (None)
    where the ledger's full check re-scored these very files (`admission.rescored_in_full`);
    a difference where its row for the run re-scored other files (the quick trials cannot
    vouch for the rest of an edited run); [] where no full check of the run is on record
    (a run not yet re-scored in full: the final line counts it apart)."""
    if admission.rescored_in_full(run_dir, ledger):
        return None
    row = ledger.get(admission.run_key(run_dir))
    if row and row["check"] == "full" and row["files_sha256"] != digest:
        return [
            f"its files are not those the ledger's full check re-scored ({row['date_utc']}): "
            f"--quick re-scores {QUICK_SEEDS} test seeds a tier and cannot vouch for the rest"
        ]
    return []


def _record_as_done(record: str, futures: dict, sample_trials: int) -> None:
    """Writes each run's ledger row as its process finishes it (`verify` logs the runs in
    path order afterwards), each with a progress line."""
    run_of = {future: run_dir for run_dir, future in futures.items()}
    for done, future in enumerate(concurrent.futures.as_completed(run_of), 1):
        if future.exception() is None:
            problems, digest = future.result()
            run_dir = run_of[future]
            write_ledger(record, {run_dir: problems}, sample_trials, digests={run_dir: digest})
            progress.write(f"recorded {done} of {len(run_of)}: {run_of[future]}")


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    flags.DEFINE_string("artifacts", ARTIFACTS, "Folder of shipped runs.")
    flags.DEFINE_bool(
        "quick",
        False,
        f"A check of the code: the first {QUICK_SEEDS} test seeds a tier of each "
        "configuration's first run.",
    )
    flags.DEFINE_integer("threads", 2, "Evaluator threads (results do not depend on it).")
    flags.DEFINE_integer("jobs", 2, "Runs re-scored at once, a process each (1: none).")
    flags.DEFINE_string(
        "ship_from", None, "none: ship nothing. First ship the finished runs under this folder."
    )
    flags.DEFINE_bool(
        "update_cards", False, "Re-score every shipped run and store its card (trials unchanged)."
    )
    flags.DEFINE_string(
        "rescore",
        None,
        "none: compare only. Re-score the shipped runs under this subfolder; store cards and "
        "trials.",
    )
    flags.DEFINE_integer(
        "upgrade_to",
        None,
        "none: no upgrade. Score every shipped run under this benchmark version, its card "
        "kept as history.",
    )
    flags.DEFINE_bool(
        "trust_code",
        False,
        "Run policies that are code: policy_code.py, SB3 pickles not trusted.",
    )
    flags.DEFINE_bool(
        "write_trusted",
        False,
        f"Write {TRUSTED_NAME} (every SB3 pickle under --artifacts).",
    )
    flags.DEFINE_integer(
        "sample",
        0,
        "Re-score this many random trials of every run (fresh entropy); 0: every trial.",
    )
    flags.DEFINE_integer(
        "entropy", None, "none: fresh. The --sample or --audit draw's entropy, to replay a check."
    )
    flags.DEFINE_integer(
        "audit", 0, "Score every run on this many fresh seeds a tier and compare; 0: no audit."
    )
    flags.DEFINE_string(
        "record",
        None,
        "none: not recorded. A ledger (CSV) to record each run's full or sampled check in.",
    )
    flags.DEFINE_string(
        "trusted_list", None, f"none: the package's {TRUSTED_NAME}. A list of trusted pickles."
    )


def _maintain(values: flags.FlagValues) -> bool:
    """Runs --rescore, --upgrade_to or --update_cards, if one is given: all or nothing.

    Every run it will change is checked first (admitted as verify admits runs, and its
    policy loadable under the trust given); one that is not stops it before any file is
    written. `--update_cards` then scores every run before it stores any card; with
    `--record`, each run whose card it stores is recorded as re-scored in full (its trials
    reproduced bit for bit, its files as they are now); each run `--upgrade_to` upgrades
    is recorded as upgraded (its old card's trials reproduced; not a full re-score).

    Args:
      values: The parsed flags.

    Returns:
      Whether one was given.

    Raises:
      UntrustedCode: On a run whose policy is code not trusted (`code_refusal`).
      cli.UsageError: On a run it may not change.
    """
    if values.rescore is None and values.upgrade_to is None and not values.update_cards:
        return False
    trusted = trusted_digests(values.trusted_list)
    if values.rescore is not None:
        chosen = os.path.join(values.artifacts, values.rescore)
        cli.check(
            os.path.isdir(chosen),
            f"--rescore={values.rescore} is not a folder of {values.artifacts}",
        )
        run_dirs = shipped_runs(chosen)
    else:
        cli.check(
            values.upgrade_to is None or values.upgrade_to in protocol.VERSIONS,
            f"--upgrade_to must be one of {sorted(protocol.VERSIONS)}, got {values.upgrade_to}",
        )
        run_dirs = shipped_runs(values.artifacts)
    _check_all(run_dirs, values.trust_code, trusted, admit=values.rescore is None)
    if values.rescore is not None:
        for run_dir in run_dirs:
            rescore_run(run_dir, values.threads, values.trust_code, trusted)
            progress.write(f"re-scored: {run_dir}")
    elif values.upgrade_to is not None:
        for run_dir in run_dirs:
            old = stored_card(run_dir).get("benchmark_version", 1)
            if upgrade_run(run_dir, values.upgrade_to, values.threads, values.trust_code, trusted):
                if values.record:  # its old card's trials reproduced; the rest are new
                    write_ledger(values.record, {run_dir: []}, upgrade=(old, values.upgrade_to))
                progress.write(f"upgraded to version {values.upgrade_to}: {run_dir}")
    else:
        update_cards(run_dirs, values.threads, values.trust_code, trusted, values.record)
    return True


def update_cards(
    run_dirs: list[str],
    threads: int = 2,
    trust_code: bool = False,
    trusted: frozenset[str] | None = None,
    record: str | None = None,
) -> None:
    """Re-scores every run, then stores each one's new card and trial tables (`update_card`,
    all or nothing).

    Args:
      run_dirs: Shipped runs.
      threads: Evaluator threads.
      trust_code: Whether a policy that is code may run (`code_refusal`).
      trusted: The trusted pickles' digests (None: the package's list).
      record: A ledger (`write_ledger`; None: none): each run whose card is stored is
        recorded as re-scored in full (its trials reproduced, its files as they are now).

    Raises:
      NotAdmitted: If the board refuses one of the runs (`admission.refusals`, the runs
        judged together: a copy among them is refused); nothing is scored or written.
      ValueError: If a run's trials differ from its `trials.csv` (no card is written then).
      UntrustedCode: If a policy is code not trusted (nothing is loaded or written).
    """
    require_admitted(run_dirs)
    made = [(run_dir, fresh_scoring(run_dir, threads, trust_code, trusted)) for run_dir in run_dirs]
    for run_dir, (test, history) in made:
        _store_scoring(run_dir, test, history)
        store_in_sample(run_dir, threads)
        if record:
            write_ledger(record, {run_dir: []})
        progress.write(f"card updated: {run_dir}")


def require_admitted(run_dirs: list[str]) -> None:
    """Raises `NotAdmitted` naming the first run the board refuses, and why.

    A card or ledger row is written only for a run the board admits: a maintenance call
    never gives a refused run (a copy counted as a seed, an edited file) a fresh card.

    Args:
      run_dirs: The runs a maintenance call is about to change, judged together.

    Raises:
      NotAdmitted: On the first refused run, in path order.
    """
    refused = admission.refusals(run_dirs)
    for run_dir in sorted(refused):
        raise NotAdmitted(f"nothing changed: {run_dir}: {refused[run_dir]}")


def _check_all(run_dirs: list[str], trust_code: bool, trusted: frozenset[str], admit: bool) -> None:
    """Stops, before anything is written, at the first run a maintenance command may not
    change: one the board refuses (with `admit`) or whose policy may not be loaded."""
    refused = admission.refusals(run_dirs) if admit else {}
    for run_dir in run_dirs:
        reason = refused.get(run_dir) or code_refusal(run_dir, trust_code, trusted)
        if reason:
            raise cli.UsageError(f"nothing changed: {run_dir}: {reason}")


def main(argv: list[str]) -> None:
    """Ships (with --ship_from) and verifies; exit code 1 if any run differs."""
    del argv
    values = flags.FLAGS
    cli.check(values.threads >= 1, f"--threads must be ≥ 1, got {values.threads}")
    cli.check(values.jobs >= 1, f"--jobs must be ≥ 1, got {values.jobs}")
    cli.check(values.sample >= 0, f"--sample must be ≥ 0 trials, got {values.sample}")
    cli.check(values.audit >= 0, f"--audit must be ≥ 0 seeds a tier, got {values.audit}")
    cli.check(
        not (values.audit and values.sample),
        "give --audit (fresh seeds) or --sample (the card's own trials), not both",
    )
    cli.check(
        values.entropy is None or values.entropy >= 0,
        f"--entropy must be ≥ 0, got {values.entropy}",
    )
    cli.check(
        values.trusted_list is None or os.path.isfile(values.trusted_list),
        f"--trusted_list={values.trusted_list} is not a file",
    )
    if values.ship_from is not None:
        cli.check(
            os.path.isdir(values.ship_from), f"--ship_from={values.ship_from} is not a directory"
        )
        shipped = ship_all(values.ship_from, values.artifacts, trust_code=values.trust_code)
        lacking = [(d, unshippable(d)) for d in run_folders(values.ship_from)]
        lacking = [(d, missing) for d, missing in lacking if missing]
        if not shipped and lacking and not run_folders(values.artifacts):
            first, missing = lacking[0]
            more = f" (and {len(lacking) - 1} more folders)" if len(lacking) > 1 else ""
            raise cli.UsageError(
                f"nothing to ship from {values.ship_from}: {first} lacks {', '.join(missing)}{more}"
            )
    cli.check(os.path.isdir(values.artifacts), f"--artifacts={values.artifacts} is not a directory")
    if values.write_trusted:
        inside = os.path.relpath(os.path.abspath(values.artifacts), repository())
        cli.check(
            not inside.startswith(os.pardir),
            f"--write_trusted lists the project's runs: --artifacts={values.artifacts} is "
            "outside the repository",
        )
        runs.write_text(TRUSTED_LIST, trusted_artifacts_text(values.artifacts))
        progress.write(f"wrote {TRUSTED_LIST}")
        return
    try:
        if _maintain(values):
            return  # the cards were just made by the same scoring: run verify on its own
    except UntrustedCode as e:
        raise cli.UsageError(str(e)) from None
    if values.audit:
        try:
            flagged = audit_runs(
                values.artifacts,
                values.audit,
                entropy=values.entropy,
                jobs=values.jobs,
                threads=values.threads,
                trust_code=values.trust_code,
                trusted_list=values.trusted_list,
                quick=values.quick,
            )
        except ValueError as e:
            raise cli.UsageError(str(e)) from None
        if flagged:
            raise SystemExit(1)
        return
    try:
        failed = verify(
            values.artifacts,
            values.quick,
            values.threads,
            jobs=values.jobs,
            trust_code=values.trust_code,
            sample_trials=values.sample,
            entropy=values.entropy,
            trusted_list=values.trusted_list,
            record=None if values.quick and not values.sample else values.record,
        )
    except ValueError as e:
        raise cli.UsageError(str(e)) from None
    if failed:
        raise SystemExit(1)


if __name__ == "__main__":
    define_flags()
    cli.run(main)
