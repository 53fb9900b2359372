"""A closed-loop CPG: the study's CPG with posture reflexes and contact-driven phases.

Beyond the study (its Ch. 7 names sensory feedback as future work;
docs/decisions.md#feedback-cpg). The open-loop CPG (`cpg_suite.cpg`, thesis Eq. 5.1-5.18)
makes the joint targets a function of time. This one reads the torso IMU and the sole
touch sensors every control step:

* **Posture reflexes** (a). The torso's pitch θ_p (forward lean +) and roll θ_r (lean to
  its left +), from the IMU orientation, and their rates from the gyro, offset the
  anatomical joint targets:

      Δ hip pitch = −(g₀ θ_p + g₃ θ̇_p),  Δ knee = +(g₁ θ_p + g₄ θ̇_p),
      Δ ankle pitch = −(g₂ θ_p + g₅ θ̇_p)                              (both legs)
      Δ hip roll  = ∓(g₆ θ_r + g₈ θ̇_r),   Δ ankle roll = ∓(g₇ θ_r + g₉ θ̇_r)   (left −, right +)

  in degrees, gains in degrees per radian (per rad/s for rates). With positive gains a
  forward lean extends the hips and plantarflexes the ankles (which rotates the torso
  backward: measured on the model, `tests/test_feedback.py`), and a lean to the left
  rolls both legs so that the pelvis moves right. This is the form of ROBOTIS' own
  DARwIn-OP walking engine, which adds the gyro to knee and ankle pitch and to hip and
  ankle roll, with the tilt angles added as in ankle/hip posture strategies.
* **Phase feedback from contact** (b). Each leg's phase is the open-loop one plus a
  deviation δ, driven by the load N on its sole (in body weights):

      φᵢ = φᵢ⁰(t) + δᵢ,    δ̇ᵢ = g₁₀ Nᵢ sin φᵢ

  the "Tegotae" rule of Owaki et al. (2013, Biol. Cybern.; Owaki & Ishiguro 2017), a
  continuous relative of the phase resetting of Aoi & Tsuchiya (2005) and Righetti &
  Ijspeert (2008), written for this CPG's convention (swing centred at φ = 0): a loaded
  leg late in its stance (sin φ < 0) is held back, delaying lift-off, and a leg that
  touches down before its swing ends (sin φ > 0) is advanced into stance.

The parameters are one vector of `N_PARAMS` = 11 amplitudes (thesis Sec. 6.2 order) then
the `N_GAINS` gains (`GAIN_NAMES`). With every gain 0 the targets equal the open-loop
`cpg.CPG`'s bit for bit: δ stays exactly 0 and the reflex offsets are exactly 0.
"""

from __future__ import annotations

import json
import math

import numpy as np

from cpg_suite import cpg, portable

GAIN_NAMES = (
    "pitch_hip",  # deg/rad
    "pitch_knee",
    "pitch_ankle",
    "pitch_rate_hip",  # deg/(rad/s)
    "pitch_rate_knee",
    "pitch_rate_ankle",
    "roll_hip",  # deg/rad
    "roll_ankle",
    "roll_rate_hip",  # deg/(rad/s)
    "roll_rate_ankle",
    "phase",  # rad/s per body weight of sole load
)
N_GAINS = len(GAIN_NAMES)
N_PARAMS = cpg.N_AMPLITUDES + N_GAINS

# The nominal model's weight (2.925 kg × 9.81 m/s², docs/darwin_op_model.md), N: the unit
# of sole load of the phase feedback.
BODY_WEIGHT_N = 28.70

# Sensor inputs per trial, the columns of `sensor_inputs`.
INPUT_NAMES = ("pitch", "roll", "pitch_rate", "roll_rate", "load_left", "load_right")

