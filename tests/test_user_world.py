"""Cables in a user's own MuJoCo world (issue 10): every model builds into the user's spec, honours its gravity,
keeps its names and indices, and holds body pins both ways (a body feels the cable).

Physics against independent references: a box's weight through the cable (statics), a box pendulum on a light cable
(the rigid pendulum's period, complete elliptic integral), an actuated arm's sag (kp·Δθ = m g r cos θ).
"""

import math
import os
import warnings

import mujoco
import numpy as np
import pytest
from scipy.special import ellipk

import mjcable
from catalog_params import marked, model_params
from mjcable import CableSpec, Pin, Scene, Simulator
from mjcable.mjcf import springs as springs_mjcf

MODELS = tuple(mjcable.catalog.names())
INEXTENSIBLE = ("joints", "composite", "flexrod", "xpbd")
# the physics tests' quick run: pbd and jakobsen (Gauss-Seidel cousins of xpbd, a few seconds each) go with the slow
# tests, which CI runs too
PHYSICS_MODELS = tuple(marked(m) if m not in ("pbd", "jakobsen") else pytest.param(m, marks=pytest.mark.slow)
                       for m in MODELS)
# flexrod's soft edge equality and pins need substeps under an end mass 100-2000 times a particle's
SETTINGS = {"flexrod": {"substeps": 4}}


def _sim(scene, model, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # stability warnings of capped stiffness
        return Simulator(scene, model, dt=0.002, **{**SETTINGS.get(model, {}), **kw})


# ---------------------------------------------------------------------------------------------------------- weight

G_WORLD = 4.9
TOP = np.array([0.0, 0.0, 1.0])
LENGTH, N, CABLE_MASS, BOX_MASS, HALF = 0.5, 20, 0.05, 0.5, 0.03


def _weight_scene() -> Scene:
    # the box slides on three damped slide joints, so that every model comes to rest
    below = TOP[2] - LENGTH - HALF
    xml = f"""<mujoco><option gravity="0 0 -{G_WORLD}"/><worldbody>
      <body name="box" pos="0 0 {below}">
        <joint name="bx" type="slide" axis="1 0 0" damping="5"/><joint name="by" type="slide" axis="0 1 0"
        damping="5"/><joint name="bz" type="slide" axis="0 0 1" damping="5"/>
        <geom name="box" type="box" size="{HALF} {HALF} {HALF}" mass="{BOX_MASS}"/>
      </body></worldbody></mujoco>"""
    cable = CableSpec([TOP, TOP - [0, 0, LENGTH]], N, 0.005, CABLE_MASS)
    return Scene(cable, (Pin(0), Pin(-1, "body", body="box", offset=(0, 0, HALF))),
                 world=mujoco.MjSpec.from_string(xml))


@pytest.mark.parametrize("model", PHYSICS_MODELS)
def test_a_box_hangs_from_the_cable_in_the_worlds_gravity(model):
    scene = _weight_scene()
    sim = _sim(scene, model)
    assert sim.mj_model.opt.gravity[2] == pytest.approx(-G_WORLD)
    sim.step(3.0)
    weight = (CABLE_MASS + BOX_MASS) * G_WORLD
    top = sim.pin_forces[0]
    assert top[2] == pytest.approx(weight, rel=0.01), f"{model}: top pin force {top}, weight {weight:.4f} N"
    assert np.linalg.norm(top[:2]) < 1e-3 * weight
    mujoco.mj_kinematics(sim.mj_model, sim.mj_data)
    box_top = sim.mj_data.body("box").xpos[2] + HALF
    stretch = (TOP[2] - LENGTH) - box_top  # m the cable is longer than its rest length
    # the pinned particle follows the box's point
    assert np.linalg.norm(sim.positions[-1] - [0, 0, box_top]) < 1e-3
    if model in INEXTENSIBLE:
        assert abs(stretch) < 5e-3, f"{model}: the box hangs {stretch * 1e3:.2f} mm below an inextensible cable's end"
    elif model == "springs":
        # Hooke's law in each spring tendon (the model's documented k₁), each carrying the box and what hangs below
        k1, _ = springs_mjcf.spring_stiffness(scene, sim.dt / sim.settings.substeps)
        masses = scene.cable.particle_masses
        below = BOX_MASS + np.cumsum(masses[::-1])[::-1][1:]  # kg below segment i: particles i+1..n and the box
        expected = float(np.sum(below * G_WORLD / k1))
        assert stretch == pytest.approx(expected, rel=0.05, abs=2e-4)
    else:  # jakobsen, pbd: stretch under load depends on iterations; it must not shorten the cable
        assert -1e-4 < stretch < 0.02


# -------------------------------------------------------------------------------------------------------- pendulum

PIVOT = np.array([0.0, 0.0, 1.0])
SWING = math.radians(20.0)


def _pendulum_scene() -> Scene:
    end = PIVOT + LENGTH * np.array([math.sin(SWING), 0.0, -math.cos(SWING)])
    xml = f"""<mujoco><worldbody><body name="box" pos="{end[0]} {end[1]} {end[2]}"><freejoint/>
      <geom name="box" type="box" size="0.02 0.02 0.02" mass="{BOX_MASS}"/></body></worldbody></mujoco>"""
    cable = CableSpec([PIVOT, end], N, 0.003, 0.005)  # 5 g: a hundredth of the box
    return Scene(cable, (Pin(0), Pin(-1, "body", body="box")), world=mujoco.MjSpec.from_string(xml))


@pytest.mark.parametrize("model", PHYSICS_MODELS)
def test_a_box_on_a_light_cable_swings_with_the_rigid_pendulums_period(model):
    sim = _sim(_pendulum_scene(), model)
    box = sim.mj_model.body("box").id
    steps = 2200  # 4.4 s, three periods
    x, t, reach = np.zeros(steps), np.zeros(steps), np.zeros(steps)
    for k in range(steps):
        sim.step()
        x[k], t[k] = sim.mj_data.xpos[box][0], sim.time
        reach[k] = np.linalg.norm(sim.mj_data.xpos[box] - PIVOT)
    i = np.flatnonzero(np.sign(x[:-1]) != np.sign(x[1:]))
    crossings = t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])
    assert len(crossings) >= 5, f"{model}: the box did not swing ({len(crossings)} crossings)"
    period = 2.0 * float(np.mean(np.diff(crossings)))
    length = float(np.mean(reach))  # the pivot-to-box length the cable actually holds
    expected = 4.0 * math.sqrt(length / 9.81) * ellipk(math.sin(SWING / 2.0) ** 2)
    if model in INEXTENSIBLE:
        assert abs(length - LENGTH) < 5e-3
        assert period == pytest.approx(expected, rel=0.02), f"{model}: period {period:.4f} s, rigid {expected:.4f} s"
    else:  # stretchy models swing on their stretched length: still a pendulum of that length
        assert period == pytest.approx(expected, rel=0.05)


