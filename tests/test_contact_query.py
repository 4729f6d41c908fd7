"""The particle solvers' contact query (``mjcable.solvers.query_kernels.contacts_from_mujoco``) against geometry."""

import dataclasses

import mujoco
import numpy as np

import mjcable
from mjcable import catalog
from mjcable.backends.particle import ParticleBackend
from mjcable.solvers import kernels, kernels_layout, query_kernels

DT = 0.002  # s, the Simulator's default


def _backend(scene) -> ParticleBackend:
    """The xpbd particle backend of ``scene`` at its defaults (dt = 2 ms), built as the Simulator builds it: these
    tests read the solver's contact buffers and its kept query, below the Simulator."""
    return ParticleBackend(scene, catalog.get("xpbd"), DT, catalog.make_settings("xpbd"))


def _steps(backend: ParticleBackend, count: int = 1) -> None:
    n = backend.scene.cable.n_particles
    result = backend.run(count, rows=np.zeros(0, dtype=np.int64), out_x=np.zeros((0, n, 3)),
                         out_v=np.zeros((0, n, 3)))
    assert result.failure is None and result.steps == count


def test_a_cable_resting_on_a_table_has_one_contact_per_particle():
    """A straight cable lying on a flat face touches it at every particle, once: MuJoCo gives each of the two
    capsules meeting at a particle an end contact there (a few 1e-6 of the segment off its end), and the query
    keeps one, so that the solver does not project the same constraint twice."""
    scene = mjcable.scenes.get("table")
    backend = _backend(scene)
    _steps(backend, round(1.0 / DT))
    z = backend.positions()[:, 2]
    assert z.max() - z.min() < 1e-6  # at rest on the table top, every particle on it
    # the steps at rest keep the contacts of the last query, run as the cable came to rest: query again now
    backend.arrays.par[0]["query_margin"] = -np.inf
    _steps(backend)
    assert backend.diagnostics()["contacts"] == scene.cable.n_segments + 1


def test_a_cable_at_rest_keeps_its_last_query():
    """Issue 18: nothing moves, so nothing needs querying. A cable lying still on the table runs far fewer
    ``mj_collision`` queries than steps (every step queried before the rule), and stays on the table top."""
    scene = mjcable.scenes.get("table")
    sim = mjcable.Simulator(scene, "xpbd")
    sim.step(2.0)  # falls for 0.2 s, lands, comes to rest
    before, steps = sim.diagnostics["queries"], sim.steps
    sim.step(1.0)
    assert sim.diagnostics["queries"] - before < 0.05 * (sim.steps - steps)
    z = sim.positions[:, 2]
    top = mjcable.scenes.TABLE_TOP + scene.cable.radius
    np.testing.assert_allclose(z, top, atol=1e-4)  # resting on the top, not sunk into it
    assert sim.diagnostics["contacts"] >= scene.cable.n_segments + 1  # its contacts kept: every particle's


def _fresh_pairs(backend, margin: float) -> set:
    """(segment, obstacle geom) of every pair MuJoCo finds within ``margin`` m at the cable's current positions: a
    fresh ``mj_collision`` on a data copy (the model's pair margins restored after)."""
    m, n = backend.mj_model, backend.scene.cable.n_segments
    d = mujoco.MjData(m)
    query_kernels.proxy_poses(backend.positions(), d.mocap_pos[:n], d.mocap_quat[:n])
    saved = m.pair_margin.copy()
    par = backend.arrays.par[0]
    m.pair_margin[par["pair_start"]:par["pair_stop"]] = margin  # the cable's pairs
    mujoco.mj_kinematics(m, d)
    mujoco.mj_collision(m, d)
    m.pair_margin[:] = saved
    seg = backend.arrays.segment_of_geom
    pairs = set()
    for g0, g1 in d.contact.geom[:d.ncon]:
        if (seg[g0] >= 0) != (seg[g1] >= 0):
            pairs.add((int(max(seg[g0], seg[g1])), int(g0 if seg[g0] < 0 else g1)))
    return pairs


def _kept_covers(backend, pair) -> bool:
    """Whether the step's contacts act on ``pair`` = (segment, obstacle geom): a contact of that segment with that
    obstacle, or one at either of its particles (the query keeps one contact where two capsules meet)."""
    n = int(backend.arrays.par[0]["n_con"])
    seg, frac, _, _, _, shape = (a[:n] for a in kernels_layout.contact_buffers(backend.state)[:6])
    row_of_geom = backend.arrays.shape_of_geom
    geoms = np.flatnonzero(row_of_geom >= 0)[np.argsort(row_of_geom[row_of_geom >= 0])][shape]
    i, g = pair
    same = geoms == g
    at_start = (seg == i - 1) & (frac == 1.0) | (seg == i) & (frac == 0.0)
    at_end = (seg == i) & (frac == 1.0) | (seg == i + 1) & (frac == 0.0)
    return bool(np.any(same & ((seg == i) | at_start | at_end)))


