"""The capsule-chain native models ``joints`` and ``composite`` against physics.

References are independent of the models: the analytic inextensible catenary (``conftest.catenary_at_arc``),
Euler-Bernoulli beam theory for a heavy cantilever, and the geometry of the scenes (pin positions, table top).
"""

import math

import mujoco
import numpy as np
import pytest

import mjcable
from catalog_params import model_params
from mjcable.mjcf import world
from mjcable.mjcf.world import START_KEY
from mjcable.scene import GRAVITY, CableSpec, Pin, Scene
from mjcable.scenes import HANG_HEIGHT, HANG_LENGTH, HANG_SPAN, TABLE_TOP

MODELS = model_params(models=["joints", "composite"])  # composite carries its marker
CATENARY_TOL = 5e-3  # m, every particle, at the default dt
REST_SPEED = 1e-3  # m/s: a cable slower than this everywhere is at rest
PIN_TOL = 1e-3  # m: how far a particle held by a soft connect equality may sit from its anchor
BEAM_TOL = 0.02  # relative: discrete chain vs beam theory (at particle 1 the half-segment joint's bend, (2/3) l₀/L)
FREE_FALL_TOL = 1e-2  # relative: semi-implicit Euler's first-order error after 250 steps is 1/250
G = -GRAVITY[2]
GRIPPER_SPEED = 0.5  # m/s: the environments' fastest gripper axis speed
GRIPPER_REACH = 0.3  # m: how far from its start the randomly moving gripper may wander


def _speed(sim: mjcable.Simulator, seconds: float = 0.02) -> float:
    before = sim.positions
    sim.step(seconds)
    return float(np.linalg.norm(sim.positions - before, axis=1).max() / seconds)


def _socket_force(sim: mjcable.Simulator, k: int) -> float:
    """The socket's force on the plug in the last MuJoCo step: the vector sum of the constraint forces of the
    connect equalities ``pin{k}`` and ``pin{k}_clamp`` (0 once released)."""
    mj_model, mj_data = sim.mj_model, sim.mj_data
    rows = mj_data.efc_type[: mj_data.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    total = np.zeros(3)
    for clamp in (False, True):
        eq = mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_EQUALITY, world.pin_equality(k, clamp=clamp))
        force = mj_data.efc_force[: mj_data.nefc][rows & (mj_data.efc_id[: mj_data.nefc] == eq)][:3]
        if force.size:
            total += force
    return float(np.linalg.norm(total))


@pytest.mark.slow  # (keeps the quick suite of a cold clone under 5 minutes)
@pytest.mark.parametrize("model", MODELS)
def test_hang_settles_to_the_inextensible_catenary(model, catenary):
    scene = mjcable.scenes.get("hang", damping=3.0)  # 50 segments, limp
    sim = mjcable.Simulator(scene, model)  # default dt = 0.002
    sim.step(5.0)
    assert _speed(sim) < REST_SPEED
    s = np.arange(scene.cable.n_particles) * scene.cable.segment_length
    error = np.linalg.norm(sim.positions - catenary(HANG_LENGTH, HANG_SPAN, HANG_HEIGHT, s), axis=1)
    assert error.max() < CATENARY_TOL, f"{model}: {error.max() * 1e3:.2f} mm at particle {error.argmax()}"


@pytest.mark.parametrize("model", MODELS)
def test_mass_and_rest_length(model):
    scene = mjcable.scenes.get("socket")  # a gripper (massless mocap body) and a socket
    sim = mjcable.Simulator(scene, model)
    assert np.sum(sim.mj_model.body_mass) == pytest.approx(scene.cable.mass, rel=1e-12)
    cable_bodies = sim.mj_model.body_mass > 0
    np.testing.assert_allclose(sim.mj_model.body_mass[cable_bodies], scene.cable.mass / scene.cable.n_segments)
    assert np.count_nonzero(cable_bodies) == scene.cable.n_segments
    np.testing.assert_allclose(sim.positions, scene.cable.particles, atol=1e-12)
    sim.step(0.5)
    chords = np.linalg.norm(np.diff(sim.positions, axis=0), axis=1)
    np.testing.assert_allclose(chords, scene.cable.segment_length, rtol=1e-9)  # inextensible by construction
    assert chords.sum() == pytest.approx(scene.cable.length, rel=1e-9)


