"""What a parameter file may hold (`feedback.params_problem`): one definition, used by the
loaders (`feedback.load_params`, `cpg.load_amplitudes`), the scorer's CLI and the board's
admission. No simulation here."""

import glob
import json
import math
import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest

from cpg_suite import cpg, feedback
from cpg_suite.protocol import admission, verify

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, "results")
RUNS = os.path.join(RESULTS, "protocol", "runs")
FEEDBACK_RUN = os.path.join(RUNS, "cmaes", "darwin_walk_rough", "K50_s1_feedback_seed1")

AMPLITUDES = dict(zip(cpg.AMPLITUDE_NAMES, cpg.PRESETS["hand_tuned"]))
GOOD = {"amplitudes": AMPLITUDES, "gains": {name: 1.0 for name in feedback.GAIN_NAMES}}

# Values no parameter may take, whichever it is: not a number, or not a finite one, or one
# past every bound.
NOT_NUMBERS = ["7", "", True, False, None, {"value": 1.0}, [1.0], []]
NOT_FINITE = [math.nan, math.inf, -math.inf]
TOO_LARGE = [1e6, -1e6, 1e300, -1e300, 10**400]
BAD_VALUES = NOT_NUMBERS + NOT_FINITE + TOO_LARGE


def _with_gain(name, value):
    return {"amplitudes": AMPLITUDES, "gains": {**GOOD["gains"], name: value}}


def _with_amplitude(name, value):
    return {"amplitudes": {**AMPLITUDES, name: value}, "gains": GOOD["gains"]}


# Whole files that are not parameter files, with the words the refusal names.
BAD_FILES = {
    "unknown gain": ({**GOOD, "gains": {"pitch_hipp": 1.0}}, "unknown gains ['pitch_hipp']"),
    "unknown key": ({**GOOD, "gainz": {"pitch_hip": 1.0}}, "unknown keys ['gainz']"),
    "missing amplitude": (
        {"amplitudes": {k: v for k, v in AMPLITUDES.items() if k != "knee"}},
        "missing ['knee']",
    ),
    "unknown amplitude": ({"amplitudes": {**AMPLITUDES, "neck": 1.0}}, "unknown ['neck']"),
    "gains as a list": ({**GOOD, "gains": [1.0] * feedback.N_GAINS}, "gains are a JSON array"),
    "gains as null": ({**GOOD, "gains": None}, "gains are a JSON null"),
    "amplitudes nested": ({"amplitudes": {"amplitudes": AMPLITUDES}}, "amplitudes need"),
    "amplitudes as null": ({"amplitudes": None}, "amplitudes are a JSON null"),
    "a short list": ([1.0] * 10, "amplitudes are a JSON array of 10"),
    "the full vector as a list": ([0.0] * feedback.N_PARAMS, "amplitudes are a JSON array of 22"),
    "a string": ("hand_tuned", "amplitudes are a JSON string"),
    "a number": (3.0, "amplitudes are a JSON number"),
    "null": (None, "amplitudes are a JSON null"),
    "gains alone": ({"gains": GOOD["gains"]}, "unknown ['gains']"),
}


def _bad_cases():
    for value in BAD_VALUES:
        for name in feedback.GAIN_NAMES:
            yield pytest.param(_with_gain(name, value), f"gains.{name} is", id=f"{name}={value!r}")
        for name in cpg.AMPLITUDE_NAMES:
            yield pytest.param(
                _with_amplitude(name, value), f"amplitudes.{name} is", id=f"{name}={value!r}"
            )
    for label, (data, words) in BAD_FILES.items():
        yield pytest.param(data, words, id=label)


def _one_line(problem):
    assert isinstance(problem, str) and problem and "\n" not in problem


@pytest.mark.parametrize("data, words", list(_bad_cases()))
def test_params_problem_names_the_problem_and_what_is_valid(data, words):
    problem = feedback.params_problem(data)
    _one_line(problem)
    assert words in problem
    assert "valid" in problem or "need" in problem  # and what is valid


def test_just_past_each_bound_is_refused_and_the_bound_itself_is_not():
    for name in feedback.GAIN_NAMES:
        bound = feedback.MAX_PHASE_GAIN if name == "phase" else feedback.MAX_POSTURE_GAIN
        for sign in (1, -1):
            assert feedback.params_problem(_with_gain(name, sign * bound)) is None
            assert feedback.params_problem(_with_gain(name, sign * bound * 1.001))
    for name in cpg.AMPLITUDE_NAMES:
        for sign in (1, -1):
            bound = feedback.MAX_AMPLITUDE_DEG
            assert feedback.params_problem(_with_amplitude(name, sign * bound)) is None
            assert feedback.params_problem(_with_amplitude(name, sign * bound * 1.001))


