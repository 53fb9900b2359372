r"""The benchmark's score card: what a gait or a policy does on the held-out test tiers.

  python -m cpg_suite.protocol.score --params=hand_tuned
  python -m cpg_suite.protocol.score --out=DIR \
      --params=runs/cmaes/darwin_walk/K50_s1_seed0/best_params.json

Per tier (`cpg_suite.protocol.TIERS`), over the 50 test seeds: success-weighted distance (a
fallen trial scores 0; the score that ranks methods), fall rate, the distance's mean, median
and interquartile mean, 95 % bootstrap intervals (`scipy.stats.bootstrap`, percentile, a
fixed generator so a card is reproducible) and a Wilson interval for the fall rate, and the
gait-quality medians of `cpg_suite.evaluation.quality`. "all" pools the tiers' trials (equal
weight).

Open-loop gaits run on the batched `mujoco.rollout` evaluator; a policy (any callable from
a dm_env observation to a 12-vector action in [−1, 1]) runs step by step. Both give the
numbers stepping the environment gives (tested).

A card made under other settings than the protocol's card settings (every tier, all 50
test seeds, 1000-step trials, the version's supply limit) says so: `"protocol": false` and
the list of differences (`"not_protocol"`, `card.deviations`) in its JSON, and
`NOT A PROTOCOL CARD (...)` at the start of its first printed line (`format_card`).
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import json
import math
import os
from collections.abc import Callable

import mujoco
import numpy as np
from absl import flags

import cpg_suite
from cpg_suite import (
    cli,
    cpg,
    electrical,
    evaluation,
    feedback,
    progress,
    protocol,
)
from cpg_suite.base import clear_invalid_state_warnings, invalid_state
from cpg_suite.darwin import recording as darwin_recording
from cpg_suite.evaluation import gait, ray_backend
from cpg_suite.evaluation import quality as gait_quality
from cpg_suite.evaluation.open_loop import BROWNOUT, FALL
from cpg_suite.protocol import card as card_stats
from cpg_suite.runfiles import runs

summarize = card_stats.summarize  # a tier's statistics (`cpg_suite.protocol.card`)
MAX_SUPPLY_WINDOW = 3600.0  # s: a window longer than any trial (inf: the whole trial)


@dataclasses.dataclass(frozen=True)
class ScoreSettings:
    """What a score card measures.

    Attributes:
      tiers: The test tiers (comma-separated on the command line; None: the benchmark
        version's, `protocol.tiers`).
      seeds: How many of the 50 test seeds (all for a reported score).
      steps: Control steps per trial (1000 = 16 s).
      threads: Evaluator threads (results do not depend on it).
      backend: "local" threads or "ray" actors (results do not depend on it).
      ray_address: The Ray cluster for backend "ray" (host:port, "auto", or None).
      controller: "open_loop" (11 amplitudes) or "feedback" (`cpg_suite.feedback`).
      benchmark_version: The benchmark version scored under (`protocol.VERSIONS`; 1: no
        supply limit).
      supply_window: The supply limit's averaging window, s (`electrical.SupplyLimit`; inf:
        the whole trial); 1 s is the benchmark's, others measure the ranking's sensitivity.
    """

    tiers: tuple[str, ...] | None = None
    seeds: int = len(protocol.TEST)
    steps: int = 1000
    threads: int = 2
    backend: str = "local"
    ray_address: str | None = None
    controller: str = "open_loop"
    benchmark_version: int = protocol.BENCHMARK_VERSION
    supply_window: float = electrical.SUPPLY_WINDOW

    def __post_init__(self):
        protocol.require_version(self.benchmark_version)
        tiers = protocol.tiers(self.benchmark_version) if self.tiers is None else tuple(self.tiers)
        object.__setattr__(self, "tiers", tiers)
        unknown = [t for t in tiers if t not in protocol.TIERS]
        cli.require(
            bool(tiers) and not unknown,
            f"unknown --tiers {unknown or tiers}; valid: {', '.join(protocol.TIERS)}",
        )
        cli.require_integer("seeds", self.seeds, 1, len(protocol.TEST))
        cli.require_integer("steps", self.steps, 1)
        cli.require_integer("threads", self.threads, 1)
        cli.require_backend(self.backend, self.ray_address)
        cli.require_controller(self.controller)
        protocol.require_version(self.benchmark_version)
        cli.require(
            isinstance(self.supply_window, (int, float))
            and (0 < self.supply_window <= MAX_SUPPLY_WINDOW or self.supply_window == math.inf),
            f"--supply_window must be in (0, {MAX_SUPPLY_WINDOW:g}] s or inf (the whole "
            f"trial), got {self.supply_window!r}",
        )

    def task_kwargs(self) -> dict:
        """The tiers' task arguments for this version (the supply's limit)."""
        return {"supply": protocol.supply_limit(self.benchmark_version, self.supply_window)}


def _card(per_tier: dict, settings: ScoreSettings, budget: dict) -> dict:
    keys = ("d", "f", "c")
    pooled = {k: np.concatenate([per_tier[t][k] for t in settings.tiers]) for k in keys}
    pooled_quality = {
        f: np.concatenate([per_tier[t]["q"][f] for t in settings.tiers])
        for f in gait_quality.FIELDS
    }

    def row(d, f, q, c):
        return card_stats.row(d, f, q, c, settings.steps)

    deviations = card_stats.deviations(
        settings.tiers,
        settings.seeds,
        settings.steps,
        settings.benchmark_version,
        settings.supply_window,
    )
    # A card made under other settings says so (a protocol card: no key, as before).
    marking = (
        {card_stats.PROTOCOL_KEY: False, card_stats.DEVIATIONS_KEY: deviations}
        if deviations
        else {}
    )
    return {
        "benchmark_version": settings.benchmark_version,
        **marking,
        # Where it ran is not what it measured: the card is the same on either backend.
        "settings": {
            k: v
            for k, v in dataclasses.asdict(settings).items()
            if k not in ("backend", "ray_address")
        },
        "seeds": protocol.held_out_seeds(settings.seeds),
        "tiers": {
            t: row(per_tier[t]["d"], per_tier[t]["f"], per_tier[t]["q"], per_tier[t]["c"])
            for t in settings.tiers
        },
        "all": row(pooled["d"], pooled["f"], pooled_quality, pooled["c"]),
        "scoring_sim_steps": budget["sim_steps"],
    }


def score_gait(amplitudes: np.ndarray, settings: ScoreSettings | None = None) -> dict:
    """The score card of an open-loop CPG gait.

    Args:
      amplitudes: The 11 CPG amplitudes, degrees.
      settings: What to measure (default: every tier, all 50 test seeds).

    Returns:
      The card: per tier and pooled ("all") statistics, the seeds, the settings.

    Raises:
      ray_backend.ClusterUnreachable: With backend "ray", if no cluster answers.
    """
    return score_gait_trials(amplitudes, settings)[0]


# What a run stores of its card (summary.json's "test"): the card less its settings and
# seeds, which the run's config holds; the marking of a non-protocol card where it has one.
CARD_KEYS = (
    "benchmark_version",
    card_stats.PROTOCOL_KEY,
    card_stats.DEVIATIONS_KEY,
    "tiers",
    "all",
    "scoring_sim_steps",
)


def stored_card(card: dict) -> dict:
    """The part of a card a run stores (`CARD_KEYS`; a protocol card has no marking)."""
    return {k: card[k] for k in CARD_KEYS if k in card}


# The columns of a card's per-trial table (`score_gait_trials`, `trials.csv` of a shipped run);
# after them, one column per gait-quality measure of the card (a row's `quality`).
TRIAL_FIELDS = ("tier", "seed", "distance_m", "fell", "fall_step", "cause")


def trial_row(tier: str, seed: int, arrays: dict, i: int) -> dict:
    """Trial `i` of a tier's arrays (`d`, `f`, `s`, `c`, `q`) as a trial table's row: its
    outcome (`TRIAL_FIELDS`) and its gait-quality measures (`quality`: a float each, None
    where the trial has none: NaN), from which the card's medians are made."""
    return {
        "tier": tier,
        "seed": seed,
        "distance_m": float(arrays["d"][i]),
        "fell": bool(arrays["f"][i]),
        "fall_step": int(arrays["s"][i]),
        "cause": cause_name(arrays["c"][i]),
        "quality": {f: _measure(v[i]) for f, v in arrays["q"].items()},
    }


