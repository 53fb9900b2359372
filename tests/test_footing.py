"""How the feet meet the floor (`cpg_suite.evaluation.footing`, issue 54): known answers,
MuJoCo's sensors on a sole pivoting and sliding, the robot, and both scoring paths."""

import json

import mujoco
import numpy as np
import pytest
from mujoco import rollout

import cpg_suite
from cpg_suite import cpg, darwin, protocol
from cpg_suite.evaluation import footing
from cpg_suite.evaluation.open_loop import BatchEvaluator
from cpg_suite.protocol import score

DT = 0.002  # s: the robot's physics step
A, B = darwin.robot.SOLE_HALF_SIZE
CORNERS = {"toe_l": (A, B), "toe_r": (A, -B), "heel_l": (-A, B), "heel_r": (-A, -B)}
SHIPPED = "results/protocol/runs/cmaes/darwin_walk/K50_s1_seed0/selected_params.json"


def _feet(steps):
    """A footing record of two feet standing still, upright, at the origin, no contacts."""
    feet = np.zeros((steps, 2, footing.FOOT_WIDTH))
    sole = footing.SLOTS * footing.SLOT
    feet[..., sole + 6] = 1.0  # x axis (1, 0, 0)
    feet[..., sole + 10] = 1.0  # y axis (0, 1, 0)
    return feet


def _touch(feet, t, foot, points, force=10.0):
    """Contacts of one foot at sole coordinates `points` (x, y), each carrying `force`."""
    for k, (x, y) in enumerate(points):
        slot = feet[t, foot, k * footing.SLOT : (k + 1) * footing.SLOT]
        slot[0], slot[1], slot[4:7] = len(points), force, (x, y, 0.0)


def _measures(feet, velocity=None, distance=1.0):
    velocity = np.zeros((len(feet), 2, 3)) if velocity is None else velocity
    return footing.measures(
        velocity, feet, stance_force=1.0, timestep=DT, distance=distance, min_distance=0.05
    )


def test_the_sole_constants_are_the_models():
    physics = cpg_suite.load("darwin_walk").physics
    model = physics.model
    for foot, site in zip(darwin.robot.FOOT_GEOMS, darwin.robot.SOLE_SITES):
        g, s = model.name2id(foot, "geom"), model.name2id(site, "site")
        np.testing.assert_array_equal(model.geom_size[g, :2], darwin.robot.SOLE_HALF_SIZE)
        # The sole's site: its centre on the box's bottom face, its axes the box's.
        np.testing.assert_allclose(
            model.site_pos[s], model.geom_pos[g] - [0, 0, model.geom_size[g, 2]]
        )
        np.testing.assert_array_equal(model.site_quat[s], model.geom_quat[g])
    footing_slice = physics.sensor_slices()["footing"]
    assert footing_slice.stop - footing_slice.start == 2 * footing.FOOT_WIDTH
    contact = model.name2id("floor_contacts_l", "sensor")
    assert model.sensor_dim[contact] == footing.SLOTS * footing.SLOT


def test_a_foot_turning_about_an_edge_does_not_slip_and_a_sliding_one_does():
    steps = 100
    feet, velocity = _feet(steps), np.zeros((steps, 2, 3))
    sole = footing.SLOTS * footing.SLOT
    omega = np.array([0.3, -2.0, 0.5])  # rad/s, about the toe's left corner
    centre = np.array([0.01, -0.02, 0.03])
    pivot = centre + [A, B, 0.0]
    feet[:, 0, sole : sole + 3], feet[:, 0, sole + 3 : sole + 6] = omega, centre
    velocity[:, 0] = np.cross(omega, centre - pivot)  # the sole centre turns about the pivot
    for t in range(steps):
        _touch(feet, t, 0, [(A, B)])
        feet[t, 0, 4:7] = pivot
    rolling = _measures(feet, velocity)
    assert rolling["contact_slip_per_m"] == pytest.approx(0.0, abs=1e-15)
    assert np.hypot(velocity[0, 0, 0], velocity[0, 0, 1]) > 0.03  # the centre moves
    # The same foot sliding at 0.5 m/s besides: 0.2 s of it is 0.1 m of slip.
    velocity[:, 0] += [0.3, 0.4, 0.0]
    assert _measures(feet, velocity, distance=2.0)["contact_slip_per_m"] == pytest.approx(0.05)