# Corrective direction of each reflex per leg joint (anatomical signs, `cpg.JOINTS_PER_LEG`
# order): pitch on hip pitch −, knee +, ankle pitch −; roll on hip and ankle roll, the left
# leg − and the right +.
_PITCH_JOINTS = ((cpg.HPITCH, -1.0), (cpg.KNEE, +1.0), (cpg.APITCH, -1.0))
_ROLL_JOINTS = (cpg.HROLL, cpg.AROLL)
_ROLL_LEG_SIGNS = (-1.0, +1.0)


def sensor_inputs(orientation, gyro, touch) -> np.ndarray:
    """The feedback's inputs from the task's observations.

    Args:
      orientation: (..., 4) torso quaternions (w, x, y, z) from the IMU.
      gyro: (..., 3) IMU angular velocities in the torso frame, rad/s.
      touch: (..., 2) normal forces on the (left, right) soles, N.

    Returns:
      (..., 6) `INPUT_NAMES`: pitch and roll of the torso's z axis (rad; forward and left
      lean +), their rates (rad/s; from the gyro's y and −x, the small-tilt rates) and the
      sole loads in body weights.
    """
    q = np.asarray(orientation, dtype=np.float64)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    # The torso's z axis in the world frame.
    zx = 2.0 * (x * z + w * y)
    zy = 2.0 * (y * z - w * x)
    zz = 1.0 - 2.0 * (x * x + y * y)
    g = np.asarray(gyro, dtype=np.float64)
    load = np.asarray(touch, dtype=np.float64) / BODY_WEIGHT_N
    pitch, roll = portable.arctan2(np.stack([zx, zy]), zz)  # one call: element-wise alike
    return np.stack([pitch, roll, g[..., 1], -g[..., 0], load[..., 0], load[..., 1]], axis=-1)


def split(params) -> tuple[np.ndarray, np.ndarray]:
    """(K, 11) amplitudes and (K, `N_GAINS`) gains from (K, `N_PARAMS`) or (`N_PARAMS`,).

    Raises:
      ValueError: On another shape or a non-finite value.
    """
    p = np.atleast_2d(np.asarray(params, dtype=np.float64))
    if p.ndim != 2 or p.shape[1] != N_PARAMS or not np.all(np.isfinite(p)):
        raise ValueError(f"params must be finite with {N_PARAMS} columns, got shape {p.shape}")
    return p[:, : cpg.N_AMPLITUDES], p[:, cpg.N_AMPLITUDES :]


def reflex_offsets(gains: np.ndarray, inputs: np.ndarray) -> np.ndarray:
    """(K, 12) anatomical target offsets, degrees, of the posture reflexes (a)."""
    k = len(inputs)
    pitch, roll = inputs[:, 0], inputs[:, 1]
    pitch_rate, roll_rate = inputs[:, 2], inputs[:, 3]
    out = np.zeros((k, 12))
    for j, (joint, sign) in enumerate(_PITCH_JOINTS):
        signal = sign * (gains[:, j] * pitch + gains[:, 3 + j] * pitch_rate)
        out[:, joint] = signal
        out[:, 6 + joint] = signal
    for j, joint in enumerate(_ROLL_JOINTS):
        signal = gains[:, 6 + j] * roll + gains[:, 8 + j] * roll_rate
        for leg, sign in enumerate(_ROLL_LEG_SIGNS):
            out[:, 6 * leg + joint] = sign * signal
    return out


