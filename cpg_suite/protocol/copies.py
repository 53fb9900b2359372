"""Copies by value: two runs are one run when their trial outcomes or their gaits or
policies are equal as values, whatever their bytes (docs/protocol.md#admission).

A run's fingerprint holds

* its trial outcomes: per trial of its card, the tier, the seed, whether it failed, the
  control step and cause of the failure (equal), and the distance walked (equal within
  `TRIAL_TOLERANCE_M`);
* its gait or policy as parsed values: a gait's amplitudes and feedback gains (absent
  gains are 0, as `feedback.load_params` reads them), an exported policy's arrays (as the
  scorer reads them: an unused array or a default spelled out is none of it) or an
  action table (NumPy, read without unpickling), each array within `VALUE_RTOL` of its
  largest value or its artifact's median array's (`value_distance`); a policy's
  Python file as its syntax tree (comments and layout aside; parsed, never run); a
  Stable-Baselines3 model's zip members and normalizer as bytes (reading them as values
  would unpickle them).

Padding in a `.npy` header, keys reordered or spaces added in JSON, a comment added to
code: the values stay, and so does the copy (a trial table has one text only: admission
reads it in the scorer's spelling or not at all). The tolerances
catch what the bytes hide too — a gait nudged by up to 2 % of its largest amplitude and
scored again is the same gait.

Across kinds (`across_kinds`): an open-loop gait and an action table are one when the
table's rows are the gait's own actions (`ActionTable.from_gait`) by the same rules, so a
gait entered again as its table, a few rows changed, is a copy (the third outside attack
of 2026-11-28). A feedback gait's actions depend on what it senses: it has no table.

Near-copies, value by value (`near_copy`): two artifacts of one structure are also one
when, comparing each value with its counterpart relative to the larger of the two
(`coordinate_differences`; values both within `VALUE_RTOL` of zero, such as an open-loop
gait's absent gains, are left out), at least half lie within `HALF_RTOL` (1 %) or all lie
within `ALL_RTOL` (5 %). The first catches a copy with a minority of its values changed by
any amount — one amplitude times 1.025 (which `VALUE_RTOL` misses when that amplitude is
among the largest), a sign flipped, two values swapped; the second a copy with every
value nudged by up to 5 %. Honest seeds lie apart: of the 895 pairs of shipped gaits
trained alike, same configuration or not, the closest have half their values 3.1 % apart
(CEM version-1 seeds 0 and 5; the next 6.0 %) and none has all its values within 25.7 %
(CEM seeds 2 and 4); the 96 policy pairs lie 53 % and 200 % apart.

What no rule on values catches: a copy with more than half its values moved by over 1 %
and one of its largest by over 5 % (six of a gait's eleven amplitudes times 1.011, its
largest of them times 1.06), or every value by over 5 %; a gait permuted or mirrored as
a whole (another gait by value, though one that walks at all is unlikely); a network's
hidden units permuted consistently across its layers (the same policy, other values:
caught only if its trials come out equal); and a copy trained a little further from
where it stood. The thresholds only make such copies move further; only re-training a run
from its config and seed shows where a gait came from.

The tolerances are choices, below what separates two honest seeds: a test checks that
the shipped runs of one trained version lie at least 1000 times the trial tolerance,
5 times `VALUE_RTOL`, 3 times `HALF_RTOL` and 5 times `ALL_RTOL` apart (`closest_pairs`).

Nothing here executes code: JSON and CSV are parsed, NumPy arrays are read by
`exported.load_npy` and `load_npz` (headers checked before anything is allocated, no
pickles), Python is parsed with `ast`, pickles are hashed.
"""

from __future__ import annotations

import ast
import dataclasses
import functools
import hashlib
import os
import zipfile

import numpy as np

import cpg_suite
from cpg_suite import cpg, darwin, feedback, residual
from cpg_suite.protocol import files as run_files
from cpg_suite.runfiles import exported

# A gait run's in-sample best (its best training trial's gait, the round that found it and
# what it walked there): what the board's in-sample column shows, and verify tries again.
IN_SAMPLE = "best_params.json"