@pytest.mark.parametrize(
    "data",
    [
        GOOD,
        {"amplitudes": AMPLITUDES},  # open loop: gains 0
        AMPLITUDES,  # by name, alone
        list(cpg.PRESETS["table6_2"]),  # an array in `AMPLITUDE_NAMES` order
        {"amplitudes": AMPLITUDES, "gains": {"phase": -2}},  # some gains; ints; negative
        {**GOOD, "source": "final_mean", "round": 3, "distance_m": 1.5, "fell": False},
    ],
)
def test_valid_files(data, tmp_path):
    assert feedback.params_problem(data) is None
    path = tmp_path / "params.json"
    path.write_text(json.dumps(data))
    vector = feedback.load_params(str(path))
    assert vector.shape == (feedback.N_PARAMS,) and vector.dtype.kind == "f"
    assert list(cpg.load_amplitudes(str(path))) == list(vector[: cpg.N_AMPLITUDES])


def test_load_params_reads_the_gains_by_name(tmp_path):
    path = tmp_path / "params.json"
    path.write_text(json.dumps({"amplitudes": AMPLITUDES, "gains": {"roll_hip": 2.5}}))
    vector = feedback.load_params(str(path))
    gains = dict(zip(feedback.GAIN_NAMES, vector[cpg.N_AMPLITUDES :]))
    assert gains == {n: (2.5 if n == "roll_hip" else 0.0) for n in feedback.GAIN_NAMES}


@pytest.mark.parametrize("data, words", list(_bad_cases()))
def test_the_loaders_raise_the_same_line(data, words, tmp_path):
    path = tmp_path / "params.json"
    path.write_text(json.dumps(data))  # NaN and Infinity as Python writes them
    with pytest.raises(ValueError) as raised:
        feedback.load_params(str(path))
    assert str(raised.value) == feedback.params_problem(data)
    # The open-loop loader reads the amplitudes only: a bad gain is the feedback CPG's
    # (and admission refuses any gains in an open-loop run's gait file).
    problem = cpg.amplitudes_problem(data)
    assert problem is None or problem == feedback.params_problem(data)
    if problem is None:
        assert cpg.load_amplitudes(str(path)).shape == (cpg.N_AMPLITUDES,)
        return
    with pytest.raises(ValueError) as raised:
        cpg.load_amplitudes(str(path))
    assert str(raised.value) == problem


def _shipped_params_files():
    return sorted(glob.glob(os.path.join(RESULTS, "**", "*params*.json"), recursive=True))


def test_every_shipped_params_file_is_valid():
    paths = _shipped_params_files()
    assert len(paths) > 300  # the protocol's and the study's runs
    feedback_files = 0
    for path in paths:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
        assert feedback.params_problem(data) is None, path
        feedback.load_params(path)
        cpg.load_amplitudes(path)
        feedback_files += "gains" in data
    assert feedback_files >= 10


def test_the_bounds_are_generous_multiples_of_what_shipped_runs_use():
    """Every shipped value is within half its bound (the bounds' comments cite these)."""
    largest = {"amplitude": 0.0, "posture": 0.0, "phase": 0.0}
    for path in _shipped_params_files():
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
        amplitudes = data.get("amplitudes", data) if isinstance(data, dict) else data
        values = amplitudes.values() if isinstance(amplitudes, dict) else amplitudes
        largest["amplitude"] = max(largest["amplitude"], *map(abs, values))
        for name, gain in (data.get("gains", {}) if isinstance(data, dict) else {}).items():
            kind = "phase" if name == "phase" else "posture"
            largest[kind] = max(largest[kind], abs(gain))
    assert largest["amplitude"] <= feedback.MAX_AMPLITUDE_DEG / 2
    assert largest["posture"] <= feedback.MAX_POSTURE_GAIN / 20
    assert largest["phase"] <= feedback.MAX_PHASE_GAIN / 30


def test_the_amplitude_bound_is_past_every_leg_joints_range():
    """The comment's source: no leg joint of the model spans as much as the bound (so an
    amplitude past it only saturates the joint), the widest under 183°."""
    model = ET.parse(os.path.join(ROOT, "cpg_suite", "xml", "darwin.xml"))
    legs = ("PelvY", "Pelv", "LegUpper", "LegLower", "Ankle", "Foot")
    spans = []
    for joint in model.iter("joint"):
        name = joint.get("name", "")
        if name[:-1] in legs and name[-1] in "LR":
            low, high = map(float, joint.get("range").split())
            spans.append(math.degrees(high - low))
    assert len(spans) == 12
    assert max(spans) < 183.0 < feedback.MAX_AMPLITUDE_DEG
    assert feedback.MAX_PHASE_GAIN > 10 * cpg.CPGConfig().omega