def _measure(value) -> float | None:
    value = float(value)
    return None if math.isnan(value) else value


def score_gait_trials(
    amplitudes: np.ndarray, settings: ScoreSettings | None = None
) -> tuple[dict, list[dict]]:
    """The score card of a gait (`score_gait`) and the trials behind it.

    Args:
      amplitudes: The 11 CPG amplitudes (or the feedback CPG's parameters), degrees.
      settings: What to measure (default: every tier, all 50 test seeds).

    Returns:
      `(card, trials)`: `trials` has one row per tier and test seed with `TRIAL_FIELDS`
      (distance in metres, the failure flag, the 1-based control step of the failure or
      0, its cause: "fall", "brownout" or "").

    Raises:
      ray_backend.ClusterUnreachable: With backend "ray", if no cluster answers.
    """
    return cards_and_trials(np.asarray(amplitudes), [settings or ScoreSettings()])[0]


def cards_and_trials(
    gait_or_policy, settings_list: list[ScoreSettings]
) -> list[tuple[dict, list[dict]]]:
    """Cards and trial tables of one gait or policy under several settings that differ
    only in their tiers and benchmark version (with the same task physics: the versions'
    `protocol.trained_alike` and supply equal), each tier scored once.

    `verify.upgrade_run` makes a run's card under its own version and under a version that
    adds a tier from one scoring: each card is the one its settings alone give, bit for bit.

    Args:
      gait_or_policy: The gait's parameters (an array), or a policy (a callable).
      settings_list: The settings, each as `score_gait_trials` takes them.

    Returns:
      `(card, trials)` per settings, in order.

    Raises:
      ValueError: If the settings differ in more than tiers and version.
      ray_backend.ClusterUnreachable: With backend "ray", if no cluster answers.
    """
    union = settings_list[-1]
    tiers = tuple(dict.fromkeys(t for s in settings_list for t in s.tiers))
    for s in settings_list:
        alike = dataclasses.replace(s, tiers=union.tiers, benchmark_version=union.benchmark_version)
        if alike != union or s.task_kwargs() != union.task_kwargs():
            raise ValueError(f"settings differ in more than tiers and version: {s} vs {union}")
    union = dataclasses.replace(union, tiers=tiers)
    if callable(gait_or_policy):
        per_tier = _policy_tiers(gait_or_policy, union)
    else:
        with ray_backend.connected(union.backend, union.ray_address):
            per_tier = _score_tiers(gait_or_policy, union)
    return [_card_and_trials(per_tier, s) for s in settings_list]


