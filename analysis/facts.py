"""Numbers the README and the docs quote from the shipped runs, filled in from the runs.

A quoted number stands between two markers, the fact's name and argument in the first:

    scored <!-- fact: test_range ppo_mjx/darwin_walk/cpg_v1_seed* -->3.98-5.39<!-- /fact --> m

`python -m analysis.rebuild` writes each fact's value from the files (`fill`), and
`--check` fails where a page's text differs from its rebuild, so a number quoted this way
cannot go stale. The facts (`FACTS`), each a function of the shipped runs' folder and
its argument (a glob of run folders under it, relative to it):

* `runs`: how many runs ship (folders with a summary.json);
* `seeds GLOB`: how many runs match;
* `test_range GLOB`: the lowest and highest test score (success-weighted distance over
  every tier, m) of the matching runs, under the benchmark version they are scored with;
* `v1_test_range GLOB`, `v2_test_range GLOB`: the same, of their version-1 (version-2)
  cards kept as history;
* `test_mean GLOB`: the mean test score of the matching runs (m);
* `tier_failures GLOB`: per tier of their cards, in the card's order, the share of failed
  trials over the matching runs (%, one decimal, joined by " / ");
* `validation_range GLOB`: the lowest and highest validation score of the selected
  policy or gait (m);
* `train_s_range GLOB`: the lowest and highest training wall time (s, `train_wall_s`).
"""

from __future__ import annotations

import glob
import json
import os
import re
from collections.abc import Callable

PATTERN = re.compile(r"<!-- fact: ([a-z0-9_]+)(?: ([^ ]+))? -->(.*?)<!-- /fact -->", re.S)


def _summaries(runs: str, pattern: str) -> list[dict]:
    """The summary.json of every run folder matching `pattern` under `runs`.

    Raises:
      ValueError: If none matches.
    """
    paths = sorted(glob.glob(os.path.join(runs, pattern, "summary.json")))
    if not paths:
        raise ValueError(f"no shipped run matches {pattern!r} under {runs}")
    found = []
    for path in paths:
        with open(path, encoding="utf-8") as f:
            found.append(json.load(f))
    return found


def _range(values: list[float], spec: str = ".2f") -> str:
    """`low-high` as `spec` writes them, or one value where both read the same."""
    low, high = format(min(values), spec), format(max(values), spec)
    return low if low == high else f"{low}-{high}"


def _test(card: dict) -> float:
    return card["all"]["success_weighted_distance_m"]["mean"]


def _runs(runs: str, arg: str | None) -> str:
    del arg
    return str(len(glob.glob(os.path.join(runs, "*", "*", "*", "summary.json"))))


def _seeds(runs: str, arg: str | None) -> str:
    return str(len(_summaries(runs, _required(arg))))


def _test_range(runs: str, arg: str | None) -> str:
    return _range([_test(s["test"]) for s in _summaries(runs, _required(arg))])


def _history_test_range(version: int) -> Callable[[str, str | None], str]:
    def fact(runs: str, arg: str | None) -> str:
        found = _summaries(runs, _required(arg))
        return _range([_test(s["history"][f"v{version}"]) for s in found])

    return fact


def _test_mean(runs: str, arg: str | None) -> str:
    scores = [_test(s["test"]) for s in _summaries(runs, _required(arg))]
    return format(sum(scores) / len(scores), ".2f")


def _tier_failures(runs: str, arg: str | None) -> str:
    cards = [s["test"] for s in _summaries(runs, _required(arg))]
    tiers = list(cards[0]["tiers"])
    if any(list(c["tiers"]) != tiers for c in cards):
        raise ValueError(f"the runs matching {arg!r} have cards of different tiers")
    shares = [
        100 * sum(c["tiers"][t]["fall_rate"]["value"] for c in cards) / len(cards) for t in tiers
    ]
    return " / ".join(format(x, ".1f") for x in shares)


def _validation_range(runs: str, arg: str | None) -> str:
    found = _summaries(runs, _required(arg))
    return _range([s["selected"]["validation_success_weighted_m"] for s in found])


def _train_s_range(runs: str, arg: str | None) -> str:
    return _range([s["train_wall_s"] for s in _summaries(runs, _required(arg))], ",.0f")


def _required(arg: str | None) -> str:
    if not arg:
        raise ValueError("this fact needs a glob of run folders")
    return arg


FACTS: dict[str, Callable[[str, str | None], str]] = {
    "runs": _runs,
    "seeds": _seeds,
    "test_range": _test_range,
    "v1_test_range": _history_test_range(1),
    "v2_test_range": _history_test_range(2),
    "test_mean": _test_mean,
    "tier_failures": _tier_failures,
    "validation_range": _validation_range,
    "train_s_range": _train_s_range,
}


def fill(text: str, runs: str) -> str:
    """`text` with every fact's value written from the shipped runs.

    Args:
      text: A markdown page.
      runs: The shipped runs' folder (`results/protocol/runs`).

    Returns:
      The page, each fact's value between its markers made again.

    Raises:
      ValueError: On an unknown fact, a fact without its argument, or one whose glob
        matches no shipped run.
    """

    def value(match: re.Match) -> str:
        name, arg = match.group(1), match.group(2)
        if name not in FACTS:
            raise ValueError(f"unknown fact {name!r}; known: {', '.join(FACTS)}")
        head = f"<!-- fact: {name}{' ' + arg if arg else ''} -->"
        return f"{head}{FACTS[name](runs, arg)}<!-- /fact -->"

    return PATTERN.sub(value, text)


def pages(root: str = ".") -> list[str]:
    """The pages whose facts are filled: the README, every page under docs/ and every
    README under results/."""
    found = [os.path.join(root, "README.md")]
    for pattern in (("docs", "*.md"), ("results", "README.md"), ("results", "*", "README.md")):
        found += sorted(glob.glob(os.path.join(root, *pattern)))
    return found
