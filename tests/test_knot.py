"""Knots (issue 22): the overhand knot's start shape, the knot determinant, a cable's closest approach to itself,
and the must-show "Knot": one rope in a loose overhand knot, its ends pulled apart by grippers until taut,
self-collision on."""

import math
import warnings

import numpy as np
import pytest

import mjcable
from mjcable import geometry, knots, metrics
from mjcable.bench import knot


# ----------------------------------------------------------------------------------------- segment distances

def test_self_distance_leaves_out_the_neighbours_it_is_told_to():
    # a hairpin: two straight legs 1 cm apart joined by two short segments; the closest pair two apart is the
    # first leg's end and the bend's second segment, (0.204, 0.008) nearest: 8.94 mm
    x = np.array([[0, 0, 0], [0.1, 0, 0], [0.2, 0, 0], [0.21, 0.005, 0], [0.2, 0.01, 0], [0.1, 0.01, 0]], float)
    d, i, j = metrics.self_distance(x, skip=1)
    assert (i, j) == (1, 3) and d == pytest.approx(math.hypot(0.004, 0.008))
    assert metrics.self_distance(x, skip=2)[0] == pytest.approx(0.01)  # the legs
    assert metrics.self_distance(x[:3], skip=1) == (math.inf, -1, -1)
    with pytest.raises(ValueError, match="skip"):
        metrics.self_distance(x, skip=0)


# ------------------------------------------------------------------------------------------- the start shape

@pytest.mark.parametrize("clearance", [0.012, 0.03])
def test_the_overhand_knot_keeps_its_clearance_between_strands(clearance):
    shape = knots.overhand_knot(clearance, tail=0.2, centre=(0.1, -0.2, 1.5))
    cable = mjcable.CableSpec(shape.points, 600, 1e-3, 0.1)  # (fine segments: the curve itself)
    x = cable.particles
    l0 = cable.segment_length
    # strands: segments more than π c / 2 apart along the cable (a curve bent at radius c/2 is c across there)
    k = np.arange(cable.n_segments)
    strands = (k[None, :] - k[:, None] - 1) * l0 > 0.5 * math.pi * clearance
    d = geometry.segment_distances(x, x)[strands]
    assert d.min() >= clearance * (1 - 1e-3)  # (the chords cut the curve's corners by ~l0²/8R)
    assert d.min() <= clearance * 1.02  # the clearance is the strands' own, not a loose bound
    t = np.diff(x, axis=0) / l0
    turn = np.arccos(np.clip(np.sum(t[1:] * t[:-1], axis=1), -1.0, 1.0))
    assert l0 / turn.max() >= 0.5 * clearance  # its curvature radius: a tube of the clearance does not fold
    assert x[-1] - x[0] == pytest.approx([np.linalg.norm(x[-1] - x[0]), 0, 0], abs=1e-6)
    assert 0.5 * (x[0] + x[-1]) == pytest.approx([0.1, -0.2, 1.5], abs=1e-6)
    assert shape.length == pytest.approx(cable.length, rel=1e-3)
    assert knots.knot_determinant(x) == 3
    assert 0.0 < shape.loop_length < shape.length - 2 * 0.2


@pytest.mark.parametrize("name, value", [("clearance", 0.0), ("clearance", float("nan")), ("tail", -0.1)])
def test_the_overhand_knot_refuses_bad_sizes(name, value):
    with pytest.raises(ValueError, match=name):
        knots.overhand_knot(**{"clearance": 0.01, name: value})


# -------------------------------------------------------------------------------------- the knot determinant

def _cut_at_outermost(closed):
    """A closed curve's points (k, 3) opened at its point farthest from the axis: the ends outermost."""
    start = int(np.argmax(np.hypot(closed[:, 0], closed[:, 1])))
    return np.roll(closed, -start, axis=0)[1:]


