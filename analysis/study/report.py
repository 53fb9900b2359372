"""The study's report: each claim with its verdict and evidence, the numbers, the figure.

The figure needs matplotlib (the `plots` extra): without it `write` raises
`MissingExtra` rather than write a report that differs from the tracked one.
"""

from __future__ import annotations

import os
from collections import Counter

import numpy as np

from analysis.study import chapter6
from analysis.study import verdicts as v
from analysis.study.evidence import Evidence, MissingEvidence
from analysis.study.verdicts import counts, leaves, tally

FIGURE = "cem_cost_per_round.png"
PLOTS = "pip install '.[plots]'"


class MissingExtra(RuntimeError):
    """An optional package the report needs is not installed (the message says which)."""


def require_matplotlib() -> None:
    """Raises `MissingExtra` unless matplotlib imports."""
    try:
        import matplotlib  # noqa: F401
    except ImportError as e:
        raise MissingExtra(
            f"the report's figure needs matplotlib, which is not installed: {PLOTS}"
        ) from e


CHAPTERS = {
    "4.1": "Chapter 4.1: the crawler",
    "4.2": "Chapter 4.2: the pole",
    "5": "Chapter 5: the CPG and the Natural Actor-Critic",
    "6": "Chapter 6: the Cross-Entropy Method",
    "7": "Chapter 7: conclusions",
    "A": "Appendix: value iteration step by step",
}
# Panels of the figure: the thesis' figure, its title, the settings it plots.
PANELS = (
    ("Fig. 6.2", "K 10, no noise", chapter6.NO_NOISE),
    ("Fig. 6.3", "K 10, noise 0.8", chapter6.NOISE),
    ("Fig. 6.4", "lateral penalty", ["K10_n0.8_e2_lateral"]),
    ("Fig. 6.5-6.6", "K 10 / 20 / 50", ["K10_n0.8_e2", "K20_n0.8_e2", "K50_n0.8_e2"]),
    ("Sec. 6.3", "noise 0.2 / 0.8 / 1.0", ["K10_n0.2_e2", "K10_n0.8_e2", "K10_n1_e2"]),
    ("Sec. 6.3", "K 50 / 70 / 100", ["K50_n0.8_e2", "K70_n0.8_e2", "K100_n0.8_e2"]),
)


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _claims_lines(claims: list[dict]) -> list[str]:
    lines = []
    for chapter, title in CHAPTERS.items():
        rows = [c for c in claims if c["chapter"] == chapter]
        if not rows:
            continue
        lines += [
            f"## {title}",
            "",
            "| id | verdict | claim | evidence | why |",
            "|---|---|---|---|---|",
        ]
        for c in rows:
            name = f"↳ {c['id']}" if c["parent"] else f"**{c['id']}**"
            verdict = c["verdict"]
            if c["why"].startswith(f"{verdict} in part ("):  # parts not testable here left out
                verdict = c["why"].partition(";")[0]
            if c.get("first_verdict"):
                verdict += f" (criterion as first written: {c['first_verdict']})"
            cells = (name, verdict, c["statement"], c["evidence"], c["why"])
            lines.append("| " + " | ".join(_cell(x) for x in cells) + " |")
        lines.append("")
    return lines


