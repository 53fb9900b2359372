"""The CPG action space of `cpg_suite.residual` in JAX: one `ModulatedCPG` row, pure functions.

A policy's action (12,) in [−1, 1] sets the 11 amplitudes Aₚ = A⁰ₚ + `AMPLITUDE_SCALE` · aₚ
degrees around the hand-tuned amplitudes and the phase rate φ̇ = ω (1 + `RATE_SCALE` · a₁₁);
the CPG then advances one control step in substeps of `CPGConfig.substep` (Eq. 5.2), as
`residual.ModulatedCPG.step` does. The arithmetic is that of `cpg.primitive_basis` and
`cpg.CPG.step`, written with `jax.numpy` so that it runs under `jit` and `vmap`
(`tests/test_mjx.py` checks both against the NumPy reference). Action 0 is the open-loop
gait of the amplitudes.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from cpg_suite import cpg, residual


class CPGState(NamedTuple):
    """One CPG row: time t (s), anatomical variables z (12,) (degrees), phase deviation δ."""

    time: jax.Array
    z: jax.Array
    delta: jax.Array


def initial_state(config: cpg.CPGConfig) -> CPGState:
    """t = 0, z = O (the standing posture), δ = 0: `ModulatedCPG.reset`.

    Args:
      config: The CPG constants.

    Returns:
      The row's state.
    """
    return CPGState(
        time=jnp.zeros(()), z=jnp.asarray(config.anatomical_offsets()), delta=jnp.zeros(())
    )


def primitive_basis(phases: jax.Array, omega: jax.Array, config: cpg.CPGConfig) -> jax.Array:
    """`cpg.primitive_basis` in JAX: (11, 12) joint rates per unit amplitude.

    Args:
      phases: (2,) phases (left, right), rad.
      omega: φ̇, rad/s.
      config: The CPG constants (flexion form, σ).

    Returns:
      (11, 12) rates of the anatomical variables, degrees/s per degree of amplitude.
    """
    out = jnp.zeros((cpg.N_AMPLITUDES, 12), dtype=phases.dtype)
    s2 = config.sigma**2
    for leg in (0, 1):
        phi = phases[leg]
        base = 6 * leg
        sin_phi, cos_phi = jnp.sin(phi), jnp.cos(phi)
        wrapped = jnp.pi - jnp.mod(jnp.pi - phi, 2 * jnp.pi)  # cpg.wrap_phase
        gauss = jnp.exp(-wrapped * wrapped / (2.0 * s2))
        if config.flexion_form == "gaussian_derivative":
            bump = -omega * wrapped / s2 * gauss
        else:
            bump = omega / s2 * gauss
        entries = (
            (0, cpg.HROLL, omega * sin_phi),
            (1, cpg.AROLL, omega * sin_phi),
            (2, cpg.HPITCH, bump),
            (3, cpg.KNEE, -bump),
            (4, cpg.APITCH, -bump),
            (5, cpg.APITCH, bump),
            (6, cpg.KNEE, -omega * sin_phi),
            (7, cpg.APITCH, -omega * sin_phi),
            (8, cpg.HYAW, omega * cos_phi),
            (9, cpg.HPITCH, omega * cos_phi),
            (10, cpg.APITCH, omega * cos_phi),
        )
        for p, joint, value in entries:
            out = out.at[p, base + joint].set(value)
    return out


def step(
    state: CPGState,
    action: jax.Array,
    nominal: np.ndarray,
    control_timestep: float,
    config: cpg.CPGConfig,
) -> tuple[CPGState, jax.Array]:
    """Modulates the row by a policy action and advances it one control step.

    Args:
      state: The row's state.
      action: (12,) policy action (clipped to [−1, 1]).
      nominal: (11,) amplitudes of action 0, degrees.
      control_timestep: The control step, s.
      config: The CPG constants.

    Returns:
      `(state, targets)`: the advanced row and the (12,) leg joint targets, rad.
    """
    a = jnp.clip(action, -1.0, 1.0)
    amplitudes = jnp.asarray(nominal) + residual.AMPLITUDE_SCALE * a[: cpg.N_AMPLITUDES]
    rate = 1.0 + residual.RATE_SCALE * a[cpg.N_AMPLITUDES]
    n = max(1, int(round(control_timestep / config.substep)))
    h = control_timestep / n
    decay = math.exp(-config.beta * h)
    gain = (1.0 - decay) / config.beta if config.beta > 0 else h
    offsets = jnp.asarray(config.anatomical_offsets())

    def substep(row: CPGState, _) -> tuple[CPGState, None]:
        t = row.time + 0.5 * h
        left = config.initial_phase + config.omega * t + row.delta
        basis = primitive_basis(jnp.stack([left, left - jnp.pi]), config.omega * rate, config)
        ramp = _smoothstep(t / config.ramp_time) if config.ramp_time > 0 else 1.0
        combined = jnp.zeros(12, dtype=row.z.dtype)
        for p in range(cpg.N_AMPLITUDES):  # the order of `ModulatedCPG._rates`
            combined = combined + amplitudes[p] * basis[p]
        z = offsets + (row.z - offsets) * decay + gain * (ramp * combined)
        delta = row.delta + (rate - 1.0) * config.omega * h
        return CPGState(time=row.time + h, z=z, delta=delta), None

    state, _ = jax.lax.scan(substep, state, None, length=n)
    return state, jnp.deg2rad(state.z) * cpg.JOINT_SIGNS


def _smoothstep(x: jax.Array) -> jax.Array:
    """`cpg.smoothstep` in JAX."""
    x = jnp.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def phase_features(state: CPGState, config: cpg.CPGConfig) -> jax.Array:
    """(2,) cos φ_L, sin φ_L: the `cpg_phase` observation of `vector.CPGActions`."""
    phi = config.initial_phase + config.omega * state.time + state.delta
    return jnp.stack([jnp.cos(phi), jnp.sin(phi)])
