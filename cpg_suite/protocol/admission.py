"""Which runs the leaderboard admits (docs/protocol.md#admission); no simulation here.

A DARwIn-OP run is ranked or listed on the board of a benchmark version only if

* its folder is a folder of its own (not a symbolic link), and its name, its method's and
  task's, and every file's name in it are printable text (no newline or other control
  character, which could forge a line of the board's listing; `path_refusal`); a name
  that ends in `seed` and digits ends in ASCII digits (`SEED_NAME`);
* every file of it that the board or verify reads is a plain file of its own, of bounded
  size, strict JSON and CSV (`cpg_suite.protocol.files`);
* its folder holds what `cpg_suite.protocol.verify` needs to score it again: `config.json`
  (the card's settings), `summary.json` (the card), the trial table of the card
  (`trials.csv`, or `trials_v<n>.csv` for a card kept as history), the gait or policy
  (`ARTIFACTS`: `selected_params.json`; `selected_policy.npz`; `selected_actions.npy`;
  `policy_code.py`; or `selected_model.zip` with `selected_vecnormalize.pkl`) and
  `versions.json` (what it was made and scored with);
* its card was made under the protocol's card settings (`card.deviations`): every tier in
  order, all 50 test seeds, 1000-step trials, the supply limit of its version — as its
  config says verify would score it, and as the card shows of itself;
* its config's benchmark version is the one its first card was made under (a run keeps
  the card of the version it trained under as history when re-scored under a later one),
  and its test card is its latest;
* each of its cards' trial tables holds the card's tiers × test seeds and produces the
  card: every statistic but the gait-quality medians (which need the simulation) is made
  again from the table with the card's own arithmetic (`card.row`) and must be equal, bit
  for bit; a card kept as history holds the test card's trials on the tiers both versions
  score alike (`protocol.scored_alike`);
* what it says of its training holds together (`training_refusal`): its task, its budget;
* an action table (`selected_actions.npy`) has one row of 12 float64 actions per control
  step of a trial, each finite and in [-1, 1] (`actions_refusal`); an exported policy's
  arrays (`selected_policy.npz`) are plain numbers or text, finite (`policy_refusal`);
  either is read only after each `.npy` header is checked against the bytes that follow
  it (`exported.read_npy`), so a header that claims more than the file holds is refused
  before anything is allocated;
* it is no copy: no earlier run of any configuration or method has the same trial outcomes
  or the same gait or policy, as values (`cpg_suite.protocol.copies`), and no other run of
  its configuration has its seed.

Everything else is refused with a one-line reason (`refusals`). Nothing here executes code
from a run folder: JSON and CSV are parsed, NumPy arrays are read as data (headers first,
never unpickled), the other gait or policy files are only hashed. A run whose policy is
code (`CODE_FILES`: a Python file, or Stable-Baselines3's pickles) is admitted on its
files like any other; whether its code may run is `verify`'s question (`--trust_code`,
`verify.code_refusal`).
"""

from __future__ import annotations

import collections
import csv
import hashlib
import io
import json
import math
import os
import re
import shlex
from collections.abc import Iterable

import numpy as np

from cpg_suite import cpg, electrical, feedback, protocol
from cpg_suite.protocol import card as card_stats
from cpg_suite.protocol import copies, files, sample
from cpg_suite.runfiles import exported

BOARD_VERSION = protocol.BENCHMARK_VERSION  # the version the leaderboard ranks by default
GAIT = "selected_params.json"
EXPORTED = "selected_policy.npz"  # `cpg_suite.runfiles.exported.FILE`
ACTIONS = "selected_actions.npy"  # `cpg_suite.runfiles.exported.ACTIONS_FILE`
CODE = "policy_code.py"  # a Python file defining `make_policy()` (`sandbox.load_policy_code`)
SB3_MODEL, SB3_NORMALIZER = "selected_model.zip", "selected_vecnormalize.pkl"
# The gait or policy files, in verify's order of precedence (the first a folder holds is
# the one scored): an exported policy, a Stable-Baselines3 policy (model and normalizer),
# an action table, a policy's code, a gait.
ARTIFACTS = ((EXPORTED,), (SB3_MODEL, SB3_NORMALIZER), (ACTIONS,), (CODE,), (GAIT,))
# Those that run code when loaded: a Python file, and the pickles of an SB3 policy. The
# others are data (JSON, NumPy arrays read without unpickling).
CODE_FILES = (CODE, SB3_MODEL, SB3_NORMALIZER)
# The project's list of trusted pickles, shipped inside the package (never read from the
# working directory): the SHA-256 and path of every Stable-Baselines3 file of its shipped
# runs, as `sha256sum` writes them (`verify --write_trusted` makes it; in a checkout,
# `sha256sum -c cpg_suite/data/trusted_pickles.txt` checks it).
TRUSTED_LIST = os.path.join(
    os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "data", "trusted_pickles.txt"
)
_TRUSTED_LINE = re.compile(r"^(?P<digest>[0-9a-f]{64}) [ *](?P<path>.+)$")
# The gait-quality measures the board shows (`analysis.leaderboard.QUALITY`;
# cpg_suite.evaluation.quality.FIELDS defines them: this module imports no simulation code,
# and tests/test_leaderboard.py checks that these are its names and that every electrical
# field is shown). A trial table that holds measures holds at least these.
BOARD_MEASURES = (
    "cost_of_transport",
    "slip_per_m",
    "torque_limit_share",
    "peak_joint_speed",
    "electrical_power_w",
    "energy_per_m",
    "supply_current_a",
    "supply_peak_1s_a",
    "rms_torque_ratio",
    "copper_loss_ratio",
    # How the feet meet the floor (`cpg_suite.evaluation.footing.FIELDS`, named here:
    # admission imports no simulation code; tests/test_leaderboard.py keeps them equal).
    "contact_slip_per_m",
    "flat_stance_share",
    "swing_clearance_m",
    "toe_strike_share",
    "heel_strike_share",
)
IN_SAMPLE = copies.IN_SAMPLE  # a gait run's in-sample best: its gait and training record
# A run folder's name: `<config>_seed<S>`, the configuration's name (not empty) less its
# seed, the seed in ASCII digits only (`\d` would read `seed٠` or `seed１` as seeds 0 and
# 1). `seed0`, `_seed0` or `K50seed0` name no configuration: a copy renamed so was once a
# configuration of its own ("default" or "K50"), one seed each.
SEED_NAME = re.compile(r"^(?P<config>.+)_seed(?P<seed>[0-9]+)$")
# A name that ends in `seed` and digits of any script, some not ASCII: always refused.
_ANY_DIGIT_SEED = re.compile(r"seed\d+$")


def shown_name(name: str) -> str:
    """A name from disk (a folder, a file, a path) as the board prints it: as it is if all
    its characters are printable, else its `repr` (escaped: a newline in a name cannot
    start a line of the board's listing).

    Args:
      name: The name.

    Returns:
      The name, or its escaped form.
    """
    return name if name.isprintable() else repr(name)


def name_refusal(name: str, what: str = "its folder") -> str | None:
    """Why a folder's or file's name may not be on the board (None: it may): a character
    that is not printable (a newline, a tab, another control or format character, which
    could forge or hide a line of the board's listing), a letter outside ASCII or a space
    at either end (a name that only looks like another's), or a seed number in digits
    other than ASCII's.

    Args:
      name: The name (one path component).
      what: What it names, for the reason ("its folder", "its method's folder", ...).

    Returns:
      A one-line reason showing the name escaped, or None.
    """
    if not name.isprintable():
        return (
            f"{what}'s name {name!r} holds a control or other non-printable character: a "
            "name on the board is printable text"
        )
    seed = _ANY_DIGIT_SEED.search(name)
    if seed and not seed.group().isascii():
        return (
            f"{what}'s name {name!r} ends in a seed number that is not in ASCII digits: a "
            "run's name ends in seed<0-9...>"
        )
    if not name.isascii() or name != name.strip():
        return (
            f"{what}'s name {name!r} holds a letter outside ASCII or starts or ends with a "
            "space: a name on the board is ASCII text without them (a lookalike, such as a "
            "Cyrillic с for c or a trailing space, would read as another run's name)"
        )
    return None


LINK_REFUSAL = "a symbolic link, not a folder of its own: the board reads no run through a link"
# A run found at another depth than `<method>/<task>/<run>` under the tree the board was
# given: its last three names could pass for another run's, whose ledger row (`run_key`)
# it would share (an outside attack of 2026-11-29 had a copy one folder deeper displace
# its original); and the board reads the ledger beside the tree it is given, so a folder
# inside the tree could not move which ledger is read (a third attack did, while the
# board took the tree's depth from its runs).
DEPTH_REFUSAL = (
    "not <method>/<task>/<run> under the run tree the board was given (give it the tree, "
    "the folder above the methods' folders): the board counts a run by its place there"
)


