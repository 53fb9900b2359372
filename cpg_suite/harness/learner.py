r"""The run loop shared by the policy learners (PPO and any Stable-Baselines3 learner).

A learner is given as a `Learner`: its name, its SB3 algorithm class and how to build a
fresh model from the run's settings; `run` takes it through a run. Training runs on
`num_envs` sub-environments (`cpg_suite.harness.sb3.FlatVecEnv` behind `VecNormalize`) in
segments of `validation_every` env steps (whole rollouts). Each segment starts every
sub-environment afresh from new training seeds (`segment_seed`), then learns; at its end
the deterministic policy is scored on `validation_seeds` validation seeds of the training
tier (`validate`), a row goes to progress.csv and `checkpoint.pkl` is written atomically
(the model with its optimizer, the VecNormalize statistics, NumPy's and torch's generator
states, the best-validation policy). Because a segment depends only on that state,
`--resume` continues a killed run bit for bit. At the end the best-validation policy is
scored on the test protocol (`cpg_suite.protocol.score.score_policy`) and summary.json
gets the "test" card and the simulation budget (training plus validation physics steps),
which makes a leaderboard row (`analysis.leaderboard`).

Run directory `<output_dir>/<method>/<task>/<run_name>/`: config.json, progress.csv,
checkpoint.pkl, selected_model.zip + selected_vecnormalize.pkl (the reported policy; load
with `sb3_policy.TrainedPolicy.load`), final_model.zip + final_vecnormalize.pkl, summary.json.
"""

from __future__ import annotations

import dataclasses
import math
import os
import pickle
import time
from collections.abc import Callable
from typing import Any, Protocol

import gymnasium
import numpy as np
import torch  # before cpg_suite: with MUJOCO_GL=egl the other order crashes torch (README)
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.vec_env import VecEnv, VecNormalize

from cpg_suite import progress, protocol
from cpg_suite.harness import sb3
from cpg_suite.harness.checkpoints import CheckpointError, check_identity
from cpg_suite.protocol import score
from cpg_suite.runfiles import runs, sb3_policy

PROGRESS_FIELDS = [
    "segment",
    "env_steps",
    "physics_steps",
    "episodes",
    "mean_return_m",
    "fall_rate",
    "validation_m",
    "validation_fall_rate",
    "best_validation_m",
    "steps_per_s",
    "wall_s",
]


class LearnerSettings(sb3_policy.EnvSettings, Protocol):
    """The settings of a policy learner's run the harness reads (a frozen dataclass: all of
    its fields are the run's identity)."""

    @property
    def num_envs(self) -> int: ...  # sub-environments stepped together

    @property
    def seed(self) -> int: ...  # seed of the model and of the training seeds

    @property
    def total_steps(self) -> int: ...  # training env steps (rounded up to whole rollouts)

    @property
    def rollout_steps(self) -> int: ...  # env steps per rollout (one learning update)

    @property
    def validation_every(self) -> int: ...  # env steps between validations

    @property
    def validation_seeds(self) -> int: ...  # validation seeds the policy is selected on

    @property
    def test_seeds(self) -> int: ...  # test seeds per tier of the score card (0: none)

    @property
    def test_tiers(self) -> tuple[str, ...]: ...  # the tiers of the score card

    @property
    def gamma(self) -> float: ...  # the discount (VecNormalize's reward scale)

    @property
    def supply_cost(self) -> float: ...  # κ, m/C: the reward's supply shaping (0: none)


@dataclasses.dataclass(frozen=True)
class Learner:
    """A policy learner, as the harness takes it through a run.

    Attributes:
      method: Its name: its run directories' second level and its leaderboard rows.
      program: The module that runs it as a program (config.json's re-run command).
      algorithm: Its SB3 algorithm class (`algorithm.load` restores a saved model).
      make_model: `make_model(settings, env)`: a fresh model of the run's settings,
        learning on `env` (the normalized training env), seeded from the settings.
      run_name: `run_name(settings)`: the default run directory name.
    """

    method: str
    program: str
    algorithm: type[BaseAlgorithm]
    make_model: Callable[[Any, VecEnv], BaseAlgorithm]
    run_name: Callable[[Any], str]


