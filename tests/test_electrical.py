"""The servos' electrical model and the supply's limit (`cpg_suite.electrical`), known answers
from the MX-28 datasheet, and the same verdicts on every evaluation path."""

import math

import mujoco
import numpy as np
import pytest

import cpg_suite
from cpg_suite import cpg, electrical
from cpg_suite.darwin import recording as darwin_recording
from cpg_suite.evaluation import closed_loop, open_loop
from cpg_suite.protocol import score

DT = 0.002  # s: the model's physics step


def _free_servo(joint: str = "LegLowerL"):
    """The DARwIn-OP model with gravity and contacts off and the torso welded in place."""
    xml, assets = cpg_suite.darwin.get_model_and_assets()
    model = mujoco.MjModel.from_xml_string(xml, assets)
    model.opt.gravity[:] = 0.0
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    root = model.joint("root")
    model.dof_damping[root.dofadr[0] : root.dofadr[0] + 6] = 1e9  # the torso held still
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data, model.actuator(joint).id, model.joint(joint)


def _servo_current(model, data, actuator: int, joint) -> float:
    """One servo's supply current (input power / V, floored, plus its standby), A."""
    force = data.actuator_force[actuator]
    velocity = data.qvel[joint.dofadr[0]]
    damping = model.dof_damping[joint.dofadr[0]]
    power = max(0.0, float(electrical.input_power(force, velocity, damping)))
    return power / electrical.SUPPLY_VOLTAGE + electrical.STANDBY_CURRENT


def test_a_free_servo_at_its_no_load_speed_draws_only_its_standby_current():
    # Driven from one end of its range towards the other at full command (f = −2.5 N·m),
    # the joint reaches its no-load speed: the back-EMF braking b·q̇ cancels the command.
    model, data, actuator, joint = _free_servo()
    model.jnt_limited[joint.id] = 0  # free to turn on, towards a target far away
    model.actuator_ctrllimited[actuator] = 0
    data.ctrl[actuator] = -100.0  # rad: the force stays clamped at −2.5 N·m
    mujoco.mj_forward(model, data)
    for _ in range(400):  # 0.8 s: the joint reaches its steady speed (τ = J/b ≈ 12 ms)
        mujoco.mj_step(model, data)
    assert data.actuator_force[actuator] == pytest.approx(-electrical.STALL_TORQUE)
    speed = abs(data.qvel[joint.dofadr[0]])
    assert speed == pytest.approx(2.5 / model.dof_damping[joint.dofadr[0]], rel=1e-3)
    current = _servo_current(model, data, actuator, joint)
    assert current == pytest.approx(electrical.STANDBY_CURRENT, rel=0.01)


def test_a_stalled_servo_draws_its_stall_current_and_standby():
    model, data, actuator, joint = _free_servo()
    model.actuator_ctrllimited[actuator] = 0
    data.ctrl[actuator] = 100.0  # rad: far beyond, full command
    model.jnt_range[joint.id] = [-1e-9, 1e-9]  # held at 0 by its limit: stalled
    data.qvel[:] = 0.0
    mujoco.mj_forward(model, data)
    assert data.actuator_force[actuator] == pytest.approx(electrical.STALL_TORQUE)
    current = _servo_current(model, data, actuator, joint)
    assert current == pytest.approx(electrical.STALL_CURRENT + electrical.STANDBY_CURRENT)


def test_the_idle_robot_draws_standby_board_and_pc():
    zero = np.zeros(electrical.N_SERVOS)
    idle = electrical.supply_current(zero, zero, np.full(electrical.N_SERVOS, 0.43))
    assert idle == pytest.approx(20 * 0.1 + 0.15 + 6.0 / 12.0)


def test_braking_returns_nothing_to_the_battery():
    # Back-driven against its command, the motor is a generator: P < 0, floored at 0.
    force, velocity, damping = np.array([1.0]), np.array([-5.0]), 0.43
    assert electrical.input_power(force, velocity, damping)[0] > 0  # I > 0, V_cmd > 0
    assert electrical.input_power(-force, velocity, damping)[0] < 0
    current = electrical.supply_current(-force[None], velocity[None], damping)
    assert current[0] == pytest.approx(electrical.IDLE_CURRENT)


