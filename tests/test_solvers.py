"""The particle solvers (jakobsen, pbd, xpbd) against physics: free fall, catenary, E·A elongation, beam theory,
Coulomb friction, socket release; plus their settings, proxy and failure modes."""

import math

import mujoco
import numba
import numpy as np
import pytest

import mjcable
from mjcable.mjcf import proxy
from mjcable.solvers import UserConstraint, cable_contact_kernels, kernels

G = 9.81
PARTICLE = ("jakobsen", "pbd", "xpbd")


def _com(sim) -> np.ndarray:
    m = sim.scene.cable.particle_masses
    return (sim.positions * m[:, None]).sum(axis=0) / m.sum()


def _hanging(*, n=50, length=1.0, mass=0.1, top=1.5, pin_kind="world", **fields) -> mjcable.Scene:
    """A straight vertical cable hanging from a pin on its top particle, at rest length (unstretched)."""
    release = fields.pop("release", None)
    cable = mjcable.CableSpec([[0, 0, top], [0, 0, top - length]], n, 0.005, mass, **fields)
    return mjcable.Scene(cable, pins=(mjcable.Pin(0, pin_kind, release_force=release),))


# -- free fall ---------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("model, settings, verlet", [
    ("xpbd", {}, False),
    ("xpbd", {"substeps": 7, "order": "direct"}, False),
    ("xpbd", {"order": "jacobi", "iterations": 3}, False),
    ("pbd", {"integrator": "euler"}, False),
    ("pbd", {"integrator": "verlet", "iterations": 2}, True),
    ("jakobsen", {"sqrt_approx": True}, True),
])
def test_free_fall_follows_the_integrators_exact_path(model, settings, verlet):
    cable = mjcable.CableSpec([[0, 0, 2], [0.6, 0.1, 2.3], [1, 0, 2]], 12, 0.005, 0.1)
    sim = mjcable.Simulator(mjcable.Scene(cable), model, dt=0.004, **settings)
    z0 = _com(sim)[2]
    sim.step(0.6)
    t, h = sim.time, sim.dt / sim.settings.substeps
    # Verlet started by Taylor's x₁ = x₀ + ½ g h² is exact for constant gravity; semi-implicit Euler from rest falls an
    # extra ½ g t h: z = z₀ − g h² k(k+1)/2 after k substeps.
    expected = z0 - 0.5 * G * t * t - (0.0 if verlet else 0.5 * G * t * h)
    assert _com(sim)[2] == pytest.approx(expected, abs=1e-9)
    np.testing.assert_allclose(_com(sim)[:2], cable.particles.T[:2] @ cable.particle_masses / cable.mass, atol=1e-12)


# -- catenary ----------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("model, settings", [
    ("xpbd", {"order": "direct"}),  # α = 0, one iteration, default dt and substeps
    ("xpbd", {"substeps": 20}),  # α = 0, Gauss-Seidel: 20 substeps × 1 iteration
    ("pbd", {"iterations": 50}),
    ("jakobsen", {"iterations": 50}),
])
def test_hanging_cable_settles_on_the_catenary(model, settings, catenary):
    scene = mjcable.scenes.get("hang", damping=20.0)  # 50 segments, 1 m over 0.8 m
    sim = mjcable.Simulator(scene, model, **settings)  # default dt = 0.002 s
    sim.step(1.5)
    c = scene.cable
    reference = catenary(1.0, 0.8, 1.0, np.arange(c.n_particles) * c.segment_length)
    assert np.max(np.linalg.norm(sim.positions - reference, axis=1)) < 1e-3


def test_jacobi_converges_towards_the_catenary_with_iterations(catenary):
    scene = mjcable.scenes.get("hang", damping=20.0)
    c = scene.cable
    reference = catenary(1.0, 0.8, 1.0, np.arange(c.n_particles) * c.segment_length)
    errors = []
    for iterations in (2, 8, 32):
        sim = mjcable.Simulator(scene, "xpbd", order="jacobi", omega=1.5, iterations=iterations)
        sim.step(1.0)
        errors.append(np.max(np.linalg.norm(sim.positions - reference, axis=1)))
    assert errors[0] > errors[1] > errors[2]


def test_direct_order_keeps_an_inextensible_hanging_cable_inextensible():
    sim = mjcable.Simulator(mjcable.scenes.get("hang", damping=20.0), "xpbd", order="direct")
    sim.step(1.0)
    strain = np.linalg.norm(np.diff(sim.positions, axis=0), axis=1) / sim.scene.cable.segment_length - 1.0
    assert np.max(np.abs(strain)) <= 1e-6


