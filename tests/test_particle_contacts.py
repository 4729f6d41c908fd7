"""The particle solvers' contacts against physics and independent references: the capstan law on a peg (hold,
slide, no creep) at any substep count and dt, Coulomb's law for self contacts as for a table, the obstacle shapes
against MuJoCo's own distance, and no tunnelling through a thin plate."""

import math

import mujoco
import numpy as np
import pytest

import mjcable
from mjcable.bench import contact
from mjcable.bench.case import Case
from mjcable.bench.runner import run_case
from mjcable.solvers import contact_kernels, kernels_layout

G = 9.81
CAPSTAN_MU = 0.3  # the rope over a peg: long/short < e^{0.3 π} ≈ 2.57 for a light rope
CONFIGS = [  # (model, dt, settings): the particle solvers' defaults, and xpbd at substeps 1, 4, 16 and dt 0.5 ms
    ("jakobsen", 0.002, {}),
    ("pbd", 0.002, {}),
    ("xpbd", 0.002, {}),
    ("xpbd", 0.002, {"substeps": 1}),
    ("xpbd", 0.002, {"substeps": 16}),
    ("xpbd", 0.0005, {}),
]
CREEP_SPEED = 1e-3  # m/s at 60 % of the threshold


@pytest.mark.parametrize("model, dt, settings", CONFIGS)
def test_rope_over_a_peg_obeys_the_heavy_capstan_law(model, dt, settings):
    """Held (end slower than 2 mm/s) at 0.85 e^{μπ} of the heavy-rope ratio, sliding (faster than 100 mm/s) at
    1.15 e^{μπ}, creeping less than 1 mm/s at 0.6 e^{μπ}: measured over seconds 1 to 3."""
    speeds = {f: contact.capstan_end_speed(model, dt, settings, factor=f, mu=CAPSTAN_MU) for f in (0.6, 0.85, 1.15)}
    assert speeds[0.6] < CREEP_SPEED, speeds
    assert speeds[0.85] < contact.HOLD_SPEED, speeds
    assert speeds[1.15] > contact.SLIDE_SPEED, speeds


def _slide_block(mu: float, tilt: float, *, self_contact: bool, substeps: int = 4, steps: int = 250,
                 dt: float = 0.002) -> np.ndarray:
    """A free segment (particles 2, 3, along y) lying across a held segment (particles 0, 1, along x) or on a
    plane, under gravity tilted ``tilt`` radians in the xz plane (the slope runs along x). Returns its
    centre's x over the steps, metres."""
    r = 0.005
    h = dt / substeps
    g = np.array([G * math.sin(tilt), 0.0, -G * math.cos(tilt)])
    x = np.array([[-0.1, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, -0.1, 2 * r], [0.0, 0.1, 2 * r]])
    w = np.array([0.0, 0.0, 1.0, 1.0])  # the lower segment (or the unused pair) is held
    v = np.zeros_like(x)
    react = np.zeros_like(x)
    pair = np.array([[2, 0]], dtype=np.int64)
    sgeo = np.array([[0.5, 0.5, 0.0, 0.0, 1.0]])
    slam = np.zeros((1, 2))
    # the table: a plane at z = r under the free segment, through contact_sweep and friction_sweep
    shapes = np.zeros((1, kernels_layout.N_SH))
    shapes[0, kernels_layout.SH_TYPE] = mujoco.mjtGeom.mjGEOM_PLANE
    shapes[0, kernels_layout.SH_ROT:kernels_layout.SH_ROT + 9] = np.eye(3).ravel()
    shapes[0, kernels_layout.SH_POS + 2] = r
    seg = np.array([2], dtype=np.int64)
    geo = np.array([[0.5, 0.0, 0.0, 1.0, 2 * r, mu, 0.0]])
    lam = np.zeros(1)
    fric = np.zeros((4, kernels_layout.N_FR))
    anchor = np.zeros((4, 3))
    anchor_ob = np.full(4, -1, dtype=np.int64)
    centre = []
    for _ in range(steps):
        for _ in range(substeps):
            x0 = x.copy()
            v[w > 0] += h * g
            x[w > 0] += h * v[w > 0]
            if self_contact:
                slam[:] = 0.0
                contact_kernels.self_contact_sweep(x, x0, w, react, pair, sgeo, 2 * r, mu, slam)
            else:
                lam[:] = 0.0
                _plane_contact(x, x0, w, react, fric, seg, geo, lam, shapes, r, anchor, anchor_ob)
            v = (x - x0) / h
        centre.append(0.5 * (x[2, 0] + x[3, 0]))
    return np.array(centre)


def _plane_contact(x, x0, w, react, fric, seg, geo, lam, shapes, r, anchor, anchor_ob):
    contact_kernels.reset_friction(fric)
    contact_kernels.contact_sweep(x, w, react, fric, anchor_ob, seg, geo, lam, shapes, r)
    contact_kernels.friction_sweep(x, x0, w, fric, anchor, anchor_ob, shapes)
    contact_kernels.update_anchors(x, fric, anchor, anchor_ob, shapes)