def test_a_kept_query_holds_every_pair_a_step_needs_while_a_gripper_drags_the_cable_off_the_table():
    """A cable held by a gripper lies at rest on the table (0.6 s), then is dragged off its edge onto the floor (2 s)
    and lies there (1 s). Before every step that keeps the last query's contacts (no new ``mj_collision``), every pair that MuJoCo finds within
    the step's margin at that moment is among them; and the cable never sinks into the table or the floor."""
    table = mjcable.scenes.get("table", n_segments=30)
    z = mjcable.scenes.TABLE_TOP + table.cable.radius
    cable = dataclasses.replace(table.cable, points=((-0.5, 0.0, z), (0.5, 0.0, z)))  # straight, on the top
    scene = dataclasses.replace(table, cable=cable, pins=(mjcable.Pin(0, "gripper"),))
    backend = _backend(scene)
    start = backend.gripper_positions()[0]
    edge = np.array([-0.7, 0.0, start[2]])  # past the table's edge (x = -0.6), then down and away to the floor
    end = np.array([-2.0, 0.0, 0.02])

    def leg(a, b, steps):
        return a + np.linspace(0.0, 1.0, steps)[:, None] * (b - a)

    path = np.concatenate([np.repeat(start[None], 300, axis=0), leg(start, edge, 200), leg(edge, end, 800),
                           np.repeat(end[None], 500, axis=0)])  # 0.6 s at rest, 2 s dragged (up to 1.2 m/s), 1 s
    kept = queried = flat = 0
    r = scene.cable.radius
    a, par = backend.arrays, backend.arrays.par[0]
    for step, target in enumerate(path):  # one step at a time, checked before each
        margin = kernels.step_margin(a.v, backend.settings.contact_margin, DT, par["fall"])
        queries = backend.diagnostics()["queries"]
        backend.move_gripper(0, target)
        if query_kernels.query_holds(a.x, margin, a.query_x, par["query_margin"]):
            need = _fresh_pairs(backend, margin)
            missing = [p for p in need if not _kept_covers(backend, p)]
            assert not missing, f"step {step}: pairs within the step's margin not kept: {missing}"
            kept += 1
        _steps(backend)
        queried += backend.diagnostics()["queries"] - queries
        x = backend.positions()
        assert x[:, 2].min() > -1e-3 + r  # never through the floor
        over = (np.abs(x[:, 0]) < 0.6 - r) & (np.abs(x[:, 1]) < 0.4 - r)  # over or under the table's 4 cm slab
        top, bottom = mjcable.scenes.TABLE_TOP, mjcable.scenes.TABLE_TOP - 0.04
        assert not np.any((x[over, 2] < top + r - 1e-3) & (x[over, 2] > bottom - r + 1e-3))  # never inside it
        flat += _flat_contacts_are_their_face(backend, scene)
    x = backend.positions()
    assert np.all(x[:, 2] < 0.05) and kept > 100 and queried > 50  # it reached the floor; both kinds of step ran
    assert flat > 1000  # the flat-face contacts were checked on the table and on the floor


def _box_distance(p, centre, half):
    """Signed distance (m) of points ``p`` (k, 3) from an axis-aligned box (``centre``, half-sizes ``half``): the
    textbook box SDF, written here independently of the solver's kernels."""
    q = np.abs(p - centre) - half
    return np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)


def _flat_contacts_are_their_face(backend, scene) -> int:
    """Every contact measured as a flat face's plane (``BOX_FACE_FLAT``, or ``BOX_FACE_SOLE``) measures, at the
    cable's positions now, the exact distance of its point from the obstacle (the table's box, or the floor's plane)
    less the radius: the point has not left the face. A ``BOX_FACE_SOLE`` contact acts at a particle that no other
    contact touches, marked ``fric_sole`` with the contact's normal as its friction normal, and only those particles
    are marked. Returns how many it checked."""
    n = int(backend.arrays.par[0]["n_con"])
    seg, frac, normal, offset, _, shape, face, _ = (a[:n] for a in kernels_layout.contact_buffers(backend.state))
    flat = np.isin(face, (kernels_layout.BOX_FACE_FLAT, kernels_layout.BOX_FACE_SOLE))
    sole = face == kernels_layout.BOX_FACE_SOLE
    at = np.where(frac == 1.0, seg + 1, seg)  # the particle a contact at a segment's end acts on
    assert np.all((frac[sole] == 0.0) | (frac[sole] == 1.0))
    touches = np.bincount(seg[frac < 1.0], minlength=len(backend.arrays.x)) + np.bincount(
        seg[frac > 0.0] + 1, minlength=len(backend.arrays.x))
    assert np.all(touches[at[sole]] == 1)
    marked = np.zeros(len(backend.arrays.x), dtype=bool)
    marked[at[sole]] = True
    np.testing.assert_array_equal(backend.arrays.fric_sole, marked)
    np.testing.assert_array_equal(backend.arrays.fric_unit[at[sole]], normal[sole])
    x = backend.positions()
    p = (1.0 - frac[flat, None]) * x[seg[flat]] + frac[flat, None] * x[seg[flat] + 1]
    planes = np.einsum("kc,kc->k", normal[flat], p) - offset[flat]
    table = next(o for o in scene.obstacles if isinstance(o, mjcable.Box))
    on_box = backend.arrays.shape_type[shape[flat]] == mujoco.mjtGeom.mjGEOM_BOX
    exact = np.where(on_box, _box_distance(p, np.array(table.pos), np.array(table.size)), p[:, 2])
    np.testing.assert_allclose(planes, exact - scene.cable.radius, atol=1e-12)
    return int(flat.sum())
