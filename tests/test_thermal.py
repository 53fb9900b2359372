"""The servos' two-node thermal model (`cpg_suite.thermal`): known answers, an independent
integration, and the claims docs/darwin_op_model.md#heat makes with it."""

import numpy as np
import pytest

from cpg_suite import electrical, thermal

DT = 0.002  # s: the model's physics step
TRIAL = 8000  # physics steps: a 16 s trial


def _euler(loss: np.ndarray, dt: float, motor: thermal.MotorThermal, coefficient: float):
    """The model's equations integrated by explicit Euler steps of `dt` (a reference):
    the winding's and the housing's temperatures after each step."""
    c_w, c_h = motor.capacities
    rise_w, rise_h, out = 0.0, 0.0, []
    for p in loss:
        flow = (rise_w - rise_h) / motor.r_winding_housing
        heat = p * (1.0 + coefficient * rise_w)
        rise_w, rise_h = (
            rise_w + dt * (heat - flow) / c_w,
            rise_h + dt * (flow - rise_h / motor.r_housing_ambient) / c_h,
        )
        out.append((rise_w, rise_h))
    return thermal.AMBIENT + np.array(out)


@pytest.mark.parametrize("motor", list(thermal.MOTORS.values()), ids=list(thermal.MOTORS))
def test_the_exact_steps_agree_with_fine_euler_integration(motor):
    """60 s of a loss changing every 20 ms, against Euler steps 100 times finer (whose own
    error is a few 1e-4 K here): both nodes within 2e-3 K."""
    rng = np.random.default_rng(0)
    loss = np.repeat(rng.uniform(0.0, 6.0, 3000), 10)
    winding, housing = thermal.temperatures(loss[:, None], DT, motor)
    fine = _euler(np.repeat(loss, 100), DT / 100, motor, thermal.COPPER_COEFFICIENT)[99::100]
    np.testing.assert_allclose(winding[:, 0], fine[:, 0], atol=2e-3)
    np.testing.assert_allclose(housing[:, 0], fine[:, 1], atol=2e-3)
    assert housing[-1, 0] - thermal.AMBIENT > 1.0  # the housing has warmed: it was tested


@pytest.mark.parametrize("motor", list(thermal.MOTORS.values()), ids=list(thermal.MOTORS))
def test_a_constant_loss_settles_at_its_steady_rise(motor):
    """Six hours at 1 W: the winding at P·(R_wh + R_ha)/(1 − α·P·R), the housing P·R_ha·(…)."""
    winding, housing = thermal.temperatures(np.ones((21600, 1)), 1.0, motor)  # 1 s steps
    rise = thermal.steady_rise(1.0, motor)
    assert winding[-1, 0] - thermal.AMBIENT == pytest.approx(rise, rel=1e-6)
    heat = rise / (motor.r_winding_housing + motor.r_housing_ambient)  # W at that temperature
    assert housing[-1, 0] - thermal.AMBIENT == pytest.approx(heat * motor.r_housing_ambient)


def test_without_the_copper_coefficient_the_heat_stored_is_the_energy_less_what_left():
    """α = 0, a pulse of loss and then none: C_w·ΔT_w + C_h·ΔT_h = ∫P − ∫ΔT_h / R_ha."""
    motor = thermal.RE_MAX_21
    loss = np.zeros((TRIAL, 1))
    loss[:1000] = 10.0  # 2 s at 10 W: 20 J
    winding, housing = thermal.temperatures(loss, DT, motor, coefficient=0.0)
    c_w, c_h = motor.capacities
    stored = c_w * (winding[-1, 0] - 25.0) + c_h * (housing[-1, 0] - 25.0)
    # Heat left to the air: the housing's rise integrated (step-average by the trapezoid rule).
    rise_h = np.concatenate([[0.0], housing[:, 0] - 25.0])
    left = np.sum((rise_h[1:] + rise_h[:-1]) / 2) * DT / motor.r_housing_ambient
    assert stored + left == pytest.approx(20.0, rel=1e-4)


@pytest.mark.parametrize(
    "motor, seconds",
    [(thermal.RE_MAX_21, 4.590), (thermal.RE_MAX_13, 2.744)],
    ids=list(thermal.MOTORS),
)
def test_a_stalled_servo_heats_its_winding_past_the_limit_in_seconds_not_its_housing(
    motor, seconds
):
    """docs/darwin_op_model.md#heat: at the stall copper loss (16.8 W) held, α = 0 (a
    stalled servo is voltage-limited: its current, and its loss, fall as the copper warms,
    which the coefficient, meant for a current set by the torque, does not model), the
    winding passes 80 °C after 4.59 s (RE-max 21) or 2.74 s (RE-max 13), while the housing
    stays under 40 °C for the whole 16 s trial."""
    loss = np.full((TRIAL, 1), electrical.STALL_COPPER_LOSS)
    winding, housing = thermal.temperatures(loss, DT, motor, coefficient=0.0)
    crossing = (np.argmax(winding[:, 0] >= thermal.SHUTDOWN_TEMPERATURE) + 1) * DT
    assert crossing == pytest.approx(seconds, abs=DT / 2)
    assert housing[-1, 0] < 40.0


def test_the_loss_is_held_within_a_step_and_the_first_step_is_heated():
    winding, housing = thermal.temperatures(np.array([[1.0, 0.0]]), DT, thermal.RE_MAX_21)
    assert winding[0, 0] > thermal.AMBIENT and winding[0, 1] == thermal.AMBIENT
    assert housing[0, 0] > thermal.AMBIENT  # the exact step passes some heat on at once


@pytest.mark.parametrize(
    "loss, timestep, match",
    [
        (np.ones(5), DT, "steps, servos"),
        (np.ones((5, 2)), 0.0, "timestep"),
        (-np.ones((5, 2)), DT, "negative"),
        (np.full((5, 2), np.nan), DT, "not a number"),
    ],
)
def test_bad_input_is_refused(loss, timestep, match):
    with pytest.raises(ValueError, match=match):
        thermal.temperatures(loss, timestep, thermal.RE_MAX_21)


def test_a_loss_that_runs_away_has_no_steady_temperature():
    motor = thermal.RE_MAX_21
    runaway = 1.0 / (
        thermal.COPPER_COEFFICIENT * (motor.r_winding_housing + motor.r_housing_ambient)
    )
    assert thermal.steady_rise(runaway * 1.01, motor) == float("inf")
    assert np.isfinite(thermal.steady_rise(runaway * 0.99, motor))
