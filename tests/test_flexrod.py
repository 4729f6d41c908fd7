"""The ``flexrod`` native model (a MuJoCo 1D flex) against physics and independent references."""

import math
import warnings

import mujoco
import numpy as np
import pytest

import mjcable
from mjcable import CableSpec, Floor, Pin, Scene
from mjcable.mjcf import flexrod
from mjcable.mjcf.world import START_KEY
from mjcable.scene import GRAVITY
from mjcable.scenes import HANG_HEIGHT, HANG_LENGTH, HANG_SPAN, TABLE_TOP

MODEL = "flexrod"
G = -GRAVITY[2]  # m/s²
CATENARY_TOL = 5e-3  # m, every particle, at the default dt
STRAIN_TOL = 1e-3  # the flex edge equality must keep a 100-segment cable this inextensible
BEAM_TOL = 0.02  # relative, tip deflection vs Euler-Bernoulli (small deflection)


def _steady(sim: mjcable.Simulator, seconds: float = 0.05) -> float:
    """The fastest particle's mean speed (m/s) over the next ``seconds``."""
    before = sim.positions
    sim.step(seconds)
    return float(np.linalg.norm(sim.positions - before, axis=1).max() / seconds)


def _equality_force(sim: mjcable.Simulator, name: str) -> float:
    """Norm of the force (N) of connect equality ``name`` in the last step (its first three constraint rows)."""
    mj_model, mj_data = sim.mj_model, sim.mj_data
    eq = mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_EQUALITY, name)
    n = mj_data.nefc
    rows = (mj_data.efc_type[:n] == mujoco.mjtConstraint.mjCNSTR_EQUALITY) & (mj_data.efc_id[:n] == eq)
    return float(np.linalg.norm(mj_data.efc_force[:n][rows][:3]))


def test_settles_to_the_inextensible_catenary(catenary):
    scene = mjcable.scenes.get("hang", n_segments=50, damping=3.0)
    sim = mjcable.Simulator(scene, MODEL)  # default dt = 0.002
    sim.step(6.0)
    assert _steady(sim) < 1e-3
    s = np.arange(scene.cable.n_particles) * scene.cable.segment_length
    error = np.linalg.norm(sim.positions - catenary(HANG_LENGTH, HANG_SPAN, HANG_HEIGHT, s), axis=1)
    assert error.max() < CATENARY_TOL, f"max error {error.max() * 1e3:.2f} mm at particle {error.argmax()}"
    assert HANG_HEIGHT - sim.positions[:, 2].min() == pytest.approx(0.2654, abs=CATENARY_TOL)


def test_edge_strain_of_a_100_segment_hanging_cable_stays_below_1e_3():
    scene = mjcable.scenes.get("hang", n_segments=100)
    sim = mjcable.Simulator(scene, MODEL, dt=0.002)
    worst = 0.0
    for _ in range(1000):  # 2 s: the swing from the spline start shape and the settling
        sim.step()
        chords = np.linalg.norm(np.diff(sim.positions, axis=0), axis=1)
        worst = max(worst, float(np.abs(chords / scene.cable.segment_length - 1.0).max()))
    assert worst < STRAIN_TOL, f"max edge strain {worst:.3g}"


@pytest.mark.parametrize("young", [0.0, 1e6])
def test_mass_and_rest_length_are_the_cables(young):
    scene = mjcable.scenes.get("socket", young=young)  # a gripper and a clamped socket: extra bodies and sites
    sim = mjcable.Simulator(scene, MODEL, substeps=flexrod.stable_substeps(scene, 0.002))
    mj_model = sim.mj_model
    bodies = [mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_BODY, flexrod.vertex_body(i))
              for i in range(scene.cable.n_particles)]
    np.testing.assert_allclose(mj_model.body_mass[bodies], scene.cable.particle_masses, rtol=1e-12)
    assert mj_model.body_mass[bodies].sum() == pytest.approx(scene.cable.mass, rel=1e-12)
    assert mj_model.flexedge_length0.sum() == pytest.approx(scene.cable.length, rel=1e-9)
    np.testing.assert_allclose(mj_model.flexedge_length0, scene.cable.segment_length, rtol=1e-9)
    assert mj_model.flex_radius[0] == scene.cable.radius
    np.testing.assert_allclose(sim.positions, scene.cable.particles, atol=1e-12)


def test_every_vertex_is_a_point_mass_on_three_slide_joints():
    scene = mjcable.scenes.get("hang", n_segments=10)
    mj_model = mjcable.build(scene, MODEL).compile()
    n = scene.cable.n_particles
    assert mj_model.nq == mj_model.nv == 3 * n
    assert np.all(mj_model.jnt_type == mujoco.mjtJoint.mjJNT_SLIDE)
    np.testing.assert_array_equal(mj_model.flex_vertbodyid, [mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_BODY,
                                                                         flexrod.vertex_body(i)) for i in range(n)])
    np.testing.assert_allclose(mj_model.dof_damping, scene.cable.damping * np.repeat(scene.cable.particle_masses, 3))


