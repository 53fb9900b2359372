"""The hot paths' shortcuts give the same bits as the definitions they stand for, and
(slow) every hot path keeps its ratio to a raw `mujoco.rollout` (issue 55).

The ratio test measures with the process's CPU time, ours and the rollout timed in turn,
best of 5 each, a path below its floor measured again before it fails, so it holds on a
loaded machine; it asserts a ratio, never a time. What it measured is printed at the end of
the run with the CPU's name (`conftest.py`), so every CI run adds a reading of its CPU.
"""

from __future__ import annotations

import importlib.util
import math
import os
import shutil
import sys

import numpy as np
import pytest

import cpg_suite
from cpg_suite import electrical
from cpg_suite.darwin import recording

_BENCH = os.path.join(os.path.dirname(__file__), os.pardir, "benchmarks", "bench_hot_paths.py")


def _walked(task_id: str = "darwin_walk", steps: int = 40):
    env = cpg_suite.load(task_id, task_kwargs={"random": 1})
    env.reset()
    rng = np.random.default_rng(0)
    for _ in range(steps):
        if env.step(rng.uniform(-1.0, 1.0, 12)).last():
            env.reset()
    return env


def test_power_sums_and_update_sums_give_supply_current_bit_for_bit():
    """`SupplyMeter.power_sums` (every joint's b·q̇, one take) then `currents`, and the
    monitor's `update_sums`, equal `supply_current` and `update`, signed zeros and braking
    servos included, for one robot and for robots × steps."""
    rng = np.random.default_rng(5)
    nv, steps = 26, 8
    dofs = rng.permutation(np.arange(6, nv))
    for shape in ((steps,), (3, steps)):
        force = rng.uniform(-2.5, 2.5, (*shape, electrical.N_SERVOS))
        qvel = rng.uniform(-8.0, 8.0, (*shape, nv))
        force.reshape(-1, electrical.N_SERVOS)[0, :3] = -0.0
        qvel.reshape(-1, nv)[0, dofs[:3]] = 0.0
        dof_damping = rng.uniform(0.3, 0.6, (*shape[:-1], 1, nv) if len(shape) > 1 else nv)
        damping = dof_damping[..., dofs]
        expected = electrical.supply_current(force, qvel[..., dofs], damping)
        meter = electrical.SupplyMeter(shape)
        index = electrical.servo_index(math.prod(shape), dofs, nv)
        for _ in range(2):  # the buffers are reused
            sums = meter.power_sums(force, qvel, dof_damping, index)
            by_sums = electrical.SupplyMonitor(electrical.SupplyLimit(3.5, 0.004), 0.002)
            by_currents = electrical.SupplyMonitor(electrical.SupplyLimit(3.5, 0.004), 0.002)
            for row_sums, row in zip(sums.reshape(-1, steps), expected.reshape(-1, steps)):
                assert by_sums.update_sums(row_sums) == by_currents.update(row)
            state = (by_sums.total, by_sums.worst, by_sums.browned_out, by_sums._ring)
            assert state == (by_currents.total, by_currents.worst, by_currents.browned_out,
                             by_currents._ring)  # fmt: skip
            assert meter.currents(sums).tobytes() == expected.tobytes()


def test_the_tasks_shortcuts_equal_the_accessors():
    """`Physics.observation` = the eight accessors, `set_leg_action` =
    `set_leg_targets(action_to_targets(...))`, and `recording.supply_currents` =
    `supply_current` of `servo_steps`, bits included."""
    env = _walked()
    physics = env.physics
    expected = (
        physics.leg_joint_angles(),
        physics.leg_joint_velocities(),
        physics.torso_orientation(),
        np.array([physics.torso_height()]),
        physics.torso_velocity(),
        physics.gyro(),
        physics.accelerometer(),
        physics.foot_touch(),
    )
    got = physics.observation()
    assert [a.tobytes() for a in got] == [a.tobytes() for a in expected]
    assert [a.shape for a in got] == [a.shape for a in expected]
    force, velocity = recording.servo_steps(physics)
    currents = electrical.supply_current(force, velocity, physics.servo_damping())
    assert recording.supply_currents(physics).tobytes() == currents.tobytes()
    action = np.clip(np.random.default_rng(2).uniform(-1.2, 1.2, 12), -1.0, 1.0)
    action[0] = -0.0
    physics.set_leg_targets(physics.action_to_targets(action))
    before = physics.data.ctrl.copy()
    physics.data.ctrl[physics._leg_act] = np.nan
    physics.set_leg_action(action)
    assert physics.data.ctrl.tobytes() == before.tobytes()


