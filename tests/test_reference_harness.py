"""The harness reference against the single-cable references, symmetry, statics read from the positions alone, and
the discrete chain's convergence to the catenaries."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mjcable import reference
from mjcable.reference_harness import LEG_SAMPLES, Harness, harness_error, y_harness

G_VEC = np.array([0.0, 0.0, -9.81])
# An asymmetric Y-harness like the issue's: three 0.6 m legs, pins at different heights.
Y_PINS = np.array([[0.45, 0.0, 1.0], [-0.2, 0.4, 0.85], [-0.25, -0.35, 0.7]])
Y_LENGTHS = np.array([0.6, 0.6, 0.6])
Y_MASSES = np.array([0.03, 0.05, 0.04])


def _lumped(mass, n):
    """Particle masses as CableSpec.particle_masses lumps them (written out again here: m/n inside, m/2n at ends)."""
    return np.array([0.5] + [1.0] * (n - 1) + [0.5]) * mass / n


def _statics(harness, masses, gravity=G_VEC):
    """Link tensions (N) read from a discrete harness' positions alone: the least-squares solution of every free
    particle's balance (J, each leg's inner particles), its largest residual (N), and the pin forces (N) they give."""
    legs = harness.legs
    n = [len(leg) - 1 for leg in legs]
    cols = np.concatenate([[0], np.cumsum(n)])
    dirs = [np.diff(leg, axis=0) / np.linalg.norm(np.diff(leg, axis=0), axis=1)[:, None] for leg in legs]
    lumped = [_lumped(m, ni) for m, ni in zip(masses, n)]
    rows, rhs = [], []
    j_row = np.zeros((3, cols[-1]))
    for i, u in enumerate(dirs):
        j_row[:, cols[i]] = u[0]
    rows.append(j_row)
    rhs.append(-gravity * sum(lm[0] for lm in lumped))
    for i, u in enumerate(dirs):
        for j in range(1, n[i]):
            row = np.zeros((3, cols[-1]))
            row[:, cols[i] + j] = u[j]
            row[:, cols[i] + j - 1] = -u[j - 1]
            rows.append(row)
            rhs.append(-gravity * lumped[i][j])
    a, b = np.vstack(rows), np.concatenate(rhs)
    tension = np.linalg.lstsq(a, b, rcond=None)[0]
    per_leg = [tension[cols[i]:cols[i + 1]] for i in range(len(legs))]
    pin_forces = np.array([t[-1] * u[-1] - gravity * lm[-1] for t, u, lm in zip(per_leg, dirs, lumped)])
    return per_leg, float(np.abs(a @ tension - b).max()), pin_forces


# ------------------------------------------------------------------------------------------- two legs: one cable

def test_two_continuous_legs_are_one_catenary():
    p1, p2 = np.array([-0.5, 0.2, 1.0]), np.array([0.4, -0.1, 0.75])
    l1, l2 = 0.5, 0.8
    h = y_harness([p1, p2], [l1, l2], [0.05 * l1, 0.05 * l2])  # one cable: the same mass per metre
    c = reference.catenary(p1, p2, l1 + l2)
    s = np.linspace(0.0, 1.0, LEG_SAMPLES)
    assert h.junction == pytest.approx(c.at_arclength([l1])[0], abs=1e-6)
    assert np.abs(h.legs[0] - c.at_arclength(l1 * (1.0 - s))).max() < 1e-6  # J → P1 runs back along the cable
    assert np.abs(h.legs[1] - c.at_arclength(l1 + l2 * s)).max() < 1e-6
    # The pins hold the cable's ends with the catenary's horizontal tension H = w a, in opposite directions.
    horizontal = np.hypot(h.pin_forces[:, 0], h.pin_forces[:, 1])
    assert horizontal == pytest.approx([0.05 * 9.81 * c.a] * 2, rel=1e-6)
    assert h.tensions[0] == pytest.approx(h.tensions[1], rel=1e-9)  # no mass at J: one tension passes through


def test_two_discrete_legs_are_one_discrete_chain():
    p1, p2 = [-0.35, 0.0, 1.0], [0.45, 0.0, 1.0]
    # Equal links (0.05 m) and masses per segment, so that J is an ordinary particle of the 20-link chain.
    h = y_harness([p1, p2], [0.4, 0.6], [0.04, 0.06], [8, 12])
    chain = reference.discrete_catenary(p1, p2, 1.0, 20)
    assert np.abs(h.legs[0] - chain[8::-1]).max() < 1e-9
    assert np.abs(h.legs[1] - chain[8:]).max() < 1e-9
    assert h.junction == pytest.approx(chain[8], abs=1e-9)


# ------------------------------------------------------------------------------------------------- symmetry

@pytest.mark.parametrize("n_segments", [None, (16, 16, 16)])
def test_symmetric_harness_has_its_junction_on_the_axis(n_segments):
    axis = np.array([0.1, -0.2])
    phi = 0.3 + np.arange(3) * 2 * math.pi / 3
    pins = np.column_stack([axis[0] + 0.4 * np.cos(phi), axis[1] + 0.4 * np.sin(phi), np.full(3, 1.2)])
    h = y_harness(pins, [0.6] * 3, [0.05] * 3, n_segments)
    assert h.junction[:2] == pytest.approx(axis, abs=1e-9)
    assert h.junction[2] < 1.2
    assert h.tensions == pytest.approx([h.tensions[0]] * 3, rel=1e-9)
    # Each pin carries a third of the weight, and the legs are copies of one another turned by 120°.
    assert h.pin_forces[:, 2] == pytest.approx([0.05 * 9.81] * 3, rel=1e-9)
    turn = Rotation.from_euler("z", 2 * math.pi / 3).as_matrix()
    centre = np.array([axis[0], axis[1], 0.0])
    assert np.abs((h.legs[0] - centre) @ turn.T + centre - h.legs[1]).max() < 1e-9


def test_turning_the_scene_turns_the_harness():
    # Pins and gravity turned together: the rest state turns with them (the solver works in gravity's own frame).
    turn = Rotation.from_rotvec([0.4, -0.7, 0.2]).as_matrix()
    h = y_harness(Y_PINS, Y_LENGTHS, Y_MASSES, (12, 15, 10))
    turned = y_harness(Y_PINS @ turn.T, Y_LENGTHS, Y_MASSES, (12, 15, 10), gravity=turn @ G_VEC)
    assert turned.junction == pytest.approx(turn @ h.junction, abs=1e-9)
    assert turned.pin_forces == pytest.approx(h.pin_forces @ turn.T, abs=1e-9)
    assert turned.tensions == pytest.approx(h.tensions, rel=1e-9)


# ---------------------------------------------------------------------------------------------- statics, lengths

@pytest.mark.parametrize("n_segments", [None, (20, 25, 15)])
def test_pin_forces_carry_the_harness_weight(n_segments):
    h = y_harness(Y_PINS, Y_LENGTHS, Y_MASSES, n_segments)
    weight = Y_MASSES.sum() * G_VEC
    assert np.abs(h.pin_forces.sum(axis=0) + weight).max() < 1e-9 * np.linalg.norm(weight)
    assert np.all(h.pin_forces[:, 2] > 0)  # every pin holds some of it up


@pytest.mark.parametrize("n_segments", [None, (20, 25, 15)])
def test_each_leg_has_its_length_and_ends_at_its_pin(n_segments):
    h = y_harness(Y_PINS, Y_LENGTHS, Y_MASSES, n_segments)
    for leg, pin, length in zip(h.legs, Y_PINS, Y_LENGTHS):
        links = np.linalg.norm(np.diff(leg, axis=0), axis=1)
        assert leg[0] == pytest.approx(h.junction, abs=1e-12)
        assert leg[-1] == pytest.approx(pin, abs=1e-9)
        if n_segments is None:
            assert links.sum() == pytest.approx(length, rel=1e-6)  # a fine polyline of the curve
        else:
            assert links == pytest.approx(length / (len(leg) - 1), rel=1e-9)


def test_continuous_legs_are_the_catenaries_and_their_tensions_balance_at_the_junction():
    h = y_harness(Y_PINS, Y_LENGTHS, Y_MASSES)
    force = np.zeros(3)
    for leg, pin, length, mass in zip(h.legs, Y_PINS, Y_LENGTHS, Y_MASSES):
        c = reference.catenary(h.junction, pin, length)  # an independent solve of each leg between J and its pin
        assert np.abs(leg - c.points(LEG_SAMPLES)).max() < 1e-6
        # The leg pulls J along its tangent there, with the horizontal tension w a.
        d = pin - h.junction
        e = np.array([d[0], d[1], 0.0]) / np.hypot(d[0], d[1])
        force += mass * 9.81 / length * c.a * (e + np.array([0.0, 0.0, math.sinh(-c.x0 / c.a)]))
    assert np.abs(force).max() < 1e-6 * Y_MASSES.sum() * 9.81


@pytest.mark.parametrize("n_segments", [(20, 25, 15), (6, 9, 4)])
def test_discrete_statics_read_from_the_positions(n_segments):
    h = y_harness(Y_PINS, Y_LENGTHS, Y_MASSES, n_segments)
    tension, residual, pin_forces = _statics(h, Y_MASSES)
    weight = Y_MASSES.sum() * 9.81
    assert residual < 1e-9 * weight  # some tensions balance every particle, J included, with its lumped weight
    assert np.all(np.concatenate(tension) > 0)  # a chain: every link pulls
    assert [t[0] for t in tension] == pytest.approx(h.tensions, rel=1e-8)
    assert pin_forces == pytest.approx(h.pin_forces, abs=1e-8 * weight)
    # Each leg hangs in the vertical plane through J and its pin.
    for leg, pin in zip(h.legs, Y_PINS):
        normal = np.cross(pin - h.junction, [0.0, 0.0, 1.0])
        assert np.abs((leg - h.junction) @ normal).max() < 1e-9


def test_a_coarse_leg_folding_back_to_the_junction_may_push():
    # A three-link leg whose pin hangs near J: the chain's rest state needs a link that pushes, which no walk along
    # pulling links reaches; the rigid-link solve still gives the balanced, stable rest state.
    pins = np.array([[0.4, 0.0, 1.0], [-0.2, 0.35, 1.1], [0.0, 0.0, 1.0]])
    masses = [0.05, 0.05, 0.05]
    h = y_harness(pins, [0.6, 0.6, 0.8], masses, (20, 20, 3))
    tension, residual, pin_forces = _statics(h, masses)
    assert residual < 1e-9 * 0.15 * 9.81
    assert min(t.min() for t in tension) < 0
    for leg, length in zip(h.legs, [0.6, 0.6, 0.8]):
        assert np.linalg.norm(np.diff(leg, axis=0), axis=1) == pytest.approx(length / (len(leg) - 1), rel=1e-9)
    assert pin_forces == pytest.approx(h.pin_forces, abs=1e-8)
    assert h.pin_forces.sum(axis=0) == pytest.approx([0.0, 0.0, 0.15 * 9.81], rel=1e-9, abs=1e-12)


def test_discrete_chains_converge_to_the_catenaries_at_second_order():
    smooth = y_harness(Y_PINS, Y_LENGTHS, Y_MASSES)
    gaps = []
    for n in (8, 16, 32, 64):
        chains = y_harness(Y_PINS, Y_LENGTHS, Y_MASSES, (n, n, n))
        gaps.append(max(harness_error(chains.legs, smooth), np.linalg.norm(chains.junction - smooth.junction)))
    ratios = np.array(gaps[:-1]) / np.array(gaps[1:])
    assert np.all(ratios > 3.5)  # halving the links quarters the gap
    assert gaps[-1] < 1e-4


# ----------------------------------------------------------------------------------------------- measuring

def test_harness_error_measures_particles_against_the_reference():
    h = y_harness(Y_PINS, Y_LENGTHS, Y_MASSES, (10, 12, 8))
    assert harness_error(h.legs, h) == 0.0
    moved = [leg.copy() for leg in h.legs]
    moved[1][5] += [0.0, 0.003, 0.0]
    assert harness_error(moved, h) == pytest.approx(0.003, rel=1e-12)
    smooth = y_harness(Y_PINS, Y_LENGTHS, Y_MASSES)
    on_curve = [leg[::100] for leg in smooth.legs]
    assert harness_error(on_curve, smooth) < 1e-12
    with pytest.raises(ValueError, match=r"positions_per_leg\[2\] must have shape \(9, 3\)"):
        harness_error(h.legs[:2] + (h.legs[2][:-1],), h)
    with pytest.raises(ValueError, match="sequence of 3"):
        harness_error(h.legs[:2], h)


# ------------------------------------------------------------------------------------------------ bad input

@pytest.mark.parametrize("kwargs, match", [
    (dict(pins=[[0, 0, 1]]), "at least 2"),
    (dict(pins=[[0, 0], [1, 0]]), "pins must be an"),
    (dict(lengths=[0.6, 0.6]), "lengths must be 3"),
    (dict(lengths=[0.6, -0.6, 0.6]), "lengths must be 3"),
    (dict(masses=[0.1, 0.0, 0.1]), "masses must be 3"),
    (dict(n_segments=[10, 10]), "n_segments must be None or 3"),
    (dict(n_segments=[10, 0, 10]), r"n_segments\[1\] must be an integer >= 1"),
    (dict(n_segments=[10, 2.5, 10]), r"n_segments\[1\]"),
    (dict(gravity=(0, 0, 0)), "gravity must be non-zero"),
    (dict(gravity=(0, 0)), "gravity must be 3"),
    (dict(lengths=[0.2, 0.2, 0.2]), "too short for the legs to meet"),
])
def test_rejects_bad_input(kwargs, match):
    args = dict(pins=Y_PINS, lengths=Y_LENGTHS, masses=Y_MASSES, n_segments=None, gravity=tuple(G_VEC))
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        y_harness(args.pop("pins"), args.pop("lengths"), args.pop("masses"), args.pop("n_segments"), **args)


def test_legs_that_just_cannot_meet_are_refused():
    # Two pins 1.2 m apart, legs of 0.6 m and 0.5999 m: they fall 0.1 mm short of meeting.
    with pytest.raises(ValueError, match=r"lengths \[0.6, 0.5999\] m are too short"):
        y_harness([[0, 0, 1], [1.2, 0, 1]], [0.6, 0.5999], [0.1, 0.1])
    assert isinstance(y_harness([[0, 0, 1], [1.2, 0, 1]], [0.6, 0.6001], [0.1, 0.1]), Harness)


def test_an_unstable_rest_state_is_refused():
    # A one-link leg standing on a pin below J is a strut; the balance found near the catenaries holds it upright,
    # which is unstable (it would fall over): the reference says so instead of returning it.
    pins = [[0.4, 0.0, 1.0], [-0.2, 0.35, 1.1], [0.02, 0.0, 0.3]]
    with pytest.raises(RuntimeError, match="unstable rest state"):
        y_harness(pins, [0.6, 0.6, 0.5], [0.05] * 3, (20, 20, 1))
