"""A ``cosserat`` rod clamped in a body of a user world, two-way: the clamp holds the segment's whole frame in the
body, and the body feels the rod's torque, its axial twist included. References: a hub on a hinge spring k about
the rod's axis, the rod's far end turned by φ in a gripper, settles where the spring's torque k θ is the rod's
C (φ − θ) / L; a heavy cantilever clamped to a hub on a hinge spring across it tilts the hub until k θ is the
weight's moment about the root."""

import math

import mujoco
import numpy as np
import pytest

import mjcable
from mjcable import CableSpec, Pin, Scene

G = 9.81
L, RADIUS, YOUNG = 1.0, 0.005, 1e8
START = np.array([0.0, 0.0, 0.5])


def _turn(axis, angle) -> np.ndarray:
    axis = np.asarray(axis, dtype=float)
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * axis / np.linalg.norm(axis)])


def _hub(axis, stiffness, inertia, damping, gravity="0 0 0") -> mujoco.MjSpec:
    """A hub at START on a hinge about ``axis`` with a spring (N·m/rad) and damping (N·m·s/rad), inertia kg·m²."""
    return mujoco.MjSpec.from_string(f"""<mujoco><option gravity="{gravity}"/><worldbody>
      <body name="hub" pos="{START[0]} {START[1]} {START[2]}">
        <joint name="hinge" type="hinge" axis="{axis}" stiffness="{stiffness}" damping="{damping}"/>
        <inertial pos="0 0 0" mass="0.1" diaginertia="{inertia} {inertia} {inertia}"/>
      </body></worldbody></mujoco>""")


@pytest.mark.parametrize("order, n_segments, length, iterations, inertia, damped", [
    ("direct", 50, L, 1, 1e-4, True),  # a hub heavier than the rod, its hinge damped
    ("direct", 50, L, 1, 1e-7, False),  # a hub lighter than the rod's 50 segments together (6e-7 kg·m²)
    ("gauss-seidel", 8, 0.2, 200, 1e-4, True),  # enough sweeps to converge (test_cosserat)
])
def test_a_hub_on_a_hinge_spring_feels_the_rods_twist(order, n_segments, length, iterations, inertia, damped):
    phi = math.pi
    cable = CableSpec([START, START + [length, 0, 0]], n_segments, RADIUS, 0.05, young=YOUNG,
                      damping=30.0)
    c_over_l = cable.torsion_stiffness / length
    k = c_over_l  # as stiff as the rod: the hub turns by φ / 2
    damping = 2.0 * math.sqrt(k * inertia) if damped else 0.0
    scene = Scene(cable, (Pin(0, "body", body="hub", clamp=True), Pin(-1, "gripper", clamp=True)),
                  world=_hub("1 0 0", k, inertia, damping))
    sim = mjcable.Simulator(scene, "cosserat", order=order, iterations=iterations)
    end = sim.gripper_positions[0]
    for j in range(1, 41):
        sim.move_gripper(1, end, _turn([1, 0, 0], phi * j / 40))
        sim.step()
    sim.step(2.0)
    theta = sim.mj_data.qpos[0]
    assert theta == pytest.approx(phi * c_over_l / (k + c_over_l), rel=0.01)  # k θ = C (φ − θ) / L
    assert -sim.pin_torques[0, 0] == pytest.approx(k * theta, rel=0.01)  # the clamp's torque is the spring's
    assert sim.pin_torques[1, 0] == pytest.approx(k * theta, rel=0.01)
    assert abs(sim.mj_data.qvel[0]) < 1e-3  # settled


@pytest.mark.parametrize("load", [1.0, 10.0])
def test_a_cantilever_clamped_to_a_hub_tilts_it_by_the_weights_moment(load):
    mass, n = 0.1, 50
    q = mass * G / L
    ei = q * L**3 / load
    damping = 2 * 3.52 * math.sqrt(G / (load * L))  # about critical for the first mode
    cable = CableSpec([START, START + [L, 0, 0]], n, RADIUS, mass, young=ei / (math.pi * RADIUS**4 / 4),
                      damping=damping)
    k, inertia = 20.0 * mass * G * L, 1e-4  # the hub tilts by about 1/40 rad
    scene = Scene(cable, (Pin(0, "body", body="hub", clamp=True),),
                  world=_hub("0 1 0", k, inertia, 2.0 * math.sqrt(k * inertia), gravity=f"0 0 {-G}"))
    sim = mjcable.Simulator(scene, "cosserat")
    sim.step(5.0)
    x = sim.positions
    moment = G * np.sum(sim.particle_masses * (x[:, 0] - x[0, 0]))  # about the root, along +y
    theta = sim.mj_data.qpos[0]
    assert theta > 0.01  # the hub did tilt, tip down
    assert k * theta == pytest.approx(moment, rel=0.005)
    assert -sim.pin_torques[0, 1] == pytest.approx(moment, rel=0.005)