def test_set_leg_action_equals_action_to_targets_for_every_kind_of_action():
    """The folded halving in `set_leg_action` gives `action_to_targets`' bits for actions
    spread over [−1, 1], its ends, signed zeros and the values next to them."""
    physics = _walked(steps=1).physics
    rng = np.random.default_rng(11)
    edges = np.array([-1.0, 1.0, 0.0, -0.0, np.nextafter(-1.0, 0), np.nextafter(1.0, 0), 5e-324])
    actions = np.concatenate([rng.uniform(-1.0, 1.0, (4000, 12)), rng.choice(edges, (500, 12))])
    for action in actions:
        physics.set_leg_action(action)
        expected = physics.action_to_targets(action)
        assert physics.data.ctrl[physics._leg_act].tobytes() == expected.tobytes()


def _bench(name: str = "bench_hot_paths"):
    path = os.path.join(os.path.dirname(_BENCH), f"{name}.py")
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclass looks its module up
    spec.loader.exec_module(module)
    return module


# Below or at the floor on the machine the test was written on (2-core AVX-512 EPYC, issue
# 55), each held to a lower floor of its own so that a regression still fails: the balance
# reward's contact forces (mj_forwardSkip) and centre-of-pressure loop; the push tier and
# the vector env measured 0.73-0.78x, too near 0.75 for a test that must not flake; the
# closed-loop evaluator.
_KNOWN_LOW = {
    "env.step darwin_balance": (0.6, "0.66-0.74x: 10 us of mj_forwardSkip, ~12 of the COP loop"),
    "env.step darwin_walk_push": (0.65, "0.73-0.78x"),
    "vector env": (0.65, "0.74-0.76x"),
    # Its feedback CPG's phases take 16 sequential substeps a control step in NumPy (~9 us a
    # trial-step at 100 trials): arithmetic of the controller's, which a rollout of its
    # controls skips. 0.62x before its rollout, 0.68-0.74x before the batched CPG step.
    "closed-loop evaluator": (0.65, "0.72-0.81x (2026-11-28)"),
}


def _floor(name: str, floor: float) -> float:
    return next((low for known, (low, _) in _KNOWN_LOW.items() if name.startswith(known)), floor)


def _below_floor(bench, paths, repeats: int, readings: list, tiers=None) -> dict[str, float]:
    """Each measured path below its floor → its ratio; every reading appended to `readings`."""
    kwargs = {} if tiers is None else {"tiers": tiers}
    low = {}
    for name, ours, raw in bench.ratios(paths, steps=1000, repeats=repeats, threads=1, **kwargs):
        readings.append((name, ours / raw, repeats))
        if ours / raw < _floor(name, bench.FLOOR):
            low[name] = ours / raw
    return low


@pytest.mark.slow
@pytest.mark.parametrize("path", ["env", "vector", "evaluator", "feedback", "score"])
def test_every_hot_path_keeps_three_quarters_of_raw_rollout(path, hot_path_readings):
    """Ours and the rollout timed in turn, best of 5 each; a path below its floor is timed
    again, best of 9, and fails only if it is below again: a slow spell of a shared machine
    does not fail it, a regression does (it is below in both)."""
    bench = _bench()
    low = _below_floor(bench, (path,), 5, hot_path_readings)
    if low:
        tiers = [name.removeprefix("env.step ") for name in low] if path == "env" else None
        low = _below_floor(bench, (path,), 9, hot_path_readings, tiers)
    if path == "env":  # where a control step's time goes on this CPU, for the summary
        profiler = _bench("bench_step_profile")
        for task_id in ("darwin_walk", "darwin_balance"):
            rows = profiler.profile(task_id, 1000, 3, "cpu")
            hot_path_readings.append((f"profile of {task_id} (µs a control step)", rows, 3))
    shown = "; ".join(f"{name}: {ratio:.3f}x raw" for name, ratio in low.items())
    assert not low, f"below {bench.FLOOR}x raw mujoco.rollout twice: {shown}"