def run(
    learner: Learner,
    settings: LearnerSettings,
    options: runs.RunOptions | None = None,
    log: Callable[[str], None] = progress.write,
    on_checkpoint: Callable[[dict], None] | None = None,
) -> tuple[str, dict]:
    """Trains, selects and scores one policy in `<output_dir>/<method>/<task>/<run_name>/`.

    Torch runs on one CPU thread inside this call (restored after): the numbers of a run
    then do not depend on the machine's core count (a multi-threaded reduction may sum
    in another order), and the environment's physics threads (`options.threads`) get the
    cores. The networks are small, so more torch threads would gain little.

    Args:
      learner: The learner.
      settings: The run's settings.
      options: Output directory, run name (default `learner.run_name(settings)`),
        physics threads (results do not depend on them), resume, overwrite.
      log: Receives a line per segment.
      on_checkpoint: Called with the totals after each checkpoint is written.

    Returns:
      `(run_dir, summary)`; the summary holds the test score card unless `test_seeds` = 0.

    Raises:
      runs.RunDirectoryExists: The run directory holds a run and neither resume nor
        overwrite was asked.
      CheckpointError: On a corrupt or foreign checkpoint when resuming.
    """
    options = options or runs.RunOptions()
    name = options.run_name or learner.run_name(settings)
    run_dir = runs.run_directory(
        options.output_dir,
        learner.method,
        settings.task,
        name,
        overwrite=options.overwrite,
        resume=options.resume,
    )
    summary_path = os.path.join(run_dir, "summary.json")
    if options.resume and os.path.exists(summary_path):
        log(f"{run_dir}: already finished")
        return run_dir, runs.read_json(summary_path)
    checkpoint = _open(learner, settings, options, run_dir, name)
    with sb3_policy.single_threaded():
        summary = _train_and_score(
            learner, settings, options, run_dir, checkpoint, log, on_checkpoint
        )
    runs.write_json(summary_path, summary)
    return run_dir, summary


def segment_seed(settings: LearnerSettings, segment: int) -> int:
    """The training seed of sub-environment 0 in a segment (sub-environment i: + i).

    Args:
      settings: The run's settings.
      segment: The segment, from 0.

    Returns:
      A training seed drawn from (seed, segment).
    """
    rng = np.random.default_rng([settings.seed, segment])
    return int(rng.integers(protocol.TRAINING.start, protocol.TRAINING.stop - settings.num_envs))


def validate(
    model: BaseAlgorithm,
    normalizer: VecNormalize,
    env: gymnasium.vector.VectorEnv,
    settings: LearnerSettings,
) -> tuple[float, float, int]:
    """Scores the deterministic policy on the first `validation_seeds` validation seeds.

    Args:
      model: The SB3 model.
      normalizer: Its VecNormalize (statistics only; not updated).
      env: `sb3.make_vector_env(settings, settings.validation_seeds)`.
      settings: The run's settings.

    Returns:
      (success-weighted distance, m: mean over the seeds of the distance, 0 for a fall;
      fall rate; physics steps of the trials).
    """
    keys = sb3.observation_keys(env.single_observation_space)
    observations, _ = env.reset(seed=protocol.VALIDATION.start)  # seeds validation_seeds(n)
    n = env.num_envs
    distance, fell, done = np.zeros(n), np.zeros(n, bool), np.zeros(n, bool)
    control_steps = 0
    for _ in range(settings.trial_steps):
        actions = sb3.predict(model, normalizer, sb3.flatten(observations, keys))
        observations, rewards, terminated, truncated, _ = env.step(actions)
        active = ~done
        distance[active] += np.asarray(rewards)[active]
        control_steps += int(active.sum())
        fell |= np.asarray(terminated) & active
        done |= np.asarray(terminated) | np.asarray(truncated)
        if done.all():
            break
    n_sub = env.unwrapped.n_sub
    return float(np.where(fell, 0.0, distance).mean()), float(fell.mean()), control_steps * n_sub


