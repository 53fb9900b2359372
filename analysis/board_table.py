"""The README's leaderboard table, in Markdown, from a `darwin_leaderboard.csv`.

`analysis.rebuild` writes it into the README between its board markers. One row per
configuration of the board, in its order: the ranked rows of each track, then the
provisional ones and those trained under an earlier benchmark version (`trained_v<n>`,
listed without a rank). Every figure is the CSV's, rounded for reading.
"""

from __future__ import annotations

import csv

from cpg_suite.protocol import TIERS

METHODS = {
    "cem": "CEM K = 50, the main job",
    "cmaes": "CMA-ES K = 50",
    "ppo": "PPO",
    "ppo_mjx": "PPO on MJX",
}
TRAINING = {"darwin_walk": "nominal", "darwin_walk_randomized": "randomized"}
HEADER = (
    "| track | rank | method (training tier) | seeds | IQM [95 % CI] | mean [95 % CI] | m/s "
    "| failures (brown-outs) | A, worst 1 s | nominal | randomized | push | rough | contact "
    "| P(improvement over next) [95 % CI] | re-scored in full |\n" + "|---" * 16 + "|"
)


def _method(row: dict) -> str:
    config = row["config"].removesuffix("_v1")  # runs trained under version 1 were renamed
    name = METHODS.get(row["method"], row["method"])
    if row["method"] in ("ppo", "ppo_mjx"):
        name += f" `{config}`"
    if config.endswith("_feedback"):
        name = "CMA-ES K = 50, feedback CPG"
    training = TRAINING.get(row["training_task"], row["training_task"])
    return f"{name} ({training})"


def _f(value: str, digits: int = 2) -> str:
    return "" if value == "" else f"{float(value):.{digits}f}"


def _rank(row: dict) -> str:
    if row["status"] == "ranked":
        return row["rank"]
    return row["status"].replace("_", " ")


def _p_next(row: dict) -> str:
    if row["p_improvement_next"] == "":
        return "—"
    text = (
        f"{_f(row['p_improvement_next'])} [{_f(row['p_improvement_ci95_low'])}, "
        f"{_f(row['p_improvement_ci95_high'])}]"
    )
    return text + (" (tied)" if row["tied_with_next"] == "True" else "")


def _rescored(row: dict) -> str:
    """How many of the row's runs a full re-score reproduced, with the files they hold now,
    and when (the ledger, `verify --record`); every run is also re-scored in part by CI."""
    runs = f"{row.get('rescored_full_runs') or 0} of {row['n_seeds']}"
    return f"{runs}, {row['rescored_full_on']}" if row.get("rescored_full_on") else runs


def _tier(row: dict, tier: str) -> str:
    """A tier's cell: its score and failure share ("—" where the row's cards lack it)."""
    if row[f"{tier}_score_m"] in ("", None):
        return "—"
    return f"{_f(row[f'{tier}_score_m'])}, {100 * float(row[f'{tier}_fall_rate']):.0f}%"


def markdown_row(row: dict) -> str:
    """One configuration's table row."""
    iqm = (
        f"{_f(row['iqm_m'])} [{_f(row['iqm_ci95_low'])}, {_f(row['iqm_ci95_high'])}]"
        if row["iqm_m"]
        else "—"
    )
    mean = f"{_f(row['test_score_m'])} [{_f(row['test_ci95_low'])}, {_f(row['test_ci95_high'])}]"
    failures = (
        f"{100 * float(row['test_fall_rate']):.1f}% "
        f"({100 * float(row['test_brownout_rate'] or 0):.1f}%)"
    )
    supply = f"{_f(row['supply_current_a'], 1)}, {_f(row['supply_peak_1s_a'], 1)}"
    tiers = [_tier(row, t) for t in TIERS]
    cells = [
        row["track"],
        _rank(row),
        _method(row),
        row["n_seeds"],
        iqm,
        mean,
        _f(row["speed_m_s"], 3),
        failures,
        supply,
        *tiers,
        _p_next(row),
        _rescored(row),
    ]
    return "| " + " | ".join(cells) + " |"


def markdown(path: str) -> str:
    """The table (header and a row per configuration but the untrained references) of the
    board CSV at `path`."""
    with open(path, encoding="utf-8") as f:
        rows = [r for r in csv.DictReader(f) if r["status"] != "reference"]
    return "\n".join([HEADER, *(markdown_row(r) for r in rows)]) + "\n"