# ------------------------------------------------------------------------------------------------------------- arm

ARM_R, ARM_KP, ARM_CABLE = 0.3, 100.0, 0.2
ARM_XML = f"""<mujoco><option timestep="0.002"/><worldbody>
  <body name="arm" pos="0 0 1"><joint name="shoulder" type="hinge" axis="0 -1 0" damping="2"/>
    <geom name="link" type="capsule" fromto="0 0 0 {ARM_R - 0.03} 0 0" size="0.01" mass="0.3"/>
    <body name="hand" pos="{ARM_R} 0 0"><geom name="palm" type="sphere" size="0.015" mass="0.05"/></body>
  </body></worldbody>
  <actuator><position name="shoulder" joint="shoulder" kp="{ARM_KP}" kv="5"/></actuator>
  <sensor><jointpos name="angle" joint="shoulder"/></sensor></mujoco>"""


def _arm_rest(spec: mujoco.MjSpec) -> float:
    m = spec.copy().compile()
    d = mujoco.MjData(m)
    mujoco.mj_step(m, d, nstep=2000)
    return float(d.qpos[0])


@pytest.mark.parametrize("model", PHYSICS_MODELS)
def test_an_actuated_arm_sags_by_the_hanging_cables_moment(model):
    spec = mujoco.MjSpec.from_string(ARM_XML)
    alone = _arm_rest(spec)
    hand = np.array([ARM_R, 0.0, 1.0])
    cable = CableSpec([hand, hand - [0, 0, 0.4]], N, 0.005, ARM_CABLE, damping=2.0)
    sim = _sim(Scene(cable, (Pin(0, "body", body="hand"),), world=spec), model)
    # the user's names and indices
    assert sim.mj_model.joint(0).name == "shoulder" and sim.mj_model.actuator(0).name == "shoulder"
    assert sim.mj_model.sensor(0).name == "angle"
    sim.step(4.0)
    angle = float(sim.mj_data.joint("shoulder").qpos[0])
    assert sim.mj_data.sensordata[0] == pytest.approx(angle, abs=1e-3)
    sag = alone - angle  # the hinge's axis −y: a positive angle lifts the hand
    expected = ARM_CABLE * 9.81 * ARM_R * math.cos(angle) / ARM_KP
    assert sag == pytest.approx(expected, rel=0.1), f"{model}: sag {sag:.3e} rad, expected {expected:.3e}"
    mujoco.mj_kinematics(sim.mj_model, sim.mj_data)
    assert np.linalg.norm(sim.positions[0] - sim.mj_data.body("hand").xpos) < 1e-3
    assert spec.to_xml() == mujoco.MjSpec.from_string(ARM_XML).to_xml()  # the user's spec is never mutated


