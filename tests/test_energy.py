"""``Simulator.energy``: the whole energy (kinetic + gravity + each model's own elastic energy) against physics and
against MuJoCo's own energy and forces, and velocities that are exactly zero for a scene starting at rest."""

import copy
import dataclasses
import math
import warnings

import mujoco
import numpy as np
import pytest

import mjcable
from catalog_params import model_params
from mjcable.bench import scenarios
from mjcable.mjcf import flexrod

G = 9.81
MODEL_PARAMS = model_params()
SWING_SECONDS = 10.0  # s of the undamped swing
SWING_SAMPLE = 0.02  # s between energy samples
SPRINGS_DRIFT = 0.005  # of the swing energy: springs' total stays within this (issue 20)
BEAM_LOAD = 0.1  # q L³ / E I of the cantilever: small deflections (tip 1.25 % of L), beam theory holds
BEAM_SEGMENTS = 20
SETTLE_SECONDS = 3.0


def _param(model, *rest):
    """A test parameter set for ``model`` (``composite`` carries its marker: MuJoCo 3.x only)."""
    return pytest.param(model, *rest, marks=(pytest.mark.composite,) if model == "composite" else ())


def _swing():
    """The undamped chain of the bench's energy scenario and its swing energy (J) above hanging straight down."""
    scene = scenarios.chain_scene(50, amplitude=scenarios.ENERGY_AMPLITUDE)
    c = scene.cable
    z_com = float(c.particle_masses @ c.particles[:, 2]) / c.mass
    return scene, c.mass * G * (z_com - (scenarios.CHAIN_TOP - c.length / 2))  # (derived here, not from the bench)


def _energies(sim, seconds: float) -> list:
    out = [sim.energy(parts=True)]
    for _ in range(int(round(seconds / SWING_SAMPLE))):
        sim.step(SWING_SAMPLE)
        out.append(sim.energy(parts=True))
    return out


# -- velocities at rest -------------------------------------------------------------------------------------------


@pytest.mark.parametrize("model, settings", [_param(m, {}) for m in mjcable.MODELS]
                         + [("pbd", {"integrator": "verlet"})])
def test_velocities_are_exactly_zero_at_the_start_and_after_reset(model, settings):
    # jakobsen (and pbd's Verlet) used to read −½ g h from a fictitious previous position x₋₁ = x₀ + ½ g h²
    sim = mjcable.Simulator(mjcable.scenes.get("hang", n_segments=20), model, **settings)
    assert np.array_equal(sim.velocities, np.zeros((21, 3)))
    assert sim.energy(parts=True).kinetic == 0.0
    sim.step(0.1)
    assert np.abs(sim.velocities).max() > 0.0  # (it moves: the start's catenary is not the model's rest shape)
    sim.reset()
    assert np.array_equal(sim.velocities, np.zeros((21, 3)))