# Checkpoints.
@dataclasses.dataclass
class _Training:
    """A run's training state: what a checkpoint holds besides the generators."""

    model: BaseAlgorithm
    normalizer: VecNormalize
    totals: dict
    rows: list
    best: dict | None
    saved: tuple[bytes, bytes] | None = None  # the model's and normalizer's last bytes

    def checkpoint(self, identity: dict) -> dict:
        """The checkpoint of the last segment (`saved`), with the generators' states."""
        model_bytes, normalizer_bytes = self.saved
        return {
            "identity": identity,
            "totals": self.totals,
            "rows": self.rows,
            "best": self.best,
            "model": model_bytes,
            "vecnormalize": normalizer_bytes,
            "np_rng": np.random.get_state(),
            "torch_rng": torch.get_rng_state(),
        }


def _fresh_totals() -> dict:
    return {
        "segment": 0,
        "rollouts": 0,
        "env_steps": 0,
        "physics_steps": 0,
        "validation_sim_steps": 0,
        "episodes": 0,
        "falls": 0,
        "best_return_m": None,
        "last_mean_return_m": None,
        "wall_s": 0.0,
    }


def _open(
    learner: Learner, settings: LearnerSettings, options: runs.RunOptions, run_dir: str, name: str
) -> dict | None:
    """The checkpoint to resume from, or None after writing a fresh run's config.json."""
    checkpoint_path = os.path.join(run_dir, "checkpoint.pkl")
    identity = dataclasses.asdict(settings)
    if options.resume and os.path.exists(checkpoint_path):
        return _read_checkpoint(checkpoint_path, identity)
    flags_of_run = {**identity, "output_dir": options.output_dir, "run_name": name}
    runs.write_config(run_dir, settings, runs.command_line(learner.program, flags_of_run))
    return None


def _read_checkpoint(path: str, identity: dict) -> dict:
    try:
        with open(path, "rb") as f:
            checkpoint = pickle.load(f)
    except (OSError, pickle.UnpicklingError, EOFError, AttributeError) as e:
        raise CheckpointError(f"cannot read checkpoint {path}: {e}") from None
    return check_identity(checkpoint, path, identity)


def _start(
    learner: Learner, settings: LearnerSettings, train_env: VecEnv, checkpoint: dict | None
) -> _Training:
    """A fresh model and normalizer on `train_env`, or the checkpoint's (generators too)."""
    if checkpoint is None:
        normalizer = sb3.normalized(train_env, settings.gamma)
        model = learner.make_model(settings, normalizer)
        return _Training(model, normalizer, _fresh_totals(), [], None)
    normalizer = pickle.loads(checkpoint["vecnormalize"])
    normalizer.set_venv(train_env)
    model = sb3_policy.load_model(learner.algorithm, checkpoint["model"], normalizer)
    np.random.set_state(checkpoint["np_rng"])
    torch.set_rng_state(checkpoint["torch_rng"])
    return _Training(
        model, normalizer, checkpoint["totals"], checkpoint["rows"], checkpoint["best"]
    )


def _write_bytes(path: str, data: bytes) -> None:
    """Writes bytes atomically (a temporary file moved into place)."""
    runs._atomic_write_bytes(path, data)


# Training.
def _train_and_score(
    learner: Learner,
    settings: LearnerSettings,
    options: runs.RunOptions,
    run_dir: str,
    checkpoint: dict | None,
    log: Callable[[str], None],
    on_checkpoint: Callable[[dict], None] | None,
) -> dict:
    """Trains to `total_steps`, writes the policies and returns the summary."""
    sb3_policy.import_torch()
    train_env = sb3.FlatVecEnv(
        sb3.make_vector_env(settings, settings.num_envs, options.threads), settings.supply_cost
    )
    threads = min(options.threads, settings.validation_seeds)
    validation_env = sb3.make_vector_env(settings, settings.validation_seeds, threads)
    try:
        state = _start(learner, settings, train_env, checkpoint)
        _train(state, settings, run_dir, train_env, validation_env, log, on_checkpoint)
        final = (sb3_policy.model_bytes(state.model), pickle.dumps(state.normalizer))
    finally:
        train_env.close()
        validation_env.close()
    _write_policies(run_dir, final, state.best)
    summary = _summary(settings, state.totals, state.best)
    if settings.test_seeds:
        summary["test"] = _test_card(learner, settings, options.threads, state.best, log)
    return summary


