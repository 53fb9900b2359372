"""The state a gait optimizer's run keeps between rounds, and its checkpoint.

`checkpoint.json` (written atomically after every round by `cpg_suite.harness.rounds`)
holds the settings it belongs to (`identity`), the bookkeeping (`RunState`) and the
optimizer's own state (`Optimizer.state_dict`); resuming from it continues bit-identically.
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np

from cpg_suite.harness.interface import Optimizer
from cpg_suite.runfiles import runs


class CheckpointError(Exception):
    """A checkpoint that cannot be read or belongs to another configuration."""


def _fresh_totals() -> dict:
    return {"round": 0, "falls_total": 0, "evaluations": 0, "sim_steps": 0, "wall_s": 0.0}


@dataclasses.dataclass
class RunState:
    """What a checkpoint holds besides the optimizer.

    Attributes:
      totals: Rounds done, falls, evaluations, physics steps, wall time (and validation
        physics steps once the mean has been validated).
      best: The cheapest trial so far (`cost` inf until one has a finite cost).
      rows: The progress rows so far.
      top: The in-sample best candidates so far, for selection.
    """

    totals: dict = dataclasses.field(default_factory=_fresh_totals)
    best: dict = dataclasses.field(default_factory=lambda: {"cost": np.inf})
    rows: list = dataclasses.field(default_factory=list)
    top: list = dataclasses.field(default_factory=list)

    def to_json(self, identity: dict, optimizer: Optimizer) -> dict:
        """The checkpoint's content.

        Args:
          identity: The run's settings as a dict (`dataclasses.asdict`).
          optimizer: The optimizer, whose `state_dict()` goes in.

        Returns:
          A JSON-serializable dict.
        """
        return {
            "identity": identity,
            "totals": self.totals,
            "best": self.best,
            "rows": self.rows,
            "top": self.top,
            "optimizer": optimizer.state_dict(),
        }

    def keep_top(self, samples: np.ndarray, costs: np.ndarray, k: int) -> None:
        """Keeps the `k` cheapest distinct candidates seen so far (finite costs only).

        Args:
          samples: The round's candidates, one per row.
          costs: Their costs.
          k: How many to keep.
        """
        entries = self.top + [
            {"cost": float(c), "params": x.tolist()}
            for x, c in zip(samples, costs)
            if np.isfinite(c)
        ]
        entries.sort(key=lambda e: e["cost"])
        kept = []
        for entry in entries:
            if len(kept) < k and all(entry["params"] != e["params"] for e in kept):
                kept.append(entry)
        self.top = kept


def check_identity(checkpoint, path: str, identity: dict) -> dict:
    """`checkpoint` if it is a run state of the configuration `identity` (any run kind).

    Raises:
      CheckpointError: If it belongs to another configuration or is no run state.
    """
    if not isinstance(checkpoint, dict) or checkpoint.get("identity") != identity:
        raise CheckpointError(
            f"checkpoint {path} belongs to another configuration; use another --run_name "
            "or --overwrite"
        )
    return checkpoint


def _read_checkpoint(path: str, identity: dict) -> dict:
    try:
        checkpoint = runs.read_json(path)
    except (OSError, ValueError) as e:
        raise CheckpointError(f"cannot read checkpoint {path}: {e}") from None
    return check_identity(checkpoint, path, identity)


def restore(path: str, identity: dict, optimizer: Optimizer, resume: bool) -> RunState:
    """The state of a fresh run, or the checkpoint's (loading the optimizer's state too).

    Args:
      path: The run's `checkpoint.json`.
      identity: The run's settings as a dict; the checkpoint's must be equal.
      optimizer: Receives the checkpoint's optimizer state.
      resume: Continue from the checkpoint if it exists (else start afresh).

    Returns:
      The run state to continue from.

    Raises:
      CheckpointError: On a checkpoint that cannot be read or belongs to other settings.
    """
    if not (resume and os.path.exists(path)):
        return RunState()
    checkpoint = _read_checkpoint(path, identity)
    optimizer.load_state_dict(checkpoint["optimizer"])
    best = checkpoint["best"]
    best["cost"] = float(best["cost"])
    return RunState(checkpoint["totals"], best, checkpoint["rows"], checkpoint["top"])