def _numbers_lines(table: list[dict]) -> list[str]:
    lines = [
        "## Every published number beside ours",
        "",
        "Results: ours from the same setting and measure (mean over seeds, bootstrap 95 % "
        "interval). Inputs are settings and facts the benchmark takes as given; claims are "
        "judged above.",
        "",
        "| id | quantity | setting | thesis | ours | 95 % CI | seeds | comparison |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for n in table:
        if n["role"] != "result":
            continue
        published = f"{n['published']} {n['unit']}".strip()
        cells = (
            n["id"],
            n["quantity"],
            n["setting"],
            published,
            n.get("ours", ""),
            n.get("ours_ci95", ""),
            n.get("seeds", ""),
            n.get("comparison", ""),
        )
        lines.append("| " + " | ".join(_cell(x) for x in cells) + " |")
    roles = Counter(n["role"] for n in table)
    lines += ["", f"Inputs: {roles['input']}; claims in words: {roles['claim']} (numbers.csv).", ""]
    return lines


def draw(ev: Evidence, out: str) -> str | None:
    """The mean vector's cost per round, median over seeds (thin: each seed), per panel.

    Returns:
      The figure's path.

    Raises:
      MissingExtra: Without matplotlib.
    """
    require_matplotlib()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(13, 7), sharey=True)
    for ax, (figure, title, settings) in zip(axes.ravel(), PANELS):
        for i, setting in enumerate(settings):
            try:
                runs = ev.cem(setting)
            except MissingEvidence:
                continue
            costs = np.array([r.mean_costs() for r in runs])
            rounds = np.arange(1, costs.shape[1] + 1)
            color = f"C{i}"
            for c in costs:
                ax.plot(rounds, c, color=color, lw=0.4, alpha=0.4)
            ax.plot(rounds, np.median(costs, axis=0), color=color, lw=1.8, label=setting)
        ax.set_title(f"{title} (thesis {figure})", fontsize=10)
        ax.set_xlabel("round")
        ax.set_ylim(-4.0, 10.5)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="upper right")
    for ax in axes[:, 0]:
        ax.set_ylabel("mean vector's cost (−m; +10 a fall)")
    fig.tight_layout()
    path = os.path.join(out, FIGURE)
    fig.savefig(path, dpi=100, metadata={"Software": None})
    plt.close(fig)
    return path


def _compute_lines(ev: Evidence) -> list[str]:
    """What the CEM evidence cost: each finished run's wall time from its summary (on the
    2-core development machine, one thread a run, two runs at a time)."""
    from analysis.study.evidence import cem_runs

    found = cem_runs(ev.study, ev.protocol)
    hours = {s: sum(r.summary.get("wall_s", 0.0) for r in rs) / 3600 for s, rs in found.items()}
    total = sum(hours.values())
    rows = ", ".join(f"{s} {h:.2f}" for s, h in sorted(hours.items()))
    return [
        "## Compute",
        "",
        f"The finished CEM runs took {total:.1f} hours of run time by their summaries, one "
        f"thread a run and two runs at a time ({rows}; K 50: the shipped runs, 2 threads "
        "each). The rest of the evidence (crawler, computed evidence) takes minutes.",
        "",
    ]


# How far a verdict goes the claim's way, to say which way a revision moved it.
_TOWARD = {v.FAILS: 0, v.NOT_REPRODUCED: 0, v.INCONCLUSIVE: 1, v.MIXED: 1, v.HOLDS: 2}


# Where the catalog marks a revision made after the runs ("revised after ...: was ..."), and
# the mark of a compound claim's combination rule restated to what `verdicts.combine` does.
REVISED = "revised after"
_MARKED_FIELDS = ("criterion", "measure", "setting")
_COMBINATION_RESTATED = "which verdicts.combine did not apply"


def marked_revised(row: dict) -> bool:
    """Whether a catalog row marks a revision of its rule (criterion, measure or setting)
    made after its runs."""
    return any(REVISED in row.get(k, "") for k in _MARKED_FIELDS)


