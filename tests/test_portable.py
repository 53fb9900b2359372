"""Runs give the same bits on any x86-64 CPU: CPU-independent linear algebra, and short CEM
and CMA-ES runs and an exported policy's actions under forced OpenBLAS kernels and NumPy
SIMD levels."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from cpg_suite import portable


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


_SHORT_RUNS = r"""
import hashlib, json, sys
from baselines import cem, cmaes
from cpg_suite.harness import runs
from cpg_suite import cpg, darwin
targets = cpg.trajectories(cpg.PRESETS["hand_tuned"], 1000, darwin.CONTROL_TIMESTEP)
out = {"cpg_sha256": hashlib.sha256(targets.tobytes()).hexdigest()}
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
# A policy exported to NumPy (PPO on MJX's format), its actions on 64 observations.
from cpg_suite.harness import exported
import numpy as np
rng = np.random.default_rng(0)
sizes = (40, 256, 256, 12)
arrays = {"mean": rng.standard_normal(40), "std": rng.random(40) + 0.5, "head": "normal"}
for i, (n, m) in enumerate(zip(sizes[:-1], sizes[1:])):
    arrays[f"kernel_{i}"] = rng.standard_normal((n, m)) / np.sqrt(n)
    arrays[f"bias_{i}"] = 0.1 * rng.standard_normal(m)
policy = exported.NumpyPolicy(arrays, "joints")
actions = np.concatenate([policy.act(rng.standard_normal((1, 40))) for _ in range(64)])
out["numpy_policy_sha256"] = hashlib.sha256(actions.tobytes()).hexdigest()
print(json.dumps(out))
"""


def _cpu_flags() -> set:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("flags"):
                    return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


def _variants() -> dict:
    from numpy._core._multiarray_umath import __cpu_dispatch__

    avx512 = [f for f in __cpu_dispatch__ if "AVX512" in f or f == "X86_V4"]
    variants = {
        "default": {},
        "Haswell": {"OPENBLAS_CORETYPE": "Haswell"},
        "Sandybridge": {"OPENBLAS_CORETYPE": "Sandybridge"},
        "no AVX-512 in NumPy": {"NPY_DISABLE_CPU_FEATURES": " ".join(avx512)},
    }
    if "X86_V3" in __cpu_dispatch__:  # NumPy ≥ 2.4 names its AVX2/FMA level X86_V3.
        variants["no AVX2 in NumPy"] = {"NPY_DISABLE_CPU_FEATURES": " ".join(["X86_V3"] + avx512)}
    if "avx512f" in _cpu_flags():  # A SkylakeX kernel needs AVX-512 to run at all.
        variants["SkylakeX"] = {"OPENBLAS_CORETYPE": "SkylakeX"}
    return variants


@pytest.mark.skipif(sys.platform != "linux", reason="forced OpenBLAS kernels: x86-64 Linux")
def test_runs_are_identical_under_every_blas_kernel_and_simd_level(tmp_path):
    results = {}
    for name, extra in _variants().items():
        env = {
            k: v
            for k, v in os.environ.items()
            if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES")
        }
        out_dir = tmp_path / name.replace(" ", "_")
        proc = subprocess.run(
            [sys.executable, "-c", _SHORT_RUNS, str(out_dir)],
            capture_output=True,
            text=True,
            env={**env, **extra},
            timeout=600,
        )
        assert proc.returncode == 0, f"{name}: {proc.stderr[-2000:]}"
        results[name] = json.loads(proc.stdout.strip().splitlines()[-1])
    reference = results.pop("default")
    for name, result in results.items():
        assert result == reference, f"{name} differs from the default kernel"
