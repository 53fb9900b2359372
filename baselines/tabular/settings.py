"""The settings of one tabular run: a frozen dataclass validated on construction.

`TabularSettings` is what `python -m baselines.tabular` builds from its flags (flag names ==
field names), what the experiment scripts build directly, what `runner.execute` runs and what
goes into the run's `config.json`. Invalid values raise `ValueError` with a one-line reason
naming the flag (the CLI reports it and exits with code 2).
"""

from __future__ import annotations

import dataclasses

import cpg_suite
from baselines.tabular import discretize, exploration, learners, models
from cpg_suite import cli
from cpg_suite.cli import require

PLANNERS = ("value_iteration", "policy_iteration")
ALGOS = PLANNERS + tuple(learners.LEARNERS)
POLE_REWARDS = ("angle", "approach")

# The study's real-time ε schedule (thesis Sec. 4.1.7): 0.9 for 100 moves, 0 at move 300.
CRAWLER_EPSILON = "0:0.9,100:0.9,300:0"


@dataclasses.dataclass(frozen=True)
class TabularSettings:
    """Every setting of a tabular run (the flags of `python -m baselines.tabular`).

    Exactly one of `task` and `model` is given.

    Attributes:
      task: Discrete cpg_suite task id (`pole_balance`, `crawler_walk`, ...).
      model: Complete tabular model (`tokic`).
      algo: One of `ALGOS`.
      gamma: Discount factor γ in [0, 1].
      alpha: Learning rate α in [0, 1] (TD learners, real-time planners).
      lam: Trace decay λ in [0, 1] (sarsa_lambda, td_lambda).
      trace: Trace type, one of `learners.TRACES`.
      double_alpha: Use the thesis' printed δ = α[...] (α applied twice).
      epsilon: ε as a constant or `step:value` points (None: `default_epsilon`).
      steps: Online learning steps (crawler: moves).
      sweeps: value_iteration: exactly this many sweeps (None: until converged).
      iterations: policy_iteration: exactly this many iterations (None: until stable).
      eval_sweeps: policy_iteration: sweeps per evaluation (None: exact solve).
      tol: value_iteration convergence tolerance.
      slip: Model: probability that a move does not happen.
      bins: Pole: `ANGLExVELOCITY` or `ANGLE` bin counts.
      force: Pole: push force, N (None: the task's default).
      actions: Pole: 3 for {-F, 0, +F}, 2 for {-F, +F}.
      reward: Pole reward variant, one of `POLE_REWARDS`.
      seed: Random seed (initial states, exploration, ties).
      output_dir: Root of the output tree.
      run_name: Run directory name (None: `seed<N>`).
      overwrite: Replace an existing run directory.
      realtime: Crawler: plan (value/policy iteration) on rewards measured online.
      explore_moves: Crawler: the first N moves are random (ε = 1), approach 1b.
      stochastic: Crawler: probability that a move does not happen.
      backward_penalty: Crawler: factor k ≥ 1 on a backward move's displacement in the
        reward (1: none; the study's CR-10).
      eval_moves: Crawler: moves of the frozen greedy policy after learning.
    """

    task: str | None = None
    model: str | None = None
    algo: str = "q_learning"
    gamma: float = 0.9
    alpha: float = 0.1
    lam: float = 0.9
    trace: str = "accumulating"
    double_alpha: bool = False
    epsilon: str | None = None
    steps: int = 20000
    sweeps: int | None = None
    iterations: int | None = None
    eval_sweeps: int | None = None
    tol: float = 1e-9
    slip: float = 0.0
    bins: str = "20x20"
    force: float | None = None
    actions: int = 3
    reward: str = "angle"
    seed: int = 0
    output_dir: str = "runs"
    run_name: str | None = None
    overwrite: bool = False
    realtime: bool = False
    explore_moves: int = 0
    stochastic: float = 0.0
    backward_penalty: float = 1.0
    eval_moves: int = 100

    def __post_init__(self):
        _check_target(self)
        _check_ranges(self)
        _check_texts(self)

    @property
    def target(self) -> str:
        """The task id or model name (the run directory's task level)."""
        return self.task or self.model

    @property
    def on_crawler(self) -> bool:
        """Whether the run acts in the MuJoCo crawler."""
        return (self.task or "").startswith("crawler")

    def run_name_or_default(self) -> str:
        """The run directory name: `run_name`, or `seed<N>`."""
        return self.run_name or f"seed{self.seed}"


