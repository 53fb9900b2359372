"""Every command's --help: one screen, its own flags and the harness flags, exit code 0."""

import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCREEN = 60  # lines
MAIN_JOBS = (
    "baselines.cem",
    "baselines.experiments.cem_study",
    "analysis.study",
    "cpg_suite.protocol.verify",
    "baselines.tabular",
)


def _programs() -> list[str]:
    found = []
    for package in ("cpg_suite", "baselines", "analysis", "benchmarks"):
        for dirpath, _, names in os.walk(os.path.join(ROOT, package)):
            for name in sorted(names):
                path = os.path.join(dirpath, name)
                if name.endswith(".py") and "cli.run(" in open(path, encoding="utf-8").read():
                    module = os.path.relpath(path, ROOT)[:-3].replace(os.sep, ".")
                    found.append(module.removesuffix(".__main__"))
    return sorted(found)


def _help(module: str) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "DISPLAY")}
    return subprocess.run(
        [sys.executable, "-m", module, "--help"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )


def _check(module: str) -> None:
    done = _help(module)
    assert done.returncode == 0, f"{module} --help exited {done.returncode}: {done.stderr[-300:]}"
    lines = done.stdout.splitlines()
    assert len(lines) <= SCREEN, f"{module} --help: {len(lines)} lines"
    assert "flags (defaults in brackets" in done.stdout
    assert not any(line.startswith("  --verbosity") for line in lines), "absl's own flags shown"


@pytest.mark.parametrize("module", MAIN_JOBS)
def test_the_main_commands_help_fits_a_screen(module):
    _check(module)


def test_the_main_job_lists_the_harness_flags():
    out = _help("baselines.cem").stdout
    for flag in ("--task", "--population", "--rounds", "--seed", "--output_dir", "--threads"):
        assert f"  {flag} [" in out or f"  {flag}:" in out, flag


@pytest.mark.slow
def test_every_command_help_fits_a_screen():
    programs = _programs()
    assert set(MAIN_JOBS) <= set(programs) and len(programs) > 30
    for module in programs:
        _check(module)