def test_energy_is_copper_loss_plus_the_motors_work_over_a_walking_trial():
    env = cpg_suite.load("darwin_walk", task_kwargs={"random": 0})
    env.reset()
    physics = env.physics
    targets = cpg.trajectories(cpg.amplitudes_from("hand_tuned"), 300, env.control_timestep())
    electric = copper = work = 0.0
    for action in physics.targets_to_action(targets[0]):
        env.step(action)
        force, velocity = darwin_recording.servo_steps(physics)
        damping = physics.servo_damping()
        electric += float(np.sum(electrical.input_power(force, velocity, damping))) * DT
        copper += float(np.sum(electrical.copper_loss(force, velocity, damping))) * DT
        work += float(np.sum(electrical.motor_power(force, velocity, damping))) * DT
    assert copper > 1.0 and abs(work) > 0.01  # the trial did work and heated the windings
    assert electric == pytest.approx(copper + work, rel=1e-12, abs=1e-12)


def test_the_window_does_not_depend_on_how_the_steps_are_fed():
    rng = np.random.default_rng(0)
    currents = rng.uniform(2.0, 14.0, 4000)
    for window in (0.25, 1.0, math.inf):
        limit = electrical.SupplyLimit(current=8.0, window=window)
        by_control_step = electrical.SupplyMonitor(limit, DT)
        for i in range(0, len(currents), 8):
            by_control_step.update(currents[i : i + 8])
        at_once = electrical.SupplyMonitor(limit, DT)
        at_once.update(currents)
        assert by_control_step.browned_out == at_once.browned_out > 0
        assert by_control_step.total == at_once.total
        assert by_control_step.worst == at_once.worst


@pytest.mark.parametrize("window_steps", [None, 1, 3, 50, 500])
def test_long_updates_in_numpy_equal_the_step_by_step_loop(window_steps, monkeypatch):
    """`SupplyMonitor`'s NumPy path for long updates (`_add_many`) leaves every number the
    Python loop leaves: the verdict, running total, worst window, step count, brown-out step
    and the ring of earlier totals, over updates of many lengths, with and without the limit
    enforced, and with a NaN current (a diverged step) inside a long update."""
    rng = np.random.default_rng(window_steps or 0)
    window = math.inf if window_steps is None else window_steps * DT
    for trial in range(12):
        limit = electrical.SupplyLimit(current=float(rng.uniform(3.0, 6.0)), window=window)
        enforce = bool(trial % 3)
        fast, loop = (electrical.SupplyMonitor(limit, DT, enforce) for _ in range(2))
        for _ in range(6):
            values = rng.gamma(2.0, 2.0, int(rng.choice([1, 8, 63, 64, 65, 700, 3000]))).tolist()
            if trial == 5 and len(values) > 64:
                values[3] = math.nan
            verdict = fast.update(values)
            with monkeypatch.context() as m:
                m.setattr(electrical, "_IN_NUMPY_FROM", 10**9)  # the loop only
                expected = loop.update(values)
            got = (verdict, fast.total, fast.worst, fast.steps, fast.browned_out, fast._ring)
            want = (expected, loop.total, loop.worst, loop.steps, loop.browned_out, loop._ring)
            assert repr(got) == repr(want)