@pytest.mark.parametrize("scene_name", mjcable.scenes.names())
def test_builtin_scenes_run_two_seconds(scene_name):
    sim = mjcable.Simulator(mjcable.scenes.get(scene_name), MODEL)
    sim.step(2.0)  # raises SimulationDivergedError on any MuJoCo warning, NaN or runaway
    assert not np.any(sim.mj_data.warning.number)


def test_cable_comes_to_rest_on_the_table_top():
    scene = mjcable.scenes.get("table", damping=2.0)
    sim = mjcable.Simulator(scene, MODEL)
    sim.step(2.0)
    assert _steady(sim) < 1e-2
    z = sim.positions[:, 2]
    resting = TABLE_TOP + scene.cable.radius
    assert np.abs(z - resting).max() < 1.5e-3, f"z in [{z.min():.4f}, {z.max():.4f}], expected {resting:.4f}"
    mj_data = sim.mj_data
    flex_contacts = mj_data.contact.flex[: mj_data.ncon, 1] == 0  # geom (table) vs flex 0
    assert flex_contacts.any() and np.all(mj_data.contact.dim[: mj_data.ncon][flex_contacts] == 3)


@pytest.mark.parametrize("friction, slides", [(0.6, False), (0.2, True)])
def test_coulomb_friction_on_an_incline(friction, slides):
    slope = math.radians(20.0)  # tan = 0.364
    normal = np.array([math.sin(slope), 0.0, math.cos(slope)])
    downhill = np.array([math.cos(slope), 0.0, -math.sin(slope)])
    radius = 0.005
    ends = np.array([-0.2 * downhill, 0.2 * downhill]) + radius * normal + np.array([0.0, 0.0, 0.5])
    floor = Floor(pos=(0.0, 0.0, 0.5), euler=(0.0, math.degrees(slope), 0.0))
    scene = Scene(CableSpec(ends, 20, radius, 0.05, friction=friction), obstacles=(floor,))
    sim = mjcable.Simulator(scene, MODEL)
    start = sim.positions
    sim.step(1.0)
    travel = float(np.mean((sim.positions - start) @ downhill))
    if slides:  # a block on an incline: a = g (sin α − μ cos α)
        expected = 0.5 * G * (math.sin(slope) - friction * math.cos(slope)) * 1.0**2
        assert travel == pytest.approx(expected, rel=0.05)
    else:  # μ > tan α holds it; MuJoCo's soft friction lets it creep slowly (world.py's obstacle contact softness)
        assert abs(travel) < 1e-2


def test_damping_rate_decays_free_fall_velocity():
    rate = 2.0  # 1/s
    scene = Scene(CableSpec([[0, 0, 5], [1, 0, 5]], 10, 0.005, 0.1, damping=rate))
    sim = mjcable.Simulator(scene, MODEL)
    sim.step(1.0)
    # m dv/dt = −m g − c m v  ⇒  v(t) = −(g / c)(1 − e^{−c t}); implicit Euler per step: v ← (v − g h) / (1 + c h)
    expected = -(G / rate) * (1.0 - math.exp(-rate * sim.time))
    v = sim.mj_data.qvel.reshape(-1, 3)
    np.testing.assert_allclose(v[:, 2], expected, rtol=2e-3)
    np.testing.assert_allclose(v[:, :2], 0.0, atol=1e-9)


def test_bending_moment_of_a_small_kink_is_ei_times_curvature():
    young, radius, length = 1e7, 0.005, 0.02
    cable = CableSpec([[0, 0, 1], [2 * length, 0, 1]], 2, radius, 0.01, young=young)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # too stiff to step at this dt; only forces are read here
        mj_model = mjcable.build(Scene(cable), MODEL).compile()
    mj_data = mujoco.MjData(mj_model)
    theta = 1e-3  # rad: turn the last edge about the middle vertex
    mj_data.qpos[6:9] = length * np.array([math.cos(theta) - 1.0, 0.0, math.sin(theta)])
    mujoco.mj_forward(mj_model, mj_data)
    # Euler-Bernoulli: moment M = E·I κ with κ = θ / l (Voronoi length l); the end force is F = M / l
    expected = cable.bending_stiffness * theta / length**2
    force = mj_data.qfrc_passive.reshape(3, 3)[2]
    assert np.linalg.norm(force) == pytest.approx(expected, rel=1e-3)
    assert force[2] < 0  # it pushes the kink back


