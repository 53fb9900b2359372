"""Dynamic programming on complete tabular models: value and policy iteration.

Value iteration follows thesis Alg. 4.1 / Eq. 3.1 and sweeps **in place** (Gauss-Seidel) in
a given state order: that is what reproduces thesis Tables A.2/A.3 (row-major order from
(0, 0)); a synchronous sweep does not (see docs/decisions.md#tabular-methods).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from baselines.tabular.exploration import argmax_ties
from baselines.tabular.models import TabularModel


def action_values(model: TabularModel, values: np.ndarray, gamma: float) -> np.ndarray:
    """Q(s, a) = Σ_s' P[s, a, s'] (R[s, a, s'] + γ V(s')); −inf for disallowed actions."""
    q = np.einsum("ijk,ijk->ij", model.transitions, model.rewards + gamma * values[None, None, :])
    return np.where(model.allowed, q, -np.inf)


def greedy_policy(
    model: TabularModel, values: np.ndarray, gamma: float, tie_order=None
) -> np.ndarray:
    """The greedy policy of Eq. 3.2, ties to the first maximiser in `tie_order`.

    Args:
      model: The model.
      values: State values V.
      gamma: Discount factor.
      tie_order: Action order for ties (default: the model's `tie_order`).

    Returns:
      Action index per state, shape (S,).
    """
    order = tie_order if tie_order is not None else model.tie_order
    q = action_values(model, values, gamma)
    return np.array([argmax_ties(q[s], None, order) for s in range(model.n_states)])


def _check_gamma(gamma: float) -> None:
    if not 0.0 <= gamma <= 1.0:
        raise ValueError(f"gamma must lie in [0, 1], got {gamma}")


@dataclasses.dataclass
class PlanningResult:
    """Values after each iteration and the final policy."""

    values: np.ndarray  # final V, (S,)
    policy: np.ndarray  # greedy policy of the final V, (S,)
    iterations: int
    converged: bool
    history: list[np.ndarray]  # V after each iteration (index 0 = initial V)
    policies: list[np.ndarray] = dataclasses.field(default_factory=list)  # PI only


def value_iteration(
    model: TabularModel,
    gamma: float,
    sweeps: int | None = None,
    tol: float = 1e-9,
    order=None,
    initial_values: np.ndarray | None = None,
    max_sweeps: int = 100_000,
) -> PlanningResult:
    """Value iteration with in-place sweeps (thesis Alg. 4.1, Eq. 3.1).

    Args:
      model: The complete model.
      gamma: Discount factor in [0, 1].
      sweeps: Exactly this many sweeps; None sweeps until the largest change of a sweep is
        below `tol` (the study gives no tolerance).
      tol: Convergence tolerance on the sup-norm change of one sweep.
      order: State order of a sweep (default: ascending index = row-major for grids).
      initial_values: V before the first sweep (default: zeros).
      max_sweeps: Safety bound when `sweeps` is None.

    Returns:
      A `PlanningResult`; `history[k]` is V after k sweeps.

    Raises:
      ValueError: On γ outside [0, 1] or a negative number of sweeps.
    """
    _check_gamma(gamma)
    if sweeps is not None and sweeps < 0:
        raise ValueError(f"sweeps must be ≥ 0, got {sweeps}")
    order = np.arange(model.n_states) if order is None else np.asarray(order)
    v = (
        np.zeros(model.n_states)
        if initial_values is None
        else np.array(initial_values, dtype=np.float64)
    )
    P, R, allowed = model.transitions, model.rewards, model.allowed
    history = [v.copy()]
    limit = sweeps if sweeps is not None else max_sweeps
    converged = False
    done = 0
    while done < limit:
        change = 0.0
        for s in order:
            q = (P[s] * (R[s] + gamma * v[None, :])).sum(axis=1)
            new = q[allowed[s]].max()
            change = max(change, abs(new - v[s]))
            v[s] = new  # In place: later states of this sweep see it.
        done += 1
        history.append(v.copy())
        if change < tol:
            converged = True
            if sweeps is None:
                break
    return PlanningResult(v, greedy_policy(model, v, gamma), done, converged, history)


def evaluate_policy(
    model: TabularModel,
    policy: np.ndarray,
    gamma: float,
    sweeps: int | None = None,
    initial_values: np.ndarray | None = None,
    order=None,
) -> np.ndarray:
    """V^π by an exact linear solve (`sweeps=None`), or by in-place sweeps.

    With γ = 1 the exact solve needs a proper policy; use sweeps then.
    """
    n = model.n_states
    idx = np.arange(n)
    P = model.transitions[idx, policy]  # (S, S)
    r = np.einsum("ij,ij->i", P, model.rewards[idx, policy])
    if sweeps is None:
        return np.linalg.solve(np.eye(n) - gamma * P, r)
    v = np.zeros(n) if initial_values is None else np.array(initial_values, dtype=np.float64)
    order = idx if order is None else np.asarray(order)
    for _ in range(sweeps):
        for s in order:
            v[s] = r[s] + gamma * P[s] @ v
    return v


def policy_iteration(
    model: TabularModel,
    gamma: float,
    rng: np.random.RandomState,
    eval_sweeps: int | None = None,
    max_iterations: int = 1000,
    iterations: int | None = None,
) -> PlanningResult:
    """Policy iteration (thesis Sec. 4.1.6) from a uniformly random initial policy.

    One iteration = one policy evaluation + one greedy improvement (the study does not
    define its Fig. 4.4 "iteration"; this is the textbook one).

    Args:
      model: The complete model.
      gamma: Discount factor in [0, 1] (< 1 for exact evaluation).
      rng: Draws the random initial policy among allowed actions.
      eval_sweeps: None for exact evaluation, else this many in-place sweeps per
        evaluation, warm-started from the previous values (modified policy iteration).
      max_iterations: Bound when iterating to a stable policy.
      iterations: Run exactly this many iterations (e.g. 30 for Fig. 4.4) instead.

    Returns:
      A `PlanningResult`; `history[k]` is V^π after k evaluations, `policies[k]` the policy
      evaluated in iteration k + 1.
    """
    _check_gamma(gamma)
    if eval_sweeps is None and gamma >= 1.0:
        raise ValueError("exact policy evaluation needs gamma < 1; give eval_sweeps")
    policy = np.array([rng.choice(np.flatnonzero(model.allowed[s])) for s in range(model.n_states)])
    v = np.zeros(model.n_states)
    history, policies = [v.copy()], []
    limit = iterations if iterations is not None else max_iterations
    converged = False
    done = 0
    while done < limit:
        policies.append(policy.copy())
        v = evaluate_policy(model, policy, gamma, eval_sweeps, v)
        history.append(v.copy())
        done += 1
        improved = greedy_policy(model, v, gamma)
        # Keep the current action where it is still greedy (avoids cycling between ties).
        q = action_values(model, v, gamma)
        idx = np.arange(model.n_states)
        keep = q[idx, policy] >= q[idx, improved] - 1e-12
        improved = np.where(keep, policy, improved)
        stable = np.array_equal(improved, policy)
        policy = improved
        if stable and eval_sweeps is None:
            converged = True
            if iterations is None:
                break
    return PlanningResult(v, policy, done, converged, history, policies)


@dataclasses.dataclass
class Cycle:
    """The recurrent cycle reached by following a deterministic policy."""

    transient: list[int]  # states visited before entering the cycle
    states: list[int]  # the cycle, starting at its first visited state
    rewards: list[float]  # reward of each move of the cycle

    @property
    def length(self) -> int:
        return len(self.states)

    @property
    def reward(self) -> float:
        return float(sum(self.rewards))


def policy_cycle(model: TabularModel, policy: np.ndarray, start: int | None = None) -> Cycle:
    """Follows `policy` from `start` along intended successors until a state repeats.

    Args:
      model: The model (for stochastic models the intended, most likely move is used).
      policy: Action per state.
      start: Start state (default: the model's start state).

    Returns:
      The transient path and the recurrent cycle with its move rewards.
    """
    s = model.start_state if start is None else int(start)
    path: list[int] = []
    seen: dict[int, int] = {}
    while s not in seen:
        seen[s] = len(path)
        path.append(s)
        s = model.intended_successor(s, int(policy[s]))
    first = seen[s]
    cycle = path[first:]
    rewards = []
    for i, c in enumerate(cycle):
        nxt = cycle[(i + 1) % len(cycle)]
        rewards.append(float(model.rewards[c, int(policy[c]), nxt]))
    return Cycle(path[:first], cycle, rewards)