# Each path's floor on the instructions it runs beyond its rollout's (raw's instructions per
# physics step over ours'), about 0.03 below what `bench_instructions.py --steps=100` counted
# on 2026-11-29 (docs/benchmarks.md): a count moves by 1 part in 10,000 between runs,
# whatever the machine's load, so a floor this close fails on ~8,000 more instructions a
# physics step (30 more NumPy calls a control step took walk from 0.912 to 0.852), and
# leaves room for other versions of NumPy and MuJoCo within the pins.
_INSTRUCTION_FLOORS = {
    "env.step darwin_walk": 0.88,  # counted 0.912
    "env.step darwin_balance": 0.82,  # 0.856
    "vector env": 0.87,  # 0.902 (25 control steps: its resets weigh more than at 200)
    "open-loop evaluator": 0.95,  # 0.987
}


@pytest.mark.slow
@pytest.mark.skipif(
    shutil.which("valgrind") is None or shutil.which("callgrind_control") is None,
    reason="Valgrind is not installed (apt install valgrind): it counts the instructions",
)
def test_every_hot_path_runs_few_instructions_beyond_its_rollout():
    """The instructions each path runs per physics step against its raw rollout's, counted
    by callgrind (`bench_instructions.py`): unlike a timed ratio, the same on a loaded
    machine, so its floor sits close under the count."""
    bench = _bench("bench_instructions")
    settings = bench.InstructionSettings(
        steps=100, paths=("env", "vector", "evaluator"), tiers=("darwin_walk", "darwin_balance")
    )
    rows = bench.measure(settings)
    ratios = {row["path"]: row["ratio"] for row in rows}
    assert len(ratios) == len(_INSTRUCTION_FLOORS), ratios
    low = {
        name: ratio
        for name, ratio in ratios.items()
        if ratio < next(f for known, f in _INSTRUCTION_FLOORS.items() if name.startswith(known))
    }
    for row in rows:  # the counts are exact: ours' parts add up to ours
        assert sum(row["parts"].values()) == pytest.approx(row["ours"], rel=1e-12)
        assert row["parts"]["MuJoCo"] > 0.8 * row["ours"]
    assert not low, f"more instructions beyond the rollout than before: {low}"


_DUMP = """\
version: 1
creator: callgrind-3.19.0
events: Ir
summary: 1110

ob=(1) /usr/lib/libmujoco.so.3.17.0
fl=(1) ???
fn=(1) mj_step
0 1000
cob=(2) /usr/lib/python3.11/site-packages/numpy/_core/_multiarray_umath.so
cfn=(2) ufunc
calls=2 0
0 99999
ob=(2)
fn=(2)
0 70
+2 30
ob=(3) /usr/lib/libpython3.11.so.1.0
fn=(3) eval
* 10
"""


def test_the_instruction_counts_are_read_as_callgrind_writes_them(tmp_path):
    """`bench_instructions.self_costs` counts each library's own instructions (a call's
    inclusive cost, after `calls=`, is its callee's and is not counted again; names given
    once by number are reused), and refuses a dump whose counts miss its total."""
    bench = _bench("bench_instructions")
    dump = tmp_path / "callgrind.1"
    dump.write_text(_DUMP)
    costs = bench.self_costs(str(dump))
    assert dict(costs) == {
        "/usr/lib/libmujoco.so.3.17.0": 1000,
        "/usr/lib/python3.11/site-packages/numpy/_core/_multiarray_umath.so": 100,
        "/usr/lib/libpython3.11.so.1.0": 10,
    }
    parts = bench.by_part(costs)
    assert (parts["MuJoCo"], parts["NumPy"], parts["Python"], parts[bench.OTHER]) == (
        1000,
        100,
        10,
        0,
    )
    dump.write_text(_DUMP.replace("summary: 1110", "summary: 1111"))
    with pytest.raises(ValueError, match="add to 1110, not 1111"):
        bench.self_costs(str(dump))
