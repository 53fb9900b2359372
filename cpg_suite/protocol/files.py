"""A run folder's files, read as the board reads them: plain files of the folder's own, of a
bounded size, parsed strictly (docs/protocol.md#admission).

A run folder comes from whoever submitted it. Before anything in it is parsed, each file
the board or verify reads must be a regular file (not a symbolic link, which could point at
another run's files, at a file outside the tree or at a device such as `/dev/zero`) of at
most `MAX_BYTES`; JSON must be strict (no repeated key, whose first and last values a
reader and a reviewer see differently; no NaN or Infinity, which JSON does not have); a
CSV table's header names each column once.
"""

from __future__ import annotations

import json
import math
import os
import stat

# Bytes a run file may hold (a choice: 30 times the largest shipped run file, a 1.9 MB
# Stable-Baselines3 zip; a trial table is 15 kB, a summary 30 kB).
MAX_BYTES = 64 * 2**20


def refusal(path: str) -> str | None:
    """Why a run file may not be read (None: it may): a symbolic link, not a regular file,
    larger than `MAX_BYTES`, or one that cannot be opened (its permissions). A missing file
    is the caller's question (None here).

    Args:
      path: The file's path.

    Returns:
      A one-line reason naming the file, or None.
    """
    name = os.path.basename(path)
    try:
        info = os.lstat(path)
    except FileNotFoundError:
        return None
    except OSError as e:
        return f"{name} cannot be read ({type(e).__name__})"
    if stat.S_ISLNK(info.st_mode):
        return f"{name} is a symbolic link, not a file of the run's own"
    if not stat.S_ISREG(info.st_mode):
        return f"{name} is not a regular file"
    if info.st_size > MAX_BYTES:
        return f"{name} holds {info.st_size} bytes, over the {MAX_BYTES} a run file may hold"
    try:  # a regular file: opening it neither blocks nor follows a link
        with open(path, "rb"):
            pass
    except OSError as e:
        return f"{name} cannot be read ({type(e).__name__})"
    return None


def read_bytes(path: str) -> bytes:
    """A run file's bytes, if `refusal` allows it.

    Raises:
      OSError: If it cannot be read.
      ValueError: With `refusal`'s reason.
    """
    reason = refusal(path)
    if reason:
        raise ValueError(reason)
    with open(path, "rb") as f:
        return f.read(MAX_BYTES + 1)


def _strict_object(pairs: list[tuple[str, object]]) -> dict:
    keys = [k for k, _ in pairs]
    repeated = sorted({k for k in keys if keys.count(k) > 1})
    if repeated:
        raise ValueError(f"the key {repeated[0]!r} appears twice in one object")
    return dict(pairs)


def _no_constant(name: str):
    raise ValueError(f"{name} is not a JSON number")


def _bounded_int(text: str) -> int:
    """A JSON integer, refused beyond a 64-bit integer's range (a 400-digit count overflowed
    the board's float conversion: an outside attack of 2026-11-29)."""
    value = int(text) if len(text.lstrip("-")) <= 19 else None  # no 400-digit conversion
    if value is None or not -(2**63) <= value < 2**63:
        raise ValueError(f"{text[:24]}{'...' if len(text) > 24 else ''} does not fit 64 bits")
    return value


def _finite_float(text: str) -> float:
    """A JSON number as a float, refused if it does not fit one (1e309 is not infinity)."""
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"{text} does not fit a float")
    return value


# The most a run's JSON file may hold: the largest shipped holds 30,927 bytes (a PPO run's
# summary.json); a summary padded to 64 MiB of empty objects took the board 7 minutes and
# 4.9 GB to read (an outside attack of 2026-11-29). A choice: 1 MiB, 33 times the largest.
MAX_JSON_BYTES = 2**20
# How deep a run's JSON may nest: the deepest shipped file nests 7 levels; a deeper one
# would send the board's recursive card comparisons past Python's recursion limit (an
# outside attack of 2026-11-29). A choice, with room to spare.
MAX_JSON_DEPTH = 32