def _card_and_trials(per_tier: dict, settings: ScoreSettings) -> tuple[dict, list[dict]]:
    """The card and trial table of the tiers `settings` names, from per-tier arrays."""
    seeds = protocol.held_out_seeds(settings.seeds)
    trials = [
        trial_row(tier, seed, per_tier[tier], i)
        for tier in settings.tiers
        for i, seed in enumerate(seeds)
    ]
    sim_steps = sum(int(per_tier[t]["n"]) for t in settings.tiers)
    return _card(per_tier, settings, {"sim_steps": sim_steps}), trials


def cause_name(cause: int) -> str:
    """A trial's cause code (`open_loop.FALL`, `BROWNOUT`, 0) as the trial table writes it."""
    return electrical.CAUSES[int(cause) - 1] if cause else ""


def _score_tiers(amplitudes: np.ndarray, settings: ScoreSettings) -> dict:
    """A gait's arrays per tier (`_gait_tier`'s, with `n`: the tier's physics steps)."""
    seeds = protocol.held_out_seeds(settings.seeds)
    per_tier = {}
    for tier in progress.track(settings.tiers, desc="tiers", unit="tier"):
        arrays, steps = _gait_tier(amplitudes, tier, seeds, settings)
        per_tier[tier] = {**arrays, "n": steps}
    return per_tier


