"""The catalog of the thesis' distinct claims (`analysis/catalog.csv`).

Each row: its id (a part's id ends in a letter and names its whole claim in `parent`), the
chapter and place in the thesis, the statement in our words, the setting the thesis used,
what is measured, the criterion (written before the runs), the published numbers it
states or rests on (`analysis/published.csv` ids), the rows it absorbs, the evidence family,
and whether it is testable here (or why not).
"""

from __future__ import annotations

import csv
import importlib.resources

FIELDS = (
    "id",
    "parent",
    "chapter",
    "place",
    "statement",
    "setting",
    "measure",
    "criterion",
    "numbers",
    "merged",
    "evidence",
    "testable",
)


def load() -> list[dict]:
    """The catalog's rows in file order.

    Raises:
      ValueError: On a duplicate id, a part whose parent is missing, or other columns.
    """
    text = importlib.resources.files("analysis").joinpath("catalog.csv").read_text("utf-8")
    rows = list(csv.DictReader(text.splitlines()))
    if rows and tuple(rows[0]) != FIELDS:
        raise ValueError(f"catalog.csv columns {tuple(rows[0])}, expected {FIELDS}")
    ids = [r["id"] for r in rows]
    duplicates = sorted({i for i in ids if ids.count(i) > 1})
    if duplicates:
        raise ValueError(f"catalog.csv repeats ids {duplicates}")
    orphans = [r["id"] for r in rows if r["parent"] and r["parent"] not in ids]
    if orphans:
        raise ValueError(f"catalog.csv parts without their whole claim: {orphans}")
    return rows


def parts_of(rows: list[dict]) -> dict[str, list[str]]:
    """Whole claim id -> its parts' ids (only claims that have parts)."""
    parts: dict[str, list[str]] = {}
    for r in rows:
        if r["parent"]:
            parts.setdefault(r["parent"], []).append(r["id"])
    return parts
