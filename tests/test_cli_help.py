"""Every command's --help: one screen, its own flags and the harness flags, exit code 0."""

import json
import os
import re
import subprocess
import sys

import pytest
from absl import flags

from cpg_suite import cli

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCREEN = 60  # lines
MAIN_JOBS = (
    "baselines.cem",
    "baselines.experiments.cem_study",
    "analysis.study",
    "cpg_suite.protocol.verify",
    "baselines.tabular",
)


# A flag's line: `  --name [default]: help`, the default being a value, "required", or
# "none" with what it means ("none: <meaning>"); never a bare "[none]".
_FLAG_LINE = re.compile(r"^  --\w+ \[(?:none: [^\]]+|(?!none\])[^\]]*)\]: \S")
# Commands whose flags once showed a bare "[none]" (beside MAIN_JOBS; every command is
# checked in the slow tier).
NONE_EXPLAINED = (
    "analysis.report",
    "analysis.reproduce",
    "analysis.table6_3",
    "baselines.experiments.overspeed",
    "benchmarks.ppo_mjx_time_to_target",
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


# The test install (README: pip install ".[test]") has none of the rl, mjx and cluster
# extras. A process started with this prelude cannot import them, whatever this machine has.
_EXTRAS = ("torch", "stable_baselines3", "jax", "jaxlib", "brax", "ray", "warp")
_AS_TEST_INSTALL = f"""
import importlib.abc, runpy, sys

class _NotInstalled(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {_EXTRAS!r} or name.startswith("mujoco.mjx"):
            raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)

sys.meta_path.insert(0, _NotInstalled())
"""
# Commands that need an extra to start at all (each says so in its docstring).
NEED_EXTRAS = {
    "baselines.ppo": "rl",
    "baselines.ppo_mjx": "mjx",
    "benchmarks.bench_mjx": "mjx",
    "cpg_suite.harness.sb3": "rl",
}


def _help(module: str, test_install: bool = True) -> subprocess.CompletedProcess:
    """`python -m module --help`, headless; as on the test install unless told otherwise."""
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "DISPLAY")}
    run = (
        f"sys.argv = [{module!r}, '--help']\n"
        f"runpy.run_module({module!r}, run_name='__main__', alter_sys=True)"
    )
    command = ["-c", _AS_TEST_INSTALL + run] if test_install else ["-m", module, "--help"]
    return subprocess.run(
        [sys.executable, *command],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )


def _check(module: str, test_install: bool = True) -> None:
    done = _help(module, test_install)
    assert done.returncode == 0, f"{module} --help exited {done.returncode}: {done.stderr[-300:]}"
    lines = done.stdout.splitlines()
    assert len(lines) <= SCREEN, f"{module} --help: {len(lines)} lines"
    assert "flags (defaults in brackets" in done.stdout
    assert not any(line.startswith("  --verbosity") for line in lines), "absl's own flags shown"
    flag_lines = lines[lines.index(next(x for x in lines if x.startswith("flags (defaults"))) + 1 :]
    for line in flag_lines:  # every flag shows its default, or what leaving it out means
        assert _FLAG_LINE.match(line), f"{module} --help: {line!r}"


@pytest.mark.parametrize("module", MAIN_JOBS)
def test_the_main_commands_help_fits_a_screen(module):
    _check(module)


@pytest.mark.parametrize("module", NONE_EXPLAINED)
def test_a_flag_left_out_says_what_that_means(module):
    _check(module)  # `[none: <meaning>]` or `[required]`, never `[none]`


def test_a_bare_none_is_refused():
    assert not _FLAG_LINE.match("  --out [none]: Output folder.")
    for line in (
        "  --out [none: print only]: Where.",
        "  --runs [required]: Root.",
        "  --seeds [3]: Seeds.",
        '  --name [""]: A name.',
        "  --nonesuch [none_left]: A value that begins with none.",
    ):
        assert _FLAG_LINE.match(line), line