# m: two trial tables whose outcomes are equal and whose distances all lie this close are
# one run's (a choice: the closest two shipped tables with equal outcomes differ by 4.1 m;
# a float printed with fewer digits differs by < 1e-15 m; a forger nudging every trial by
# more than this moves the card by as much, and meets `verify --sample`).
TRIAL_TOLERANCE_M = 1e-3
# Relative to an array's largest magnitude (or its artifact's median array's): two gaits
# or policies each of whose arrays differ by at most this share are one (a choice: the closest two
# shipped runs of one trained version differ by 11.5 % of their amplitudes' largest, CEM
# seeds 0 and 4, so honest seeds lie 5.7 times above; a gait nudged by less, each nudge
# scored again as a seed, is the same gait).
VALUE_RTOL = 2e-2
VALUE_ATOL = 1e-12
# Per value, relative to the larger magnitude of its pair (`coordinate_differences`): two
# artifacts at least half of whose values lie this close are one (a choice: the closest
# two shipped gaits trained alike have half their values 3.11 % apart, CEM version-1 seeds
# 0 and 5 — 3.1 times above; the next pair 6.0 %, CEM seeds 0 and 4 of both versions 6.4 %;
# two shipped policies 53 %). Catches a copy with fewer than half its values changed, by
# any amount.
HALF_RTOL = 1e-2
# Per value, as `HALF_RTOL`: two artifacts all of whose values lie this close are one (a
# choice: every two shipped gaits trained alike have a value 25.7 % or more apart, CEM
# seeds 2 and 4 — 5.1 times above; policies 200 %). Catches a copy with every value
# nudged by up to 5 %.
ALL_RTOL = 5e-2


@dataclasses.dataclass(frozen=True)
class Fingerprint:
    """What a run is, as values (`fingerprint`).

    Attributes:
      outcomes: Per trial: tier, seed, failed, failure step, cause.
      distances: Per trial: the distance walked, m.
      kind: The gait or policy's file name (what kind of artifact).
      structure: The names, shapes and types its values sit under.
      values: Its numeric values, one array per name (None: not numeric).
      digest: A digest of what is not numeric (code's syntax tree, pickles' bytes).
      in_sample: A gait run's in-sample gait (`best_params.json`) as values, or None.
      responses: An exported policy's action space and head, and its network's outputs on
        the DARwIn-OP's own observations (`policy_responses`), or None.
    """

    outcomes: tuple
    distances: np.ndarray
    kind: str
    structure: tuple
    values: tuple | None
    digest: str | None
    in_sample: tuple | None = None
    responses: tuple | None = None  # a policy's (`policy_responses`): (its kind, outputs)


# The most a policy's code (`policy_code.py`) may hold: its syntax tree is built to compare
# it with other runs', and a 4 MB file of one-line statements cost 2.6 GB (an outside
# attack of 2026-11-29). A choice: 256 KiB, far above a policy's few dozen lines.
MAX_CODE_CHARS = 2**18


def _sha256(*parts: bytes) -> str:
    digest = hashlib.sha256()
    for part in parts:
        digest.update(len(part).to_bytes(8, "little"))
        digest.update(part)
    return digest.hexdigest()


def _arrays(named: dict) -> tuple[tuple, tuple]:
    """Numeric arrays as values; others (an action space's name) as part of the structure."""
    names = sorted(named)
    arrays = [np.asarray(named[n]) for n in names]
    numeric = [a.dtype.kind in "biuf" for a in arrays]
    structure = tuple(  # a number's kind, not its width: float32 and float64 are values alike
        (n, a.shape, a.dtype.kind if is_number else a.dtype.str, None if is_number else a.tolist())
        for n, a, is_number in zip(names, arrays, numeric)
    )
    values = tuple(a.astype(np.float64).ravel() for a, ok in zip(arrays, numeric) if ok)
    return structure, values


def _load_policy(path: str) -> exported.NumpyPolicy:
    """A policy exported to NumPy, each of its arrays unpacking to at most a run file's
    size (`_require_bounded_zip`), read as the scorer reads it."""
    _require_bounded_zip(path)
    return exported.NumpyPolicy.load(path)


