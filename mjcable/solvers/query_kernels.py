"""Contact queries and the proxy's poses, ``@njit`` (cached, see :mod:`mjcable.solvers._kernel_cache`), called by the
step driver (:func:`mjcable.solvers.kernels.run_steps`), which queries between steps through MuJoCo's C API
(:func:`query_obstacles`, :mod:`mjcable.solvers.capi`), and by the Python fallback where that is unavailable
(:meth:`mjcable.solvers.contacts.ObstacleContacts.query`: :func:`contacts_from_mujoco` on the bindings' contacts).
Both turn MuJoCo's contacts into the solver's with :func:`_take_contact`. The bounding-box test that skips the query
(:func:`touches_obstacles`) and the step's margin (:func:`step_margin`) are here too.

**Reusing a query** (:func:`query_holds`). A step needs every pair of a segment and an obstacle closer than its
margin m (:func:`step_margin`: the contact margin plus the step's travel). A query run with
the margin m_q at positions x_q found every pair closer than m_q; a pair it did not find was farther than m_q, and
after every particle has moved by at most δ = maxₚ |xₚ − x_qₚ| it is farther than m_q − δ (a segment's axis point
is a convex combination of its two particles, so it moves by at most δ too, and the proxy capsule, of the rest
length, follows it to within the cable's strain; static obstacles do not move). So the last query's contacts still
hold every pair a step needs while m_q − δ ≥ m, and the query need not run again; each contact is measured against
the obstacle's real shape in every substep anyway (:func:`mjcable.solvers.contact_kernels.contact_sweep`), and one
found farther than needed does nothing while it does not press. The step loop queries with m_q = m +
``query_slack`` (:class:`mjcable.solvers.settings.ParticleSettings`), so a cable at rest keeps one query's contacts
for as long as it stays within the slack of where it was. A kept contact keeps its point on the segment and its
normal from the query, which go stale as the cable moves: the slack also bounds that (so it is microns, not
millimetres: the setting's comment). Not for moving obstacles or a user world: their queries are never kept.
A fresh query marks its contacts that stay over one flat face while it is kept (:func:`flatten_contacts`): their
point moves less than m_q, so one found more than that inside a static box's face never leaves the face's plane.
The self contacts and the contacts between cables are found by :mod:`mjcable.solvers.cable_contact_kernels`.
"""

from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from mjcable.solvers._kernel_cache import inline as _inline, jit as _jit
from mjcable.solvers.contact_kernels import box_face
from mjcable.solvers.kernels_layout import (BOX_FACE_FLAT, BOX_FACE_NEGATIVE, BOX_FACE_NONE, BOX_FACE_SOLE, GEOM_BOX,
                                            GEOM_PLANE)

__all__ = ["step_margin", "touches_obstacles", "query_holds", "contacts_from_mujoco", "query_obstacles", "reserve_contacts", "refresh_moving",
           "proxy_poses"]

_TINY_LENGTH = 1e-12  # m: a segment shorter than this has no direction
# A contact this close to a segment's end (as a fraction of it) acts at the particle (20 µm on a 2 cm segment). MuJoCo
# puts the end contacts of a capsule lying on a flat face up to a few 1e-5 of the segment off its ends (the table
# scene at rest), so that a fraction of 1e-9 kept most pairs of the neighbouring capsules' contacts at one particle
# apart: two projections of the same constraint (86 contacts instead of 51 on the table at rest).
_END_FRACTION = 1e-3
_SAME_NORMAL = 1.0 - 1e-6  # cosine above which two contacts at one particle with one obstacle are one contact

