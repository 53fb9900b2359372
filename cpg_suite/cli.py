"""Command-line plumbing shared by every entry point (absl flags).

Every command reports bad input the same way: one line `error: <what is wrong>` on stderr
and exit code 2 — for flags absl cannot parse, for values our own checks reject, and for
output paths that cannot be written, all before any work starts.

A program chooses MuJoCo's rendering backend for itself before dm_control loads, in the
first lines of its module (`import cpg_suite` does not load dm_control):

    if __name__ == "__main__":
        from cpg_suite import cli

        cli.without_rendering()  # or cli.choose_renderer() in a program that renders

Importing this module changes nothing; only those two calls set `MUJOCO_GL`, and only in
the process that calls them.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import os
import re
import subprocess
import sys
from collections.abc import Callable, Sequence
from typing import TypeVar

from absl import flags

_Settings = TypeVar("_Settings")


class UsageError(Exception):
    """A bad flag value or combination; reported as one line, exit code 2."""


# dm_control's names for "no OpenGL backend" and the headless backends in the order tried.
_NO_RENDERER = "disable"
_HEADLESS_BACKENDS = ("egl", "osmesa")
# Creates and frees a small OpenGL context: whether a backend works on this machine.
_PROBE = "from dm_control._render import Renderer; Renderer(16, 16).free()"


def without_rendering() -> None:
    """Chooses no rendering backend for this process, unless `MUJOCO_GL` says otherwise.

    For programs that never render: dm_control then tries no OpenGL backend when it loads,
    so nothing prints GLFW's "DISPLAY is missing" warning. Call it before dm_control is
    imported (first thing under `if __name__ == "__main__":`).
    """
    os.environ.setdefault("MUJOCO_GL", _NO_RENDERER)


def rendering_child_env() -> dict[str, str]:
    """This process's environment for a child program that renders: without the
    `MUJOCO_GL` that `without_rendering` set here, so the child chooses its own backend."""
    env = dict(os.environ)
    if env.get("MUJOCO_GL") == _NO_RENDERER:
        del env["MUJOCO_GL"]
    return env


def choose_renderer() -> None:
    """Chooses a rendering backend that works, for a program that renders.

    With `MUJOCO_GL` set or a display (`DISPLAY`), dm_control's own choice stands.
    Otherwise each headless backend (EGL, then OSMesa) is tried in a child process and
    the first that creates an OpenGL context is set in `MUJOCO_GL`. Call it before
    dm_control is imported.

    Raises:
      SystemExit: With one `error:` line and code 2 if no headless backend works.
    """
    if "MUJOCO_GL" in os.environ or os.environ.get("DISPLAY"):
        return
    for backend in _HEADLESS_BACKENDS:
        probe = subprocess.run(
            [sys.executable, "-c", _PROBE],
            env={**os.environ, "MUJOCO_GL": backend},
            capture_output=True,
            timeout=120,
        )
        if probe.returncode == 0:
            os.environ["MUJOCO_GL"] = backend
            return
    fail(
        "no display and no headless OpenGL backend works here (tried MUJOCO_GL="
        f"{', '.join(_HEADLESS_BACKENDS)}); install EGL (libegl1) or OSMesa (libosmesa6)"
    )


def check_output_dir(path: str, flag: str) -> None:
    """Checks that a directory can be created (or written) at `path`, creating nothing.

    Args:
      path: The directory a command will write into.
      flag: The flag that named it, for the message (e.g. `--output_dir`).

    Raises:
      UsageError: Naming the path and why it cannot be written.
    """
    if os.path.exists(path):
        if not os.path.isdir(path):
            raise UsageError(f"{flag}={path}: exists and is not a directory")
        if not os.access(path, os.W_OK | os.X_OK):
            raise UsageError(f"{flag}={path}: directory is not writable")
        return
    _check_creatable(path, flag)


def check_output_file(path: str, flag: str) -> None:
    """Checks that a file can be written at `path`, creating nothing.

    Args:
      path: The file a command will write.
      flag: The flag that named it, for the message (e.g. `--out`).

    Raises:
      UsageError: Naming the path and why it cannot be written.
    """
    if os.path.isdir(path):
        raise UsageError(f"{flag}={path}: is a directory, expected a file")
    if os.path.exists(path):
        if not os.access(path, os.W_OK):
            raise UsageError(f"{flag}={path}: file is not writable")
        return
    _check_creatable(os.path.dirname(path) or ".", flag, shown=path)


def _check_creatable(path: str, flag: str, shown: str | None = None) -> None:
    """Raises `UsageError` unless the nearest existing ancestor of `path` is a writable
    directory (so that `os.makedirs(path)` can succeed)."""
    shown = path if shown is None else shown
    ancestor = os.path.abspath(path)
    while not os.path.exists(ancestor):
        ancestor = os.path.dirname(ancestor)
    if not os.path.isdir(ancestor):
        raise UsageError(f"{flag}={shown}: {_relative(ancestor)} is not a directory")
    if not os.access(ancestor, os.W_OK | os.X_OK):
        raise UsageError(f"{flag}={shown}: directory {_relative(ancestor)} is not writable")


def _relative(path: str) -> str:
    relative = os.path.relpath(path)
    return path if relative.startswith("..") else relative


def fail(message: str) -> None:
    """Prints `error: message` to stderr and exits with code 2."""
    sys.stderr.write(f"error: {message}\n")
    sys.stderr.flush()
    raise SystemExit(2)


HELP = ("--help", "-h", "-?", "--helpshort")
_PROJECT = tuple(
    os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), package) + os.sep
    for package in ("cpg_suite", "baselines", "analysis", "benchmarks", "investigations")
)


def _usage(doc: str | None) -> str:
    """The program's docstring up to its first paragraph after the usage lines."""
    paragraphs = (doc or "").strip().split("\n\n")
    return "\n\n".join(paragraphs[:2]).strip()


