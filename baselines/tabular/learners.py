"""Model-free temporal-difference learners (thesis Sec. 4.1.3, 4.1.6).

All learners share one interface over integer states and actions:

  * `act(s, epsilon)`: ε-greedy action in state `s`;
  * `update(s, a, r, s2, discount, a2)`: one learning step for the transition
    s --a--> s2 with reward r; `discount` is the environment's (0 at a fall, 1 otherwise)
    and is multiplied by γ; `a2` is the next action (used by SARSA only);
  * `end_episode()`: clears eligibility traces.

Q-learners (Q-learning, SARSA, SARSA(λ)) act from Q. V-learners (TD(0), TD(λ)) learn state
values and act greedily on a one-step look-ahead `R̂(s, a) + γ V(succ(s, a))` with the
rewards they have observed (overwritten by the latest measurement, as in the study) and a
known deterministic successor function: the study does not say how its V-learners act,
and this is the natural reading for the crawler. They therefore need `successor`.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from baselines.tabular.exploration import argmax_ties, epsilon_greedy

TRACES = ("accumulating", "replacing")


class Learner:
    """Common state and checks of the tabular learners."""

    learns = "Q"
    on_policy = False  # True: `update` needs the next action a2 (SARSA family).

    def __init__(
        self,
        n_states: int,
        n_actions: int,
        gamma: float,
        alpha: float,
        rng: np.random.RandomState,
        allowed: np.ndarray | None = None,
        random_ties: bool = True,
        tie_order=None,
        initial_value: float = 0.0,
    ):
        """Args:
          n_states: Number of states.
          n_actions: Number of actions.
          gamma: Discount factor in [0, 1].
          alpha: Learning rate in [0, 1].
          rng: Random generator for exploration and tie-breaking.
          allowed: (n_states, n_actions) mask of allowed actions (default: all).
          random_ties: Break greedy ties at random (default) or by `tie_order`.
          tie_order: Action order for deterministic tie-breaking.
          initial_value: Initial Q (or V) for every entry; 0 is optimistic when all
            rewards are ≤ 0 (thesis Sec. 4.2.1).

        Raises:
          ValueError: If γ or α is outside [0, 1].
        """
        if not 0.0 <= gamma <= 1.0:
            raise ValueError(f"gamma must lie in [0, 1], got {gamma}")
        if not 0.0 <= alpha <= 1.0:
            raise ValueError(f"alpha must lie in [0, 1], got {alpha}")
        self.n_states, self.n_actions = int(n_states), int(n_actions)
        self.gamma, self.alpha = float(gamma), float(alpha)
        self.rng = rng
        self.allowed = (
            np.ones((n_states, n_actions), dtype=bool)
            if allowed is None
            else np.asarray(allowed, dtype=bool)
        )
        self.random_ties = random_ties
        self.tie_order = tie_order
        self.q = np.full((n_states, n_actions), float(initial_value))

    def action_values(self, s: int) -> np.ndarray:
        """Values the learner acts on in state `s` (−inf for disallowed actions)."""
        return np.where(self.allowed[s], self.q[s], -np.inf)

    def act(self, s: int, epsilon: float) -> int:
        return epsilon_greedy(
            self.action_values(s),
            epsilon,
            self.rng,
            self.allowed[s],
            self.tie_order,
            self.random_ties,
        )

    def greedy(self, s: int) -> int:
        """The greedy action in `s` with deterministic tie-breaking (for reporting)."""
        return argmax_ties(self.action_values(s), None, self.tie_order)

    def state_values(self) -> np.ndarray:
        """max_a over allowed actions of the values acted on, per state."""
        return np.array([self.action_values(s).max() for s in range(self.n_states)])

    def update(
        self, s: int, a: int, r: float, s2: int, discount: float, a2: int | None = None
    ) -> float:
        raise NotImplementedError

    def end_episode(self) -> None:
        """Clears eligibility traces (nothing to do without traces)."""


class QLearning(Learner):
    """Q-learning, thesis Alg. 4.2 / Eq. 3.3 (off-policy)."""

    def update(self, s, a, r, s2, discount, a2=None):
        target = r + self.gamma * discount * self.q[s2][self.allowed[s2]].max()
        delta = target - self.q[s, a]
        self.q[s, a] += self.alpha * delta
        return delta


class Sarsa(Learner):
    """SARSA, thesis Eq. 4.2 (on-policy: bootstraps on the action actually taken next)."""

    on_policy = True

    def update(self, s, a, r, s2, discount, a2=None):
        if a2 is None:
            raise ValueError("SARSA needs the next action a2")
        delta = r + self.gamma * discount * self.q[s2, a2] - self.q[s, a]
        self.q[s, a] += self.alpha * delta
        return delta


class EligibilityTraces:
    """Eligibility traces over a value table (thesis Eq. 4.3-4.4), decayed by γλ each step.

    The thesis prints δ = α[r + γ V(s') − V(s)] and then updates V += α δ e, i.e. α twice;
    the cited source (Sutton & Barto 1998) has α once. `double_alpha=True` reproduces the
    printed form.
    """

    def __init__(self, shape, lam: float, trace: str, double_alpha: bool):
        if not 0.0 <= lam <= 1.0:
            raise ValueError(f"lambda must lie in [0, 1], got {lam}")
        if trace not in TRACES:
            raise ValueError(f"trace must be one of {TRACES}, got {trace!r}")
        self.lam, self.trace, self.double_alpha = float(lam), trace, double_alpha
        self.e = np.zeros(shape)

    def apply(self, table: np.ndarray, index, delta: float, alpha: float, decay: float) -> None:
        """Marks `index` eligible, moves every entry of `table` by α δ e, then decays e.

        Args:
          table: The value table, updated in place.
          index: The entry just visited (state, or (state, action)).
          delta: The TD error.
          alpha: Learning rate.
          decay: γ times the environment's discount (0 at a fall).
        """
        if self.double_alpha:
            delta *= alpha
        if self.trace == "replacing":
            self.e[index] = 1.0
        else:
            self.e[index] += 1.0
        table += alpha * delta * self.e
        self.e *= decay * self.lam

    def clear(self) -> None:
        self.e[:] = 0.0


class _TracedLearner:
    """Mixin: eligibility traces over the learner's value table (`_table()`)."""

    def __init__(
        self,
        *args,
        lam: float = 0.9,
        trace: str = "accumulating",
        double_alpha: bool = False,
        **kwargs,
    ):
        super().__init__(*args, **kwargs)
        self.traces = EligibilityTraces(self._table().shape, lam, trace, double_alpha)

    @property
    def e(self) -> np.ndarray:
        """The current eligibility of every table entry."""
        return self.traces.e

    def end_episode(self):
        self.traces.clear()


class SarsaLambda(_TracedLearner, Learner):
    """SARSA(λ), thesis Eq. 4.4, with eligibility traces e(s, a) (see `EligibilityTraces`)."""

    on_policy = True

    def _table(self):
        return self.q

    def update(self, s, a, r, s2, discount, a2=None):
        if a2 is None:
            raise ValueError("SARSA(λ) needs the next action a2")
        delta = r + self.gamma * discount * self.q[s2, a2] - self.q[s, a]
        self.traces.apply(self.q, (s, a), delta, self.alpha, self.gamma * discount)
        return delta


class _VLearner(Learner):
    """Base of TD(0) / TD(λ): learns V and a reward table R̂, acts by one-step look-ahead."""

    learns = "V"

    def __init__(self, *args, successor: Callable[[int, int], int] | None = None, **kwargs):
        super().__init__(*args, **kwargs)
        if successor is None:
            raise ValueError(
                "TD(0) and TD(λ) learn state values and need the task's deterministic "
                "successor function to act; use a tabular model or the crawler, or a "
                "Q-learner (q_learning, sarsa, sarsa_lambda)"
            )
        self.v = np.full(self.n_states, self.q[0, 0])
        self.r_hat = np.zeros((self.n_states, self.n_actions))
        self._succ = np.zeros((self.n_states, self.n_actions), dtype=np.int64)
        for s in range(self.n_states):
            for a in range(self.n_actions):
                self._succ[s, a] = successor(s, a) if self.allowed[s, a] else s

    def action_values(self, s):
        return np.where(
            self.allowed[s], self.r_hat[s] + self.gamma * self.v[self._succ[s]], -np.inf
        )

    def state_values(self):
        return self.v.copy()

    def _record(self, s, a, r):
        self.r_hat[s, a] = r  # The latest measurement overwrites (thesis Sec. 4.1.4).


class TD0(_VLearner):
    """TD(0), thesis Eq. 4.1: V(s) += α [r + γ V(s') − V(s)]."""

    def update(self, s, a, r, s2, discount, a2=None):
        self._record(s, a, r)
        delta = r + self.gamma * discount * self.v[s2] - self.v[s]
        self.v[s] += self.alpha * delta
        return delta


class TDLambda(_TracedLearner, _VLearner):
    """TD(λ), thesis Eq. 4.3, with state eligibility traces (see `EligibilityTraces`)."""

    def _table(self):
        return self.v

    def update(self, s, a, r, s2, discount, a2=None):
        self._record(s, a, r)
        delta = r + self.gamma * discount * self.v[s2] - self.v[s]
        self.traces.apply(self.v, s, delta, self.alpha, self.gamma * discount)
        return delta


class RealTimeValueIteration(_VLearner):
    """Thesis Alg. 4.1 in real time: the robot acts, and after every move R̂(s, a) ← r and
    one in-place sweep over all states, V(s) = max_a [R̂(s, a) + γ V(succ(s, a))].

    The reward table starts at 0 and is filled in as moves are made (the latest measurement
    overwrites, thesis Sec. 4.1.4). With `slip` = p > 0 (the stochastic variant, p known)
    the backup is the expectation (1 − p)[R̂ + γ V(succ)] + p γ V(s), and a move that left
    the state unchanged is taken for a slip and does not overwrite R̂.
    """

    def __init__(self, *args, slip: float = 0.0, **kwargs):
        super().__init__(*args, **kwargs)
        if not 0.0 <= slip < 1.0:
            raise ValueError(f"slip must lie in [0, 1), got {slip}")
        self.slip = float(slip)

    def _backup(self, s: int) -> np.ndarray:
        moved = self.r_hat[s] + self.gamma * self.v[self._succ[s]]
        return (1.0 - self.slip) * moved + self.slip * self.gamma * self.v[s]

    def action_values(self, s):
        return np.where(self.allowed[s], self._backup(s), -np.inf)

    def _observe(self, s, a, r, s2):
        if not (self.slip > 0.0 and s2 == s and self._succ[s, a] != s):
            self._record(s, a, r)

    def update(self, s, a, r, s2, discount, a2=None):
        self._observe(s, a, r, s2)
        change = 0.0
        for state in range(self.n_states):  # One in-place (Gauss-Seidel) sweep.
            new = self._backup(state)[self.allowed[state]].max()
            change = max(change, abs(new - self.v[state]))
            self.v[state] = new
        return change


class RealTimePolicyIteration(RealTimeValueIteration):
    """Policy iteration in real time: after every move, R̂(s, a) ← r, the greedy policy of
    the current V is evaluated exactly on R̂ (a linear solve), and acting is greedy on the
    result (one evaluation + improvement per move)."""

    def update(self, s, a, r, s2, discount, a2=None):
        self._observe(s, a, r, s2)
        n = self.n_states
        policy = np.array(
            [argmax_ties(self.action_values(x), None, self.tie_order) for x in range(n)]
        )
        idx = np.arange(n)
        succ = self._succ[idx, policy]
        transition = np.zeros((n, n))
        transition[idx, succ] += 1.0 - self.slip
        transition[idx, idx] += self.slip
        reward = (1.0 - self.slip) * self.r_hat[idx, policy]
        old = self.v.copy()
        self.v = np.linalg.solve(np.eye(n) - self.gamma * transition, reward)
        return float(np.abs(self.v - old).max())


LEARNERS = {
    "q_learning": QLearning,
    "sarsa": Sarsa,
    "sarsa_lambda": SarsaLambda,
    "td0": TD0,
    "td_lambda": TDLambda,
}

# Model-based planners learning their reward model online (thesis Alg. 4.1, "real time").
REALTIME_PLANNERS = {
    "value_iteration": RealTimeValueIteration,
    "policy_iteration": RealTimePolicyIteration,
}