@_inline
def _take_contact(S, g0, g1, dist, pos, frame, at_particle, count):
    """One MuJoCo contact (geoms ``g0``, ``g1``, ``dist``, ``pos`` and ``frame[:3]`` as 3 floats each) into row
    ``count`` of the state's obstacle-contact buffers (see :func:`contacts_from_mujoco`); returns the new count
    (unchanged for a contact that is not between a capsule and an obstacle, or that repeats one already acting at
    the same particle). ``at_particle`` (N,): the contact already acting at each particle (−1: none)."""
    segment_of_geom, shape_of_geom = S.segment_of_geom, S.shape_of_geom
    x = S.x
    pos_x, pos_y, pos_z = pos
    f0, f1, f2 = frame
    s0 = segment_of_geom[g0]
    s1 = segment_of_geom[g1]
    if (s0 >= 0) == (s1 >= 0):
        return count
    if s0 >= 0:
        i, other, sign = s0, g1, -1.0
    else:
        i, other, sign = s1, g0, 1.0
    radius = S.seg_radius[i]  # (its cable's)
    nx, ny, nz = sign * f0, sign * f1, sign * f2
    half = 0.5 * dist
    qx, qy, qz = pos_x - half * nx, pos_y - half * ny, pos_z - half * nz
    reach = half + radius
    px, py, pz = pos_x + reach * nx, pos_y + reach * ny, pos_z + reach * nz
    ex, ey, ez = x[i + 1, 0] - x[i, 0], x[i + 1, 1] - x[i, 1], x[i + 1, 2] - x[i, 2]
    e2 = ex * ex + ey * ey + ez * ez
    frac = 0.0
    if e2 > 0.0:
        frac = ((px - x[i, 0]) * ex + (py - x[i, 1]) * ey + (pz - x[i, 2]) * ez) / e2
    frac = 0.0 if frac < _END_FRACTION else (1.0 if frac > 1.0 - _END_FRACTION else frac)
    con_normal = S.con_normal
    if frac == 0.0 or frac == 1.0:  # at a particle: the neighbouring capsule's end contact may be the same
        p = i if frac == 0.0 else i + 1
        q = at_particle[p]
        if q >= 0 and S.con_shape[q] == shape_of_geom[other] and (
                con_normal[q, 0] * nx + con_normal[q, 1] * ny + con_normal[q, 2] * nz > _SAME_NORMAL):
            return count
        at_particle[p] = count
    S.con_seg[count] = i
    S.con_s[count] = frac
    con_normal[count, 0], con_normal[count, 1], con_normal[count, 2] = nx, ny, nz
    S.con_offset[count] = nx * qx + ny * qy + nz * qz + radius
    S.con_mu[count] = S.geom_friction[other, 0]
    row = shape_of_geom[other]
    S.con_shape[count] = row
    # a static box's face, once (a moving box's rotation changes: every sweep finds it)
    static_box = row >= 0 and S.shape_type[row] == GEOM_BOX and not S.shape_moves[row]
    S.con_face[count] = box_face(S.shape_rot, row, nx, ny, nz) if static_box else BOX_FACE_NONE
    return count + 1


@_inline
def flatten_contacts(S, n_con, inset):
    """Mark the state's first ``n_con`` obstacle contacts that stay over one flat face while their query is kept
    (``con_face`` = ``BOX_FACE_FLAT``, ``con_normal`` and ``con_offset`` that face's plane n·p = n·pos + h + r):
    every contact with a static plane, and a contact with a static box whose point lies over its face (the one
    ``con_face`` names) at least ``inset`` m inside the face's edges. Over the face, the box's distance is the face
    plane's (:func:`~mjcable.solvers.contact_kernels.shape_distance`), and a kept query's point moves less than its
    margin m_q (module docstring): with ``inset`` ≥ m_q the point never leaves the face while the contact lives, and
    each sweep measures it with one dot product instead of the box's frame.

    A flat contact at a particle (s = 0 or 1) that is the particle's only contact is marked ``BOX_FACE_SOLE``, and
    the particle ``fric_sole`` with the face's normal in ``fric_unit`` and no sideways push in ``fric_push``: its
    friction cone is the face's, μ Σ Δλₙ about that normal, with no sums of normals to keep
    (:func:`~mjcable.solvers.contact_kernels.contact_sweep`, :func:`~mjcable.solvers.contact_kernels.friction_sweep`;
    a cable lying on a floor or a table)."""
    x, seg_radius = S.x, S.seg_radius
    typ, size, pos, rot, moves = S.shape_type, S.shape_size, S.shape_pos, S.shape_rot, S.shape_moves
    seg, frac, normal, offset, shape, face = S.con_seg, S.con_s, S.con_normal, S.con_offset, S.con_shape, S.con_face
    for c in range(n_con):
        k = shape[c]
        if k < 0 or moves[k]:
            continue
        if typ[k] == GEOM_PLANE:
            axis, sign, half = 2, 1.0, 0.0
        elif typ[k] == GEOM_BOX and face[c] >= 0:
            axis = face[c] % BOX_FACE_NEGATIVE
            sign = -1.0 if face[c] >= BOX_FACE_NEGATIVE else 1.0
            half = size[k, axis]
            i, s = seg[c], frac[c]
            inside = True
            for e in range(3):  # the point's coordinate along each edge direction of the face, against the edge
                if e != axis:
                    q = 0.0
                    for comp in range(3):
                        q += rot[k, comp, e] * ((1.0 - s) * x[i, comp] + s * x[i + 1, comp] - pos[k, comp])
                    inside = inside and abs(q) <= size[k, e] - inset
            if not inside:
                continue
        else:
            continue
        nx, ny, nz = sign * rot[k, 0, axis], sign * rot[k, 1, axis], sign * rot[k, 2, axis]
        normal[c, 0], normal[c, 1], normal[c, 2] = nx, ny, nz
        offset[c] = nx * pos[k, 0] + ny * pos[k, 1] + nz * pos[k, 2] + half + seg_radius[seg[c]]
        face[c] = BOX_FACE_FLAT
    sole, unit, push = S.fric_sole, S.fric_unit, S.fric_push
    sole[:] = False
    touches = np.zeros(x.shape[0], dtype=np.int64)  # the contacts acting on each particle
    for c in range(n_con):
        touches[seg[c]] += frac[c] < 1.0
        touches[seg[c] + 1] += frac[c] > 0.0
    for c in range(n_con):
        s = frac[c]
        p = seg[c] + 1 if s == 1.0 else seg[c]
        if face[c] == BOX_FACE_FLAT and (s == 0.0 or s == 1.0) and touches[p] == 1:
            face[c] = BOX_FACE_SOLE
            sole[p] = True
            unit[p, 0], unit[p, 1], unit[p, 2] = normal[c, 0], normal[c, 1], normal[c, 2]
            push[p, 0] = push[p, 1] = push[p, 2] = 0.0