# How a flag's help says what leaving it out (default None) means: "none: <meaning>. <help>"
# at its start, or "(default: <meaning>)" / "(default <meaning>)" anywhere in it.
_NONE_LEAD = re.compile(r"^none: (?P<meaning>.+?)\.(\s+|$)")
_NONE_DEFAULT = re.compile(r"\s*\(default:? (?P<meaning>[^)]+)\)")
_REQUIRED = "must have a value other than None"  # absl's required-flag validator


def flag_default(flag: flags.Flag) -> tuple[str, str]:
    """What a flag's help line shows: its default, in words, and its help text.

    A flag with a default shows it (`[2]`, `[darwin_walk]`, `[""]`). A flag whose default
    is None shows `[required]` if absl requires it, else `[none: <meaning>]`, the meaning
    taken from its help ("none: <meaning>. ..." at the start, or "(default: <meaning>)"),
    and moved out of the help text ("none: required." shows `[required]` too); `[none]` if
    its help says nothing of it.

    Args:
      flag: An absl flag.

    Returns:
      (the default's words, without brackets; the help text on one line).
    """
    text = " ".join((flag.help or "").split())
    if flag.default is not None:
        shown = flag.default_as_str
        shown = shown[1:-1] if len(shown) >= 2 and shown[0] == shown[-1] == "'" else shown
        return (shown if shown else '""'), text
    if any(_REQUIRED in getattr(v, "message", "") for v in flag.validators):
        return "required", text
    for pattern in (_NONE_LEAD, _NONE_DEFAULT):
        found = pattern.search(text)
        if found:
            rest = (text[: found.start()] + text[found.end() :]).strip()
            rest = rest[:1].upper() + rest[1:]
            meaning = found.group("meaning").strip()
            return ("required" if meaning == "required" else f"none: {meaning}"), rest
    return "none", text


def help_text(doc: str | None = None) -> str:
    """One screen of help: the program's usage, then every flag the project defines for
    it (absl's own are under --helpfull), one line each with its default (`flag_default`)."""
    lines = [_usage(doc), "", "flags (defaults in brackets; --helpfull lists absl's too):"]
    for module, defined in sorted(flags.FLAGS.flags_by_module_dict().items()):
        dotted = module.split(".")[0] in (
            "cpg_suite",
            "baselines",
            "analysis",
            "benchmarks",
            "investigations",
        )
        if not (dotted or os.path.abspath(module).startswith(_PROJECT)):
            continue
        for flag in sorted(defined, key=lambda f: f.name):
            default, text = flag_default(flag)
            lines.append(f"  --{flag.name} [{default}]: {text}")
    return "\n".join(lines) + "\n"


def _parse_flags(argv: list[str]) -> list[str]:
    if any(arg in HELP for arg in argv[1:]):
        sys.stdout.write(help_text(getattr(sys.modules.get("__main__"), "__doc__", None)))
        raise SystemExit(0)
    try:
        return flags.FLAGS(argv)
    except flags.Error as e:
        fail(str(e).splitlines()[0] if str(e) else "invalid flags")
        raise  # unreachable