def test_the_main_job_lists_the_harness_flags():
    out = _help("baselines.cem").stdout
    for flag in ("--task", "--population", "--rounds", "--seed", "--output_dir", "--threads"):
        assert f"  {flag} [" in out or f"  {flag}:" in out, flag


@pytest.mark.slow
def test_every_command_help_fits_a_screen():
    programs = _programs()
    assert set(MAIN_JOBS) <= set(programs) and len(programs) > 30
    for module in programs:
        _check(module, test_install=module not in NEED_EXTRAS)


def test_every_command_imports_on_the_test_install_but_those_that_need_an_extra():
    """The class of CI's failure: a command importing torch at the top for one flag."""
    programs = _programs()
    code = (
        _AS_TEST_INSTALL
        + f"""
import importlib, json
failed = {{}}
for name in {programs!r}:
    try:
        importlib.import_module(name)
    except ImportError as e:
        failed[name] = str(e)
print(json.dumps(failed))
"""
    )
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "DISPLAY")}
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, env=env, timeout=300
    )
    assert done.returncode == 0, done.stderr[-2000:]
    failed = json.loads(done.stdout.strip().splitlines()[-1])
    assert set(failed) == set(NEED_EXTRAS), failed


def _flag_lines(module: str) -> dict[str, str]:
    done = _help(module)
    assert done.returncode == 0, done.stderr[-300:]
    return {line.split()[0]: line for line in done.stdout.splitlines() if line.startswith("  --")}


def test_submit_help_shows_what_each_flag_left_out_means_and_the_budget_rule():
    shown = _flag_lines("cpg_suite.protocol.submit")
    for flag in ("--gait", "--policy", "--actions", "--code", "--evaluations", "--control_steps"):
        assert re.match(rf"  {flag} \[none: \w[^\]]*\]: ", shown[flag]), shown[flag]
    budget = shown["--evaluations"]
    assert "untrained reference" in budget and "never ranked" in budget


def test_verify_help_shows_what_each_flag_left_out_means():
    shown = _flag_lines("cpg_suite.protocol.verify")
    for flag in ("--ship_from", "--rescore", "--upgrade_to", "--entropy", "--trusted_list"):
        assert re.match(rf"  {flag} \[none: \w[^\]]*\]: ", shown[flag]), shown[flag]


def test_leaderboard_help_points_to_the_protocol_and_names_its_files():
    out = _help("analysis.leaderboard").stdout
    assert "docs/protocol.md" in out and "docs/submit.md" in out
    assert "docs/architecture.md" not in out
    for name in ("leaderboard.csv", "darwin_leaderboard.csv", "darwin_not_admitted.csv"):
        assert name in out
    assert "  --runs [required]: " in out


def test_flag_default_words():
    values = flags.FlagValues()  # not the process's flags
    flags.DEFINE_integer("steps", 5, "Steps.", flag_values=values)
    flags.DEFINE_string("name", "", "A name.", flag_values=values)
    flags.DEFINE_string("out", None, "none: print only. Where to write.", flag_values=values)
    flags.DEFINE_string(
        "strip", None, "Between snapshots (default: a quarter).", flag_values=values
    )
    flags.DEFINE_string("run", None, "A run.", flag_values=values, required=True)
    flags.DEFINE_string("dir", None, "none: required. A folder.", flag_values=values)
    flags.DEFINE_string("path", "a.txt", "A path.", flag_values=values)
    flags.DEFINE_string("other", None, "Something.", flag_values=values)
    assert {name: cli.flag_default(values[name]) for name in values} == {
        "steps": ("5", "Steps."),
        "name": ('""', "A name."),
        "out": ("none: print only", "Where to write."),
        "strip": ("none: a quarter", "Between snapshots."),
        "run": ("required", "A run."),
        "dir": ("required", "A folder."),
        "path": ("a.txt", "A path."),
        "other": ("none", "Something."),
    }