def _gait_tier(amplitudes: np.ndarray, tier: str, seeds, settings: ScoreSettings) -> tuple:
    """A gait's trials on one tier's seeds: their arrays (`d`, `f`, `s`, `c`, `q`) and the
    physics steps they took."""
    with evaluation.open_evaluator(
        tier,
        settings.steps,
        settings.threads,
        settings.backend,
        settings.ray_address,
        settings.controller,
        task_kwargs=settings.task_kwargs(),
    ) as evaluator:
        result = evaluator.evaluate(amplitudes, list(seeds), quality=True)
    arrays = {
        "d": result.distance_m[0],
        "f": result.fell[0],
        "s": result.fall_step[0],
        "c": result.cause[0],
        "q": {f: v[0] for f, v in result.quality.items()},
    }
    return arrays, result.sim_steps


def seed_trials(gait_or_policy, settings: ScoreSettings, seeds_by_tier: dict) -> list[dict]:
    """The trials of a gait or a policy on chosen test seeds of each tier, as the card's
    trial table holds them (`TRIAL_FIELDS`): each trial is the one the full card runs, bit
    for bit (a trial depends only on its tier and seed).

    Args:
      gait_or_policy: The gait's parameters (an array), or a policy (a callable).
      settings: What the card measures (`tiers` and `seeds` unused).
      seeds_by_tier: {tier: [seed, ...]}, in the order wanted.

    Returns:
      One row per chosen trial, tier by tier.
    """
    rows = []
    tiers = [tier for tier, seeds in seeds_by_tier.items() if seeds]
    if callable(gait_or_policy):
        done = {
            tiers[i]: _policy_tier(gait_or_policy, tiers[i], seeds_by_tier[tiers[i]], settings)
            for i in _order(gait_or_policy, len(tiers))
        }
    for tier in tiers:
        seeds = seeds_by_tier[tier]
        if callable(gait_or_policy):
            arrays = _policy_arrays(done[tier])
        else:
            arrays, _ = _gait_tier(np.asarray(gait_or_policy), tier, seeds, settings)
        rows += [trial_row(tier, seed, arrays, i) for i, seed in enumerate(seeds)]
    return rows


def policy_trial(
    policy: Callable[[dict], np.ndarray],
    tier: str,
    seed: int,
    steps: int = 1000,
    task_kwargs: dict | None = None,
) -> dict:
    """One trial of a policy on a tier, stepping the physics as `control.Environment` does.

    Each control step (`control_step`): the task applies the action (and any push), the
    physics takes its substeps as dm_control's stepping does (`mj_step2` finishes the step
    whose `mj_step1` ran for the last observation, then `mj_step`; each one's quality
    sensors recorded, as `mujoco.rollout` records them), then `mj_step1` refreshes
    positions and velocities for the observation, and the task adds the step's supply
    currents. A fall, a brown-out or a divergent state (MuJoCo's invalid-state warnings)
    ends the trial.

    Args:
      policy: Maps the task's observation (an ordered dict of arrays) to a (12,) action.
      tier: A task id of `cpg_suite.protocol.TIERS`.
      seed: The episode's seed.
      steps: Control steps.
      task_kwargs: Further task arguments (default: the benchmark version's supply limit).

    Returns:
      `distance_m`, `lateral_m`, `fell` (failed: a fall or a brown-out), `fall_step`
      (1-based or 0), `cause` (0, `open_loop.FALL` or `open_loop.BROWNOUT`), `sim_steps`
      and the gait-quality measures under `quality`.
    """
    if task_kwargs is None:
        task_kwargs = ScoreSettings().task_kwargs()
    trial = _Trial(*start_trial(policy, tier, seed, task_kwargs))
    for t in range(steps):
        if trial.step(policy(trial.observation), t):
            break
    return trial.result()