# composite steps the same capsule chain as joints (identical trajectories): its runs go with the slow tests
@pytest.mark.parametrize("model", ["joints", pytest.param("composite", marks=[pytest.mark.slow, pytest.mark.composite])])
@pytest.mark.parametrize("scene_name", mjcable.scenes.names())
def test_builtin_scenes_run(model, scene_name):
    scene = mjcable.scenes.get(scene_name)
    sim = mjcable.Simulator(scene, model)
    sim.step(2.0)  # SimulationDivergedError on any MuJoCo warning, NaN or runaway
    assert np.all(np.isfinite(sim.positions))
    if scene_name == "table":  # resting on the top, not through it
        np.testing.assert_allclose(sim.positions[:, 2], TABLE_TOP + scene.cable.radius, atol=1e-3)
    if scene_name == "drape":  # still over the peg
        peg = scene.obstacles[1]
        assert sim.positions[:, 2].max() == pytest.approx(peg.pos[2] + peg.radius + scene.cable.radius, abs=2e-3)


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("young", [0.0, 1e7])
def test_builtin_scenes_step_from_compiled_pose(model, young):
    """Plain mj_step from qpos0 (or the start keyframe) for 2 s raises no MuJoCo warning."""
    for name in ("hang", "socket", "drape"):
        scene = mjcable.scenes.get(name, young=young, n_segments=20)
        mj_model = mjcable.build(scene, model).compile()
        mj_data = mujoco.MjData(mj_model)
        key = mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_KEY, START_KEY)
        if key >= 0:
            mujoco.mj_resetDataKeyframe(mj_model, mj_data, key)
        mujoco.mj_step(mj_model, mj_data, nstep=round(2.0 / mj_model.opt.timestep))
        assert not np.any(mj_data.warning.number), f"{name}: warnings {mj_data.warning.number}"


@pytest.mark.parametrize("model", MODELS)
def test_stiff_cable_has_a_straight_rest_shape(model):
    """With E > 0 the start shape is posed (keyframe or compiled) while the reference shape is straight: without
    gravity, a bent cable that is free unbends."""
    points = [[0.0, 0.0, 1.0], [0.15, 0.0, 1.1], [0.3, 0.0, 1.0]]
    scene = Scene(CableSpec(points, 15, 0.005, 0.02, young=5e6, damping=5.0))
    spec = mjcable.build(scene, model)
    spec.option.gravity = [0.0, 0.0, 0.0]
    mj_model = spec.compile()
    mj_data = mujoco.MjData(mj_model)
    key = mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_KEY, START_KEY)
    if key >= 0:
        mujoco.mj_resetDataKeyframe(mj_model, mj_data, key)
    sites = [mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_SITE, world.particle_site(i)) for i in range(16)]
    mujoco.mj_forward(mj_model, mj_data)
    np.testing.assert_allclose(mj_data.site_xpos[sites], scene.cable.particles, atol=1e-12)
    mujoco.mj_step(mj_model, mj_data, nstep=round(3.0 / mj_model.opt.timestep))
    mujoco.mj_kinematics(mj_model, mj_data)
    p = mj_data.site_xpos[sites]
    end_to_end = np.linalg.norm(p[-1] - p[0])
    assert end_to_end == pytest.approx(scene.cable.length, rel=1e-3)


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("root", ["world", "gripper"])
def test_cantilever_matches_beam_theory(model, root):
    length, n, radius, mass, young = 0.5, 40, 0.005, 0.02, 6e8  # tip deflection ≈ 2 % of the length
    straight = [[0.0, 0.0, 1.0], [length, 0.0, 1.0]]
    pins = (Pin(0, root, clamp=True),)
    stiff = Scene(CableSpec(straight, n, radius, mass, young=young, damping=20.0), pins=pins)
    limp = Scene(CableSpec(straight, n, radius, mass, damping=20.0), pins=pins)
    q = mass * G / length
    ei = young * stiff.cable.second_moment
    droop = {}
    for label, scene in (("stiff", stiff), ("limp", limp)):
        sim = mjcable.Simulator(scene, model)
        sim.step(2.0)
        droop[label] = 1.0 - sim.positions[-1, 2]
        np.testing.assert_allclose(sim.positions[0], scene.cable.particles[0], atol=1e-9)  # the clamp holds
        if label == "limp":  # a limp cable's clamp holds its first segment
            np.testing.assert_allclose(sim.positions[1], scene.cable.particles[1], atol=1e-9)
        else:  # a stiff one holds the tangent at the particle: segment 0 bends away as the beam does there
            x = scene.cable.segment_length
            beam_at_x = q * x**2 * (6 * length**2 - 4 * length * x + x**2) / (24 * ei)
            assert 1.0 - sim.positions[1, 2] == pytest.approx(beam_at_x, rel=BEAM_TOL)
    assert droop["stiff"] < 0.1 * droop["limp"]
    beam = q * length**4 / (8.0 * ei)
    assert droop["stiff"] == pytest.approx(beam, rel=BEAM_TOL)