def test_contact_speeds_are_weighted_by_their_normal_forces():
    feet, velocity = _feet(1), np.zeros((1, 2, 3))
    sole = footing.SLOTS * footing.SLOT
    feet[0, 1, sole : sole + 3] = [0.0, 0.0, 1.0]  # turning about z at 1 rad/s
    _touch(feet, 0, 1, [(A, 0.0), (-A, 0.0)])
    feet[0, 1, 1], feet[0, 1, 8] = 30.0, 10.0  # the toe carries 3/4
    velocity[0, 1] = [0.0, A, 0.0]  # the heel stands still, the toe moves at 2A
    m = _measures(feet, velocity)  # one step
    assert m["contact_slip_per_m"] == pytest.approx(0.75 * 2 * A * DT)


def test_a_sole_is_flat_on_three_or_four_corners_not_on_an_edge():
    feet = _feet(6)
    c = CORNERS
    cases = [
        (list(c.values()), True),
        ([c["toe_l"], c["toe_r"], c["heel_l"]], True),
        ([c["toe_l"], c["heel_r"]], True),  # opposite corners
        ([c["heel_l"], c["heel_r"]], False),  # on its heel
        ([c["toe_l"], c["heel_l"]], False),  # on its outer edge
        ([(0.3 * A, B), (0.3 * A, -B), (-A, B)], False),  # across a tile's edge
    ]
    for t, (points, _) in enumerate(cases):
        _touch(feet, t, 0, points)
    m = _measures(feet)
    assert m["flat_stance_share"] == sum(flat for _, flat in cases) / len(cases)


def test_a_bounce_is_not_a_swing():
    stance = np.array([1] * 5 + [0] * 3 + [1] * 5 + [0] * 30 + [1] * 5 + [0] * 4, bool)
    assert footing.swings(stance) == [(5, 8), (13, 43)]  # the last run ends no swing
    assert footing.swings(stance, min_steps=25) == [(13, 43)]


def _stride(first_contact, swing=40, air=30, lift=0.02):
    """One foot: stance, a swing `swing` steps long (in the air for `air` of them, its
    centre `lift` up), a first contact at `first_contact`, then stance again."""
    steps = 10 + swing + 10
    feet = _feet(steps)
    flat = list(CORNERS.values())
    sole = footing.SLOTS * footing.SLOT
    for t in range(steps):
        if t < 10 or t >= 10 + swing:
            _touch(feet, t, 0, flat)
        elif t >= 10 + air:
            _touch(feet, t, 0, first_contact, force=0.1)  # light: not yet stance
        else:
            feet[t, 0, sole + 5] = lift * np.sin(np.pi * (t - 10) / air)
    return feet


def test_strikes_are_classified_by_the_first_contact():
    c = CORNERS
    heel = _measures(_stride([c["heel_l"], c["heel_r"]]))
    assert (heel["heel_strike_share"], heel["toe_strike_share"]) == (1.0, 0.0)
    toe = _measures(_stride([c["toe_r"]]))
    assert (toe["heel_strike_share"], toe["toe_strike_share"]) == (0.0, 1.0)
    flat = _measures(_stride(list(c.values())))
    assert (flat["heel_strike_share"], flat["toe_strike_share"]) == (0.0, 0.0)
    side = _measures(_stride([c["toe_l"], c["heel_l"]]))
    assert (side["heel_strike_share"], side["toe_strike_share"]) == (0.0, 0.0)
    # A foot dragged along the floor through its swing has no touchdown.
    dragged = _measures(_stride([c["heel_l"]], air=0))
    assert np.isnan(dragged["heel_strike_share"])
    # A swing shorter than `MIN_SWING` is a bounce: no touchdown, no clearance.
    bounce = _measures(_stride([c["heel_l"]], swing=20, air=15))
    assert np.isnan(bounce["heel_strike_share"]) and np.isnan(bounce["swing_clearance_m"])


