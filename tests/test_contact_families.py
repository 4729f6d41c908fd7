"""The contact families of the benchmark (issue 9): the heavy-rope capstan law, the scenes of the capstan, incline
and thin-plate runs, the slip-factor bisection, and physics checks that the harness measures what it claims.

No timing asserts."""

import math

import numpy as np
import pytest
from scipy import integrate

import mjcable
from mjcable import metrics, reference
from mjcable.bench import accuracy, case, contact, scenarios, stress
from mjcable.bench.case import Case
from mjcable.bench.runner import run_case
from mjcable.scene import Box, CableSpec, Scene

G = 9.81


# ------------------------------------------------------------------------------------------- the capstan law


def _long_leg_from_ode(short: float, mu: float, rc: float) -> float:
    """The long leg at the point of slipping from the rope's equilibrium on the arc, integrated numerically:
    dT/dφ = μ (T + w R_c cos φ) − w R_c sin φ from T(−π/2) = w L_short (w = 1 N/m), L_long = T(π/2)."""
    sol = integrate.solve_ivp(lambda phi, t: mu * (t + rc * np.cos(phi)) - rc * np.sin(phi),
                              (-math.pi / 2, math.pi / 2), [short], rtol=1e-12, atol=1e-14)
    return float(sol.y[0, -1])


@pytest.mark.parametrize("mu, rc, short", [(0.2, 0.035, 0.3), (0.5, 0.035, 0.3), (0.3, 0.1, 0.05), (1.0, 0.02, 1.0)])
def test_heavy_capstan_law_is_the_arc_equilibrium(mu, rc, short):
    long = _long_leg_from_ode(short, mu, rc)
    assert reference.heavy_capstan_long_leg(short, mu, rc) == pytest.approx(long, rel=1e-9)
    assert reference.heavy_capstan_ratio(long, short, mu, rc) == pytest.approx(math.exp(mu * math.pi), rel=1e-9)
    # the weightless rope's law is the limit of a thin peg, and the heavy rope holds more than it
    assert long > math.exp(mu * math.pi) * short
    assert reference.heavy_capstan_beta(mu, 1e-9) < 1e-8
    assert reference.capstan_ratio(mu, math.pi / 2) ** 2 == pytest.approx(reference.capstan_ratio(mu))


def test_capstan_and_incline_references_check_their_arguments():
    for call in (lambda: reference.capstan_ratio(-0.1), lambda: reference.heavy_capstan_beta(0.3, 0.0),
                 lambda: reference.incline_acceleration(0.3, math.pi / 2)):
        with pytest.raises(ValueError):
            call()
    # Coulomb on an incline: 0 while tan θ <= μ
    assert reference.incline_acceleration(0.5, math.atan(0.49)) == 0.0
    assert reference.incline_acceleration(0.0, math.radians(30)) == pytest.approx(G / 2)


# ------------------------------------------------------------------------------------------- capstan scenes


def _segment_distances(x: np.ndarray, axis_xz) -> np.ndarray:
    """Distance in the xz plane from the peg's axis to each segment (chord) of the rope."""
    p, q = x[:-1][:, [0, 2]], x[1:][:, [0, 2]]
    c = np.asarray(axis_xz)
    d = q - p
    t = np.clip(np.sum((c - p) * d, axis=1) / np.sum(d * d, axis=1), 0.0, 1.0)
    return np.linalg.norm(p + t[:, None] * d - c, axis=1)


def _legs(x: np.ndarray, height: float) -> tuple:
    """Arc lengths from each end of the rope to where it first rises through the peg axis's height."""
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(x, axis=0), axis=1))])
    above = np.nonzero(x[:, 2] >= height)[0]
    a, b = above[0], above[-1]
    left = s[a - 1] + (s[a] - s[a - 1]) * (height - x[a - 1, 2]) / (x[a, 2] - x[a - 1, 2])
    right = s[b] + (s[b + 1] - s[b]) * (x[b, 2] - height) / (x[b, 2] - x[b + 1, 2])
    return left, s[-1] - right


@pytest.mark.parametrize("factor, mu, per_metre", [(0.3, 0.2, 50), (0.85, 0.5, 50), (1.15, 0.2, 20),
                                                   (2.0, 0.5, 100)])