@pytest.mark.parametrize("model", MODELS)
def test_socket_releases_only_above_its_force(model):
    scene = mjcable.scenes.get("socket")
    socket, gripper = 0, 1
    release = scene.pins[socket].release_force
    sim = mjcable.Simulator(scene, model)
    start = scene.cable.particles[-1]

    # Pushing gently towards the socket: no release.
    for t in np.arange(1, 251) * sim.dt:
        sim.move_gripper(gripper, start + np.array([-0.1, 0.0, 0.0]) * t / 0.5)
        sim.step()
        assert _socket_force(sim, socket) < release
    assert not sim.released

    # Pulling slowly away: the force rises through release_force, then the socket lets go for good.
    seen = []
    end = start + np.array([-0.1, 0.0, 0.0])
    for t in np.arange(1, 2001) * sim.dt:
        sim.move_gripper(gripper, end + np.array([0.25, 0.0, 0.0]) * t)
        sim.step()
        seen.append(_socket_force(sim, socket))  # the last force it saw, even in the step that released it
        if sim.released:
            break
    assert sim.released == {socket}
    assert seen[-1] > release
    assert max(seen[:-1]) <= release
    tip = sim.positions[0]
    sim.step(0.2)
    assert np.linalg.norm(sim.positions[0] - tip) > 0.01  # the plug end moves freely now
    assert _socket_force(sim, socket) == 0.0


PIN_CASES = [(kind, index, clamp) for kind in ("world", "gripper", "socket") for index in (0, -1)
             for clamp in (False, True)]


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("kind,index,clamp", PIN_CASES)
def test_every_pin_kind_holds(model, kind, index, clamp):
    """A horizontal limp cable held at one end: the held particle (and with a clamp its neighbour, so the tangent)
    stays with its anchor while the rest falls; a gripper carries them along."""
    points = [[-0.3, 0.0, 1.0], [0.3, 0.0, 1.0]]
    release = {"release_force": 1e3} if kind == "socket" else {}
    scene = Scene(CableSpec(points, 12, 0.005, 0.05, damping=1.0), pins=(Pin(index, kind, clamp=clamp, **release),))
    sim = mjcable.Simulator(scene, model)
    held = [scene.pin_particle(0)] + ([scene.clamp_neighbour(0)] if clamp else [])
    free_end = scene.cable.n_segments - scene.pin_particle(0)
    shift = np.array([0.0, 0.05, 0.1]) if kind == "gripper" else np.zeros(3)
    steps = 250  # move over 0.5 s, then hold for 0.5 s (a connect equality trails a moving anchor by ~1 mm)
    for s in range(1, 2 * steps + 1):
        if kind == "gripper":
            sim.move_gripper(0, scene.cable.particles[held[0]] + shift * min(s, steps) / steps)
        sim.step()
    np.testing.assert_allclose(sim.positions[held], scene.cable.particles[held] + shift, atol=PIN_TOL)
    assert sim.positions[free_end, 2] < 1.0 + shift[2] - 0.2  # the rest swings down


