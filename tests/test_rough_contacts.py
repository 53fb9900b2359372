"""The rough tier's ground where its tiles are flat: box soles on box tiles behave as on the
floor plane (investigations/rough_falls.py, docs/contact.md)."""

import mujoco
import numpy as np

import cpg_suite
from cpg_suite import perturbations
from cpg_suite.darwin import perturb
from cpg_suite.protocol import score, verify

STEPS = 100  # physics steps (0.2 s) of standing, servos holding the starting posture
TILE_TOP = 0.002  # m: every tile raised to this height (the tier draws U(0, 3 mm))
TILE_CENTRE = (0.1, 0.1)  # m: the middle of a tile; the origin is a corner of four tiles


def _standing(on_tiles: bool, shift: tuple[float, float]) -> tuple:
    """The robot standing `STEPS` physics steps on the plane or on tiles all `TILE_TOP` high,
    moved by `shift` in x and y (and up by `TILE_TOP` on the tiles).

    Returns:
      Per foot (left, right): the number of floor contacts and their normal force, N; the
      torso's position relative to the ground under the start.
    """
    env = cpg_suite.load("darwin_walk_rough", task_kwargs={"random": 0})
    env.reset()
    physics = env.physics
    model, data = physics.model.ptr, physics.data.ptr
    height = TILE_TOP if on_tiles else 0.0
    perturb.set_tile_heights(physics, np.full(len(physics._tiles), height))
    data.qpos[:3] += (*shift, height)
    for _ in range(STEPS):
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    counts, forces, force = [0, 0], [0.0, 0.0], np.zeros(6)
    ground = {int(physics._floor), *map(int, physics._tiles)}
    for i in range(data.ncon):
        g1, g2 = (int(g) for g in data.contact[i].geom)
        for foot, geom in enumerate(int(g) for g in physics._feet):
            if geom in (g1, g2) and (g1 in ground or g2 in ground):
                mujoco.mj_contactForce(model, data, i, force)
                counts[foot] += 1
                forces[foot] += force[0]
    return counts, np.array(forces), data.qpos[:3] - (*shift, height)


def test_a_sole_inside_a_flat_tile_meets_it_as_it_meets_the_plane():
    plane = _standing(False, TILE_CENTRE)
    tiles = _standing(True, TILE_CENTRE)
    assert plane[0] == tiles[0] == [4, 4]  # the sole's four corners, box-plane and box-box
    np.testing.assert_allclose(tiles[1], plane[1], rtol=1e-6)
    np.testing.assert_allclose(tiles[2], plane[2], atol=1e-9)


def test_a_sole_across_a_seam_of_flat_tiles_carries_the_same_load():
    plane = _standing(False, (0.0, 0.0))
    seam = _standing(True, (0.0, 0.0))  # each sole straddles the tiles' edges at x=0, y=0
    # Box-box clipping adds a point where the sole crosses the seams: 5 where the plane has 4.
    assert plane[0] == [4, 4] and seam[0] == [5, 5]
    # The same load in all, shared a little differently between the feet (within 3 %).
    np.testing.assert_allclose(seam[1].sum(), plane[1].sum(), rtol=3e-3)
    np.testing.assert_allclose(seam[1], plane[1], rtol=0.03)
    np.testing.assert_allclose(seam[2], plane[2], atol=5e-4)  # the torso within 0.5 mm


def test_zero_height_tiles_score_a_shipped_gait_as_the_nominal_tier():
    run = f"{verify.ARTIFACTS}/cmaes/darwin_walk/K50_s1_seed0"
    policy = score.OpenLoopPolicy(verify.gait_params(run, "open_loop"))
    kwargs = verify.run_settings(run).task_kwargs()
    flat = {**kwargs, "terrain": perturbations.Terrain(max_height=0.0)}
    rough = score.policy_trial(policy, "darwin_walk_rough", 2000000, steps=150, task_kwargs=flat)
    nominal = score.policy_trial(policy, "darwin_walk", 2000000, steps=150, task_kwargs=kwargs)
    assert rough == nominal