@_jit
def contacts_from_mujoco(S, geom, dist, pos, frame):
    """Turn MuJoCo's contacts (``geom`` (c, 2), ``dist`` (c,), ``pos`` (c, 3), ``frame`` (c, 9)) between proxy
    capsules and obstacles into the state's contacts: fills its obstacle-contact buffers (segment ``con_seg``,
    fraction ``con_s``, normal ``con_normal``, ``con_offset``, ``con_mu``, shape row ``con_shape`` and a static
    box's face ``con_face``, see
    :func:`mjcable.solvers.contact_kernels.contact_sweep`; ``S.shape_of_geom`` maps a geom id to its shape row, −1
    for none) and returns their number. The buffers must hold ``c`` contacts (:func:`reserve_contacts`).

    MuJoCo's normal points from geom[0] to geom[1] and ``pos`` lies midway between the surfaces; with n the normal
    from the obstacle to the cable, the obstacle's surface point is q = pos − (dist/2) n and the capsule's axis
    point pos + (dist/2 + radius) n, at fraction s along its segment; offset = n·q + radius; μ is the obstacle's
    (obstacles carry the higher priority, so theirs is the μ in force). Two capsules meeting at a particle that both
    touch an obstacle there with the same normal (a cable lying on a flat face: MuJoCo gives each capsule a contact
    at each end) are one contact at that particle, kept once."""
    count = 0
    at_particle = np.full(S.x.shape[0], -1, dtype=np.int64)  # the contact already acting at a particle (s = 0 or 1)
    for c in range(dist.shape[0]):
        count = _take_contact(S, geom[c, 0], geom[c, 1], dist[c], (pos[c, 0], pos[c, 1], pos[c, 2]),
                              (frame[c, 0], frame[c, 1], frame[c, 2]), at_particle, count)
    return count


@intrinsic
def _call_model_data(typingctx, fn, model, data):
    """Call the C function at address ``fn`` as ``void fn(const mjModel* model, mjData* data)`` (addresses as
    integers: :mod:`mjcable.solvers.capi`); nothing of it is baked into the compiled code, so it caches."""
    if not all(isinstance(a, types.Integer) for a in (fn, model, data)):
        return None

    def codegen(context, builder, signature, args):
        pointer = ir.IntType(8).as_pointer()
        function = ir.FunctionType(ir.VoidType(), [pointer, pointer])
        address, m, d = (context.cast(builder, a, t, types.intp) for a, t in zip(args, signature.args))
        builder.call(builder.inttoptr(address, function.as_pointer()),
                     [builder.inttoptr(m, pointer), builder.inttoptr(d, pointer)])
        return context.get_dummy_value()

    return types.void(fn, model, data), codegen