class _Trial:
    """One policy trial's environment and what it has recorded (`policy_trial`)."""

    def __init__(self, env, observation, n_sub: int):
        self.env, self.observation, self.n_sub = env, observation, n_sub
        self.start = env.physics.torso_position()
        self.last, self.ended = None, (0, 0)
        self.records = []  # the gait-quality inputs of each control step (`sensor_steps`)

    def step(self, action, t: int) -> bool:
        """Control step t with `action` (`control_step`); whether the trial has ended."""
        env = self.env
        last, ended, observation = control_step(
            action, env.task, env.physics, self.n_sub, t, self.records
        )
        self.last = last if last is not None else self.last
        self.observation = observation if observation is not None else self.observation
        self.ended = ended
        return bool(ended[0])

    def result(self) -> dict:
        last = self.start if self.last is None else self.last
        distance = float(last[0] - self.start[0])
        fall_step, cause = self.ended
        return {
            "distance_m": distance,
            "lateral_m": float(last[1] - self.start[1]),
            "fell": bool(fall_step),
            "fall_step": fall_step,
            "cause": cause,
            "sim_steps": sum(len(chunk[0]) for chunk in self.records),
            "quality": _quality(self.records, self.env.physics, distance),
        }


def start_trial(policy, tier: str, seed: int, task_kwargs: dict | None = None) -> tuple:
    """The start of `policy_trial`: the tier's environment reset with `seed` (no time
    limit), the policy reset, the first observation and the physics steps per control step.

    Args:
      task_kwargs: Further task arguments (e.g. `supply`).

    Returns:
      `(env, observation, n_sub)`.
    """
    kwargs = {"random": seed, "time_limit": float("inf"), **(task_kwargs or {})}
    env = cpg_suite.load(tier, task_kwargs=kwargs)
    if hasattr(policy, "reset"):
        policy.reset()
    observation = env.reset().observation
    n_sub = int(round(env.control_timestep() / env.physics.model.opt.timestep))
    return env, observation, n_sub


def step_policy(policy, task, physics, observation, steps: int, n_sub: int, record=None):
    """The control loop of `policy_trial`, for other records (`control_step`).

    Args:
      policy, task, physics, observation: The policy, the environment's task and physics
        after its reset, and the first observation.
      steps: Control steps.
      n_sub: Physics steps per control step.
      record: Called with the physics after each physics step; its values are returned
        (default: the gait-quality inputs).

    Returns:
      The torso position after the last valid control step (None if none), the failure
      as `(1-based control step or 0, cause)`, and the per-physics-step records.
    """
    last, records = None, []
    for t in range(steps):
        position, ended, observation = control_step(
            policy(observation), task, physics, n_sub, t, records, record or _record
        )
        last = position if position is not None else last
        if ended[0]:
            return last, ended, records
    return last, (0, 0), records


def control_step(action, task, physics, n_sub: int, t: int, records: list, record=None):
    """Control step t of a trial, as `control.Environment.step` takes it.

    Args:
      action: The policy's (12,) action.
      task, physics: The trial's task and physics.
      n_sub: Physics steps per control step.
      t: The control step (0-based).
      records: Extended with `record`'s value after each physics step; without `record`,
        given the step's gait-quality inputs as one chunk (`darwin_recording.sensor_steps`).
      record: Called with the physics after each physics step.

    Returns:
      `(position, (failure step or 0, cause), observation)`: the torso's position and the
      new observation (None after a divergent step, which ends the trial).
    """
    model, data = physics.model.ptr, physics.data.ptr
    task.before_step(action, physics)
    clear_invalid_state_warnings(data)
    if record is None:
        darwin_recording.substeps(physics, n_sub, finish=True, sensors=True)
        records.append(darwin_recording.sensor_steps(physics))
    else:
        records += darwin_recording.substeps(physics, n_sub, finish=True, record=record)
    if invalid_state(data):
        return None, (t + 1, FALL), None
    mujoco.mj_step1(model, data)  # positions and velocities for the observation
    task.after_step(physics)
    position = physics.torso_position()
    observation = task.get_observation(physics)
    if task.get_termination(physics) is not None:
        return position, (t + 1, FALL if task.failure == "fall" else BROWNOUT), observation
    return position, (0, 0), observation