def _policy_arrays(policy: exported.NumpyPolicy) -> tuple[tuple, tuple]:
    """A policy's structure and values (`_arrays`) as the scorer reads it: what it does not
    read (an extra array, a default spelled out) is no part of the policy."""
    return _arrays({**policy.arrays(), "action_space": policy.action_space})


def artifact_values(run_dir: str, files: tuple[str, ...]) -> tuple[tuple, tuple | None, str | None]:
    """A run's gait or policy as values: `(structure, values, digest)` (see `Fingerprint`).

    Args:
      run_dir: The run folder.
      files: Its gait or policy files (`admission.artifact_files`).

    Raises:
      OSError, ValueError, KeyError: On a file that cannot be read as its kind.
      SyntaxError: On a policy file that is not Python.
    """
    path = os.path.join(run_dir, files[0])
    name = files[0]
    if name.endswith(".json"):
        return (*_arrays({"params": feedback.load_params(path)}), None)
    if name.endswith(".npz"):
        return (*_policy_arrays(_load_policy(path)), None)
    if name.endswith(".npy"):
        return (*_arrays({"actions": exported.load_npy(path)}), None)  # header checked first
    if name.endswith(".py"):
        source = run_files.read_text(path)  # a regular file of bounded size
        if len(source) > MAX_CODE_CHARS:
            raise ValueError(
                f"{name} holds {len(source)} characters, over the {MAX_CODE_CHARS} a policy's "
                "code may hold"
            )
        try:
            tree = ast.dump(ast.parse(source), annotate_fields=False)
        except (RecursionError, MemoryError):
            raise ValueError(f"{name} is nested too deeply to parse") from None
        return ("python",), None, _sha256(tree.encode())
    parts = []
    for file_name in files:  # an SB3 model (zip) and its normalizer (pickle)
        file_path = os.path.join(run_dir, file_name)
        if zipfile.is_zipfile(file_path):
            _require_bounded_zip(file_path)
            with zipfile.ZipFile(file_path) as z:
                for member in sorted(z.namelist()):
                    parts += [member.encode(), z.read(member)]
        else:
            with open(file_path, "rb") as f:
                parts.append(f.read())
    return ("bytes",), None, _sha256(*parts)


def _require_bounded_zip(path: str) -> None:
    """Checks that a zip (an `.npz`, an SB3 model) unpacks to at most `files.MAX_BYTES` in
    all, as its members declare: no member is read before this holds (each `.npy` member
    is then held to its declared size, `exported.read_npy`).

    Args:
      path: The zip file.

    Raises:
      ValueError: If it would unpack to more, or is not a zip file.
      OSError: If it cannot be read.
    """
    try:
        with zipfile.ZipFile(path) as z:
            total = sum(info.file_size for info in z.infolist())
    except zipfile.BadZipFile as e:
        raise ValueError(f"{os.path.basename(path)} is not a zip archive ({e})") from None
    if total > run_files.MAX_BYTES:
        raise ValueError(
            f"{os.path.basename(path)} unpacks to {total} bytes, over the {run_files.MAX_BYTES}"
            " a run file may hold"
        )


def fingerprint(run_dir: str, files: tuple[str, ...], trials: list[dict]) -> Fingerprint:
    """A run's fingerprint: its trial outcomes and its gait or policy as values.

    Args:
      run_dir: The run folder.
      files: Its gait or policy files (`admission.artifact_files`).
      trials: Its card's trial table (`admission.read_trials`).
    """
    outcomes = tuple((t["tier"], t["seed"], t["fell"], t["fall_step"], t["cause"]) for t in trials)
    distances = np.array([t["distance_m"] for t in trials], dtype=np.float64)
    responses = None
    if files[0].endswith(".npz"):  # read once: its arrays as values, and what it does
        policy = _load_policy(os.path.join(run_dir, files[0]))
        (structure, values), digest = _policy_arrays(policy), None
        responses = policy_responses(policy)
    else:
        structure, values, digest = artifact_values(run_dir, files)
    in_sample = None  # a gait run's (`admission.has_in_sample`)
    if files == ("selected_params.json",) and os.path.isfile(os.path.join(run_dir, IN_SAMPLE)):
        in_sample = artifact_values(run_dir, (IN_SAMPLE,))[1]
    return Fingerprint(
        outcomes, distances, files[0], structure, values, digest, in_sample, responses
    )


