"""Batched evaluation of CPG gaits with `mujoco.rollout` (docs/architecture.md).

The CPG is open-loop: for fixed amplitudes the joint targets are a function of time only.
So evaluating K amplitude vectors is K independent rollouts of precomputed controls, run
in C without Python in the loop. This evaluator gives the same distances and fall verdicts
as stepping the dm_control environment (`cpg_suite.evaluation.gait.evaluate_gait`), bit for bit:

* the initial state is the task's own reset state for the seed (`mj_getState`);
* the controls are exactly those the task sets for the same actions, held for the
  substeps of each control step;
* each trajectory is rolled out in segments of `segment` control steps, carrying the
  solver warm start from segment to segment (`initial_warmstart`), which keeps the result
  identical to one uninterrupted rollout; a candidate that has fallen is not simulated
  further (the environment would have ended its episode);
* the fall test and the distance use `cpg_suite.darwin.has_fallen` and the torso position,
  as the task does.

Candidates are spread over `threads` Python threads, each calling `mujoco.rollout` (which
releases the GIL) on its own `MjData`; a candidate's result does not depend on the thread
that ran it, so results are identical for any thread count.
"""

from __future__ import annotations

import concurrent.futures
import copy
import dataclasses
import threading

import mujoco
import numpy as np
from mujoco import rollout

import cpg_suite
from cpg_suite import cpg, darwin, electrical
from cpg_suite.base import clear_invalid_state_warnings, invalid_state
from cpg_suite.evaluation import quality as gait_quality
from cpg_suite.evaluation.gait import DARWIN_TASKS

_STATE = mujoco.mjtState.mjSTATE_FULLPHYSICS
_CTRL = int(mujoco.mjtState.mjSTATE_CTRL)
_CTRL_AND_PUSH = _CTRL | int(mujoco.mjtState.mjSTATE_XFRC_APPLIED)
# The DARwIn-OP tasks this evaluator runs: the nominal tasks and the perturbed test tiers.
TASKS = DARWIN_TASKS


@dataclasses.dataclass
class Episode:
    """What one initial-state seed fixes for a trial: the reset state and, on the perturbed
    tiers, the episode's own model (randomized parameters, raised tiles) and push forces."""

    state: np.ndarray  # mjSTATE_FULLPHYSICS after reset
    model: mujoco.MjModel
    pushes: np.ndarray | None  # (steps, 3) force on the torso per control step, N
    ctrl: np.ndarray | None = None  # the reset's actuator controls (the posture's targets)


# The sensors a trial records for its gait measures and its electrical load, in the
# record's order (after the 20 servos' joint velocities).
RECORDED_SENSORS = ("servo_forces", "foot_touch", "sole_velocities", "footing")
# Why a trial ended early (`BatchResult.cause`): 0 it did not, else 1 + the index in
# `electrical.CAUSES` (1 a fall or a divergent simulation, 2 a brown-out).
FALL, BROWNOUT = 1 + electrical.CAUSES.index("fall"), 1 + electrical.CAUSES.index("brownout")


@dataclasses.dataclass
class BatchResult:
    """Per candidate (and per initial state): distance, lateral displacement, fall."""

    distance_m: np.ndarray  # (K, S) torso x displacement at the end or at the fall
    lateral_m: np.ndarray  # (K, S) torso y displacement
    fall_step: np.ndarray  # (K, S) 1-based control step of the failure, 0 = none
    sim_steps: int  # physics steps simulated
    quality: dict | None = None  # (K, S) arrays of `cpg_suite.evaluation.quality.FIELDS`, if asked
    cause: np.ndarray | None = None  # (K, S) why it ended early: 0, `FALL` or `BROWNOUT`

    @property
    def fell(self) -> np.ndarray:
        """Failed: a fall or a brown-out ended the trial early (`cause` says which)."""
        return self.fall_step > 0


def check_amplitudes(amplitudes) -> np.ndarray:
    """(K, 11) float64 amplitudes from a (K, 11) or (11,) array.

    Raises:
      ValueError: On another shape or a non-finite value.
    """
    amps = np.atleast_2d(np.asarray(amplitudes, dtype=np.float64))
    if amps.ndim != 2 or amps.shape[1] != cpg.N_AMPLITUDES or not np.all(np.isfinite(amps)):
        raise ValueError(
            f"amplitudes must be finite with {cpg.N_AMPLITUDES} columns, got shape {amps.shape}"
        )
    return amps


