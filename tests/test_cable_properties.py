"""Cables of different radius, segment length, mass per length, damping, E·A and E·I in one particle-solver state
(issue 22): each cable's contacts, stretch, bending and statics are its own, against physics and independent
references."""

import numpy as np
import pytest
from scipy import optimize

import mjcable
from mjcable import geometry, reference

G = 9.81
PARTICLE = ("jakobsen", "pbd", "xpbd")
SETTLED = {"jakobsen": {"iterations": 50}, "pbd": {"iterations": 50}, "xpbd": {}}  # converged statics
CONTACT_TOLERANCE = 1e-4  # m: a resting contact's distance from the sum of the radii (penetration and round-off)


def _quick_first(models):
    """``models`` as parameters, all but the first slow."""
    return [m if k == 0 else pytest.param(m, marks=pytest.mark.slow) for k, m in enumerate(models)]


@pytest.mark.parametrize("model", _quick_first(("xpbd", "pbd", "jakobsen")))
def test_a_thick_cable_rests_on_a_thin_one_at_the_sum_of_their_radii(model):
    """A thick cable (r = 12 mm) draped across a thin one (r = 3 mm) held at every particle: their centrelines rest
    r₁ + r₂ apart (not 2 r of either)."""
    r_thin, r_thick = 0.003, 0.012
    thin = mjcable.CableSpec([[-0.3, 0.0, 1.0], [0.3, 0.0, 1.0]], 20, r_thin, 0.02, friction=0.5)
    top = 1.0 + r_thin + r_thick + 0.002
    thick = mjcable.CableSpec([[0.0, -0.3, 0.95], [0.0, 0.0, top], [0.0, 0.3, 0.95]], 24, r_thick, 0.1,
                              damping=20.0, friction=0.5)
    pins = tuple(mjcable.Pin(k) for k in range(21)) + (mjcable.Pin(0, cable=1), mjcable.Pin(-1, cable=1))
    scene = mjcable.Scene((thin, thick), pins)
    sim = mjcable.Simulator(scene, model)
    sim.step(1.0)
    a, b = (sim.positions[part] for part in scene.cable_slices)
    closest = float(geometry.segment_distances(b, a).min())
    assert closest == pytest.approx(r_thin + r_thick, abs=CONTACT_TOLERANCE)
    assert b[:, 2].max() < top - 0.001  # it came down onto the thin one (and rests there)


@pytest.mark.slow
@pytest.mark.parametrize("model", PARTICLE)
def test_cables_of_different_radius_rest_on_a_floor_at_their_own_radius(model):
    """Two cables side by side dropped onto a floor: each one's centreline rests at its own radius."""
    radii = (0.004, 0.015)
    cables = tuple(mjcable.CableSpec([[-0.3, y, r + 0.01], [0.3, y, r + 0.01]], 20, r, 0.05, damping=10.0)
                   for y, r in zip((0.0, 0.1), radii))
    scene = mjcable.Scene(cables, obstacles=(mjcable.Floor(),))
    sim = mjcable.Simulator(scene, model)
    sim.step(1.0)
    for r, part in zip(radii, scene.cable_slices):
        np.testing.assert_allclose(sim.positions[part][:, 2], r, atol=CONTACT_TOLERANCE)


def _leg(start, end, length, n, radius, mass, **fields):
    """A cable of ``length`` metres and ``n`` segments from ``start`` to ``end`` through a lowered midpoint, the sag
    found so that its chords add up to ``length`` (so that the reference's legs have the cable's length)."""
    p0, p1 = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    mid = 0.5 * (p0 + p1)

    def make(depth):
        return mjcable.CableSpec([p0, mid - [0.0, 0.0, depth], p1], n, radius, mass, **fields)

    depth = optimize.brentq(lambda d: make(d).segment_length * n - length, 1e-4, length, xtol=1e-14)
    return make(depth)


@pytest.mark.slow
@pytest.mark.parametrize("model", PARTICLE)
def test_a_harness_of_different_legs_settles_on_the_reference(model):
    """A Y-harness of a thick heavy trunk and two thin light legs (radii 8, 3 and 5 mm, 0.1, 0.02 and 0.05 kg/m,
    30, 24 and 40 segments, different damping; for ``xpbd`` E·A of 5e4, 2e4 and 1e5 N), their free ends pinned at
    different heights: the particles within 1 mm of the discrete three-leg reference of those masses and segments
    (:func:`mjcable.reference_harness.y_harness`), the pins carrying the harness' weight within 1 %."""
    from mjcable.reference_harness import y_harness

    junction = [0.0, 0.05, 0.6]
    ends = [[-0.4, 0.0, 1.0], [0.4, 0.0, 0.9], [0.0, 0.45, 0.8]]
    shape = dict(n=(30, 24, 40), radius=(0.008, 0.003, 0.005), mass=(0.06, 0.012, 0.03), damping=(20.0, 10.0, 30.0),
                 stretch_stiffness=(5e4, 2e4, 1e5))
    cables = []
    for k, end in enumerate(ends):
        extra = dict(stretch_stiffness=shape["stretch_stiffness"][k]) if model == "xpbd" else {}
        cables.append(_leg(end, junction, 0.6, shape["n"][k], shape["radius"][k], shape["mass"][k],
                           damping=shape["damping"][k], **extra))
    scene = mjcable.Scene(tuple(cables), tuple(mjcable.Pin(0, cable=k) for k in range(3)),
                          junctions=(mjcable.Junction((0, -1), (1, -1)), mjcable.Junction((0, -1), (2, -1))))
    sim = mjcable.Simulator(scene, model, **SETTLED[model])
    sim.step(3.0)
    ref = y_harness(ends, [0.6] * 3, list(shape["mass"]), list(shape["n"]))
    x = sim.positions
    for part, leg in zip(scene.cable_slices, ref.legs):  # a leg runs from the junction to its pin
        assert np.max(np.linalg.norm(x[part][::-1] - leg, axis=1)) < 1e-3
    weight = sum(shape["mass"]) * G
    np.testing.assert_allclose(sim.pin_forces.sum(axis=0), [0.0, 0.0, weight], atol=0.01 * weight)


