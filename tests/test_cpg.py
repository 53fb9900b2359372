"""The CPG (thesis Eq. 5.1-5.18) and the DMP term (Eq. 5.19-5.20)."""

import json
import math

import numpy as np
import pytest

from cpg_suite import cpg

NO_RELAX = cpg.CPGConfig(beta=0.0, ramp_time=0.0)


def _single(name, value, config=NO_RELAX, steps=300, dt=0.011):
    amps = np.zeros(cpg.N_AMPLITUDES)
    amps[cpg.AMPLITUDE_NAMES.index(name)] = value
    pattern = cpg.CPG(amps, config)
    z = []
    for _ in range(steps):
        pattern.step(dt)
        z.append(pattern.z[0].copy())
    return np.array(z) - config.anatomical_offsets()


@pytest.mark.parametrize(
    "name, joint",
    [
        ("balancing_hip", cpg.HROLL),
        ("balancing_ankle", cpg.AROLL),
        ("pelvis_rotation", cpg.HYAW),
        ("compass_hip", cpg.HPITCH),
        ("flex_knee", cpg.KNEE),
    ],
)
def test_sine_primitives_oscillate_with_amplitude_a(name, joint):
    """With β = 0, A φ̇ sin(φ + c) integrates to an oscillation of amplitude A (degrees)."""
    z = _single(name, 10.0)[:, joint]
    assert (z.max() - z.min()) / 2 == pytest.approx(10.0, abs=0.05)


def test_relaxation_attenuates_by_omega_over_norm():
    config = cpg.CPGConfig(beta=8.0, ramp_time=0.0)
    z = _single("balancing_hip", 10.0, config, steps=1500)[-300:, cpg.HROLL]
    w = config.omega
    assert (z.max() - z.min()) / 2 == pytest.approx(10.0 * w / math.hypot(w, 8.0), rel=0.01)
    assert z.mean() == pytest.approx(0.0, abs=0.05)  # centred on the offset


def test_flexion_is_a_gaussian_bump_of_height_a():
    z = _single("hip", 20.0)[:, cpg.HPITCH]
    assert z.max() == pytest.approx(20.0, abs=0.05)
    assert z.min() == pytest.approx(0.0, abs=0.05)
    knee = _single("knee", 40.0)[:, cpg.KNEE]
    assert knee.min() == pytest.approx(-40.0, abs=0.1)  # knee flexion is negative


def test_printed_flexion_ratchets():
    """As printed (no φ̄ factor) the flexion term steps by A √(2π)/σ ≈ 4.79 A per cycle."""
    config = cpg.CPGConfig(beta=0.0, ramp_time=0.0, flexion_form="printed")
    z = _single("hip", 1.0, config, steps=200, dt=0.011)[:, cpg.HPITCH]  # 2 cycles
    assert z[-1] == pytest.approx(2 * math.sqrt(2 * math.pi) / (math.pi / 6), rel=0.01)


def test_swing_is_centred_on_zero_phase():
    config = cpg.CPGConfig()
    pattern = cpg.CPG("hand_tuned", config)
    t_swing = (2 * math.pi - config.initial_phase % (2 * math.pi)) / config.omega
    phases = pattern.phases(t_swing)
    assert cpg.wrap_phase(phases[0]) == pytest.approx(0.0, abs=1e-9)
    assert abs(cpg.wrap_phase(phases[1])) == pytest.approx(math.pi)


def test_batch_trajectories_equal_the_stepped_cpg():
    rng = np.random.RandomState(0)
    amps = np.vstack(
        [
            cpg.amplitudes_from("hand_tuned"),
            cpg.amplitudes_from("table6_2"),
            rng.uniform(-30, 30, size=(3, 11)),
        ]
    )
    batch = cpg.trajectories(amps, 400, 0.016)
    assert batch.shape == (5, 400, 12)
    for k in range(5):
        pattern = cpg.CPG(amps[k])
        stepped = np.array([pattern.step(0.016) for _ in range(400)])
        np.testing.assert_allclose(batch[k], stepped, atol=1e-9)
    # A several-vector CPG steps like separate ones.
    many = cpg.CPG(amps)
    np.testing.assert_allclose(many.step(0.016), batch[:, 0], atol=1e-12)


def test_ramp_starts_from_the_offsets():
    config = cpg.CPGConfig()
    targets = cpg.trajectories(cpg.amplitudes_from("hand_tuned"), 3, 0.016, config)[0]
    np.testing.assert_allclose(targets[0], config.offsets(), atol=1e-4)


