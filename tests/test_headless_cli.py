"""On a headless machine with no rendering variables, every command speaks clean lines.

A program that does not render chooses no OpenGL backend for itself (no GLFW warning); one
that renders picks a headless backend that works, or says in one line that none does; an
output path that cannot be written stops a command before any work, with one line.
"""

import os
import re
import subprocess
import sys

import pytest

from cpg_suite import cli

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# A new user's headless machine: no display, no rendering variables.
HEADLESS = {
    k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "DISPLAY", "PYOPENGL_PLATFORM")
}

# Every command that writes, with the flag that names where.
WRITERS = [
    ("baselines.cem", "--output_dir"),
    ("baselines.cmaes", "--output_dir"),
    ("baselines.ppo", "--output_dir"),
    ("baselines.nac", "--output_dir"),
    ("baselines.experiments.nac_experiments", "--output_dir"),
    ("baselines.experiments.crawler_experiments", "--output_dir"),
    ("baselines.experiments.pole_claims", "--output_dir"),
    ("baselines.tabular", "--output_dir"),
    ("cpg_suite.protocol.score", "--out"),
    ("baselines.experiments.calibrate_cpg", "--output"),
    ("cpg_suite.explore", "--out"),
]


def _run(*args, env=None, cwd=None):
    return subprocess.run(
        [sys.executable, *args],
        capture_output=True,
        text=True,
        env=HEADLESS if env is None else env,
        cwd=cwd,
        timeout=300,
    )


@pytest.mark.slow  # a child process per command
@pytest.mark.parametrize("module,flag", WRITERS)
def test_output_under_a_regular_file_is_one_line_before_any_work(tmp_path, module, flag):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    out = _run("-m", module, f"{flag}={blocker}/x/y", cwd=tmp_path)
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {flag}={blocker}/x/y: "), lines
    assert "is not a directory" in lines[0]
    assert sorted(os.listdir(tmp_path)) == ["a_file"]  # nothing written anywhere
    assert out.stdout == ""


def _commands() -> list[str]:
    """Every module that runs as a command (`cli.run(main...)` under `__main__`)."""
    found = []
    for package in ("cpg_suite", "baselines", "analysis"):
        for dirpath, _, names in os.walk(os.path.join(ROOT, package)):
            for name in sorted(names):
                path = os.path.join(dirpath, name)
                if name.endswith(".py") and "cli.run(main" in open(path, encoding="utf-8").read():
                    module = os.path.relpath(path, ROOT)[:-3].replace(os.sep, ".")
                    found.append(module.removesuffix(".__main__"))
    return sorted(found)


def test_commands_are_found():
    assert {"baselines.cem", "cpg_suite.evaluation.evaluate", "analysis.report"} <= set(_commands())


@pytest.mark.slow  # a child process per command
@pytest.mark.parametrize("module", _commands())
def test_every_command_says_an_unknown_flag_in_one_line(module):
    out = _run("-m", module, "--no_such_flag=1")
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "no_such_flag" in lines[0], lines


def test_bad_flag_is_one_line_without_rendering_noise():
    out = _run("-m", "baselines.cem", "--population=1")
    assert out.returncode == 2
    assert out.stderr.splitlines() == ["error: --population must be an integer ≥ 2, got 1"]


def test_importing_cpg_suite_loads_no_renderer():
    code = "import sys, cpg_suite, cpg_suite.cli; print('dm_control' in sys.modules)"
    assert _run("-c", code).stdout.strip() == "False"


_BACKEND_AFTER = (
    "import os; from cpg_suite import cli; cli.{call}(); print(os.environ['MUJOCO_GL'])"
)


def test_without_rendering_disables_unless_the_user_chose():
    code = _BACKEND_AFTER.format(call="without_rendering")
    assert _run("-c", code).stdout.strip() == "disable"
    assert _run("-c", code, env={**HEADLESS, "MUJOCO_GL": "egl"}).stdout.strip() == "egl"


def test_choose_renderer_picks_a_working_headless_backend():
    out = _run("-c", _BACKEND_AFTER.format(call="choose_renderer"))
    assert out.returncode == 0, out.stderr
    backend = out.stdout.strip()
    assert backend in ("egl", "osmesa")
    probe = _run("-c", cli._PROBE, env={**HEADLESS, "MUJOCO_GL": backend})
    assert probe.returncode == 0 and probe.stderr == ""


