r"""Thesis Table 6.3 from CEM run directories: our figures next to the published ones.

  python -m analysis.table6_3 --runs=runs/table6_3 [--out=table6_3.md]

Reads `<runs>/cem/darwin_walk/<setting>_seed<k>/summary.json` (as written by
`python -m baselines.cem --grid=table6_3`) and prints, per setting: the number of seeds,
mean ± std of the best distance and of its round, the final mean vector's distance and
fall rate, the fall rate over all trials, and the study's best distance and round.
Run directories whose summary is missing or malformed are skipped and listed.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import json
import os
import re
import sys

import numpy as np
from absl import flags

from analysis import leaderboard, published
from cpg_suite import cli

_RUN = re.compile(r"^(?P<setting>.+)_seed(?P<seed>\d+)$")


def collect(runs_dir: str) -> tuple[dict[str, list[dict]], list[str]]:
    """Summaries per setting, and the run directories that could not be read."""
    root = os.path.join(runs_dir, "cem", "darwin_walk")
    by_setting: dict[str, list[dict]] = {}
    skipped = []
    if not os.path.isdir(root):
        return by_setting, [f"{root}: no such directory"]
    for name in sorted(os.listdir(root)):
        match = _RUN.match(name)
        path = os.path.join(root, name, "summary.json")
        if not match:
            continue
        try:
            with open(path, encoding="utf-8") as f:
                summary = json.load(f)
            float(summary["best_distance_m"]), int(summary["best_round"])
        except (OSError, ValueError, KeyError, TypeError) as e:
            skipped.append(f"{path}: {type(e).__name__}")
            continue
        by_setting.setdefault(match["setting"], []).append(summary)
    return by_setting, skipped


def _mean_std(values, digits: int = 3) -> str:
    values = np.asarray(values, dtype=float)
    std = values.std(ddof=1) if len(values) > 1 else 0.0
    return f"{values.mean():.{digits}f} ± {std:.{digits}f}"


def table(by_setting: dict[str, list[dict]]) -> str:
    """The markdown table."""
    order = list(published.TABLE6_3) + list(published.NOISE_CLAIMS)
    order += sorted(set(by_setting) - set(order))
    lines = [
        "| setting | n | best distance (m) | round of best | final mean (m) | "
        "final mean fell | trials fell | published best (u.d.) | published round |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for name in order:
        runs = by_setting.get(name)
        if not runs:
            continue
        pub = published.TABLE6_3.get(name)
        pub_best = f"{pub[0]:.3f} ({pub[2]})" if pub else published.NOISE_CLAIMS.get(name, "—")
        pub_round = f"{pub[1]} ({pub[3]})" if pub else "—"
        fell_final = np.mean([r["final_mean_fell"] for r in runs])
        fell_trials = sum(r["falls_total"] for r in runs) / sum(r["evaluations"] for r in runs)
        lines.append(
            f"| {name} | {len(runs)} | {_mean_std([r['best_distance_m'] for r in runs])} | "
            f"{_mean_std([r['best_round'] for r in runs], 1)} | "
            f"{_mean_std([r['final_mean_distance_m'] for r in runs])} | {fell_final:.0%} | "
            f"{fell_trials:.0%} | {pub_best} | {pub_round} |"
        )
    return "\n".join(lines) + "\n"


@dataclasses.dataclass(frozen=True)
class Table63Settings:
    """What `python -m analysis.table6_3` reads and writes.

    Attributes:
      runs: The root of the CEM output tree; must be an existing directory.
      out: Also write the table to this markdown file (None: print only).
    """

    runs: str | None = None
    out: str | None = None

    def __post_init__(self):
        leaderboard.check_runs_dir(self.runs)


def write_table(runs: str, out: str | None = None) -> tuple[str, list[str]]:
    """Thesis Table 6.3 from the CEM runs under `runs`, written to `out` if given.

    Args:
      runs: The root of the CEM output tree (`<runs>/cem/darwin_walk/<setting>_seed<k>/`).
      out: A markdown file to write the table to (None: none).

    Returns:
      `(table, skipped)`: the markdown table and the run directories that could not be
      read (a missing `cem/darwin_walk` tree is one of them).

    Raises:
      OSError: If `out` cannot be written.
    """
    by_setting, skipped = collect(runs)
    text = table(by_setting)
    if out:
        with open(out, "w", encoding="utf-8") as f:
            f.write(text)
    return text, skipped


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    flags.DEFINE_string(
        "runs", None, "none: required. Root of the CEM output tree (an existing directory)."
    )
    flags.DEFINE_string(
        "out", None, "none: print only. Also write the table to this markdown file."
    )


def main(argv: list[str]) -> None:
    del argv
    settings = cli.settings_from_flags(Table63Settings)
    text, skipped = write_table(settings.runs, settings.out)
    print(text, end="")
    if skipped:
        print("skipped: " + "; ".join(skipped), file=sys.stderr)


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_files=("out",))