def test_offsets_keep_the_sole_parallel_and_mirror():
    anat = cpg.CPGConfig(crouch=30).anatomical_offsets()
    assert anat[cpg.HPITCH] + anat[cpg.KNEE] + anat[cpg.APITCH] == 0.0
    joints = cpg.CPGConfig(crouch=30).offsets()
    np.testing.assert_allclose(joints[6:], joints[:6] * cpg.JOINT_SIGNS[6:] * cpg.JOINT_SIGNS[:6])


def test_roll_input_adds_to_hip_and_ankle_roll():
    config = cpg.CPGConfig(beta=0.0, ramp_time=0.0)
    pattern = cpg.CPG(np.zeros(11), config)
    pattern.set_roll_input([10.0, -10.0])
    pattern.step(0.1)
    delta = pattern.z[0] - config.anatomical_offsets()
    assert delta[cpg.HROLL] == pytest.approx(1.0) and delta[cpg.AROLL] == pytest.approx(1.0)
    assert delta[6 + cpg.HROLL] == pytest.approx(-1.0)
    assert np.count_nonzero(np.abs(delta) > 1e-12) == 4


def test_dmp_kernels_and_output():
    psi = cpg.dmp_kernels(np.linspace(0, 2 * np.pi, 7))
    assert psi.shape == (7, 15)
    assert psi[0, 0] == pytest.approx(1.0)
    centres = 2 * np.pi * np.arange(15) / 15
    assert np.argmax(cpg.dmp_kernels(centres[4])) == 4
    theta = np.arange(15.0)
    assert cpg.dmp_output(centres[4], theta) == pytest.approx(4.0, abs=0.01)  # h = 37.5: narrow
    assert cpg.dmp_output(1.234, np.full(15, 3.0)) == pytest.approx(3.0)


def test_amplitudes_from_presets_names_and_files(tmp_path):
    assert cpg.amplitudes_from("hand_tuned")[3] == 40.0
    named = dict(zip(cpg.AMPLITUDE_NAMES, range(11)))
    np.testing.assert_array_equal(cpg.amplitudes_from(named), np.arange(11.0))
    path = tmp_path / "gait.json"
    path.write_text(json.dumps(named))
    np.testing.assert_array_equal(cpg.load_amplitudes(str(path)), np.arange(11.0))
    for bad in ("walk_fast", {"hip": 1.0}, [1.0] * 10, [np.nan] * 11, {**named, "extra": 1}):
        with pytest.raises(ValueError):
            cpg.amplitudes_from(bad)


def test_config_validation():
    with pytest.raises(ValueError):
        cpg.CPGConfig(flexion_form="cubic")
    with pytest.raises(ValueError):
        cpg.CPGConfig(stride_period=0.0)
    with pytest.raises(ValueError):
        cpg.CPGConfig(beta=-1.0)


@pytest.mark.parametrize("shape", [(2, 3), (5, 2, 3), (400, 2, 3), (16, 120, 2, 3)])
def test_combine_by_entry_equals_the_gathered_sum_bit_for_bit(shape):
    """`combine`'s two ways (gathered per element for few rows, entry by entry over many)
    give the same bits: values and amplitudes with zeros of both signs and of both
    magnitudes, so the `+ 0.0` of the zero padding shows."""
    rng = np.random.default_rng(len(shape))
    k = shape[-3] if len(shape) > 2 else 6
    amplitudes = rng.normal(0, 20, (k, cpg.N_AMPLITUDES))
    amplitudes[0], amplitudes[1, ::2] = -0.0, 0.0
    values = rng.normal(0, 5, shape) * 10.0 ** rng.integers(-300, 300, shape)
    values.flat[::7], values.flat[::11] = 0.0, -0.0
    by_entry = cpg._combine_by_entry(amplitudes, values)
    terms = amplitudes[:, cpg._ENTRY_AMPLITUDES] * cpg._entries(values)  # the reference sum
    padded = np.concatenate([terms, np.zeros(terms.shape[:-1] + (1,))], axis=-1)
    parts = padded[..., cpg._JOINT_TERMS]
    reference = ((parts[..., 0] + parts[..., 1]) + parts[..., 2]) + parts[..., 3]
    assert by_entry.tobytes() == reference.tobytes()
    assert cpg.combine(amplitudes, values).tobytes() == reference.tobytes()