class BatchEvaluator:
    """Evaluates batches of CPG amplitude vectors on a DARwIn-OP task."""

    def __init__(
        self,
        task: str = "darwin_walk",
        steps: int = 1000,
        threads: int = 1,
        config: cpg.CPGConfig | None = None,
        segment: int = 125,
        task_kwargs: dict | None = None,
    ):
        """Args:
          task: One of `TASKS` (the walking tiers and `darwin_balance`; the distances and
            falls are the same measure on each).
          steps: Control steps per trial (the study: 1000).
          threads: Worker threads.
          config: CPG constants; the task starts in the CPG's standing posture.
          segment: Control steps per rollout segment (early stop after a fall).
          task_kwargs: Further task arguments (e.g. `servo_gain`).

        Raises:
          ValueError: On a non-DARwIn task or non-positive sizes.
        """
        if task not in TASKS:
            raise ValueError(f"the batched evaluator runs {', '.join(TASKS)}; got {task!r}")
        if steps < 1 or threads < 1 or segment < 1:
            raise ValueError("steps, threads and segment must be ≥ 1")
        self.task, self.steps, self.threads, self.segment = task, steps, threads, segment
        self.config = config or cpg.CPGConfig()
        self._task_kwargs = {
            "posture": self.config.offsets(),
            "time_limit": float("inf"),
            **(task_kwargs or {}),
        }
        env = cpg_suite.load(task, task_kwargs=self._task_kwargs)
        self._physics = env.physics
        self.model = env.physics.model.ptr
        self.control_timestep = env.control_timestep()
        self.n_sub = int(round(self.control_timestep / self.model.opt.timestep))
        self._episodes: dict[int, Episode] = {}
        self._reset_env = cpg_suite.load(task, task_kwargs=self._task_kwargs)
        self._torso = env.physics.torso_body()
        nq = self.model.nq
        self._servo_qvel = 1 + nq + env.physics.servo_dofs()  # in the FULLPHYSICS state
        self._servo_dofs = env.physics.servo_dofs()
        self.supply = env.task.supply_limit  # None: the study's unlimited physics
        slices = env.physics.sensor_slices()
        self._sensors = {k: slices[k] for k in RECORDED_SENSORS}
        self._local = threading.local()
        self._executor = concurrent.futures.ThreadPoolExecutor(threads) if threads > 1 else None
        qpos = self.model.jnt_qposadr[self.model.joint("root").id]
        self._root = slice(1 + qpos, 1 + qpos + 7)  # FULLPHYSICS state: time, qpos, ...

    def close(self) -> None:
        if self._executor is not None:
            self._executor.shutdown()
            self._executor = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def episode(self, seed: int) -> Episode:
        """The task's episode for `seed`: one environment, reseeded and reset (the same
        draws as a new environment created with `random=seed`)."""
        if seed not in self._episodes:
            env = self._reset_env
            env.task.reseed(seed)
            env.reset()
            model, data = env.physics.model.ptr, env.physics.data.ptr
            state = np.empty(mujoco.mj_stateSize(model, _STATE))
            mujoco.mj_getState(model, data, state, _STATE)
            task = env.task
            own_model = task.changes_model
            pushes = task.push_forces(self.steps) if task.pushes is not None else None
            self._episodes[seed] = Episode(
                state, copy.copy(model) if own_model else self.model, pushes, data.ctrl.copy()
            )
        return self._episodes[seed]

    def initial_state(self, seed: int) -> np.ndarray:
        """The task's reset state for `seed`."""
        return self.episode(seed).state

    def controls(self, amplitudes: np.ndarray) -> np.ndarray:
        """(K, steps, nu) actuator controls, as the task sets them for the CPG's targets."""
        physics = self._physics
        targets = cpg.trajectories(amplitudes, self.steps, self.control_timestep, self.config)
        legs = physics.action_to_targets(physics.targets_to_action(targets))
        return physics.controls_for(legs)

    def _worker(self):
        local = self._local
        if not hasattr(local, "data"):
            local.data = mujoco.MjData(self.model)
            local.rollout = rollout.Rollout(nthread=0)
        return local

    def _run_one(self, ctrl: np.ndarray, episode: Episode, quality: bool = False) -> tuple:
        """One trajectory: (distance, lateral, failure step or 0, physics steps, quality or
        None, cause).

        A divergent simulation (MuJoCo's invalid-state warnings, after which MuJoCo resets
        the model to its initial pose) is a fall at the control step where it happened,
        with the displacement of the last valid control step, as in the environment. A
        brown-out (`electrical.SupplyMonitor`) ends the trial at the control step whose
        physics step crossed the limit; a fall in the same control step is the cause.
        """
        worker = self._worker()
        state0 = episode.state
        start = state0[self._root][:2].copy()
        state, warm = state0[None].copy(), np.zeros((1, self.model.nv))
        last, fall_step, simulated, cause = state0[self._root], 0, 0, 0
        supply = self._monitor(episode)
        trace = [] if quality else None
        for begin in range(0, self.steps, self.segment):
            end = min(begin + self.segment, self.steps)
            steps = self._physics_controls(ctrl, episode, begin, end)
            roots, final, diverged, record = self._segment(
                worker, episode.model, steps, state, warm
            )
            simulated += (end - begin) * self.n_sub
            ended = self._failure(roots, diverged, supply, record, episode)
            if ended is not None:
                step, cause = ended
                fall_step = begin + step
                valid = len(roots) if diverged is None else diverged  # control steps
                if step <= valid:
                    last = roots[step - 1]
                elif valid:
                    last = roots[valid - 1]  # a divergence: the last valid control step
            else:
                last = roots[-1]
            if trace is not None:
                kept = (fall_step - begin) if fall_step else (end - begin)
                trace.append(record[: kept * self.n_sub])
            if fall_step:
                break
            state, warm = final
        distance = float(last[0] - start[0])
        measures = self._measures(trace, episode, distance) if quality else None
        return distance, float(last[1] - start[1]), fall_step, simulated, measures, cause

    def _monitor(self, episode: Episode) -> electrical.SupplyMonitor:
        limit = self.supply or electrical.SupplyLimit()
        return electrical.SupplyMonitor(
            limit, float(episode.model.opt.timestep), self.supply is not None
        )

    def _failure(self, roots, diverged, supply, record, episode) -> tuple[int, int] | None:
        """The segment's first failure: (its 1-based control step in the segment, cause).

        A fall (the torso's test after a control step, or a divergence) and a brown-out (the
        supply's window crossing the limit at a physics step) in the same control step count
        as a fall, as the task's termination tests the fall first.
        """
        n = len(roots) if diverged is None else diverged
        fallen = np.flatnonzero(darwin.has_fallen(roots[:n]))
        fall = int(fallen[0]) + 1 if fallen.size else (diverged + 1 if diverged is not None else 0)
        if self.supply is None:  # the study's physics: nothing to test
            return (fall, FALL) if fall else None
        width = len(self._servo_qvel)
        limit_steps = (fall if fall else len(roots)) * self.n_sub
        currents = electrical.supply_current(
            record[:limit_steps, width : 2 * width],
            record[:limit_steps, :width],
            episode.model.dof_damping[self._servo_dofs],
        )
        crossed = supply.update(currents)
        brownout = (crossed - 1) // self.n_sub + 1 if crossed else 0
        if brownout and (not fall or brownout < fall):
            return brownout, BROWNOUT
        return (fall, FALL) if fall else None

    def _measures(self, trace: list, episode: Episode, distance: float) -> dict:
        """Gait quality of a trajectory from its recorded physics steps."""
        record = np.concatenate(trace) if trace else np.zeros((0, self._record_width()))
        width = len(self._servo_qvel)
        widths = [self._sensors[k].stop - self._sensors[k].start for k in self._sensors]
        force, touch, sole, feet = np.split(record[:, width:], np.cumsum(widths)[:-1], axis=1)
        model = episode.model
        return gait_quality.measures(
            record[:, :width],
            force,
            touch,
            sole.reshape(-1, 2, 3),
            feet.reshape(len(feet), 2, -1),
            damping=model.dof_damping[self._servo_dofs],
            timestep=float(model.opt.timestep),
            torque_limit=float(model.actuator_forcerange[0, 1]),
            mass=float(model.body_subtreemass[self._torso]),
            distance=distance,
        )

    def _record_width(self) -> int:
        return len(self._servo_qvel) + sum(s.stop - s.start for s in self._sensors.values())

    def _physics_controls(self, ctrl: np.ndarray, episode: Episode, begin: int, end: int):
        """Per control step of [begin, end): the controls of its physics steps and their spec.

        Returns:
          `(controls, spec)`: (end − begin, n_sub, width) controls and the `mjtState` bits
          they set: the actuators, plus the torso's applied force on the push tier.
        """
        controls = ctrl[begin:end, None, :].repeat(self.n_sub, axis=1)
        if episode.pushes is None:
            return controls, _CTRL
        xfrc = np.zeros((end - begin, self.model.nbody, 6))
        xfrc[:, self._torso, :3] = episode.pushes[begin:end]
        xfrc = xfrc.reshape(end - begin, 1, -1).repeat(self.n_sub, axis=1)
        return np.concatenate([controls, xfrc], axis=2), _CTRL_AND_PUSH

    def _segment(self, worker, model, steps, state: np.ndarray, warm: np.ndarray):
        """Rolls out a segment's control steps from `state`.

        Returns:
          `(roots, (state, warm), diverged, record)`: the root coordinates after each
          control step, the state and warm start to continue from, the index of the control
          step in which the simulation diverged (None if it did not), and per physics step
          the leg joint velocities and the quality sensors (`_record_width()` columns).
        """
        controls, spec = steps
        n = len(controls)
        flat = controls.reshape(1, n * self.n_sub, -1)
        states, sensordata = self._rollout(worker, model, state, flat, spec, warm)
        roots = states[0, self.n_sub - 1 :: self.n_sub, self._root]
        final = (states[:, -1].copy(), worker.data.qacc_warmstart[None].copy())
        record = np.concatenate(
            [states[0][:, self._servo_qvel]]
            + [sensordata[0][:, s] for s in self._sensors.values()],
            axis=1,
        )
        if not invalid_state(worker.data) and np.all(np.isfinite(states)):
            return roots, final, None, record
        return roots, final, self._divergent_step(worker, model, steps, state, warm), record

    def _rollout(self, worker, model, state, controls, spec, warm):
        clear_invalid_state_warnings(worker.data)
        return worker.rollout.rollout(
            model, worker.data, state, controls, control_spec=spec, initial_warmstart=warm
        )

    def _divergent_step(self, worker, model, steps, state, warm) -> int:
        """Replays a segment one control step at a time to find the step that diverged."""
        controls, spec = steps
        for t in range(len(controls)):
            states, _ = self._rollout(worker, model, state, controls[t : t + 1], spec, warm)
            if invalid_state(worker.data) or not np.all(np.isfinite(states)):
                return t
            state, warm = states[:, -1].copy(), worker.data.qacc_warmstart[None].copy()
        return len(controls) - 1

    def evaluate(self, amplitudes, seeds=(0,), quality: bool = False) -> BatchResult:
        """Evaluates every amplitude vector from every initial-state seed.

        Args:
          amplitudes: (K, 11) or (11,) amplitudes, degrees.
          seeds: Initial-state seeds, the same for every candidate.
          quality: Also measure gait quality (`cpg_suite.evaluation.quality`).

        Returns:
          A `BatchResult` with (K, len(seeds)) arrays.
        """
        amps = check_amplitudes(amplitudes)
        seeds = [int(s) for s in np.atleast_1d(seeds)]
        ctrl = self.controls(amps)
        jobs = [(k, j) for k in range(len(amps)) for j in range(len(seeds))]
        episodes = {s: self.episode(s) for s in seeds}

        def run(job):
            k, j = job
            return self._run_one(ctrl[k], episodes[seeds[j]], quality)

        if self._executor is None:
            results = [run(job) for job in jobs]
        else:
            results = list(self._executor.map(run, jobs))
        shape = (len(amps), len(seeds))
        out = np.array([r[:3] for r in results]).reshape(shape + (3,))
        measured = None
        if quality:
            measured = {
                f: np.array([r[4][f] for r in results]).reshape(shape) for f in gait_quality.FIELDS
            }
        return BatchResult(
            out[..., 0],
            out[..., 1],
            out[..., 2].astype(int),
            int(sum(r[3] for r in results)),
            measured,
            np.array([r[5] for r in results]).reshape(shape),
        )
