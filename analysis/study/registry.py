"""The rule of each testable claim of the catalog, by id.

A rule takes the evidence (`analysis.study.evidence.Evidence`) and returns a `Verdict`; chapters
register theirs with `@rule("CEM-3a")`. A whole claim split into parts has no rule of its
own: its verdict combines its parts' (`verdicts.combine`).
"""

from __future__ import annotations

from collections.abc import Callable

from analysis.study.evidence import Evidence
from analysis.study.verdicts import Verdict

Rule = Callable[[Evidence], Verdict]
RULES: dict[str, Rule] = {}


def rule(claim_id: str) -> Callable[[Rule], Rule]:
    """Registers the decorated function as the rule of `claim_id`.

    Raises:
      ValueError: If the id has a rule already.
    """

    def register(fn: Rule) -> Rule:
        if claim_id in RULES:
            raise ValueError(f"{claim_id} has a rule already ({RULES[claim_id].__name__})")
        RULES[claim_id] = fn
        return fn

    return register