def test_swing_clearance_is_the_lowest_corners_highest_point():
    feet = _stride([CORNERS["heel_l"]], lift=0.02)
    # The sole pitched 10 degrees, toe down, through its swing: the toe is its lowest point.
    pitch = np.deg2rad(10.0)
    sole = footing.SLOTS * footing.SLOT
    feet[10:50, 0, sole + 6 : sole + 9] = [np.cos(pitch), 0.0, -np.sin(pitch)]
    m = _measures(feet)
    expected = 0.02 * np.sin(np.pi * 15 / 30) - A * np.sin(pitch)
    assert m["swing_clearance_m"] == pytest.approx(expected)


def test_measures_are_undefined_without_their_events():
    m = _measures(_feet(10), distance=0.01)
    assert all(np.isnan(m[f]) for f in footing.FIELDS)


_BOX = """<mujoco><option timestep="0.002" integrator="implicitfast"/>
<worldbody><geom name="floor" type="plane" size="5 5 .1"/>
<body name="sole" pos="{pos}">{joints}
<geom name="box" type="box" size="{a} {b} 0.0065" mass="1" pos="0 0 0.0065"/>
<site name="s"/></body></worldbody>
<actuator>{actuator}</actuator>
<sensor><framelinvel objtype="site" objname="s"/>
<contact geom1="box" body2="world" num="{num}" data="found force pos" reduce="maxforce"/>
<frameangvel objtype="site" objname="s"/><framepos objtype="site" objname="s"/>
<framexaxis objtype="site" objname="s"/><frameyaxis objtype="site" objname="s"/></sensor>
</mujoco>"""