# How many of the DARwIn-OP's own observations a policy's responses are taken on: every
# `_RESPONSE_EVERY`-th control step of the hand-tuned gait from `darwin_walk`'s seed-0
# start (a choice; what a policy does there, whatever its arrays look like).
RESPONSE_OBSERVATIONS = 64
_RESPONSE_EVERY = 4


@functools.lru_cache(maxsize=1)
def _response_observations() -> dict:
    """The observations `policy_responses` reads, stacked per key (made once)."""
    env = cpg_suite.load("darwin_walk", task_kwargs={"random": 0})
    steps = RESPONSE_OBSERVATIONS * _RESPONSE_EVERY
    targets = cpg.trajectories(cpg.amplitudes_from("hand_tuned"), steps, env.control_timestep())[0]
    actions = env.physics.targets_to_action(targets)
    env.reset()
    seen = []
    for t, action in enumerate(actions):
        observation = env.step(action).observation
        if t % _RESPONSE_EVERY == 0:
            seen.append(observation)
    return {k: np.stack([np.asarray(o[k], np.float64) for o in seen]) for k in seen[0]}


def policy_responses(policy: exported.NumpyPolicy) -> tuple | None:
    """What a policy exported to NumPy does, whatever its arrays look like: its network's
    outputs before the head (`NumpyPolicy.outputs`) on `RESPONSE_OBSERVATIONS` of the
    robot's own observations (a fresh CPG's phase features for the `cpg` action space),
    with its action space and head. Two policies whose responses lie within `VALUE_RTOL`
    (or a near-copy) are one, however their hidden units are ordered, scaled or nudged
    (helper-51 admitted a copy of a PPO policy as a new seed: its hidden units permuted and
    its last layer nudged by 1e-7, so that no array matched by position). None for a
    policy whose network does not take these observations.

    Args:
      policy: The policy.
    """
    observations = _response_observations()
    rows = None
    if policy.action_space == "cpg":
        rows = residual.ModulatedCPG(RESPONSE_OBSERVATIONS, **policy.scales)
    features = residual.batch_features(observations, darwin.OBSERVATION_KEYS, rows)
    try:
        with np.errstate(all="ignore"):
            outputs = policy.outputs(features)
    except (ValueError, IndexError, TypeError, ArithmeticError):
        return None  # admission refuses such a policy before comparing it
    return (policy.action_space, policy.head), outputs.ravel()


def same_trials(a: Fingerprint, b: Fingerprint) -> bool:
    """Whether two runs' trial outcomes are equal (distances within `TRIAL_TOLERANCE_M`)."""
    return a.outcomes == b.outcomes and bool(
        np.all(np.abs(a.distances - b.distances) <= TRIAL_TOLERANCE_M)
    )


def same_artifact(a: Fingerprint, b: Fingerprint) -> bool:
    """Whether two runs' gaits or policies are equal as values (within `VALUE_RTOL`, or a
    near-copy), an open-loop gait and an action table by the gait's own table
    (`across_kinds`)."""
    if a.kind != b.kind and across_kinds(a, b):
        return True
    if _same_responses(a, b):
        return True
    if (a.kind, a.structure, a.digest) != (b.kind, b.structure, b.digest):
        return False
    if a.values is None:
        return True
    return value_distance(a.values, b.values) <= VALUE_RTOL or near_copy(a.values, b.values)


def _same_responses(a: Fingerprint, b: Fingerprint) -> bool:
    """Whether two policies do the same (`policy_responses`: of one action space and head,
    their outputs within `VALUE_RTOL` or a near-copy)."""
    if a.responses is None or b.responses is None or a.responses[0] != b.responses[0]:
        return False
    ours, theirs = a.responses[1], b.responses[1]
    if ours.shape != theirs.shape:
        return False
    pair = (ours,), (theirs,)
    return value_distance(*pair) <= VALUE_RTOL or near_copy(*pair)


