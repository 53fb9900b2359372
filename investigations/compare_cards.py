"""The shipped runs' test cards at a git revision beside the cards in the working tree.

    python investigations/compare_cards.py --before=REV

prints a Markdown table, one row per shipped run whose card or trials differ: the all-tier
success-weighted distance with its 95 % interval and the falls per tier (of the trials per
tier) before and now, and how many trials changed; then the range of the changes. It reads
the old files with `git show REV:PATH`, so run it from the repository.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # the repository
RUNS = os.path.join("results", "protocol", "runs")
sys.path.insert(0, ROOT)
from cpg_suite.protocol import TIERS  # noqa: E402  (every version's tiers, in the card's order)


def _at(revision: str | None, path: str) -> str:
    if revision is None:
        with open(os.path.join(ROOT, path), encoding="utf-8") as f:
            return f.read()
    return subprocess.run(
        ["git", "show", f"{revision}:{path}"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout


def _card(revision: str | None, run: str) -> tuple[dict, list[dict]]:
    summary = json.loads(_at(revision, f"{run}/summary.json"))["test"]
    trials = list(csv.DictReader(io.StringIO(_at(revision, f"{run}/trials.csv"))))
    return summary, trials


def _cell(card: dict, trials: list[dict]) -> str:
    score = card["all"]["success_weighted_distance_m"]
    falls = [sum(t["fell"] == "True" for t in trials if t["tier"] == tier) for tier in TIERS]
    low, high = score["ci95"]
    return f"{score['mean']:.3f} m [{low:.3f}, {high:.3f}], {'/'.join(map(str, falls))}"


def shipped() -> list[str]:
    """The shipped runs' folders, relative to the repository, sorted."""
    found = []
    for dirpath, _, names in os.walk(os.path.join(ROOT, RUNS)):
        if "summary.json" in names and "trials.csv" in names:
            found.append(os.path.relpath(dirpath, ROOT))
    return sorted(found)


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", required=True, help="git revision of the old cards")
    args = parser.parse_args(argv)
    print(
        "| run | before: all tiers [95 % CI], falls nom./rand./push/rough | now | trials changed |"
    )
    print("|---|---|---|---:|")
    moves, unchanged = [], 0
    for run in shipped():
        old, old_trials = _card(args.before, run)
        new, new_trials = _card(None, run)
        changed = sum(a != b for a, b in zip(old_trials, new_trials))
        if old == new and not changed:
            unchanged += 1
            continue
        name = os.path.relpath(run, RUNS)
        print(
            f"| {name} | {_cell(old, old_trials)} | {_cell(new, new_trials)} | "
            f"{changed} of {len(new_trials)} |"
        )
        before = old["all"]["success_weighted_distance_m"]["mean"]
        moves.append(new["all"]["success_weighted_distance_m"]["mean"] - before)
    print()
    if moves:
        print(
            f"{len(moves)} runs changed, {unchanged} did not; all-tier scores moved by "
            f"{min(moves):+.3f} to {max(moves):+.3f} m"
        )
    else:
        print(f"no run changed ({unchanged} compared)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