def _train(
    state: _Training,
    settings: LearnerSettings,
    run_dir: str,
    train_env: sb3.FlatVecEnv,
    validation_env: gymnasium.vector.VectorEnv,
    log: Callable[[str], None],
    on_checkpoint: Callable[[dict], None] | None,
) -> None:
    """The segments left: each learns, validates, checkpoints and writes its row."""
    identity = dataclasses.asdict(settings)
    checkpoint_path = os.path.join(run_dir, "checkpoint.pkl")
    total_rollouts = math.ceil(settings.total_steps / settings.rollout_steps)
    per_segment = math.ceil(settings.validation_every / settings.rollout_steps)
    with runs.ProgressCSV(os.path.join(run_dir, "progress.csv"), PROGRESS_FIELDS) as csv:
        for row in state.rows:
            csv.append(row)
        while state.totals["rollouts"] < total_rollouts:
            k = min(per_segment, total_rollouts - state.totals["rollouts"])
            row = _segment(state, settings, k, train_env, validation_env)
            _write_bytes(checkpoint_path, pickle.dumps(state.checkpoint(identity)))
            csv.append(row)
            log(_segment_line(row))
            if on_checkpoint is not None:
                on_checkpoint(dict(state.totals))


def _segment(
    state: _Training,
    settings: LearnerSettings,
    k: int,
    train_env: sb3.FlatVecEnv,
    validation_env: gymnasium.vector.VectorEnv,
) -> dict:
    """Learns `k` rollouts from fresh episodes, validates; returns the progress row."""
    start, physics_before = time.perf_counter(), train_env.physics_steps
    train_env.seed(segment_seed(settings, state.totals["segment"]))
    state.model._last_obs = None  # every segment starts from fresh episodes
    state.model.learn(k * settings.rollout_steps, reset_num_timesteps=False)
    episodes = train_env.drain_episodes()
    validation = validate(state.model, state.normalizer, validation_env, settings)
    elapsed = time.perf_counter() - start
    physics = train_env.physics_steps - physics_before
    _add_to_totals(state.totals, k, int(state.model.num_timesteps), physics, validation, episodes)
    state.totals["wall_s"] += elapsed
    state.saved = (sb3_policy.model_bytes(state.model), pickle.dumps(state.normalizer))
    _keep_best(state, validation)
    row = _progress_row(state, episodes, validation, k * settings.rollout_steps, elapsed)
    state.rows.append(row)
    return row


def _add_to_totals(
    totals: dict,
    rollouts: int,
    env_steps: int,
    physics: int,
    validation: tuple[float, float, int],
    episodes: list[tuple[float, int, bool]],
) -> None:
    """Counts one segment (all but its wall time) into the run's totals."""
    totals["segment"] += 1
    totals["rollouts"] += rollouts
    totals["env_steps"] = env_steps
    totals["physics_steps"] += physics
    totals["validation_sim_steps"] += validation[2]
    totals["episodes"] += len(episodes)
    totals["falls"] += sum(e[2] for e in episodes)
    returns = [e[0] for e in episodes]
    if returns:
        top = max(returns)
        previous = totals["best_return_m"]
        totals["best_return_m"] = top if previous is None else max(previous, top)
        totals["last_mean_return_m"] = float(np.mean(returns))


