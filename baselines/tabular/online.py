"""Online (real-time) learning of a tabular learner against a dm_env environment.

The loop is the study's: one iteration = one control step with one update (thesis Sec. 4.2.1).
There are no separate learning episodes: when the environment ends an episode (the pole
falls, or a time limit) it is reset and learning continues with the same tables.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from baselines.tabular.exploration import EpsilonSchedule
from baselines.tabular.learners import Learner
from cpg_suite import progress


@dataclasses.dataclass
class Episode:
    """One environment episode within an online run."""

    index: int
    start_step: int
    end_step: int  # exclusive
    fell: bool  # ended with discount 0
    episode_return: float

    @property
    def length(self) -> int:
        return self.end_step - self.start_step


@dataclasses.dataclass
class OnlineResult:
    """What an online run produced, step by step and episode by episode."""

    rewards: np.ndarray  # (steps,)
    states: np.ndarray  # (steps,) state index before each step
    actions: np.ndarray  # (steps,)
    observations: dict[str, np.ndarray]  # recorded scalar observations after each step
    episodes: list[Episode]
    fall_steps: list[int]  # 0-based step index at which each fall happened

    @property
    def falls(self) -> int:
        return len(self.fall_steps)


def run_online(
    env,
    learner: Learner,
    to_state: Callable[[dict], int],
    steps: int,
    epsilon: EpsilonSchedule,
    record: tuple[str, ...] = (),
    on_episode: Callable[[Episode], None] | None = None,
    on_step: Callable[[], None] | None = None,
) -> OnlineResult:
    """Runs `steps` learning steps of `learner` on `env` (thesis Alg. 4.2).

    Args:
      env: A `dm_env.Environment` with a discrete action spec.
      learner: The tabular learner (its tables persist across episodes).
      to_state: Maps an observation to a state index (a `Discretizer`, or a lookup).
      steps: Number of environment steps (= learning iterations).
      epsilon: ε as a function of the step count.
      record: Scalar observation names to keep for every step (e.g. `("angle",)`).
      on_episode: Called with each finished episode (for progress files).
      on_step: Called after each learning update (e.g. to record the value table).

    Returns:
      An `OnlineResult`.
    """
    log = _Log(steps, record, on_episode)
    ts = env.reset()
    s = to_state(ts.observation)
    a = learner.act(s, epsilon(0))
    for t in progress.track(range(steps), desc="online learning", unit="step"):
        ts = env.step(a)
        s2 = to_state(ts.observation)
        log.step(t, s, a, ts)
        a2 = _learn(learner, s, a, float(ts.reward), s2, float(ts.discount), epsilon(t + 1))
        if on_step is not None:
            on_step()
        if ts.last():  # No learning episodes: reset and go on with the same tables.
            log.end_episode(t + 1, fell=ts.discount == 0.0)
            learner.end_episode()
            ts = env.reset()
            s2 = to_state(ts.observation)
            a2 = learner.act(s2, epsilon(t + 1))
        s, a = s2, a2
    return log.result()


def _learn(
    learner: Learner, s: int, a: int, r: float, s2: int, discount: float, next_epsilon: float
) -> int:
    """One learning update on s --a--> s2; returns the next action a'."""
    if learner.on_policy:  # SARSA: choose a', then update on it.
        a2 = learner.act(s2, next_epsilon)
        learner.update(s, a, r, s2, discount, a2)
    else:  # Q-learning, TD: update, then choose with the updated table.
        learner.update(s, a, r, s2, discount)
        a2 = learner.act(s2, next_epsilon)
    return a2


class _Log:
    """What `run_online` records: the trajectory, the episodes and the falls."""

    def __init__(
        self, steps: int, record: tuple[str, ...], on_episode: Callable[[Episode], None] | None
    ):
        self.steps, self.record, self.on_episode = steps, record, on_episode
        self.rewards = np.zeros(steps)
        self.states = np.zeros(steps, dtype=np.int64)
        self.actions = np.zeros(steps, dtype=np.int64)
        self.recorded = {k: np.zeros(steps) for k in record}
        self.episodes: list[Episode] = []
        self.fall_steps: list[int] = []
        self.start, self.ret = 0, 0.0

    def step(self, t: int, s: int, a: int, ts) -> None:
        """Records step t: state and action before it, its reward and observations."""
        r = float(ts.reward)
        self.states[t], self.actions[t], self.rewards[t] = s, a, r
        for k in self.record:
            self.recorded[k][t] = float(np.asarray(ts.observation[k]).reshape(-1)[0])
        self.ret += r

    def end_episode(self, end: int, fell: bool) -> None:
        """Closes the episode that ends before step `end` (exclusive)."""
        if fell:
            self.fall_steps.append(end - 1)
        episode = Episode(len(self.episodes), self.start, end, fell, self.ret)
        self.episodes.append(episode)
        if self.on_episode is not None:
            self.on_episode(episode)
        self.start, self.ret = end, 0.0

    def result(self) -> OnlineResult:
        """Closes an unfinished last episode and returns the run's record."""
        if self.start < self.steps:
            self.end_episode(self.steps, fell=False)
        return OnlineResult(
            self.rewards, self.states, self.actions, self.recorded, self.episodes, self.fall_steps
        )


def balance_metrics(result: OnlineResult, last: int = 5000) -> dict:
    """The pole figures of merit of an online run.

    Returns:
      `falls`, `last_fall_step` (1-based step of the last fall, 0 if none),
      `longest_balance_steps` (longest run of steps without a fall),
      `falls_last_<last>`, `balanced_last_<last>` (no fall in the last `last` steps),
      `rms_angle_last_<last>` and `max_abs_angle_last_<last>` (rad; needs `angle` recorded).
    """
    steps = len(result.rewards)
    bounds = [-1] + result.fall_steps + [steps - 1]
    longest = max(b - a for a, b in zip(bounds, bounds[1:]))
    tail_start = max(0, steps - last)
    falls_tail = sum(1 for f in result.fall_steps if f >= tail_start)
    out = {
        "steps": steps,
        "falls": result.falls,
        "last_fall_step": (result.fall_steps[-1] + 1) if result.fall_steps else 0,
        "longest_balance_steps": int(longest),
        f"falls_last_{last}": falls_tail,
        f"balanced_last_{last}": falls_tail == 0,
    }
    if "angle" in result.observations:
        tail = result.observations["angle"][tail_start:]
        out[f"rms_angle_last_{last}"] = float(np.sqrt(np.mean(tail**2)))
        out[f"max_abs_angle_last_{last}"] = float(np.max(np.abs(tail)))
    return out