# How far a table may be shifted in time against a gait's and still be compared, control
# steps: one stride of the CPG (68.75 steps, `cpg.CPGConfig`'s ω), so a table started at any
# phase of the gait is compared with the gait at that phase.
MAX_LAG = 69


def across_kinds(a: Fingerprint, b: Fingerprint) -> bool:
    """Whether one run's action table is the other's open-loop gait as values: the table's
    rows against the gait's own table (`exported.ActionTable.from_gait`, the actions its
    scorer takes), started at any step of its first stride (`MAX_LAG`), the rows they
    share within `VALUE_RTOL` or a near-copy. A gait with gains (the feedback CPG's) has no
    table; nor has a policy."""
    gait = next((f for f in (a, b) if f.kind.endswith(".json") and f.values is not None), None)
    table = next((f for f in (a, b) if f.kind.endswith(".npy") and f.values is not None), None)
    if gait is None or table is None:
        return False
    params = gait.values[0]
    if params.shape != (feedback.N_PARAMS,) or np.any(params[cpg.N_AMPLITUDES :] != 0.0):
        return False
    shape = table.structure[0][1]
    actions = _gait_table(params[: cpg.N_AMPLITUDES].tobytes(), shape[0] if shape else 0)
    if not len(actions) or len(shape) != 2 or shape[1] != actions.shape[1]:
        return False
    rows = table.values[0].reshape(shape)
    n = len(rows)
    for lag in range(-MAX_LAG, MAX_LAG + 1):  # the table's row t is the gait's row t + lag
        ours = rows[:n] if lag >= 0 else rows[-lag:]
        theirs = actions[lag : lag + n] if lag >= 0 else actions[: n + lag]
        pair = (ours.ravel(),), (theirs.ravel(),)
        if value_distance(*pair) <= VALUE_RTOL or near_copy(*pair):
            return True
    return False


@functools.lru_cache(maxsize=128)
def _gait_table(amplitudes: bytes, steps: int) -> np.ndarray:
    """An open-loop gait's action table, `steps + MAX_LAG` rows (its amplitudes' bytes: a
    cache key); empty for a non-finite gait or no steps."""
    gait = np.frombuffer(amplitudes, dtype=np.float64)
    if not np.all(np.isfinite(gait)) or steps <= 0:
        return np.zeros((0, 12))
    return exported.ActionTable.from_gait(gait, steps + MAX_LAG).actions


def coordinate_differences(xs: tuple, ys: tuple) -> np.ndarray:
    """Each value's difference from its counterpart relative to the larger magnitude of the
    two (0 where equal, 2 for a sign flipped; inf for a NaN or infinity against another
    value), over the values not both within `VALUE_RTOL` of zero as `value_distance`
    scales them (an open-loop gait's absent gains, a policy's all-zero bias: left out).

    Args:
      xs, ys: Float arrays, pairwise of one shape.
    """
    magnitudes = [(np.abs(x), np.abs(y)) for x, y in zip(xs, ys)]
    scales = [
        max((float(np.max(np.where(np.isfinite(m), m, 0.0))) for m in pair if m.size), default=0.0)
        for pair in magnitudes
    ]
    floor = float(np.median(scales)) if scales else 0.0
    kept = []
    for x, y, (mx, my), scale in zip(xs, ys, magnitudes, scales):
        negligible = VALUE_RTOL * max(scale, floor)
        counted = ~((mx <= negligible) & (my <= negligible))  # NaN: counted
        same = (x == y) | (np.isnan(x) & np.isnan(y))
        with np.errstate(invalid="ignore", divide="ignore"):
            share = np.abs(x - y) / np.maximum(mx, my)
        share = np.where(same, 0.0, np.where(np.isfinite(share), share, np.inf))
        kept.append(share[counted])
    return np.concatenate(kept) if kept else np.zeros(0)