def _random_gripper_walk(sim: mjcable.Simulator, k: int, seconds: float, seed: int) -> np.ndarray:
    """Move gripper ``k`` at ``GRIPPER_SPEED`` in a new random direction every 10 steps for ``seconds``, reflected
    back whenever it would leave the ball of radius ``GRIPPER_REACH`` around its start; return its last position."""
    rng = np.random.default_rng(seed)
    home = sim.positions[sim.scene.pin_particle(k)].copy()
    pos, velocity = home.copy(), np.zeros(3)
    for s in range(round(seconds / sim.dt)):
        if s % 10 == 0:
            direction = rng.normal(size=3)
            velocity = GRIPPER_SPEED * direction / np.linalg.norm(direction)
        if np.linalg.norm(pos + velocity * sim.dt - home) > GRIPPER_REACH:
            velocity = -velocity
        pos = pos + velocity * sim.dt
        sim.move_gripper(k, pos)
        sim.step()  # SimulationDivergedError on any MuJoCo warning (mjWARN_BADQACC), NaN or runaway
    return pos


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("socket", [False, True])
@pytest.mark.parametrize("seed", [1, pytest.param(2, marks=pytest.mark.slow)])  # seed 2 with the slow tests
def test_far_end_gripper_moving_randomly_stays_stable(model, socket, seed):
    """A gripper holding the cable's far end (particle n, not the chain's first particle), moved at 0.5 m/s in
    random directions for 3 s, keeps the simulation finite and warning-free and carries its particle along; with a
    weak socket at particle 0 (the ``unplug`` task) the plug is yanked out early and then dangles."""
    hang = mjcable.scenes.get("hang")
    pins = ((Pin(0, "socket", release_force=0.5),) if socket else ()) + (Pin(-1, "gripper"),)
    scene = Scene(hang.cable, pins=pins)
    gripper = len(pins) - 1
    sim = mjcable.Simulator(scene, model)
    pos = _random_gripper_walk(sim, gripper, 3.0, seed)
    assert np.all(np.isfinite(sim.positions))
    assert not np.any(sim.mj_data.warning.number)
    np.testing.assert_allclose(sim.positions[-1], pos, atol=PIN_TOL)
    chords = np.linalg.norm(np.diff(sim.positions, axis=0), axis=1)
    np.testing.assert_allclose(chords, scene.cable.segment_length, rtol=1e-9)  # still one inextensible chain
    if socket:
        assert sim.released == {0}


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("seed", [1, pytest.param(2, marks=pytest.mark.slow)])  # seed 2 with the slow tests
def test_stiff_clamped_cable_stays_stable_under_a_randomly_moving_clamped_gripper(model, seed):
    """A stiff ``hang`` cable (E = 1e7 Pa) clamped in the world at particle 0 and by a gripper at particle n (the
    frames at both ends held by clamp bodies and their connects), the gripper moved at 0.5 m/s in random directions
    for 2 s (the world pin trails by a few mm meanwhile, as with a limp cable: the gripper roots the tree and carries
    the chain each step; the monitor raises beyond 2 cm), then held for 0.5 s: warning-free, both ends on their pins
    and the world clamp's tangent kept (its clamp site, a segment in, within ``PIN_TOL`` of its anchor)."""
    hang = mjcable.scenes.get("hang", young=1e7)
    scene = Scene(hang.cable, pins=(Pin(0, clamp=True), Pin(-1, "gripper", clamp=True)))
    sim = mjcable.Simulator(scene, model)
    pos = _random_gripper_walk(sim, 1, 2.0, seed)
    sim.step(0.5)
    assert not np.any(sim.mj_data.warning.number)
    np.testing.assert_allclose(sim.positions[[0, -1]], [scene.cable.particles[0], pos], atol=PIN_TOL)
    site = mujoco.mj_name2id(sim.mj_model, mujoco.mjtObj.mjOBJ_SITE, world.clamp_site(0))
    anchor = mujoco.mj_name2id(sim.mj_model, mujoco.mjtObj.mjOBJ_SITE, f"{world.anchor_site(0)}_clamp")
    assert np.linalg.norm(sim.mj_data.site_xpos[site] - sim.mj_data.site_xpos[anchor]) < PIN_TOL


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("n_segments", [1, 2, 3])
def test_short_chains(model, n_segments):
    scene = Scene(CableSpec([[0.0, 0.0, 1.0], [0.2, 0.0, 0.9]], n_segments, 0.005, 0.01), pins=(Pin(0),))
    sim = mjcable.Simulator(scene, model)
    sim.step(0.5)
    assert sim.positions.shape == (n_segments + 1, 3)
    np.testing.assert_allclose(sim.positions[0], scene.cable.particles[0], atol=1e-9)


@pytest.mark.parametrize("model", MODELS)
def test_free_fall(model):
    """Damping is a drag on velocities only: with c = 0 a free cable falls exactly as g t² / 2."""
    scene = Scene(CableSpec([[0.0, 0.0, 1.0], [0.3, 0.0, 1.05]], 10, 0.005, 0.02))
    sim = mjcable.Simulator(scene, model)
    sim.step(0.5)
    drop = scene.cable.particles[:, 2] - sim.positions[:, 2]
    np.testing.assert_allclose(drop, 0.5 * G * sim.time**2, rtol=FREE_FALL_TOL)


@pytest.mark.composite
def test_composite_plugin_moduli():
    from mjcable.mjcf import composite

    scene = mjcable.scenes.get("hang", young=3e6)
    spec = mjcable.build(scene, "composite")
    xml = spec.to_xml()
    assert 'plugin="mujoco.elasticity.cable"' in xml
    bend, twist = composite.plugin_moduli(scene)
    assert bend == 3e6 and twist == pytest.approx(3e6 / (2 * (1 + 0.5)))
    assert "mujoco.elasticity.cable" not in mjcable.build(mjcable.scenes.get("hang"), "composite").to_xml()


def test_joints_stiffness_is_ei_over_l0():
    scene = mjcable.scenes.get("hang", young=2e6)
    mj_model = mjcable.build(scene, "joints").compile()
    stiffness = mj_model.jnt_stiffness[mj_model.jnt_type == mujoco.mjtJoint.mjJNT_BALL]
    expected = 2e6 * math.pi * scene.cable.radius**4 / 4 / scene.cable.segment_length
    assert stiffness[0] == 0.0  # hang's world pin at particle 0: a ball joint free to rotate
    np.testing.assert_allclose(stiffness[1:], expected)
    assert stiffness.size == scene.cable.n_segments