# -- stiffness effects: E·A elongation ----------------------------------------------------------------------------

EA = 50.0  # N
ITERATIONS = (1, 12, 25)
DTS = (0.02, 0.002, 0.0002)


def _elongation(model, iterations, dt, **settings) -> float:
    scene = _hanging(stretch_stiffness=EA, damping=20.0)
    sim = mjcable.Simulator(scene, model, dt=dt, iterations=iterations, **settings)
    sim.step(1.0)
    p = sim.positions
    return float(p[0, 2] - p[-1, 2]) - scene.cable.length


def test_xpbd_direct_elongation_is_e_a_theory_for_any_iterations_and_dt():
    theory = 0.1 * G * 1.0 / (2.0 * EA)  # W·L / 2EA for a cable hanging under its own weight
    grid = np.array([[_elongation("xpbd", it, dt, order="direct") for dt in DTS] for it in ITERATIONS])
    assert np.ptp(grid) / grid.mean() < 0.02
    np.testing.assert_allclose(grid, theory, rtol=0.05)


@pytest.mark.slow  # (keeps the quick suite of a cold clone under 5 minutes)
@pytest.mark.parametrize("model", ["pbd", "jakobsen"])
def test_pbd_and_jakobsen_stiffen_with_iterations_and_smaller_steps(model):
    """The thesis's accuracy- and timescale-stiffness effects (its Figs. 3.37–3.38) as numbers: with k = 1 the
    elongation is pure non-convergence, so it shrinks with more iterations and with smaller steps."""
    grid = np.array([[_elongation(model, it, dt) for dt in DTS] for it in ITERATIONS])
    assert np.all(np.diff(grid, axis=0) < 0)  # more iterations: stiffer
    assert np.all(np.diff(grid, axis=1) < 0)  # smaller dt: stiffer
    assert grid.max() / grid.min() > 100


# -- beam theory ---------------------------------------------------------------------------------------------------


def test_clamped_cantilever_matches_beam_theory():
    length, mass, radius, n = 1.0, 0.1, 0.005, 100
    q = mass * G / length
    ei = q * length**3 / 0.1  # q L³ / EI = 0.1
    cable = mjcable.CableSpec([[0, 0, 1], [length, 0, 1]], n, radius, mass,
                              young=ei / (math.pi * radius**4 / 4), damping=20.0)
    scene = mjcable.Scene(cable, pins=(mjcable.Pin(0, clamp=True),))
    sim = mjcable.Simulator(scene, "xpbd", order="direct")
    sim.step(1.0)
    deflection = 1.0 - sim.positions[-1, 2]
    assert deflection == pytest.approx(q * length**4 / (8 * ei), rel=0.02)


@pytest.mark.parametrize("model, settings", [
    ("jakobsen", {}),
    ("pbd", {}),
    ("xpbd", {"bend_compliance": 1e-5}),
    ("xpbd", {"bend_compliance": 1e-5, "order": "direct"}),
])
def test_next_neighbour_stick_bending_holds_a_clamped_cable_up(model, settings):
    cable = mjcable.CableSpec([[0, 0, 1], [0.3, 0, 1]], 8, 0.005, 0.1, damping=5.0)
    scene = mjcable.Scene(cable, pins=(mjcable.Pin(0, clamp=True),))
    tips = {}
    for bending in ("none", "distance"):
        extra = settings if bending == "distance" else {}
        sim = mjcable.Simulator(scene, model, bending=bending, iterations=20, substeps=5, **extra)
        sim.step(1.0)
        tips[bending] = sim.positions[-1, 2]
    assert tips["none"] < 1.0 - 0.2  # limp: it hangs from the clamp
    assert tips["distance"] > tips["none"] + 0.1  # the (i, i+2) sticks resist bending