def test_cantilever_tip_deflection_matches_beam_theory():
    length, n, mass, radius, young = 0.5, 25, 0.05, 0.005, 6.3e8
    cable = CableSpec([[0, 0, 1], [length, 0, 1]], n, radius, mass, young=young, damping=40.0)
    scene = Scene(cable, pins=(Pin(0, clamp=True),))
    sim = mjcable.Simulator(scene, MODEL, substeps=flexrod.stable_substeps(scene, 0.002))
    sim.step(1.0)
    assert _steady(sim) < 1e-4
    tip = 1.0 - sim.positions[-1, 2]
    # Clamping particles 0 and 1 fixes the first segment; the curvature at vertex i stands for the arc of length l₀
    # around it, so the bending starts at s = l₀/2: a beam of free length L − l₀/2 under the load q = m g / L.
    q = mass * G / length
    free = length - cable.segment_length / 2
    expected = q * free**4 / (8 * cable.bending_stiffness)
    assert expected / length < 0.05  # small deflection
    assert tip == pytest.approx(expected, rel=BEAM_TOL)
    assert tip == pytest.approx(q * length**4 / (8 * cable.bending_stiffness), rel=0.1)

    limp = mjcable.Simulator(scene.with_cable(young=0.0), MODEL)
    limp.step(1.0)
    assert tip < 0.2 * (1.0 - limp.positions[-1, 2])


def test_stiff_cable_compiles_straight_and_starts_from_the_keyframe():
    scene = mjcable.scenes.get("hang", young=1e6)
    spec = mjcable.build(scene, MODEL)
    mj_model = spec.compile()
    assert mj_model.nkey == 1 and mujoco.mj_id2name(mj_model, mujoco.mjtObj.mjOBJ_KEY, 0) == START_KEY
    mj_data = mujoco.MjData(mj_model)
    mujoco.mj_forward(mj_model, mj_data)
    sites = [mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_SITE, f"particle{i}")
             for i in range(scene.cable.n_particles)]
    chords = np.diff(mj_data.site_xpos[sites], axis=0)
    np.testing.assert_allclose(chords, np.broadcast_to(chords[0], chords.shape), atol=1e-12)  # straight
    mujoco.mj_step(mj_model, mj_data, nstep=1000)  # the default pose steps 2 s without warnings
    assert not np.any(mj_data.warning.number)

    sim = mjcable.Simulator(scene, MODEL)
    np.testing.assert_allclose(sim.positions, scene.cable.particles, atol=1e-12)
    sim.step(0.01)
    assert np.abs(sim.positions - scene.cable.particles).max() < 1e-3  # all pins satisfied at the start


def test_too_stiff_a_cable_warns_and_stable_substeps_fix_it():
    scene = mjcable.scenes.get("hang", young=1e7)
    with pytest.warns(UserWarning, match="substeps"):
        mjcable.build(scene, MODEL)
    substeps = flexrod.stable_substeps(scene, 0.002)
    assert substeps > 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim = mjcable.Simulator(scene, MODEL, substeps=substeps)
    sim.step(1.0)


def test_finite_stretch_stiffness_stretches_a_hanging_cable_by_mgl_over_2ea():
    ea, mass, length = 20.0, 0.1, 1.0  # N, kg, m: soft enough for explicit edge springs at dt = 0.002
    cable = CableSpec([[0, 0, 2], [0, 0, 2 - length]], 20, 0.005, mass, stretch_stiffness=ea, damping=5.0)
    scene = Scene(cable, pins=(Pin(0),))
    assert flexrod.uses_edge_springs(scene, 0.002)
    sim = mjcable.Simulator(scene, MODEL)
    sim.step(3.0)
    assert _steady(sim) < 1e-3
    stretch = float(np.linalg.norm(np.diff(sim.positions, axis=0), axis=1).sum()) - length
    assert stretch == pytest.approx(mass * G * length / (2 * ea), rel=0.02)


def test_socket_releases_only_above_its_release_force():
    scene = mjcable.scenes.get("socket", damping=1.0)
    release = scene.pins[0].release_force
    sim = mjcable.Simulator(scene, MODEL)
    sim.step(0.5)
    socket = sim.mj_data.site_xpos[mujoco.mj_name2id(sim.mj_model, mujoco.mjtObj.mjOBJ_SITE, "anchor0")].copy()
    grip = scene.cable.particles[-1].copy()
    eq = mujoco.mj_name2id(sim.mj_model, mujoco.mjtObj.mjOBJ_EQUALITY, "pin0")
    forces, span_at_release = [], None
    for _ in range(2000):  # pull away at 0.1 m/s
        grip += np.array([0.1 * sim.dt, 0.0, 0.0])
        sim.move_gripper(1, grip)
        sim.step()
        if not sim.mj_data.eq_active[eq]:
            span_at_release = float(np.linalg.norm(grip - socket))
            break
        forces.append(_equality_force(sim, "pin0"))
    assert span_at_release is not None, "the socket never let go"
    assert max(forces) < release  # held while its force stayed below the release force
    assert span_at_release > 0.97 * scene.cable.length  # it let go only once the cable was pulled taut
    sim.step(0.2)
    assert np.linalg.norm(sim.positions[0] - socket) > 0.01  # the plug came out


