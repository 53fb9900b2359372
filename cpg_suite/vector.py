"""N DARwIn-OP walking environments stepped in one call, as a Gymnasium vector env.

    import gymnasium
    import cpg_suite.gym  # registers cpg_suite/<task_id>-v0 with a vector entry point
    envs = gymnasium.make_vec("cpg_suite/darwin_walk_randomized-v0", num_envs=16)
    observations, infos = envs.reset(seed=0)  # sub-environment i seeded with 0 + i

or `cpg_suite.vector.DarwinVectorEnv("darwin_walk_randomized", 16)`. Needs the `gym` extra.

Each sub-environment is a `cpg_suite.load(task_id)` environment; its task draws the
episode (initial posture, randomized physics, pushes, terrain) at reset exactly as the
single environment does. A step then bypasses dm_control's per-environment Python: the
actions become servo targets for all environments at once, the physics substeps of every
environment run in C threads (`mujoco.mj_step`, which releases the GIL), and the
observations, rewards, falls and time limits are read out as (N, ...) arrays. Each
sub-environment takes the steps `control.Environment.step` takes (dm_control's default
stepping: `mj_step2` finishes the first substep, whose `mj_step1` ran for the previous
observation, `mj_step` takes the others, then `mj_step1` for the observation), so exactly
`n_sub` physics steps per control step, and its transitions equal those of the
Gymnasium environment `gymnasium.make("cpg_suite/<task_id>-v0")` reset with the same seed,
bit for bit, for any thread count (`tests/test_vector_env.py`).

Episodes end as in the single environment: a fall or a brown-out of the supply
(`cpg_suite.electrical`; `infos["brownout"]` flags those that were not falls too)
terminates, the time limit (1000 control steps) truncates, and at the limit a fallen
robot is truncated too (dm_control gives discount 1 there). Where dm_control would raise
`PhysicsError` (an invalid physics state), the sub-environment terminates instead and
`infos["physics_error"]` flags it.
Autoreset follows Gymnasium's modes: next-step (the default, as `SyncVectorEnv`) or
same-step (the final observation in `infos["final_obs"]`).
"""

from __future__ import annotations

import concurrent.futures
import os
from collections.abc import Iterator

try:
    import gymnasium
except ImportError as e:  # the core install: one line that says what to install
    raise ImportError(
        f"cpg_suite.vector needs Gymnasium: pip install 'cpg-suite[gym]' ({e})"
    ) from e
import mujoco
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

import cpg_suite
from cpg_suite import base, cpg, darwin, electrical, perturbations, residual
from cpg_suite.darwin import recording as darwin_recording

WALK_TASKS = tuple(t for t in cpg_suite.TASK_IDS if t.startswith("darwin_walk"))


