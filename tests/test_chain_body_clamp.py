"""A point-chain cable (``xpbd``, ``pbd``, ``jakobsen``) clamped in a body of a user world, two-way: the clamp holds
the tangent along a direction fixed in the body, and the body feels the clamp's moment. Reference: a heavy
cantilever clamped to a hub on a hinge spring k across it tilts the hub until the spring's torque k θ is the cable's
weight moment about the hinge (static balance of the cable, whatever its stiffness), and in the hub's frame the
cable bends as the clamped heavy elastica (:func:`mjcable.reference.cantilever`). The balance on a short rod is
checked for every particle model (``cosserat`` too) in every order it takes."""

import math

import mujoco
import numpy as np
import pytest

import mjcable
from mjcable import CableSpec, Pin, Scene, reference
from test_pin_balance import STIFFNESS_WARNING, model_orders

G = 9.81
RADIUS = 0.005
START = np.array([0.0, 0.0, 0.5])


def _hub(stiffness, inertia, damping) -> mujoco.MjSpec:
    """A hub at START on a hinge about y (across the cable) with a spring (N·m/rad) and damping (N·m·s/rad)."""
    return mujoco.MjSpec.from_string(f"""<mujoco><option gravity="0 0 {-G}"/><worldbody>
      <body name="hub" pos="{START[0]} {START[1]} {START[2]}">
        <joint name="hinge" type="hinge" axis="0 1 0" stiffness="{stiffness}" damping="{damping}"/>
        <inertial pos="0 0 0" mass="0.1" diaginertia="{inertia} {inertia} {inertia}"/>
      </body></worldbody></mujoco>""")


def _settled(model, length, n, inertia, damped, **options):
    """A cantilever (q L³ / E I = 1) clamped to the hub, settled: (simulator, k, the weight's moment about the hinge
    along +y)."""
    mass = 0.1 * length
    q = mass * G / length
    ei = q * length**3
    cable = CableSpec([START, START + [length, 0, 0]], n, RADIUS, mass, young=ei / (math.pi * RADIUS**4 / 4),
                      damping=2 * 3.52 * math.sqrt(G / length))  # about critical for the first mode
    k = 20.0 * mass * G * length  # the hub tilts by about 1/40 rad
    damping = 2.0 * math.sqrt(k * inertia) if damped else 0.0
    scene = Scene(cable, (Pin(0, "body", body="hub", clamp=True),), world=_hub(k, inertia, damping))
    sim = mjcable.Simulator(scene, model, **options)
    sim.step(3.0)
    x = sim.positions
    moment = G * np.sum(sim.particle_masses * (x[:, 0] - x[0, 0]))
    return sim, k, moment


@pytest.mark.parametrize("inertia, damped", [
    (1e-4, True),  # a hub heavier than the cable's first segments, its hinge damped
    (1e-6, False),  # a hub 3e4 times lighter than the cable about the hinge (0.033 kg·m²)
])
def test_a_cantilever_clamped_to_a_hub_tilts_it_by_the_weights_moment(inertia, damped):
    length = 1.0
    sim, k, moment = _settled("xpbd", length, 50, inertia, damped)
    theta = sim.mj_data.qpos[0]
    assert theta > 0.01  # the hub did tilt, tip down
    assert k * theta == pytest.approx(moment, rel=0.005)
    assert -sim.pin_torques[0, 1] == pytest.approx(moment, rel=0.005)
    assert abs(sim.mj_data.qvel[0]) < 1e-4  # settled
    # the clamp held the tangent in the hub's frame: there the cable is the clamped heavy elastica (to 1 %: the tilted
    # weight's pull along the cable, q sin θ, stiffens it by about 0.3 %)
    x = sim.positions - sim.positions[0]
    tip = math.sin(theta) * x[-1, 0] + math.cos(theta) * x[-1, 2]  # the tip's height in the hub's frame
    expected = reference.cantilever(length, 0.1 * G, 0.1 * G * length**3).z[-1]
    assert tip == pytest.approx(expected, rel=0.01)


@pytest.mark.filterwarnings(STIFFNESS_WARNING)
@pytest.mark.parametrize("model, order", model_orders())
def test_a_short_cantilever_on_a_hub_balances_the_hinge_spring_in_every_order(model, order):
    """Every particle model in every order: the hinge spring carries the cable's weight moment and the pin its
    weight, whatever the shape (the Gauss-Seidel and Jacobi orders give a short rod of few segments its stiffness;
    a long one is limp, with a warning)."""
    sim, k, moment = _settled(model, 0.2, 10, 1e-4, True, order=order)
    theta = sim.mj_data.qpos[0]
    assert theta > 0.01
    assert abs(sim.mj_data.qvel[0]) < 1e-4
    assert k * theta == pytest.approx(moment, rel=0.01)
    assert -sim.pin_torques[0, 1] == pytest.approx(moment, rel=0.01)
    weight = 0.1 * 0.2 * G
    np.testing.assert_allclose(sim.pin_forces[0], [0.0, 0.0, weight], atol=0.01 * weight)