class _StepByStep:
    """The monitor's definition, one step at a time in Python floats: T_k = T_{k−1} + i_k,
    the mean over the window (T_k − T_{k−w}) / w (T_j = j·idle for j < 0) or over the trial
    T_k / k, the worst the first of the largest means that are numbers, the brown-out the
    first step whose mean exceeds the enforced limit."""

    def __init__(self, limit, enforce):
        self.limit, self.enforce = limit, enforce
        self.w = limit.window_steps(DT)
        self.totals = {}  # j -> T_j
        self.total, self.worst, self.steps, self.browned_out = 0.0, -math.inf, 0, 0

    def earlier(self, j):
        return self.totals[j] if j >= 1 else float(j) * electrical.IDLE_CURRENT

    def update(self, values):
        first = 0
        for i, current in enumerate(values, 1):
            self.steps += 1
            self.total = self.total + current
            self.totals[self.steps] = self.total
            if self.w is None:
                mean = self.total / self.steps
            else:
                mean = (self.total - self.earlier(self.steps - self.w)) / self.w
            if mean > self.worst:
                self.worst = mean
            if self.enforce and not self.browned_out and mean > self.limit.current:
                self.browned_out = self.steps
                first = i
        return first


@pytest.mark.parametrize("window_steps", [None, 1, 3, 5, 8, 9, 50, 500])
def test_short_updates_equal_the_monitors_definition_step_by_step(window_steps):
    """`SupplyMonitor`'s path for control-step-sized updates (`itertools.accumulate`,
    `map` and `max` over the steps, the ring wrapped) leaves the numbers of the definition
    taken one step at a time: the verdict, the running total, the worst window (its signed
    zero), the step count, the brown-out step and the ring of the last w totals; over updates
    of 0 to 63 steps, shorter and longer than the window, with NaN, infinite and ±0
    currents, with and without the limit enforced."""
    rng = np.random.default_rng(window_steps or 0)
    window = math.inf if window_steps is None else window_steps * DT
    specials = [math.nan, math.inf, -math.inf, 0.0, -0.0, 5e-324, -5e-324]
    for trial in range(24):
        limit = electrical.SupplyLimit(current=float(rng.uniform(3.0, 6.0)), window=window)
        enforce = bool(trial % 3)
        monitor = electrical.SupplyMonitor(limit, DT, enforce)
        reference = _StepByStep(limit, enforce)
        for _ in range(40):
            n = int(rng.choice([0, 1, 2, 7, 8, 9, 16, 63]))
            values = rng.gamma(2.0, 2.0, n).tolist()
            if trial >= 16 and n:  # a special current in some updates
                values[int(rng.integers(n))] = specials[int(rng.integers(len(specials)))]
            if trial in (6, 7):  # equal currents: ties between window means
                values = [3.0] * n
            got = monitor.update(values)
            want = reference.update(values)
            state = (got, monitor.total, monitor.worst, monitor.steps, monitor.browned_out)
            defined = (want, reference.total, reference.worst, reference.steps)
            assert repr(state) == repr((*defined, reference.browned_out))
            if window_steps is not None:  # the ring: T_{k+1−w}, …, T_k from ring[k % w]
                k, w = monitor.steps, window_steps
                ring = monitor._ring[k % w :] + monitor._ring[: k % w]
                assert repr(ring) == repr([reference.earlier(j) for j in range(k + 1 - w, k + 1)])


def test_long_updates_keep_the_loops_signed_zero_and_lists_of_other_floats_convert():
    """The first of equal largest means is the worst, as in the loop (−0 before +0), and a
    list of NumPy float32 numbers is read as float64, as an array of them is."""
    values = [-5e-324] + [0.0] * 70 + [5e-324] * 3
    fast, loop = (
        electrical.SupplyMonitor(electrical.SupplyLimit(window=math.inf), DT) for _ in "ab"
    )
    fast.update(values)
    for chunk in (values[:32], values[32:63], values[63:]):
        loop.update(chunk)
    assert repr(fast.worst) == repr(loop.worst) == "-0.0"
    single = list(np.linspace(0.1, 3.3, 10, dtype=np.float32))
    by_list, by_array = (electrical.SupplyMonitor(electrical.SupplyLimit(), DT) for _ in "ab")
    by_list.update(single)
    by_array.update(np.array(single))
    assert type(by_list.total) is float and by_list.total == by_array.total


