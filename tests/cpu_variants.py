"""The CPU variants a result must not depend on, as environments for a child process.

Each variant makes this machine's libraries take the code paths they take on another
x86-64 CPU: NumPy without its AVX-512 loops (an AVX2 machine) or without its AVX2 ones
too, torch's ATen at its default or AVX2 capability, and OpenBLAS with another CPU's
kernels. The variables are read when the libraries load, so each variant runs in a
child process.
"""

from __future__ import annotations

import os
import subprocess
import sys

_CONTROLLED = ("NPY_DISABLE_CPU_FEATURES", "ATEN_CPU_CAPABILITY", "OPENBLAS_CORETYPE")


def cpu_flags() -> set[str]:
    """This CPU's feature flags, from /proc/cpuinfo (empty where it cannot be read)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("flags"):
                    return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


def variants(
    blas_kernels: tuple[str, ...] = ("Haswell",), torch: bool = True
) -> dict[str, dict[str, str]]:
    """Variant name → the environment variables that make it (native: none).

    Args:
      blas_kernels: OpenBLAS kernels to force (SkylakeX only where the CPU has AVX-512).
      torch: Include torch's capabilities (`ATEN_CPU_CAPABILITY`: it changes nothing in a
        process that never imports torch).
    """
    from numpy._core._multiarray_umath import __cpu_dispatch__

    avx512 = [f for f in __cpu_dispatch__ if "AVX512" in f or f == "X86_V4"]
    out = {
        "native": {},
        "NumPy without AVX-512": {"NPY_DISABLE_CPU_FEATURES": " ".join(avx512)},
    }
    if "X86_V3" in __cpu_dispatch__:  # NumPy ≥ 2.4 names its AVX2/FMA level X86_V3.
        out["NumPy without AVX2 and AVX-512"] = {
            "NPY_DISABLE_CPU_FEATURES": " ".join(["X86_V3", *avx512])
        }
    if torch:
        out["torch at its default capability"] = {"ATEN_CPU_CAPABILITY": "default"}
        out["torch at AVX2"] = {"ATEN_CPU_CAPABILITY": "avx2"}
    for kernel in blas_kernels:
        if kernel != "SkylakeX" or "avx512f" in cpu_flags():
            out[f"OpenBLAS {kernel}"] = {"OPENBLAS_CORETYPE": kernel}
    return out


def machines() -> dict[str, dict[str, str]]:
    """Other x86-64 CPUs as one environment each: every library at once takes the code
    paths it takes there (native; an AVX2 CPU: NumPy without AVX-512, torch at AVX2,
    OpenBLAS's Haswell kernels; a CPU without AVX2: NumPy and torch at their baseline,
    OpenBLAS's Sandybridge kernels). Every setting of `variants` is in one of them, so a
    whole-pipeline check (`verify --quick`) runs once a machine rather than once a variant.
    """
    single = variants(blas_kernels=())
    avx2 = {
        **single["NumPy without AVX-512"],
        **single["torch at AVX2"],
        "OPENBLAS_CORETYPE": "Haswell",
    }
    older = {
        **single.get("NumPy without AVX2 and AVX-512", single["NumPy without AVX-512"]),
        **single["torch at its default capability"],
        "OPENBLAS_CORETYPE": "Sandybridge",
    }
    return {"native": {}, "as on an AVX2 CPU": avx2, "as on a CPU without AVX2": older}


def environment(variant: dict[str, str]) -> dict[str, str]:
    """This process's environment with the variant's variables (and none of the others)."""
    env = {k: v for k, v in os.environ.items() if k not in _CONTROLLED}
    return {**env, **variant}


def start(variant: dict[str, str], args: list[str], **kwargs) -> subprocess.Popen:
    """`python ARGS` in a child process under the variant, its output captured as text."""
    return subprocess.Popen(
        [sys.executable, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=environment(variant),
        **kwargs,
    )