@pytest.mark.slow
def test_a_stiff_and_a_soft_cable_under_one_load_stretch_by_their_own_tension_over_ea():
    """Two hanging cables of one mass and length, E·A = 2000 N and 200 N, side by side in one ``xpbd`` state (the
    direct order: the stated stiffness): each segment stretches by its tension over its own E·A, T l₀ / E·A, T the
    weight of the particles below it."""
    stiffness = (2000.0, 200.0)
    n, mass = 20, 0.5
    cables = tuple(mjcable.CableSpec([[y, 0.0, 1.0], [y, 0.0, 0.0]], n, 0.005, mass, stretch_stiffness=ea,
                                     damping=20.0) for y, ea in zip((0.0, 0.2), stiffness))
    scene = mjcable.Scene(cables, (mjcable.Pin(0), mjcable.Pin(0, cable=1)))
    sim = mjcable.Simulator(scene, "xpbd", order="direct")
    sim.step(3.0)
    for cab, ea, part in zip(cables, stiffness, scene.cable_slices):
        below = np.cumsum(cab.particle_masses[::-1])[::-1][1:] * G  # (n,) N: the weight below each segment
        stretch = np.linalg.norm(np.diff(sim.positions[part], axis=0), axis=1) - cab.segment_length
        np.testing.assert_allclose(stretch, below * cab.segment_length / ea, rtol=1e-6)


#: two clamped cantilevers side by side: (length m, segments, radius m, mass kg, young Pa, y m); E·I 0.29 and 0.070
#: N·m², segments of 12.5 and 10 mm, 40 and 30 g/m
CANTILEVERS = ((0.5, 40, 0.005, 0.02, 6e8, 0.0), (0.4, 40, 0.004, 0.012, 3.5e8, 0.2))
LIMP = (0.3, 20, 0.003, 0.01, 0.0, 0.4)  # a limp cable (E = 0) clamped beside them: it hangs from its clamp


def _cantilevers(specs) -> mjcable.Scene:
    cables = tuple(mjcable.CableSpec([[0.0, y, 1.0], [length, y, 1.0]], n, r, m, young=e, damping=20.0)
                   for length, n, r, m, e, y in specs)
    return mjcable.Scene(cables, tuple(mjcable.Pin(0, clamp=True, cable=k) for k in range(len(cables))))


@pytest.mark.slow
def test_two_cantilevers_of_different_bending_stiffness_droop_as_the_heavy_elastica():
    """Two clamped cantilevers of different E·I, segment and weight in one ``xpbd`` state (the direct order: the
    stated stiffness), a limp cable clamped beside them: each tip droops as the heavy elastica of its own E·I and
    weight (:func:`mjcable.reference.cantilever`) within 0.5 % (40 segments of the continuous rod), and the limp
    cable hangs straight down from its first segment, which its (rigid) clamp holds level."""
    scene = _cantilevers(CANTILEVERS + (LIMP,))
    sim = mjcable.Simulator(scene, "xpbd", order="direct")
    sim.step(2.0)
    limp = sim.positions[scene.cable_slices[-1]]
    assert 1.0 - limp[-1, 2] == pytest.approx(LIMP[0] * (1.0 - 1.0 / LIMP[1]), rel=1e-3)
    for cab, (length, *_), part in zip(scene.cables, CANTILEVERS, scene.cable_slices):
        droop = 1.0 - sim.positions[part][-1, 2]
        expected = -reference.cantilever(length, cab.mass * G / length, cab.bending_stiffness).z[-1]
        assert droop == pytest.approx(expected, rel=0.005)


@pytest.mark.slow
@pytest.mark.parametrize("model, order", [("pbd", "gauss-seidel"), ("jakobsen", "gauss-seidel"),
                                          ("xpbd", "gauss-seidel"), ("pbd", "jacobi"), ("xpbd", "jacobi")])
def test_cantilevers_of_different_material_side_by_side_bend_as_each_alone(model, order):
    """The two cantilevers and a limp cable clamped beside them in one state move as each does alone (to 1e-12 m
    after 1 s): each cable's bend factor (``pbd`` and ``jakobsen`` derive it from its E·I, segment and mass per
    segment), compliances, clamp and damping are its own, and the limp one has no bending rows. (The Gauss-Seidel
    sweeps of ``pbd`` and ``jakobsen`` leave a cantilever far softer than its E·I at any iteration count,
    ``docs/measurements.md``: the elastica is ``xpbd``'s test.)"""
    settings = dict(order=order, iterations=8)  # (one order for both: several cables would take pbd's direct)
    specs = CANTILEVERS + (LIMP,)
    together = mjcable.Simulator(_cantilevers(specs), model, **settings)
    together.step(1.0)
    for spec, part in zip(specs, together.scene.cable_slices):
        alone = mjcable.Simulator(_cantilevers((spec,)), model, **settings)
        alone.step(1.0)
        np.testing.assert_allclose(together.positions[part], alone.positions, rtol=0.0, atol=1e-12)
        assert np.max(np.abs(alone.positions - alone.scene.cable.particles)) > 1e-3  # (they bent)