@_inline
def step_margin(v, contact_margin, dt, fall):
    """The contact query's margin (m) for the next step: ``contact_margin`` plus the fastest particle's travel in
    one step, speed · dt + ``fall`` (½ g dt²), from ``v`` (N, 3); ``contact_margin`` alone for a non-finite state."""
    top = 0.0
    for p in range(v.shape[0]):
        s2 = v[p, 0] * v[p, 0] + v[p, 1] * v[p, 1] + v[p, 2] * v[p, 2]
        if s2 > top or s2 != s2:
            top = s2
    margin = contact_margin + math.sqrt(top) * dt + fall
    return margin if math.isfinite(margin) else contact_margin


@_jit
def touches_obstacles(x, reach, box_lo, box_hi, plane_n, plane_p):
    """Whether the bounding box of particles ``x`` (N, 3), grown by ``reach`` metres, touches an obstacle: a world
    bounding box (``box_lo``, ``box_hi`` (B, 3)) or the solid side of a plane (unit normal ``plane_n``, point
    ``plane_p`` (F, 3))."""
    lo0 = lo1 = lo2 = math.inf
    hi0 = hi1 = hi2 = -math.inf
    for p in range(x.shape[0]):
        lo0, lo1, lo2 = min(lo0, x[p, 0]), min(lo1, x[p, 1]), min(lo2, x[p, 2])
        hi0, hi1, hi2 = max(hi0, x[p, 0]), max(hi1, x[p, 1]), max(hi2, x[p, 2])
    lo, hi = (lo0 - reach, lo1 - reach, lo2 - reach), (hi0 + reach, hi1 + reach, hi2 + reach)
    for k in range(box_lo.shape[0]):
        if (lo[0] <= box_hi[k, 0] and hi[0] >= box_lo[k, 0] and lo[1] <= box_hi[k, 1] and hi[1] >= box_lo[k, 1]
                and lo[2] <= box_hi[k, 2] and hi[2] >= box_lo[k, 2]):
            return True
    for k in range(plane_n.shape[0]):
        depth = 0.0
        for comp in range(3):
            depth += plane_n[k, comp] * (0.5 * (lo[comp] + hi[comp]) - plane_p[k, comp])
            depth -= abs(plane_n[k, comp]) * 0.5 * (hi[comp] - lo[comp])
        if depth <= 0.0:
            return True
    return False


@_inline
def query_holds(x, margin, query_x, query_margin):
    """Whether the last query's contacts hold every pair a step at positions ``x`` (N, 3) m needs within ``margin``
    m: maxₚ |xₚ − ``query_x``ₚ| ≤ ``query_margin`` − ``margin`` (module docstring, "Reusing a query"). False for
    none recorded (−inf) and for a non-finite state or margin."""
    room = query_margin - margin
    if not room >= 0.0:  # (also NaN)
        return False
    room2 = room * room
    for p in range(x.shape[0]):
        dx, dy, dz = x[p, 0] - query_x[p, 0], x[p, 1] - query_x[p, 1], x[p, 2] - query_x[p, 2]
        if not dx * dx + dy * dy + dz * dz <= room2:
            return False
    return True


@_jit
def reserve_contacts(S, capacity):
    """Grow the obstacle-contact buffers (``S.con_*``) together to hold at least ``capacity`` contacts (to twice
    that, when they must grow)."""
    if capacity > S.con_seg.shape[0]:
        cap = 2 * capacity
        S.con_seg = np.zeros(cap, dtype=np.int64)
        S.con_s = np.zeros(cap)
        S.con_normal = np.zeros((cap, 3))
        S.con_offset = np.zeros(cap)
        S.con_mu = np.zeros(cap)
        S.con_shape = np.zeros(cap, dtype=np.int64)
        S.con_face = np.zeros(cap, dtype=np.int64)
        S.con_lam = np.zeros(cap)