def _keep_best(state: _Training, validation: tuple[float, float, int]) -> None:
    """Makes the last segment's policy the best if it validates higher (earliest on ties)."""
    value, falls, _ = validation
    if state.best is None or value > state.best["validation_m"]:
        model_bytes, normalizer_bytes = state.saved
        state.best = {
            "validation_m": value,
            "validation_fall_rate": falls,
            "segment": state.totals["segment"],
            "env_steps": state.totals["env_steps"],
            "model": model_bytes,
            "vecnormalize": normalizer_bytes,
        }


def _progress_row(
    state: _Training,
    episodes: list[tuple[float, int, bool]],
    validation: tuple[float, float, int],
    steps: int,
    elapsed: float,
) -> dict:
    """progress.csv's row of the segment just counted."""
    totals = state.totals
    returns = [e[0] for e in episodes]
    return {
        "segment": totals["segment"],
        "env_steps": totals["env_steps"],
        "physics_steps": totals["physics_steps"],
        "episodes": len(episodes),
        "mean_return_m": float(np.mean(returns)) if returns else "",
        "fall_rate": float(np.mean([e[2] for e in episodes])) if episodes else "",
        "validation_m": validation[0],
        "validation_fall_rate": validation[1],
        "best_validation_m": state.best["validation_m"],
        "steps_per_s": round(steps / elapsed) if elapsed else 0,
        "wall_s": round(totals["wall_s"], 3),
    }


def _segment_line(row: dict) -> str:
    return (
        f"segment {row['segment']:3d}  {row['env_steps']:,} steps  episodes "
        f"{row['episodes']}  mean return {_fmt(row['mean_return_m'])} m  validation "
        f"{row['validation_m']:+.3f} m (falls {row['validation_fall_rate']:.0%})  "
        f"{row['steps_per_s']:,} steps/s"
    )


def _fmt(value) -> str:
    return "n/a" if value == "" or value is None else f"{value:+.3f}"


# The end of a run.
def _write_policies(run_dir: str, final: tuple[bytes, bytes], best: dict) -> None:
    """The final and the selected (best-validation) model and normalizer statistics."""
    _write_bytes(os.path.join(run_dir, "final_model.zip"), final[0])
    _write_bytes(os.path.join(run_dir, "final_vecnormalize.pkl"), final[1])
    _write_bytes(os.path.join(run_dir, "selected_model.zip"), best["model"])
    _write_bytes(os.path.join(run_dir, "selected_vecnormalize.pkl"), best["vecnormalize"])


def _summary(settings: LearnerSettings, totals: dict, best: dict) -> dict:
    """summary.json without the test card."""
    return {
        "action_space": settings.action_space,
        "best_distance_m": totals["best_return_m"],
        "final_mean_distance_m": totals["last_mean_return_m"],
        "evaluations": totals["episodes"],
        "falls_total": totals["falls"],
        "env_steps": totals["env_steps"],
        "sim_steps": totals["physics_steps"],
        "validation_sim_steps": totals["validation_sim_steps"],
        "segments": totals["segment"],
        "wall_s": totals["wall_s"],
        "selected": {
            "source": f"segment_{best['segment']}",
            "env_steps": best["env_steps"],
            "validation_success_weighted_m": best["validation_m"],
            "validation_fall_rate": best["validation_fall_rate"],
            "validation_seeds": settings.validation_seeds,
        },
    }


def _test_card(
    learner: Learner,
    settings: LearnerSettings,
    threads: int,
    best: dict,
    log: Callable[[str], None],
) -> dict:
    """The selected policy's score card on the test protocol (summary.json's "test")."""
    model = sb3_policy.load_model(learner.algorithm, best["model"])
    policy = sb3_policy.TrainedPolicy(model, pickle.loads(best["vecnormalize"]), settings)
    card = score.score_policy(
        policy,
        score.ScoreSettings(
            tiers=settings.test_tiers,
            seeds=settings.test_seeds,
            steps=settings.trial_steps,
            threads=threads,
        ),
    )
    log(f"selected policy: segment {best['segment']} (validation {best['validation_m']:+.3f} m)")
    log(score.format_card(card))
    return score.stored_card(card)