class FeedbackCPG(cpg.CPG):
    """The CPG with feedback, for one or K parameter vectors (the reference stepper).

    `step(dt, inputs)` holds the sensor inputs (`sensor_inputs`) over the step, advances
    the phases and the pattern generators, and returns the joint targets (radians,
    DARwIn-OP joint signs, `cpg.LEG_JOINTS` order).
    """

    def __init__(self, params, config: cpg.CPGConfig | None = None):
        """Args:
          params: (`N_PARAMS`,) or (K, `N_PARAMS`): amplitudes (degrees) then gains.
          config: CPG constants (default `cpg.CPGConfig()`).

        Raises:
          ValueError: On a wrong shape or a non-finite value.
        """
        amplitudes, self.gains = split(params)
        super().__init__(amplitudes, config)
        self._single = np.ndim(params) == 1

    def reset(self) -> None:
        """t = 0, z = O, δ = 0, no sensor input."""
        super().reset()
        self.delta = np.zeros((len(self.amplitudes), 2))
        self.inputs = np.zeros((len(self.amplitudes), len(INPUT_NAMES)))

    def _phases_at(self, t: float) -> np.ndarray:
        return self.phases(t)[None, :] + self.delta  # (K, 2)

    def _advance_phases(self, t: float, h: float) -> None:
        load = self.inputs[:, 4:6]  # sin φ(t): kept by this substep's `_rates`
        self.delta = self.delta + h * self.gains[:, 10, None] * load * self._sin_phi

    def _anatomical_targets(self) -> np.ndarray:
        return self.z + reflex_offsets(self.gains, self.inputs)

    def step(self, dt: float, inputs=None) -> np.ndarray:
        """Advances by `dt` seconds with the sensor inputs held; returns the joint targets.

        Args:
          dt: Seconds.
          inputs: (6,) or (K, 6) `sensor_inputs` (None: keep the last ones).

        Returns:
          (12,) or (K, 12) joint targets, radians.
        """
        if inputs is not None:
            self.inputs = np.broadcast_to(
                np.asarray(inputs, dtype=np.float64), self.inputs.shape
            ).copy()
        n, h, decay, gain = self._substeps(dt)
        mid, time = [], self.time  # each substep's mid-time, accumulated as `cpg.CPG.step` does
        for _ in range(n):
            mid.append(time + 0.5 * h)
            time += h
        # The state changes only once every substep is computed (an error, such as a
        # non-finite phase, leaves it as it was).
        phases, sin_phi, cos_phi, delta = self._phase_path(mid, h)
        values = cpg.values_from(phases, sin_phi, cos_phi, self._omega(), self.config)
        rates = self._rates_from(values, np.array(mid)[:, None])  # (n, K, 12)
        increments = gain * rates
        z, offsets = self.z, self._offsets
        for i in range(n):
            z = offsets + (z - offsets) * decay + increments[i]
        self.time, self.z, self.delta, self._sin_phi = time, z, delta, sin_phi[-1]
        targets = cpg.to_joint_angles(self._anatomical_targets())
        return targets[0] if self._single else targets

    def _phase_path(self, mid: list[float], h: float) -> tuple[np.ndarray, ...]:
        """The phases at the substeps' mid-times and their sines and cosines, (n, K, 2)
        each, and δ after the substeps (advanced as `_advance_phases` does, one substep at
        a time: each substep's δ depends on the last one's sin φ)."""
        start, omega = self.config.initial_phase, self.config.omega
        shape = (len(mid),) + self.delta.shape
        phases, sin_phi, cos_phi = np.empty(shape), np.empty(shape), np.empty(shape)
        rate = h * self.gains[:, 10, None] * self.inputs[:, 4:6]  # `_advance_phases`' factor
        delta = self.delta
        for i, t in enumerate(mid):
            left = start + omega * t  # `phases(t)`
            np.add(np.array([left, left - math.pi]), delta, out=phases[i])
            sin_phi[i], cos_phi[i] = portable.sincos(phases[i])
            delta = delta + rate * sin_phi[i]
        return phases, sin_phi, cos_phi, delta


def start_params(amplitudes) -> np.ndarray:
    """(`N_PARAMS`,) parameters: the open-loop amplitudes with every gain 0 (the same gait)."""
    return np.concatenate([cpg.amplitudes_from(amplitudes), np.zeros(N_GAINS)])


