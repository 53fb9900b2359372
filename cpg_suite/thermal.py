"""The MX-28 servos' motors as heat sources: a two-node (winding, housing) thermal model.

Each servo's winding takes its copper loss P (`electrical.copper_loss`) and passes heat to
the motor's housing through R_wh; the housing passes it to the air through R_ha. With the
heat capacities C_w = τ_w / R_wh and C_h = τ_m / R_ha (the catalogue's time constants over
the resistance each node loses heat through), the temperatures above the ambient obey

    C_w · dΔT_w/dt = P − (ΔT_w − ΔT_h) / R_wh
    C_h · dΔT_h/dt = (ΔT_w − ΔT_h) / R_wh − ΔT_h / R_ha

and the copper's resistance, so the loss at a given current, grows with the winding's
temperature: P = P₂₅ · (1 + α_Cu · (T_w − 25 °C)). The current is the one the servo's
torque sets (`electrical.motor_current`), as while it walks; a servo held at its voltage
limit (stalled, or saturated) would instead draw less current as it warms, which this
does not model. `temperatures` steps the equations exactly for a loss held over each
physics step (the matrix exponential of the linear part).

**Sources (docs/darwin_op_model.md#heat).** No source found gives the thermal constants of
the MX-28's own motor (ROBOTIS: a coreless maxon; a secondary source: maxon RE-max 17,
214897). The two motor families either side of it give them (`RE_MAX_21`, `RE_MAX_13`):
which one is a choice, and so is the copper's coefficient; results/thermal shows both
motors, and the minutes to the limit without the coefficient too.

Nothing here is part of the task: the episode's end does not depend on it
(docs/decisions.md#heat says why).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.linalg

AMBIENT = 25.0  # °C: the air around the motors when a trial starts (a choice)
SHUTDOWN_TEMPERATURE = 80.0  # °C: the MX-28's default temperature limit (e-Manual, register 11)
# Copper's resistance temperature coefficient near room temperature, 1/K (the International
# Annealed Copper Standard's 0.00393 at 20 °C; maxon's catalogues use 0.0039). The datasheet
# resistance (`electrical.RESISTANCE`) is taken as the one at `AMBIENT`.
COPPER_COEFFICIENT = 0.0039


@dataclasses.dataclass(frozen=True)
class MotorThermal:
    """A motor's thermal data as maxon's catalogue gives it.

    Attributes:
      name: What the data is of, and where it comes from.
      r_winding_housing: Thermal resistance winding-housing R_wh, K/W.
      r_housing_ambient: Thermal resistance housing-ambient R_ha, K/W.
      tau_winding: Thermal time constant of the winding τ_w, s.
      tau_motor: Thermal time constant of the motor τ_m, s.
      max_winding: The winding's maximum permissible temperature, °C.
    """

    name: str
    r_winding_housing: float
    r_housing_ambient: float
    tau_winding: float
    tau_motor: float
    max_winding: float

    @property
    def capacities(self) -> tuple[float, float]:
        """(C_w, C_h), J/K: each node's time constant over its resistance."""
        return (
            self.tau_winding / self.r_winding_housing,
            self.tau_motor / self.r_housing_ambient,
        )

    def rates(self) -> np.ndarray:
        """The 2×2 matrix A of d[ΔT_w, ΔT_h]/dt = A·[ΔT_w, ΔT_h] + [P / C_w, 0], 1/s."""
        c_w, c_h = self.capacities
        g_wh, g_ha = 1.0 / self.r_winding_housing, 1.0 / self.r_housing_ambient
        return np.array([[-g_wh / c_w, g_wh / c_w], [g_wh / c_h, -(g_wh + g_ha) / c_h]])


# maxon RE-max 21, Ø21 mm, graphite brushes, 6 W (250000-250008), catalogue of May 2015,
# p. 181: one size above the RE-max 17. The page is kept by the Rhoban RoboCup team
# (github.com/RhobanProject/Dynaban, docs/re-max-21_probably_the_one_in_the_mx64.pdf),
# who take it for the MX-64's motor.
RE_MAX_21 = MotorThermal(
    "maxon RE-max 21, 6 W (catalogue, May 2015)", 8.0, 28.0, 8.75, 501.0, 125.0
)
# maxon RE-max 13, 2.5 W, 24 V (203950): one size below, as Meka's robot configuration
# transcribes maxon's data (github.com/CentralLabFacilities/m3meka,
# python/scripts/m3qa/config_hand_h2r4.py); a secondary source.
RE_MAX_13 = MotorThermal(
    "maxon RE-max 13, 2.5 W (Meka's transcription)", 10.0, 37.0, 6.93, 444.0, 85.0
)
MOTORS = {"re_max_21": RE_MAX_21, "re_max_13": RE_MAX_13}


def temperatures(
    loss: np.ndarray,
    timestep: float,
    motor: MotorThermal,
    coefficient: float = COPPER_COEFFICIENT,
) -> tuple[np.ndarray, np.ndarray]:
    """Each servo's winding and housing temperature after each physics step, from 25 °C.

    The loss of step k, P₂₅,k · (1 + α · ΔT_w at the step's start), is held over the step,
    and the linear model is stepped exactly: x_{k+1} = Φ·x_k + Γ·P_k, Φ = exp(A·h),
    Γ = A⁻¹(Φ − I)·[1/C_w, 0].

    Args:
      loss: (steps, servos) copper loss at 25 °C (`electrical.copper_loss`), W.
      timestep: The physics step h, s.
      motor: The motor's thermal data.
      coefficient: Copper's temperature coefficient α, 1/K (0: a fixed resistance).

    Returns:
      (winding, housing): (steps, servos) temperatures, °C.

    Raises:
      ValueError: If `loss` is not 2-D, `timestep` not positive or a loss negative.
    """
    loss = np.asarray(loss, dtype=np.float64)
    if loss.ndim != 2:
        raise ValueError(f"loss must be (steps, servos), got shape {loss.shape}")
    if not timestep > 0:
        raise ValueError(f"timestep must be > 0 s, got {timestep!r}")
    if not np.all(loss >= 0):  # NaN fails too
        raise ValueError("a copper loss is negative or not a number")
    rates = motor.rates()
    phi = scipy.linalg.expm(rates * timestep)
    gamma = np.linalg.solve(rates, phi - np.eye(2)) @ np.array([1.0 / motor.capacities[0], 0.0])
    rise = np.zeros((2, loss.shape[1]))  # ΔT_w, ΔT_h of every servo
    out = np.empty((len(loss), 2, loss.shape[1]))
    for k, p in enumerate(loss):
        heat = p * (1.0 + coefficient * rise[0])
        rise = phi @ rise + np.outer(gamma, heat)
        out[k] = rise
    return AMBIENT + out[:, 0], AMBIENT + out[:, 1]


def steady_rise(loss: float, motor: MotorThermal, coefficient: float = COPPER_COEFFICIENT) -> float:
    """The winding's final rise above the ambient under a constant loss.

    ΔT = P₂₅(1 + αΔT)(R_wh + R_ha), so ΔT = P₂₅·R / (1 − α·P₂₅·R).

    Args:
      loss: The copper loss at 25 °C, P₂₅, W.
      motor: The motor's thermal data.
      coefficient: Copper's temperature coefficient α, 1/K.

    Returns:
      The rise, K; inf where the loss runs away (α·P₂₅·R ≥ 1: the copper's loss grows
      faster with its temperature than the motor sheds heat).
    """
    resistance = motor.r_winding_housing + motor.r_housing_ambient
    gain = coefficient * loss * resistance
    return loss * resistance / (1.0 - gain) if gain < 1.0 else float("inf")