# ---------------------------------------------------------------------------------------------------------- the API


def test_a_world_from_a_file_resolves_its_assets_against_its_folder(tmp_path, monkeypatch):
    (tmp_path / "meshes").mkdir()
    corners = [(x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)]
    faces = [(1, 2, 4, 3), (5, 7, 8, 6), (1, 5, 6, 2), (3, 4, 8, 7), (1, 3, 7, 5), (2, 6, 8, 4)]
    (tmp_path / "meshes" / "cube.obj").write_text(
        "".join(f"v {0.1 * x} {0.1 * y} {0.1 * z}\n" for x, y, z in corners)
        + "".join("f " + " ".join(map(str, f)) + "\n" for f in faces))
    (tmp_path / "world.xml").write_text(
        '<mujoco><asset><mesh name="cube" file="meshes/cube.obj"/></asset><worldbody>'
        '<geom name="block" type="mesh" mesh="cube" pos="1 0 0"/></worldbody></mujoco>')
    monkeypatch.chdir(os.path.dirname(mjcable.__file__))  # anywhere but the world's folder
    cable = CableSpec([[0, 0, 1], [0.5, 0, 1]], 10, 0.005, 0.05)
    scene = Scene(cable, (Pin(0),), world=tmp_path / "world.xml")
    for model in ("joints", "xpbd"):
        sim = _sim(scene, model)
        assert sim.mj_model.geom("block").type == mujoco.mjtGeom.mjGEOM_MESH
        sim.step(0.1)


def test_bad_worlds_and_body_pins_are_rejected_with_the_reason(tmp_path):
    xml = '<mujoco><worldbody><body name="box" pos="0 0 0.5"><freejoint/><geom size="0.05"/></body></worldbody>' \
          '<keyframe><key name="home" qpos="0 0 0.5 1 0 0 0"/></keyframe></mujoco>'
    spec = mujoco.MjSpec.from_string(xml)
    cable = CableSpec([[0, 0, 1], [0, 0, 0.5]], 10, 0.005, 0.05)
    with pytest.raises(ValueError, match="nowhere"):
        Scene(cable, (Pin(-1, "body", body="nowhere"),), world=spec)
    with pytest.raises(ValueError, match="0.05 m from particle 10"):
        Scene(cable, (Pin(-1, "body", body="box", offset=(0, 0.05, 0)),), world=spec)
    with pytest.raises(ValueError, match="no world"):
        Scene(cable, (Pin(-1, "body", body="box"),))
    with pytest.raises(ValueError, match="keyframe 'away'"):
        Scene(cable, world=spec, keyframe="away")
    with pytest.raises(ValueError, match="no such file"):
        Scene(cable, world=tmp_path / "missing.xml")
    with pytest.raises(ValueError, match="MjSpec"):
        Scene(cable, world=42)
    with pytest.raises(ValueError, match="body is required"):
        Pin(0, "body")
    clash = mujoco.MjSpec.from_string('<mujoco><worldbody><site name="particle3"/></worldbody></mujoco>')
    scene = Scene(cable, world=clash)
    for model in ("springs", "xpbd"):
        with pytest.raises(ValueError, match="particle3"):
            Simulator(scene, model)
    assert Scene(cable, (Pin(-1, "body", body="box"),), world=spec, keyframe="home").world.keyframe == "home"