def default_epsilon(settings: TabularSettings) -> str:
    """ε when none is given: the study's schedule on the crawler, 0 elsewhere."""
    if settings.epsilon is not None:
        return settings.epsilon
    return CRAWLER_EPSILON if settings.on_crawler else "0"


def _check_target(s: TabularSettings) -> None:
    """The task or model, and which algorithms can run on it."""
    require(
        (s.task is None) != (s.model is None),
        f"give exactly one of --task (a discrete task) or --model ({', '.join(models.MODELS)})",
    )
    require(s.algo in ALGOS, f"unknown --algo {s.algo!r}; valid: {', '.join(ALGOS)}")
    if s.model is not None:
        require(
            s.model in models.MODELS,
            f"unknown --model {s.model!r}; valid: {', '.join(models.MODELS)}",
        )
        return
    cpg_suite.split_task_id(s.task)  # ValueError listing the valid ids
    require(
        s.algo not in PLANNERS or (s.on_crawler and (s.realtime or s.explore_moves > 0)),
        f"{s.algo} needs a complete model (--model=tokic), or on the crawler a model "
        "measured online (--realtime or --explore_moves=N)",
    )
    require(
        s.algo not in ("td0", "td_lambda") or not s.task.startswith("pole"),
        f"{s.algo} learns state values and acts through a known successor "
        "function, which the pole does not have; use q_learning, sarsa or sarsa_lambda",
    )
    require(
        hasattr(cpg_suite.load(s.task).action_spec(), "num_values"),
        f"{s.task} has continuous actions; tabular methods need a discrete "
        "task such as pole_balance",
    )
    require(s.task.startswith(("pole", "crawler")), f"no discretizer is defined for {s.task}")


def _check_ranges(s: TabularSettings) -> None:
    """Numeric ranges of the settings."""
    for name in ("gamma", "alpha", "lam"):
        cli.require_number(name, getattr(s, name), 0, 1)
    cli.require_number("slip", s.slip, 0, 1, high_open=True)
    require(s.steps >= 1, f"--steps must be ≥ 1, got {s.steps}")
    for name, low in (("sweeps", 0), ("iterations", 1), ("eval_sweeps", 1)):
        value = getattr(s, name)
        require(value is None or value >= low, f"--{name} must be ≥ {low}, got {value}")
    cli.require_number("tol", s.tol, 0, 1e6, low_open=True)  # a choice: the Bellman residual
    require(s.seed >= 0, f"--seed must be ≥ 0, got {s.seed}")
    require(s.actions in (2, 3), f"--actions must be 2 or 3, got {s.actions}")
    if s.force is not None:
        cli.require_number("force", s.force, 0, 1e4, low_open=True)  # a choice, N
    require(s.explore_moves >= 0, f"--explore_moves must be ≥ 0, got {s.explore_moves}")
    cli.require_number("stochastic", s.stochastic, 0, 1, high_open=True)
    cli.require_number("backward_penalty", s.backward_penalty, 1, 1e6)  # a choice: finite
    require(s.eval_moves >= 0, f"--eval_moves must be ≥ 0, got {s.eval_moves}")
    require(
        not (s.algo == "policy_iteration" and s.gamma >= 1.0 and s.model is None),
        "policy_iteration in real time needs --gamma < 1",
    )


def _check_texts(s: TabularSettings) -> None:
    """The settings given as text or names: ε schedule, bins, trace, reward."""
    require(s.trace in learners.TRACES, f"unknown --trace {s.trace!r}; valid: {learners.TRACES}")
    require(s.reward in POLE_REWARDS, f"unknown --reward {s.reward!r}; valid: {POLE_REWARDS}")
    try:
        if s.epsilon is not None:
            exploration.EpsilonSchedule.parse(s.epsilon)
        bins = discretize.parse_bins(s.bins)
    except ValueError as e:
        raise ValueError(str(e)) from None
    require(len(bins) in (1, 2), f"--bins takes 1 or 2 counts, got {s.bins!r}")


# Every setting of a tabular run and its default (the fields of `TabularSettings`).
DEFAULTS = {f.name: f.default for f in dataclasses.fields(TabularSettings)}