def path_refusal(run_dir: str, base: str = "", name: str | None = None) -> str | None:
    """Why a run folder's place may not be on the board (None: it may), before anything
    in it is read: the folder is a symbolic link (`LINK_REFUSAL`), or a name on its path
    (the folders under `base`, its method's, its task's and its own; every entry in it)
    is refused by `name_refusal`.

    Args:
      run_dir: The run folder.
      base: The folder of the runs judged together (their common path; "": none).
      name: The run's folder name, if not `run_dir`'s own (`run_refusal`).

    Returns:
      A one-line reason, or None.
    """
    path = os.path.normpath(os.path.abspath(run_dir))
    if os.path.islink(path):
        return LINK_REFUSAL
    parts = path.split(os.sep)
    own = parts[-1] if name is None else name
    rel = os.path.relpath(path, base) if base else ""
    above = [] if rel in ("", ".") or rel.startswith("..") else rel.split(os.sep)[:-3]
    for folder in above:
        reason = name_refusal(folder, "a folder above it")
        if reason:
            return reason
    for folder, what in zip(parts[-3:-1], ("its method's folder", "its task's folder")):
        reason = name_refusal(folder, what)
        if reason:
            return reason
    reason = name_refusal(own)
    if reason:
        return reason
    try:
        entries = sorted(os.listdir(path))
    except OSError as e:
        return f"its folder cannot be listed ({type(e).__name__})"
    for entry in entries:
        if not entry.isprintable():
            return name_refusal(entry, "a file in it")
    return None