def batched_policy_trials(
    policy, tier: str, seeds: list[int], steps: int, task_kwargs: dict
) -> list[dict]:
    """`policy_trial` for many seeds at once, with one policy call per control step.

    For a policy with `reset_batch(n)` and `act_batch(observations)` (observations of n
    trials as (n, ...) arrays → (n, 12) actions), whose rows do not depend on each other
    (`exported.NumpyPolicy`, `sb3_policy.TrainedPolicy`): each trial then takes the steps
    `policy_trial` takes, and its result is the same, bit for bit (`tests/test_score.py`).
    A trial that has ended keeps its row in the batch (its last observation) but is not
    stepped. The trials are stepped in this thread: with the policy's and the task's
    Python holding the GIL, two threads were slower than one on 2 cores
    (`benchmarks/bench_policy_score.py`).

    Returns:
      The trials' results, as `policy_trial`'s, in the order of `seeds`.
    """
    trials = [_Trial(*start_trial(None, tier, seed, task_kwargs)) for seed in seeds]
    policy.reset_batch(len(trials))
    keys = trials[0].observation.keys()
    active = list(range(len(trials)))
    for t in range(steps):
        observations = {k: np.stack([trial.observation[k] for trial in trials]) for k in keys}
        actions = policy.act_batch(observations)
        active = [i for i in active if not trials[i].step(actions[i], t)]
        if not active:
            break
    return [trial.result() for trial in trials]


def _quality(chunks: list, physics, distance: float) -> dict:
    """The card's gait-quality measures of a trial from its control steps' chunks."""
    columns = [np.concatenate(c) for c in zip(*chunks)] if chunks else [np.zeros((0, 20))] * 5
    return gait_quality.measures(
        columns[0],
        columns[1],
        columns[2].reshape(-1, 2),
        columns[3].reshape(-1, 2, 3),
        columns[4].reshape(len(columns[4]), 2, -1),
        damping=physics.servo_damping(),
        timestep=float(physics.model.opt.timestep),
        torque_limit=physics.torque_limit(),
        mass=physics.total_mass(),
        distance=distance,
    )


def _record(physics) -> tuple:
    return (
        physics.servo_velocities(),
        physics.servo_forces(),
        physics.foot_touch(),
        physics.sole_velocities(),
        physics.footing_sensors(),
    )


def score_policy(
    policy: Callable[[dict], np.ndarray], settings: ScoreSettings | None = None
) -> dict:
    """The score card of a policy (closed- or open-loop), stepping each trial.

    Args:
      policy: Maps the task's observation to a (12,) action in [−1, 1]. If it has a
        `reset()` method, that is called before each trial.
      settings: What to measure (default: every tier, all 50 test seeds; `threads` unused).

    Returns:
      The card, as `score_gait`.
    """
    return score_policy_trials(policy, settings)[0]


def score_policy_trials(
    policy: Callable[[dict], np.ndarray], settings: ScoreSettings | None = None
) -> tuple[dict, list[dict]]:
    """The score card of a policy (`score_policy`) and the trials behind it.

    Returns:
      `(card, trials)`, as `score_gait_trials`.
    """
    return cards_and_trials(policy, [settings or ScoreSettings()])[0]


def _policy_tiers(policy, settings: ScoreSettings) -> dict:
    """A policy's arrays per tier (`d`, `f`, `s`, `c`, `q` and `n`, as `_score_tiers`)."""
    seeds = protocol.held_out_seeds(settings.seeds)
    tiers = settings.tiers
    done = {
        tiers[i]: _policy_tier(policy, tiers[i], seeds, settings)
        for i in _order(policy, len(tiers))
    }
    return {tier: _policy_arrays(done[tier]) for tier in tiers}


def _policy_arrays(trials: list[dict]) -> dict:
    """A policy's trials on one tier (`_policy_tier`) as a tier's arrays (`_gait_tier`'s,
    with `n`)."""
    return {
        "d": np.array([r["distance_m"] for r in trials]),
        "f": np.array([r["fell"] for r in trials]),
        "s": np.array([r["fall_step"] for r in trials]),
        "c": np.array([r["cause"] for r in trials]),
        "q": {f: np.array([r["quality"][f] for r in trials]) for f in gait_quality.FIELDS},
        "n": sum(r["sim_steps"] for r in trials),
    }