def test_the_window_mean_is_the_last_seconds_mean_with_an_idle_start():
    currents = np.r_[np.full(600, 3.0), np.full(400, 11.0)]
    monitor = electrical.SupplyMonitor(electrical.SupplyLimit(), DT)
    monitor.update(currents)
    # After 1000 steps the 500-step window holds 100 × 3 A and 400 × 11 A: 9.4 A.
    assert monitor.worst == pytest.approx(9.4)
    assert not monitor.browned_out
    # From the idle robot (2.65 A) before t = 0, 250 steps of 20 A: (250·2.65 + 250·20)/500.
    early = electrical.SupplyMonitor(electrical.SupplyLimit(), DT)
    early.update(np.full(250, 20.0))
    assert early.worst == pytest.approx((250 * electrical.IDLE_CURRENT + 250 * 20.0) / 500)
    crossed = electrical.SupplyMonitor(electrical.SupplyLimit(), DT)
    first = crossed.update(np.full(500, 20.0))
    # The window mean first exceeds 10 A when k·20 + (500 − k)·2.65 > 5000.
    k = math.floor((5000 - 500 * electrical.IDLE_CURRENT) / (20.0 - electrical.IDLE_CURRENT)) + 1
    assert first == crossed.browned_out == k


def test_bad_limits_are_refused():
    with pytest.raises(ValueError, match="supply limit"):
        electrical.SupplyLimit(current=0.0)
    with pytest.raises(ValueError, match="supply window"):
        electrical.SupplyLimit(window=-1.0)
    with pytest.raises(ValueError, match="under one physics step"):
        electrical.SupplyLimit(window=1e-4).window_steps(DT)
    with pytest.raises(ValueError, match="supply must be"):
        cpg_suite.load("darwin_walk", task_kwargs={"supply": 10.0})


# A limit the hand-tuned gait crosses (its 1 s mean peaks near 3.4-3.5 A): the same rule
# with a lower current, so that each path has brown-outs to agree on.
LOW = electrical.SupplyLimit(current=3.4)


def _env_trial(amplitudes, seed: int, steps: int, supply):
    env = cpg_suite.load(
        "darwin_walk", task_kwargs={"random": seed, "time_limit": float("inf"), "supply": supply}
    )
    env.reset()
    start = env.physics.torso_position()
    targets = cpg.trajectories(amplitudes, steps, env.control_timestep())[0]
    for t, action in enumerate(env.physics.targets_to_action(targets)):
        ts = env.step(action)
        if ts.last():
            return env.physics.torso_position()[0] - start[0], t + 1, env.task.failure
    return env.physics.torso_position()[0] - start[0], 0, env.task.failure


def test_a_brownout_ends_the_episode_like_a_fall_and_only_with_the_limit():
    amps = cpg.amplitudes_from("hand_tuned")
    distance, step, failure = _env_trial(amps, 0, 300, LOW)
    assert failure == "brownout" and 0 < step < 300
    env = cpg_suite.load("darwin_walk", task_kwargs={"random": 0, "supply": LOW})
    env.reset()
    targets = cpg.trajectories(amps, step, env.control_timestep())[0]
    for action in env.physics.targets_to_action(targets):
        ts = env.step(action)
    assert ts.last() and ts.discount == 0.0
    _, unlimited_step, unlimited = _env_trial(amps, 0, 300, None)
    assert unlimited is None and unlimited_step == 0


