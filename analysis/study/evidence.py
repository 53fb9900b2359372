"""The shipped run files the study's verdicts are computed from, read once.

* CEM in the Table 6.3 settings (`baselines.experiments.cem_study`): each run's
  `progress.csv` (a row per round) and `summary.json`, under `<study>/cem/darwin_walk/`,
  and the shipped K = 50 version-1 runs of `results/protocol/runs` for K = 50;
* the crawler, pole and NAC experiments' per-seed tables under `results/`.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import os
import re

import numpy as np
import pandas as pd

from analysis import leaderboard

STUDY = os.path.join("results", "study", "runs")  # baselines.experiments.cem_study's output
PROTOCOL = os.path.join("results", "protocol", "runs")  # the board's shipped runs
FALL_PENALTY = 10.0  # the runs' cost of a fall, m (baselines.cem's default, config.json)
_NAME = re.compile(r"^(?P<setting>.+?)(?:_v1)?_seed(?P<seed>\d+)$")


@dataclasses.dataclass(frozen=True)
class CEMRun:
    """One CEM run of the study: its setting, seed, per-round progress and summary."""

    setting: str
    seed: int
    progress: pd.DataFrame
    summary: dict
    config: dict
    best_params: dict
    mean_params: dict

    @property
    def population(self) -> int:
        return int(self.config["settings"]["population"])

    @property
    def elite(self) -> int:
        return int(self.config["settings"]["elite"])

    def mean_scores(self) -> np.ndarray:
        """Per round, the mean vector's distance (sample 1), NaN where it fell."""
        p = self.progress
        return np.where(p["mean_fell"].to_numpy() == 0, p["mean_distance_m"].to_numpy(), np.nan)

    def sample_scores(self) -> np.ndarray:
        """Per round, the best sample's score −cost (the distance, less the lateral penalty
        where there is one), NaN where every sample fell."""
        p = self.progress
        return np.where(p["best_fell"].to_numpy() == 0, -p["best_cost"].to_numpy(), np.nan)

    def mean_costs(self) -> np.ndarray:
        """Per round, the mean vector's cost without a lateral term: −distance, plus the
        fall penalty where it fell (thesis Figs. 6.2-6.6 plot a round's cost)."""
        p = self.progress
        return -p["mean_distance_m"].to_numpy() + FALL_PENALTY * p["mean_fell"].to_numpy()


def best_of(scores: np.ndarray, rounds: int | None = None) -> tuple[float, int]:
    """The best score over the first `rounds` rounds and the first round it came in
    (1-based); (NaN, 0) if every round fell."""
    s = scores[:rounds] if rounds else scores
    if np.all(np.isnan(s)):
        return float("nan"), 0
    return float(np.nanmax(s)), int(np.nanargmax(s)) + 1


def _json(path: str) -> dict:
    """A JSON file, or {} where it is not there (the shipped K = 50 runs have no
    mean_params.json: their final mean is in selected_params.json only when selected)."""
    if not os.path.isfile(path):
        return {}
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def _read_run(path: str) -> tuple[pd.DataFrame, dict, dict, dict, dict]:
    progress = pd.read_csv(os.path.join(path, "progress.csv"))
    names = ("summary.json", "config.json", "best_params.json", "mean_params.json")
    return (progress, *(_json(os.path.join(path, n)) for n in names))


def _finished(path: str) -> bool:
    return os.path.isfile(os.path.join(path, "summary.json"))


@functools.lru_cache(maxsize=4)
def cem_runs(study: str = STUDY, protocol: str = PROTOCOL) -> dict[str, list[CEMRun]]:
    """The finished CEM runs by setting (`baselines.cem.TABLE6_3` names), seeds in order.

    K = 50 comes from the shipped version-1 runs `K50_n0.8_e2_v1_seed<S>` where the study
    has no K = 50 runs of its own.

    Raises:
      ValueError: If a run was not trained under version 1 (the study's physics).
    """
    found: dict[str, list[CEMRun]] = {}
    roots = [os.path.join(study, "cem", "darwin_walk")]
    own_k50 = os.path.isdir(roots[0]) and any(n.startswith("K50_") for n in os.listdir(roots[0]))
    if not own_k50:
        roots.append(os.path.join(protocol, "cem", "darwin_walk"))
    for root in roots:
        if not os.path.isdir(root):
            continue
        for name in sorted(os.listdir(root)):
            m = _NAME.match(name)
            path = os.path.join(root, name)
            if not m or not _finished(path):
                continue
            if root != roots[0] and not (name.startswith("K50_") and "_v1_" in name):
                continue
            run = CEMRun(m["setting"], int(m["seed"]), *_read_run(path))
            trained = leaderboard.trained_version(os.path.join(path, "config.json"))
            if trained != 1 and root == roots[0]:
                raise ValueError(f"{path} was not trained under version 1 (the study's physics)")
            found.setdefault(run.setting, []).append(run)
    for runs in found.values():
        runs.sort(key=lambda r: r.seed)
    return found


MIN_SEEDS = 5  # seeds a setting needs before its claims are judged


class MissingEvidence(LookupError):
    """A claim's runs are not (all) there yet: its verdict is inconclusive, and says which."""


@dataclasses.dataclass(frozen=True)
class Evidence:
    """Where the shipped run files are.

    Attributes:
      study: The study's CEM runs (`baselines.experiments.cem_study --out`).
      protocol: The board's shipped runs (K = 50 version-1 runs stand in for K = 50).
      results: The results folder (crawler, pole and NAC tables).
    """

    study: str = STUDY
    protocol: str = PROTOCOL
    results: str = "results"

    def cem(self, setting: str) -> list[CEMRun]:
        """The finished runs of a Table 6.3 setting.

        Raises:
          MissingEvidence: With fewer than `MIN_SEEDS` seeds.
        """
        runs = cem_runs(self.study, self.protocol).get(setting, [])
        if len(runs) < MIN_SEEDS:
            raise MissingEvidence(
                f"{setting}: {len(runs)} of {MIN_SEEDS} seeds finished "
                "(python -m baselines.experiments.cem_study)"
            )
        return runs

    def table(self, *path: str) -> pd.DataFrame:
        """A CSV table under `results`."""
        return pd.read_csv(os.path.join(self.results, *path))

    def computed(self, section: str):
        """A section of the computed evidence (`baselines.experiments.study_evidence`).

        Raises:
          MissingEvidence: If the file or the section is not there.
        """
        data = _computed(os.path.join(self.results, *COMPUTED))
        if section not in data:
            raise MissingEvidence(
                f"{section} not in results/study/computed.json "
                "(python -m baselines.experiments.study_evidence)"
            )
        return data[section]


COMPUTED = ("study", "computed.json")


@functools.lru_cache(maxsize=4)
def _computed(path: str) -> dict:
    return _json(path)