# -- contacts and friction ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("model", PARTICLE)
def test_dropped_cable_rests_on_the_table(model):
    scene = mjcable.scenes.get("table")
    sim = mjcable.Simulator(scene, model, iterations=4)
    sim.step(1.5)
    top = scene.obstacles[1].pos[2] + scene.obstacles[1].size[2]
    z = sim.positions[:, 2]
    assert np.max(scene.cable.radius - (z - top)) < 1e-3  # penetration
    assert np.max(z - top) < scene.cable.radius + 1e-3  # lying on it, not floating
    assert sim.diagnostics["contacts"] > 0
    # the proxy capsules render where the cable is
    seg = [mujoco.mj_name2id(sim.mj_model, mujoco.mjtObj.mjOBJ_GEOM, proxy.segment_name(i)) for i in range(3)]
    np.testing.assert_allclose(sim.mj_data.geom_xpos[seg], 0.5 * (sim.positions[:3] + sim.positions[1:4]), atol=1e-12)
    assert sim.mj_data.time == pytest.approx(sim.time)
    np.testing.assert_allclose(sim.mj_data.cam_xpos[0], sim.mj_model.cam_pos[0])  # the camera is placed


TILT = math.radians(10.0)


def _tilted_table(mu: float) -> mjcable.Scene:
    normal = np.array([0.0, -math.sin(TILT), math.cos(TILT)])
    center = np.array([0.0, 0.0, 0.5])
    on_top = center + normal * (0.02 + 0.005)
    cable = mjcable.CableSpec([on_top - [0.4, 0, 0], on_top + [0.4, 0, 0]], 40, 0.005, 0.1, friction=mu)
    table = mjcable.Box(size=(1.0, 1.5, 0.02), pos=tuple(center), euler=(10.0, 0.0, 0.0), friction=mu)
    return mjcable.Scene(cable, obstacles=(table,))


@pytest.mark.parametrize("model", PARTICLE)
@pytest.mark.parametrize("mu", [0.5, 0.1])
def test_tilted_table_holds_with_high_friction_and_lets_slide_with_low(model, mu):
    sim = mjcable.Simulator(_tilted_table(mu), model, iterations=4)
    start = sim.positions.mean(axis=0)
    sim.step(1.0)
    downhill = np.array([0.0, -math.cos(TILT), -math.sin(TILT)])
    slide = (sim.positions.mean(axis=0) - start) @ downhill
    # Coulomb: stick while μ > tan 10° = 0.176, else slide ½ g (sin θ − μ cos θ) t²
    expected = max(0.5 * G * (math.sin(TILT) - mu * math.cos(TILT)) * sim.time**2, 0.0)
    if expected == 0.0:
        assert abs(slide) < 1e-3
    else:
        assert slide == pytest.approx(expected, rel=0.02)


def test_self_collision_keeps_segments_apart():
    points = [[-0.3, -0.1, 0.021], [0.3, 0.1, 0.021], [0.35, 0.15, 0.065], [0.3, 0.2, 0.095], [-0.3, -0.2, 0.095]]
    cable = mjcable.CableSpec(points, 80, 0.005, 0.1, damping=2.0, friction=0.5)
    scene = mjcable.Scene(cable, obstacles=(mjcable.Floor(),))
    gaps = {}
    for on in (False, True):
        sim = mjcable.Simulator(scene, "xpbd", substeps=4, self_collision=on)
        sim.step(1.0)
        x = sim.positions
        pair, st, normal = np.zeros((4000, 2), dtype=np.int64), np.zeros((4000, 2)), np.zeros((4000, 3))
        one_chain = (np.array([[0, len(x) - 1]]), True, np.zeros((0, 2), dtype=np.int64))  # chains, own, junctions
        count = cable_contact_kernels.find_self_contacts(x, 0.05, np.array([2]), pair, st, normal, *one_chain)
        a = (1 - st[:count, :1]) * x[pair[:count, 0]] + st[:count, :1] * x[pair[:count, 0] + 1]
        b = (1 - st[:count, 1:2]) * x[pair[:count, 1]] + st[:count, 1:2] * x[pair[:count, 1] + 1]
        gaps[on] = np.min(np.linalg.norm(a - b, axis=1))
    assert gaps[False] < 0.005  # the upper loop falls through the lower one
    assert gaps[True] > 2 * 0.005 - 5e-4  # the loops rest on each other


# -- pins ----------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("model", PARTICLE)
def test_socket_holds_below_its_release_force_and_lets_go_above(model):
    weight = 0.1 * G
    held = mjcable.Simulator(_hanging(pin_kind="socket", release=1.5 * weight, damping=2.0), model, order="direct")
    held.step(0.5)
    assert not held.released
    np.testing.assert_allclose(held.pin_forces[0], [0, 0, weight], rtol=1e-6, atol=1e-9)  # λ / h²
    dropped = mjcable.Simulator(_hanging(pin_kind="socket", release=0.5 * weight, damping=2.0), model,
                                order="direct")
    dropped.step(0.5)
    assert dropped.released == {0}
    assert dropped.positions[0, 2] < 1.5 - 0.5 * G * 0.4**2  # falling freely