def test_the_knot_determinant_tells_the_unknot_trefoil_and_figure_eight():
    # knot tables: det(unknot) = 1, det(3₁) = 3 (either handedness), det(4₁) = 5
    t = np.linspace(0.0, 2 * np.pi, 600, endpoint=False)
    trefoil = np.stack([np.sin(t) + 2 * np.sin(2 * t), np.cos(t) - 2 * np.cos(2 * t), -np.sin(3 * t)], 1)
    eight = np.stack([(2 + np.cos(2 * t)) * np.cos(3 * t), (2 + np.cos(2 * t)) * np.sin(3 * t), np.sin(4 * t)], 1)
    assert knots.knot_determinant(_cut_at_outermost(trefoil)) == 3
    assert knots.knot_determinant(_cut_at_outermost(trefoil * [1, 1, -1])) == 3
    assert knots.knot_determinant(_cut_at_outermost(eight)) == 5
    s = np.linspace(0.0, 1.0, 200)  # a rope with a twisted loop in it (a crossing, no knot), and a straight one
    loop = np.stack([3 * s + 0.5 * np.sin(2 * np.pi * s), 0.5 * np.cos(2 * np.pi * s) - 0.5,
                     0.1 * np.sin(2 * np.pi * s)], 1)
    assert len(knots.crossings(loop)) == 1 and knots.knot_determinant(loop) == 1
    assert knots.knot_determinant(np.stack([s, 0 * s, 0 * s], 1)) == 1


# ------------------------------------------------------------------------------------------------ must-show

def _pull_taut(model, **settings):
    """The knot scene pulled taut for knot.DURATION, step by step: the rope's closest approach to itself at every
    step (before each step, and after the last), the tension and the final centreline."""
    scene = knot.knot_scene(100)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mjcable.PhysicsWarning)  # (a tight knot strains the cable: measured below)
        sim = mjcable.Simulator(scene, model, self_collision=True, **settings)
        knot.knot_setup(sim, {})
        for _ in range(int(round(knot.DURATION / sim.dt))):
            knot.knot_drive(sim, sim.time, {})
            sim.step()
    x = sim.positions
    least = min(min(scene.runs["distance"]), metrics.self_distance(x, skip=scene.cable.overlapping_neighbours())[0])
    force = np.convolve(scene.runs["force"], np.ones(knot.FORCE_WINDOW) / knot.FORCE_WINDOW, mode="valid")
    return scene, x, least, force


@pytest.mark.parametrize("model", [pytest.param(m, marks=() if m == "xpbd" else pytest.mark.slow)
                                   for m in ("jakobsen", "pbd", "xpbd", "cosserat")])
def test_a_knot_pulled_taut_holds_without_pass_through(model):
    # the must-show "Knot": no two segments (beyond those overlapping at rest) ever closer than the rope's radius,
    # half the sum of their radii; the knot still there: the ends closer than the rest length less the knot's
    # length (2π · 2r, knot.knot_length) and the overhand knot's determinant, 3, at the end
    scene, x, least, force = _pull_taut(model)
    cable = scene.cable
    assert force.max() >= knot.TENSION  # it was pulled taut
    assert least >= cable.radius
    assert np.linalg.norm(x[-1] - x[0]) <= cable.length - knot.knot_length(cable)
    assert knots.knot_determinant(x) == 3


@pytest.mark.slow
@pytest.mark.xfail(strict=True, raises=mjcable.SimulationDivergedError,
                   reason="joints and composite at their default single substep tear a gripper pin of the knotted "
                          "rope within 0.2 s, with or without self-collision (docs/measurements.md)")
@pytest.mark.parametrize("model", ["joints", pytest.param("composite", marks=pytest.mark.composite)])
def test_joints_and_composite_tear_the_knotted_ropes_gripper_pin_at_one_substep(model):
    _pull_taut(model)


def test_a_knot_undone_or_passed_through_is_classified_tunneled():
    scene = knot.knot_scene(100)
    scene.runs.update(distance=[3 * scene.cable.radius], force=[])
    x = np.array(scene.cable.particles)
    assert knot.knot_verdict(scene, x) is None  # the loose start
    straight = x[0] + np.linspace(0.0, 1.0, len(x))[:, None] * (x[-1] - x[0])
    assert "undone" in knot.knot_verdict(scene, straight)[1]
    scene.runs["distance"].append(0.5 * scene.cable.radius)
    assert "pass-through" in knot.knot_verdict(scene, x)[1]


@pytest.mark.slow
@pytest.mark.parametrize("model", ["pbd", "xpbd"])
def test_a_knot_pulled_taut_at_16_substeps_holds_without_pass_through(model):
    # finer substeps: the strands slide farther round each other between two queries (within 0.57 r of each other,
    # and xpbd diverged, while the self contacts kept the query's points for the whole step)
    scene, x, least, force = _pull_taut(model, substeps=16)
    assert force.max() >= knot.TENSION
    assert least >= scene.cable.radius
    assert knots.knot_determinant(x) == 3