def file_digest(path: str) -> str:
    """The SHA-256 of a file, as hex digits."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def trusted_digests(path: str | None = None) -> frozenset[str]:
    """The SHA-256 digests of the trusted pickles (`TRUSTED_LIST`).

    Args:
      path: The list (None: the package's, `TRUSTED_LIST`).

    Returns:
      The digests; none if the list does not exist.

    Raises:
      ValueError: On a line that is not `<sha256>  <path>`.
    """
    path = TRUSTED_LIST if path is None else path
    if not os.path.isfile(path):
        return frozenset()
    digests = set()
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            match = _TRUSTED_LINE.match(line.rstrip("\n"))
            if not match:
                raise ValueError(f"{path}:{number} is not '<sha256>  <path>'")
            digests.add(match["digest"])
    return frozenset(digests)


def unvetted_code(run_dir: str, trusted: frozenset[str] | None = None) -> bool:
    """Whether a run's policy is code the project has not vetted: a `policy_code.py`, or
    Stable-Baselines3 pickles not all in the package's trusted list. Such a policy can
    tell which public test trial it is in from its first observation and replay the
    trial in its own simulator (docs/protocol.md#data-and-code: measured 1.42 m → 4.66
    m on 10 trials), so the board lists its configuration without ranking it.

    Args:
      run_dir: A run folder.
      trusted: The trusted digests (None: the package's list).
    """
    names = artifact_files(run_dir)
    if not names or names[0] not in CODE_FILES:
        return False
    if names == (CODE,):
        return True
    trusted = trusted_digests() if trusted is None else trusted
    return any(file_digest(os.path.join(run_dir, n)) not in trusted for n in names)


def artifact_files(run_dir: str) -> tuple[str, ...]:
    """The files verify scores a run from: the first of `ARTIFACTS` whose first file the
    folder holds; () for none."""
    for names in ARTIFACTS:
        if os.path.exists(os.path.join(run_dir, names[0])):
            return names
    return ()


def artifact_phrase() -> str:
    """The gait or policy files a run may hold, as one phrase (for what a folder lacks)."""
    names = (GAIT, EXPORTED, ACTIONS, CODE, SB3_MODEL)
    return f"{', '.join(names[:-1])} or {names[-1]}"


def trials_file(card_version: int, current_version: int) -> str:
    """The trial table of a run's card under `card_version`: `trials.csv` for its current
    card (of `current_version`), `trials_v<n>.csv` for one kept as history."""
    return "trials.csv" if card_version == current_version else f"trials_v{card_version}.csv"


def missing_files(run_dir: str, trials: str = "trials.csv") -> list[str]:
    """What a run folder lacks of what verify needs to score it again (empty: nothing).

    Args:
      run_dir: The run folder.
      trials: The name of the card's trial table.

    Returns:
      The missing names, in a fixed order; the gait or policy as one phrase.
    """
    missing = [
        name
        for name in ("config.json", "summary.json", trials, "versions.json")
        if not os.path.isfile(os.path.join(run_dir, name))
    ]
    artifacts = artifact_files(run_dir)
    if not artifacts:
        missing.append(f"the gait or policy ({artifact_phrase()})")
    missing += [a for a in artifacts if not os.path.isfile(os.path.join(run_dir, a))]
    return missing


OUTCOME_FIELDS = ("tier", "seed", "distance_m", "fell", "fall_step", "cause")  # score.TRIAL_FIELDS
# What the board reads of a trial's size (`card`'s, one definition; `analysis` imports
# admission, not the card's statistics): control steps a trial, physics steps each.
TRIAL_STEPS = card_stats.TRIAL_STEPS
PHYSICS_STEPS_PER_CONTROL_STEP = card_stats.PHYSICS_STEPS_PER_CONTROL_STEP


# The most a trial table may hold: the largest shipped holds 99,187 characters (250
# trials with their measures); 20 times that leaves room for more seeds or measures, and
# keeps the rows the board builds from a table far below a run file's `files.MAX_BYTES`
# (a 64 MiB table made about 3 GB of them: an outside attack of 2026-11-29). A choice.
MAX_TRIAL_TABLE_CHARS = 2_000_000


def read_trials(path: str) -> list[dict]:
    """A trial table (`score.TRIAL_FIELDS`, then a column per gait-quality measure) as
    `score.score_gait_trials` returns it: a table with measure columns gives each row its
    `quality` ({measure: float, or None for an empty cell}); one without (made before
    tables held them) gives rows without `quality`.

    Raises:
      OSError: If it cannot be read.
      KeyError, ValueError: On a missing column, a column named twice, a value of the
        wrong kind, or a file the board may not read (`files.refusal`).
    """
    text = files.read_text(path)
    if len(text) > MAX_TRIAL_TABLE_CHARS:
        raise ValueError(
            f"{os.path.basename(path)} holds {len(text)} characters, over the "
            f"{MAX_TRIAL_TABLE_CHARS} a trial table may hold"
        )
    try:
        reader = csv.DictReader(io.StringIO(text, newline=""))
        header = reader.fieldnames or []
        rows = list(reader)
    except csv.Error as e:  # a cell over csv's field limit, a NUL byte
        raise ValueError(f"{os.path.basename(path)} is not readable as CSV ({e})") from None
    twice = sorted(name for name, n in collections.Counter(header).items() if n > 1)
    if twice:
        raise ValueError(f"{os.path.basename(path)} names the column {twice[0]!r} twice")
    measures = [name for name in header if name not in OUTCOME_FIELDS]
    if text != _table_text(header, rows):
        raise ValueError(
            f"{os.path.basename(path)} is not written as the scorer writes a trial table "
            "(csv's own quoting and \\r\\n line endings, one line per row)"
        )
    trials = [
        {
            "tier": r["tier"],
            "seed": int(r["seed"]),
            "distance_m": float(r["distance_m"]),
            "fell": r["fell"] == "True",
            "fall_step": int(r["fall_step"]),
            "cause": r.get("cause") or ("fall" if r["fell"] == "True" else ""),
        }
        for r in rows
    ]
    if measures:
        for trial, r in zip(trials, rows):
            trial["quality"] = {name: _measure(r[name], name) for name in measures}
    if text != table_text(trials):
        raise ValueError(
            f"{os.path.basename(path)} does not spell its cells as the scorer writes them "
            "(a number's shortest repr, True/False, a failure's cause)"
        )
    return trials


def table_text(trials: list[dict]) -> str:
    """A trial table's text as the scorer writes it (`trial_cells`; floats with all their
    digits, which read back exactly): the one text a table of these trials may have."""
    rows = [
        {k: repr(v) if isinstance(v, float) else v for k, v in trial_cells(t).items()}
        for t in trials
    ]
    return _table_text(list(rows[0]), rows) if rows else ""


def _table_text(header: list[str], rows: list[dict]) -> str:
    """The text `verify.write_trials` writes for these cells (csv's default dialect): a
    table is read only in this form, so no two texts read as one table."""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=header, restval=None, extrasaction="raise")
    writer.writeheader()
    writer.writerows(rows)
    return buf.getvalue()


def _measure(text: str | None, name: str) -> float | None:
    """A trial table's gait-quality cell: empty (None: the trial has no such measure) or a
    number, NaN read as empty."""
    if text is None:
        raise ValueError(f"a row of the trial table has no {name} cell")
    if text == "":
        return None
    value = float(text)
    return None if math.isnan(value) else value


def trial_cells(trial: dict) -> dict:
    """A trial as its table's row writes it: its outcome, then its gait-quality measures
    (None: an empty cell)."""
    outcome = {k: v for k, v in trial.items() if k != "quality"}
    measures = {k: "" if v is None else v for k, v in (trial.get("quality") or {}).items()}
    return {**outcome, **measures}


same_trial = sample.same_trial  # one definition; sample imports nothing of admission


def same_trials(fresh: list[dict], stored: list[dict]) -> bool:
    """`same_trial` for two tables, row by row (and of the same length)."""
    return len(fresh) == len(stored) and all(map(same_trial, fresh, stored))


def differing_trials(fresh: list[dict], stored: list[dict]) -> int:
    """How many rows of two tables are not the same trial (`same_trial`), those beyond the
    shorter table's end included."""
    return sum(not same_trial(a, b) for a, b in zip(fresh, stored)) + abs(len(fresh) - len(stored))


def _jsonable(value):
    return json.loads(json.dumps(value))


def _without_quality(row: dict) -> dict:
    return {k: v for k, v in row.items() if k != "quality"}


def _card_row(trials: list[dict], steps: int) -> dict:
    distance = np.array([t["distance_m"] for t in trials], dtype=float)
    fell = np.array([t["fell"] for t in trials], dtype=bool)
    cause = np.array([electrical.CAUSES.index(t["cause"]) + 1 if t["cause"] else 0 for t in trials])
    return card_stats.row(distance, fell, {}, cause, steps)


def trials_refusal(
    card: dict, trials: list[dict], steps: int, measures: tuple[str, ...] = BOARD_MEASURES
) -> str | None:
    """Why a trial table does not stand behind a card (None: it produces it).

    Args:
      card: The stored card (`tiers`, `all`, `scoring_sim_steps`).
      trials: Its trial table (`read_trials`).
      steps: Control steps per trial (the run's `trial_steps`).
      measures: The gait-quality measures a table that holds any must hold (a card kept
        as history holds those of its day: none required).

    Returns:
      A one-line reason, or None.
    """
    tiers = list(card["tiers"])
    wanted = [(tier, seed) for tier in tiers for seed in protocol.TEST]
    if [(t["tier"], t["seed"]) for t in trials] != wanted:
        return (
            f"its trial table ({len(trials)} trials) is not the card's {len(tiers)} tiers × "
            f"{len(protocol.TEST)} test seeds in order"
        )
    for t in trials:
        ended = t["fall_step"] > 0
        if not 0 <= t["fall_step"] <= steps or ended != t["fell"]:
            return f"its trial table's {t['tier']} seed {t['seed']} ends at step {t['fall_step']}"
        if t["cause"] not in ("", *electrical.CAUSES) or bool(t["cause"]) != ended:
            return f"its trial table's {t['tier']} seed {t['seed']} has cause {t['cause']!r}"
        if not abs(t["distance_m"]) <= sample.MAX_TRIAL_DISTANCE_M:
            return (
                f"its trial table's {t['tier']} seed {t['seed']} walks {t['distance_m']!r} m, "
                f"beyond the {sample.MAX_TRIAL_DISTANCE_M:g} m a trial may claim"
            )
    by_tier = {tier: [t for t in trials if t["tier"] == tier] for tier in tiers}
    fresh = {tier: _card_row(rows, steps) for tier, rows in by_tier.items()}
    fresh["all"] = _card_row([t for tier in tiers for t in by_tier[tier]], steps)
    for name, row in fresh.items():
        stored = card["all"] if name == "all" else card["tiers"][name]
        made = _jsonable(_without_quality(row))
        for key, value in made.items():
            if stored.get(key) != value and key != "speed_m_s":
                return f"its trial table does not produce the card ({name}: {key} differs)"
        if stored.get("speed_m_s") != made["speed_m_s"]:
            implied = card_stats.implied_steps(stored)
            if implied != steps:
                return (
                    f"its card's {name} speed is that of {implied}-step trials, not "
                    f"{steps} (config.json)"
                )
            return f"its trial table does not produce the card ({name}: speed_m_s differs)"
    reason = quality_refusal(card, trials, measures)
    if reason:
        return reason
    bound = len(trials) * steps * card_stats.PHYSICS_STEPS_PER_CONTROL_STEP
    sim_steps = card.get("scoring_sim_steps")
    if not isinstance(sim_steps, int) or not 0 < sim_steps <= bound:
        return (
            f"the card's {sim_steps} physics steps are not those of {len(trials)} trials "
            f"of at most {steps} steps"
        )
    return None


def quality_refusal(
    card: dict, trials: list[dict], measures: tuple[str, ...] = BOARD_MEASURES
) -> str | None:
    """Why a trial table's gait-quality measures do not stand behind its card (None: they
    do, or the table holds none: then the card's medians are not the board's,
    `verified_summary`).

    A table that holds measures holds one column for each of the card's and no other, and
    each median of the card (each tier's row and the pooled one) is made again from them
    with the card's own arithmetic (`card.summarize`), equal bit for bit.

    Args:
      card: The stored card (`tiers`, `all`), its trial table already found to produce
        every other statistic (`trials_refusal`).
      trials: Its trial table (`read_trials`).
      measures: The measures it must hold if it holds any (default: the board's).

    Returns:
      A one-line reason, or None.
    """
    if not trials or "quality" not in trials[0]:
        return None
    names = list(trials[0]["quality"])
    claimed = list(card["all"].get("quality") or {})
    lacking = [m for m in measures if m not in names]
    if lacking:
        return (
            f"its trial table holds gait-quality measures but not {lacking[0]!r}, which the "
            "board shows"
        )
    if sorted(names) != sorted(claimed):
        extra = sorted(set(names) - set(claimed)) or sorted(set(claimed) - set(names))
        return (
            f"its trial table's gait-quality columns are not its card's measures "
            f"({extra[0]!r} is in one only)"
        )
    tiers = list(card["tiers"])
    rows = {tier: [t for t in trials if t["tier"] == tier] for tier in tiers}
    rows["all"] = trials
    for name, tier_trials in rows.items():
        stored = (card["all"] if name == "all" else card["tiers"][name]).get("quality") or {}
        made = _jsonable(card_stats.medians(_quality_arrays(tier_trials)))
        if sorted(stored) != sorted(claimed):
            return f"its card's {name} row and its all row name other gait-quality measures"
        for measure in claimed:
            if stored[measure] != made[measure]:
                return f"its trial table does not produce the card ({name}: {measure} differs)"
    return None


def _quality_arrays(trials: list[dict]) -> dict[str, np.ndarray]:
    """A table's gait-quality measures as the card's arrays (an empty cell: NaN)."""
    names = trials[0]["quality"] if trials else {}
    return {
        name: np.array(
            [np.nan if t["quality"][name] is None else t["quality"][name] for t in trials]
        )
        for name in names
    }


def verified_summary(run_dir: str, summary: dict) -> dict:
    """A run's summary as the board shows it: each card's gait-quality medians only where
    its trial table holds the trials' measures (admission made them again from those,
    `quality_refusal`); a card whose table holds none shows none (its medians cannot be
    checked against trials, as a sampled re-score checks the table); and its in-sample best
    as tried again (`in_sample`, which verify tries again from its `IN_SAMPLE` gait), not
    its training record (`best_distance_m`, as trained: nothing re-makes it).

    Args:
      run_dir: An admitted run.
      summary: Its summary.

    Returns:
      A copy of `summary`, its cards' unchecked `quality` emptied.
    """
    cards = cards_of(summary)
    if isinstance(cards, str):
        return summary
    current = max(cards)
    checked = dict(summary)
    if not has_in_sample(run_dir):
        checked["in_sample"] = None  # no gait run's in-sample gait: nothing to show
    history = dict(summary.get("history") or {})
    for version, card in cards.items():
        path = os.path.join(run_dir, trials_file(version, current))
        if _holds_measures(path):
            continue
        blank = _without_measures(card)
        if version == current:
            checked["test"] = blank
        else:
            history[f"v{version}"] = blank
    if history:
        checked["history"] = history
    return checked


def _holds_measures(path: str) -> bool:
    """Whether a trial table has gait-quality columns (its header names more than the
    outcome's)."""
    try:
        header = next(csv.reader(io.StringIO(files.read_text(path), newline="")), [])
    except csv.Error as e:
        raise ValueError(f"{os.path.basename(path)} is not readable as CSV ({e})") from None
    return any(name not in OUTCOME_FIELDS for name in header)


def _without_measures(card: dict) -> dict:
    """A card with every row's gait-quality medians emptied."""
    tiers = {t: {**row, "quality": {}} for t, row in card["tiers"].items()}
    return {**card, "tiers": tiers, "all": {**card["all"], "quality": {}}}


def actions_refusal(path: str, steps: int) -> str | None:
    """Why an action table does not fit a run's trials (None: it does), from its `.npy`
    header alone (parsed as data; the array is not read).

    Args:
      path: The run's `selected_actions.npy`.
      steps: Control steps per trial (the run's `trial_steps`).

    Returns:
      A one-line reason, or None.

    Raises:
      OSError: If the file cannot be read.
    """
    n_actions = len(cpg.LEG_JOINTS)
    with open(path, "rb") as f:
        try:
            version = np.lib.format.read_magic(f)
            if version == (1, 0):
                shape, _, dtype = np.lib.format.read_array_header_1_0(f)
            elif version == (2, 0):
                shape, _, dtype = np.lib.format.read_array_header_2_0(f)
            else:
                return f"its {ACTIONS} is a .npy file of format {version}, not 1.0 or 2.0"
        except ValueError as e:
            return f"its {ACTIONS} is not a NumPy .npy array ({_one_line(e)})"
    if dtype.hasobject:
        return f"its {ACTIONS} holds Python objects (pickles), not float64 actions"
    if dtype != np.float64:
        return f"its {ACTIONS} holds {dtype} values, not float64"
    if tuple(shape) != (steps, n_actions):
        return (
            f"its {ACTIONS} is a {tuple(shape)} table, not one row of {n_actions} actions per "
            f"control step of its {steps}-step trials"
        )
    try:  # the header checked against the bytes behind it, then the values
        table = exported.load_npy(path)
    except (ValueError, MemoryError) as e:
        return _one_line(e)
    if not np.all(np.isfinite(table)):
        return (
            f"its {ACTIONS} holds a value that is not finite (NaN or infinity): actions are "
            "numbers in [-1, 1]"
        )
    if np.any(np.abs(table) > 1.0):
        return f"its {ACTIONS} holds an action outside the task's action space [-1, 1]"
    return None


def policy_refusal(path: str) -> str | None:
    """Why an exported policy's file (`EXPORTED`) may not be read as one (None: it may):
    a zip that unpacks to more than a run file may hold, a member that is not a plain
    `.npy` array of the size its header says (`exported.load_npz`: no pickles, nothing
    allocated that the file does not hold), no action space, or a numeric array with a
    value that is not finite (NaN or infinity: a policy's weights and normalizer are
    numbers).

    Args:
      path: The run's `selected_policy.npz`.

    Returns:
      A one-line reason, or None.

    Raises:
      OSError: If the file cannot be read.
    """
    try:
        copies._require_bounded_zip(path)
        arrays = exported.load_npz(path)
    except (ValueError, MemoryError) as e:
        return _one_line(e)
    if "action_space" not in arrays:
        return f"its {EXPORTED} names no action_space (an array of text: joints or cpg)"
    for key, array in arrays.items():
        if array.dtype.kind in "biuf" and not np.all(np.isfinite(array)):
            return (
                f"its {EXPORTED}'s {key!r} holds a value that is not finite (NaN or "
                "infinity): a policy's arrays are finite numbers"
            )
    return _forward_refusal(arrays)


def _forward_refusal(arrays: dict) -> str | None:
    """Why an exported policy's arrays are no policy the scorer can run (None: they are):
    arrays that do not fit together (`exported.NumpyPolicy`), or no finite (1, 12) action
    for one observation of the task's shapes, all zeros (its normalizer's std aside)."""
    import cpg_suite  # the task's observation shapes (a policy is scored on them)

    arrays = dict(arrays)
    try:
        policy = exported.NumpyPolicy(arrays, str(arrays.pop("action_space")))
        spec = cpg_suite.load("darwin_walk").observation_spec()
        observation = {k: np.zeros((1, *spec[k].shape)) for k in spec}
        policy.reset_batch(1)
        with np.errstate(all="ignore"):
            action = np.asarray(policy.act_batch(observation))
    except (ValueError, KeyError, IndexError, TypeError) as e:
        return _one_line(f"its {EXPORTED} is no policy the scorer can run: {e}")
    if action.shape != (1, 12) or not np.all(np.isfinite(action)):
        return (
            f"its {EXPORTED} answers an observation with a {action.shape} array"
            f"{'' if np.all(np.isfinite(action)) else ' holding a value that is not finite'}, "
            "not 12 finite leg actions"
        )
    return None


def _one_line(error: object) -> str:
    """An error's words on one line (`exported.one_line`), at most 300 characters."""
    return exported.one_line(error, 300)


def card_under(summary: dict, version: int | None) -> dict | None:
    """A run's card under a benchmark version, as `cards_of` reads its cards: its test card
    if scored under it, else the one kept as history (`verify.upgrade_run`); None: none, or
    cards that do not hold together. `version` None: its test card."""
    test = summary.get("test")
    if not isinstance(test, dict) or version is None:
        return test if isinstance(test, dict) else None
    cards = cards_of(summary)
    return None if isinstance(cards, str) else cards.get(version)


def _read_json(path: str) -> dict:
    value = files.read_json(path)
    if not isinstance(value, dict):
        raise ValueError(f"{os.path.basename(path)} is not a JSON object")
    return value


# A submission's folder while it is written (`submit.partial_folder`): `.<name>.partial-<hex>`.
PARTIAL_NAME = re.compile(r"^\..+\.partial-[0-9a-f]+$")
# What makes a folder look like a run, or part of one.
RUN_MARKS = frozenset(
    {"summary.json", "config.json", "trials.csv", "versions.json", *(f[0] for f in ARTIFACTS)}
)


def looks_like_run(dirpath: str, names: Iterable[str]) -> bool:
    """Whether a folder holds a run or part of one (`RUN_MARKS`), or is a submission's
    half-written folder: what the board lists, admitted or not."""
    return bool(RUN_MARKS & set(names)) or bool(
        PARTIAL_NAME.match(os.path.basename(os.path.normpath(dirpath)))
    )


def run_files(run_dir: str) -> list[str]:
    """The names of the files the board or verify reads of a run folder: its config,
    summary, versions, trial tables and gait or policy files, as the folder holds them."""
    read = (
        "config.json",
        "summary.json",
        "versions.json",
        IN_SAMPLE,
        *(n for a in ARTIFACTS for n in a),
    )
    return sorted(
        n
        for n in os.listdir(run_dir)
        if n in read or (n.startswith("trials") and n.endswith(".csv"))
    )


def file_refusal(run_dir: str) -> str | None:
    """Why a run folder's files may not be read (`files.refusal` of each of `run_files`:
    a symbolic link, not a regular file, too large); None: they may."""
    try:
        names = run_files(run_dir)
    except OSError as e:
        return f"its folder cannot be listed ({type(e).__name__})"
    for name in names:
        reason = files.refusal(os.path.join(run_dir, name))
        if reason:
            return reason
    return None


# The longest refusal the board prints, characters (a choice: a reason names at most two
# runs' paths, each at most three names of 255, and its own words; the longest shipped
# refusal is 55). A reason that quotes more of a run's own text is cut (helper-51: a
# 900,000-character task name made a 900 KB line of the not-admitted listing).
MAX_REASON_CHARS = 2000


def shown_reason(reason: str) -> str:
    """A refusal as the board prints it: one line of printable characters, each other
    character escaped (a reason may quote a run's own text, as a card's `not_protocol`
    does: a newline there would forge a line of the listing; an outside attack of
    2026-11-29), at most `MAX_REASON_CHARS` of them (the rest cut, and counted)."""
    if len(reason) > MAX_REASON_CHARS:
        cut = len(reason) - MAX_REASON_CHARS
        reason = f"{reason[:MAX_REASON_CHARS]}... ({cut} more characters cut)"
    if reason.isprintable():
        return reason
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in reason)


def run_refusal(run_dir: str, version: int | None = None, name: str | None = None) -> str | None:
    """Why the board of `version` refuses one run folder (None: admitted, copies aside).

    Args:
      run_dir: A run folder `<method>/<task>/<run_name>`.
      version: The board's benchmark version (None: the run's card as it stands).
      name: The run's folder name, if not `run_dir`'s own (a submission checks its folder
        before renaming it into place: `submit._submit`).

    Returns:
      A one-line reason of printable characters (`shown_reason`), or None.
    """
    reason = _run_refusal(run_dir, version, name)
    return None if reason is None else shown_reason(reason)


def _run_refusal(run_dir: str, version: int | None, name: str | None) -> str | None:
    """`run_refusal`'s reason, as the checks word it."""
    reason = path_refusal(run_dir, name=name)
    if reason:
        return reason
    name = os.path.basename(os.path.normpath(run_dir)) if name is None else name
    if PARTIAL_NAME.match(name):
        return (
            "a submission's half-written folder: its process ended before the run was "
            "complete (delete it and submit again)"
        )
    if not SEED_NAME.match(name):
        return (
            f"its folder's name {shown_name(name)} is not <configuration>_seed<N>: a run's "
            "folder names its configuration, then _seed and the seed in digits (the board "
            "counts a configuration's seeds by it)"
        )
    reason = file_refusal(run_dir)
    if reason:
        return reason
    missing = missing_files(run_dir)
    if missing:
        return "missing " + ", ".join(missing)
    try:
        return _refusal(run_dir, version, name)
    except (OSError, ValueError, KeyError, TypeError, AttributeError, IndexError) as e:
        return _one_line(f"unreadable run files ({type(e).__name__}: {e})")
    except MemoryError:
        return "unreadable run files: reading them would take more memory than there is"


HISTORY_KEY = re.compile(r"v(?P<version>[1-9][0-9]*)")  # whole key (`fullmatch`): v<n>


def _version_number(value) -> bool:
    """Whether a card's or config's `benchmark_version` is one of `protocol.VERSIONS` as an
    integer (not 3.0, True or "3")."""
    return type(value) is int and value in protocol.VERSIONS


def cards_of(summary: dict) -> dict[int, dict] | str:
    """Every card a run holds, by benchmark version: its test card, which is its latest,
    and those kept as history (`verify.upgrade_run`), each under its own version.

    Args:
      summary: The run's summary.

    Returns:
      {version: card}, or a one-line reason the summary's cards do not hold together.
    """
    test = summary.get("test")
    if not isinstance(test, dict):
        return "summary.json holds no test card"
    current = test.get("benchmark_version", 1)
    if not _version_number(current):
        known = sorted(protocol.VERSIONS)
        return f"its test card claims benchmark version {current!r}, not one of {known}"
    history = summary.get("history") or {}
    if not isinstance(history, dict):
        return "summary.json's history is not an object of cards"
    cards = {current: test}
    for key, card in history.items():
        match = HISTORY_KEY.fullmatch(key) if isinstance(key, str) else None
        if not match or not isinstance(card, dict):
            return f"summary.json's history holds {key!r}, not a card under a version v<n>"
        kept = int(match["version"])
        claimed = card.get("benchmark_version", 1)
        if claimed != kept or not _version_number(claimed):
            return f"its history card {key} says it was scored under version {claimed!r}"
        if kept >= current:
            return (
                f"its test card (version {current}) is not its latest: it keeps a version-"
                f"{kept} card as history"
            )
        cards[kept] = card
    return cards


def versions_refusal(path: str) -> str | None:
    """Why a run's `versions.json` is not the record verify writes (None: it is): an object
    whose `made_with` (and `scored_with`, where present) names each package's version as
    text (a fifth outside attack of 2026-11-29 found a file of one `{` admitted)."""
    record = files.read_json(path)
    for key in ("made_with", "scored_with"):
        if key == "scored_with" and isinstance(record, dict) and key not in record:
            continue
        entry = record.get(key) if isinstance(record, dict) else None
        if not isinstance(entry, dict) or not all(
            isinstance(v, str) or v is None for v in entry.values()
        ):
            return f"versions.json's {key} is not an object of versions as text"
    return None


def _refusal(run_dir: str, version: int | None, name: str) -> str | None:
    summary = _read_json(os.path.join(run_dir, "summary.json"))
    config = _read_json(os.path.join(run_dir, "config.json"))
    settings = config.get("settings")
    if not isinstance(settings, dict):
        return "config.json holds no settings"
    reason = versions_refusal(os.path.join(run_dir, "versions.json"))
    if reason:
        return reason
    cards = cards_of(summary)
    if isinstance(cards, str):
        return cards
    current = max(cards)
    if version is not None and version not in cards:
        return f"no card under benchmark version {version} (its card: version {current})"
    if not isinstance(settings.get("test_seeds"), int) or not isinstance(
        settings.get("trial_steps"), int
    ):
        return "config.json has no test_seeds or trial_steps (the card's settings)"
    trained = settings.get("benchmark_version", 1)
    if not _version_number(trained):
        known = sorted(protocol.VERSIONS)
        return f"config.json claims benchmark version {trained!r}, not one of {known}"
    if min(cards) != trained:
        return (
            f"config.json claims benchmark version {trained}, but the run's cards are of "
            f"version {', '.join(map(str, sorted(cards)))}: its first card is made under "
            "the version it trained under"
        )
    steps = settings["trial_steps"]
    if artifact_files(run_dir) == (EXPORTED,):
        reason = policy_refusal(os.path.join(run_dir, EXPORTED))
        if reason:
            return reason
    if artifact_files(run_dir) == (ACTIONS,):
        reason = actions_refusal(os.path.join(run_dir, ACTIONS), steps)
        if reason:
            return reason
    if artifact_files(run_dir) == (GAIT,):
        reason = gait_refusal(os.path.join(run_dir, GAIT), settings.get("controller", "open_loop"))
        if reason:
            return reason
    # The board's card first (its reason is the one a reader of that board needs), then
    # every other card the run holds: the board ranks one, the others rank elsewhere.
    order = sorted(cards, key=lambda v: (v != version, -v))
    tables = {}
    for card_version in order:
        reason, tables[card_version] = _card_refusal(
            run_dir, settings, cards[card_version], card_version, current
        )
        if reason:
            return reason
    for kept in (v for v in cards if v != current):
        reason = _alike_refusal(cards, tables, kept, current)
        if reason:
            return reason
    reason = training_refusal(run_dir, settings, summary)
    reason = reason or command_refusal(config.get("command"), settings)
    reason = reason or in_sample_refusal(run_dir, settings, summary)
    if reason:
        return reason
    match = SEED_NAME.match(name)
    seed = settings.get("seed")
    if match and (type(seed) is not int or seed != int(match["seed"])):
        return (
            f"config.json's seed {seed!r} is not the seed of its folder's name "
            f"({int(match['seed'])})"
        )
    return None


def gait_refusal(path: str, controller: str = "open_loop") -> str | None:
    """Why a run's gait file (`GAIT`, `IN_SAMPLE`) is not a valid parameter file of its
    controller (None: it is one): read strictly, as every run file (`files.read_json`),
    then `feedback.params_problem` (finite JSON numbers within physical bounds, the names
    it needs and no others); an open-loop gait holds no gains (its scorer reads none, and
    gains it does not read would make a copy look like another gait to `copies`)."""
    data = files.read_json(path)
    problem = feedback.params_problem(data)
    if not problem and controller != "feedback" and isinstance(data, dict) and "gains" in data:
        problem = "an open-loop gait holds no gains (its controller reads amplitudes only)"
    return f"{os.path.basename(path)}: {problem}" if problem else None


def _card_settings_refusal(settings: dict) -> str | None:
    """Why a config's card settings are not of their JSON kinds (None: they are): the test
    seeds and trial steps integers, the supply window (where set) a number, never a
    boolean or text (`true`, `"1"` and `" 1e0"` passed as the 1 s window: helper-51)."""
    for key in ("test_seeds", "trial_steps"):
        if type(settings.get(key)) is not int:
            return f"config.json's {key} is {settings.get(key)!r}, not an integer"
    window = settings.get("supply_window", electrical.SUPPLY_WINDOW)
    if type(window) not in (int, float):
        return f"config.json's supply_window is {window!r}, not a number of seconds"
    return None


def _card_refusal(
    run_dir: str, settings: dict, card: dict, card_version: int, current: int
) -> tuple[str | None, list[dict] | None]:
    """Why one of a run's cards is not a protocol card its trial table produces (None),
    and the table."""
    trials_name = trials_file(card_version, current)
    if not os.path.isfile(os.path.join(run_dir, trials_name)):
        return f"missing {trials_name}", None
    steps = settings["trial_steps"]
    reason = _card_settings_refusal(settings)
    if reason:
        return reason, None
    deviations = card_stats.deviations(
        protocol.card_tiers(settings.get("test_tiers"), card_version),
        settings["test_seeds"],
        steps,
        card_version,
        settings.get("supply_window", electrical.SUPPLY_WINDOW),
    ) or card_stats.card_deviations(card, infer_steps=False)
    scored = card.get("tiers")
    if not deviations and (not isinstance(scored, dict) or not scored):
        deviations = ["the card has no tiers"]
    elif not deviations:  # what the card holds, whatever settings it claims
        deviations = card_stats.deviations(
            tuple(scored), settings["test_seeds"], steps, card_version
        )
    if deviations:
        where = "" if card_version == current else f" (its version-{card_version} card)"
        return f"not under the protocol's card settings{where}: " + "; ".join(deviations), None
    trials = read_trials(os.path.join(run_dir, trials_name))
    measures = BOARD_MEASURES if card_version == current else ()
    reason = trials_refusal(card, trials, steps, measures)
    if reason and card_version != current:
        reason = f"{reason} (its version-{card_version} card, {trials_name})"
    return reason, trials


def _alike_refusal(cards: dict, tables: dict, old: int, new: int) -> str | None:
    """Why a card kept as history and the test card disagree on a tier both score alike
    (`protocol.scored_alike`: a re-score keeps those trials and their measures), None: they
    agree: the same trials, and every value of the history card's tier row (the gait-quality
    medians included) the test card's (which may hold measures added since)."""
    for tier in protocol.scored_alike(old, new):
        mine = [t for t in tables[old] if t["tier"] == tier]
        now = [t for t in tables[new] if t["tier"] == tier]
        if not same_trials(now, mine):
            return (
                f"its version-{old} trials differ from its version-{new} trials on {tier}, "
                f"which both versions score alike (trials_v{old}.csv, trials.csv)"
            )
        if not card_stats.extends(cards[new]["tiers"][tier], cards[old]["tiers"][tier]):
            return (
                f"its version-{old} card's {tier} row differs from its version-{new} card's, "
                "which both versions score alike"
            )
    return None


def _count(value) -> bool:
    return type(value) is int and value >= 0


def has_in_sample(run_dir: str) -> bool:
    """Whether a run holds an in-sample gait the board may show tried again: a gait run
    (its policy is `GAIT`) with an `IN_SAMPLE` file. A policy's run holds none: a
    `best_params.json` beside another policy is no part of it (never read)."""
    return artifact_files(run_dir) == (GAIT,) and os.path.isfile(os.path.join(run_dir, IN_SAMPLE))


def in_sample_refusal(run_dir: str, settings: dict, summary: dict) -> str | None:
    """Why a run's in-sample best does not hold together (None: it does, or it reports
    none): the best training trial `summary.json` reports (`best_distance_m`, `best_fell`,
    `best_round`) is the one its `IN_SAMPLE` gait records; and what `summary.json` stores
    of it tried again (`in_sample`: the board's in-sample column, which verify tries again
    on the training seeds of that round, `verify.in_sample_problems`) is a trial's record,
    of a run that holds that gait.

    Args:
      run_dir: The run folder.
      settings: Its config's settings.
      summary: Its summary.

    Returns:
      A one-line reason, or None.
    """
    path = os.path.join(run_dir, IN_SAMPLE)
    if not has_in_sample(run_dir):
        return None  # nothing of it is shown (`verified_summary`) or read
    reason = gait_refusal(path, settings.get("controller", "open_loop"))
    if reason:
        return reason
    best = _read_json(path)
    rounds = settings.get("rounds")
    if type(best.get("round")) is int and _count(rounds) and not 1 <= best["round"] <= rounds:
        return f"its {IN_SAMPLE} is of round {best['round']}, not one of its {rounds} rounds"
    for key, field in (
        ("best_distance_m", "distance_m"),
        ("best_fell", "fell"),
        ("best_round", "round"),
    ):
        if key in summary and summary[key] != best.get(field):
            theirs = best.get(field)
            return f"summary.json's {key} {summary[key]!r} is not its {IN_SAMPLE}'s {theirs!r}"
    if not _trial_record(best) or type(best.get("round")) is not int or best["round"] < 1:
        return (
            f"its {IN_SAMPLE} does not record a finite distance_m (within "
            f"{sample.MAX_TRIAL_DISTANCE_M:g} m), a fell flag and a round ≥ 1"
        )
    tried = summary.get("in_sample")
    if tried is not None and (not _trial_record(tried) or set(tried) != {"distance_m", "fell"}):
        return (
            f"summary.json's in_sample is not a trial's finite distance_m (within "
            f"{sample.MAX_TRIAL_DISTANCE_M:g} m) and fell flag"
        )
    return None


def _trial_record(record) -> bool:
    """Whether a record holds a trial's `distance_m` (a float within the distance any
    trial may claim, `sample.MAX_TRIAL_DISTANCE_M`: helper-51 showed a 99 m in-sample best)
    and `fell` (a bool)."""
    return (
        isinstance(record, dict)
        and type(record.get("distance_m")) is float
        and abs(record["distance_m"]) <= sample.MAX_TRIAL_DISTANCE_M
        and type(record.get("fell")) is bool
    )


def training_refusal(run_dir: str, settings: dict, summary: dict) -> str | None:
    """Why what a run says of its training does not hold together (None: it does): its
    config names the task of its folder; its budget is a count (`evaluations` for a run
    whose config sets a population and rounds, `env_steps` only for a learner's
    `total_steps`), as are its simulated steps,
    no less than its config gave it (population × rounds × `eval_seeds`, 1 if unset; the
    learner's `total_steps`). The training itself is the submitter's word: only a re-run
    shows it (docs/protocol.md#admission).

    Args:
      run_dir: The run folder `<method>/<task>/<run_name>`.
      settings: Its config's settings.
      summary: Its summary.
    """
    task = os.path.basename(os.path.dirname(os.path.normpath(os.path.abspath(run_dir))))
    if task not in protocol.TIERS:  # a fifth attack trained "darwin_walk_foo"
        return (
            f"its task folder {shown_name(task)} is no DARwIn-OP walking task: one of "
            f"{', '.join(protocol.TIERS)}"
        )
    if settings.get("task") != task:
        return f"config.json says it trained on {settings.get('task')!r}, its folder on {task!r}"
    for key in ("evaluations", "env_steps", "sim_steps", "validation_sim_steps"):
        if key in summary and not _count(summary[key]):
            return f"summary.json's {key} is {summary[key]!r}, not a count"
    if "env_steps" in summary and "total_steps" not in settings:  # the board's budget reads it
        return (
            "summary.json claims env_steps, a learner's budget, but config.json sets no total_steps"
        )
    given = {k: settings[k] for k in ("population", "rounds", "eval_seeds") if k in settings}
    if ("population" in given or "rounds" in given) and "total_steps" in settings:
        return "config.json sets both a population's rounds and a learner's total_steps"
    if "population" in given or "rounds" in given:
        given.setdefault("eval_seeds", 1)
        if not all(_count(g) and g > 0 for g in given.values()) or len(given) != 3:
            return f"config.json's budget {given} is not three positive counts"
        if "evaluations" not in summary:
            return "summary.json does not say how many training trials it took (evaluations)"
        least = given["population"] * given["rounds"] * given["eval_seeds"]
        if summary["evaluations"] < least:
            return (
                f"summary.json claims {summary['evaluations']} training trials, fewer than "
                f"its config's {given['population']} × {given['rounds']} rounds × "
                f"{given['eval_seeds']} seeds"
            )
        reason = _physics_refusal(summary, summary["evaluations"], "training trials")
        if reason:
            return reason
        reason = _validation_refusal(settings, summary)
        if reason:
            return reason
    if "total_steps" in settings:
        total = settings["total_steps"]
        if not _count(total) or total == 0:
            return f"config.json's total_steps is {total!r}, not a positive count"
        if summary.get("env_steps", -1) < total:
            return (
                f"summary.json claims {summary.get('env_steps')} training steps, fewer than "
                f"its config's total_steps {total}"
            )
        steps = summary["env_steps"]
        if summary.get("evaluations", 0) > steps:
            return (
                f"summary.json claims {steps} training control steps, fewer than its "
                f"{summary['evaluations']} training episodes (evaluations)"
            )
        return _physics_refusal(summary, steps, "training control steps")
    return None


# The settings a run's budget is read from, which its `command` must not contradict.
BUDGET_SETTINGS = (
    "population",
    "rounds",
    "eval_seeds",
    "total_steps",
    "validation_top",
    "validation_seeds",
)


def command_refusal(command: object, settings: dict) -> str | None:
    """Why a config's `command` contradicts its settings on the budget (None: it does not):
    a `--<key>=<value>` of `BUDGET_SETTINGS` whose value is not the setting's (helper-51:
    a command of `--population=100 --rounds=400` beside settings of 50 × 50 ranked on the
    study's track). A command that says nothing of a setting contradicts nothing; one that
    is consistently false is caught only by running it.

    Args:
      command: The config's `command` (text, or absent).
      settings: Its settings.
    """
    if command is None:
        return None
    if not isinstance(command, str):
        return f"config.json's command is {type(command).__name__}, not text"
    try:
        tokens = shlex.split(command)
    except ValueError:
        return "config.json's command is not a shell command line"
    for i, token in enumerate(tokens):
        key, equals, value = token.lstrip("-").partition("=")
        if not token.startswith("-"):
            continue
        if key.strip() == "flagfile":  # flags the board cannot read
            return "config.json's command reads its flags from a file (--flagfile)"
        key = key.strip()
        if key not in BUDGET_SETTINGS:
            continue
        if not equals:  # `--key value`, as absl reads it too
            value = tokens[i + 1] if i + 1 < len(tokens) else ""
        if key not in settings or not _same_number(value, settings[key]):
            return (
                f"config.json's command says --{key}={shown_name(value)}, its settings "
                f"{settings.get(key)!r}"
            )
    return None


def _same_number(text: str, setting: object) -> bool:
    """Whether a command's flag value is the setting's integer (`050` is 50, as absl reads it)."""
    try:
        return type(setting) is int and int(text.strip()) == setting
    except ValueError:
        return False


def _validation_refusal(settings: dict, summary: dict) -> str | None:
    """Why a gait search's validation budget falls short of its config (None: it does
    not): its `validation_top` best candidates and its final mean, each on
    `validation_seeds` seeds, take at least `PHYSICS_STEPS_PER_CONTROL_STEP` physics steps
    each, which it states (`validation_sim_steps`, which its budget track counts)."""
    top, seeds = settings.get("validation_top", 0), settings.get("validation_seeds", 0)
    if not (_count(top) and _count(seeds)):
        return f"config.json's validation_top {top!r} and validation_seeds {seeds!r} are not counts"
    least = (top + 1) * seeds * PHYSICS_STEPS_PER_CONTROL_STEP
    if least and "validation_sim_steps" not in summary:
        return "summary.json does not say how many physics steps choosing its gait took"
    if summary.get("validation_sim_steps", least) < least:
        return (
            f"summary.json claims {summary['validation_sim_steps']} validation physics steps, "
            f"fewer than its {top + 1} candidates on {seeds} seeds take "
            f"({PHYSICS_STEPS_PER_CONTROL_STEP} each at least)"
        )
    return None


def _physics_refusal(summary: dict, control_steps: int, what: str) -> str | None:
    """Why a summary's physics steps (`sim_steps`) fall short of its training: each control
    step, or each trial's first, takes `PHYSICS_STEPS_PER_CONTROL_STEP` of them (a third
    outside attack of 2026-11-29 showed a learner's budget 8 times smaller than it
    simulated; the shipped learners claim exactly that many, the gait runs 590 times and
    more). None: it does not, or it claims none."""
    least = control_steps * PHYSICS_STEPS_PER_CONTROL_STEP
    if summary.get("sim_steps", least) < least:
        return (
            f"summary.json claims {summary['sim_steps']} physics steps (sim_steps), fewer than "
            f"its {control_steps} {what} take ({PHYSICS_STEPS_PER_CONTROL_STEP} each at least)"
        )
    return None


def unvouched_history(summary: dict) -> list[tuple[int, dict]]:
    """The cards a run keeps as history that its test trials do not vouch for, by version:
    those with a tier whose physics differs from the test card's (`protocol.scored_alike`;
    a version-1 card, made without the supply limit). The others' tables the board holds
    to the test card's (`_alike_refusal`).

    Args:
      summary: A run's summary.

    Raises:
      ValueError: If its cards do not hold together (`cards_of`).
    """
    cards = cards_of(summary)
    if isinstance(cards, str):
        raise ValueError(cards)
    current = max(cards)
    return [
        (version, kept)
        for version, kept in sorted(cards.items())
        if version != current
        and not set(kept["tiers"]) <= set(protocol.scored_alike(version, current))
    ]


def full_check_trials(summary: dict) -> int:
    """How many trials a full re-score of a run scores (`verify.verify_run`): its test
    card's and those of the cards it keeps as history that its test trials do not vouch
    for (`unvouched_history`), each every test seed of its tiers.

    Raises:
      ValueError: If its cards do not hold together (`cards_of`).
    """
    cards = [summary["test"], *(kept for _, kept in unvouched_history(summary))]
    return sum(len(card["tiers"]) * len(protocol.TEST) for card in cards)


LEDGER = "rescored.csv"  # beside a run tree: what re-scored each run (`verify --record`)
LEDGER_FIELDS = ("run", "files_sha256", "check", "trials", "result", "date_utc", "commit")


def run_digest(run_dir: str) -> str:
    """The SHA-256 of the files verify reads of a run (config, summary, trial tables,
    versions, the gait or policy), by name: a run re-scored is that run only while this
    holds.

    Raises:
      OSError: If a file cannot be read.
      ValueError: If the board may not read one (`files.refusal`).
    """
    names = sorted(
        n
        for n in os.listdir(run_dir)
        if n
        in ("config.json", "summary.json", "versions.json", IN_SAMPLE, *artifact_files(run_dir))
        or (n.startswith("trials") and n.endswith(".csv"))
    )
    digest = hashlib.sha256()
    for name in names:
        data = files.read_bytes(os.path.join(run_dir, name))
        digest.update(f"{name}\0{len(data)}\0".encode())
        digest.update(data)
    return digest.hexdigest()


def run_key(run_dir: str) -> str:
    """A run's name in a ledger: `<method>/<task>/<run>`."""
    return "/".join(_tail(run_dir))


def read_ledger(path: str) -> dict[str, dict]:
    """A ledger's rows by run (`LEDGER_FIELDS`, each a string: "" where a row is short); {}
    if there is none.

    Raises:
      OSError: If it cannot be read.
      ValueError: If the board may not read it (`files.refusal`).
    """
    if not os.path.lexists(path):
        return {}
    rows = csv.DictReader(io.StringIO(files.read_text(path), newline=""))
    try:
        return {
            row["run"]: {k: row.get(k) or "" for k in LEDGER_FIELDS}
            for row in rows
            if row.get("run")
        }
    except csv.Error as e:
        raise ValueError(f"{os.path.basename(path)} is not readable as CSV ({e})") from None


def rescored_in_full(run_dir: str, ledger: dict[str, dict]) -> str | None:
    """The date a ledger says `run_dir` was re-scored in full and reproduced, if its files
    are still those it checked (None: not so, or files the board may not read)."""
    row = ledger.get(run_key(run_dir))
    if not row or row["check"] != "full" or row["result"] != "reproduced":
        return None
    if _digest_or_none(run_dir) != row["files_sha256"]:
        return None
    try:  # a row of an earlier check that scored fewer of its cards is no full re-score
        scored = full_check_trials(_read_json(os.path.join(run_dir, "summary.json")))
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None
    return row["date_utc"] if row["trials"] == str(scored) else None


def _digest_or_none(run_dir: str) -> str | None:
    try:
        return run_digest(run_dir)
    except (OSError, ValueError):
        return None


def run_identity(run_dir: str) -> tuple[str, str, str]:
    """A run folder's method, training task and configuration (its name less the seed)."""
    parts = os.path.normpath(os.path.abspath(run_dir)).split(os.sep)
    match = SEED_NAME.match(parts[-1])
    config = match["config"] if match else parts[-1]
    return parts[-3], parts[-2], config


def trained_version(run_dir: str) -> int:
    """The benchmark version a run trained under: its config's `benchmark_version` (1 for a
    run made before the setting existed, or without a readable config)."""
    try:
        settings = _read_json(os.path.join(run_dir, "config.json"))["settings"]
        return int(settings.get("benchmark_version", 1))
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return 1


def refusals(
    run_dirs: Iterable[str], version: int | None = None, ledger: dict[str, dict] | None = None
) -> dict[str, str]:
    """The runs the board of `version` refuses, each with its reason (`run_refusal`), and
    the copies: a run whose trial outcomes, or whose gait or policy, equal as values those
    of an earlier run trained alike (`cpg_suite.protocol.copies`),
    in any configuration of any method; and a second run of one seed of a configuration
    (`seed0` and `seed00`). Earlier: a run the ledger beside the tree records as
    reproduced with its present files (`_on_record`), then the run that says it started
    first (`copies.started`), then path order. A run and its re-run under a version of
    other training physics (`protocol.trained_alike`; the same method, configuration and
    seed, `_retrained`) are not compared: a version-1 run is listed beside its version-2
    re-run, never ranked with it (six shipped CEM seeds trained to the same gait under
    both: the limit never bit). Any other pair is, whatever physics each claims.

    Args:
      run_dirs: Run folders.
      version: The board's benchmark version (None: each run's card as it stands).
      ledger: The board's ledger (`read_ledger` of the one beside the root it was given);
        None: each run's own, beside its tree.

    Returns:
      {run folder: reason} for the refused runs.
    """
    run_dirs = list(run_dirs)
    refused, kept, seeds = {}, [], {}
    base = os.path.commonpath([os.path.abspath(d) for d in run_dirs]) if run_dirs else ""
    # A link, or a name that is not printable text: refused before anything in it is read.
    for run_dir in run_dirs:
        reason = path_refusal(run_dir, base)
        if reason:
            refused[run_dir] = reason
    judged = [d for d in run_dirs if d not in refused]
    ledgers = {d: ledger for d in judged} if ledger is not None else _ledgers(judged)
    on_record = {d: _on_record(d, ledgers[d]) for d in judged}
    for run_dir in sorted(judged, key=lambda d: (not on_record[d], copies.started(d), d)):
        reason = run_refusal(run_dir, version)
        if reason is None:
            reason, fingerprint = _copy_refusal(run_dir, version, kept, base)
        if reason is None:
            reason, seed = _seed_refusal(run_dir, seeds, base)
        if reason is None:
            kept.append((run_dir, _trained_as(run_dir), fingerprint))
            seeds[seed] = run_dir
        else:
            refused[run_dir] = reason
    return {d: shown_reason(refused[d]) for d in run_dirs if d in refused}


def _tree(run_dir: str) -> str:
    """The run tree a run lies in: the folder above its `<method>/<task>/<run>`."""
    return os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(run_dir))))