def _policy_tier(policy, tier: str, seeds, settings: ScoreSettings) -> list[dict]:
    """A policy's trials on one tier's seeds (`batched_policy_trials` or `policy_trial`), in
    the order of `seeds`; run in the order the policy's `trial_order` draws, if it has one
    (`sandbox.IsolatedPolicy`: a trial depends only on its tier and seed, so the results
    are the same, and a policy counting its trials learns nothing of which one it is in)."""
    seeds = list(seeds)
    order = _order(policy, len(seeds))
    run = [seeds[i] for i in order]
    if hasattr(policy, "act_batch"):
        done = batched_policy_trials(policy, tier, run, settings.steps, settings.task_kwargs())
    else:
        done = [
            policy_trial(policy, tier, seed, settings.steps, settings.task_kwargs())
            for seed in progress.track(run, desc=tier)
        ]
    results = [None] * len(seeds)
    for i, result in zip(order, done):
        results[i] = result
    return results


def _order(policy, n: int) -> list[int]:
    """The order to run n trials or tiers of a policy in (`_policy_tier`)."""
    draw = getattr(policy, "trial_order", None)
    return [int(i) for i in draw(n)] if callable(draw) else list(range(n))


class OpenLoopPolicy:
    """An open-loop CPG gait as a policy: the CPG's targets, one per call since `reset()`."""

    def __init__(self, amplitudes: np.ndarray, steps: int = 1000):
        # Made here, once: a policy process's trials start from this state (`sandbox`).
        env = cpg_suite.load("darwin_walk")
        amplitudes = np.asarray(amplitudes, dtype=np.float64)
        targets = cpg.trajectories(amplitudes, steps, env.control_timestep())
        self._actions = env.physics.targets_to_action(targets[0])
        self._steps = steps
        self._t = 0

    def __call__(self, observation: dict) -> np.ndarray:
        action = self._actions[self._t % self._steps]
        self._t += 1
        return action

    def reset(self) -> None:
        """Starts the pattern again (call before each trial)."""
        self._t = 0


def score_text(row: dict) -> str:
    """A card row's success-weighted distance with its 95 % interval, as one phrase.

    Args:
      row: A row of a score card (`card["all"]` or `card["tiers"][tier]`).

    Returns:
      "<mean> m [<low>, <high>]", signed, 3 decimals.
    """
    swd = row["success_weighted_distance_m"]
    return f"{swd['mean']:+.3f} m [{swd['ci95'][0]:+.3f}, {swd['ci95'][1]:+.3f}]"


REAL_ROBOT_SPEED = 0.214  # m/s: a ROBOTIS OP2 walking 3 m in 14 s (docs/darwin_op_model.md)


def format_card(card: dict) -> str:
    """The card as a fixed-width table, one line per tier and one for all tiers, then the
    feet's measures (`footing`) in a second table; the first line says so when the card is
    not the protocol's (`card.card_deviations`)."""
    deviations = card_stats.card_deviations(card)
    marking = f"NOT A PROTOCOL CARD ({'; '.join(deviations)}); " if deviations else ""
    lines = [
        f"{marking}benchmark version {card.get('benchmark_version', 1)}; "
        f"speed = success-weighted distance / trial time (the real robot: {REAL_ROBOT_SPEED} m/s)",
        f"{'tier':<24} {'success-weighted m [95% CI]':>30} {'m/s':>5} {'fail':>6} "
        f"{'brown':>6} {'median m':>9} {'CoT':>6} {'slip/m':>7} {'sat.':>6} "
        f"{'peak rad/s':>10} {'over 5.76':>9} {'A':>5} {'1s A':>5} {'W':>6} {'J/m':>6}",
    ]
    for name, row in [*card["tiers"].items(), ("all", card["all"])]:
        swd, q = row["success_weighted_distance_m"], row["quality"]
        brownout = (row.get("failures_by_cause") or {}).get("brownout")
        lines.append(
            f"{name:<24} {swd['mean']:>8.3f} [{swd['ci95'][0]:.3f}, {swd['ci95'][1]:.3f}]"
            f"{'':>5} {_fmt(row.get('speed_m_s'), '.3f'):>5} {row['fall_rate']['value']:>6.1%} "
            f"{_fmt(brownout, '.1%'):>6} {row['distance_m']['median']:>9.3f} "
            f"{_fmt(q['cost_of_transport']):>6} "
            f"{_fmt(q['slip_per_m']):>7} {_fmt(q['torque_limit_share'], '.1%'):>6} "
            f"{_fmt(q['peak_joint_speed'], '.2f'):>10} "
            f"{_fmt(q['over_speed_share'], '.1%'):>9} {_fmt(q.get('supply_current_a'), '.2f'):>5} "
            f"{_fmt(q.get('supply_peak_1s_a'), '.2f'):>5} "
            f"{_fmt(q['electrical_power_w'], '.1f'):>6} {_fmt(q['energy_per_m'], '.0f'):>6}"
        )
    if "contact_slip_per_m" not in card["all"]["quality"]:  # a card made before them
        return "\n".join(lines)
    # How the feet meet the floor (`footing`).
    lines.append(
        f"{'feet on the floor':<24} {'contact slip/m':>14} {'flat stance':>11} "
        f"{'swing clearance mm':>18} {'toe strikes':>11} {'heel strikes':>12}"
    )
    for name, row in [*card["tiers"].items(), ("all", card["all"])]:
        q = row["quality"]
        clearance = q.get("swing_clearance_m")
        lines.append(
            f"{name:<24} {_fmt(q.get('contact_slip_per_m')):>14} "
            f"{_fmt(q.get('flat_stance_share'), '.1%'):>11} "
            f"{_fmt(None if clearance is None else 1000 * clearance, '.1f'):>18} "
            f"{_fmt(q.get('toe_strike_share'), '.1%'):>11} "
            f"{_fmt(q.get('heel_strike_share'), '.1%'):>12}"
        )
    return "\n".join(lines)


