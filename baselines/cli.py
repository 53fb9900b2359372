"""Command-line plumbing shared by the baselines (absl flags).

Every baseline reports bad input the same way: one line `error: <what is wrong>` on
stderr and exit code 2 — for flags absl cannot parse as well as for values our own
checks reject.
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Callable
from typing import TypeVar

from absl import flags

_Settings = TypeVar("_Settings")


class UsageError(Exception):
    """A bad flag value or combination; reported as one line, exit code 2."""


def fail(message: str) -> None:
    """Prints `error: message` to stderr and exits with code 2."""
    sys.stderr.write(f"error: {message}\n")
    sys.stderr.flush()
    raise SystemExit(2)


def _parse_flags(argv: list[str]) -> list[str]:
    try:
        return flags.FLAGS(argv)
    except flags.Error as e:
        fail(str(e).splitlines()[0] if str(e) else "invalid flags")
        raise  # unreachable


def run(main: Callable[[list[str]], None]) -> None:
    """`absl.app.run(main)` with one-line errors and exit code 2 for bad input.

    `absl.app` defines flags of its own when imported, so it is imported here, by the
    program that runs, not by the modules that merely import this one.
    """
    from absl import app

    def wrapped(argv: list[str]) -> None:
        if len(argv) > 1:
            fail(f"unexpected arguments {argv[1:]}; all options are --flags")
        from baselines.ray_backend import ClusterUnreachable

        try:
            main(argv)
        except (UsageError, ClusterUnreachable) as e:
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


BACKENDS = ("local", "ray")  # where runs and trials execute (`baselines.ray_backend`)


def require_backend(backend: str) -> None:
    """Raises `ValueError` unless `backend` is one of `BACKENDS`."""
    require(backend in BACKENDS, f"--backend must be one of {', '.join(BACKENDS)}, got {backend!r}")


def define_backend_flags() -> None:
    """`--backend` and `--ray_address` (the settings fields `backend`, `ray_address`)."""
    flags.DEFINE_enum("backend", "local", list(BACKENDS), "local threads, or Ray (same results).")
    flags.DEFINE_string("ray_address", None, "Ray cluster: host:port of its head, or auto.")


# What the optimizers tune and the scorer scores: the study's open-loop CPG amplitudes, or
# the feedback CPG's parameters (`cpg_suite.feedback`).
CONTROLLERS = ("open_loop", "feedback")


def require_controller(controller: str) -> None:
    """Raises `ValueError` unless `controller` is one of `CONTROLLERS`."""
    require(
        controller in CONTROLLERS,
        f"--controller must be one of {', '.join(CONTROLLERS)}, got {controller!r}",
    )
