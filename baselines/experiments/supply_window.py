r"""How the ranking moves with the supply limit's averaging window (docs/darwin_op_model.md).

  python -m baselines.experiments.supply_window --out=results/protocol/supply_window
  python -m baselines.experiments.supply_window --tiers=darwin_walk --seeds=50 --out=DIR

The benchmark's supply limit is 10 A averaged over the last second (version 2); the window
is a modelling choice. This scores every shipped run (`--artifacts`) under version 2 with
each of `--windows` (s; 16 s is a whole trial's length, its part before the start the idle
robot's as for every window; `inf`: the running mean since the start) on `--tiers` and
`--seeds` test seeds, writes one row per run and window to `scores.csv` (appended run by
run: a stopped experiment resumes where it was), then prints per configuration the mean
success-weighted distance and brown-out rate under each window, and its rank.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import csv
import dataclasses
import math
import os
from collections import defaultdict

import numpy as np
from absl import flags

from cpg_suite import cli, protocol
from cpg_suite.protocol import score, verify
from cpg_suite.runfiles import runs

FIELDS = ("run", "config", "window_s", "tiers", "seeds", "score_m", "fall_rate", "brownout_rate")


@dataclasses.dataclass(frozen=True)
class WindowSettings:
    """What to score.

    Attributes:
      artifacts: The shipped runs.
      windows: The averaging windows, s (16: a whole trial; inf: the mean since the start).
      tiers: The test tiers.
      seeds: How many test seeds per tier.
      out: The folder of `scores.csv`.
      methods: Only the runs under these subfolders of `artifacts`, in this order (empty:
        every run).
    """

    artifacts: str = verify.ARTIFACTS
    windows: tuple[float, ...] = (0.25, 1.0, 16.0)
    tiers: tuple[str, ...] = ("darwin_walk",)
    seeds: int = len(protocol.TEST)
    out: str = "supply_window"
    methods: tuple[str, ...] = ()

    def __post_init__(self):
        windows = tuple(float(w) for w in self.windows)
        object.__setattr__(self, "windows", windows)
        object.__setattr__(self, "tiers", tuple(self.tiers))
        cli.require(
            bool(windows)
            and all(0 < w <= score.MAX_SUPPLY_WINDOW or w == math.inf for w in windows),
            f"--windows must be in (0, {score.MAX_SUPPLY_WINDOW:g}] s or inf, got {self.windows}",
        )
        unknown = [t for t in self.tiers if t not in protocol.TIERS]
        cli.require(
            bool(self.tiers) and not unknown,
            f"unknown --tiers {unknown or self.tiers}; valid: {', '.join(protocol.TIERS)}",
        )
        cli.require_integer("seeds", self.seeds, 1, len(protocol.TEST))


def configuration(run_dir: str, artifacts: str) -> str:
    """A run's configuration: method/task/run name less its seed."""
    relative = os.path.relpath(run_dir, artifacts)
    return relative.rsplit("seed", 1)[0].rstrip("_")


def score_run(run_dir: str, window: float, settings: WindowSettings) -> dict:
    """One run's success-weighted distance and failures under one window."""
    config = runs.read_json(os.path.join(run_dir, "config.json"))
    base = verify.card_settings(config, settings.seeds, threads=2)
    scoring = dataclasses.replace(
        base, tiers=settings.tiers, benchmark_version=2, supply_window=window, seeds=settings.seeds
    )
    card, _ = verify.score_run(run_dir, scoring)
    row = card["all"]
    return {
        "score_m": row["success_weighted_distance_m"]["mean"],
        "fall_rate": row["failures_by_cause"]["fall"],
        "brownout_rate": row["failures_by_cause"]["brownout"],
    }


def run(settings: WindowSettings) -> list[dict]:
    """Scores the runs not yet in `scores.csv` and returns every row."""
    path = os.path.join(settings.out, "scores.csv")
    rows = _read(path)
    done = {(r["run"], float(r["window_s"])) for r in rows}
    for run_dir in _runs(settings):
        name = os.path.relpath(run_dir, settings.artifacts)
        for window in settings.windows:
            if (name, window) in done:
                continue
            result = score_run(run_dir, window, settings)
            rows.append(
                {
                    "run": name,
                    "config": configuration(run_dir, settings.artifacts),
                    "window_s": window,
                    "tiers": ";".join(settings.tiers),
                    "seeds": settings.seeds,
                    **result,
                }
            )
            runs.write_rows_csv(path, rows)  # atomic: a finished run is never lost
    return rows