def test_capstan_scene_starts_clear_of_the_peg_with_the_intended_legs(factor, mu, per_metre):
    scene = contact.capstan_scene(factor, mu=mu, segments_per_metre=per_metre)
    x = scene.cable.particles
    peg = scene.obstacles[0]
    rc = peg.radius + scene.cable.radius
    assert scene.contact_radius == pytest.approx(rc)
    # every chord's surface starts clear of the peg, by about the start clearance
    gap = _segment_distances(x, (peg.pos[0], peg.pos[2])) - rc
    assert gap.min() > 0.5 * contact.START_CLEARANCE
    # the design: the law's ratio times factor, and the rope's length is the two legs and the wrapped half circle
    assert scene.ratio == pytest.approx(factor * math.exp(mu * math.pi), rel=1e-9)
    l0 = scene.cable.segment_length
    within = 2e-4 + l0**2 / (80 * rc)  # where exactly the equal chords meet the arc
    assert scene.cable.length == pytest.approx(scene.short + scene.long + math.pi * rc, abs=within)
    # measured on the start shape: the straight legs hang vertically at the start arc's radius and, with half of
    # the arc's excess over π R_c each, are the design's legs
    left, right = _legs(x, peg.pos[2])
    arc = scene.cable.length - left - right
    excess = 0.5 * (arc - math.pi * rc)
    assert left + excess == pytest.approx(scene.short, abs=within)
    assert right + excess == pytest.approx(scene.long, abs=within)
    legs = x[x[:, 2] < peg.pos[2] - 0.05]
    assert np.ptp(np.abs(legs[:, 0])) < 1e-6  # vertical, both at one radius
    assert abs(scene.cable.segment_length * per_metre - 1.0) < 0.05


def test_flexrod_holds_below_the_capstan_law_and_slides_above():
    """The harness's physics check: MuJoCo's flexrod obeys the heavy-rope capstan law at μ = 0.2."""
    hold = contact.capstan_end_speed("flexrod", 0.002, {}, factor=0.85, mu=0.2)
    slide = contact.capstan_end_speed("flexrod", 0.002, {}, factor=1.15, mu=0.2)
    assert hold < contact.HOLD_SPEED
    assert slide > contact.SLIDE_SPEED
    # without friction nothing holds
    assert contact.capstan_end_speed("flexrod", 0.002, {}, factor=0.85, mu=0.0) > contact.SLIDE_SPEED


def _search(threshold, **kw):
    calls = []

    def probe(f):
        calls.append(f)
        return 1.0 if f > threshold else 1e-3

    return contact.capstan_slip_factor("none", 0.002, {}, mu=0.3, probe=probe, **kw), calls


@pytest.mark.parametrize("threshold", [0.31, 0.62, 0.93, 1.07, 1.6, 1.99])
def test_slip_bisection_brackets_the_threshold_to_two_percent(threshold):
    found, calls = _search(threshold)
    assert found.low <= threshold < found.high
    assert found.high / found.low - 1.0 <= 0.02 + 1e-12
    assert found.factor == pytest.approx(threshold, rel=0.02)
    assert len(calls) == len(found.probes) <= 3 + 6 and found.bracketed


def test_slip_bisection_reports_unbracketed_ends_and_reuses_the_first_probe():
    slips, _ = _search(0.1)
    assert (slips.low, slips.high, slips.factor) == (0.0, contact.FACTOR_RANGE[0], contact.FACTOR_RANGE[0])
    holds, _ = _search(5.0)
    assert (holds.low, holds.high, holds.factor) == (contact.FACTOR_RANGE[1], math.inf, contact.FACTOR_RANGE[1])
    assert not slips.bracketed and not holds.bracketed
    nan, _ = contact.capstan_slip_factor("none", 0.002, {}, mu=0.3, probe=lambda f: math.nan), None
    assert nan.high == contact.FACTOR_RANGE[0]  # a diverged probe slips
    reused, calls = _search(0.93, first_speed=1e-3, steps=2)
    assert contact.FIRST_PROBES[0] not in calls and reused.probes[0] == (contact.FIRST_PROBES[0], 1e-3)
    assert len(calls) == 1 + 2


def test_capstan_scenario_measures_the_slip_ratio_through_the_runner():
    row = run_case(Case("capstan_mu0.2", "flexrod", 0.002, params=(("steps", 3),), quick=True))
    assert row["outcome"] == "stable", row["reason"]
    # flexrod's slip ratio lies within 10 % of the law (its hold at 0.85 and slide at 1.15 are tested above)
    assert 0.0 <= row["error"] < 0.1


# ------------------------------------------------------------------------------------------------- incline


@pytest.mark.parametrize("across", [False, True])
def test_incline_scene_lies_on_the_slope(across):
    scene = contact.incline_scene(0.4, 30.0, across=across)
    box = scene.obstacles[0]
    d, normals = mjcable.geometry.signed_distances(scene.cable.particles, box)
    assert np.allclose(d, scene.cable.radius, atol=1e-9)
    np.testing.assert_allclose(normals, np.tile([0.5, 0.0, math.sqrt(3) / 2], (len(d), 1)), atol=1e-9)
    direction = scene.cable.particles[-1] - scene.cable.particles[0]
    downhill = np.array([math.sqrt(3) / 2, 0.0, -0.5])
    assert abs(direction @ downhill) / np.linalg.norm(direction) == pytest.approx(0.0 if across else 1.0, abs=1e-9)
    # travel down the slope from the centre of mass's x
    assert contact.incline_travel(scene, [0.2, 0.2 + math.sqrt(3) / 2]) == pytest.approx([0.0, 1.0])