def _box(pos, joints, actuator, ctrl, steps):
    """A sole-sized box on the floor with the robot's footing sensors, driven by one
    actuator: its footing measures (slip in m: distance 1), and after each step its sole
    centre's velocity, m/s, and its floor contacts' load, N."""
    xml = _BOX.format(pos=pos, joints=joints, a=A, b=B, actuator=actuator, num=footing.SLOTS)
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    state = np.zeros(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(model, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    _, sensors = rollout.rollout(model, data, state, np.full((1, steps, 1), ctrl))
    velocity, feet = np.zeros((steps, 2, 3)), np.zeros((steps, 2, footing.FOOT_WIDTH))
    velocity[:, 0], feet[:, 0] = sensors[0, :, :3], sensors[0, :, 3:]  # the other foot: none
    m = footing.measures(
        velocity, feet, stance_force=0.5, timestep=DT, distance=1.0, min_distance=0.05
    )
    return m, velocity[:, 0], footing.contacts(feet)["normal"][:, 0].sum(axis=1)


def test_mujoco_soles_pivoting_about_an_edge_do_not_slip_and_sliding_ones_do():
    # Hinged along its toe edge, 0.5 mm into the floor, its heel lifted for 0.1 s by a
    # motor: the sole turns about its toe, whose contacts carry it.
    hinge = f'<joint name="hinge" type="hinge" axis="0 1 0" pos="{A} 0 0" damping="0.1"/>'
    motor = '<motor joint="hinge"/>'
    pivot, velocity, load = _box("0 0 -0.0005", hinge, motor, 0.8, 50)
    path = np.sum(np.linalg.norm(velocity, axis=1)) * DT
    assert path > 5e-3  # the sole centre moved
    assert np.all(load > 0.5)  # on its toe all along: in stance
    assert pivot["contact_slip_per_m"] < 0.01 * path
    # On two slide joints (x, z: it cannot tip) pushed to slide at 0.1 m/s for 0.5 s: all
    # of it slips (it hops a few microns as it slides: in stance 65 % of the steps).
    slides = '<joint name="x" type="slide" axis="1 0 0"/><joint type="slide" axis="0 0 1"/>'
    slide, velocity, load = _box("0 0 0", slides, '<velocity joint="x" kv="100"/>', 0.2, 250)
    horizontal = np.linalg.norm(velocity[:, :2], axis=1)
    path = np.sum(np.where(load > 0.5, horizontal, 0.0)) * DT  # in stance
    assert path > 0.02 and np.mean(load > 0.5) > 0.5
    assert slide["contact_slip_per_m"] == pytest.approx(path, rel=1e-9)
    assert slide["flat_stance_share"] == 1.0


def _without_footing(xml):
    """The model's XML without the footing sensors."""
    start = xml.index("    <!-- How the soles meet the floor")
    return xml[:start] + xml[xml.index("  </sensor>") :]


def test_the_footing_sensors_do_not_change_the_dynamics():
    amplitudes = cpg.load_amplitudes(SHIPPED)
    for task in ("darwin_walk", "darwin_walk_rough"):
        evaluator = BatchEvaluator(task, steps=300)
        episode = evaluator.episode(protocol.TEST.start)
        new = episode.model
        xml, assets = darwin.get_model_and_assets(cpg_suite.load(task).task.terrain)
        old = mujoco.MjModel.from_xml_string(_without_footing(xml), assets)
        old.geom_pos[:] = new.geom_pos  # the episode's raised tiles
        assert new.nsensordata - old.nsensordata == 2 * footing.FOOT_WIDTH
        ctrl = evaluator.controls(amplitudes[None])[0].repeat(evaluator.n_sub, axis=0)[None]
        states = [
            rollout.rollout(m, mujoco.MjData(m), episode.state[None], ctrl)[0] for m in (old, new)
        ]
        np.testing.assert_array_equal(states[0], states[1])


def test_the_mjx_model_keeps_the_sensor_layout():
    xml, assets = darwin.get_model_and_assets()
    ours = mujoco.MjModel.from_xml_string(xml, assets)
    mjx_model = mujoco.MjModel.from_xml_string(darwin.robot.for_mjx(xml), assets)
    np.testing.assert_array_equal(ours.sensor_adr, mjx_model.sensor_adr)
    np.testing.assert_array_equal(ours.sensor_dim, mjx_model.sensor_dim)
    mjx = pytest.importorskip("mujoco.mjx")
    mjx.put_model(mjx_model)  # MJX refuses a contact sensor that matches a body


class _Standing:
    """The CPG's standing posture, held."""

    def __init__(self, physics):
        self.action = physics.targets_to_action(cpg.CPGConfig().offsets())

    def __call__(self, observation):
        return self.action


def test_a_standing_robot_stands_flat():
    physics = cpg_suite.load("darwin_balance").physics
    trial = score.policy_trial(_Standing(physics), "darwin_balance", protocol.TEST.start, 60)
    assert not trial["fell"]
    assert trial["quality"]["flat_stance_share"] > 0.95


def test_both_scoring_paths_measure_the_footing_of_a_shipped_gait_equally():
    amplitudes = cpg.load_amplitudes(SHIPPED)
    seeds, steps = [protocol.TEST.start, protocol.TEST.start + 1], 400
    for tier in ("darwin_walk", "darwin_walk_rough"):
        settings = score.ScoreSettings(tiers=(tier,), seeds=2, steps=steps, threads=2)
        batched, _ = score._gait_tier(amplitudes, tier, seeds, settings)
        for j, seed in enumerate(seeds):
            trial = score.policy_trial(score.OpenLoopPolicy(amplitudes, steps), tier, seed, steps)
            ours = {f: float(v[j]) for f, v in batched["q"].items()}
            assert json.dumps(ours) == json.dumps(trial["quality"])
            assert all(np.isfinite(ours[f]) for f in footing.FIELDS), ours