def _runs(settings: WindowSettings) -> list[str]:
    """The shipped runs to score, those of `methods` first in that order."""
    shipped = verify.shipped_runs(settings.artifacts)
    if not settings.methods:
        return shipped
    return [
        run_dir
        for method in settings.methods
        for run_dir in shipped
        if os.path.relpath(run_dir, settings.artifacts).split(os.sep)[0] == method
    ]


def _read(path: str) -> list[dict]:
    if not os.path.exists(path):
        return []
    with open(path, newline="", encoding="utf-8") as f:
        return [
            {
                **r,
                "window_s": float(r["window_s"]),
                "seeds": int(r["seeds"]),
                **{k: float(r[k]) for k in ("score_m", "fall_rate", "brownout_rate")},
            }
            for r in csv.DictReader(f)
        ]


def table(rows: list[dict]) -> str:
    """Per configuration and window: mean score, brown-out rate and rank (1 = best)."""
    by = defaultdict(list)
    for r in rows:
        by[(r["config"], r["window_s"])].append(r)
    windows = sorted({w for _, w in by})
    configs = sorted({c for c, _ in by})
    means = {k: float(np.mean([r["score_m"] for r in v])) for k, v in by.items()}
    ranks = {}
    for w in windows:
        order = sorted((c for c in configs if (c, w) in means), key=lambda c: -means[(c, w)])
        ranks.update({(c, w): i + 1 for i, c in enumerate(order)})
    head = f"{'configuration':<44}" + "".join(
        f" {'window ' + format(w, 'g') + ' s':>27}" for w in windows
    )
    lines = [head, f"{'':<44}" + f" {'m (runs)':>10} {'brown':>7} {'rank':>7}" * len(windows)]
    for c in configs:
        cells = ""
        for w in windows:
            if (c, w) not in means:
                cells += f" {'':>27}"
                continue
            brown = np.mean([r["brownout_rate"] for r in by[(c, w)]])
            cells += f" {means[(c, w)]:>6.2f} ({len(by[(c, w)])}) {brown:>7.1%} {ranks[(c, w)]:>7}"
        lines.append(f"{c:<44}{cells}")
    return "\n".join(lines)


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    d = WindowSettings()
    flags.DEFINE_string("artifacts", d.artifacts, "Folder of shipped runs.")
    flags.DEFINE_list("windows", [format(w, "g") for w in d.windows], "Windows, s (inf: trial).")
    flags.DEFINE_list("tiers", list(d.tiers), f"Test tiers: {', '.join(protocol.TIERS)}.")
    flags.DEFINE_integer("seeds", d.seeds, "Test seeds per tier.")
    flags.DEFINE_string("out", d.out, "Folder of scores.csv.")
    flags.DEFINE_list("methods", list(d.methods), "Only these subfolders of --artifacts, in order.")


def main(argv) -> None:
    del argv
    words = flags.FLAGS.windows
    try:
        windows = tuple(float(w) for w in words)
    except ValueError:
        raise cli.UsageError(f"--windows must be numbers of seconds or inf, got {words}") from None
    settings = cli.settings_from_flags(
        WindowSettings,
        windows=windows,
        tiers=tuple(flags.FLAGS.tiers),
        methods=tuple(flags.FLAGS.methods),
    )
    cli.check(
        os.path.isdir(settings.artifacts), f"--artifacts={settings.artifacts} is not a folder"
    )
    missing = [
        m for m in settings.methods if not os.path.isdir(os.path.join(settings.artifacts, m))
    ]
    cli.check(not missing, f"--methods {missing} are not folders of {settings.artifacts}")
    os.makedirs(settings.out, exist_ok=True)
    print(table(run(settings)))


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_dirs=("out",))
