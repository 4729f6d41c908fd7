"""Checks before the first step (issue 20, item 2; :mod:`mjcable.prechecks`): what a model would get wrong about a
scene warns with a :class:`mjcable.PhysicsWarning` when the Simulator is made, and each warning is checked against
what the model then does (a property it says it ignores changes nothing; a stretch or a sag it predicts is the one
measured) and against the physics (catenary tension, beam theory)."""

import dataclasses
import math
import warnings

import numpy as np
import pytest
from scipy import optimize

import mjcable
from catalog_params import model_params
from mjcable import CableSpec, PhysicsWarning, Pin, Scene, prechecks, reference
from mjcable.mjcf import springs
from mjcable.scenes import HANG_LENGTH, HANG_SPAN
from mjcable.solvers.settings import MAX_AUTO_ITERATIONS

MODELS = mjcable.catalog.names()
PARTICLE = mjcable.catalog.names("particle")
# the issue's table: models whose segments are rigid (joints, composite) or whose stretch is the factor k (pbd,
# jakobsen) do not use E·A
IGNORE_STRETCH = {"joints", "composite", "pbd", "jakobsen"}
SOFT_EA = 2.0  # N: soft enough for flexrod's explicit edge springs at dt = 0.002 (and far from inextensible)


def _build(scene, model, **settings):
    """``(Simulator, [PhysicsWarning messages])``."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sim = mjcable.Simulator(scene, model, **settings)
    return sim, [str(w.message) for w in caught if issubclass(w.category, PhysicsWarning)]


def test_physics_warning_is_a_public_user_warning():
    assert issubclass(mjcable.PhysicsWarning, UserWarning) and "PhysicsWarning" in mjcable.__all__


# ------------------------------------------------------------------------------------------- ignored properties


@pytest.mark.parametrize("model", model_params())
def test_stretch_stiffness_warns_exactly_where_the_model_ignores_it(model):
    """Where it warns, E·A changes nothing (bit for bit); where it does not, E·A stretches the cable."""
    base = mjcable.scenes.get("hang", n_segments=20)
    elastic = base.with_cable(stretch_stiffness=SOFT_EA)
    sim, said = _build(elastic, model)
    plain, _ = _build(base, model)
    sim.step(0.3)
    plain.step(0.3)
    ignored = [m for m in said if "CableSpec.stretch_stiffness" in m]
    if model in IGNORE_STRETCH:
        assert len(ignored) == 1, said
        assert model in ignored[0] and f"= {SOFT_EA:g} N is ignored" in ignored[0]
        assert "the models that use it: " + ", ".join(mjcable.catalog.honouring("stretch_stiffness")) in ignored[0]
        np.testing.assert_array_equal(sim.positions, plain.positions)
    else:
        assert not ignored, said
        assert np.abs(sim.positions - plain.positions).max() > 1e-3  # 2 N of E·A sags the cable visibly


@pytest.mark.parametrize("model", ["pbd", "jakobsen"])
def test_young_on_a_distance_bend_warns_and_changes_nothing(model):
    scene = mjcable.scenes.get("hang", n_segments=20)
    sim, said = _build(scene.with_cable(young=1e7), model, bending="distance")
    plain, quiet = _build(scene, model, bending="distance")
    assert any("CableSpec.young = 1e+07 Pa is ignored" in m and "bending='curvature'" in m for m in said), said
    assert not quiet
    sim.step(0.2)
    plain.step(0.2)
    np.testing.assert_array_equal(sim.positions, plain.positions)


def test_explicit_overrides_and_default_cables_pass_quietly():
    scene = mjcable.scenes.get("hang", n_segments=20)
    for model in MODELS:
        assert not _build(scene, model)[1], model
    elastic = scene.with_cable(stretch_stiffness=SOFT_EA)
    assert not _build(elastic, "xpbd", stretch_compliance=0.0)[1]  # the user's own compliance
    assert not _build(scene.with_cable(young=1e7), "pbd", bending="distance", bend_factor=0.5)[1]


def test_a_model_entry_ignoring_an_unknown_field_is_refused():
    with pytest.raises(ValueError, match="ignores must pair CableSpec fields"):
        mjcable.catalog.ModelEntry(**{**_entry_fields("xpbd"), "ignores": {"colour": "not a cable property"}})


def _entry_fields(name):
    entry = mjcable.catalog.get(name)
    return {f: getattr(entry, f) for f in ("name", "family", "settings", "build", "backend", "rules", "summary")}


# ------------------------------------------------------------------------------------------------ the fall rule


@pytest.mark.parametrize("model", model_params())
def test_a_substep_that_drops_a_particle_more_than_a_segment_warns_with_the_substeps_that_fix_it(model):
    scene = mjcable.scenes.get("hang")  # l₀ = 2 cm: |g| h² > l₀ from h = 45 ms
    dt = 0.2
    substeps = mjcable.catalog.make_settings(model).substeps
    g, l0 = 9.81, scene.cable.segment_length
    fall = [m for m in _build(scene, model, dt=dt)[1] if "more than a segment" in m]
    assert (len(fall) == 1) == (g * (dt / substeps) ** 2 > l0)
    if fall:
        need = math.ceil(dt / math.sqrt(l0 / g))
        assert f"use substeps >= {need} at dt=0.2 s" in fall[0]
        assert not [m for m in _build(scene, model, dt=dt, substeps=need)[1] if "more than a segment" in m]


def test_the_fall_rule_marks_where_xpbd_stops_holding_an_inextensible_cable():
    """dt = 0.5 s, 4 substeps (|g| h² = 7.7 l₀): the hang came back 50 % long (now the physics monitor stops it); at
    the substeps the warning gives it holds its length."""
    scene = mjcable.scenes.get("hang", damping=2.0)
    lengths = {}
    for substeps in (4, math.ceil(0.5 / math.sqrt(scene.cable.segment_length / 9.81))):
        sim, _ = _build(scene, "xpbd", dt=0.5, substeps=substeps)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", PhysicsWarning)  # the monitor's strain warning
                sim.step(3.0)
        except mjcable.SimulationDivergedError:
            lengths[substeps] = math.inf
            continue
        lengths[substeps] = np.linalg.norm(np.diff(sim.positions, axis=0), axis=1).sum() / scene.cable.length
    coarse, fine = lengths.values()
    assert coarse > 1.1 and abs(fine - 1.0) < 0.01, lengths


# ---------------------------------------------------------------------------- a stretch under the cable's weight


def _hang_top_tension(mass: float) -> float:
    """N: the inextensible catenary's tension at its pins, w sqrt(a² + (L/2)²), 2 a sinh(S / 2a) = L."""
    a = optimize.brentq(lambda a: 2 * a * math.sinh(HANG_SPAN / (2 * a)) - HANG_LENGTH, 1e-3, 1e3)
    return mass * 9.81 / HANG_LENGTH * math.hypot(a, HANG_LENGTH / 2)


