"""Clamped junctions of the point chains (``jakobsen``, ``pbd``, ``xpbd``; issue 22, item 2): two particles held at
one point whose cables' tangents keep their start angle (:mod:`mjcable.solvers.junction_kernels`, the braces).

The reference is the clamp's definition: the angles between the segments that meet at the junction stay at their start
values, while an unclamped junction (a ball joint) lets a limp leg hang straight down; statics: the pins carry the
harness' weight."""

import numpy as np
import pytest

import mjcable
from mjcable import CableSpec, Junction, Pin, Scene

G = 9.81
LEG_ANGLE = 60.0  # degrees between the leg and the trunk's segment towards +x, in the horizontal plane


def _t_scene(clamp: bool) -> Scene:
    """A limp trunk (20 segments) hanging between two pins with a limp leg (10 segments as long) joined at its
    middle particle, starting horizontal at :data:`LEG_ANGLE` to the trunk's +x tangent there."""
    trunk = CableSpec([(-0.3, 0.0, 1.0), (0.0, 0.0, 0.95), (0.3, 0.0, 1.0)], 20, 0.004, 0.06, damping=5.0)
    joint = trunk.particles[10]
    tangent = trunk.particles[11] - joint
    tangent /= np.linalg.norm(tangent)
    side = np.cross([0.0, 0.0, 1.0], tangent)
    side /= np.linalg.norm(side)
    a = np.radians(LEG_ANGLE)
    direction = np.cos(a) * tangent + np.sin(a) * side
    leg = CableSpec([joint, joint + 10 * trunk.segment_length * direction], 10, 0.004, 0.03, damping=5.0)
    return Scene((trunk, leg), (Pin(0), Pin(-1)), junctions=(Junction((0, 10), (1, 0), clamp=clamp),))


def _angles(x: np.ndarray, joint: int, arms) -> np.ndarray:
    """The angles (degrees) between the segments from particle ``joint`` to each pair of particles in ``arms``."""
    out = []
    for p, q in arms:
        u, v = x[p] - x[joint], x[q] - x[joint]
        out.append(np.degrees(np.arccos(np.clip(u @ v / np.linalg.norm(u) / np.linalg.norm(v), -1.0, 1.0))))
    return np.array(out)


@pytest.mark.parametrize("model", ["xpbd", pytest.param("pbd", marks=pytest.mark.slow),
                                   pytest.param("jakobsen", marks=pytest.mark.slow)])
def test_a_clamped_leg_keeps_its_angle_to_the_trunk(model):
    """At rest the leg's first segment keeps its start angles to both trunk segments at the junction within 1°
    (it swings about the trunk's tangent, which a chain of points can't resist); unclamped, the limp leg hangs and
    those angles move by more than 10°. Either way the two pins carry the whole weight within 1 %."""
    found = {}
    for clamp in (True, False):
        scene = _t_scene(clamp)
        trunk, leg = scene.cable_slices
        joint, arms = trunk.start + 10, [(trunk.start + 11, leg.start + 1), (trunk.start + 9, leg.start + 1)]
        start = _angles(np.asarray(scene.particles), joint, arms)
        sim = mjcable.Simulator(scene, model)
        sim.step(4.0)
        assert np.abs(sim.velocities).max() < 1e-3
        found[clamp] = _angles(sim.positions, joint, arms) - start
        weight = sum(c.mass for c in scene.cables) * G
        np.testing.assert_allclose(sim.pin_forces.sum(axis=0), [0.0, 0.0, weight], atol=0.01 * weight)
    assert np.abs(found[True]).max() < 1.0, found
    assert np.abs(found[False]).max() > 10.0, found