def run(
    main: Callable[[list[str]], None],
    *,
    output_dirs: Sequence[str] = (),
    output_files: Sequence[str] = (),
) -> None:
    """`absl.app.run(main)` with one-line errors and exit code 2 for bad input.

    The flags named in `output_dirs` and `output_files` are checked (`check_output_dir`,
    `check_output_file`) after parsing and before `main` runs, so a path that cannot be
    written stops the program before any work. `absl.app` defines flags of its own when
    imported, so it is imported here, by the program that runs, not by the modules that
    merely import this one.

    Args:
      main: The program; raises `UsageError` for bad input found while it runs.
      output_dirs: Names of flags that give directories the program writes into.
      output_files: Names of flags that give files the program writes.
    """
    from absl import app, logging

    def wrapped(argv: list[str]) -> None:
        if len(argv) > 1:
            fail(f"unexpected arguments {argv[1:]}; all options are --flags")
        if not flags.FLAGS["verbosity"].present:  # no INFO lines of libraries loaded in main
            logging.set_verbosity(logging.WARNING)
        try:
            for name, check_path in [(n, check_output_dir) for n in output_dirs] + [
                (n, check_output_file) for n in output_files
            ]:
                if flags.FLAGS[name].value:
                    check_path(flags.FLAGS[name].value, f"--{name}")
            main(argv)
        except UsageError as e:
            fail(str(e))

    app.run(wrapped, flags_parser=_parse_flags)


def check(condition: bool, message: str) -> None:
    """Raises `UsageError(message)` unless `condition` holds."""
    if not condition:
        raise UsageError(message)


def parse_seeds(text: str) -> list[int]:
    """Parses `"0-9"`, `"3"`, or `"0,2,5"` into a list of seeds.

    Raises:
      UsageError: If the text is malformed or a range is empty.
    """
    seeds: list[int] = []
    try:
        for part in str(text).split(","):
            part = part.strip()
            if "-" in part:
                lo, hi = (int(v) for v in part.split("-"))
                if hi < lo:
                    raise ValueError
                seeds.extend(range(lo, hi + 1))
            else:
                seeds.append(int(part))
    except ValueError:
        raise UsageError(f"malformed seeds {text!r}; use N, A-B or a comma list") from None
    if any(s < 0 for s in seeds):
        raise UsageError(f"seeds must be ≥ 0, got {text!r}")
    return seeds


def settings_from_flags(cls: type[_Settings], **overrides) -> _Settings:
    """Builds the settings dataclass `cls` from the absl flags named like its fields.

    Each CLI is a thin layer: it defines flags named after the fields of its settings
    dataclass, and this function collects them; the dataclass validates itself.

    Args:
      cls: A dataclass whose `__post_init__` raises `ValueError` on invalid values.
      **overrides: Field values that replace the flags' (e.g. derived defaults).

    Returns:
      The validated settings.

    Raises:
      UsageError: With the dataclass's one-line reason.
    """
    values = {
        field.name: flags.FLAGS[field.name].value
        for field in dataclasses.fields(cls)
        if field.name in flags.FLAGS
    }
    values.update(overrides)
    try:
        return cls(**values)
    except ValueError as e:
        raise UsageError(str(e)) from None


def require(condition: bool, message: str) -> None:
    """Raises `ValueError(message)` unless `condition` holds (for settings validation)."""
    if not condition:
        raise ValueError(message)


def _bound(value: float) -> str:
    return (
        f"{value:g}" if abs(value) < 1e5 else f"{value:.0e}".replace("e+0", "e").replace("e+", "e")
    )


def valid_range(
    low: float | None = None,
    high: float | None = None,
    *,
    low_open: bool = False,
    high_open: bool = False,
) -> str:
    """The words for a range of finite numbers: "in [0, 1)", "> 0", "≤ 5", "finite"."""
    if low is not None and high is not None:
        return (
            f"in {'(' if low_open else '['}{_bound(low)}, {_bound(high)}{')' if high_open else ']'}"
        )
    if low is not None:
        return f"{'>' if low_open else '≥'} {_bound(low)}"
    if high is not None:
        return f"{'<' if high_open else '≤'} {_bound(high)}"
    return "finite"