def _max_strain(sim) -> float:
    return float(np.max(np.linalg.norm(np.diff(sim.positions, axis=0), axis=1)) / sim.scene.cable.segment_length - 1)


@pytest.mark.parametrize("model", model_params(models=("springs",) + PARTICLE))
def test_a_stretch_under_the_weight_warns_and_is_the_one_measured(model):
    """At dt = 0.015 s the springs' capped stiffness and the Gauss-Seidel sweeps leave the inextensible ``hang`` 12-20 %
    long at its top. The warning's strain is that of a straight chain between the two pins under its weight along
    it, m g / 2 at each, so the measured top strain is the catenary's top tension over that, 1.20, times the warned
    one."""
    scene = mjcable.scenes.get("hang", damping=2.0)
    settings = {} if model == "springs" else {"order": "gauss-seidel", "iterations": 1}
    sim, said = _build(scene, model, dt=0.015, **settings)
    warned = [m for m in said if "static strain of about" in m]
    assert len(warned) == 1, said
    expected = float(warned[0].split("static strain of about ")[1].split()[0])
    sim.step(6.0)
    top = _hang_top_tension(scene.cable.mass)
    carried = scene.cable.mass * 9.81 * 0.5
    assert _max_strain(sim) == pytest.approx(expected * top / carried, rel=0.1)
    need = int(warned[0].split("substeps >= ")[1].split()[0])
    sim, said = _build(scene, model, dt=0.015, substeps=need, **settings)
    assert not [m for m in said if "static strain" in m]
    sim.step(6.0)
    warned_beyond = springs.STRAIN_WARNING if model == "springs" else prechecks.STRAIN_WARNING
    assert _max_strain(sim) < warned_beyond * top / carried