class DarwinVectorEnv(gymnasium.vector.VectorEnv):
    """`num_envs` DARwIn-OP walking environments of one tier, stepped together."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(
        self,
        task_id: str = "darwin_walk",
        num_envs: int = 1,
        *,
        threads: int | None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        episode_seeds: Iterator[int] | None = None,
        **task_kwargs,
    ):
        """Args:
          task_id: A walking tier (`WALK_TASKS`).
          num_envs: Number of sub-environments N.
          threads: Threads stepping the physics (default: the usable CPUs, at most N);
            results do not depend on it.
          autoreset_mode: `AutoresetMode.NEXT_STEP` or `SAME_STEP` (or their values).
          episode_seeds: Each autoreset seeds its episode with the next of these (e.g. a
            learner's training seeds); None: the task's random stream goes on.
          **task_kwargs: Passed to the task factory of every sub-environment (not
            `random`: seed through `reset`).

        Raises:
          ValueError: On an unknown or non-walking task, N < 1, threads < 1, an
            unsupported autoreset mode, or `random` among the task arguments.
        """
        if task_id not in WALK_TASKS:
            raise ValueError(f"unknown walking task {task_id!r}; valid: {', '.join(WALK_TASKS)}")
        if int(num_envs) < 1:
            raise ValueError(f"num_envs must be ≥ 1, got {num_envs!r}")
        if "random" in task_kwargs:
            raise ValueError("seed the sub-environments through reset(seed=...), not random=")
        mode = AutoresetMode(autoreset_mode)
        if mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            raise ValueError(f"autoreset_mode must be NextStep or SameStep, got {mode.value!r}")
        threads = min(int(num_envs), len(os.sched_getaffinity(0))) if threads is None else threads
        if int(threads) < 1:
            raise ValueError(f"threads must be ≥ 1, got {threads!r}")
        self.task_id, self.num_envs, self.threads = task_id, int(num_envs), int(threads)
        self.autoreset_mode = mode
        self._episode_seeds = episode_seeds
        self.metadata = {**self.metadata, "autoreset_mode": mode}
        self.envs = [cpg_suite.load(task_id, task_kwargs=task_kwargs) for _ in range(num_envs)]
        first = self.envs[0]
        # shimmy's spaces (imported here: it defines absl flags, as `cpg_suite.gym` avoids too).
        from shimmy.utils.dm_env import dm_spec2gym_space

        self.single_observation_space = gymnasium.spaces.Dict(
            {k: dm_spec2gym_space(s) for k, s in first.observation_spec().items()}
        )
        self.single_action_space = dm_spec2gym_space(first.action_spec())
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._layout(first.physics)
        self._models = [env.physics.model.ptr for env in self.envs]
        self._datas = [env.physics.data.ptr for env in self.envs]
        # Each robot's views made once (cheaper than looking them up on every step): its
        # leg controls, warning counts (`base.invalid_state`'s) and what `_read` copies.
        self._leg_ctrls = [env.physics._leg_ctrl for env in self.envs]  # `set_leg_action`'s
        self._warning_counts = [env.physics._warnings for env in self.envs]
        self._invalid_warnings = np.array(base._INVALID_STATE_WARNINGS)
        # What the observations, rewards and fall tests read, per sub-environment.
        model = first.physics.model
        self._qpos = np.zeros((self.num_envs, model.nq))
        self._qvel = np.zeros((self.num_envs, model.nv))
        self._sensordata = np.zeros((self.num_envs, model.nsensordata))
        self._torso_pos = np.zeros((self.num_envs, 3))
        self._reads = [
            [
                (memoryview(mine[i]), memoryview(theirs))
                for mine, theirs in (
                    (self._qpos, d.qpos),
                    (self._qvel, d.qvel),
                    (self._sensordata, d.sensordata),
                    (self._torso_pos, d.xpos[self._torso]),
                )
            ]
            for i, d in enumerate(self._datas)
        ]
        self.n_sub = int(round(first.control_timestep() / first.physics.timestep()))
        # Every robot's servo forces and joint velocities after each physics step of the
        # control step, recorded by its physics into its row
        # (`darwin_recording.record_steps_into`), and the supply currents computed from them
        # for all robots at once.
        self._step_force = np.zeros((self.num_envs, self.n_sub, model.nu))
        self._step_qvel = np.zeros((self.num_envs, self.n_sub, model.nv))
        for i, env in enumerate(self.envs):
            darwin_recording.record_steps_into(env.physics, self._step_force[i], self._step_qvel[i])
        self._servo_dofs = first.physics.servo_dofs()
        self._dof_damping = np.zeros((self.num_envs, 1, model.nv))  # at each reset
        self._meter = electrical.SupplyMeter((self.num_envs, self.n_sub), len(self._servo_dofs))
        self._servo_index = electrical.servo_index(
            self.num_envs * self.n_sub, self._servo_dofs, model.nv
        )
        self._currents: np.ndarray | None = None  # the last control step's (the meter's buffer)
        self.step_limit = int(round(first._step_limit)) if np.isfinite(first._step_limit) else None
        self.physics_steps = 0  # physics steps simulated so far, all sub-environments
        self._steps = np.zeros(self.num_envs, dtype=np.int64)  # control steps this episode
        self._done = np.zeros(self.num_envs, dtype=bool)
        self._x = np.zeros(self.num_envs)  # torso x before the step
        pool = concurrent.futures.ThreadPoolExecutor
        self._pool = pool(self.threads - 1) if self.threads > 1 else None

    def _layout(self, physics: darwin.Physics) -> None:
        """Addresses shared by every sub-environment (the tiers change no layout)."""
        model = physics.model
        address = {n: model.name2id(n, "joint") for n in ("root",) + cpg.LEG_JOINTS}
        self._root_q = int(model.jnt_qposadr[address["root"]])
        self._root_v = int(model.jnt_dofadr[address["root"]])
        self._leg_q = np.array([model.jnt_qposadr[address[n]] for n in cpg.LEG_JOINTS])
        self._leg_v = physics.leg_dofs()
        self._leg_act = np.array([model.name2id(n, "actuator") for n in cpg.LEG_JOINTS])
        self._torso = physics.torso_body()

        self._sensors = physics.sensor_slices()
        self._root_slice = slice(self._root_q, self._root_q + 7)  # the free joint's qpos

    # Gymnasium API.
    def reset(self, *, seed: int | list | None = None, options: dict | None = None):
        """Resets the sub-environments (all, or those in `options["reset_mask"]`).

        Args:
          seed: None (continue each task's random stream), an int s (sub-environment i
            seeded with s + i) or a list of N seeds (None entries continue).
          options: `{"reset_mask": (N,) bool}` resets only those.

        Returns:
          `(observations, infos)`.

        Raises:
          ValueError: On a seed list or mask of the wrong length.
        """
        super().reset(seed=seed if isinstance(seed, int) else None)
        mask = np.ones(self.num_envs, dtype=bool)
        if options and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"], dtype=bool)
            if mask.shape != (self.num_envs,):
                raise ValueError(f"reset_mask must have shape ({self.num_envs},), got {mask.shape}")
        seeds = _seeds(seed, self.num_envs)
        for i in np.flatnonzero(mask):
            self._reset_one(int(i), seeds[i])
        return self._observations(), {}

    def step(self, actions):
        """Steps every sub-environment one control step (next-step mode: resets the done ones).

        Args:
          actions: (N, 12) normalized leg targets in [−1, 1] (clipped, as the task does).

        Returns:
          `(observations, rewards, terminations, truncations, infos)`.

        Raises:
          ValueError: On a wrong shape or a non-finite action.
        """
        actions = self._check(actions)
        stepping = ~self._done if self.autoreset_mode == AutoresetMode.NEXT_STEP else None
        if stepping is None:
            stepping = np.ones(self.num_envs, dtype=bool)
        else:
            for i in np.flatnonzero(self._done):
                self._reset_one(int(i), self._next_seed())
        rewards = np.zeros(self.num_envs)
        terminated = np.zeros(self.num_envs, dtype=bool)
        truncated = np.zeros(self.num_envs, dtype=bool)
        errors = np.zeros(self.num_envs, dtype=bool)
        browned = np.zeros(self.num_envs, dtype=bool)
        active = np.flatnonzero(stepping)
        if len(active):
            errors[active] = self._physics_step(active, actions)
            x = self._torso_pos[active, 0]
            rewards[active] = x - self._x[active]
            self._x[active] = x
            self._steps[active] += 1
            brownout = np.array([self.envs[i].task.supply.browned_out > 0 for i in active])
            fallen = darwin.has_fallen(self._qpos[active, self._root_slice]) | errors[active]
            browned[active] = brownout & ~fallen
            fallen |= brownout
            at_limit = (
                self._steps[active] >= self.step_limit
                if self.step_limit is not None
                else np.zeros(len(active), bool)
            )
            truncated[active] = at_limit
            terminated[active] = fallen & ~at_limit
        self._done = terminated | truncated
        observations = self._observations()
        infos = {"physics_error": errors, "_physics_error": errors} if errors.any() else {}
        if browned.any():
            infos.update(brownout=browned, _brownout=browned)
        if self.autoreset_mode == AutoresetMode.SAME_STEP and self._done.any():
            infos.update(self._same_step_reset(observations))
            observations = self._observations()
            self._done[:] = False
        return observations, rewards, terminated, truncated, infos

    def close_extras(self, **kwargs) -> None:
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None

    # Internals.
    def _reset_one(self, i: int, seed: int | None) -> None:
        env = self.envs[i]
        if seed is not None:
            env.task.reseed(seed)
        env.reset()
        self._steps[i], self._done[i] = 0, False
        self._dof_damping[i, 0] = env.physics.model.dof_damping  # the episode's drawn damping
        self._read(i)
        self._x[i] = self._torso_pos[i, 0]

    def _next_seed(self) -> int | None:
        return None if self._episode_seeds is None else int(next(self._episode_seeds))

    def _same_step_reset(self, observations: dict) -> dict:
        done = self._done.copy()
        final = np.empty(self.num_envs, dtype=object)
        for i in np.flatnonzero(done):
            final[i] = {k: v[i].copy() for k, v in observations.items()}
            self._reset_one(int(i), self._next_seed())
        return {"final_obs": final, "_final_obs": done, "final_info": {}, "_final_info": done}

    def _check(self, actions) -> np.ndarray:
        try:
            a = np.asarray(actions, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise ValueError(f"actions must be numeric with shape ({self.num_envs}, 12)") from e
        if a.shape != (self.num_envs, 12):
            raise ValueError(f"actions have shape {a.shape}, expected ({self.num_envs}, 12)")
        if not np.isfinite(a).all():
            raise ValueError("actions contain NaN or infinite values")
        return np.clip(a, -1.0, 1.0)

    def _physics_step(self, active: np.ndarray, actions: np.ndarray) -> np.ndarray:
        """One control step of the `active` sub-environments; returns their invalid-state flags."""
        targets = self.envs[0].physics.action_to_targets(actions)  # the tiers share ranges
        work = []
        for i in active:
            task = self.envs[i].task
            push = None
            if task.pushes is not None:
                push = perturbations.push_force(task.push_schedule, int(self._steps[i]))
            work.append((int(i), targets[i], push))
        blocks = [work[k :: self.threads] for k in range(min(self.threads, len(work)))]
        # The calling thread steps the first block while the pool steps the others.
        futures = [self._pool.submit(self._step_block, b) for b in blocks[1:]]
        flags = [self._step_block(blocks[0])] + [f.result() for f in futures]
        errors = np.zeros(len(active), dtype=bool)
        for k, block_flags in enumerate(flags):
            errors[k :: self.threads] = block_flags
        self.physics_steps += self.n_sub * len(active)
        self._add_supply(active[~errors])
        return errors

    def _add_supply(self, stepped: np.ndarray) -> None:
        """The supply currents of this control step's physics steps, for every robot at
        once (`electrical.SupplyMeter`: each robot's the same bits as its own task's
        `darwin_recording.supply_currents`), into the tasks' monitors of the robots `stepped`."""
        meter = self._meter
        sums = meter.power_sums(
            self._step_force, self._step_qvel, self._dof_damping, self._servo_index
        )
        currents = meter.currents(sums)
        rows = currents.tolist()
        for i in stepped:
            self.envs[i].task.supply.update_floats(rows[i])
        self._currents = currents

    def supply_currents(self) -> np.ndarray:
        """Each robot's supply current after each physics step of the last control step, A:
        the values its task's supply monitor was given (a copy).

        Returns:
          (num_envs, physics steps per control step) float64; zeros before the first step.
        """
        if self._currents is None:
            return np.zeros((self.num_envs, self.n_sub))
        return self._currents.copy()

    def _step_block(self, work: list) -> list[bool]:
        """`control.Environment.step` for some sub-environments, in one thread: the servo
        targets and push, the substeps (`mj_step2` then `mj_step`, the GIL released), the
        invalid-state test, `mj_step1`, and a copy of the state the observations read (the
        supply currents follow for all robots at once, `_add_supply`)."""
        flags = []
        invalid, n_sub, step1 = self._invalid_warnings, self.n_sub, mujoco.mj_step1
        for i, targets, push in work:
            model, data = self._models[i], self._datas[i]
            self._leg_ctrls[i][...] = targets  # `data.ctrl[leg actuators]`, a view
            if push is not None:
                data.xfrc_applied[self._torso, :3] = push
            counts = self._warning_counts[i]  # `base.clear_invalid_state_warnings`
            counts[invalid] = 0
            darwin_recording.substeps(self.envs[i].physics, n_sub, finish=True)  # recorded
            bad = bool(np.count_nonzero(counts[invalid]))  # `base.invalid_state`
            if not bad:
                step1(model, data)
            for mine, theirs in self._reads[i]:  # `_read`
                mine[:] = theirs
            flags.append(bad)
        return flags

    def _read(self, i: int) -> None:
        """Copies the state sub-environment i's observation, reward and fall test read."""
        for mine, theirs in self._reads[i]:
            mine[:] = theirs

    def _observations(self) -> dict[str, np.ndarray]:
        """`CPGTask.get_observation` for every sub-environment, as (N, ...) arrays."""
        qvel, sensors, s = self._qvel, self._sensordata, self._sensors
        observations = {
            "joint_angles": self._qpos[:, self._leg_q],
            "joint_velocities": qvel[:, self._leg_v],
            "torso_orientation": sensors[:, s["torso_orientation"]].copy(),
            "torso_height": self._torso_pos[:, 2:3].copy(),
            "torso_velocity": qvel[:, self._root_v : self._root_v + 3].copy(),
            "gyro": sensors[:, s["gyro"]].copy(),
            "accelerometer": sensors[:, s["accelerometer"]].copy(),
            "foot_touch": sensors[:, s["foot_touch"]].copy(),
        }
        return {key: observations[key] for key in self.single_observation_space}


class CPGActions(gymnasium.vector.VectorWrapper):
    """The CPG action space over a `DarwinVectorEnv` in same-step autoreset mode.

    Each step: the policy's (N, 12) actions modulate the CPG rows (`ModulatedCPG.modulate`),
    the CPG advances one control step, and its joint targets become the environment's
    normalized actions. Rows whose episode ended restart with their sub-environment. The
    observations gain `"cpg_phase"` (cos φ_L, sin φ_L), also in `infos["final_obs"]`.
    """

    def __init__(
        self,
        env: gymnasium.vector.VectorEnv,
        *,
        amplitudes="hand_tuned",
        amplitude_scale: float = residual.AMPLITUDE_SCALE,
        rate_scale: float = residual.RATE_SCALE,
        config: cpg.CPGConfig | None = None,
    ):
        """Args:
          env: A `DarwinVectorEnv` (or a wrapper of one) with `AutoresetMode.SAME_STEP`.
          amplitudes, amplitude_scale, rate_scale, config: As for `ModulatedCPG`.

        Raises:
          ValueError: On another autoreset mode, or bad CPG arguments.
        """
        super().__init__(env)
        if env.metadata.get("autoreset_mode") != AutoresetMode.SAME_STEP:
            raise ValueError("CPGActions needs a vector env with AutoresetMode.SAME_STEP")
        self.cpg = residual.ModulatedCPG(
            env.num_envs,
            amplitudes,
            config,
            amplitude_scale=amplitude_scale,
            rate_scale=rate_scale,
        )
        self._physics = env.unwrapped.envs[0].physics  # for `targets_to_action`
        self._dt = float(env.unwrapped.envs[0].control_timestep())
        self.single_action_space = gymnasium.spaces.Box(
            -1.0, 1.0, (residual.N_ACTIONS,), np.float64
        )
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        spaces = dict(env.single_observation_space.spaces)
        spaces[residual.PHASE_KEY] = gymnasium.spaces.Box(-1.0, 1.0, (2,), np.float64)
        self.single_observation_space = gymnasium.spaces.Dict(spaces)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)

    def reset(self, *, seed=None, options=None):
        observations, infos = self.env.reset(seed=seed, options=options)
        mask = np.ones(self.num_envs, dtype=bool)
        if options and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"], dtype=bool)
        self.cpg.reset_rows(mask)
        return self._with_phase(observations), infos

    def step(self, actions):
        a = np.asarray(actions, dtype=np.float64)
        if a.shape != (self.num_envs, residual.N_ACTIONS) or not np.isfinite(a).all():
            raise ValueError(
                f"actions must be finite with shape ({self.num_envs}, {residual.N_ACTIONS}), "
                f"got {a.shape}"
            )
        self.cpg.modulate(a)
        targets = self.cpg.step(self._dt)
        joint_actions = self._physics.targets_to_action(targets)
        observations, rewards, terminated, truncated, infos = self.env.step(joint_actions)
        done = np.asarray(terminated) | np.asarray(truncated)
        if done.any():
            features = self.cpg.phase_features()
            if "final_obs" in infos:
                final = infos["final_obs"].copy()
                for i in np.flatnonzero(done):
                    final[i] = {**final[i], residual.PHASE_KEY: features[i].copy()}
                infos = {**infos, "final_obs": final}
            self.cpg.reset_rows(done)
        return self._with_phase(observations), rewards, terminated, truncated, infos

    def _with_phase(self, observations: dict) -> dict:
        return {**observations, residual.PHASE_KEY: self.cpg.phase_features()}


def _seeds(seed, n: int) -> list:
    if seed is None:
        return [None] * n
    if isinstance(seed, (int, np.integer)):
        return [int(seed) + i for i in range(n)]
    seeds = list(seed)
    if len(seeds) != n:
        raise ValueError(f"need {n} seeds, got {len(seeds)}")
    return seeds


def make_vector_env(num_envs: int, task_id: str, **kwargs) -> DarwinVectorEnv:
    """The vector entry point of the Gymnasium registration (`gymnasium.make_vec`)."""
    kwargs.pop("max_episode_steps", None)  # the task's own time limit applies
    return DarwinVectorEnv(task_id, num_envs, **kwargs)