def revisions_line(claims: list[dict], rows: list[dict] | None = None) -> str:
    """One paragraph: the claims judged by a rule revised after their runs, by which way the
    revision moved the verdict (towards the claim, against it, between verdicts of the same
    side, not at all, or into or out of what is testable); with the catalog's rows, also the
    revisions marked there that have no first verdict beside.

    Args:
      claims: claims.csv's rows.
      rows: The catalog's rows (`catalog.load`), or None to leave the second part out.

    Returns:
      The paragraph (ids listed under each direction).
    """
    moved: dict[str, list[str]] = {k: [] for k in ("towards", "against", "side", "same", "out")}
    for c in claims:
        if not c.get("first_verdict"):
            continue
        now, was = c["verdict"], c["first_verdict"].split(":")[0].strip()
        if now == was:
            key = "same"
        elif v.UNTESTABLE in (now, was):
            key = "out"
        elif _TOWARD[now] == _TOWARD[was]:
            key = "side"
        else:
            key = "towards" if _TOWARD[now] > _TOWARD[was] else "against"
        moved[key].append(c["id"])
    names = {
        "towards": "moved the verdict towards holds",
        "against": "moved it away from holds",
        "side": "moved it between fails and not reproduced here, or between inconclusive and mixed",
        "same": "left it as it was",
        "out": "moved it into or out of not testable here",
    }
    parts = [f"{len(ids)} {names[k]} ({', '.join(ids)})" for k, ids in moved.items() if ids]
    total = sum(len(ids) for ids in moved.values())
    line = (
        f"{total} claims are judged by a rule revised after their runs, the first rule's "
        "verdict beside (each revision marked in the catalog, in the claim's criterion, "
        f"measure or setting, with what it replaced): {'; '.join(parts)} (in the order fails "
        "and not reproduced here, then inconclusive and mixed, then holds)."
    )
    return line if rows is None else f"{line} {_unpaired_revisions(claims, rows)}"


def _unpaired_revisions(claims: list[dict], rows: list[dict]) -> str:
    """The sentence on the catalog's marked revisions that have no first verdict beside."""
    paired = {c["id"] for c in claims if c.get("first_verdict")}
    unpaired = [r for r in rows if marked_revised(r) and r["id"] not in paired]
    restated = [r["id"] for r in unpaired if _COMBINATION_RESTATED in r["criterion"]]
    other = [r["id"] for r in unpaired if r["id"] not in restated]
    return (
        f"Another {len(unpaired)} revisions marked in the catalog have no first verdict "
        f"beside: {len(restated)} compound claims whose combination rule was restated to what "
        "the code does (`verdicts.combine`; their verdict under the first wording is the "
        f"same, else it would stand beside), and {len(other)} criteria whose first rule is "
        f"not computed here ({', '.join(other)})."
    )


def write(
    out: str, claims: list[dict], table: list[dict], ev: Evidence, rows: list[dict] | None = None
) -> str:
    """Writes `report.md` and the figure into `out`; returns the report's path.

    Args:
      out: The folder.
      claims: The judged claims (`build.judge`).
      table: The numbers' table (`numbers.table`).
      ev: The evidence.
      rows: The catalog's rows (for the revisions' summary; None: that part left out).

    Raises:
      MissingExtra: Without matplotlib (nothing is written).
    """
    figure = os.path.basename(draw(ev, out))
    whole, judged = counts(claims), leaves(claims)
    lines = [
        "# The study, claim by claim",
        "",
        "Made by `python -m analysis.study` from the shipped run files; do not edit "
        "(docs/study.md#claim-by-claim says how each verdict is reached).",
        "",
        f"{sum(whole.values())} distinct claims: {tally(whole)}. A claim's parts (↳) are "
        "judged one by one; the whole is mixed where they differ. Judged one by one, the "
        f"{sum(judged.values())} parts and claims without parts: {tally(judged)}.",
        "",
        "**fails**: tested in the thesis' setting (as far as the thesis gives it), the claim "
        "does not hold; its why says whose the failure is. **not reproduced here**: it does "
        "not hold here, and the outcome turns on something the thesis does not give (a "
        "constant, a dimension, a definition) or on a named, measured difference between our "
        "model and the thesis'; its why names it, with the thesis' line (seed Lnnn). A claim "
        "read on a precondition our runs do not meet (CPG-4: the CPG alone keeps the COP at "
        "the sole's edge, so the balance reward is saturated) is not reproduced here whatever "
        "its rule gives on those runs; its evidence shows what the rule gave. Where a "
        "criterion was revised after its runs, the verdict it gave as first written stands "
        "beside the verdict.",
        "",
        revisions_line(claims, rows),
        "",
        f"![CEM cost per round]({figure})",
        "",
    ]
    lines += _claims_lines(claims) + _numbers_lines(table) + _compute_lines(ev)
    path = os.path.join(out, "report.md")
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines))
    return path
