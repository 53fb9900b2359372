"""Complete tabular models (states, actions, transitions, rewards) and the `tokic` model.

A model holds dense arrays `P[s, a, s']` and `R[s, a, s']` plus a mask of the actions
allowed in each state. The crawler's 5×5 grid (thesis Sec. 4.1.2) is the main user:
state (r, c) has index 5 r + c, actions are 0 = up (r − 1), 1 = right (c + 1),
2 = down (r + 1), 3 = left (c − 1), the order of the `crawler_walk` action spec; moves off
the grid are not allowed.
"""

from __future__ import annotations

import dataclasses
import importlib.resources
import json

import numpy as np

from cpg_suite import crawler

# The crawler's grid (cpg_suite.crawler is its one definition): actions and their moves.
GRID_ACTIONS = crawler.ACTIONS
_GRID_MOVES = crawler.MOVES
# Tie order that reproduces the thesis appendix's picks: up, down, left, right
# (docs/decisions.md#tabular-methods).
APPENDIX_TIE_ORDER = (0, 2, 3, 1)


@dataclasses.dataclass(frozen=True)
class TabularModel:
    """A finite MDP without discount.

    Attributes:
      name: Model name.
      transitions: `P[s, a, s']`, shape (S, A, S); rows of allowed actions sum to 1.
      rewards: `R[s, a, s']`, shape (S, A, S).
      allowed: Allowed actions, bool (S, A).
      start_state: Initial state index.
      action_names: Name per action.
      grid_shape: `(rows, cols)` when states form a grid (index = row * cols + col).
      tie_order: Action order for deterministic tie-breaking of greedy choices.
    """

    name: str
    transitions: np.ndarray
    rewards: np.ndarray
    allowed: np.ndarray
    start_state: int = 0
    action_names: tuple[str, ...] = ()
    grid_shape: tuple[int, int] | None = None
    tie_order: tuple[int, ...] | None = None

    @property
    def n_states(self) -> int:
        return self.transitions.shape[0]

    @property
    def n_actions(self) -> int:
        return self.transitions.shape[1]

    def expected_rewards(self) -> np.ndarray:
        """r(s, a) = Σ_s' P R, shape (S, A)."""
        return np.einsum("ijk,ijk->ij", self.transitions, self.rewards)

    def intended_successor(self, s: int, a: int) -> int:
        """The most likely successor of (s, a) (the only one if deterministic)."""
        return int(np.argmax(self.transitions[s, a]))

    def label(self, s: int):
        """`(row, col)` for grid models, else the index."""
        if self.grid_shape is None:
            return s
        return divmod(int(s), self.grid_shape[1])


def grid_index(r: int, c: int, cols: int = crawler.GRID) -> int:
    """State index of cell (r, c) in a grid of `cols` columns (row-major, as the crawler's)."""
    return r * cols + c


def grid_model(
    rewards: dict[tuple[tuple[int, int], tuple[int, int]], float],
    rows: int = crawler.GRID,
    cols: int = crawler.GRID,
    slip: float = 0.0,
    name: str = "grid",
    start: tuple[int, int] = (0, 0),
    tie_order: tuple[int, ...] | None = APPENDIX_TIE_ORDER,
) -> TabularModel:
    """Builds a grid-world model of the crawler kind.

    Args:
      rewards: `{((r, c), (r2, c2)): reward}` for moves between neighbouring cells;
        moves that are missing get reward 0.
      rows: Number of rows.
      cols: Number of columns.
      slip: Probability that a move leaves the state unchanged (thesis Sec. 4.1.5, the
        stochastic variant; the study gives no value). A slip earns reward 0.
      name: Model name.
      start: Start cell.
      tie_order: Greedy tie-break order.

    Returns:
      The model.

    Raises:
      ValueError: If `slip` is outside [0, 1) or a reward names a non-neighbour move.
    """
    if not 0.0 <= slip < 1.0:
        raise ValueError(f"slip must lie in [0, 1), got {slip}")
    n = rows * cols
    P = np.zeros((n, 4, n))
    R = np.zeros((n, 4, n))
    allowed = np.zeros((n, 4), dtype=bool)
    moves = {}
    for r in range(rows):
        for c in range(cols):
            s = grid_index(r, c, cols)
            for a, (dr, dc) in enumerate(_GRID_MOVES):
                r2, c2 = r + dr, c + dc
                if 0 <= r2 < rows and 0 <= c2 < cols:
                    s2 = grid_index(r2, c2, cols)
                    allowed[s, a] = True
                    P[s, a, s2] += 1.0 - slip
                    P[s, a, s] += slip
                    moves[(r, c), (r2, c2)] = (s, a, s2)
    for key, value in rewards.items():
        if key not in moves:
            raise ValueError(f"reward for {key} is not a move between neighbouring cells")
        s, a, s2 = moves[key]
        R[s, a, s2] = float(value)
    return TabularModel(
        name, P, R, allowed, grid_index(*start, cols), GRID_ACTIONS, (rows, cols), tie_order
    )


def load_tokic_rewards(
    status: str | None = None,
) -> dict[tuple[tuple[int, int], tuple[int, int]], float]:
    """The reconstructed thesis Table 4.1 (Tokic et al. 2009), from the package data.

    Source: `cpg_suite/data/tokic_rewards.json` (see `cpg_suite/data/SOURCES.md`).

    Args:
      status: Only the entries of this status (`pinned`: fixed by the thesis' Tables A.2
        and A.3 or its text; `inferred`; `unknown`: placeholders); None: every entry.

    Raises:
      ValueError: If `status` is none of those.
    """
    text = (
        importlib.resources.files("cpg_suite")
        .joinpath("data/tokic_rewards.json")
        .read_text(encoding="utf-8")
    )
    data = json.loads(text)
    if status is not None and status not in data["status_meaning"]:
        raise ValueError(f"status must be one of {', '.join(data['status_meaning'])}: {status!r}")
    table = {k: v for k, v in data["rewards"].items() if status in (None, data["status"][k])}
    out = {}
    for key, value in table.items():
        a, b = key.split("->")
        out[tuple(int(v) for v in a.split(",")), tuple(int(v) for v in b.split(","))] = value
    return out


def tokic_model(slip: float = 0.0) -> TabularModel:
    """The crawler reward model of thesis Table 4.1 as a complete 5×5 grid model.

    Args:
      slip: Probability that a move does not happen (the stochastic variant).

    Returns:
      The `tokic` model; start state (0, 0), appendix tie order (up, down, left, right).
    """
    return grid_model(load_tokic_rewards(), slip=slip, name="tokic")


MODELS = {"tokic": tokic_model}