def _fmt(value, spec: str = ".2f") -> str:
    return "n/a" if value is None else format(value, spec)


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    d = ScoreSettings()
    flags.DEFINE_string("params", "hand_tuned", f"Preset ({', '.join(cpg.PRESETS)}) or JSON.")
    flags.DEFINE_list(
        "tiers",
        None,
        f"none: --benchmark_version's (version {protocol.BENCHMARK_VERSION}: all "
        f"{len(protocol.TIERS)}). Test tiers, of {', '.join(protocol.TIERS)}.",
    )
    flags.DEFINE_integer("seeds", d.seeds, "How many of the 50 test seeds.")
    flags.DEFINE_integer("steps", d.steps, "Control steps per trial.")
    flags.DEFINE_integer("threads", d.threads, "Evaluator threads (results do not depend on it).")
    cli.define_backend_flags()
    flags.DEFINE_enum("controller", d.controller, list(cli.CONTROLLERS), "What --params holds.")
    flags.DEFINE_integer(
        "benchmark_version",
        d.benchmark_version,
        f"Score under this benchmark version: {protocol.VERSIONS}.",
    )
    flags.DEFINE_float(
        "supply_window", d.supply_window, "The supply limit's averaging window, s (inf: trial)."
    )
    flags.DEFINE_string("out", None, "Directory for score.json (default: print only).")


def main(argv):
    del argv
    settings = cli.settings_from_flags(ScoreSettings)
    try:
        if settings.controller == "feedback" and flags.FLAGS.params not in cpg.PRESETS:
            cli.check(
                os.path.isfile(flags.FLAGS.params),
                f"--params {flags.FLAGS.params!r} is neither a preset ({', '.join(cpg.PRESETS)}) "
                "nor an existing JSON file",
            )
            amplitudes = feedback.load_params(flags.FLAGS.params)
        elif settings.controller == "feedback":
            amplitudes = feedback.start_params(flags.FLAGS.params)  # a preset, gains 0
        else:
            amplitudes = gait.parse_params(flags.FLAGS.params)
    except (ValueError, json.JSONDecodeError) as e:  # one line, exit 2, before any scoring
        said = str(e) if str(e).startswith("--params") else f"--params {flags.FLAGS.params}: {e}"
        raise cli.UsageError(said) from None
    card = {"params": flags.FLAGS.params, **score_gait(amplitudes, settings)}
    print(format_card(card))
    if flags.FLAGS.out:
        os.makedirs(flags.FLAGS.out, exist_ok=True)
        path = os.path.join(flags.FLAGS.out, "score.json")
        runs.write_json(path, card)
        print(f"wrote {path}")


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_dirs=("out",))