# -- the parts --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("model", MODEL_PARAMS)
def test_energy_parts_add_up_and_gravity_and_kinetic_are_the_particles(model):
    scene = mjcable.scenes.get("hang", n_segments=20, damping=0.0, young=2e5, stretch_stiffness=20.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # stretch_stiffness on models with rigid segments
        sim = mjcable.Simulator(scene, model)
    sim.step(0.3)
    e = sim.energy(parts=True)
    assert isinstance(e, mjcable.Energy)
    assert sim.energy() == e.total == pytest.approx(e.kinetic + e.gravity + e.stretch + e.bending + e.twist,
                                                    abs=1e-15)
    m, x, v = sim.particle_masses, sim.positions, sim.velocities
    # lumped particle masses carry the same weight as the capsule chains' segment bodies
    assert e.gravity == pytest.approx(float(m @ x[:, 2]) * G, rel=1e-12)
    point = 0.5 * float(np.sum(m * np.sum(v * v, axis=1)))
    if model in ("joints", "composite"):  # segments also rotate, and the ball joints carry armature
        assert e.kinetic > point
    elif model == "cosserat":  # its frames spin too
        assert e.kinetic >= point
    else:
        assert e.kinetic == pytest.approx(point, rel=1e-12)
    assert e.bending > 0.0
    assert min(e.stretch, e.twist) >= 0.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        e.kinetic = 0.0


@pytest.mark.parametrize("model", MODEL_PARAMS)
def test_energy_in_a_user_world_is_the_cables_alone(model):
    """A 2 kg box falls freely beside the cable in the user's world (gravity 4.9 m/s²): the cable's energy holds
    none of its weight or speed."""
    g_world = 4.9
    xml = f"""<mujoco><option gravity="0 0 -{g_world}"/><worldbody><body name="box" pos="1 0 1">
      <joint type="slide" axis="0 0 1"/><geom type="box" size="0.05 0.05 0.05" mass="2"/></body></worldbody></mujoco>"""
    cable = mjcable.CableSpec([[0, 0, 1.0], [0.3, 0, 1.0]], 10, 0.005, 0.05, young=1e5)
    scene = mjcable.Scene(cable, pins=(mjcable.Pin(0),), world=mujoco.MjSpec.from_string(xml))
    sim = mjcable.Simulator(scene, model)
    sim.step(0.2)
    box = sim.mj_data.body("box")
    assert box.cvel[5] == pytest.approx(-g_world * 0.2, rel=0.02)  # (the box falls: 2 kg at ~1 m/s)
    e = sim.energy(parts=True)
    m, x, v = sim.particle_masses, sim.positions, sim.velocities
    assert e.gravity == pytest.approx(float(m @ x[:, 2]) * g_world, rel=1e-12)
    if model not in ("joints", "composite", "cosserat"):  # (those have rotating segments or frames too)
        assert e.kinetic == pytest.approx(0.5 * float(np.sum(m * np.sum(v * v, axis=1))), rel=1e-12)
    assert e.kinetic < 0.1 * 0.5 * 2.0 * (g_world * 0.2) ** 2  # the swinging cable's, not the falling box's 0.96 J


# -- native models: MuJoCo's own energy and forces ------------------------------------------------------------------


def _mujoco_energy(sim) -> float:
    """MuJoCo's own total (mj_energyPos + mj_energyVel) of the simulator's state, on a copy of its data."""
    m, d = sim.mj_model, copy.copy(sim.mj_data)
    mujoco.mj_forward(m, d)
    mujoco.mj_energyPos(m, d)
    mujoco.mj_energyVel(m, d)
    return float(d.energy[0] + d.energy[1])


@pytest.mark.parametrize("model, overrides, settings", [
    ("springs", {"young": 2e5}, {}),  # stretch and bending tendon springs
    ("joints", {"young": 2e6}, {}),  # ball-joint springs, armature
    ("flexrod", {"stretch_stiffness": 50.0}, {"substeps": 4}),  # edge springs
])
def test_native_energy_changes_as_mujocos_own_where_mujoco_sums_the_models_potential(model, overrides, settings):
    scene = mjcable.scenes.get("hang", n_segments=20, damping=0.0, **overrides)
    sim = mjcable.Simulator(scene, model, **settings)
    ours, theirs = sim.energy(), _mujoco_energy(sim)
    sim.step(0.3)
    e = sim.energy(parts=True)
    assert e.stretch + e.bending + e.twist > 1e-6  # the elastic terms take part
    # MuJoCo's gravity also counts bodies that never move (anchors): compare changes
    assert e.total - ours == pytest.approx(_mujoco_energy(sim) - theirs, abs=1e-12)


@pytest.mark.parametrize("model, young, settings", [
    _param("composite", 2e6, {}),  # the cable plugin's passive torques (MuJoCo's energy leaves a plugin out)
    ("flexrod", 2e5, {"substeps": 4}),  # 1D flex bending (mj_energyPos leaves it out)
    ("joints", 2e6, {}),
])
@pytest.mark.parametrize("state", ["bent", "twisted"])
def test_elastic_energy_is_the_potential_of_mujocos_passive_forces(model, young, settings, state):
    """At rest (no damping, drag or velocity), MuJoCo's passive force is the elastic force: −∇U of energy()'s
    elastic parts, by central differences along every degree of freedom."""
    if state == "twisted" and model == "flexrod":
        pytest.skip("a flex has no frames to twist")
    sim = mjcable.Simulator(mjcable.scenes.get("hang", n_segments=12, damping=0.0, young=young), model, **settings)
    sim.step(0.2)  # a planar swing: bent, no twist
    m, d = sim.mj_model, sim.mj_data
    if state == "twisted":  # every ball joint turned about its segment axis by 0.1 rad: pure twist, straight
        for j in np.flatnonzero(m.jnt_type == mujoco.mjtJoint.mjJNT_BALL)[1:]:
            twist = np.array([math.cos(0.05), math.sin(0.05), 0.0, 0.0])
            back = m.body_quat[m.jnt_bodyid[j]] * np.array([1.0, -1.0, -1.0, -1.0])
            quat = np.empty(4)
            mujoco.mju_mulQuat(quat, back, twist)
            d.qpos[m.jnt_qposadr[j]:m.jnt_qposadr[j] + 4] = quat
    d.qvel[:] = 0.0
    mujoco.mj_forward(m, d)
    force = d.qfrc_passive.copy()
    q0 = d.qpos.copy()

    def elastic(dof, step):
        d.qpos[:] = q0
        mujoco.mj_integratePos(m, d.qpos, np.eye(m.nv)[dof] * step, 1.0)
        mujoco.mj_kinematics(m, d)
        mujoco.mj_flex(m, d)
        e = sim.energy(parts=True)
        return e.stretch + e.bending + e.twist

    eps = 1e-6
    gradient = np.array([(elastic(i, eps) - elastic(i, -eps)) / (2 * eps) for i in range(m.nv)])
    d.qpos[:] = q0
    assert np.abs(force).max() > 1e-4
    np.testing.assert_allclose(-gradient, force, atol=1e-7 * np.abs(force).max() + 1e-12)
    if state == "twisted" and model != "flexrod":
        assert sim.energy(parts=True).twist > 0.0


# -- the undamped swing ---------------------------------------------------------------------------------------------


def test_springs_energy_is_conserved_on_an_undamped_swinging_chain():
    scene, swing = _swing()
    energies = _energies(mjcable.Simulator(scene, "springs"), SWING_SECONDS)
    total = np.array([e.total for e in energies])
    assert np.max(np.abs(total - total[0])) < SPRINGS_DRIFT * swing
    # without its springs' energy the sum would swing by far more (the issue's 58 % of the excitation)
    moving = np.array([e.kinetic + e.gravity for e in energies])
    assert np.max(np.abs(moving - moving[0])) > 10 * SPRINGS_DRIFT * swing


def test_xpbd_numerical_damping_is_first_order_in_the_substep():
    """Implicit Euler damps a mode of frequency ω at the rate ω² h / 2: a quarter of the substep loses about a
    quarter of the energy (the swing's, over the same time)."""
    scene, swing = _swing()
    loss = {}
    for substeps in (1, 4):
        energies = _energies(mjcable.Simulator(scene, "xpbd", substeps=substeps), 4.0)
        loss[substeps] = (energies[0].total - energies[-1].total) / swing
    assert 0.0 < loss[4] < loss[1]
    assert loss[4] / loss[1] == pytest.approx(0.25, abs=0.08)


# -- statics: stretch and bending against continuum mechanics -------------------------------------------------------


@pytest.mark.parametrize("model, settings", [("springs", {}), ("flexrod", {}), ("xpbd", {}),
                                             ("xpbd", {"order": "gauss-seidel", "iterations": 50})])
def test_stretch_energy_of_a_cable_hanging_under_its_weight_is_continuum_mechanics(model, settings):
    """A 1 m cable of E·A = 10 N hangs from its top: its tension at arc length s (from the top) is T = w (L − s),
    its strain T / E·A, and its stretch energy ∫ T² / (2 E·A) ds = w² L³ / (6 E·A) (16 mJ; the lumped masses put
    each segment's tension at its midpoint's, −1/(4 n²) of the integral)."""
    length, ea, n = 1.0, 10.0, 20
    cable = mjcable.CableSpec([[0, 0, 2.0], [0, 0, 2.0 - length]], n, 0.005, 0.1, stretch_stiffness=ea, damping=20.0)
    sim = mjcable.Simulator(mjcable.Scene(cable, pins=(mjcable.Pin(0),)), model, **settings)
    sim.step(SETTLE_SECONDS)
    assert np.abs(sim.velocities).max() < 1e-4
    w = cable.mass * G / length
    e = sim.energy(parts=True)
    assert e.stretch == pytest.approx(w**2 * length**3 / (6 * ea), rel=0.005)
    assert e.bending == e.twist == 0.0


@pytest.mark.parametrize("model", model_params(models=("joints", "composite", "jakobsen", "pbd")))
def test_rigid_and_hard_segments_store_no_stretch_energy(model):
    cable = mjcable.CableSpec([[0, 0, 2.0], [0.5, 0, 1.5]], 10, 0.005, 0.1, damping=5.0)
    sim = mjcable.Simulator(mjcable.Scene(cable, pins=(mjcable.Pin(0),)), model)
    sim.step(0.5)
    assert sim.energy(parts=True).stretch == 0.0


def _beam_energy(weight: float, length: float, ei: float, start: float = 0.0) -> float:
    """∫ M² / (2 E I) ds from ``start`` to L of a cantilever clamped at s = 0 under its weight w per metre:
    M(s) = w (L − s)² / 2, so the integral is w² (L − start)⁵ / (40 E I) (Euler-Bernoulli)."""
    return weight**2 * (length - start) ** 5 / (40.0 * ei)


@pytest.mark.parametrize("model, clamp_gap", [("xpbd", 0.0), ("joints", 0.0), _param("composite", 0.0),
                                              ("flexrod", 0.5)])
def test_bending_energy_of_a_cantilever_is_beam_theory(model, clamp_gap):
    """A clamped horizontal rod at q L³ / E I = 0.1 (small deflections). XPBD's clamp carries half a Voronoi cell
    of curvature (a ghost particle), the capsule chains' clamp a half-segment joint: the whole rod. The flex's first
    bending vertex sits one segment from the clamp, standing for the curvature of one segment around it: the first
    half segment does not bend, so its rod is beam theory's from s = l₀ / 2 on (12 % less energy at 20 segments, as
    its tip deflection)."""
    second_moment = math.pi * 0.005**4 / 4
    weight = scenarios.MASS * G
    ei = weight * 1.0**3 / BEAM_LOAD
    scene = scenarios.cantilever_scene(BEAM_SEGMENTS, young=ei / second_moment)
    settings = {"substeps": flexrod.stable_substeps(scene, 0.002)} if model == "flexrod" else {}
    sim = mjcable.Simulator(scene, model, **settings)
    sim.step(SETTLE_SECONDS)
    assert np.abs(sim.velocities).max() < 1e-6
    e = sim.energy(parts=True)
    expected = _beam_energy(weight, 1.0, ei, clamp_gap * scene.cable.segment_length)
    assert e.bending == pytest.approx(expected, rel=0.01)
    assert e.stretch == 0.0 and e.twist == pytest.approx(0.0, abs=1e-12 * expected)
