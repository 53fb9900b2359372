"""Runs give the same bits on any x86-64 CPU: CPU-independent linear algebra and elementary
functions (within an ulp or two of 60-digit references), and the CPG's targets (open and
closed loop), exported policies' actions (Brax's and Stable-Baselines3's PPO, as NumPy
arrays) and short CEM and CMA-ES runs under forced OpenBLAS kernels and NumPy SIMD levels
(torch's CPU capabilities: the slow tier's `verify --quick` under every variant, where the
SB3 pickles load torch)."""

import json
import math
import os
import sys

import cpu_variants
import mpmath
import numpy as np
import pytest

from cpg_suite import portable

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_matmul_and_sums_match_numpy():
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal((7, 11)), rng.standard_normal((11, 5))
    np.testing.assert_allclose(portable.matmul(a, b), a @ b, rtol=1e-13, atol=1e-13)
    w = rng.random(7)
    np.testing.assert_allclose(portable.weighted_sum(w, a), w @ a, rtol=1e-13)
    np.testing.assert_allclose(
        portable.weighted_outer_sum(w, a), (a.T * w) @ a, rtol=1e-12, atol=1e-13
    )
    assert portable.norm([3.0, 4.0]) == 5.0
    with pytest.raises(ValueError, match="cannot multiply"):
        portable.matmul(a, a)
    for shape in ((7, 11, 5), (1, 256, 12), (2, 1, 3)):  # odd, even and single inner sizes
        x, k = rng.standard_normal(shape[:2]), rng.standard_normal(shape[1:])
        np.testing.assert_allclose(portable.pairwise_matmul(x, k), x @ k, rtol=1e-12, atol=1e-13)
    with pytest.raises(ValueError, match="cannot multiply"):
        portable.pairwise_matmul(a, a)


def _tree_sum(values: list[float]) -> float:
    """The order `pairwise_matmul` promises, one scalar at a time: pad to even with +0.0,
    add element j to element j + n/2, repeat until one is left."""
    while len(values) > 1:
        if len(values) % 2:
            values = values + [0.0]
        half = len(values) // 2
        values = [values[j] + values[j + half] for j in range(half)]
    return values[0]


def test_pairwise_matmul_sums_in_its_documented_tree_bit_for_bit():
    rng = np.random.default_rng(3)
    for rows, inner, cols in ((3, 42, 5), (2, 256, 4), (1, 7, 3), (2, 1, 2)):
        x, k = rng.standard_normal((rows, inner)), rng.standard_normal((inner, cols))
        x[0, :] = -0.0  # a row of products that are all -0.0: the padding's +0.0 shows
        expect = np.array(
            [
                [_tree_sum([x[i, j] * k[j, c] for j in range(inner)]) for c in range(cols)]
                for i in range(rows)
            ]
        )
        got = portable.pairwise_matmul(x, k)
        assert got.view(np.int64).tolist() == expect.view(np.int64).tolist()


def test_cholesky_of_definite_semidefinite_and_zero_matrices():
    rng = np.random.default_rng(1)
    a = rng.standard_normal((11, 11))
    definite = a @ a.T + 0.8 * np.eye(11)
    low = portable.cholesky_psd(definite)
    np.testing.assert_allclose(low, np.linalg.cholesky(definite), rtol=1e-10, atol=1e-12)
    d = rng.standard_normal((2, 11))
    rank_one = np.outer(d[0] - d[1], d[0] - d[1]) / 4  # CEM, elite 2, no noise
    low = portable.cholesky_psd(rank_one)
    np.testing.assert_allclose(low @ low.T, rank_one, atol=1e-12)
    assert not portable.cholesky_psd(np.zeros((3, 3))).any()


def test_jacobi_eigendecomposition():
    rng = np.random.default_rng(2)
    a = rng.standard_normal((11, 11))
    s = a @ a.T
    values, vectors = portable.symmetric_eig(s)
    np.testing.assert_allclose(vectors.T @ vectors, np.eye(11), atol=1e-12)
    np.testing.assert_allclose(vectors @ np.diag(values) @ vectors.T, s, atol=1e-10)
    np.testing.assert_allclose(np.sort(values), np.linalg.eigvalsh(s), rtol=1e-10, atol=1e-10)


def _ulps(got: np.ndarray, exact, args) -> float:
    """The largest error of `got` against `exact` (an mpmath function) in units in the last
    place of the correctly rounded result."""
    worst = 0.0
    for value, *point in zip(got, *args):
        reference = exact(*(mpmath.mpf(float(p)) for p in point))
        rounded = float(reference)
        unit = math.ulp(rounded) if rounded else math.ulp(0.0)
        worst = max(worst, float(abs(mpmath.mpf(float(value)) - reference)) / unit)
    return worst