def near_copy(xs: tuple, ys: tuple) -> bool:
    """Whether at least half of two artifacts' values lie within `HALF_RTOL` of their
    counterparts, or all within `ALL_RTOL` (`coordinate_differences`; no value left: both
    are zero, which `value_distance` tells)."""
    shares = coordinate_differences(xs, ys)
    if not shares.size:
        return False
    return bool(np.mean(shares <= HALF_RTOL) >= 0.5 or np.max(shares) <= ALL_RTOL)


def value_distance(xs: tuple, ys: tuple) -> float:
    """How far apart two artifacts' values are (arrays of one structure): the largest over
    their arrays of the array's largest difference over its largest finite magnitude, or
    over the median of the artifact's arrays' magnitudes if that is larger (an all-zero
    bias is measured against the arrays beside it, not against itself). Equal elements (NaN
    or infinities included) differ by 0; a NaN or infinity against another value by inf.

    Args:
      xs, ys: Float arrays, pairwise of one shape.
    """
    scales, differences = [], []
    for x, y in zip(xs, ys):
        same = (x == y) | (np.isnan(x) & np.isnan(y))
        finite = np.isfinite(x) & np.isfinite(y)
        if np.any(~same & ~finite):
            return float("inf")
        magnitude = np.abs(np.where(finite, x, 0.0)), np.abs(np.where(finite, y, 0.0))
        scales.append(max((float(np.max(m)) for m in magnitude if m.size), default=0.0))
        differences.append(float(np.max(np.where(same, 0.0, np.abs(x - y)), initial=0.0)))
    floor = float(np.median(scales)) if scales else 0.0
    return (
        max(
            (0.0 if d <= VALUE_ATOL else d / max(scale, floor, VALUE_ATOL))
            for d, scale in zip(differences, scales)
        )
        if scales
        else 0.0
    )


def copy_of(later: Fingerprint, earlier: Fingerprint) -> str | None:
    """What makes `later` a copy of `earlier` ("trial outcomes", "gait or policy"), or None."""
    if same_trials(later, earlier):
        return "trial outcomes"
    if same_artifact(later, earlier):
        return "gait or policy"
    if later.in_sample is not None and earlier.in_sample is not None:
        near = value_distance(later.in_sample, earlier.in_sample) <= VALUE_RTOL
        if near or near_copy(later.in_sample, earlier.in_sample):
            return "in-sample gait"
    return None


def started(run_dir: str) -> str:
    """When a run says it started (its config's `environment.started_utc`; "" if it does
    not say): the older of two copies is the original (ties: path order)."""
    try:
        config = run_files.read_json(os.path.join(run_dir, "config.json"))
        value = config["environment"]["started_utc"]
    except (OSError, ValueError, KeyError, TypeError):
        return "~"  # after every date: a run that does not say comes last
    return value if isinstance(value, str) else "~"


def closest_pairs(prints: dict[str, Fingerprint]) -> tuple[float, float, float, float]:
    """The smallest trial-table and gait-or-policy distances between two runs of `prints`
    (max absolute distance difference over trials with equal outcomes, m; between two
    artifacts of one structure, `value_distance` and the median and largest of
    `coordinate_differences`): how far the tolerances lie from honest runs.

    Returns:
      `(trials_m, values_rel, half_rel, all_rel)`, to hold against `TRIAL_TOLERANCE_M`,
      `VALUE_RTOL`, `HALF_RTOL` and `ALL_RTOL`; inf where no two runs are comparable.
    """
    items = list(prints.values())
    trials_m = values_rel = half_rel = all_rel = np.inf
    for i, a in enumerate(items):
        for b in items[i + 1 :]:
            if a.outcomes == b.outcomes:
                trials_m = min(trials_m, float(np.max(np.abs(a.distances - b.distances))))
            if a.values is not None and (a.kind, a.structure) == (b.kind, b.structure):
                values_rel = min(values_rel, value_distance(a.values, b.values))
                shares = coordinate_differences(a.values, b.values)
                if shares.size:
                    # the share at or under which half the values lie (`near_copy`'s test)
                    half_rel = min(half_rel, float(np.sort(shares)[(shares.size - 1) // 2]))
                    all_rel = min(all_rel, float(np.max(shares)))
    return trials_m, values_rel, half_rel, all_rel
