r"""Rebuilds the study's verdicts, the published numbers beside ours, and the report.

  python -m analysis.study                       # into results/study/
  python -m analysis.study --out=DIR             # elsewhere (e.g. to compare)

Reads the catalog (`analysis/catalog.csv`), the published numbers (`analysis/published.csv`)
and the shipped run files (`analysis.study.evidence`); trains nothing. Writes:

  claims.csv   a row per catalog claim and part: its verdict (holds, fails, not
               reproduced here, mixed, inconclusive, not testable here), the evidence line,
               why where it did not hold (for "not reproduced here": what of our model or
               of what the thesis leaves open the outcome turns on, or the unmet
               precondition it rests on: readings.PRECONDITION), and where a criterion
               was revised after its runs, the verdict it gave as first written;
  numbers.csv  a row per published number: ours from the same setting and measure with
               its interval and seeds, or its role (a setting, a robot fact) or the reason
               we have none;
  report.md    each claim with its verdict and evidence, by chapter, the numbers table,
               and the cost-per-round figure (`cem_cost_per_round.png`, thesis
               Figs. 6.2-6.6; matplotlib, the `plots` extra, is required: without it
               nothing is written).
"""

from __future__ import annotations

import csv
import dataclasses
import os

from analysis.study import catalog, chapter4, chapter5, chapter6, numbers, revisions  # noqa: F401
from analysis.study import verdicts as v
from analysis.study.evidence import Evidence, MissingEvidence
from analysis.study.readings import NEEDS, NOT_REPRODUCED, READINGS, UNMET
from analysis.study.registry import RULES
from analysis.study.verdicts import UNTESTED, counts, leaves, tally

OUT = os.path.join("results", "study")
CLAIM_FIELDS = (
    "id",
    "parent",
    "chapter",
    "place",
    "statement",
    "criterion",
    "verdict",
    "evidence",
    "why",
    "first_verdict",
    "numbers",
    "rerun",
)
# The command that makes a claim's evidence again, by the catalog's evidence family (then
# `python -m analysis.study` judges it); claims whose runs a flag of the family's command
# makes name that flag.
RERUN = {
    "cem_grid": "python -m baselines.experiments.cem_study --out=results/study/runs",
    "pole": "python -m baselines.experiments.pole_claims --output_dir=results/study/pole --seeds=5",
    "crawler": "python -m baselines.experiments.crawler_experiments "
    "--output_dir=results/study/crawler --seeds=5",
    "tokic": "python -m baselines.experiments.study_evidence",
    "cem_toy": "python -m baselines.experiments.study_evidence",
    "cpg": "python -m baselines.experiments.study_evidence",
    "nac": "python -m baselines.experiments.nac_experiments --output_dir=results/study/nac "
    "--seeds=5",
    "none": "",
}
_NAC_SWEEP = RERUN["nac"] + " --sweep --resume"
_NAC_SCALED = RERUN["nac"] + " --scaled"
RERUN_OF_CLAIM = {
    **dict.fromkeys(("NAC-1", "NAC-2a", "NAC-7"), _NAC_SWEEP),
    **dict.fromkeys(("NAC-4b", "NAC-5", "NAC-5a", "NAC-5b", "NAC-6"), _NAC_SCALED),
}


def judge(rows: list[dict], ev: Evidence) -> list[dict]:
    """Each catalog row with its verdict, evidence and why, in catalog order."""
    done: dict[str, v.Verdict] = {}
    for row in rows:
        done[row["id"]] = _judge_one(row, ev)
    first: dict[str, str] = {}
    for whole, parts in catalog.parts_of(rows).items():
        if whole not in RULES:
            found = [done[p] for p in parts]
            verdict = v.combine(found)
            summary = ", ".join(f"{p}: {done[p].verdict}" for p in parts)
            why = _why_of_parts(parts, done)
            partial = v.in_part({p: done[p] for p in parts})
            if partial:
                why = f"{partial}; {why}" if why else partial
            done[whole] = v.Verdict(verdict, summary, why)
            if v.combine_as_first_written(found) != verdict:  # the rule before 2026-11-27
                first[whole] = v.combine_as_first_written(found)
    return [
        {
            **{k: row[k] for k in CLAIM_FIELDS if k in row},
            "verdict": done[row["id"]].verdict,
            "evidence": done[row["id"]].evidence,
            "why": done[row["id"]].why,
            "first_verdict": first.get(row["id"]) or revisions.text(ev, row["id"]),
            "rerun": RERUN_OF_CLAIM.get(row["id"], RERUN[row["evidence"]]),
        }
        for row in rows
    ]


def _judge_one(row: dict, ev: Evidence) -> v.Verdict:
    if row["testable"].startswith("no"):
        return v.untestable(row["testable"].partition(":")[2].strip())
    rule = RULES.get(row["id"])
    if rule is None:
        return _Untested("", f"no evidence yet: needs {NEEDS.get(row['id'], 'a rule')}")
    try:
        verdict = rule(ev)
    except MissingEvidence as e:
        return v.Verdict(v.INCONCLUSIVE, "", f"runs missing: {e}")
    if row["id"] in UNMET:  # read on a precondition the runs do not meet
        shown = f"{verdict.evidence}; the rule on these runs: {verdict.verdict}"
        return v.Verdict(v.NOT_REPRODUCED, shown, UNMET[row["id"]])
    if verdict.verdict == v.FAILS and row["id"] in NOT_REPRODUCED:
        return v.Verdict(v.NOT_REPRODUCED, verdict.evidence, NOT_REPRODUCED[row["id"]])
    if verdict.verdict in (v.FAILS, v.MIXED) and row["id"] in READINGS:
        return v.Verdict(verdict.verdict, verdict.evidence, READINGS[row["id"]])
    return verdict


@dataclasses.dataclass(frozen=True)
class _Untested:
    evidence: str
    why: str
    verdict: str = UNTESTED


def _why_of_parts(parts: list[str], done: dict) -> str:
    return "; ".join(f"{p}: {done[p].why}" for p in parts if done[p].why)


def write_csv(path: str, rows: list[dict], fields) -> None:
    """Writes rows atomically (a temporary file, then renamed)."""
    tmp = path + ".tmp"
    with open(tmp, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(fields), lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    os.replace(tmp, path)


def build(out: str = OUT, ev: Evidence | None = None) -> str:
    """Writes claims.csv, numbers.csv and report.md (and the figure) into `out`.

    Returns:
      One line: how many claims have each verdict, and where the files are.

    Raises:
      report.MissingExtra: Without matplotlib, before anything is written.
    """
    from analysis.study import report

    report.require_matplotlib()
    ev = ev or Evidence()
    os.makedirs(out, exist_ok=True)
    rows = catalog.load()
    claims = judge(rows, ev)
    table = numbers.table(ev, rows)
    write_csv(os.path.join(out, "claims.csv"), claims, CLAIM_FIELDS)
    write_csv(os.path.join(out, "numbers.csv"), table, numbers.FIELDS)
    report.write(out, claims, table, ev, rows)
    whole, judged = counts(claims), leaves(claims)
    return (
        f"{sum(whole.values())} claims ({tally(whole)}); "
        f"{sum(judged.values())} parts and single claims ({tally(judged)}) -> {out}"
    )