_RNG = np.random.default_rng(7)
_ANGLES = np.concatenate(
    [_RNG.uniform(-8, 8, 1500), _RNG.uniform(-3000, 3000, 1500), [0.0, math.pi, 355.0, 103993.0]]
)
_EXPONENTS = np.concatenate(
    [_RNG.uniform(-20, 20, 1500), _RNG.uniform(-745, 709.7, 500), _RNG.uniform(-1e-6, 1e-6, 200)]
)


@pytest.mark.parametrize(
    "name, exact, args, bound",
    [
        ("sin", mpmath.sin, (_ANGLES,), 1.0),
        ("cos", mpmath.cos, (_ANGLES,), 1.0),
        ("exp", mpmath.exp, (_EXPONENTS,), 1.0),
        ("expm1", mpmath.expm1, (np.concatenate([_EXPONENTS[:1500] / 10, _EXPONENTS]),), 1.0),
        ("tanh", mpmath.tanh, (_EXPONENTS[:1700] / 4,), 2.0),
        ("expit", lambda x: 1 / (1 + mpmath.exp(-x)), (_EXPONENTS[:1700] * 2,), 2.0),
        ("arctan2", mpmath.atan2, (_RNG.standard_normal(1500), _RNG.standard_normal(1500)), 2.0),
        ("hypot", mpmath.hypot, (_RNG.standard_normal(1500), _RNG.standard_normal(1500)), 1.5),
    ],
)
def test_elementary_functions_are_within_their_bound_of_60_digit_references(
    name, exact, args, bound
):
    mpmath.mp.dps = 60
    got = getattr(portable, name)(*args)
    assert got.shape == args[0].shape
    assert _ulps(got, exact, args) < bound


def test_elementary_functions_special_values():
    assert list(portable.exp([0.0, np.inf, -np.inf, 710.0, -746.0])) == [1, np.inf, 0, np.inf, 0]
    assert np.isnan(portable.exp(np.nan)) and np.isnan(portable.tanh(np.nan))
    assert list(portable.tanh([0.0, 30.0, -30.0])) == [0.0, 1.0, -1.0]
    assert list(portable.expm1([0.0, -50.0])) == [0.0, -1.0]
    assert list(portable.expit([-800.0, 0.0, 800.0])) == [0.0, 0.5, 1.0]
    sin, cos = portable.sincos(np.array([0.0, np.pi / 2, np.pi]))
    assert sin[0] == 0.0 and cos[0] == 1.0 and sin[1] == 1.0 and abs(cos[2] + 1.0) < 1e-16
    assert portable.arctan2(0.0, -1.0) == np.pi and portable.arctan2(-1.0, 0.0) == -np.pi / 2
    assert portable.sincos(5.0)[0].shape == ()  # a number gives 0-d arrays
    for bad in (np.inf, np.nan, 2.0**19 * np.pi * 1.001):
        with pytest.raises(ValueError, match="finite angles"):
            portable.sin([0.0, bad])
    with pytest.raises(ValueError, match="finite coordinates"):
        portable.arctan2([1.0], [np.inf])