def _ledgers(run_dirs: list[str]) -> dict[str, dict]:
    """Each run's own ledger (`LEDGER`), beside its tree: for a caller that names no root.
    The board passes the one beside the root it was given, so that neither a ledger inside
    a submitted tree nor a folder at another depth changes which ledger it reads."""
    trees = {d: _tree(d) for d in run_dirs}
    read = {
        t: _ledger_or_none(os.path.join(os.path.dirname(t), LEDGER)) for t in set(trees.values())
    }
    return {d: read[trees[d]] for d in run_dirs}


def ledger_beside(root: str) -> dict[str, dict]:
    """The ledger of a run tree, beside it (`LEDGER`): what `refusals` of the runs under
    `root` judges by (no rows where there is none or it cannot be read)."""
    return _ledger_or_none(os.path.join(os.path.dirname(os.path.abspath(root)), LEDGER))


def _ledger_or_none(path: str) -> dict[str, dict]:
    """`read_ledger`, or no rows where it cannot be read (no run is then on record)."""
    try:
        return read_ledger(path)
    except (OSError, ValueError):
        return {}


def _on_record(run_dir: str, ledger: dict[str, dict]) -> bool:
    """Whether the ledger (`_ledgers`) records this run as re-scored (in full, or its trials
    when upgraded) and reproduced, with the files it holds now: such a run entered first,
    whatever start time a copy's config claims. A sampled or differing row does not
    count."""
    row = ledger.get(run_key(run_dir))
    return (
        bool(row)
        and (row["check"] == "full" or row["check"].startswith("upgrade "))
        and row["result"] == "reproduced"
        and row["files_sha256"] == _digest_or_none(run_dir)
    )