def _depth(value: object) -> int:
    """How many lists and objects deep `value` nests (without recursion)."""
    deepest, stack = 0, [(value, 0)]
    while stack:
        node, level = stack.pop()
        if isinstance(node, (dict, list)):
            deepest = max(deepest, level + 1)
            stack.extend(
                (child, level + 1) for child in (node.values() if isinstance(node, dict) else node)
            )
    return deepest


def read_json(path: str) -> object:
    """A run's JSON file, strictly: a regular file (`refusal`), each key once per object,
    no NaN or Infinity (nor a float too large for one, nor an integer beyond 64 bits), at
    most `MAX_JSON_BYTES` long and nesting at most `MAX_JSON_DEPTH` lists and objects deep.

    Raises:
      OSError: If it cannot be read.
      ValueError: If it may not be read, or is not strict JSON (the message says why).
    """
    data = read_bytes(path)
    if len(data) > MAX_JSON_BYTES:
        raise ValueError(
            f"{os.path.basename(path)} holds {len(data)} bytes, over the {MAX_JSON_BYTES} a "
            "run's JSON file may hold"
        )
    text = data.decode("utf-8")
    too_deep = f"{os.path.basename(path)}: nested more than {MAX_JSON_DEPTH} lists and objects deep"
    try:
        value = json.loads(
            text,
            object_pairs_hook=_strict_object,
            parse_constant=_no_constant,
            parse_float=_finite_float,
            parse_int=_bounded_int,
        )
    except RecursionError:
        raise ValueError(too_deep) from None
    except ValueError as e:
        raise ValueError(f"{os.path.basename(path)}: {e}") from None
    if _depth(value) > MAX_JSON_DEPTH:
        raise ValueError(too_deep)
    return value


def read_text(path: str) -> str:
    """A run's text file (a CSV table), if `refusal` allows it.

    Raises:
      OSError: If it cannot be read.
      ValueError: If it may not be read.
    """
    return read_bytes(path).decode("utf-8")


# The deepest folder a walk of a run tree enters, counted from the folder it is given: the
# board's runs lie at `<method>/<task>/<run>` (3), the study's a little deeper (the deepest
# shipped run folder is 5 below results/). A choice: deeper folders are listed, not
# entered (an 1,100-deep tree crashed Python 3.11's recursive `os.walk`: helper-51).
MAX_TREE_DEPTH = 16


def walk_sorted(root: str, too_deep: list[str] | None = None):
    """`os.walk(root)` top-down in name order, without recursion and at most
    `MAX_TREE_DEPTH` folders deep: yields `(dirpath, dirnames, filenames)`, both lists
    sorted, a link to a folder listed among the folders and never entered (as `os.walk`
    lists and skips it), an unreadable folder skipped (as `os.walk` does).

    Args:
      root: The folder to walk.
      too_deep: Where to append each folder left unread for its depth (None: nowhere).
    """
    stack = [(root, 0)]
    while stack:
        dirpath, depth = stack.pop()
        try:
            with os.scandir(dirpath) as entries:
                listed = [(entry.name, _is_dir(entry)) for entry in entries]
        except OSError:
            continue
        dirnames = sorted(name for name, is_dir in listed if is_dir)
        yield dirpath, dirnames, sorted(name for name, is_dir in listed if not is_dir)
        below = [os.path.join(dirpath, n) for n in dirnames]
        below = [path for path in below if not os.path.islink(path)]
        if depth >= MAX_TREE_DEPTH:
            if too_deep is not None:
                too_deep.extend(below)
            continue
        stack.extend((path, depth + 1) for path in reversed(below))


def _is_dir(entry: os.DirEntry) -> bool:
    """`entry.is_dir()` as `os.walk` reads it (a link to a folder counts; an error: no)."""
    try:
        return entry.is_dir()
    except OSError:
        return False