def test_choose_renderer_says_in_one_line_when_none_works():
    # Backends dm_control does not know fail their probe like a missing EGL or OSMesa.
    code = (
        "from cpg_suite import cli; cli._HEADLESS_BACKENDS = ('no_such_gl', 'nor_this');"
        "cli.choose_renderer()"
    )
    out = _run("-c", code)
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: no display and no headless OpenGL")


def test_output_checks_create_nothing(tmp_path):
    cli.check_output_dir(str(tmp_path / "new" / "deeper"), "--output_dir")
    cli.check_output_file(str(tmp_path / "new" / "out.csv"), "--out")
    cli.check_output_dir(str(tmp_path), "--output_dir")
    assert os.listdir(tmp_path) == []
    (tmp_path / "f").write_text("")
    with pytest.raises(cli.UsageError, match="exists and is not a directory"):
        cli.check_output_dir(str(tmp_path / "f"), "--output_dir")
    with pytest.raises(cli.UsageError, match="is a directory, expected a file"):
        cli.check_output_file(str(tmp_path), "--out")
    with pytest.raises(cli.UsageError, match="is not a directory"):
        cli.check_output_file(str(tmp_path / "f" / "x.csv"), "--out")


# Quiet headless: library use, the submission path and a script print nothing on stderr
# without a display (dm_control's GLFW warning is ignored while cpg_suite loads it), and
# loading changes no warning filter of the process.
_LIBRARY = (
    "import warnings\nimport cpg_suite\nfilters = list(warnings.filters)\n"
    "env = cpg_suite.load('darwin_walk'); env.reset(); env.step([0.0] * 12)\n"
    "assert warnings.filters == filters, 'load changed the warning filters'\n"
    "print(len(cpg_suite.ALL_TASKS))"
)


def test_library_use_prints_nothing_headless():
    out = _run("-c", _LIBRARY)
    assert out.returncode == 0 and out.stderr == "", out.stderr
    assert int(out.stdout) > 5


@pytest.mark.parametrize(
    "code",
    [
        "import cpg_suite; cpg_suite.submit_gait, cpg_suite.format_card",
        "from cpg_suite.protocol import submit",
        "from cpg_suite import darwin; darwin.Physics",
    ],
)
def test_the_submission_path_imports_quietly_headless(code):
    out = _run("-c", code)
    assert out.returncode == 0 and out.stderr == "", out.stderr


def test_submit_command_prints_nothing_headless(tmp_path):
    out = _run("-m", "cpg_suite.protocol.submit", "--help", cwd=tmp_path)
    assert out.returncode == 0 and out.stderr == "", out.stderr


def test_a_script_prints_nothing_headless(tmp_path):
    """A user's script, run as a file: the README's pole example."""
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        (script, *_) = re.findall(r"```python\n(.*?)```", f.read(), flags=re.S)
    (tmp_path / "my_pole.py").write_text(script)
    out = _run(str(tmp_path / "my_pole.py"), cwd=tmp_path)
    assert out.returncode == 0 and out.stderr == "", out.stderr
    assert out.stdout.startswith("return ")


def test_rendering_still_works_where_a_backend_exists():
    """With MUJOCO_GL naming a backend that works here, the library renders, quietly."""
    backends = [
        b
        for b in cli._HEADLESS_BACKENDS
        if _run("-c", cli._PROBE, env={**HEADLESS, "MUJOCO_GL": b}).returncode == 0
    ]
    if not backends:
        pytest.skip("no headless OpenGL backend (EGL, OSMesa) on this machine")
    code = (
        "import cpg_suite\nenv = cpg_suite.load('pole_balance'); env.reset()\n"
        "print(env.physics.render(height=24, width=32).shape)"
    )
    out = _run("-c", code, env={**HEADLESS, "MUJOCO_GL": backends[0]})
    assert out.returncode == 0 and out.stderr == "", out.stderr
    assert out.stdout.strip() == "(24, 32, 3)"