def shown(run_dir: str, base: str) -> str:
    """A run as a refusal names it: its path under the runs judged (`base`, their common
    folder) where that names its method, task and run, else `<method>/<task>/<run>`;
    escaped where a name in it is not printable (`shown_name`)."""
    rel = os.path.relpath(os.path.abspath(run_dir), base) if base else ""
    if rel.count(os.sep) >= 2 and not rel.startswith(".."):
        return shown_name(rel)
    return shown_name(os.path.join(*_tail(run_dir)))


def _seed_refusal(run_dir: str, seeds: dict, base: str = "") -> tuple[str | None, tuple]:
    """Why an admissible run is a second run of a seed of its configuration (None: it is
    not), and its key in `seeds` ({(method, task, configuration, training physics, seed):
    the run kept})."""
    settings = _read_json(os.path.join(run_dir, "config.json"))["settings"]
    match = SEED_NAME.match(os.path.basename(os.path.normpath(run_dir)))
    seed = int(match["seed"]) if match else settings.get("seed")  # the folder's, if named
    key = (*run_identity(run_dir), _trained_as(run_dir), seed)
    if seed is not None and key in seeds:
        where = shown(seeds[key], base)
        return f"a second run of seed {key[-1]} of its configuration ({where}: the first)", key
    return None, key


