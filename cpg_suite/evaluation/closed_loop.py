"""Batched evaluation of the feedback CPG (`cpg_suite.feedback`) on the DARwIn-OP tiers.

Feedback needs the sensors every control step, so the open-loop evaluator's precomputed
controls do not apply. `FeedbackEvaluator` steps K candidates × S starts together: each
control step, the trials' physics steps run in threads (`mujoco.mj_step` in C, the GIL
released), then one `FeedbackCPG` holding all K·S trials computes the next targets from
their sensors, vectorized in NumPy. Each trial steps exactly as `control.Environment`
does (`cpg_suite.protocol.score.policy_trial`): the action, any push, the physics substeps,
`mj_step1` for the observation, the fall test. So a trial's distance, fall step and gait
quality equal those of stepping the environment with `FeedbackPolicy`, bit for bit
(`tests/test_feedback_eval.py`); a trial depends only on its parameters and its seed, not
on the batch or the thread count.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses

import mujoco
import numpy as np
from mujoco import rollout

import cpg_suite
from cpg_suite import cpg, darwin, electrical, feedback
from cpg_suite.base import _INVALID_STATE_WARNINGS
from cpg_suite.evaluation import quality as gait_quality
from cpg_suite.evaluation.open_loop import (
    BROWNOUT,
    FALL,
    RECORDED_SENSORS,
    BatchEvaluator,
    BatchResult,
    Episode,
)

_FULLPHYSICS = mujoco.mjtState.mjSTATE_FULLPHYSICS
# The inputs a rollout leaves as they are (controls, applied forces, mocap, equalities):
# given none, it neither sets nor clears them, so the trial's stay in its data.
_INPUTS = int(mujoco.mjtState.mjSTATE_USER)
# The warnings `invalid_state` reads: a slice where their numbers run on (basic indexing:
# cheaper than an index array on every trial's control step), else the numbers.
_INVALID: slice | np.ndarray = np.array(sorted(_INVALID_STATE_WARNINGS))
if np.array_equal(_INVALID, np.arange(_INVALID[0], _INVALID[0] + len(_INVALID))):
    _INVALID = slice(int(_INVALID[0]), int(_INVALID[-1]) + 1)
_CONTIGUOUS = isinstance(_INVALID, slice)  # `_Trial.invalid`: a view of them


class FeedbackPolicy:
    """The feedback CPG as a policy: observation → action, for env stepping and scoring."""

    def __init__(self, params, config: cpg.CPGConfig | None = None):
        """Args:
          params: (`feedback.N_PARAMS`,) amplitudes (degrees) then gains.
          config: CPG constants (default `cpg.CPGConfig()`).

        Raises:
          ValueError: On a wrong shape or a non-finite value.
        """
        self.params = np.asarray(params, dtype=np.float64)
        self.config = config or cpg.CPGConfig()
        self._cpg = feedback.FeedbackCPG(self.params, self.config)
        self._physics = cpg_suite.load("darwin_walk").physics  # the joint ranges

    def reset(self) -> None:
        self._cpg.reset()

    def __call__(self, observation) -> np.ndarray:
        inputs = feedback.sensor_inputs(
            observation["torso_orientation"], observation["gyro"], observation["foot_touch"]
        )
        targets = self._cpg.step(darwin.CONTROL_TIMESTEP, inputs)
        return self._physics.targets_to_action(targets)


@dataclasses.dataclass(frozen=True)
class _Layout:
    """Addresses every trial of an evaluator shares (the tiers change no layout)."""

    root: int  # the free joint's first `qpos` address
    torso: int  # the torso's body id (the row of `xfrc_applied` a push acts on)
    servo_dofs: np.ndarray  # the servos' joints' `qvel` addresses, actuator order
    n_sub: int  # physics steps per control step


class _Trial:
    """One trial's MuJoCo data, what it has measured so far, and its substeps' records.

    The views of its data a control step reads and writes are made once (cheaper than
    looking them up on every step).
    """

    def __init__(
        self,
        episode: Episode,
        supply: electrical.SupplyMonitor,
        layout: _Layout,
        states: np.ndarray | None = None,
        sensors: np.ndarray | None = None,
    ):
        """Args:
        episode: The trial's start, model and pushes.
        supply: Its supply monitor.
        layout: The addresses all trials share.
        states, sensors: (n_sub, ·) buffers for the full state and the sensors after each
          substep of a control step (rows of the evaluator's arrays for all trials; None:
          its own).
        """
        model = self.model = episode.model
        self.pushes, self.supply = episode.pushes, supply
        data = self.data = mujoco.MjData(model)
        mujoco.mj_setState(model, data, episode.state, _FULLPHYSICS)
        data.ctrl[:] = episode.ctrl
        mujoco.mj_forward(model, data)  # the reset's observation (its sensors)
        root = layout.root
        self.start = data.qpos[root : root + 2].copy()
        self.last = self.start.copy()
        self.root = data.qpos[root : root + 7].copy()
        self.fall_step, self.cause, self.simulated, self.record = 0, 0, 0, []
        self.ctrl, self.push = data.ctrl, data.xfrc_applied[layout.torso, :3]  # views
        self.root_qpos = data.qpos[root : root + 7]  # a view
        self.warnings = data.warning.number  # a view: the counts a rollout clears
        # Memoryviews of the counts (all, and those `invalid_state` reads where they run
        # on): `any` over one costs a fraction of NumPy's `count_nonzero`.
        self.counted = memoryview(self.warnings)
        self.invalid = memoryview(self.warnings[_INVALID]) if _CONTIGUOUS else None
        self.sensordata = data.sensordata  # a view: the observation's sensors (`_inputs`)
        self.damping = model.dof_damping[layout.servo_dofs]  # the episode's, fixed
        if states is None:
            states = np.zeros((layout.n_sub, mujoco.mj_stateSize(model, _FULLPHYSICS)))
        if sensors is None:
            sensors = np.zeros((layout.n_sub, model.nsensordata))
        self.states, self.sensors = states, sensors  # the full state, sensors after each substep
        self._first_sensors = memoryview(sensors[0])  # the first substep's row
        self._models, self._datas = [model], [data]
        self._warmstart = np.zeros((1, model.nv))  # the warm start a rollout starts from
        self._inputs = np.zeros(mujoco.mj_stateSize(model, _INPUTS))  # controls, forces, ...
        self._warmstart_now = data.qacc_warmstart  # a view
        # Memoryviews the substeps copy through (cheaper than NumPy's `row[...] =`).
        self._warmstart_row, self._warmstart_view = (
            memoryview(self._warmstart[0]),
            memoryview(self._warmstart_now),
        )
        self._sensordata_view = memoryview(data.sensordata)
        self._runner = rollout.Rollout(nthread=0)  # on the calling thread, the GIL released

    def substeps(self) -> None:
        """The physics steps of a control step as dm_control takes them (`mj_step2`, which
        finishes the step whose `mj_step1` ran for the last observation, then `mj_step`),
        each step's full state and sensors recorded.

        The `mj_step` calls are one `mujoco.rollout` from the state and warm start the loop
        would step from: the same calls on the same inputs, so the same bits, with the GIL
        released. A rollout clears the warning counts and stops at a warning (MuJoCo resets
        the data at a divergent acceleration, inputs included); after one, the steps are
        taken again in the loop from the same state and inputs, so the counts and the state
        are the loop's (`tests/test_feedback_eval.py`).
        """
        model, data, states, sensors = self.model, self.data, self.states, self.sensors
        mujoco.mj_step2(model, data)
        mujoco.mj_getState(model, data, states[0], _FULLPHYSICS)
        self._first_sensors[:] = self._sensordata_view
        counts = self.warnings.copy() if any(self.counted) else None
        self._warmstart_row[:] = self._warmstart_view
        mujoco.mj_getState(model, data, self._inputs, _INPUTS)  # a reset at a warning clears them
        self._runner.rollout(
            self._models,
            self._datas,
            states[:1],
            control_spec=_INPUTS,
            skip_checks=True,
            nstep=len(states) - 1,
            initial_warmstart=self._warmstart,
            state=states[1:],
            sensordata=sensors[1:],
        )
        if any(self.counted):  # it stopped at a warning: the loop's steps
            mujoco.mj_setState(model, data, states[0], _FULLPHYSICS)
            mujoco.mj_setState(model, data, self._inputs, _INPUTS)
            self._warmstart_now[:] = self._warmstart[0]
            self.warnings[:] = 0 if counts is None else counts
            for i in range(1, len(states)):
                mujoco.mj_step(model, data)
                mujoco.mj_getState(model, data, states[i], _FULLPHYSICS)
                sensors[i] = data.sensordata
        elif counts is not None:
            self.warnings[:] = counts  # the rollout cleared them


class FeedbackEvaluator:
    """Evaluates feedback-CPG parameter vectors on a walking tier, K × S trials at once."""

    def __init__(
        self,
        task: str = "darwin_walk",
        steps: int = 1000,
        threads: int = 1,
        config: cpg.CPGConfig | None = None,
        task_kwargs: dict | None = None,
    ):
        """Args:
          task: A walking tier (`cpg_suite.evaluation.open_loop.TASKS`).
          steps: Control steps per trial.
          threads: Threads stepping the physics (results do not depend on it).
          config: CPG constants; the task starts in the CPG's standing posture.
          task_kwargs: Further task arguments (e.g. `supply`).

        Raises:
          ValueError: On an unknown task or non-positive sizes.
        """
        # The episodes (reset state, own model, pushes) and the sensor layout are the
        # open-loop evaluator's.
        self._open = BatchEvaluator(task, steps, 1, config, task_kwargs=task_kwargs)
        self.task, self.steps, self.config = task, steps, self._open.config
        self.n_sub = self._open.n_sub
        physics = cpg_suite.load(task, task_kwargs={"posture": self.config.offsets()}).physics
        self._physics = physics
        self._legs = physics.leg_dofs()
        self._torso = physics.torso_body()
        self._sensors = physics.sensor_slices()
        self._servo_dofs = physics.servo_dofs()
        model = physics.model
        # The columns of a recorded full state holding the servos' joint velocities, and the
        # sensor columns a quality record holds after them (`RECORDED_SENSORS`' order).
        self._servo_velocities = 1 + model.nq + self._servo_dofs
        self._recorded = np.concatenate(
            [np.arange(self._sensors[k].start, self._sensors[k].stop) for k in RECORDED_SENSORS]
        )
        forces = self._sensors["servo_forces"]
        self._servo_forces = np.arange(forces.start, forces.stop)
        self._record_shape = (mujoco.mj_stateSize(model.ptr, _FULLPHYSICS), model.nsensordata)
        self.supply = self._open.supply  # None: the study's unlimited physics
        self._root = int(model.jnt_qposadr[model.name2id("root", "joint")])
        self._layout = _Layout(self._root, self._torso, self._servo_dofs, self.n_sub)
        self._executor = concurrent.futures.ThreadPoolExecutor(threads) if threads > 1 else None
        self.threads = threads

    def close(self) -> None:
        self._open.close()
        if self._executor is not None:
            self._executor.shutdown()
            self._executor = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def evaluate(self, params, seeds=(0,), quality: bool = False) -> BatchResult:
        """Evaluates every parameter vector from every initial-state seed.

        Args:
          params: (K, `feedback.N_PARAMS`) or (`feedback.N_PARAMS`,).
          seeds: Initial-state seeds.
          quality: Also measure gait quality (`cpg_suite.evaluation.quality.FIELDS`).

        Returns:
          A `BatchResult` with (K, len(seeds)) arrays.
        """
        amplitudes, _ = feedback.split(params)
        p = np.atleast_2d(np.asarray(params, dtype=np.float64))
        seeds = [int(s) for s in np.atleast_1d(seeds)]
        rows = np.repeat(p, len(seeds), axis=0)  # trial i = (k, seed) = (i // S, i % S)
        episodes = [self._open.episode(s) for s in seeds]
        n_state, n_sensor = self._record_shape
        states = np.zeros((len(rows), self.n_sub, n_state))  # every trial's substeps
        sensors = np.zeros((len(rows), self.n_sub, n_sensor))
        trials = [
            _Trial(episode, self._open._monitor(episode), self._layout, states[i], sensors[i])
            for i, episode in enumerate(episodes * len(p))
        ]
        damping = np.array([trial.damping for trial in trials])[:, None, :]
        controller = feedback.FeedbackCPG(rows, self.config)
        active = list(range(len(trials)))
        for t in range(self.steps):
            inputs = self._inputs(trials)
            targets = controller.step(darwin.CONTROL_TIMESTEP, inputs)
            legs = self._physics.action_to_targets(self._physics.targets_to_action(targets))
            ctrl = self._physics.controls_for(legs)
            self._step_all([(trials[i], ctrl[i]) for i in active], t)
            self._measure(trials, active, (states, sensors, damping), t, quality)
            self._falls([trials[i] for i in active], t)
            active = [i for i in active if not trials[i].fall_step]
            if not active:
                break
        return self._result(trials, (len(amplitudes), len(seeds)), quality)

    def _inputs(self, trials: list[_Trial]) -> np.ndarray:
        """(K·S, 6) feedback inputs from every trial's sensors (a fallen trial's are unused)."""
        sensors, s = np.array([t.sensordata for t in trials]), self._sensors
        return feedback.sensor_inputs(
            sensors[:, s["torso_orientation"]], sensors[:, s["gyro"]], sensors[:, s["foot_touch"]]
        )

    @staticmethod
    def _falls(stepped: list[_Trial], t: int) -> None:
        """Marks the trials whose torso has fallen after control step t (`has_fallen`); a
        fall in a brown-out's control step is the cause, as in the task."""
        alive = [tr for tr in stepped if not tr.fall_step or tr.cause == BROWNOUT]
        if alive:
            fallen = darwin.has_fallen(np.array([trial.root for trial in alive]))
            for trial in np.array(alive, dtype=object)[fallen]:
                trial.fall_step, trial.cause = t + 1, FALL

    def _step_all(self, work: list, t: int) -> None:
        if self._executor is None:
            self._step_block(work, t)
            return
        blocks = [work[i :: self.threads] for i in range(self.threads)]
        for future in [self._executor.submit(self._step_block, b, t) for b in blocks]:
            future.result()

    def _step_block(self, work: list, t: int) -> None:
        for trial, ctrl in work:
            self._step_trial(trial, ctrl, t)

    def _step_trial(self, trial: _Trial, ctrl: np.ndarray, t: int) -> None:
        """One control step's physics as `control.Environment.step` takes it
        (`score.step_policy`): the action, any push, the substeps, `mj_step1` for the
        observation. A divergence ends the trial there (`invalid_state`); the supply's
        verdict on the substeps follows for all trials at once (`_measure`)."""
        trial.ctrl[:] = ctrl
        if trial.pushes is not None:
            trial.push[:] = trial.pushes[t]
        trial.warnings[_INVALID] = 0  # `clear_invalid_state_warnings`
        trial.substeps()
        trial.simulated += self.n_sub
        if any(trial.invalid) if _CONTIGUOUS else np.count_nonzero(trial.warnings[_INVALID]):
            trial.fall_step, trial.cause = t + 1, FALL
            return
        mujoco.mj_step1(trial.model, trial.data)
        trial.root = trial.root_qpos.copy()
        trial.last = trial.root[:2]

    def _measure(self, trials: list, stepped: list, records: tuple, t: int, quality: bool):
        """The stepped trials' supply currents from their substeps' records, each fed to
        its monitor (a brown-out ends the trial, unless it fell too: `_falls`), and with
        `quality` the records kept; in one batch of NumPy calls.

        Args:
          trials: Every trial.
          stepped: The indices of the trials stepped in control step t.
          records: (states, sensors, damping): the trials' substep records and servo
            damping, (trials, n_sub, ·) and (trials, 1, servos).
          t: The control step.
          quality: Keep each substep's servo velocities and `RECORDED_SENSORS`.
        """
        states, sensors, damping = records
        rows = np.array(stepped) if len(stepped) < len(trials) else None

        def columns(records: np.ndarray, index: np.ndarray) -> np.ndarray:
            # C-ordered copies (`take`), as the arrays of a loop's rows: NumPy's reductions
            # over them then add in the same order.
            out = records.take(index, axis=2)
            return out if rows is None else out.take(rows, axis=0)

        velocity = columns(states, self._servo_velocities)
        if quality:  # each substep: its servos' velocities, then `RECORDED_SENSORS`
            recorded = np.concatenate([velocity, columns(sensors, self._recorded)], axis=2)
            for i, record in zip(stepped, recorded):
                trials[i].record.append(record)
        force = columns(sensors, self._servo_forces)  # `actuator_force` after each substep
        if rows is not None:
            damping = damping.take(rows, axis=0)
        with np.errstate(all="ignore"):  # a diverged trial's records (not used)
            currents = electrical.supply_current(force, velocity, damping).tolist()
        for i, values in zip(stepped, currents):
            trial = trials[i]
            if trial.fall_step:  # diverged (`_step_trial`)
                continue
            if trial.supply.update_floats(values):
                trial.fall_step, trial.cause = t + 1, BROWNOUT

    def _result(self, trials: list, shape: tuple, quality: bool) -> BatchResult:
        distance = np.array([t.last[0] - t.start[0] for t in trials]).reshape(shape)
        lateral = np.array([t.last[1] - t.start[1] for t in trials]).reshape(shape)
        fall = np.array([t.fall_step for t in trials]).reshape(shape)
        measured = None
        if quality:
            cards = [self._measures(t, d) for t, d in zip(trials, distance.ravel())]
            measured = {
                f: np.array([c[f] for c in cards]).reshape(shape) for f in gait_quality.FIELDS
            }
        cause = np.array([t.cause for t in trials]).reshape(shape)
        simulated = int(sum(t.simulated for t in trials))
        return BatchResult(distance, lateral, fall, simulated, measured, cause)

    def _measures(self, trial: _Trial, distance: float) -> dict:
        s, n = self._sensors, len(self._servo_dofs)
        width = n + sum(s[k].stop - s[k].start for k in RECORDED_SENSORS)
        record = np.concatenate(trial.record) if trial.record else np.zeros((0, width))
        force, touch, sole, feet = np.split(record[:, n:], [n, n + 2, n + 8], axis=1)
        return gait_quality.measures(
            record[:, :n],
            force,
            touch,
            sole.reshape(-1, 2, 3),
            feet.reshape(len(feet), 2, -1),
            damping=trial.model.dof_damping[self._servo_dofs],
            timestep=float(trial.model.opt.timestep),
            torque_limit=float(trial.model.actuator_forcerange[0, 1]),
            mass=float(trial.model.body_subtreemass[self._torso]),
            distance=float(distance),
        )