def test_springs_refuses_a_hanging_cable_its_capped_springs_would_tear_and_warns_a_lying_one():
    """The same 1 m, 0.1 kg rod (E = 10⁵ Pa: its bending springs capped too) at dt = 0.05 s on springs' default 10
    substeps: the straight chain of springs k₁ + 4 k₂ per segment (a cut crosses one stretch and two bending
    springs) carries its whole weight at the pin with a static strain of about 0.97, twice that as it is let go.
    Hanging from its pin it tears (measured: strain 1.09 at 0.35 s, docs/measurements.md), so it is refused; lying
    clamped and horizontal its weight pulls only partly along it (measured: 0.92 at most), so it only warns."""
    from mjcable.bench.scenarios import cantilever_scene

    lying = cantilever_scene(50, young=1e5)
    top = lying.cable.particles[0]
    hanging = Scene(dataclasses.replace(lying.cable, points=np.array([top, top - [0.0, 0.0, 1.0]])), pins=(Pin(0),))
    h = 0.05 / 10
    limit = 0.25 * lying.cable.mass / (50 * h * h)  # springs' stability rule: k₁ + k₂, k₂ capped at its half
    below = lying.cable.mass * (1.0 - 0.5 / 50)  # all but the pinned end particle's half segment
    expected = below * 9.81 / ((0.5 * limit + 4.0 * 0.5 * limit) * lying.cable.segment_length)
    with pytest.raises(ValueError, match=r"^springs: .*static strain of about (\S+) .*the cable tears") as err:
        mjcable.Simulator(hanging, "springs", dt=0.05)
    assert float(str(err.value).split("static strain of about ")[1].split()[0]) == pytest.approx(expected, rel=0.01)
    _, said = _build(lying, "springs", dt=0.05)
    assert [m for m in said if "static strain of about" in m]


@pytest.mark.parametrize("model", PARTICLE)
def test_the_default_iterations_keep_an_inextensible_cable_within_its_promise(model):
    """``iterations=None`` (the default) takes the fewest iterations whose estimate is within the warning: none
    fires, and the measured top strain of the same hang as above is within the warned strain (the measured top
    strain is 1.20 times the estimate: the catenary's top tension over m g / 2). At the default dt and substeps of
    every built-in scene it takes one."""
    scene = mjcable.scenes.get("hang", damping=2.0)
    sim, said = _build(scene, model, dt=0.015, order="gauss-seidel")
    assert not [m for m in said if "static strain" in m], said
    assert 1 < sim.settings.iterations <= MAX_AUTO_ITERATIONS
    sim.step(6.0)
    top = _hang_top_tension(scene.cable.mass)
    assert _max_strain(sim) < prechecks.STRAIN_WARNING * top / (scene.cable.mass * 9.81 * 0.5)
    for name in mjcable.scenes.names():
        assert _build(mjcable.scenes.get(name), model)[0].settings.iterations == 1, name


# ----------------------------------------------------------------------------------- a rod softer than stated

ROD_LENGTH, ROD_RADIUS, ROD_MASS = 0.5, 0.005, 0.02


def _cantilever(n: int, load: float) -> Scene:
    """A horizontal rod clamped at particle 0, its weight q L³ / E·I = ``load``."""
    q = ROD_MASS * 9.81 / ROD_LENGTH
    young = q * ROD_LENGTH**3 / load / (math.pi * ROD_RADIUS**4 / 4)
    cable = CableSpec([[0, 0, 1], [ROD_LENGTH, 0, 1]], n, ROD_RADIUS, ROD_MASS, young=young, damping=20.0)
    return Scene(cable, pins=(Pin(0, clamp=True),))


def _fraction(messages):
    said = [m for m in messages if "of its stated bending stiffness" in m]
    return float(said[0].split("reaches about ")[1].split()[0]) if said else None


# (model, settings): a light cantilever of 10 segments (q L³ / E·I = 0.05, beam theory's tip drop L / 160, so the
# rod stays in the linear range even where it sags 3.4 times as far)
WARNED = [("xpbd", {"order": "gauss-seidel"}), ("pbd", {"iterations": 10}), ("xpbd", {"order": "gauss-seidel",
          "substeps": 16}), ("jakobsen", {"substeps": 32}), ("xpbd", {"order": "jacobi", "iterations": 10})]
QUIET = [("xpbd", {}), ("xpbd", {"order": "gauss-seidel", "iterations": 8}), ("pbd", {"substeps": 16}),
         ("jakobsen", {"substeps": 12})]