def _copy_refusal(run_dir: str, version: int | None, kept: list, base: str = "") -> tuple:
    """Why an admissible run is a copy of one of `kept` (None) and its fingerprint."""
    summary = _read_json(os.path.join(run_dir, "summary.json"))
    card = card_under(summary, version)
    current = summary["test"].get("benchmark_version", 1)
    trials_name = trials_file(card.get("benchmark_version", 1), current)
    trials = read_trials(os.path.join(run_dir, trials_name))
    try:
        fingerprint = copies.fingerprint(run_dir, artifact_files(run_dir), trials)
    except (OSError, ValueError, KeyError, TypeError, SyntaxError, MemoryError) as e:
        return _one_line(f"unreadable gait or policy ({type(e).__name__}: {e})"), None
    trained_as = _trained_as(run_dir)
    for earlier, their_physics, theirs in kept:
        if their_physics != trained_as and _retrained(run_dir, earlier):
            continue  # one seed trained again under another version's physics: not compared
        same = copies.copy_of(fingerprint, theirs)
        if same:
            where = shown(earlier, base)
            if their_physics != trained_as:
                return (
                    f"a copy of {where}, which trained under other physics: the same {same} "
                    "as values, under another method, configuration or seed"
                ), None
            return f"a copy of {where}: the same {same} as values (one run, not another)", None
    return None, fingerprint


