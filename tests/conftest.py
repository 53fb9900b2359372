"""Shared pytest hooks: the hot-path ratios a run measured, printed at its end with the CPU.

The slow hot-path test (`test_hot_paths.py`) appends `(path, ratio, repeats)` (and, for
`env.step`, `(name, [(part, µs), ...], repeats)`: where a control step's time goes) to the
`hot_path_readings` fixture; the terminal summary lists them under the CPU's model name and
whether it has AVX-512, so each CI run records the ratios on whatever machine it ran on
(issue 55 asks for them on AVX2 and AVX-512 CPUs).
"""

from __future__ import annotations

import cpu_variants
import pytest

_READINGS = pytest.StashKey[list]()


def _cpu() -> str:
    """The CPU's model name and its widest vector extension, from /proc/cpuinfo (its flags
    as `cpu_variants` reads them)."""
    name = "unknown CPU"
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            name = next((v.strip() for k, _, v in map(lambda line: line.partition(":"), f)
                         if k.strip() == "model name"), name)  # fmt: skip
    except OSError:
        pass
    flags = cpu_variants.cpu_flags()
    widest = "AVX-512" if "avx512f" in flags else "AVX2" if "avx2" in flags else "no AVX2"
    return f"{name} ({widest})"


@pytest.fixture
def hot_path_readings(request) -> list:
    """The list the hot-path test appends its readings to (one per run of pytest)."""
    return request.config.stash.setdefault(_READINGS, [])


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    readings = config.stash.get(_READINGS, [])
    if not readings:
        return
    terminalreporter.write_sep("-", f"hot paths / raw mujoco.rollout on {_cpu()}")
    for name, value, repeats in readings:
        if isinstance(value, list):  # a profile: (part, µs) rows
            terminalreporter.write_line(f"{name}:")
            for part, micros in value:
                terminalreporter.write_line(f"  {part.strip():62s} {micros:7.1f}")
        else:
            terminalreporter.write_line(f"{name:48s} {value:6.3f}x  (best of {repeats})")
