"""Pin reactions at rest against the statics of the whole cable, for every particle model in every order it takes:
a clamped heavy rod's clamp carries its weight W and the weight's moment ∫ x g dm about the clamp, and a hanging
chain's pins carry its weight and the catenary's horizontal tension H = a·w, whatever shape each settles in (the
moment is taken from the settled positions and the particles' masses). A rod clamped in a body of a user world:
tests/test_chain_body_clamp.py."""

import math

import numpy as np
import pytest

import mjcable
from mjcable import catalog, reference
from mjcable.scenes import HANG_LENGTH, HANG_SPAN
from mjcable.solvers.settings import ORDERS
from test_simulator_api import catenary_parameter

G = 9.81
ROD_LENGTH, ROD_MASS, ROD_YOUNG, ROD_RADIUS = 0.2, 0.02, 1e6, 0.005  # q L³ / E·I = 16: a heavy rod
AT_REST = 1e-3  # m/s: the fastest particle of a settled cable
# the prechecks' word on an unconverged order's bending stiffness: the balance holds whatever shape the rod takes
STIFFNESS_WARNING = "ignore:.*stated (bending )?stiffness:mjcable.PhysicsWarning"


def model_orders() -> list:
    """``(model, order)`` for every particle model of the catalogue and every order its settings accept."""
    pairs = []
    for model in catalog.names("particle"):
        for order in ORDERS:
            try:
                catalog.make_settings(model, order=order)
            except ValueError:
                continue
            pairs.append((model, order))
    return pairs


def test_every_point_chain_takes_every_order():
    """The list below covers the Jacobi order of each point chain (the order whose reactions were once wrong)."""
    assert {("jakobsen", "jacobi"), ("pbd", "jacobi"), ("xpbd", "jacobi")} <= set(model_orders())


def _clamped_rod(n: int = 10) -> mjcable.Scene:
    cable = mjcable.CableSpec([[0, 0, 1], [ROD_LENGTH, 0, 1]], n, ROD_RADIUS, ROD_MASS, young=ROD_YOUNG,
                              damping=20.0)
    return mjcable.Scene(cable, pins=(mjcable.Pin(0, clamp=True),))


@pytest.mark.filterwarnings(STIFFNESS_WARNING)
@pytest.mark.parametrize("model, order", model_orders())
def test_a_clamped_heavy_rod_at_rest_carries_its_weight_and_moment(model, order):
    scene = _clamped_rod()
    sim = mjcable.Simulator(scene, model, order=order)
    sim.step(3.0)
    assert np.abs(sim.velocities).max() < AT_REST, "not at rest"
    x, m = sim.positions, sim.particle_masses
    weight = ROD_MASS * G
    moment = G * np.sum(m * (x[:, 0] - x[0, 0]))  # about the clamp, along −y for a rod along +x under −z gravity
    assert x[0, 2] - x[-1, 2] > 0.1 * ROD_LENGTH  # it did bend: the moment's lever is the settled shape's
    np.testing.assert_allclose(sim.pin_forces[0], [0.0, 0.0, weight], atol=0.01 * weight)
    assert -sim.pin_torques[0, 1] == pytest.approx(moment, rel=0.01)
    np.testing.assert_allclose(sim.pin_torques[0, [0, 2]], 0.0, atol=0.01 * moment)


@pytest.mark.parametrize("model, order", model_orders())
def test_a_hanging_chain_at_rest_carries_its_weight_and_the_catenary_tension(model, order):
    scene = mjcable.scenes.get("hang", n_segments=20, damping=6.0)
    sim = mjcable.Simulator(scene, model, order=order)
    sim.step(4.0)
    assert np.abs(sim.velocities).max() < AT_REST, "not at rest"
    f = sim.pin_forces
    weight = scene.cable.mass * G
    assert f[:, 2].sum() == pytest.approx(weight, rel=0.01)
    tension = catenary_parameter(HANG_LENGTH, HANG_SPAN) * weight / HANG_LENGTH
    assert -f[0, 0] == pytest.approx(tension, rel=0.02)  # 20 segments: the polygon's H is within 1 % of a·w
    assert f[1, 0] == pytest.approx(tension, rel=0.02)


def test_a_converged_jacobi_order_reaches_the_heavy_elastica():
    """XPBD's Jacobi iterations, converged, give the model's own statics: the clamped heavy rod bends as the elastica
    (within 2 %: the 10-segment rod's discretisation, 1.3 % for the direct order), not as a rod carrying its
    particles' weights times their constraint counts (20 % further down, whatever the iterations, before the
    constraints applied equal and opposite shares)."""
    scene = _clamped_rod()
    sim = mjcable.Simulator(scene, "xpbd", order="jacobi", iterations=50)
    sim.step(3.0)
    ei = ROD_YOUNG * math.pi * ROD_RADIUS**4 / 4
    elastica = reference.cantilever(ROD_LENGTH, ROD_MASS * G / ROD_LENGTH, ei)
    assert sim.positions[-1, 2] - 1.0 == pytest.approx(elastica.z[-1], rel=0.02)
