"""The central pattern generator of the study (thesis Eq. 5.1-5.18) and its DMP term (5.19-5.22).

One phase oscillator per leg, φ̇ᵢ = ω, the right leg half a cycle behind the left (5.1).
Each of the 12 leg joints has a motion-pattern generator

    żᵢⱼ = r(t) Σₙ fⁿᵢⱼ(φᵢ) − β (zᵢⱼ − Oᵢⱼ) [+ DMP term on hip and ankle roll]      (5.2)

whose primitives f are driven by the leg's phase (5.3-5.12), and z is the joint target.

Decisions where the study is silent (docs/decisions.md#cpg):

* **Amplitudes are degrees** of joint excursion, in the order of thesis Sec. 6.2
  (`AMPLITUDE_NAMES`). A sine primitive `A φ̇ sin(φ + c)` integrates to an oscillation of
  amplitude A (attenuated by ω/√(ω²+β²) through the relaxation term).
* **Flexion primitives** (5.6-5.8) are read as the time derivative of a Gaussian bump of
  height A centred on the swing, `−s A φ̇ (φ̄/σ²) exp(−φ̄²/(2σ²))`, φ̄ = φ wrapped to
  (−π, π], σ = π/6, s = the printed sign (`flexion_form="gaussian_derivative"`). The
  printed form without the φ̄ factor is kept as `flexion_form="printed"`.
* **Anatomical variables.** z is an anatomical angle per leg: hip yaw + = internal
  rotation; hip roll + = adduction; hip pitch + = flexion (thigh forward); knee + = extension
  (so flexion is negative, as in Eq. 5.7); ankle pitch + = dorsiflexion, so that
  hip + knee + ankle pitch = 0 keeps the sole parallel to the torso (the hand-tuned flexion
  amplitudes cancel: 20 − 40 + 40 − 20 = 0); ankle roll + = the rotation that cancels an
  equal hip roll, so equal hip and ankle roll keep the sole flat while the pelvis sways.
  `JOINT_SIGNS` maps them onto the DARwIn-OP joints (docs/darwin_op_model.md#frames-and-joints):
  mirrored legs, one sign per joint. With these signs the printed compass (5.11-5.12) and
  flexKnee (5.9-5.10) primitives with equal positive amplitudes tilt the sole (the ankle
  adds to the hip or knee instead of cancelling it); the study gives no convention that
  makes all printed primitives sole-parallel, and no single per-joint sign can.
* **Phase**: φ_L(0) = `initial_phase`, φ_R = φ_L − π (anti-phase); the swing of a leg is
  centred on φ̄ = 0.
* **Start-up ramp**: the primitives are multiplied by a smoothstep r(t) rising from 0 to
  1 over `ramp_time` seconds, so the gait starts from standing without a jolt (allowed by
  docs/decisions.md#cpg; the study does not say how its trials started).
* **Integration**: exact exponential integration of the relaxation term over substeps of
  `substep` seconds with the primitives taken at each substep's midpoint.
* ω, β, the offsets O (standing posture) and the ramp are `CPGConfig` fields; the defaults
  are the result of `python -m baselines.experiments.calibrate_cpg` (see that module).
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np

from cpg_suite import cli, portable

# The 11 CEM parameters, thesis Sec. 6.2 order (units: degrees).
AMPLITUDE_NAMES = (
    "balancing_hip",  # A_balancingHip, Eq. 5.3
    "balancing_ankle",  # A_balancingAnk, Eq. 5.4
    "hip",  # A_Hip, Eq. 5.6
    "knee",  # A_Knee, Eq. 5.7
    "ankle_hip",  # A_AnkHip, Eq. 5.8
    "ankle_knee",  # A_AnkKnee, Eq. 5.8
    "flex_knee",  # A_flexKnee, Eq. 5.9
    "flex_ankle",  # A_flexAnk, Eq. 5.10
    "pelvis_rotation",  # A_pelvisRot, Eq. 5.5
    "compass_hip",  # A_compassHip, Eq. 5.11
    "compass_ankle",  # A_compassAnk, Eq. 5.12
)
N_AMPLITUDES = len(AMPLITUDE_NAMES)

# Thesis Table 6.1 "hand-tuned values" and the two CEM results (Tables 6.1 and 6.2).
PRESETS = {
    "hand_tuned": (11.0, 11.0, 20.0, 40.0, 20.0, 40.0, 2.0, 2.0, 0.0, 0.0, 0.0),
    "table6_1": (
        2.979604,
        4.339130,
        29.370636,
        35.984702,
        15.705181,
        23.451423,
        2.894878,
        5.565523,
        23.346823,
        6.059359,
        1.057788,
    ),
    "table6_2": (
        3.886218,
        12.091291,
        28.796737,
        33.628418,
        29.245331,
        38.766492,
        7.986102,
        0.801668,
        5.145981,
        25.679888,
        18.227246,
    ),
}

# Leg joints in action order: left leg, then right leg, each
# (hip yaw, hip roll, hip pitch, knee, ankle pitch, ankle roll).
LEG_JOINTS = (
    "PelvYL",
    "PelvL",
    "LegUpperL",
    "LegLowerL",
    "AnkleL",
    "FootL",
    "PelvYR",
    "PelvR",
    "LegUpperR",
    "LegLowerR",
    "AnkleR",
    "FootR",
)
JOINTS_PER_LEG = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")
HYAW, HROLL, HPITCH, KNEE, APITCH, AROLL = range(6)

# Anatomical variable -> DARwIn-OP joint angle (docs/darwin_op_model.md#frames-and-joints).
JOINT_SIGNS = np.array([+1, +1, +1, +1, -1, +1, -1, -1, -1, -1, +1, -1], dtype=np.float64)

FLEXION_FORMS = ("gaussian_derivative", "printed")


@dataclasses.dataclass(frozen=True)
class CPGConfig:
    """The CPG constants the study does not give (docs/decisions.md#cpg).

    Attributes:
      stride_period: Period of one full cycle (a left and a right step), s; ω = 2π / period.
      beta: Relaxation rate β toward the offsets, 1/s.
      crouch: Standing knee flexion, degrees; hip and ankle pitch offsets are half of it
        each so that the torso stays upright and the soles flat.
      hip_roll_offset: Hip and ankle roll offset (adduction), degrees.
      sigma: Width σ of the flexion bump, rad of phase (thesis: π/6).
      flexion_form: `"gaussian_derivative"` (R1, default) or `"printed"`.
      ramp_time: Duration of the smoothstep start-up ramp of the primitives, s (0 = none).
      initial_phase: φ_L at t = 0, rad; φ_R = φ_L − π.
      substep: Integration substep, s.
    """

    stride_period: float = 1.1
    beta: float = 8.0
    crouch: float = 23.0
    hip_roll_offset: float = 0.0
    sigma: float = math.pi / 6
    flexion_form: str = "gaussian_derivative"
    ramp_time: float = 1.1
    initial_phase: float = math.pi
    substep: float = 0.001

    def __post_init__(self):
        if self.flexion_form not in FLEXION_FORMS:
            raise ValueError(
                f"flexion_form must be one of {FLEXION_FORMS}, got {self.flexion_form!r}"
            )
        # The upper ends are choices: beyond them the CPG means nothing on this robot.
        for name, low, high in (
            ("stride_period", 0.0, 100.0),  # s
            ("sigma", 0.0, 2 * math.pi),  # rad of phase
            ("substep", 0.0, 1.0),  # s
        ):
            cli.require_number(name, getattr(self, name), low, high, low_open=True, prefix="")
        for name, low, high in (
            ("beta", 0.0, 1e4),  # 1/s
            ("ramp_time", 0.0, 1e3),  # s
            ("crouch", 0.0, 90.0),  # degrees of knee flexion
            ("hip_roll_offset", -45.0, 45.0),  # degrees
            ("initial_phase", -2 * math.pi, 2 * math.pi),  # rad: a cycle either way
        ):
            cli.require_number(name, getattr(self, name), low, high, prefix="")

    @property
    def omega(self) -> float:
        """ω, rad/s."""
        return 2.0 * math.pi / self.stride_period

    def anatomical_offsets(self) -> np.ndarray:
        """O per leg joint (12,), anatomical degrees."""
        leg = np.zeros(6)
        leg[HROLL] = leg[AROLL] = self.hip_roll_offset
        leg[HPITCH] = self.crouch / 2
        leg[KNEE] = -self.crouch
        leg[APITCH] = self.crouch / 2
        return np.concatenate([leg, leg])

    def offsets(self) -> np.ndarray:
        """O as DARwIn-OP joint angles (12,), radians: the standing posture."""
        return to_joint_angles(self.anatomical_offsets())


def to_joint_angles(anatomical_degrees: np.ndarray) -> np.ndarray:
    """Anatomical CPG variables (degrees, last axis 12) -> joint angles (radians)."""
    return np.deg2rad(anatomical_degrees) * JOINT_SIGNS


def to_anatomical(joint_angles: np.ndarray) -> np.ndarray:
    """Joint angles (radians, last axis 12) -> anatomical CPG variables (degrees)."""
    return np.rad2deg(np.asarray(joint_angles) * JOINT_SIGNS)


def wrap_phase(phi):
    """Wraps a phase to (−π, π]."""
    return np.pi - np.mod(np.pi - phi, 2 * np.pi)


def smoothstep(x):
    """0 for x ≤ 0, 1 for x ≥ 1, 3x² − 2x³ between."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def amplitudes_from(params) -> np.ndarray:
    """The 11 amplitudes from a preset name, a mapping of names, or a sequence.

    Raises:
      ValueError: On an unknown preset or name, a missing name, a wrong length or a
        non-finite value.
    """
    if isinstance(params, str):
        if params not in PRESETS:
            raise ValueError(f"unknown amplitude preset {params!r}; valid: {', '.join(PRESETS)}")
        params = PRESETS[params]
    if isinstance(params, dict):
        unknown = set(params) - set(AMPLITUDE_NAMES)
        missing = [n for n in AMPLITUDE_NAMES if n not in params]
        if unknown or missing:
            raise ValueError(
                f"amplitudes need exactly the names {', '.join(AMPLITUDE_NAMES)}; "
                f"unknown {sorted(unknown)}, missing {missing}"
            )
        params = [params[n] for n in AMPLITUDE_NAMES]
    try:
        arr = np.asarray(params, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise ValueError(f"amplitudes must be numbers, got {params!r}") from e
    if arr.shape != (N_AMPLITUDES,):
        raise ValueError(f"expected {N_AMPLITUDES} amplitudes, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"amplitudes must be finite, got {arr}")
    return arr


# What a parameter file may hold (`amplitudes_problem`, `feedback.params_problem`). The
# bounds are generous: they refuse what means nothing physically (and what would
# overflow), not what walks badly.
#
# Amplitudes, degrees (`AMPLITUDE_NAMES`; the oscillation or flexion bump of a joint
# target, cpg.py's docstring). A choice: 360°, a full turn. Every leg joint's range is under
# 183° wide (the widest, PelvY, −0.69..2.50 rad in cpg_suite/xml/darwin.xml; the targets are
# clipped to it, `inheritrange`), so an amplitude of 90° already spans it (the reasoning of
# `residual.MAX_AMPLITUDE_SCALE`) and one past a full turn only saturates the joints. It is
# over twice the largest any shipped run uses (167.9°, hip, results/protocol/runs/cmaes/
# darwin_walk/K50_s1_v1_seed0/selected_params.json: the relaxation term attenuates it).
MAX_AMPLITUDE_DEG = 360.0
# Top-level keys a parameter file may hold besides "amplitudes" and "gains": what the
# harness writes with them (`harness.selection`: "source"; `harness.rounds`: "round",
# "distance_m", "fell"). Not parameters: never read as such.
METADATA_KEYS = ("source", "round", "distance_m", "fell")


def number_problem(where: str, value, bound: float, unit: str) -> str | None:
    """Why `value` is no JSON number within ±`bound` (None: it is one)."""
    valid = f"valid: a finite JSON number in [-{bound:g}, {bound:g}] {unit}"
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return f"{where} is {json.dumps(value)[:40]} (a JSON {json_kind(value)}); {valid}"
    if (isinstance(value, float) and not math.isfinite(value)) or abs(value) > bound:
        digits = len(str(abs(value))) if isinstance(value, int) else 0
        shown = f"an integer of {digits} digits" if digits > 20 else repr(value)
        return f"{where} is {shown}; {valid}"
    return None


def json_kind(value) -> str:
    """What kind of JSON value `value` is, as a message names it."""
    if isinstance(value, bool):
        return "boolean"
    if value is None:
        return "null"
    return {str: "string", list: "array", dict: "object"}.get(type(value), "number")


def amplitudes_problem(data) -> str | None:
    """Why parsed JSON is not a valid amplitude file (None: it is one), in one line that
    names the problem and what is valid: {"amplitudes": A, ...} (with `METADATA_KEYS` and
    "gains", which only the feedback CPG reads: `feedback.params_problem` checks them) or
    A alone, where A is an object of all 11 `AMPLITUDE_NAMES` (or an array of 11 in that
    order), each a JSON number (not a boolean or a string), finite, within
    `MAX_AMPLITUDE_DEG`."""
    if isinstance(data, dict) and "amplitudes" in data:
        unknown = sorted(set(data) - {"amplitudes", "gains", *METADATA_KEYS})
        if unknown:
            return (
                f"unknown keys {unknown}; valid: amplitudes, gains and {', '.join(METADATA_KEYS)}"
            )
        amplitudes = data["amplitudes"]
    else:
        amplitudes = data
    names = ", ".join(AMPLITUDE_NAMES)
    if isinstance(amplitudes, dict):
        unknown = sorted(set(amplitudes) - set(AMPLITUDE_NAMES))
        missing = [n for n in AMPLITUDE_NAMES if n not in amplitudes]
        if unknown or missing:
            return (
                f"amplitudes need exactly the names {names}; unknown {unknown}, missing {missing}"
            )
        values = [(f"amplitudes.{n}", amplitudes[n]) for n in AMPLITUDE_NAMES]
    elif isinstance(amplitudes, list) and len(amplitudes) == N_AMPLITUDES:
        values = [(f"amplitudes[{i}]", v) for i, v in enumerate(amplitudes)]
    else:
        return (
            f"amplitudes are a JSON {json_kind(amplitudes)}"
            + (f" of {len(amplitudes)}" if isinstance(amplitudes, list) else "")
            + f"; valid: an object of the {N_AMPLITUDES} names {names} (or an array of "
            f"{N_AMPLITUDES} in that order)"
        )
    for where, value in values:
        problem = number_problem(where, value, MAX_AMPLITUDE_DEG, "degrees")
        if problem:
            return problem
    return None


def load_amplitudes(path: str) -> np.ndarray:
    """Reads a JSON file holding the 11 amplitudes by name (or a list, or {"amplitudes": ...}).

    Raises:
      ValueError: On a file that is not JSON, or not a valid amplitude file
        (`amplitudes_problem`'s line: the open-loop and feedback files are one format).
    """
    with open(path, encoding="utf-8") as f:
        data = json.load(f)
    problem = amplitudes_problem(data)
    if problem:
        raise ValueError(problem)
    if isinstance(data, dict) and "amplitudes" in data:
        data = data["amplitudes"]
    return amplitudes_from(data)


# The nonzero entries of the basis (Eq. 5.3-5.12), per leg: (amplitude, joint, value, sign),
# where the values are ω sin φ, ω cos φ and the flexion bump. sin(φ + π/2) = cos φ and
# sin(φ + π) = −sin φ.
_SIN, _COS, _BUMP = range(3)
_BASIS_ENTRIES = (
    (0, HROLL, _SIN, +1.0),  # Eq. 5.3, 5.4: balancing, hip and ankle roll
    (1, AROLL, _SIN, +1.0),
    (2, HPITCH, _BUMP, +1.0),  # Eq. 5.6-5.8: flexion of hip (+), knee (−),
    (3, KNEE, _BUMP, -1.0),
    (4, APITCH, _BUMP, -1.0),  # ankle (+AnkKnee − AnkHip)
    (5, APITCH, _BUMP, +1.0),
    (6, KNEE, _SIN, -1.0),  # Eq. 5.9, 5.10: flexKnee, flexAnk
    (7, APITCH, _SIN, -1.0),
    (8, HYAW, _COS, +1.0),  # Eq. 5.5: pelvis rotation
    (9, HPITCH, _COS, +1.0),  # Eq. 5.11, 5.12: compass
    (10, APITCH, _COS, +1.0),
)
_ENTRY_LEGS = np.repeat([0, 1], len(_BASIS_ENTRIES))
_ENTRY_AMPLITUDES, _ENTRY_JOINTS, _ENTRY_VALUES, _ENTRY_SIGNS = (
    np.tile(np.array(column), 2) for column in zip(*_BASIS_ENTRIES)
)
_ENTRY_JOINTS = _ENTRY_JOINTS.astype(int) + 6 * _ENTRY_LEGS
_ENTRY_AMPLITUDES, _ENTRY_VALUES = _ENTRY_AMPLITUDES.astype(int), _ENTRY_VALUES.astype(int)


# Σₚ Aₚ basisₚ per joint, the terms in the order p = 0..10 (the zero terms dropped: adding
# them changes no value), padded with a zero term (index 22) to 4 per joint.
_JOINT_TERMS = np.array(
    [
        (list(np.flatnonzero(_ENTRY_JOINTS == joint)) + [2 * len(_BASIS_ENTRIES)] * 4)[:4]
        for joint in range(12)
    ]
)
ROLL_JOINTS = np.array([HROLL, AROLL, 6 + HROLL, 6 + AROLL])  # the DMP term's joints
# The same sums entry by entry (`_combine_by_entry`): each joint's entries, its value's
# column in `primitive_values` flattened per row (leg · 3 + value), and the size of
# `values` from which that is the faster way (NumPy calls on whole blocks of rows, where
# the gather costs per element).
_JOINT_ENTRIES = [[e for e in row if e < 2 * len(_BASIS_ENTRIES)] for row in _JOINT_TERMS.tolist()]
_ENTRY_COLUMNS = (3 * _ENTRY_LEGS + _ENTRY_VALUES).tolist()
_BY_ENTRY_FROM = 2000


def primitive_values(phases: np.ndarray, omega, config: CPGConfig) -> np.ndarray:
    """The values the primitives are made of (Eq. 5.3-5.12): ω sin φ, ω cos φ and the
    flexion bump per leg.

    sin, cos and exp are `cpg_suite.portable`'s, so the values have the same bits on every
    CPU.

    Args:
      phases: Phases of the two legs, shape (..., 2) (left, right), rad.
      omega: φ̇, rad/s: a number, or one per row of `phases` (shape (...)).
      config: The CPG configuration (flexion form, σ).

    Returns:
      Array (..., 2, 3): per leg, ω sin φ, ω cos φ and the bump (degrees/s per degree).
    """
    return _values_and_sin(phases, omega, config)[0]


def _values_and_sin(phases, omega, config: CPGConfig) -> tuple[np.ndarray, np.ndarray]:
    """`primitive_values` and sin φ."""
    phases = np.asarray(phases, dtype=np.float64)
    sin_phi, cos_phi = portable.sincos(phases)
    return values_from(phases, sin_phi, cos_phi, omega, config), sin_phi


def values_from(phases, sin_phi, cos_phi, omega, config: CPGConfig) -> np.ndarray:
    """`primitive_values` from the phases and their sines and cosines (`portable.sincos`).

    Args:
      phases, sin_phi, cos_phi: (..., 2) float64 arrays: φ, sin φ, cos φ.
      omega: φ̇, rad/s: a number, or one per row of `phases` (shape (...)).
      config: The CPG configuration (flexion form, σ).

    Returns:
      Array (..., 2, 3), as `primitive_values`.
    """
    omega = np.asarray(omega, dtype=np.float64)[..., None]  # against the legs' axis
    s2 = config.sigma**2
    wrapped = wrap_phase(phases)
    gauss = portable.exp(-wrapped * wrapped / (2.0 * s2))
    if config.flexion_form == "gaussian_derivative":
        bump = -omega * wrapped / s2 * gauss  # d/dt of exp(-φ̄²/2σ²)
    else:
        bump = omega / s2 * gauss  # As printed (no φ̄ factor).
    return np.stack([omega * sin_phi, omega * cos_phi, bump], axis=-1)


def primitive_basis(phases: np.ndarray, omega, config: CPGConfig) -> np.ndarray:
    """∂ż/∂A: the primitives per unit amplitude (Eq. 5.3-5.12).

    Args:
      phases: Phases of the two legs, shape (..., 2) (left, right), rad.
      omega: φ̇, rad/s: a number, or one per row of `phases` (shape (...)).
      config: The CPG configuration (flexion form, σ).

    Returns:
      Array (..., 11, 12): the rate of each joint's anatomical variable (degrees/s) per
      degree of each amplitude.
    """
    values = primitive_values(phases, omega, config)
    out = np.zeros(values.shape[:-2] + (N_AMPLITUDES, 12))
    out[..., _ENTRY_AMPLITUDES, _ENTRY_JOINTS] = _entries(values)
    return out


def _entries(values: np.ndarray) -> np.ndarray:
    """The basis' 22 nonzero entries (`_BASIS_ENTRIES`, both legs) from `primitive_values`."""
    return values[..., _ENTRY_LEGS, _ENTRY_VALUES] * _ENTRY_SIGNS


def combine(amplitudes: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Σₚ Aₚ basisₚ: the primitives' joint rates for each row of amplitudes.

    The sum runs over p in increasing order, as `Σₚ amplitudes[:, p] * primitive_basis(...)[p]`
    would, without the basis' zero terms (a fixed order, not a BLAS product, whose last bit
    depends on the CPU's kernel).

    Args:
      amplitudes: (K, 11) amplitudes, degrees.
      values: `primitive_values`, (2, 3) for all rows or (..., K, 2, 3).

    Returns:
      (..., K, 12) rates of the anatomical variables, degrees/s.
    """
    values = np.asarray(values, dtype=np.float64)
    if values.size >= _BY_ENTRY_FROM:
        return _combine_by_entry(amplitudes, values)
    terms = amplitudes[:, _ENTRY_AMPLITUDES] * _entries(values)  # (..., K, 22)
    zero = np.zeros(terms.shape[:-1] + (1,))
    terms = np.concatenate([terms, zero], axis=-1)[..., _JOINT_TERMS]  # (..., 12, 4)
    return ((terms[..., 0] + terms[..., 1]) + terms[..., 2]) + terms[..., 3]


def _combine_by_entry(amplitudes: np.ndarray, values: np.ndarray) -> np.ndarray:
    """`combine` joint by joint, each term over all rows at once (many rows: the feedback
    CPG's substeps × trials). The same operations on the same numbers, so the same bits:
    Aₚ·(±v) = (±Aₚ)·v exactly (IEEE products round symmetrically), the terms added in the
    same order, and `+ 0.0` where `combine` adds its zero padding (it turns −0 into +0)."""
    columns = np.moveaxis(values.reshape(values.shape[:-2] + (6,)), -1, 0)
    signed = (amplitudes[:, _ENTRY_AMPLITUDES] * _ENTRY_SIGNS).T.copy()  # (22, K)
    joints = []
    for entries in _JOINT_ENTRIES:  # every joint has 1 to 4 entries
        terms = [signed[e] * columns[_ENTRY_COLUMNS[e]] for e in entries]
        total = terms[0]
        for term in terms[1:]:
            total = total + term
        joints.append(total + 0.0 if len(entries) < 4 else total)
    return np.stack(joints, axis=-1)


class CPG:
    """A steppable CPG for one or several amplitude vectors (the reference path).

    `step(dt)` advances time by `dt` and returns the joint targets (radians, DARwIn-OP
    joint signs, action order `LEG_JOINTS`). An optional DMP term (Eq. 5.19-5.22) adds a
    rate to hip and ankle roll of both legs: set it with `set_roll_input` before a step.
    """

    def __init__(self, amplitudes, config: CPGConfig | None = None):
        """Args:
        amplitudes: (11,) or (K, 11) amplitudes in degrees (or a preset name).
        config: CPG constants (default `CPGConfig()`).
        """
        self.config = config or CPGConfig()
        if isinstance(amplitudes, (str, dict)):
            amplitudes = amplitudes_from(amplitudes)
        amps = np.asarray(amplitudes, dtype=np.float64)
        self._single = amps.ndim == 1
        self.amplitudes = np.atleast_2d(amps)
        if self.amplitudes.shape[1] != N_AMPLITUDES or not np.all(np.isfinite(self.amplitudes)):
            raise ValueError(
                f"amplitudes must be finite with {N_AMPLITUDES} columns, got shape {amps.shape}"
            )
        self._offsets = self.config.anatomical_offsets()
        self.reset()

    def reset(self) -> None:
        """t = 0, z = O, no roll input."""
        self.time = 0.0
        self.z = np.tile(self._offsets, (len(self.amplitudes), 1))
        self.roll_input = np.zeros((len(self.amplitudes), 2))

    def phases(self, t: float | None = None) -> np.ndarray:
        """(φ_L, φ_R) at time t (default: now), rad, unwrapped."""
        t = self.time if t is None else t
        left = self.config.initial_phase + self.config.omega * t
        return np.array([left, left - math.pi])

    def set_roll_input(self, rates_deg) -> None:
        """Adds a rate (degrees/s) to hip and ankle roll of (left, right) legs (Eq. 5.21-5.22).

        Args:
          rates_deg: (2,) or (K, 2): the DMP output F per leg, held until changed.
        """
        self.roll_input = np.broadcast_to(
            np.asarray(rates_deg, dtype=np.float64), self.roll_input.shape
        ).copy()

    def _phases_at(self, t: float) -> np.ndarray:
        """The phases the primitives are driven by: (2,) for all vectors (open loop)."""
        return self.phases(t)

    def _omega(self):
        """φ̇ of the primitives: ω (open loop)."""
        return self.config.omega

    def _ramp(self, t):
        """The start-up ramp r(t) (Eq. 5.2) at time t."""
        cfg = self.config
        return smoothstep(t / cfg.ramp_time) if cfg.ramp_time > 0 else 1.0

    def _rates(self, t: float) -> np.ndarray:
        # sin φ is kept for `_advance_phases`, which the same substep calls next (φ unchanged).
        values, self._sin_phi = _values_and_sin(self._phases_at(t), self._omega(), self.config)
        return self._rates_from(values, t)

    def _rates_from(self, values: np.ndarray, t) -> np.ndarray:
        """ż's primitive part (Eq. 5.2) from `primitive_values` at time(s) t: the ramp times
        Σₚ Aₚ basisₚ, plus the DMP term's roll input; (..., K, 12)."""
        rates = np.asarray(self._ramp(t))[..., None] * combine(self.amplitudes, values)
        rates[..., ROLL_JOINTS] += self.roll_input[:, [0, 0, 1, 1]]
        return rates

    def _substeps(self, dt: float) -> tuple[int, float, float, float]:
        """`(n, h, decay, gain)`: a step of `dt` in n substeps of h, and the exact
        exponential integration of the relaxation term over one (z ← O + (z − O)·decay +
        gain·rates)."""
        cfg = self.config
        n = max(1, int(round(dt / cfg.substep)))
        h = dt / n
        decay = math.exp(-cfg.beta * h)
        return n, h, decay, (1.0 - decay) / cfg.beta if cfg.beta > 0 else h

    def step(self, dt: float) -> np.ndarray:
        """Advances by `dt` seconds; returns the joint targets, radians ((12,) or (K, 12))."""
        n, h, decay, gain = self._substeps(dt)
        for _ in range(n):
            rates = self._rates(self.time + 0.5 * h)
            self._advance_phases(self.time + 0.5 * h, h)
            self.z = self._offsets + (self.z - self._offsets) * decay + gain * rates
            self.time += h
        targets = to_joint_angles(self._anatomical_targets())
        return targets[0] if self._single else targets

    def _advance_phases(self, t: float, h: float) -> None:
        """Phase feedback over a substep of `h` s at mid-time `t` (none in open loop)."""

    def _anatomical_targets(self) -> np.ndarray:
        """(K, 12) anatomical targets, degrees: z (open loop)."""
        return self.z


def trajectories(
    amplitudes, n_steps: int, control_timestep: float, config: CPGConfig | None = None
) -> np.ndarray:
    """Open-loop joint targets for a batch of amplitude vectors (the fast path).

    The CPG is linear in its amplitudes: z(t) = O + Σₚ Aₚ Yₚ(t). The unit responses Yₚ are
    computed once with the reference stepper (`CPG`), then combined for every vector.

    Args:
      amplitudes: (K, 11) or (11,) amplitudes, degrees.
      n_steps: Number of control steps.
      control_timestep: Control step, s.
      config: CPG constants.

    Returns:
      (K, n_steps, 12) joint targets in radians (target of step t = z((t + 1) Δt)).
    """
    config = config or CPGConfig()
    amps = np.atleast_2d(np.asarray(amplitudes, dtype=np.float64))
    if amps.shape[1] != N_AMPLITUDES:
        raise ValueError(f"amplitudes need {N_AMPLITUDES} columns, got {amps.shape}")
    unit = _unit_responses(n_steps, control_timestep, config)  # (n_steps, 11, 12)
    # Accumulate in a fixed order, one amplitude at a time: each row's arithmetic is then the
    # same whatever the batch size (a BLAS contraction may block differently per shape), so
    # a vector evaluated alone or in a batch gets bit-identical targets.
    z = np.broadcast_to(config.anatomical_offsets(), (len(amps), n_steps, 12)).copy()
    for p in range(N_AMPLITUDES):
        z += amps[:, p, None, None] * unit[None, :, p, :]
    return to_joint_angles(z)


_UNIT_CACHE: dict = {}


def _unit_responses(n_steps: int, control_timestep: float, config: CPGConfig) -> np.ndarray:
    key = (n_steps, float(control_timestep), config)
    if key not in _UNIT_CACHE:
        cpg = CPG(np.eye(N_AMPLITUDES), config)
        out = np.empty((n_steps, N_AMPLITUDES, 12))
        offsets = config.anatomical_offsets()
        for t in range(n_steps):
            cpg.step(control_timestep)
            out[t] = cpg.z - offsets
        if len(_UNIT_CACHE) > 16:
            _UNIT_CACHE.clear()
        _UNIT_CACHE[key] = out
    return _UNIT_CACHE[key]


# The DMP term (Eq. 5.19-5.20): periodic kernels of Gams et al. (2009).
N_KERNELS = 15


def dmp_kernels(phase, n_kernels: int = N_KERNELS, width: float | None = None) -> np.ndarray:
    """ψₖ(φ) = exp(h (cos(φ − cₖ) − 1)), cₖ = 2πk/N, h = 2.5 N (Eq. 5.20).

    Returns:
      (..., N) kernel activations.
    """
    h = 2.5 * n_kernels if width is None else width
    centres = 2.0 * np.pi * np.arange(n_kernels) / n_kernels
    return portable.exp(h * (portable.cos(np.asarray(phase)[..., None] - centres) - 1.0))


def dmp_output(phase, theta: np.ndarray) -> np.ndarray:
    """F = Σ ψₖ θₖ / Σ ψₖ (Eq. 5.19) for one or more phases."""
    psi = dmp_kernels(phase, len(theta))
    return (psi @ theta) / psi.sum(axis=-1)
