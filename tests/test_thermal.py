"""The servos' two-node thermal model (`cpg_suite.thermal`): known answers, an independent
integration, and the claims docs/darwin_op_model.md#heat makes with it."""

import numpy as np
import pytest

from cpg_suite import electrical, thermal

DT = 0.002  # s: the model's physics step
TRIAL = 8000  # physics steps: a 16 s trial


def _euler(loss: np.ndarray, dt: float, motor: thermal.MotorThermal, coefficient: float):
    """The model's equations integrated by explicit Euler steps of `dt` (a reference)."""
    c_w, c_h = motor.capacities
    rise_w, rise_h, out = 0.0, 0.0, []
    for p in loss:
        flow = (rise_w - rise_h) / motor.r_winding_housing
        heat = p * (1.0 + coefficient * rise_w)
        rise_w, rise_h = (
            rise_w + dt * (heat - flow) / c_w,
            rise_h + dt * (flow - rise_h / motor.r_housing_ambient) / c_h,
        )
        out.append(rise_w)
    return thermal.AMBIENT + np.array(out)


@pytest.mark.parametrize("motor", list(thermal.MOTORS.values()), ids=list(thermal.MOTORS))
def test_the_exact_steps_agree_with_fine_euler_integration(motor):
    rng = np.random.default_rng(0)
    loss = np.repeat(rng.uniform(0.0, 6.0, 400), 10)  # 8 s of a loss changing every 20 ms
    winding, _ = thermal.temperatures(loss[:, None], DT, motor)
    fine = _euler(np.repeat(loss, 100), DT / 100, motor, thermal.COPPER_COEFFICIENT)[99::100]
    np.testing.assert_allclose(winding[:, 0], fine, atol=0.02)  # K; Euler's error is O(dt)


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


@pytest.mark.parametrize("motor", list(thermal.MOTORS.values()), ids=list(thermal.MOTORS))
def test_a_servo_held_stalled_for_a_trial_heats_its_winding_past_the_limit_not_its_housing(motor):
    """docs/darwin_op_model.md#heat: at the stall copper loss (16.8 W) the winding passes
    80 °C within 2-5 s, while the housing stays under 50 °C for the whole 16 s."""
    loss = np.full((TRIAL, 1), electrical.STALL_COPPER_LOSS)
    winding, housing = thermal.temperatures(loss, DT, motor)
    crossing = np.argmax(winding[:, 0] >= thermal.SHUTDOWN_TEMPERATURE) * DT
    assert 2.0 < crossing < 5.0
    assert housing[-1, 0] < 50.0


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