# A configuration's run kept under its version-n name when it was trained again under a
# later version: `<config>_v<n>_seed<S>` beside `<config>_seed<S>` (K50_n0.8_e2_v1 and
# K50_n0.8_e2, cpg_v1 and cpg).
_VERSIONED = re.compile(r"^(?P<config>.+)_v(?P<version>[1-9][0-9]*)_seed(?P<seed>[0-9]+)$")
_VERSIONED_CONFIG = re.compile(r"_v[0-9]+$")  # a configuration that itself names a version


def _retrained(run_dir: str, earlier: str) -> bool:
    """Whether two runs are one method's configuration and seed, on one training task,
    trained under two versions of other training physics: one named `<config>_v<n>_seed<S>`
    and trained under version n, the other `<config>_seed<S>` and trained under a later
    one (`_VERSIONED`; `<config>` names no version itself). Such a pair may hold the same
    gait (six shipped CEM seeds trained to it under both: the limit never bit); any other
    pair that does is a copy, whatever physics each claims. Three outside attacks of
    2026-11-29 got relabelled version-1 runs ranked as another configuration, as
    `K50_s1_v1_v2` beside `K50_s1_v1`, and on another training task."""
    (method, task, name), (their_method, their_task, their_name) = _tail(run_dir), _tail(earlier)
    if (method, task) != (their_method, their_task):  # a third attack moved it to a task
        return False
    pairs = ((name, their_name, run_dir, earlier), (their_name, name, earlier, run_dir))
    for old, new, old_dir, new_dir in pairs:
        kept = _VERSIONED.match(old)
        if (
            kept is not None
            and _VERSIONED_CONFIG.search(kept["config"]) is None  # not `<x>_v1_v2`
            and new == f"{kept['config']}_seed{kept['seed']}"
            and trained_version(old_dir) == int(kept["version"]) < trained_version(new_dir)
        ):
            return True
    return False


def _trained_as(run_dir: str) -> int:
    """The version whose training physics the run trained under (`protocol.trained_alike`):
    runs trained under versions 2 and 3 trained alike and are compared as copies."""
    return protocol.trained_alike(trained_version(run_dir))


def _tail(run_dir: str) -> list[str]:
    return os.path.normpath(os.path.abspath(run_dir)).split(os.sep)[-3:]
