"""The analysis commands reject bad input with one `error:` line and exit code 2, at once.

Each runs as a program without a display or `MUJOCO_GL` (as in CI) and must fail before any
work: an unknown flag, an `--out` that cannot be created (under a regular file), a `--runs`
that is not a directory, and a missing `--quick`/`--full` leave nothing written.
"""

import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REGULAR_FILE = os.path.join(ROOT, "setup.py")
BAD_OUT = os.path.join(REGULAR_FILE, "x")  # under a regular file: can never be created
_RENDERING = ("MUJOCO_GL", "DISPLAY", "PYOPENGL_PLATFORM")  # unset: as on a headless machine


# (module, flags, words the error line must contain); {tmp} is the test's folder, in which
# runs/ and other.csv (not a leaderboard) exist and nope/ does not.
_RUNS, _MISSING = "--runs={tmp}/runs", "--runs={tmp}/nope"
_UNKNOWN = ["Unknown command line flag 'bogus'"]
_BAD_OUT = [f"--out={BAD_OUT}", "setup.py is not a directory"]
_NOT_DIR = ["--runs={tmp}/nope is not a directory"]
CASES = {
    "leaderboard-unknown-flag": (
        "leaderboard",
        [_RUNS, "--out={tmp}/o/l.csv", "--bogus"],
        _UNKNOWN,
    ),
    "leaderboard-bad-out": ("leaderboard", [_RUNS, f"--out={BAD_OUT}"], _BAD_OUT),
    "leaderboard-missing-runs": ("leaderboard", [_MISSING, "--out={tmp}/o/l.csv"], _NOT_DIR),
    "report-unknown-flag": ("report", [_RUNS, "--out={tmp}/o", "--bogus"], _UNKNOWN),
    "report-bad-out": ("report", [_RUNS, f"--out={BAD_OUT}"], _BAD_OUT),
    "report-missing-runs": ("report", [_MISSING, "--out={tmp}/o"], _NOT_DIR),
    "reproduce-unknown-flag": ("reproduce", ["--quick", "--out={tmp}/o", "--bogus"], _UNKNOWN),
    "reproduce-bad-out": ("reproduce", ["--quick", f"--out={BAD_OUT}"], _BAD_OUT),
    "reproduce-no-size": ("reproduce", ["--out={tmp}/o"], ["exactly one of --quick and --full"]),
    "reproduce-both-sizes": (
        "reproduce",
        ["--quick", "--full", "--out={tmp}/o"],
        ["exactly one of --quick and --full"],
    ),
    "table6_3-unknown-flag": ("table6_3", [_RUNS, "--bogus"], _UNKNOWN),
    "table6_3-bad-out": ("table6_3", [_RUNS, f"--out={BAD_OUT}"], _BAD_OUT),
    "table6_3-missing-runs": ("table6_3", [_MISSING], _NOT_DIR),
}


def _tree(path) -> list[str]:
    return sorted(str(p.relative_to(path)) for p in path.rglob("*"))


@pytest.mark.parametrize("case", list(CASES))
def test_bad_input_is_one_error_line_and_exit_code_2(tmp_path, case):
    (tmp_path / "runs").mkdir()
    (tmp_path / "other.csv").write_text("rank,score\n1,2\n")
    module, args, words = CASES[case]
    args = [a.format(tmp=tmp_path) for a in args]
    words = [w.format(tmp=tmp_path) for w in words]
    env = {k: v for k, v in os.environ.items() if k not in _RENDERING}
    before = _tree(tmp_path)
    out = subprocess.run(
        [sys.executable, "-m", f"analysis.{module}", *args],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
        timeout=60,
    )
    assert out.returncode == 2, (module, args, out.stdout, out.stderr)
    lines = out.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), out.stderr
    for word in words:
        assert word in lines[0], (word, lines[0])
    assert out.stdout == ""
    assert _tree(tmp_path) == before  # nothing written
    assert os.path.isfile(REGULAR_FILE)