def test_socket_scene_lets_go_when_the_gripper_pulls_the_cable_taut():
    scene = mjcable.scenes.get("socket", damping=2.0)  # clamped socket, release force 2 N
    sim = mjcable.Simulator(scene, "xpbd", order="direct")
    sim.step(1.0)
    start = sim.positions[-1].copy()
    socket = scene.cable.particles[0]
    for k in range(1, 1001):
        t = k * sim.dt  # accelerate smoothly to 0.1 m/s over 0.5 s, then pull steadily
        s = 0.1 * (t * t / 1.0 if t < 0.5 else 0.25 + (t - 0.5))
        sim.move_gripper(1, start + [s, 0, 0])
        sim.step()
        if sim.released:
            break
        assert np.linalg.norm(sim.pin_forces[0]) <= 2.0
    assert sim.released == {0}
    span = np.linalg.norm(start + [s, 0, 0] - socket)
    assert span > 0.95 * scene.cable.length  # it let go when the cable went taut, not while slack


def test_end_load_stretches_a_compliant_cable_by_its_weight():
    scene = _hanging(stretch_stiffness=EA, damping=20.0)
    sim = mjcable.Simulator(scene, "xpbd", order="direct")
    load = 0.05  # kg on the free end
    sim.add_point_mass(-1, load)
    sim.step(1.0)
    p = sim.positions
    expected = 0.1 * G * 1.0 / (2 * EA) + load * G * 1.0 / EA  # own weight + the load's, through every segment
    assert p[0, 2] - p[-1, 2] - scene.cable.length == pytest.approx(expected, rel=1e-3)
    np.testing.assert_allclose(sim.pin_forces[0], [0, 0, (0.1 + load) * G], rtol=1e-3, atol=1e-9)
    with pytest.raises(ValueError, match="mass"):
        sim.add_point_mass(0, 0.0)


def test_gripper_drags_its_particle_and_renders_there():
    scene = mjcable.scenes.get("socket", damping=2.0)
    sim = mjcable.Simulator(scene, "pbd", iterations=4)
    target = scene.cable.particles[-1] + [0.0, 0.05, 0.02]
    sim.move_gripper(1, target)
    sim.step()
    np.testing.assert_allclose(sim.positions[-1], target, atol=1e-12)
    body = mujoco.mj_name2id(sim.mj_model, mujoco.mjtObj.mjOBJ_BODY, "gripper1")
    np.testing.assert_allclose(sim.mj_data.mocap_pos[sim.mj_model.body_mocapid[body]], target)


# -- PBD user constraints -------------------------------------------------------------------------------------------


def _ground(z_floor):
    return [UserConstraint(particles=(i,), function=lambda p: p[0, 2] - z_floor, inequality=True,
                           gradient=lambda p: np.array([[0.0, 0.0, 1.0]])) for i in range(13)]


@pytest.mark.slow  # PBD's user constraints compile the step's pieces apart (kernels.run_phase)
def test_user_constraints_analytic_and_numerical_gradients_agree():
    cable = mjcable.CableSpec([[0, 0, 1], [0.6, 0, 1]], 12, 0.005, 0.1, damping=1.0)
    pivot = np.array([0.0, 0.0, 1.2])

    def tether(p):  # particle 0 swings on a 0.2 m tether from the pivot
        return float(np.linalg.norm(p[0] - pivot)) - 0.2

    def tether_gradient(p):
        return ((p[0] - pivot) / np.linalg.norm(p[0] - pivot))[None, :]

    runs = {}
    for name, grad in (("analytic", tether_gradient), ("numerical", None)):
        users = _ground(0.5) + [UserConstraint(particles=(0,), function=tether, gradient=grad, step=1e-6)]
        sim = mjcable.Simulator(mjcable.Scene(cable), "pbd", substeps=1, iterations=8, constraints=users)
        runs[name] = []
        for _ in range(10):
            sim.step(0.1)
            runs[name].append(sim.positions)
    x = np.array(runs["analytic"])
    np.testing.assert_allclose(np.array(runs["numerical"]), x, atol=1e-7)
    np.testing.assert_allclose(np.linalg.norm(x[:, 0] - pivot, axis=-1), 0.2, atol=1e-9)  # projected last: exact
    assert x[..., 2].min() > 0.5 - 1e-3  # the user's floor holds...
    assert np.sum(x[..., 2] < 0.5 + 1e-3) >= 2  # ...and was reached