@_inline
def refresh_moving(S):
    """The moving obstacles' rows of ``S.shape_pos``, ``S.shape_rot`` from the world's current geom poses
    (``S.geom_xpos``, ``S.geom_xmat``)."""
    moving, shape_pos, shape_rot = S.moving, S.shape_pos, S.shape_rot
    for r in range(moving.shape[0]):
        g, row = moving[r, 0], moving[r, 1]
        for c in range(3):
            shape_pos[row, c] = S.geom_xpos[g, c]
        for c in range(9):
            shape_rot[row, c // 3, c % 3] = S.geom_xmat[g, c]


@_jit
def query_obstacles(S, margin):
    """The cable's contacts with the obstacles closer than ``margin`` metres, through MuJoCo's C API: pose the proxy
    capsules from ``S.x`` (:func:`proxy_poses` into the ``mocap_pos``, ``mocap_quat`` views), ``mj_kinematics``,
    the cable's pair margins (``S.pair_margin`` rows ``par.pair_start`` to ``par.pair_stop``) set to ``margin``,
    ``mj_collision``, then MuJoCo's contacts (``ncon`` and the contact array, read from the ``mjData`` struct and
    arena views at the offsets of :class:`mjcable.solvers.capi.Layout`) into the obstacle-contact buffers as
    :func:`contacts_from_mujoco` (grown to hold them). Returns their number, or −1 when the contact array does not
    lie, aligned, inside the arena (the caller queries through the bindings from then on).

    A MuJoCo *error* in these calls (``mju_error``, e.g. the arena running out) cannot become a Python exception:
    called by address, MuJoCo's own handler runs, prints the error and ends the process. The backend runs one query
    through the bindings at construction and reset, where an error raises ``mujoco.FatalError``; the proxy's arena
    holds tens of thousands of contacts."""
    P = S.par[0]
    x = S.x
    refresh_moving(S)
    proxy_poses(x, S.pose_pos, S.pose_quat)
    _call_model_data(P.fn_kinematics, P.model, P.data)
    for p in range(P.pair_start, P.pair_stop):
        S.pair_margin[p] = margin
    _call_model_data(P.fn_collision, P.model, P.data)
    ncon = S.struct_i32[P.ncon_word]
    reserve_contacts(S, np.int64(ncon))  # (one compiled version: Python's calls pass an int64)
    base = S.struct_i64[P.contact_word] - P.arena  # bytes from the arena's start to contact[0]
    stride = P.contact_size
    arena_f64, arena_i32 = S.arena_f64, S.arena_i32
    if base < 0 or base % 8 != 0 or base + ncon * stride > 8 * arena_f64.shape[0]:
        return -1
    count = 0
    at_particle = np.full(x.shape[0], -1, dtype=np.int64)
    for c in range(ncon):
        row = base + c * stride
        d, p, f, g = ((row + P.off_dist) // 8, (row + P.off_pos) // 8, (row + P.off_frame) // 8,
                      (row + P.off_geom) // 4)
        count = _take_contact(S, arena_i32[g], arena_i32[g + 1], arena_f64[d],
                              (arena_f64[p], arena_f64[p + 1], arena_f64[p + 2]),
                              (arena_f64[f], arena_f64[f + 1], arena_f64[f + 2]), at_particle, count)
    return count


@_jit
def proxy_poses(x, pos, quat):
    """Midpoints ``pos`` (n, 3) and quaternions ``quat`` (n, 4) (w, x, y, z) turning +z onto each segment of the
    particle chain ``x`` (n + 1, 3): the proxy capsules' poses."""
    for i in range(x.shape[0] - 1):
        dx = x[i + 1, 0] - x[i, 0]
        dy = x[i + 1, 1] - x[i, 1]
        dz = x[i + 1, 2] - x[i, 2]
        pos[i, 0] = 0.5 * (x[i, 0] + x[i + 1, 0])
        pos[i, 1] = 0.5 * (x[i, 1] + x[i + 1, 1])
        pos[i, 2] = 0.5 * (x[i, 2] + x[i + 1, 2])
        length = math.sqrt(dx * dx + dy * dy + dz * dz)
        if length < _TINY_LENGTH:
            quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3] = 1.0, 0.0, 0.0, 0.0
            continue
        dx, dy, dz = dx / length, dy / length, dz / length
        qw, qx, qy = 1.0 + dz, -dy, dx  # half-way quaternion between +z and d: (1 + z·d, z × d)
        norm = math.sqrt(qw * qw + qx * qx + qy * qy)
        if norm < _TINY_LENGTH:  # d = −z: half a turn about x
            quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3] = 0.0, 1.0, 0.0, 0.0
        else:
            quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3] = qw / norm, qx / norm, qy / norm, 0.0
