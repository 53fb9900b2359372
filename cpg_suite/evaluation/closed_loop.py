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

import mujoco
import numpy as np

import cpg_suite
from cpg_suite import cpg, darwin, electrical, feedback
from cpg_suite.base import clear_invalid_state_warnings, invalid_state
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


class _Trial:
    """One trial's MuJoCo data and what it has measured so far."""

    def __init__(self, episode: Episode, root: int, supply: electrical.SupplyMonitor):
        self.model, self.pushes, self.supply = episode.model, episode.pushes, supply
        self.data = mujoco.MjData(episode.model)
        mujoco.mj_setState(self.model, self.data, episode.state, _FULLPHYSICS)
        self.data.ctrl[:] = episode.ctrl
        mujoco.mj_forward(self.model, self.data)  # the reset's observation (its sensors)
        self.start = self.data.qpos[root : root + 2].copy()
        self.last = self.start.copy()
        self.root = self.data.qpos[root : root + 7].copy()
        self.fall_step, self.cause, self.simulated, self.record = 0, 0, 0, []


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
        self.supply = self._open.supply  # None: the study's unlimited physics
        self._root = int(physics.model.jnt_qposadr[physics.model.name2id("root", "joint")])
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
        trials = [
            _Trial(episode, self._root, self._open._monitor(episode))
            for _ in p
            for episode in episodes
        ]
        controller = feedback.FeedbackCPG(rows, self.config)
        active = list(range(len(trials)))
        for t in range(self.steps):
            inputs = self._inputs(trials)
            targets = controller.step(darwin.CONTROL_TIMESTEP, inputs)
            legs = self._physics.action_to_targets(self._physics.targets_to_action(targets))
            ctrl = self._physics.controls_for(legs)
            self._step_all([(trials[i], ctrl[i]) for i in active], t, quality)
            self._falls([trials[i] for i in active], t)
            active = [i for i in active if not trials[i].fall_step]
            if not active:
                break
        return self._result(trials, (len(amplitudes), len(seeds)), quality)

    def _inputs(self, trials: list[_Trial]) -> np.ndarray:
        """(K·S, 6) feedback inputs from every trial's sensors (a fallen trial's are unused)."""
        sensors, s = np.array([t.data.sensordata for t in trials]), self._sensors
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

    def _step_all(self, work: list, t: int, quality: bool) -> None:
        if self._executor is None:
            self._step_block(work, t, quality)
            return
        blocks = [work[i :: self.threads] for i in range(self.threads)]
        for future in [self._executor.submit(self._step_block, b, t, quality) for b in blocks]:
            future.result()

    def _step_block(self, work: list, t: int, quality: bool) -> None:
        for trial, ctrl in work:
            self._step_trial(trial, ctrl, t, quality)

    def _step_trial(self, trial: _Trial, ctrl: np.ndarray, t: int, quality: bool) -> None:
        """One control step as `control.Environment.step` takes it (`score.step_policy`)."""
        model, data = trial.model, trial.data
        data.ctrl[:] = ctrl
        if trial.pushes is not None:
            data.xfrc_applied[self._torso, :3] = trial.pushes[t]
        clear_invalid_state_warnings(data)
        force = np.empty((self.n_sub, model.nu))
        velocity = np.empty((self.n_sub, len(self._servo_dofs)))
        for i in range(self.n_sub):
            mujoco.mj_step(model, data)
            force[i] = data.actuator_force
            velocity[i] = data.qvel[self._servo_dofs]
            if quality:
                trial.record.append(self._record(data))
        trial.simulated += self.n_sub
        if invalid_state(data):
            trial.fall_step, trial.cause = t + 1, FALL
            return
        damping = model.dof_damping[self._servo_dofs]
        if trial.supply.update(electrical.supply_current(force, velocity, damping)):
            trial.fall_step, trial.cause = t + 1, BROWNOUT  # unless it fell too (`_falls`)
        mujoco.mj_step1(model, data)
        trial.root = data.qpos[self._root : self._root + 7].copy()
        trial.last = trial.root[:2]

    def _record(self, data) -> np.ndarray:
        s = self._sensors
        return np.concatenate(
            [
                data.qvel[self._servo_dofs],
                data.sensordata[s["servo_forces"]],
                data.sensordata[s["foot_touch"]],
                data.sensordata[s["sole_velocities"]],
                data.sensordata[s["footing"]],
            ]
        )

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
        record = np.array(trial.record) if trial.record else np.zeros((0, width))
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