# -- every scene, model and order ----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", mjcable.scenes.names())
@pytest.mark.parametrize("model", PARTICLE)
@pytest.mark.parametrize("order", ["gauss-seidel", "jacobi", "direct"])
def test_built_in_scenes_run_with_bending_in_every_order(name, model, order):
    scene = mjcable.scenes.get(name, young=2e7, n_segments=30)  # E·I = 0.0098 N·m²: a stiff cable
    sim = mjcable.Simulator(scene, model, order=order, substeps=2, iterations=2)
    sim.step(0.3)
    assert np.all(np.isfinite(sim.positions))
    strain = np.linalg.norm(np.diff(sim.positions, axis=0), axis=1) / scene.cable.segment_length - 1.0
    assert np.max(np.abs(strain)) < 0.2


# -- settings and failure modes ------------------------------------------------------------------------------------


@pytest.mark.parametrize("model, settings, match", [
    ("xpbd", {"stretch_compliance": -1.0}, r"stretch_compliance.*\[0, inf\).*-1\.0"),
    ("xpbd", {"bend_compliance": float("nan")}, "bend_compliance"),
    ("pbd", {"stretch_factor": 1.5}, r"stretch_factor.*\[0, 1\].*1\.5"),
    ("jakobsen", {"stretch_factor": -0.1}, "stretch_factor"),
    ("pbd", {"bend_factor": 2.0}, "bend_factor"),
    ("xpbd", {"iterations": 0}, r"iterations.*>= 1.*0"),
    ("jakobsen", {"substeps": 0}, r"substeps.*>= 1"),
    ("pbd", {"substeps": 2.5}, "substeps"),
    ("xpbd", {"order": "sideways"}, r"order.*gauss-seidel.*sideways"),
    ("xpbd", {"omega": 3.0}, "omega"),
    ("pbd", {"integrator": "rk4"}, "integrator"),
    ("xpbd", {"stiffness": 0.5}, r"unknown setting.*stiffness.*xpbd"),
    ("jakobsen", {"warp": 1}, r"unknown setting.*warp"),
    ("xpbd", {"bending": "distance"}, "bend_compliance"),
    ("pbd", {"constraints": [42]}, "UserConstraint"),
])
def test_bad_settings_raise_clear_errors(model, settings, match):
    with pytest.raises(ValueError, match=match):
        mjcable.Simulator(mjcable.scenes.get("hang", n_segments=10), model, **settings)


@pytest.mark.parametrize("dt", [0.0, -0.002])
def test_non_positive_dt_raises(dt):
    with pytest.raises(ValueError, match="dt"):
        mjcable.Simulator(mjcable.scenes.get("hang", n_segments=10), "xpbd", dt=dt)


def test_bad_user_constraints_raise():
    with pytest.raises(ValueError, match="step"):
        UserConstraint(particles=(0,), function=lambda p: 0.0, step=0.0)
    with pytest.raises(ValueError, match=r"particles must lie in"):
        mjcable.Simulator(mjcable.scenes.get("hang", n_segments=10), "pbd",
                          constraints=[UserConstraint(particles=(0, 99), function=lambda p: 0.0)])


@numba.njit
def _poison(S):
    S.x[4, 2] = np.nan


@pytest.mark.parametrize("model", PARTICLE)
def test_nan_state_raises_simulation_diverged_error(model, monkeypatch):
    sim = mjcable.Simulator(mjcable.scenes.get("hang", n_segments=10), model)
    sim.step(0.01)
    run = kernels.run_steps

    def faulty(S, *args):  # fault injection: a NaN particle before the step
        _poison(S)
        return run(S, *args)

    monkeypatch.setattr(kernels, "run_steps", faulty)
    with pytest.raises(mjcable.SimulationDivergedError, match=rf"{model}.*step 6 .*t = 0.012.*non-finite") as err:
        sim.step()
    assert err.value.model == model and err.value.step == 6


def test_proxy_spec_pairs_every_segment_with_every_obstacle():
    scene = mjcable.scenes.get("table", n_segments=20)
    model = mjcable.build(scene, "xpbd", contact_margin=0.01).compile()
    assert model.npair == 20 * len(scene.obstacles)
    assert model.nmocap == 20
    assert all(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, f"particle{i}") >= 0 for i in range(21))
    with pytest.raises(ValueError, match="unknown setting"):
        mjcable.build(scene, "xpbd", substep=3)
