"""Progress bars with elapsed time and an estimate of the time left, for long jobs.

A thin wrapper over `tqdm`, which follows its own convention: the bar is drawn on stderr
when stderr is a terminal and stays quiet otherwise (logs, CI, pipes), so the lines a job
prints itself are the record of what it did.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import TypeVar

from tqdm.auto import tqdm

_T = TypeVar("_T")


def track(
    iterable: Iterable[_T], *, total: int | None = None, desc: str = "", unit: str = "it"
) -> Iterator[_T]:
    """Iterates over `iterable` with a progress bar (elapsed, ETA) on a terminal.

    Args:
      iterable: The items of the job.
      total: Their number when `iterable` has no length.
      desc: A label in front of the bar.
      unit: What one item is ("run", "round", ...).

    Returns:
      An iterator over the same items.
    """
    return iter(tqdm(iterable, total=total, desc=desc, unit=unit, disable=None, leave=False))


def write(line: str) -> None:
    """Prints `line` (stdout, flushed) without breaking a progress bar drawn on stderr."""
    tqdm.write(line)