@pytest.mark.parametrize("young", [0.0, 1e6])  # a stiff joints chain makes its own start key: after the world's
@pytest.mark.parametrize("model", model_params())
def test_a_cable_starts_from_the_worlds_keyframe_and_keeps_its_keyframes(model, young):
    xml = """<mujoco><worldbody><body name="arm" pos="0 0 1"><joint name="shoulder" axis="0 1 0"/>
      <geom name="link" type="capsule" fromto="0 0 0 0.2 0 0" size="0.01" mass="0.2"/></body></worldbody>
      <actuator><position name="shoulder" joint="shoulder" kp="50" kv="2"/></actuator>
      <keyframe><key name="raised" qpos="0.4" ctrl="0.4"/></keyframe></mujoco>"""
    cable = CableSpec([[0.5, 0, 1.0], [0.5, 0, 0.6]], 10, 0.005, 0.05, young=young)
    sim = _sim(Scene(cable, (Pin(0),), world=mujoco.MjSpec.from_string(xml), keyframe="raised"), model)
    assert sim.mj_data.joint("shoulder").qpos[0] == pytest.approx(0.4)
    assert sim.mj_data.actuator("shoulder").ctrl[0] == pytest.approx(0.4)
    assert sim.mj_model.key("raised").qpos[0] == pytest.approx(0.4)
    np.testing.assert_allclose(sim.positions, cable.particles, atol=1e-9)
    sim.step(0.5)
    assert sim.mj_data.joint("shoulder").qpos[0] == pytest.approx(0.4, abs=0.02)  # the servo holds its target
    sim.reset()
    assert sim.mj_data.joint("shoulder").qpos[0] == pytest.approx(0.4)


# ------------------------------------------------------------------------------------------------------------ drag

DRAG_MU, DRAG_MASS, DRAG_HALF = 0.5, 1.0, 0.05
# noslip iterations make MuJoCo's static friction hard: its soft contacts otherwise creep 0.1 mm below the threshold
DRAG_XML = f"""<mujoco><option cone="elliptic" impratio="10" noslip_iterations="20"/><worldbody>
  <geom name="table" type="box" size="1 0.5 0.05" pos="0 0 0.45" friction="{DRAG_MU}"/>
  <body name="box" pos="0 0 {0.5 + DRAG_HALF}"><freejoint/>
    <geom name="box" type="box" size="{DRAG_HALF} {DRAG_HALF} {DRAG_HALF}" mass="{DRAG_MASS}" friction="{DRAG_MU}"/>
  </body>
  <body name="puller" pos="0.45 0 {0.5 + DRAG_HALF}"><joint name="pull" type="slide" axis="1 0 0" damping="1"/>
    <geom name="puller" type="sphere" size="0.01" mass="0.05" contype="0" conaffinity="0"/></body>
  </worldbody><actuator><motor name="pull" joint="pull" ctrlrange="0 20"/></actuator></mujoco>"""


@pytest.mark.parametrize("model", PHYSICS_MODELS)
def test_a_cable_drags_a_box_once_its_pull_reaches_static_friction(model):
    """A motor pulls the cable's far end (a body pin on a slider) with a force rising at 1 N/s; the cable's near end
    is a body pin on a 1 kg box on a table. The box starts to move when the cable's pull reaches μ M g. (Moving
    0.1 mm takes the ramp 0.08 s after the threshold: the pull is then 1.7 % above it.)"""
    a = np.array([DRAG_HALF, 0.0, 0.5 + DRAG_HALF])
    cable = CableSpec([a, [0.45, 0.0, 0.5 + DRAG_HALF]], N, 0.003, 0.01)
    scene = Scene(cable, (Pin(0, "body", body="box", offset=(DRAG_HALF, 0, 0)), Pin(-1, "body", body="puller")),
                  world=mujoco.MjSpec.from_string(DRAG_XML))
    sim = _sim(scene, model)
    sim.mj_data.ctrl[0] = 4.0  # N, below the threshold: everything settles taut
    sim.step(0.5)
    start = sim.mj_data.body("box").xpos[0]
    threshold = DRAG_MU * DRAG_MASS * 9.81
    for k in range(1500):
        sim.mj_data.ctrl[0] = 4.0 + 1.0 * k * sim.dt
        sim.step()
        if sim.mj_data.body("box").xpos[0] - start > 1e-4:
            break
    else:
        pytest.fail(f"{model}: the box never moved, pull {-sim.pin_forces[0][0]:.3f} N")
    pull = -sim.pin_forces[0][0]  # the cable's pull on the box along x
    assert pull == pytest.approx(threshold, rel=0.05), f"{model}: slid at a pull of {pull:.3f} N, μMg {threshold:.3f} N"