def require_number(
    flag: str,
    value,
    low: float | None = None,
    high: float | None = None,
    *,
    low_open: bool = False,
    high_open: bool = False,
    prefix: str = "--",
) -> None:
    """Checks that a numeric setting is a finite number in its range (for settings validation).

    Every float setting of the typed settings objects goes through this check, so NaN,
    infinities and out-of-range values get the same one-line message naming the flag and
    what is valid, e.g. "--noise must be a finite number ≥ 0, got nan".

    Args:
      flag: The setting's flag name, without dashes.
      value: The value to check.
      low, high: The range's ends (None: unbounded on that side).
      low_open, high_open: Whether an end itself is excluded.
      prefix: Put before the name in the message ("" for a setting that is not a flag).

    Raises:
      ValueError: If `value` is not a real number, not finite, or outside the range.
    """
    words = valid_range(low, high, low_open=low_open, high_open=high_open)
    message = f"{prefix}{flag} must be a finite number {words}, got {value!r}"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(message)
    x = float(value)
    inside = math.isfinite(x)
    if inside and low is not None:
        inside = x > low if low_open else x >= low
    if inside and high is not None:
        inside = x < high if high_open else x <= high
    if not inside:
        raise ValueError(message)


def require_integer(flag: str, value, low: int | None = None, high: int | None = None) -> None:
    """Checks that an integer setting is an integer in [low, high] (for settings validation).

    Args:
      flag: The setting's flag name, without dashes.
      value: The value to check (a float such as 2.0 is not an integer setting).
      low, high: The range's ends, included (None: unbounded on that side).

    Raises:
      ValueError: "--FLAG must be an integer in [low, high], got VALUE".
    """
    inside = isinstance(value, numbers.Integral) and not isinstance(value, bool)
    inside = inside and (low is None or value >= low) and (high is None or value <= high)
    if not inside:
        raise ValueError(f"--{flag} must be an integer {valid_range(low, high)}, got {value!r}")


def require_scoring(validation_seeds: int, test_seeds: int, test_tiers) -> tuple[str, ...]:
    """Checks a policy learner's validation seeds, test seeds and score-card tiers.

    Args:
      validation_seeds: Validation seeds the policy is selected on (1 .. 1,000,000).
      test_seeds: Test seeds per tier (0: no score card .. 50).
      test_tiers: The score card's tiers (`cpg_suite.protocol.TIERS`), any iterable.

    Returns:
      The tiers as a tuple.

    Raises:
      ValueError: Naming the first bad value and what is valid.
    """
    from cpg_suite import protocol

    require(
        isinstance(validation_seeds, int) and 1 <= validation_seeds <= len(protocol.VALIDATION),
        f"--validation_seeds must lie in [1, {len(protocol.VALIDATION)}], got {validation_seeds!r}",
    )
    require(
        0 <= test_seeds <= len(protocol.TEST),
        f"--test_seeds must lie in [0, {len(protocol.TEST)}], got {test_seeds}",
    )
    tiers = tuple(test_tiers)
    unknown = [t for t in tiers if t not in protocol.TIERS]
    require(
        bool(tiers) and not unknown,
        f"unknown --test_tiers {unknown or list(tiers)}; valid: {', '.join(protocol.TIERS)}",
    )
    return tiers


BACKENDS = ("local", "ray")  # where runs and trials execute (`cpg_suite.evaluation.ray_backend`)


def require_backend(backend: str, ray_address: str | None = None) -> None:
    """Raises `ValueError` unless `backend` is one of `BACKENDS` and a Ray address comes
    only with the Ray backend (the local one would ignore it)."""
    require(backend in BACKENDS, f"--backend must be one of {', '.join(BACKENDS)}, got {backend!r}")
    require(
        ray_address is None or backend == "ray",
        f"--ray_address={ray_address} needs --backend=ray (got --backend={backend})",
    )


def define_backend_flags() -> None:
    """`--backend` and `--ray_address` (the settings fields `backend`, `ray_address`)."""
    flags.DEFINE_enum("backend", "local", list(BACKENDS), "local threads, or Ray (same results).")
    flags.DEFINE_string(
        "ray_address",
        None,
        "none: a private local Ray instance. Ray cluster: host:port of its head, or auto.",
    )


# What the optimizers tune and the scorer scores: the study's open-loop CPG amplitudes, or
# the feedback CPG's parameters (`cpg_suite.feedback`).
CONTROLLERS = ("open_loop", "feedback")


def require_controller(controller: str) -> None:
    """Raises `ValueError` unless `controller` is one of `CONTROLLERS`."""
    require(
        controller in CONTROLLERS,
        f"--controller must be one of {', '.join(CONTROLLERS)}, got {controller!r}",
    )
