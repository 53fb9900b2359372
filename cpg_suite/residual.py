"""A CPG action space: a policy modulates the study's CPG every control step.

Beyond the study (docs/decisions.md#ppo). A policy's action (12,) in [−1, 1] is read as

* 11 amplitude corrections: Aₚ = A⁰ₚ + `amplitude_scale` · aₚ degrees, around the
  hand-tuned amplitudes A⁰ (`cpg.PRESETS["hand_tuned"]`, thesis Table 6.1);
* 1 phase-rate correction: φ̇ = ω (1 + `rate_scale` · a₁₁) for both legs (the right leg
  stays half a cycle behind).

The corrections act on the pattern generators' rates (Eq. 5.2), so the joint targets stay
continuous and are low-pass filtered by the relaxation term, as the open-loop CPG's are.
Action 0 is the hand-tuned open-loop gait: `ModulatedCPG` with zero corrections gives the
targets of `cpg.CPG(hand_tuned)` bit for bit (`tests/test_ppo.py`).

`ModulatedCPG` is a `cpg.CPG` with one row per sub-environment, each with its own time and
phase, so a row restarts (`reset_rows`) when its episode ends. `CPGActions` is the action
space as a Gymnasium vector wrapper over `DarwinVectorEnv` (same-step autoreset), in
`cpg_suite.vector` with the other Gymnasium classes (scoring a policy of this action
space needs `ModulatedCPG` only, not Gymnasium): it maps the policy's actions to
joint-target actions and adds the left leg's phase (cos φ_L, sin φ_L) to the observations
as `"cpg_phase"`.
"""

from __future__ import annotations

import numpy as np

from cpg_suite import cli, cpg, darwin, portable

AMPLITUDE_SCALE = 10.0  # degrees of amplitude correction per unit action
# The largest amplitude_scale, degrees (a choice: a correction of 90° exceeds every leg
# joint's range, so larger scales only saturate the joint targets).
MAX_AMPLITUDE_SCALE = 90.0
RATE_SCALE = 0.5  # phase rate ω (1 + RATE_SCALE · a), a in [−1, 1]: 0.5 ω .. 1.5 ω
N_ACTIONS = cpg.N_AMPLITUDES + 1
# A walking policy's action spaces: the task's 12 joint targets, or this module's CPG modulation.
ACTION_SPACES = ("joints", "cpg")
PHASE_KEY = "cpg_phase"