def test_every_path_gives_the_tasks_brownouts_bit_for_bit():
    amps = cpg.amplitudes_from("hand_tuned")[None] * np.array([[1.0], [1.3]])
    seeds, steps = [0, 1], 300
    expected = [_env_trial(a, s, steps, LOW) for a in amps for s in seeds]
    assert {e[2] for e in expected} == {"brownout"}
    with open_loop.BatchEvaluator("darwin_walk", steps, task_kwargs={"supply": LOW}) as ev:
        batched = ev.evaluate(amps, seeds)
    assert batched.distance_m.ravel().tolist() == [e[0] for e in expected]
    assert batched.fall_step.ravel().tolist() == [e[1] for e in expected]
    assert set(batched.cause.ravel()) == {open_loop.BROWNOUT}
    policy = score.OpenLoopPolicy(amps[0], steps)
    trial = score.policy_trial(policy, "darwin_walk", 0, steps, {"supply": LOW})
    assert (trial["distance_m"], trial["fall_step"]) == expected[0][:2]
    assert trial["cause"] == open_loop.BROWNOUT
    params = np.zeros((1, closed_loop.feedback.N_PARAMS))
    params[0, : cpg.N_AMPLITUDES] = amps[0]
    with closed_loop.FeedbackEvaluator("darwin_walk", steps, task_kwargs={"supply": LOW}) as ev:
        feedback = ev.evaluate(params, [0])
    stepped = score.policy_trial(
        closed_loop.FeedbackPolicy(params[0]), "darwin_walk", 0, steps, {"supply": LOW}
    )
    assert feedback.cause[0, 0] == stepped["cause"] == open_loop.BROWNOUT
    assert feedback.distance_m[0, 0] == stepped["distance_m"]
    assert feedback.fall_step[0, 0] == stepped["fall_step"]


def test_the_vector_env_browns_out_where_the_task_does():
    pytest.importorskip("gymnasium")
    from cpg_suite import vector

    amps = cpg.amplitudes_from("hand_tuned")
    seeds, steps = [0, 1], 300
    expected = [_env_trial(amps, s, steps, LOW) for s in seeds]
    envs = vector.DarwinVectorEnv("darwin_walk", 2, supply=LOW, time_limit=float("inf"))
    envs.reset(seed=seeds)
    targets = cpg.trajectories(amps, steps, 0.016)[0]
    actions = envs.envs[0].physics.targets_to_action(targets)
    ended = [0, 0]
    for t in range(steps):
        _, _, terminated, _, infos = envs.step(np.stack([actions[t]] * 2))
        for i in np.flatnonzero(terminated):
            if not ended[i]:
                ended[i] = t + 1
                assert infos["brownout"][i]
        if all(ended):
            break
    envs.close()
    assert ended == [e[1] for e in expected]


def test_benchmark_versions_choose_the_supply_limit():
    from cpg_suite import protocol
    from cpg_suite.harness.interface import OptimizerSettings

    assert protocol.supply_limit(1) is None
    assert protocol.supply_limit(2) == electrical.DEFAULT_SUPPLY
    assert protocol.supply_limit(3) == electrical.DEFAULT_SUPPLY  # version 3 adds a tier only
    assert OptimizerSettings(benchmark_version=1).task_kwargs() == {"supply": None}
    with pytest.raises(ValueError, match="benchmark_version"):
        OptimizerSettings(benchmark_version=4)
    amps = cpg.amplitudes_from("hand_tuned")
    for version in (1, 2):
        settings = score.ScoreSettings(
            tiers=("darwin_walk",), seeds=1, steps=20, benchmark_version=version
        )
        card = score.score_gait(amps, settings)
        assert card["benchmark_version"] == version
        assert card["all"]["failures_by_cause"] == {"fall": 0.0, "brownout": 0.0}
        assert card["all"]["speed_m_s"] == pytest.approx(
            card["all"]["success_weighted_distance_m"]["mean"] / (20 * 0.016)
        )


def test_the_meter_gives_supply_current_bit_for_bit():
    """`SupplyMeter` (in place, the tasks' hot path) = `supply_current`, bits included,
    with braking servos (negative power) and signed zeros among the inputs."""
    rng = np.random.default_rng(3)
    force = rng.uniform(-2.5, 2.5, (8, electrical.N_SERVOS))
    velocity = rng.uniform(-8.0, 8.0, (8, electrical.N_SERVOS))
    force[0, :3], velocity[0, :3] = -0.0, 0.0
    damping = rng.uniform(0.3, 0.6, electrical.N_SERVOS)
    meter = electrical.SupplyMeter(8)
    for _ in range(2):  # the buffers are reused
        got = meter(force, velocity, damping)
        assert got.tobytes() == electrical.supply_current(force, velocity, damping).tobytes()
