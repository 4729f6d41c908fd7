"""Free grippers (``Scene(grippers=...)``): grasp any particle at run time and let it go, for every model.

The must-show: a cable lying on a table, grasped at its middle particle and lifted 0.6 m, hangs at rest from the
gripper with the gripper's force equal to its weight (within 1 %) and its two halves symmetric about the vertical
through the grasp point (within 1 mm); released, it falls with its centre of mass accelerating at g (within 5 %)
and the gripper's force is 0.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import mjcable
from mjcable import Gripper, Pin, Scene, Simulator, catalog, scenes

LIFT = 0.6  # m
LIFT_TIME = 1.5  # s: a minimum-jerk lift
SETTLE, REST, FALL = 0.5, 8.0, 0.05  # s on the table, hanging, falling
DAMPING = 2.0  # 1/s: the cable's own damping brings it to rest (its drag slows the fall by about c t / 3 ≈ 3 %)
MIDDLE = 25
SLOW = {"joints", "composite"}  # 8-10 s each on the shared machine
# a wavy cable just above the table (0.94 m: its halves hang clear of it), symmetric under a half turn about the
# vertical through its middle particle
POINTS = [[-0.35, -0.1, 0.756], [-0.1, 0.1, 0.756], [0.1, -0.1, 0.756], [0.35, 0.1, 0.756]]


def _table(**fields) -> Scene:
    scene = scenes.get("table", points=POINTS, damping=DAMPING, **fields)
    return dataclasses.replace(scene, grippers=(Gripper(tuple(scene.cable.particles[MIDDLE])),))


def _lift(start: np.ndarray, dt: float) -> np.ndarray:
    """``(steps, 1, 3)`` m: the gripper from ``start`` up by LIFT along a minimum-jerk profile."""
    s = np.arange(1, int(round(LIFT_TIME / dt)) + 1) / round(LIFT_TIME / dt)
    return start + (10 * s**3 - 15 * s**4 + 6 * s**5)[:, None, None] * np.array([0.0, 0.0, LIFT])


def _mirror_gap(x: np.ndarray, i: int) -> float:
    """m: the farthest particle of one half from its partner of the other, half-turned about the vertical through
    particle ``i`` (``x[i - k]`` against ``x[i + k]``)."""
    k = np.arange(1, min(i, len(x) - 1 - i) + 1)
    a = x[i - k].copy()
    a[:, :2] = 2.0 * x[i, :2] - a[:, :2]
    return float(np.linalg.norm(a - x[i + k], axis=1).max())


@pytest.mark.parametrize("model", [pytest.param(m, marks=pytest.mark.slow) if m in SLOW else m
                                   for m in catalog.names()])
def test_grasp_lift_hang_release(model):
    scene = _table()
    sim = Simulator(scene, model)
    sim.step(SETTLE)
    assert sim.grasp(0) == MIDDLE  # the nearest particle
    gripper = len(scene.pins)
    sim.step_along(_lift(sim.gripper_positions[gripper], sim.dt))
    assert sim.positions[MIDDLE, 2] == pytest.approx(scene.cable.particles[MIDDLE, 2] + LIFT, abs=2e-3)
    sim.step(REST)
    weight = scene.cable.mass * np.linalg.norm(scene.gravity)
    force = sim.gripper_forces
    assert force.shape == (1, 3)
    np.testing.assert_allclose(force[0], [0.0, 0.0, weight], atol=0.01 * weight)
    x = sim.positions
    assert x[:, 2].min() > scene.obstacles[1].pos[2] + 0.05  # hanging clear of the table
    assert _mirror_gap(x, MIDDLE) < 1e-3
    assert sim.release(0) == MIDDLE
    assert np.all(sim.gripper_forces == 0.0)
    m = sim.particle_masses
    z0 = m @ sim.positions[:, 2] / m.sum()
    v0 = m @ sim.velocities[:, 2] / m.sum()
    sim.step(FALL)
    z1 = m @ sim.positions[:, 2] / m.sum()
    acceleration = -2.0 * (z1 - z0 - v0 * FALL) / FALL**2
    assert acceleration == pytest.approx(np.linalg.norm(scene.gravity), rel=0.05)
    assert np.all(sim.gripper_forces == 0.0)
    assert sim.grasped == (None,)


def test_gripper_and_scene_validation():
    with pytest.raises(ValueError, match=r"position must be 3 finite numbers in m, got \(0, 0\)"):
        Gripper((0, 0))
    with pytest.raises(ValueError, match="position must be 3 finite numbers"):
        Gripper((0.0, float("nan"), 1.0))
    cable = scenes.get("hang").cable
    with pytest.raises(ValueError, match=r"grippers must be a sequence of Gripper instances"):
        Scene(cable, grippers=Gripper((0.0, 0.0, 1.0)))
    with pytest.raises(ValueError, match=r"grippers\[1\] must be one of Gripper instances, .*got Pin\(index=0"):
        Scene(cable, grippers=(Gripper((0.0, 0.0, 1.0)), Pin(0)))
    scene = Scene(cable, pins=(Pin(0, "gripper"), Pin(-1)), grippers=[Gripper([0, 0, 1])])
    assert scene.grippers == (Gripper((0.0, 0.0, 1.0)),) and scene.gripper_pins == (0,)


@pytest.mark.parametrize("model", ["xpbd", "springs"])
def test_grasp_and_release_validation(model):
    scene = dataclasses.replace(scenes.get("hang"), grippers=(Gripper((0.0, 0.0, 0.5)), Gripper((0.0, 0.0, 0.9))))
    sim = Simulator(scene, model)
    n = scene.n_particles
    with pytest.raises(ValueError, match=r"g must be an integer >= 0 and <= 1, got 2"):
        sim.grasp(2)
    with pytest.raises(ValueError, match=r"g must be an integer >= 0 and <= 1, got -1"):
        sim.release(-1)
    with pytest.raises(ValueError, match=rf"index must be an integer >= {-n} and <= {n - 1}, got {n}"):
        sim.grasp(0, n)
    with pytest.raises(ValueError, match=r"index: particle 50 is held by pins\[1\] already"):
        sim.grasp(0, -1)
    with pytest.raises(ValueError, match=r"free gripper 0 holds nothing \(it is open\)"):
        sim.release(0)
    assert sim.grasp(0, 20) == 20
    with pytest.raises(ValueError, match=r"g: free gripper 0 already holds particle 20"):
        sim.grasp(0, 21)
    with pytest.raises(ValueError, match=r"index: particle 20 is held by free gripper 0 already"):
        sim.grasp(1, 20)
    with pytest.raises(ValueError, match=r"orientation: free gripper 0 \(pin_number 2\) holds a point"):
        sim.move_gripper(2, [0.0, 0.0, 0.5], [1.0, 0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"pin_number must index a gripper pin, one of \(2, 3\)"):
        sim.move_gripper(4, [0.0, 0.0, 0.5])
    assert sim.release(0) == 20 and sim.grasped == (None, None)
    plain = Simulator(scenes.get("hang"), model)
    with pytest.raises(ValueError, match=r"the scene has no free grippers"):
        plain.grasp(0)


def test_nearest_particle_skips_held_ones():
    cable = scenes.get("hang").cable
    p = cable.particles
    scene = Scene(cable, pins=(Pin(0), Pin(-1)), grippers=(Gripper(p[0] + [0.0, 0.0, 1e-3]),) * 2)
    sim = Simulator(scene, "xpbd")
    assert sim.grasp(0) == 1  # particle 0, nearest, is pinned
    assert sim.grasp(1) == 2
    np.testing.assert_array_equal(sim.gripper_positions, [p[0] + [0.0, 0.0, 1e-3]] * 2)


@pytest.mark.parametrize("model", catalog.names())
def test_open_gripper_changes_nothing(model):
    """A free gripper that never closes, moved about, leaves the cable bit for bit as without it."""
    plain = scenes.get("table", points=POINTS)
    sim = Simulator(dataclasses.replace(plain, grippers=(Gripper((0.0, 0.0, 1.0)),)), model)
    ref = Simulator(plain, model)
    sim.step_along(np.linspace([0.0, 0.0, 1.0], [0.2, 0.0, 0.8], 25)[:, None])
    sim.move_gripper(0, [0.0, 0.1, 0.9])
    sim.step(0.05)
    ref.step(0.1)
    np.testing.assert_array_equal(sim.positions, ref.positions)
    np.testing.assert_array_equal(sim.gripper_positions, [[0.0, 0.1, 0.9]])
    assert np.all(sim.gripper_forces == 0.0)


@pytest.mark.parametrize("model", ["xpbd", "cosserat", "springs", "flexrod"])
def test_reset_and_path_equal_moves(model):
    """After grasping and moving, reset() is the start bit for bit (every gripper open), and a held gripper's
    step_along equals move_gripper and step per row."""
    scene = _table()
    runs = []
    sim = Simulator(scene, model)
    start = sim.positions
    for along in (True, False):
        sim.step(0.1)
        sim.grasp(0, MIDDLE + 3)
        path = sim.gripper_positions[0] + np.linspace(0.0, 1.0, 26)[1:, None, None] * [0.0, 0.02, 0.05]
        if along:
            sim.step_along(path)
        else:
            for row in path:
                sim.move_gripper(0, row[0])
                sim.step()
        runs.append((sim.positions, sim.gripper_forces, sim.gripper_positions))
        assert np.linalg.norm(runs[-1][1]) > 0.0
        sim.reset()
        assert sim.grasped == (None,) and sim.time == 0.0
        np.testing.assert_array_equal(sim.positions, start)
        np.testing.assert_allclose(sim.gripper_positions, [scene.grippers[0].position], rtol=0, atol=1e-12)
        assert np.all(sim.gripper_forces == 0.0)
    for a, b in zip(*runs):
        np.testing.assert_array_equal(a, b)