# The scorer's command line: one line on stderr, exit 2, before any scoring.
CLI_CASES = [
    ("feedback", _with_gain("pitch_hip", math.nan), "gains.pitch_hip is nan"),
    ("feedback", _with_gain("roll_rate_ankle", math.inf), "gains.roll_rate_ankle is inf"),
    ("feedback", _with_gain("phase", -math.inf), "gains.phase is -inf"),
    ("feedback", _with_gain("pitch_knee", 1e6), "gains.pitch_knee is 1000000.0"),
    ("feedback", _with_gain("roll_hip", 1e300), "gains.roll_hip is 1e+300"),
    ("feedback", _with_gain("pitch_ankle", "7"), 'gains.pitch_ankle is "7"'),
    ("feedback", _with_gain("pitch_hip", True), "gains.pitch_hip is true"),
    ("feedback", _with_amplitude("hip", 1e6), "amplitudes.hip is 1000000.0"),
    ("feedback", {**GOOD, "gains": {"nope": 1.0}}, "unknown gains ['nope']"),
    ("open_loop", _with_amplitude("knee", math.nan), "amplitudes.knee is nan"),
    ("open_loop", _with_amplitude("knee", 1e6), "amplitudes.knee is 1000000.0"),
    ("open_loop", _with_amplitude("knee", "40"), 'amplitudes.knee is "40"'),
]


@pytest.mark.parametrize("controller, data, words", CLI_CASES)
def test_score_cli_refuses_a_bad_params_file_in_one_line(controller, data, words, tmp_path):
    path = tmp_path / "params.json"
    path.write_text(json.dumps(data))
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "cpg_suite.protocol.score",
            f"--controller={controller}",
            f"--params={path}",
            "--seeds=1",
            "--steps=1",
            "--tiers=darwin_walk",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: --params"), out.stderr
    assert words in lines[0] and "valid" in lines[0] and "Traceback" not in out.stderr
    assert out.stdout == ""  # no card: nothing was scored


def _feedback_copy(tmp_path, name="forged_seed1"):
    runs = tmp_path / "runs"
    dest = runs / "cmaes" / "darwin_walk_rough" / name
    shutil.copytree(FEEDBACK_RUN, dest)
    return runs, dest


def _edit_gait(run, change):
    path = run / admission.GAIT
    data = json.loads(path.read_text())
    change(data)
    path.write_text(json.dumps(data, indent=2))


def test_the_feedback_run_copied_is_admitted(tmp_path):
    _, run = _feedback_copy(tmp_path)
    assert admission.run_refusal(str(run)) is None


@pytest.mark.parametrize(
    "change, words",
    [
        (lambda d: d["gains"].update(pitch_hip=1e6), "gains.pitch_hip is 1000000.0"),
        (lambda d: d["gains"].update(phase=-1e300), "gains.phase is -1e+300"),
        (lambda d: d["gains"].update(roll_hip="7"), 'gains.roll_hip is "7"'),
        (lambda d: d["gains"].update(roll_ankle=True), "gains.roll_ankle is true"),
        (lambda d: d["gains"].update(pitch_knee=None), "gains.pitch_knee is null"),
        (lambda d: d["gains"].update(extra=0.0), "unknown gains ['extra']"),
        (lambda d: d["amplitudes"].update(knee=720.0), "amplitudes.knee is 720.0"),
        (lambda d: d["amplitudes"].pop("knee"), "missing ['knee']"),
        (lambda d: d.update(gainz={}), "unknown keys ['gainz']"),
    ],
)
def test_admission_refuses_a_bad_gait_under_an_unchanged_card(change, words, tmp_path):
    _, run = _feedback_copy(tmp_path)
    _edit_gait(run, change)
    reason = admission.run_refusal(str(run))
    assert reason is not None and reason.startswith(f"{admission.GAIT}: ") and words in reason
    _one_line(reason)
    assert admission.refusals([str(run)]) == {str(run): reason}


def test_admission_refuses_non_finite_gains(tmp_path):
    """NaN and Infinity are not JSON: the strict reader refuses them first."""
    for i, value in enumerate(NOT_FINITE):
        _, run = _feedback_copy(tmp_path / str(i))
        _edit_gait(run, lambda d, v=value: d["gains"].update(pitch_hip=v))
        reason = admission.run_refusal(str(run))
        assert reason is not None and admission.GAIT in reason
        _one_line(reason)


def test_verify_quick_refuses_a_bad_gait_without_scoring_it(tmp_path):
    runs, run = _feedback_copy(tmp_path)
    _edit_gait(run, lambda d: d["gains"].update(pitch_hip=1e6))
    logged = []
    assert verify.verify(str(runs), quick=True, log=logged.append) == 1
    refused = [line for line in logged if line.startswith("REFUSED")]
    assert len(refused) == 1 and "gains.pitch_hip is 1000000.0" in refused[0]
    assert not any(line.startswith(("ok", "DIFF")) for line in logged)