class ModulatedCPG(cpg.CPG):
    """K independent CPG rows whose amplitudes and phase rate are set before each step.

    Each row has its own time (`self.time`, shape (K,)) and a phase deviation δ (K,) that
    the phase-rate correction accumulates: φ_L = φ_L⁰(t) + δ, δ̇ = (rate − 1) ω. With every
    correction 0, δ stays exactly 0, and each row's arithmetic is that of `cpg.CPG`.
    """

    def __init__(
        self,
        rows: int,
        amplitudes="hand_tuned",
        config: cpg.CPGConfig | None = None,
        *,
        amplitude_scale: float = AMPLITUDE_SCALE,
        rate_scale: float = RATE_SCALE,
    ):
        """Args:
          rows: K ≥ 1 rows (sub-environments).
          amplitudes: The nominal 11 amplitudes, degrees (or a preset name): action 0.
          config: CPG constants (default `cpg.CPGConfig()`).
          amplitude_scale: Degrees of amplitude correction per unit action.
          rate_scale: Relative phase-rate correction per unit action (< 1 keeps φ̇ > 0).

        Raises:
          ValueError: On K < 1, bad amplitudes, a negative scale or rate_scale ≥ 1.
        """
        if int(rows) < 1:
            raise ValueError(f"rows must be ≥ 1, got {rows!r}")
        cli.require_number("amplitude_scale", amplitude_scale, 0, MAX_AMPLITUDE_SCALE)
        cli.require_number("rate_scale", rate_scale, 0, 1, high_open=True)
        self.nominal = cpg.amplitudes_from(amplitudes)
        self.amplitude_scale, self.rate_scale = float(amplitude_scale), float(rate_scale)
        super().__init__(np.tile(self.nominal, (int(rows), 1)), config)

    @property
    def rows(self) -> int:
        return len(self.amplitudes)

    def reset(self) -> None:
        """Every row: t = 0, z = O, δ = 0, the nominal amplitudes and rate."""
        super().reset()
        k = len(self.amplitudes)
        self.time = np.zeros(k)
        self.delta = np.zeros(k)
        self.rate = np.ones(k)
        self.amplitudes = np.tile(self.nominal, (k, 1))

    def reset_rows(self, mask) -> None:
        """Restarts the rows where `mask` ((K,) bool) is set, as `reset` does."""
        m = np.asarray(mask, dtype=bool)
        if m.shape != (self.rows,):
            raise ValueError(f"mask must have shape ({self.rows},), got {m.shape}")
        self.time[m] = 0.0
        self.delta[m] = 0.0
        self.rate[m] = 1.0
        self.z[m] = self._offsets
        self.roll_input[m] = 0.0
        self.amplitudes[m] = self.nominal

    def modulate(self, actions) -> None:
        """Sets each row's amplitudes and phase rate from (K, 12) actions (clipped to [−1, 1])."""
        a = np.clip(np.asarray(actions, dtype=np.float64), -1.0, 1.0)
        if a.shape != (self.rows, N_ACTIONS):
            raise ValueError(f"actions have shape {a.shape}, expected ({self.rows}, {N_ACTIONS})")
        self.amplitudes = self.nominal + self.amplitude_scale * a[:, : cpg.N_AMPLITUDES]
        self.rate = 1.0 + self.rate_scale * a[:, cpg.N_AMPLITUDES]

    def left_phase(self) -> np.ndarray:
        """φ_L of every row now, rad (unwrapped), (K,)."""
        return self._left(self.time, self.delta)

    def _left(self, t, delta) -> np.ndarray:
        """φ_L = φ_L⁰(t) + δ at time(s) t with phase deviation(s) δ."""
        return self.config.initial_phase + self.config.omega * t + delta

    def phase_features(self) -> np.ndarray:
        """(K, 2): cos φ_L, sin φ_L."""
        phi = self.left_phase()
        sin_phi, cos_phi = portable.sincos(phi)
        return np.stack([cos_phi, sin_phi], axis=-1)

    # Hooks of `cpg.CPG`, with a time per row.
    def _omega(self) -> np.ndarray:
        return self.config.omega * self.rate  # (K,): φ̇ of each row

    def _ramp(self, t) -> np.ndarray:
        if self.config.ramp_time > 0:
            return cpg.smoothstep(t / self.config.ramp_time)
        return np.ones(self.rows)

    def step(self, dt: float) -> np.ndarray:
        """`cpg.CPG.step` with the substeps' rates computed in one batch: a row's phases
        do not depend on its pattern generators, so its times and phase deviations at every
        substep are accumulated first (t ← t + h, δ ← δ + (rate − 1) ω h, in the stepper's
        order), then the rates of all substeps at once, then z substep by substep. The
        same bits as the stepper (`tests/test_ppo.py`), with one call of the elementary
        functions per control step instead of one per substep.

        Returns:
          (K, 12) joint targets, radians.
        """
        cfg = self.config
        n, h, decay, gain = self._substeps(dt)
        steps = np.full((n, self.rows), h)
        times = np.cumsum(np.concatenate([self.time[None], steps]), axis=0)  # (n + 1, K)
        increment = np.broadcast_to((self.rate - 1.0) * cfg.omega * h, steps.shape)
        deltas = np.cumsum(np.concatenate([self.delta[None], increment]), axis=0)
        mid = times[:n] + 0.5 * h  # the substeps' mid-times, as `_rates` is called with
        left = self._left(mid, deltas[:n])
        values = cpg.primitive_values(np.stack([left, left - np.pi], axis=-1), self._omega(), cfg)
        rates = self._rates_from(values, mid)  # (n, K, 12)
        for k in range(n):
            self.z = self._offsets + (self.z - self._offsets) * decay + gain * rates[k]
        self.time, self.delta = times[n], deltas[n]
        return cpg.to_joint_angles(self.z)


def batch_features(observations: dict, keys: tuple[str, ...], rows: ModulatedCPG | None):
    """(n, D) flat features of n trials' observations ((n, ...) arrays) in `keys` order,
    with the CPG rows' phase features last for the `cpg` action space (`rows` not None):
    each row the flat observation a policy of one trial reads.

    Args:
      observations: The trials' observations, stacked per key.
      keys: The observation keys, in the policy's order.
      rows: The trials' CPG rows, or None.
    """
    parts = [np.asarray(observations[k], dtype=np.float64) for k in keys]
    parts = [p.reshape(len(p), -1) for p in parts]
    if rows is not None:
        parts.append(rows.phase_features())
    return np.concatenate(parts, axis=1)


def joint_actions(cpg_actions, modulated: ModulatedCPG, physics: darwin.Physics, dt: float):
    """One control step of the CPG action space outside a vector env (one row per call).

    Args:
      cpg_actions: (K, 12) policy actions.
      modulated: The CPG rows (advanced by `dt`).
      physics: Any DARwIn-OP physics (its joint ranges).
      dt: Control step, s.

    Returns:
      (K, 12) normalized joint-target actions.
    """
    modulated.modulate(cpg_actions)
    return physics.targets_to_action(modulated.step(dt))