@pytest.mark.parametrize("model, settings", WARNED + QUIET)
def test_the_warned_stiffness_fraction_is_the_measured_sag_against_beam_theory(model, settings):
    """Where the warning says the rod reaches a fraction f of its stated E·I, its tip drops 1/f times beam theory's
    (within 8 %: the linear analysis leaves out the shape's geometric nonlinearity, 1 % at these sags, and Jacobi's
    averaging of rows that the analysis linearises about the straight rod); where none fires, the tip drop is within
    12 % of beam theory (the tolerance, 10 %, plus the 10-segment rod's discretisation)."""
    scene = _cantilever(10, 0.05)
    sim, said = _build(scene, model, **settings)
    f = _fraction(said)
    assert (f is None) == ((model, settings) in QUIET), said
    sim.step(5.0)
    q = ROD_MASS * 9.81 / ROD_LENGTH
    beam = reference.beam_tip_deflection(ROD_LENGTH, q, scene.cable.bending_stiffness)
    drop = 1.0 - sim.positions[-1, 2]
    if f is None:
        assert drop == pytest.approx(beam, rel=prechecks.STIFFNESS_TOLERANCE + 0.02)
    else:
        assert drop == pytest.approx(beam / f, rel=0.08)


def test_a_cosserat_rod_under_gauss_seidel_warns_that_it_needs_to_converge():
    """The rod's Gauss-Seidel order warns that it reaches its stated stiffness only when converged; the direct order
    (tests/test_cosserat.py: the elastica within 0.5 %) does not."""
    scene = _cantilever(40, 1.0)
    said = _build(scene, "cosserat", order="gauss-seidel")[1]
    assert any("order='direct'" in m and "only once the Gauss-Seidel sweeps converge" in m for m in said), said
    assert not [m for m in _build(scene, "cosserat", order="direct")[1] if "Gauss-Seidel" in m]


@pytest.mark.parametrize("model", [m for m in PARTICLE if m != "cosserat"])
def test_the_heavy_cantilever_of_the_issue_warns_that_gauss_seidel_leaves_it_limp(model):
    """q L³ / E·I = 1, 40 segments, Gauss-Seidel: the tip drops 7 times beam theory's (the rod hangs limp); the
    warning says so and points to the direct order."""
    said = _build(_cantilever(40, 1.0), model, order="gauss-seidel")[1]
    f = _fraction(said)
    assert f is not None and f < 0.1, said
    assert "order='direct'" in next(m for m in said if "bending stiffness" in m)
    if model == "xpbd":
        assert _fraction(_build(_cantilever(40, 1.0), model, order="direct")[1]) is None


@pytest.mark.parametrize("model, order, warns", [("pbd", "gauss-seidel", True), ("jakobsen", "jacobi", True),
                                                 ("pbd", "direct", False)])
def test_several_cables_in_sweeping_orders_warn_that_no_strain_estimate_is_made(model, order, warns):
    """Two cables crossing, the lower one pinned taut: the sweeping orders say that the cables' loads on each other are not
    estimated and give the direct order; the direct order (the stated stiffness in one solve) says nothing."""
    taut = CableSpec([(-0.3, 0.0, 1.0), (0.3, 0.0, 1.0)], 20, 0.003, 0.02)
    rope = CableSpec([(0.0, -0.3, 1.0065), (0.0, 0.3, 1.0065)], 20, 0.003, 0.02)  # lying across it
    scene = Scene((taut, rope), (Pin(0), Pin(-1)))
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        mjcable.Simulator(scene, model, order=order)
    said = [str(w.message) for w in record if "no estimate of the iterations' static strain" in str(w.message)]
    assert bool(said) == warns
    if warns:
        assert f"order={order!r}" in said[0] and "use order='direct'" in said[0]


def test_the_default_order_of_pbd_and_jakobsen_is_direct_where_the_sweeps_cant_carry_the_scene():
    """``order=None`` takes Gauss-Seidel sweeps on a hanging cable (one iteration keeps it within its promise) and the
    direct order with several cables, a winch or a ring (module docstring of ``resolve_order``); an order given
    stays as it is."""
    from mjcable.bench import ring

    hang = mjcable.scenes.get("hang")
    two = Scene((CableSpec([(-0.3, 0.0, 1.0), (0.3, 0.0, 1.0)], 20, 0.003, 0.02),
                 CableSpec([(-0.3, 0.2, 1.0), (0.3, 0.2, 1.0)], 20, 0.003, 0.02)), (Pin(0), Pin(-1)))
    winch = dataclasses.replace(hang, pins=(Pin(5, "winch"),))
    for model in ("pbd", "jakobsen"):
        assert mjcable.Simulator(hang, model).settings.order == "gauss-seidel"
        for scene in (two, winch, ring.atwood_scene()):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", mjcable.PhysicsWarning)
                assert mjcable.Simulator(scene, model).settings.order == "direct", (model, scene.name)
                assert mjcable.Simulator(scene, model, order="jacobi").settings.order == "jacobi"
