"""A `dm_env` environment that samples a complete tabular model.

Lets the model-free learners run on the `tokic` reward table exactly as they run on a
simulated task. The observation is the state index (`"state"`); a disallowed move leaves
the state unchanged with reward 0 and `"blocked"` set, like `crawler_walk`.
"""

from __future__ import annotations

import collections

import dm_env
import numpy as np
from dm_env import specs

from baselines.tabular.models import TabularModel


class ModelEnvironment(dm_env.Environment):
    """Samples transitions and rewards of a `TabularModel`; episodes never terminate."""

    def __init__(
        self,
        model: TabularModel,
        random: int | np.random.RandomState | None = None,
        start_state: int | None = None,
    ):
        self.model = model
        self._random = (
            random if isinstance(random, np.random.RandomState) else np.random.RandomState(random)
        )
        self._start = model.start_state if start_state is None else int(start_state)
        self._state = self._start
        self._cdf = np.cumsum(model.transitions, axis=2)

    def _observation(self, blocked: bool) -> collections.OrderedDict:
        return collections.OrderedDict(
            state=np.array(self._state, dtype=np.int64), blocked=np.array(blocked)
        )

    def reset(self) -> dm_env.TimeStep:
        self._state = self._start
        return dm_env.restart(self._observation(False))

    def step(self, action) -> dm_env.TimeStep:
        a = int(action)
        if not 0 <= a < self.model.n_actions:
            raise ValueError(f"action {a} is out of range [0, {self.model.n_actions})")
        s = self._state
        if not self.model.allowed[s, a]:
            return dm_env.transition(0.0, self._observation(True))
        u = self._random.uniform()
        s2 = int(np.searchsorted(self._cdf[s, a], u, side="right"))
        s2 = min(s2, self.model.n_states - 1)
        self._state = s2
        return dm_env.transition(float(self.model.rewards[s, a, s2]), self._observation(False))

    def observation_spec(self):
        return collections.OrderedDict(
            state=specs.DiscreteArray(self.model.n_states, name="state"),
            blocked=specs.Array((), bool, name="blocked"),
        )

    def action_spec(self):
        return specs.DiscreteArray(self.model.n_actions, name="action")


def state_of(observation) -> int:
    """The state index of a `ModelEnvironment` observation."""
    return int(observation["state"])