_SHORT_RUNS = r"""
import hashlib, json, os, sys
import numpy as np
from baselines import cem, cmaes
from cpg_suite.runfiles import exported, runs
from cpg_suite import cpg, darwin, feedback, portable, residual

def digest(arrays):
    return hashlib.sha256(b"".join(np.asarray(a).tobytes() for a in arrays)).hexdigest()

out = {}
rng = np.random.default_rng(0)
# The CPG: open loop, modulated (the cpg action space, with its phase features), with
# feedback (closed loop, sensor inputs from orientations), and the DMP kernels.
dt = darwin.CONTROL_TIMESTEP
out["open_loop"] = digest([cpg.trajectories(cpg.PRESETS["hand_tuned"], 1000, dt)])
modulated, steps = residual.ModulatedCPG(3), []
for _ in range(200):
    modulated.modulate(rng.uniform(-1, 1, (3, residual.N_ACTIONS)))
    steps += [modulated.step(dt), modulated.phase_features()]
out["modulated"] = digest(steps)
params = np.concatenate([np.tile(cpg.PRESETS["hand_tuned"], (3, 1)),
                         rng.uniform(-0.5, 0.5, (3, feedback.N_GAINS))], axis=1)
closed, steps = feedback.FeedbackCPG(params), []
for _ in range(200):
    quat = rng.standard_normal((3, 4))
    quat /= np.sqrt((quat * quat).sum(axis=1, keepdims=True))
    inputs = feedback.sensor_inputs(quat, rng.standard_normal((3, 3)), rng.uniform(0, 30, (3, 2)))
    steps += [inputs, closed.step(dt, inputs)]
out["closed_loop"] = digest(steps)
out["dmp"] = digest([cpg.dmp_kernels(rng.uniform(-50, 50, 500))])
x = rng.uniform(-30, 30, 2000)
out["functions"] = digest([*portable.sincos(x * 50), portable.exp(x), portable.expm1(x / 10),
                           portable.tanh(x / 5), portable.expit(x), portable.arctan2(x, x[::-1]),
                           portable.hypot(x, x[::-1])])
# Policies exported to NumPy (PPO on MJX's format), both heads and action spaces.
sizes = (40, 256, 256, 24)
for head in ("normal", "tanh_normal"):
    arrays = {"mean": rng.standard_normal(40), "std": rng.random(40) + 0.5, "head": head}
    for i, (n, m) in enumerate(zip(sizes[:-1], sizes[1:])):
        arrays[f"kernel_{i}"] = rng.standard_normal((n, m)) / np.sqrt(n)
        arrays[f"bias_{i}"] = 0.1 * rng.standard_normal(m)
    policy = exported.NumpyPolicy(arrays, "joints")
    actions = [policy.act(rng.standard_normal((1, 40))) for _ in range(64)]
    out[f"numpy_policy_{head}"] = digest(actions)
# The shipped Stable-Baselines3 PPO policies as the test protocol runs them (their arrays).
for name in ("joints_v1_seed0", "cpg_v1_seed0"):
    policy = exported.NumpyPolicy.load(os.path.join(sys.argv[2], name, exported.FILE))
    flat = 3 * rng.standard_normal((64, len(policy.mean)))
    out[f"sb3_{name}"] = digest([policy.act(flat[i:i + 1]) for i in range(64)])
# Short CEM and CMA-ES runs.
base = dict(population=6, rounds=3, trial_steps=150, fall_penalty=10.0)
base.update(validation_seeds=2, test_seeds=2)
for name, run, settings in (
    ("cem", cem.run_cem, cem.CEMSettings(elite=2, noise=0.8, **base)),
    ("cmaes", cmaes.run_cmaes, cmaes.CMAESSettings(**base)),
):
    options = runs.RunOptions(output_dir=sys.argv[1], run_name="r", threads=2)
    run_dir, summary = run(settings, options, log=lambda line: None)
    summary.pop("wall_s")
    files = {f: runs.read_json(f"{run_dir}/{f}") for f in ("best_params.json", "mean_params.json")}
    out[name] = {"summary": summary, **files}
print(json.dumps(out))
"""


@pytest.mark.skipif(sys.platform != "linux", reason="forced CPU variants: x86-64 Linux")
def test_runs_are_identical_under_every_cpu_variant(tmp_path):
    policies = os.path.join(ROOT, "results", "protocol", "runs", "ppo", "darwin_walk")
    # Nothing here imports torch (the PPO policies run as NumPy arrays): no torch variants.
    every = cpu_variants.variants(("Haswell", "Sandybridge", "SkylakeX"), torch=False)
    results = {}
    for name, variant in every.items():  # one at a time: the runs use both cores
        out_dir = tmp_path / name.replace(" ", "_")
        child = cpu_variants.start(variant, ["-c", _SHORT_RUNS, str(out_dir), policies])
        stdout, stderr = child.communicate(timeout=600)
        assert child.returncode == 0, f"{name}: {stderr[-2000:]}"
        results[name] = json.loads(stdout.strip().splitlines()[-1])
    reference = results.pop("native")
    for name, result in results.items():
        differ = sorted(k for k in reference if result[k] != reference[k])
        assert not differ, f"{name}: {', '.join(differ)} differ from the native run"


def test_tanh_equals_its_two_branch_definition_bit_for_bit():
    """`tanh` computes one expm1 for both of msun's branches (its argument chosen per
    element); every value is the one the two-call form gives (the form it replaced)."""
    rng = np.random.default_rng(55)
    x = np.concatenate([
        rng.uniform(-25.0, 25.0, 200_000),
        rng.standard_normal(200_000),
        rng.standard_normal(100_000) * 1e-8,
        rng.integers(0, 2**63, 200_000, dtype=np.uint64).view(np.float64),  # any bit pattern
        [0.0, -0.0, 1.0, -1.0, np.nextafter(1.0, 0), 22.0, -22.0, np.inf, -np.inf, np.nan],
        [5e-324, -5e-324, 1e308, -1e308],
    ])  # fmt: skip
    with np.errstate(all="ignore"):
        a = np.minimum(np.abs(x), 22.0)
        large = 1.0 - 2.0 / (portable.expm1(a + a) + 2.0)
        t = portable.expm1(-(a + a))
        out = np.where(a >= 1.0, large, -t / (t + 2.0))
        out = np.where(a >= 22.0, 1.0, out)
        reference = np.where(np.isnan(x), x, np.copysign(out, x))
    assert portable.tanh(x).tobytes() == reference.tobytes()