def test_fit_acceleration_recovers_uniform_acceleration():
    t = np.linspace(0.0, 1.0, 201)
    assert contact.fit_acceleration(t, 0.003 + 0.5 * 1.7 * t**2) == pytest.approx(1.7, rel=1e-9)
    assert math.isnan(contact.fit_acceleration(t[:2], t[:2]))


@pytest.mark.parametrize("name, limit", [("incline_stick", 0.01), ("incline_slide", 0.02)])
def test_incline_threshold_and_acceleration_for_xpbd(name, limit):
    """Coulomb on a flat slope: sticks just below the friction angle, slides at g (sin θ − μ cos θ) above it."""
    row = run_case(Case(name, "xpbd", 0.002))
    assert row["outcome"] == "stable", row["reason"]
    assert row["error"] < limit


_INCLINE_CASES = [(m, ()) for m in mjcable.catalog.names()] + [("xpbd", (("substeps", 1),)),
                                                                 ("xpbd", (("substeps", 16),)),
                                                                 ("pbd", (("substeps", 1),)),
                                                                 ("pbd", (("substeps", 16),))]


@pytest.mark.slow
@pytest.mark.parametrize("name, limit", [("incline_stick", 0.01), ("incline_slide", 0.02)])
@pytest.mark.parametrize("model, settings", _INCLINE_CASES, ids=lambda v: str(v) if not isinstance(v, tuple) else
                         ",".join(f"{k}={x}" for k, x in v) or "defaults")
def test_incline_is_coulomb_for_every_model(model, settings, name, limit):
    """Issue 9's incline must-show: every model, down the slope, sticks just inside the friction cone and slides
    at g (sin θ − μ cos θ) within 2 %; the particle solvers also at 1 and 16 substeps."""
    row = run_case(Case(name, model, 0.002, settings=settings))
    assert row["outcome"] == "stable", row["reason"]
    assert row["error"] < limit, f"{model} {settings}: {name} error {row['error']:.4g}"


# ------------------------------------------------------------------------------------------------ thin plate


def test_plate_scene_drops_onto_the_plate_at_the_given_speed():
    scene = contact.plate_scene(10.0)
    plate = scene.obstacles[0]
    assert 2 * plate.size[2] == pytest.approx(contact.PLATE_THICKNESS)
    gap = scene.cable.particles[:, 2].min() - scene.cable.radius - plate.size[2]
    assert math.sqrt(2 * G * (gap - contact.PLATE_CLEARANCE)) == pytest.approx(10.0, rel=1e-6)
    assert reference.free_fall(contact.plate_fall_time(10.0), gap) == pytest.approx(0.0, abs=1e-9)


def test_tunnelling_through_a_thin_plate_is_detected():
    plate = Box(size=(0.5, 0.5, 0.002))
    cable = CableSpec([[-0.2, 0.0, 0.1], [0.2, 0.0, 0.1]], 4, 0.005, 0.1)
    scene = Scene(cable, obstacles=(plate,))
    x = np.array(cable.particles)
    resting = x.copy()
    resting[:, 2] = 0.002 + 0.005
    through = x.copy()
    through[:, 2] = -0.3  # fell through, still under the plate
    beside = through + [0.0, 0.8, 0.0]  # fell past the plate's edge
    assert not metrics.tunneled(resting, scene).any()
    assert metrics.tunneled(through, scene).all() and metrics.crossed(through, scene).all()
    assert not metrics.tunneled(beside, scene).any()


def test_every_model_label_runs_in_the_contact_families():
    labels = set(case.MODEL_LABELS)  # every catalogue model and variant
    quick = accuracy.accuracy_cases(quick=True)
    full = accuracy.accuracy_cases(quick=False, scenario_names=["capstan_mu0.2"])
    for name in ("capstan_mu0.5", "incline_stick", "incline_slide", "incline_stick_across", "incline_slide_across"):
        assert {c.model for c in quick if c.scenario == name} == labels
    assert all(dict(c.params)["steps"] == scenarios.CAPSTAN_QUICK_STEPS for c in quick if "capstan" in c.scenario)
    assert "capstan_mu0.2" not in {c.scenario for c in quick}
    assert {c.model for c in full} == labels and all(c.params == () for c in full)
    plate = [c for c in stress.stress_cases(quick=False) if c.scenario == "plate"]
    assert {c.model for c in plate} == labels
    assert max(c.dt for c in plate) == pytest.approx(0.01)
    assert max(dict(c.params)["speed"] for c in plate) == pytest.approx(10.0)
