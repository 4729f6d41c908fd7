"""The references themselves, against closed forms, limits, perturbation theory and independent solvers."""

import math

import numpy as np
import pytest
from numpy.polynomial import Polynomial
from scipy import integrate, optimize, special

from mjcable import reference


# ------------------------------------------------------------------------------------------------ catenary

def test_catenary_sag_known_value():
    # L = 1 m over a span of 0.8 m: sag 0.2654 m (the value).
    assert reference.catenary_sag(1.0, 0.8) == pytest.approx(0.2654, abs=5e-5)
    c = reference.catenary([-0.4, 0.0, 1.0], [0.4, 0.0, 1.0], 1.0)
    assert c.sag == pytest.approx(0.2654, abs=5e-5)
    # The defining relation L = 2 a sinh(S / 2a) holds for the parameter found.
    assert 2 * c.a * math.sinh(0.8 / (2 * c.a)) == pytest.approx(1.0, rel=1e-12)
    assert c.lowest == pytest.approx([0.0, 0.0, 1.0 - c.sag], abs=1e-12)


@pytest.mark.parametrize("end", [[0.8, 0.0, 0.3], [0.3, 0.5, -0.2], [0.6, 0.0, 0.0]])
def test_catenary_passes_through_ends_with_its_length(end):
    start = np.array([0.1, -0.2, 1.0])
    end = start + np.array(end)
    length = 1.3 * np.linalg.norm(end - start)
    c = reference.catenary(start, end, length)
    p = c.points(20001)
    assert p[0] == pytest.approx(start, abs=1e-10)
    assert p[-1] == pytest.approx(end, abs=1e-9)
    assert np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)) == pytest.approx(length, rel=1e-7)
    # A hanging chain's lowest point lies below both ends (or at the lower one).
    assert p[:, 2].min() <= min(start[2], end[2]) + 1e-12
    # The curve is a catenary: z'' = (1 / a) sqrt(1 + z'^2) in the horizontal coordinate u.
    u = np.linspace(0.05, 0.95, 7) * c.span
    h = 1e-4
    z = lambda u: c._height(u)  # noqa: E731
    d1 = (z(u + h) - z(u - h)) / (2 * h)
    d2 = (z(u + h) - 2 * z(u) + z(u - h)) / h**2
    assert d2 == pytest.approx(np.sqrt(1 + d1**2) / c.a, rel=1e-5)


def test_catenary_rejects_bad_input():
    with pytest.raises(ValueError, match="length"):
        reference.catenary([0, 0, 0], [1, 0, 0], 0.9)
    with pytest.raises(ValueError, match="vertical line"):
        reference.catenary([0, 0, 0], [0, 0, -0.5], 1.0)
    with pytest.raises(ValueError, match="span"):
        reference.catenary_sag(1.0, -0.8)


def test_discrete_catenary_converges_to_the_catenary():
    start, end = [-0.4, 0.0, 1.0], [0.4, 0.0, 1.0]
    c = reference.catenary(start, end, 1.0)
    gaps = []
    for n in (10, 20, 40, 80):
        x = reference.discrete_catenary(start, end, 1.0, n)
        assert np.linalg.norm(np.diff(x, axis=0), axis=1) == pytest.approx(1.0 / n, rel=1e-12)
        assert x[-1] == pytest.approx(end, abs=1e-10)
        gaps.append(reference.distance_to_curve(x, c).max())
    # Second-order convergence: halving the links quarters the gap.
    ratios = np.array(gaps[:-1]) / np.array(gaps[1:])
    assert np.all(ratios > 3.5)
    assert gaps[-1] < 1e-4


def test_distance_to_curve_on_a_straight_polyline():
    line = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    x = np.array([[0.5, 0.3, 0.4], [-1.0, 0.0, 0.0], [0.2, 0.0, 0.0]])
    assert reference.distance_to_curve(x, line) == pytest.approx([0.5, 1.0, 0.0])


# ------------------------------------------------------------------------------------------------ hanging chain

def test_bessel_root_and_chain_frequency():
    assert reference.BESSEL_Z1 == pytest.approx(2.404825557695773, abs=1e-12)
    assert special.j0(reference.BESSEL_Z1) == pytest.approx(0.0, abs=1e-14)
    # ω₁ = (z₁ / 2) √(g / L); for L = 1 m the period is 1.668 s.
    assert reference.chain_frequency(1.0) == pytest.approx(1.2024128 * math.sqrt(9.81), rel=1e-7)
    assert 2 * math.pi / reference.chain_frequency(1.0) == pytest.approx(1.668, abs=1e-3)
    assert reference.chain_frequency(4.0) == pytest.approx(reference.chain_frequency(1.0) / 2)


def test_mode_shape_is_pinned_at_top_and_unit_at_free_end():
    assert reference.chain_mode_shape(0.0, 1.0) == pytest.approx(0.0, abs=1e-14)
    assert reference.chain_mode_shape(1.0, 1.0) == pytest.approx(1.0)


def test_discrete_chain_converges_to_bessel_modes():
    zeros = special.jn_zeros(0, 3)
    exact = 0.5 * zeros * math.sqrt(9.81)
    errors = []
    for n in (25, 50, 100, 200):
        m = np.full(n + 1, 1.0 / n)
        m[[0, -1]] *= 0.5
        w = reference.discrete_chain_frequencies(m, 1.0)
        errors.append(abs(w[0] / exact[0] - 1))
        assert w[:3] == pytest.approx(exact, rel=0.05)
    assert errors[-1] < 2e-5
    assert all(a > b for a, b in zip(errors, errors[1:]))