def test_socket_holds_when_pushed_gently():
    scene = mjcable.scenes.get("socket", damping=1.0)
    sim = mjcable.Simulator(scene, MODEL)
    eq = mujoco.mj_name2id(sim.mj_model, mujoco.mjtObj.mjOBJ_EQUALITY, "pin0")
    grip = scene.cable.particles[-1].copy()
    for _ in range(500):  # 0.1 m towards the socket in 1 s
        grip -= np.array([0.1 * sim.dt, 0.0, 0.0])
        sim.move_gripper(1, grip)
        sim.step()
    sim.step(1.0)
    clamp = mujoco.mj_name2id(sim.mj_model, mujoco.mjtObj.mjOBJ_EQUALITY, "pin0_clamp")
    assert sim.mj_data.eq_active[eq] and sim.mj_data.eq_active[clamp]
    np.testing.assert_allclose(sim.positions[0], scene.cable.particles[0], atol=1e-3)


@pytest.mark.parametrize("self_collision", [False, True])
def test_self_collision_stacks_a_hairpin_on_itself(self_collision):
    radius = 0.005
    # the curve dips 1 cm below its lower control points at the bend: they sit 1.6 cm up, so it starts above the floor
    hairpin = [[-0.3, 0, 0.016], [0.2, 0, 0.016], [0.3, 0, 0.06], [0.2, 0, 0.11], [-0.3, 0, 0.11]]
    scene = Scene(CableSpec(hairpin, 60, radius, 0.05, damping=2.0), obstacles=(Floor(),))
    sim = mjcable.Simulator(scene, MODEL, self_collision=self_collision)
    sim.step(1.5)
    p = sim.positions
    leg = p[:, 0] < 0.0
    half = np.arange(len(p)) < len(p) // 2
    lower, upper = p[leg & half, 2].mean(), p[leg & ~half, 2].mean()
    assert lower == pytest.approx(radius, abs=1e-3)  # on the floor
    # the upper leg lies on the lower one (two radii higher) only with self-collision, else it falls through
    assert upper == pytest.approx(lower + (2 * radius if self_collision else 0.0), abs=1e-3)


def test_too_fine_a_taut_cable_warns_and_stable_substeps_fix_it():
    scene = mjcable.scenes.get("hang", n_segments=200)  # 0.6 m g of tension: the zigzag mode outruns dt = 0.002
    with pytest.warns(UserWarning, match="too fine"):
        mjcable.build(scene, MODEL)
    substeps = flexrod.stable_substeps(scene, 0.002)
    assert substeps == 2  # h < sqrt(mᵢ l₀ / (m g)) = sqrt(L / g) / n = 1.6 ms
    sim = mjcable.Simulator(scene, MODEL, substeps=substeps)
    sim.step(0.5)
    chords = np.linalg.norm(np.diff(sim.positions, axis=0), axis=1)
    assert np.abs(chords / scene.cable.segment_length - 1.0).max() < STRAIN_TOL


def test_stiff_cable_steps_with_an_integrator_this_mujoco_accepts_and_the_same_physics():
    """MuJoCo 4 refuses flex bending under implicitfast: a stiff flexrod then steps with Euler. Where both compile
    (MuJoCo 3.x), the two integrators give the same trajectory to the bit, so the switch keeps the physics."""
    scene = mjcable.scenes.get("hang", n_segments=20, young=1e5)
    spec = mjcable.build(scene, MODEL)
    implicit = flexrod._implicit_flex_elasticity()
    euler = mujoco.mjtIntegrator.mjINT_EULER
    assert spec.option.integrator == (mujoco.mjtIntegrator.mjINT_IMPLICITFAST if implicit else euler)
    trajectories = []
    for integrator in ([mujoco.mjtIntegrator.mjINT_IMPLICITFAST, euler] if implicit else [euler]):
        spec.option.integrator = integrator
        mj_model = spec.compile()
        mj_data = mujoco.MjData(mj_model)
        mujoco.mj_resetDataKeyframe(mj_model, mj_data, 0)
        for _ in range(250):
            mujoco.mj_step(mj_model, mj_data)
        trajectories.append(mj_data.qpos.copy())
    assert np.all(np.isfinite(trajectories[-1]))
    np.testing.assert_array_equal(trajectories[0], trajectories[-1])