@pytest.mark.parametrize("self_contact", [True, False], ids=["on itself", "on a table"])
@pytest.mark.parametrize("substeps", [1, 4, 16])
def test_coulomb_friction_of_a_segment_lying_across_another_as_on_a_table(self_contact, substeps):
    """Sticks below the friction angle (no creep), slides above it at g (sin θ − μ cos θ), within 2 %."""
    mu = 0.5
    stick = _slide_block(mu, math.atan(0.95 * mu), self_contact=self_contact, substeps=substeps)
    assert abs(stick[-1] - stick[0]) < 1e-9
    tilt = math.radians(35.0)
    travel = _slide_block(mu, tilt, self_contact=self_contact, substeps=substeps)
    t = 0.002 * np.arange(1, len(travel) + 1)
    a = contact.fit_acceleration(t, travel - travel[0])
    assert a == pytest.approx(G * (math.sin(tilt) - mu * math.cos(tilt)), rel=0.02)


SHAPES = [  # (MuJoCo geom type, size): the round shapes and the box, posed off the origin and turned
    (mujoco.mjtGeom.mjGEOM_SPHERE, (0.05, 0.0, 0.0)),
    (mujoco.mjtGeom.mjGEOM_CAPSULE, (0.03, 0.08, 0.0)),
    (mujoco.mjtGeom.mjGEOM_CYLINDER, (0.04, 0.06, 0.0)),
    (mujoco.mjtGeom.mjGEOM_BOX, (0.05, 0.03, 0.02)),
    (mujoco.mjtGeom.mjGEOM_ELLIPSOID, (0.05, 0.04, 0.03)),
]


@pytest.mark.parametrize("typ, size", SHAPES, ids=lambda v: getattr(v, "name", ""))
def test_obstacle_shapes_measure_the_distance_mujoco_measures(typ, size):
    """Points around each shape (outside, within 2 cm of the surface): the kernel's distance and normal against
    MuJoCo's own geom distance (``mj_geomDistance`` to a 1 mm sphere) and its direction (given to the kernel as the
    detection normal, which picks a box's face)."""
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(pos=[0.1, -0.2, 0.3], quat=[0.9, 0.3, -0.2, 0.25])
    body.add_geom(type=typ, size=size)
    probe = spec.worldbody.add_body(name="probe", mocap=True)
    probe.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.001, 0, 0], contype=0, conaffinity=0)
    m = spec.compile()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    shape = np.zeros(kernels_layout.N_SH)
    shape[kernels_layout.SH_TYPE] = typ
    shape[kernels_layout.SH_SIZE:kernels_layout.SH_SIZE + 3] = m.geom_size[0]
    shape[kernels_layout.SH_POS:kernels_layout.SH_POS + 3] = d.geom_xpos[0]
    shape[kernels_layout.SH_ROT:kernels_layout.SH_ROT + 9] = d.geom_xmat[0]
    rng = np.random.default_rng(7)
    checked = 0
    fromto = np.zeros(6)
    while checked < 50:
        p = d.geom_xpos[0] + rng.uniform(-0.12, 0.12, 3)
        d.mocap_pos[0] = p
        mujoco.mj_kinematics(m, d)
        ref = mujoco.mj_geomDistance(m, d, 0, 1, 0.5, fromto) + 0.001
        if not 0.001 < ref < 0.02:
            continue
        direction = (fromto[3:] - fromto[:3]) / np.linalg.norm(fromto[3:] - fromto[:3])  # the detection normal
        cval, nx, ny, nz = contact_kernels.shape_distance(*p, shape[None], 0, *direction, 0.0, 0.0)
        tol = 0.1 * ref if typ == mujoco.mjtGeom.mjGEOM_ELLIPSOID else 1e-6  # ellipsoid: first-order estimate
        assert cval == pytest.approx(ref, abs=tol)
        if typ != mujoco.mjtGeom.mjGEOM_ELLIPSOID:
            np.testing.assert_allclose([nx, ny, nz], direction, atol=1e-3)
        checked += 1


@pytest.mark.parametrize("model", ["jakobsen", "pbd", "xpbd", "xpbd-gs"])
def test_particle_solvers_never_tunnel_through_a_thin_plate(model):
    """The stress family's 4 mm plate hit at 10 m/s, at dt 2 and 10 ms: the cable ends on the plate, every
    particle above it."""
    for dt in (0.002, 0.01):
        row = run_case(Case("plate", model, dt, params=(("speed", 10.0), ("save_positions", True))))
        assert row["outcome"] == "stable", row
        scene = contact.plate_scene(10.0)
        sim = mjcable.Simulator(scene, model.split("-")[0], dt=dt,
                                **({"order": "gauss-seidel"} if model == "xpbd-gs" else {}))
        sim.step(contact.plate_fall_time(10.0) + 0.3)
        assert np.all(sim.positions[:, 2] > contact.PLATE_THICKNESS / 2), model
