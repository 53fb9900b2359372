"""What every gait optimizer shares with the harness: its settings and its interface.

`OptimizerSettings` holds the settings that decide a run's result (a method subclasses it
with its own); `Optimizer` is what the round loop (`cpg_suite.harness.rounds`) asks of an
optimizer (CEM, CMA-ES, or a user's own through `cpg_suite.harness.optimize.AskTell`).
"""

from __future__ import annotations

import dataclasses
from typing import Protocol

import numpy as np

from cpg_suite import cli, protocol

TASKS = protocol.TIERS  # Optimizers may train on any tier.


# The largest fall or lateral penalty, m (a choice: six orders of magnitude above the longest
# walk of a trial, under 20 m, and small enough that no round's sum of costs overflows).
MAX_PENALTY = 1e6


@dataclasses.dataclass(frozen=True)
class OptimizerSettings:
    """Settings every gait optimizer shares; all of them decide the result.

    Attributes:
      task: The DARwIn-OP task.
      population: Samples per round K (the study: 10-50).
      rounds: Rounds.
      seed: Sampling seed.
      trial_steps: Control steps per trial (the study: 1000).
      eval_seeds: Initial states each candidate is scored on (seeds 0..N-1), every round.
      fall_penalty: Cost of a fall, m.
      lateral_penalty: Cost per metre of lateral displacement.
      fresh_starts: Draw `eval_seeds` new training seeds every round (the same for all the
        round's candidates) instead of reusing seeds 0..N-1 (the study's setting).
      validation_seeds: Validation seeds the reported gait is selected on.
      validation_every: Rounds between validation scores of the mean (0: none).
      validation_top: In-sample best candidates re-scored on validation with the final mean.
      test_seeds: Test seeds per tier the selected gait is scored on at the end (0: none).
      controller: What is tuned: "open_loop" (the study's 11 CPG amplitudes) or
        "feedback" (the amplitudes and the feedback CPG's gains, `cpg_suite.feedback`).
      benchmark_version: The benchmark version trained and scored under
        (`protocol.VERSIONS`): 2, the DARwIn-OP's supply limit; 1, the study's unlimited
        physics (to reproduce its tables).
    """

    task: str = "darwin_walk"
    population: int = 50
    rounds: int = 50
    seed: int = 0
    trial_steps: int = 1000
    eval_seeds: int = 1
    fall_penalty: float = 10.0
    lateral_penalty: float = 0.0
    fresh_starts: bool = False
    validation_seeds: int = 10
    validation_every: int = 10
    validation_top: int = 3
    test_seeds: int = len(protocol.TEST)
    controller: str = "open_loop"
    benchmark_version: int = protocol.BENCHMARK_VERSION

    def __post_init__(self):
        require = cli.require
        protocol.require_version(self.benchmark_version)
        cli.require_controller(self.controller)
        require(self.task in TASKS, f"unknown --task {self.task!r}; valid: {', '.join(TASKS)}")
        for name, low in (("population", 2), ("rounds", 1), ("seed", 0), ("trial_steps", 1)):
            cli.require_integer(name, getattr(self, name), low)
        cli.require_integer("eval_seeds", self.eval_seeds, 1)
        cli.require_number("fall_penalty", self.fall_penalty, 0, MAX_PENALTY)
        cli.require_number("lateral_penalty", self.lateral_penalty, 0, MAX_PENALTY)
        cli.require_integer("validation_seeds", self.validation_seeds, 1)
        cli.require_integer("validation_every", self.validation_every, 0)
        cli.require_integer("validation_top", self.validation_top, 0)
        cli.require_integer("test_seeds", self.test_seeds, 0, len(protocol.TEST))

    def task_kwargs(self) -> dict:
        """The training task's arguments for this version (its supply limit)."""
        return {"supply": protocol.supply_limit(self.benchmark_version)}


class Optimizer(Protocol):
    """What `rounds.run_rounds` needs of an optimizer (CEM, CMA-ES, or a user's own)."""

    mean: np.ndarray  # The current distribution mean.

    @property
    def sigma(self) -> float: ...  # Its average standard deviation (for the progress file).

    def ask(self) -> np.ndarray: ...

    def tell(self, samples: np.ndarray, costs: np.ndarray) -> None: ...

    def state_dict(self) -> dict: ...

    def load_state_dict(self, state: dict) -> None: ...