def test_single_pendulum_limit():
    # One link with all the mass at its end is a simple pendulum: ω = √(g / l).
    w = reference.discrete_chain_frequencies([1e-9, 1.0], 0.7)
    assert w[0] == pytest.approx(math.sqrt(9.81 / 0.7), rel=1e-6)


# ------------------------------------------------------------------------------------------------ cantilever

@pytest.mark.parametrize("beta", [1e-3, 1e-2, 0.1])
def test_cantilever_tends_to_beam_theory(beta):
    shape = reference.cantilever(1.0, beta, 1.0)
    assert shape.tip_deflection == pytest.approx(reference.beam_tip_deflection(1.0, beta, 1.0), rel=2e-3 * beta + 1e-7)


def test_cantilever_matches_third_order_perturbation_theory():
    """δ / L = β/8 − c₃ β³ + O(β⁵), c₃ from the perturbation equations solved here with exact polynomials:
    θ = β θ₁ + β³ θ₃, θ₁'' = 1 − σ, θ₃'' = −(1 − σ) θ₁² / 2, θ(0) = θ'(1) = 0, z = ∫ sin θ."""
    s = Polynomial([0.0, 1.0])
    theta1 = ((1 - s) ** 3 - 1) / 6
    f = (-(1 - s) * theta1**2 / 2).integ()
    theta3 = (f - f(1)).integ()
    theta3 = theta3 - theta3(0)
    z1 = theta1.integ()
    z3 = (theta3 - theta1**3 / 6).integ()
    c1, c3 = -(z1(1) - z1(0)), -(z3(1) - z3(0))
    assert c1 == pytest.approx(1 / 8)
    for beta in (0.25, 0.5):
        shape = reference.cantilever(1.0, beta, 1.0)
        series = c1 * beta + c3 * beta**3
        assert shape.tip_deflection == pytest.approx(series, abs=0.02 * beta**5)
        assert abs(shape.tip_deflection - c1 * beta) > 10 * abs(shape.tip_deflection - series)


def test_cantilever_agrees_with_independent_shooting():
    beta, length, ei = 3.0, 0.8, 0.5
    q = beta * ei / length**3
    shape = reference.cantilever(length, q, ei)

    def shoot(kappa0):
        def rhs(s, y):
            return [y[1], q / ei * (length - s) * math.cos(y[0]), math.cos(y[0]), math.sin(y[0])]
        return integrate.solve_ivp(rhs, (0, length), [0.0, kappa0, 0.0, 0.0], rtol=1e-11, atol=1e-12)

    kappa0 = optimize.brentq(lambda k: shoot(k).y[1, -1], -10 * beta / length, 0.0, xtol=1e-13)
    tip = shoot(kappa0).y[:, -1]
    assert shape.tip_deflection == pytest.approx(-tip[3], rel=1e-5)
    assert shape.x[-1] == pytest.approx(tip[2], rel=1e-5)


def test_cantilever_is_inextensible_and_hangs_down_under_heavy_load():
    shape = reference.cantilever(1.0, 1000.0, 1.0)
    assert np.sum(np.hypot(np.diff(shape.x), np.diff(shape.z))) == pytest.approx(1.0, rel=1e-4)
    # Very heavy: the rod hangs nearly straight down, δ → L, and it stays monotonic in the load.
    assert 0.97 < shape.tip_deflection < 1.0
    tips = [reference.cantilever(1.0, b, 1.0).tip_deflection for b in (1.0, 10.0, 100.0, 1000.0)]
    assert all(a < b for a, b in zip(tips, tips[1:]))


# ------------------------------------------------------------------------------------------------ others

def test_free_fall():
    t = np.array([0.0, 0.5, 1.0])
    assert reference.free_fall(t, 2.0, 1.0) == pytest.approx([2.0, 2.0 + 0.5 - 9.81 / 8, 3.0 - 9.81 / 2])


def test_table_rest_and_drape_curve():
    start = np.array([[0.0, 0.0, 0.85], [0.1, 0.05, 0.85]])
    rest = reference.table_rest(start, 0.75, 0.005)
    assert rest[:, :2] == pytest.approx(start[:, :2])
    assert rest[:, 2] == pytest.approx(0.755)
    with pytest.raises(ValueError, match="one height"):
        reference.table_rest(start + [[0, 0, 0], [0, 0, 0.01]], 0.75, 0.005)
    center = np.array([0.05, 0.0, 0.8])
    r = 0.035
    on = np.array([center + [0, 0, r], center + [-r, 0, -0.3], center + [r, 0, -0.1],
                   center + r * np.array([math.cos(1.0), 0.0, math.sin(1.0)])])
    assert reference.drape_rest_distance(on, center, 0.03, 0.005) == pytest.approx(0.0, abs=1e-6)
    off = np.array([center + [0.0, 0.0, r + 0.01], center + [-r - 0.02, 0.0, -0.3]])
    assert reference.drape_rest_distance(off, center, 0.03, 0.005) == pytest.approx([0.01, 0.02], abs=1e-6)


def test_converged_reports_the_halving_change():
    def run(dt):
        return np.array([[dt, 0.0, 0.0], [1.0, 0.0, 0.0]])

    conv = reference.converged(run, 0.01)
    assert conv.change == pytest.approx(math.sqrt(0.005**2 / 2))
    assert conv.positions[0, 0] == pytest.approx(0.005)