def params_json(vector) -> dict:
    """The parameters by name: {"amplitudes": {...}, "gains": {...}}."""
    amplitudes, gains = split(vector)
    return {
        "amplitudes": dict(zip(cpg.AMPLITUDE_NAMES, map(float, amplitudes[0]))),
        "gains": dict(zip(GAIN_NAMES, map(float, gains[0]))),
    }


# What a parameter file may hold (`params_problem`). The bounds are generous: they refuse
# what means nothing physically (and what would overflow), not what walks badly.
#
MAX_AMPLITUDE_DEG = cpg.MAX_AMPLITUDE_DEG  # cpg.py: the amplitudes' bound, with its source
# Posture-reflex gains (`GAIN_NAMES` but "phase"), degrees per radian of tilt or per rad/s of
# tilt rate. A choice: 360 deg/rad turns a tilt of 0.25 rad (14°) into an offset of 90°, past
# every leg joint's range (above), and a 1-rad tilt into a full turn; larger gains only
# saturate the joints. The largest shipped |gain| is 16.0 (pitch_ankle): 22 times less.
MAX_POSTURE_GAIN = 360.0
# The phase gain, rad/s per body weight of sole load (δ̇ = g₁₀ N sin φ). A choice: at one
# body weight 100 rad/s is 17 times the CPG's own phase rate ω (`cpg.CPGConfig().omega`,
# 5.71 rad/s): the contact, not the oscillator, would set the phase. The largest shipped
# |phase gain| is 3.17: 31 times less.
MAX_PHASE_GAIN = 100.0
METADATA_KEYS = cpg.METADATA_KEYS
_number_problem, _kind = cpg.number_problem, cpg.json_kind


def params_problem(data) -> str | None:
    """Why parsed JSON is not a valid parameter file (None: it is one), in one line that
    names the problem and what is valid.

    Valid: {"amplitudes": A, "gains": G, ...`METADATA_KEYS`} ("gains" optional: 0), or A
    alone, where A is what `cpg.amplitudes_problem` accepts and G an object of some of
    `GAIN_NAMES`; each gain a JSON number (not a boolean or a string), finite, within
    `MAX_POSTURE_GAIN` or `MAX_PHASE_GAIN`. The open-loop amplitude files
    (`cpg.load_amplitudes`) are the same with no gains.
    """
    problem = cpg.amplitudes_problem(data)
    if problem:
        return problem
    gains = data.get("gains", {}) if isinstance(data, dict) and "amplitudes" in data else {}
    if not isinstance(gains, dict):
        return (
            f"gains are a JSON {_kind(gains)}; valid: an object of some of {', '.join(GAIN_NAMES)}"
        )
    unknown = sorted(set(gains) - set(GAIN_NAMES))
    if unknown:
        return f"unknown gains {unknown}; valid: {', '.join(GAIN_NAMES)}"
    for name in GAIN_NAMES:
        if name in gains:
            bound, unit = (
                (MAX_PHASE_GAIN, "rad/s per body weight")
                if name == "phase"
                else (MAX_POSTURE_GAIN, "deg/rad" if "rate" not in name else "deg/(rad/s)")
            )
            problem = _number_problem(f"gains.{name}", gains[name], bound, unit)
            if problem:
                return problem
    return None


def load_params(path: str) -> np.ndarray:
    """(`N_PARAMS`,) parameters from a JSON file written by `params_json` (a file with
    amplitudes only is the open-loop gait: gains 0).

    Raises:
      ValueError: On a file that is not JSON, or not a valid parameter file
        (`params_problem`'s line).
    """
    with open(path, encoding="utf-8") as f:
        data = json.load(f)
    problem = params_problem(data)
    if problem:
        raise ValueError(problem)
    nested = isinstance(data, dict) and "amplitudes" in data
    vector = start_params(data["amplitudes"] if nested else data)
    gains = data.get("gains", {}) if nested else {}
    for i, name in enumerate(GAIN_NAMES):
        vector[cpg.N_AMPLITUDES + i] = gains.get(name, 0.0)
    return vector
