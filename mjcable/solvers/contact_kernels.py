"""Contacts of the particle solvers, ``@njit`` (cached, see :mod:`mjcable.solvers._kernel_cache`): the obstacles'
shapes, the normal projections of obstacle and self contacts, and Coulomb friction with persistent anchors.
Re-exported by :mod:`mjcable.solvers.kernels`; impacts get more iterations in :mod:`~mjcable.solvers.impact_kernels`.

**Geometry.** ``mj_collision`` finds the contacts once per step (with a margin that covers the step's travel): a
segment (i, i+1), the fraction s of its axis point p = (1 − s) xᵢ + s xᵢ₊₁, and the obstacle. In every substep and
iteration the point is measured against the obstacle's real shape (:func:`shape_distance`: the geom's MuJoCo type,
size and pose), C = d(p) − r ≥ 0 with r the cable's radius and n = ∇d, so that a cable sliding over a curved
surface follows it; on a sphere, cylinder or capsule the fraction is the segment's closest point to the centre or
axis, recomputed in every sweep (:func:`_round_fraction`), so that a chord turning on a peg between two queries
cannot sink into it unseen. Meshes and other types keep the detection's half-space n₀·p ≥ n₀·q + r. A contact that stays
over one flat face while its query is kept (a static plane, or a static box's face with the point well inside the
face's edges: :func:`~mjcable.solvers.query_kernels.flatten_contacts`) is measured against that face's plane, the
same distance with one dot product.

**Normal.** C ≥ 0 is projected with the segment weights (1 − s, s) of Jakobsen's segment collision ([J01],
"c1, c2"), mass-weighted ([M16] Eq. 18 with α = 0): Δλₙ = −C / Σ wⱼ ∇ⱼC², Δxⱼ = wⱼ ∇ⱼC Δλₙ, ∇ᵢC = (1 − s) n,
∇ᵢ₊₁C = s n.

**Depth at the substep's start.** Positions carry their corrections as velocity, v = (x − x₀)/h, so a depth d₀ that
the contact point already had when the substep began (C₀ = C(x₀) < 0: a start whose chords cut into the obstacle, a
contact that a query found late, a sideways friction correction of a chord on a curved surface) would leave the
substep at d₀ / h, faster the finer the substep: 2.4 m/s for 0.3 mm at h = 0.125 ms, which throws a rope off a peg. A
static obstacle therefore projects C ≥ min(0, C₀ + v_d h) with v_d = ``DEPENETRATION_SPEED`` and C₀ =
C − n·(p − p₀) (p₀ the point at the substep's start; exact on planes and box faces, to first order in |p − p₀| on
round shapes): it never lets the point in deeper than it was, and pushes the old depth out at v_d at most, whatever
h (the split of a position correction from the velocity it leaves, as in Macklin et al. 2014's pre-stabilisation of
initial overlaps). The push-out counts in the particle's normal load like any correction: the old depth of a resting
or sliding rope is what the sweeps after the contacts left (friction's sideways corrections of chords on a curved
surface), and its push-out is the surface's reaction to them, while a start overlap's adds at most v_d h per
substep, for depth / v_d (``docs/measurements.md``). A moving obstacle's C₀ would hold its motion, and is left out:
its contacts are projected whole. Where some obstacle moves, the sweep projects the static obstacles' contacts after
the moving ones', so that a cable squeezed between a moving body and a static one leaves no depth in the static one
(which would push it out at v_d only, and carry little of the squeeze's load).

**Friction per particle.** Several segment contacts share a particle (a rope wrapped on a peg touches it with every
chord), and the split of the normal force between neighbouring chords is statically indeterminate: a Gauss-Seidel
sweep leaves it alternating, big and small, while each particle's total is exact. So friction acts on particles:
particle j's normal n̂ⱼ is the mean of its pressing contacts' normals weighted by its share ∇ⱼC_c of each (on a
curve, the bisector of the two chords), its normal multiplier λₙⱼ = n̂ⱼ·Σ_c ∇ⱼC_c Δλₙ_c n_c (summed over its
contacts and the substep's iterations), and its μ the largest of its contacts'. A contact whose normal opposes the
particle's sum so far (a cable squeezed between two faces) is counted turned round, so that the cone holds the
sum of both faces' normal impulses instead of their cancelling vector sum; the particle keeps one anchor, on the
obstacle it is anchored on while it presses it (else the first it presses in the substep), and
:func:`~mjcable.solvers.impulse_kernels.collect_impulses` shares its friction among the obstacles in proportion to
their normal impulses.

**Static friction with anchors** ([M20] §3.5, positional static friction; here kept across substeps and steps). A
pressed particle has an anchor on the obstacle, stored in the obstacle's frame (a static obstacle's frame is the
world's: its anchors are kept in world coordinates); it is set where the particle was
when the substep began the first time the particle presses. Each iteration pulls the particle's tangential offset
from its anchor, Δx_t = (xⱼ − aⱼ) − ((xⱼ − aⱼ)·n̂) n̂, back with the impulse −Δx_t / wⱼ, as long as the
substep's tangential impulse (friction plus the chords' sideways push) stays in Coulomb's cone, |t| ≤ μ λₙ (both
impulses × h). Beyond, only the share that reaches the cone's rim is applied: the kinetic friction force
μ N = μ λₙ / h², and the particle slides; the anchor then moves to where the substep leaves the particle. An
anchor is dropped when its particle no longer presses. So a sticking contact does not creep: a
slip left over by one substep's single iteration is pulled back in the next ones (the drift that resetting the
anchor every substep cannot undo), and the result does not depend on the substep count ([M19]: the same forces
per unit time at any h).

**Self contacts** and contacts between cables: :mod:`mjcable.solvers.cable_contact_kernels`.

References:
  [J01] T. Jakobsen, "Advanced Character Physics", GDC 2001 (in ``shared/seeds``).
  [M16] M. Macklin, M. Müller, N. Chentanez, "XPBD: Position-Based Simulation of Compliant Constrained
        Dynamics", MIG 2016.
  [M19] M. Macklin, K. Storey, M. Lu, P. Terdiman, N. Chentanez, S. Jeschke, M. Müller, "Small Steps in Physics
        Simulation", SCA 2019.
  [M20] M. Müller, M. Macklin, N. Chentanez, S. Jeschke, T.-Y. Kim, "Detailed Rigid Body Simulation with Extended
        Position Based Dynamics", SCA 2020.
"""

from __future__ import annotations

import math

from mjcable.solvers._kernel_cache import inline as _inline, jit as _jit, variable
from mjcable.solvers.kernels_layout import (_TINY_LENGTH, BOX_FACE_FLAT, BOX_FACE_NEGATIVE, BOX_FACE_SOLE,
                                            DEPENETRATION_SPEED, GEOM_BOX, GEOM_CAPSULE, GEOM_CYLINDER,
                                            GEOM_ELLIPSOID, GEOM_PLANE, GEOM_SPHERE, Shapes)

__all__ = ["shape_distance", "shapes_of", "box_face", "contact_sweep", "friction_sweep", "update_anchors",
           "reset_friction"]


@_inline
def shapes_of(S):
    """The state's obstacle shapes as one :class:`~mjcable.solvers.kernels_layout.Shapes` (views, no copies)."""
    return Shapes(S.shape_type, S.shape_size, S.shape_pos, S.shape_rot)


@_inline
def box_face(rot, row, n0x, n0y, n0z):
    """The face of box ``row`` (rotations ``rot`` (B, 3, 3)) that the detection normal n₀ picks: the face whose
    outward normal is closest to n₀, as ``BOX_FACE_*`` (axis, plus ``BOX_FACE_NEGATIVE`` for the −axis face)."""
    mx = rot[row, 0, 0] * n0x + rot[row, 1, 0] * n0y + rot[row, 2, 0] * n0z  # n₀ in the box frame
    my = rot[row, 0, 1] * n0x + rot[row, 1, 1] * n0y + rot[row, 2, 1] * n0z
    mz = rot[row, 0, 2] * n0x + rot[row, 1, 2] * n0y + rot[row, 2, 2] * n0z
    if abs(mx) >= abs(my) and abs(mx) >= abs(mz):
        return 0 if mx >= 0.0 else BOX_FACE_NEGATIVE
    if abs(my) >= abs(mz):
        return 1 if my >= 0.0 else 1 + BOX_FACE_NEGATIVE
    return 2 if mz >= 0.0 else 2 + BOX_FACE_NEGATIVE


@_inline
def shape_distance(px, py, pz, shapes, row, n0x, n0y, n0z, offset, radius, face=-1):
    """(C, n): C = signed distance of the axis point p from the obstacle's surface minus the cable ``radius``, n the
    outward unit normal (world), from row ``row`` of ``shapes`` (a :class:`~mjcable.solvers.kernels_layout.Shapes`:
    MuJoCo geom type, size (3), world position (3) and rotation (3, 3)).

    Exact closest points for spheres, capsules, cylinders and boxes, the plane's half-space, and for ellipsoids the
    estimate k₀ (k₀ − 1) / k₁ with k₀ = |q / a|, k₁ = |q / a²| (exact on the surface and along the axes; Quílez's
    ellipsoid distance bound) and the normal along ∇(Σ qₖ² / aₖ²). Every other type, and a
    degenerate point (at a sphere's centre), uses the detection's half-space n₀·p ≥ ``offset``. Sided against
    tunnelling: a point inside a round shape whose normal turned against the detection normal n₀ (it went past
    the centre) keeps the detection half-space, and a box pushes a point out through the face n₀ detected (the
    face whose normal is closest to n₀, :func:`box_face`; ``face``, if not −1, is that face, found once for a static
    box), also after the point went through a thin plate."""
    typ = shapes.type[row]
    size, pos, rot = shapes.size, shapes.pos, shapes.rot
    sx, sy, sz = size[row, 0], size[row, 1], size[row, 2]
    dx, dy, dz = px - pos[row, 0], py - pos[row, 1], pz - pos[row, 2]
    # q = Rᵀ (p − pos): the point in the geom frame
    qx = rot[row, 0, 0] * dx + rot[row, 1, 0] * dy + rot[row, 2, 0] * dz
    qy = rot[row, 0, 1] * dx + rot[row, 1, 1] * dy + rot[row, 2, 1] * dz
    qz = rot[row, 0, 2] * dx + rot[row, 1, 2] * dy + rot[row, 2, 2] * dz
    lx, ly, lz, d, exact = 0.0, 0.0, 1.0, 0.0, True
    if typ == GEOM_PLANE:
        d = qz
    elif typ == GEOM_SPHERE or typ == GEOM_CAPSULE:
        if typ == GEOM_CAPSULE:
            qz -= min(max(qz, -sy), sy)
        rad = math.sqrt(qx * qx + qy * qy + qz * qz)
        if rad > _TINY_LENGTH:
            lx, ly, lz = qx / rad, qy / rad, qz / rad
        else:
            exact = False
        d = rad - sx
    elif typ == GEOM_CYLINDER:
        rad = math.sqrt(qx * qx + qy * qy)
        ox, oy = (qx / rad, qy / rad) if rad > _TINY_LENGTH else (1.0, 0.0)
        cap = 1.0 if qz >= 0.0 else -1.0
        d_side, d_cap = rad - sx, abs(qz) - sy
        if d_side > 0.0 and d_cap > 0.0:  # beyond the rim: the closest point is on the rim circle
            d = math.sqrt(d_side * d_side + d_cap * d_cap)
            lx, ly, lz = d_side * ox / d, d_side * oy / d, d_cap * cap / d
        elif d_side >= d_cap:
            d, lx, ly, lz = d_side, ox, oy, 0.0
        else:
            d, lz = d_cap, cap
    elif typ == GEOM_BOX:
        if face < 0:  # n₀ picks the face
            face = box_face(rot, row, n0x, n0y, n0z)
        sign = -1.0 if face >= BOX_FACE_NEGATIVE else 1.0
        ex, ey, ez = abs(qx) - sx, abs(qy) - sy, abs(qz) - sz
        if face % BOX_FACE_NEGATIVE == 0:
            axis, qk, hk, beside = 0, qx, sx, ey > 0.0 or ez > 0.0
        elif face % BOX_FACE_NEGATIVE == 1:
            axis, qk, hk, beside = 1, qy, sy, ex > 0.0 or ez > 0.0
        else:
            axis, qk, hk, beside = 2, qz, sz, ex > 0.0 or ey > 0.0
        if not beside:
            # over the detected face (outside it, inside the box, or through the plate under it): the face's plane,
            # d = sign qₖ − hₖ, n = sign Rₖ (never against n₀), the closest point's d = |qₖ − clamp(qₖ)| without
            # the square root and the rotation (a cable resting on a box takes this branch)
            return (sign * qk - hk - radius, sign * rot[row, 0, axis], sign * rot[row, 1, axis],
                    sign * rot[row, 2, axis])
        else:  # beside the face: the closest point on the box
            cx = qx - min(max(qx, -sx), sx)
            cy = qy - min(max(qy, -sy), sy)
            cz = qz - min(max(qz, -sz), sz)
            d = math.sqrt(cx * cx + cy * cy + cz * cz)
            if d > _TINY_LENGTH:
                lx, ly, lz = cx / d, cy / d, cz / d
            else:
                exact = False
    elif typ == GEOM_ELLIPSOID:
        gx, gy, gz = qx / (sx * sx), qy / (sy * sy), qz / (sz * sz)  # ½ ∇f
        g = math.sqrt(gx * gx + gy * gy + gz * gz)
        if g > _TINY_LENGTH:
            k0 = math.sqrt(qx * gx + qy * gy + qz * gz)  # |q / a|: 1 on the surface
            d = k0 * (k0 - 1.0) / g
            lx, ly, lz = gx / g, gy / g, gz / g
        else:
            exact = False
    else:
        exact = False
    nx = rot[row, 0, 0] * lx + rot[row, 0, 1] * ly + rot[row, 0, 2] * lz  # n = R l
    ny = rot[row, 1, 0] * lx + rot[row, 1, 1] * ly + rot[row, 1, 2] * lz
    nz = rot[row, 2, 0] * lx + rot[row, 2, 1] * ly + rot[row, 2, 2] * lz
    if exact and d < 0.0 and nx * n0x + ny * n0y + nz * n0z < 0.0:
        exact = False
    if not exact:
        return n0x * px + n0y * py + n0z * pz - offset, n0x, n0y, n0z
    return d - radius, nx, ny, nz


@_inline
def _to_local(shapes, row, px, py, pz):
    """Rᵀ (p − pos): a world point in the frame of ``shapes``' row ``row``."""
    pos, rot = shapes.pos, shapes.rot
    dx, dy, dz = px - pos[row, 0], py - pos[row, 1], pz - pos[row, 2]
    return (rot[row, 0, 0] * dx + rot[row, 1, 0] * dy + rot[row, 2, 0] * dz,
            rot[row, 0, 1] * dx + rot[row, 1, 1] * dy + rot[row, 2, 1] * dz,
            rot[row, 0, 2] * dx + rot[row, 1, 2] * dy + rot[row, 2, 2] * dz)


@_inline
def _to_world(shapes, row, qx, qy, qz):
    """pos + R q: a point of the frame of ``shapes``' row ``row`` in the world."""
    pos, rot = shapes.pos, shapes.rot
    return (pos[row, 0] + rot[row, 0, 0] * qx + rot[row, 0, 1] * qy + rot[row, 0, 2] * qz,
            pos[row, 1] + rot[row, 1, 0] * qx + rot[row, 1, 1] * qy + rot[row, 1, 2] * qz,
            pos[row, 2] + rot[row, 2, 0] * qx + rot[row, 2, 1] * qy + rot[row, 2, 2] * qz)


@_jit
def reset_friction(S):
    """Zero the substep's per-particle normal and friction sums (``fric_*``), keeping each particle's obstacle
    ``fric_ob``. The step drivers leave this to :func:`update_anchors` (which zeroes the rows it used); a Python
    caller of the sweeps calls it before each substep."""
    S.fric_n[:] = 0.0
    S.fric_mu[:] = 0.0
    S.fric_slid[:] = False
    S.fric_nsum[:, :] = 0.0
    S.fric_impulse[:, :] = 0.0
    S.fric_normal[:, :] = 0.0


@_inline
def is_flat(face):
    """Whether ``con_face`` marks a contact measured as a flat face's plane (``BOX_FACE_FLAT`` or ``_SOLE``)."""
    return face == BOX_FACE_FLAT or face == BOX_FACE_SOLE


@_inline
def _is_round(typ):  # a sphere, cylinder or capsule (MuJoCo geom type)
    return typ == GEOM_SPHERE or typ == GEOM_CYLINDER or typ == GEOM_CAPSULE


@_inline
def _round_fraction(shapes, row, x, i, s):
    """The fraction of segment (i, i+1) of ``x`` closest to round obstacle ``row`` of ``shapes`` (a sphere's centre,
    a cylinder's or capsule's axis line), in [0, 1]; ``s`` (the query's fraction) for every other shape and for a
    segment parallel to the axis: a chord on a round shape touches it at that point, which moves as the chord turns
    (``docs/measurements.md``, the dropped rope)."""
    typ = shapes.type[row]
    if not _is_round(typ):
        return s
    pos, rot = shapes.pos, shapes.rot
    dx, dy, dz = x[i + 1, 0] - x[i, 0], x[i + 1, 1] - x[i, 1], x[i + 1, 2] - x[i, 2]
    rx, ry, rz = x[i, 0] - pos[row, 0], x[i, 1] - pos[row, 1], x[i, 2] - pos[row, 2]
    if typ != GEOM_SPHERE:  # the axis' direction out of both: the closest point to the axis line
        ax, ay, az = rot[row, 0, 2], rot[row, 1, 2], rot[row, 2, 2]
        da, ra = dx * ax + dy * ay + dz * az, rx * ax + ry * ay + rz * az
        dx, dy, dz = dx - da * ax, dy - da * ay, dz - da * az
        rx, ry, rz = rx - ra * ax, ry - ra * ay, rz - ra * az
    dd = dx * dx + dy * dy + dz * dz
    if dd <= _TINY_LENGTH * _TINY_LENGTH:
        return s
    return min(max(-(rx * dx + ry * dy + rz * dz) / dd, 0.0), 1.0)


@_jit
def _round_fractions(S):
    """Contacts inside a segment on a round obstacle move to its closest point (:func:`_round_fraction`)."""
    shapes = shapes_of(S)
    seg, con_s, con_shape, con_face, x = S.con_seg, S.con_s, S.con_shape, S.con_face, S.x
    for c in range(S.par[0].n_con):
        k, s = con_shape[c], con_s[c]
        if k >= 0 and not is_flat(con_face[c]) and 0.0 < s < 1.0:
            con_s[c] = _round_fraction(shapes, k, x, seg[c], s)


@_inline
def contact_sweep(S):
    """:func:`_project_contacts` after :func:`_round_fractions` (compiled apart: the round shapes' pass in the
    projection's function made its loop 10 % slower where no contact is round)."""
    types = S.shape_type
    for r in range(types.shape[0]):
        if _is_round(types[r]):
            _round_fractions(S)
            break
    return _project_contacts(S)


@_jit
def _project_contacts(S):
    """The state's obstacle contacts (``par.n_con`` of them: segment ``con_seg``, fraction ``con_s``, detection
    normal ``con_normal`` and ``con_offset``, ``con_mu``, obstacle row ``con_shape`` or −1, a static box's face
    ``con_face``, multipliers ``con_lam``). Projects C ≥ 0 (module docstring; on a static obstacle C ≥ min(0, C₀ +
    v_d h), C₀ from the substep's start ``x0``) against the obstacle's shape, and adds each particle's share of
    Δλₙ to its friction sums (``fric_n``, ``fric_mu``, ``fric_nsum``, ``fric_normal``, the obstacle ``fric_ob``);
    the static obstacles' contacts come last. A held particle (w = 0) collects its share of ∇C Δλ in ``react``; a
    contact nearer a held particle than its segment's middle is left to the pin. Returns the most depth removed (m)."""
    P = S.par[0]
    seg_radius = S.seg_radius  # (each segment's cable's radius)
    recover = DEPENETRATION_SPEED * P.h
    x, x0, w, react, moves = S.x, S.x0, S.w, S.react, S.shape_moves
    fric_n, fric_mu, fric_nsum, fric_normal, fric_ob, anchor_ob = (S.fric_n, S.fric_mu, S.fric_nsum, S.fric_normal,
                                                                   S.fric_ob, S.anchor_ob)
    seg, con_s, con_normal, con_offset, con_mu, con_shape, con_face, lam = (
        S.con_seg, S.con_s, S.con_normal, S.con_offset, S.con_mu, S.con_shape, S.con_face, S.con_lam)
    shapes = shapes_of(S)
    n_con = P.n_con
    deepest = 0.0  # the most depth one projection removed
    mixed = False  # some obstacle moves: two passes, the static obstacles second (they hold when the sweep ends)
    for r in range(moves.shape[0]):
        mixed = mixed or moves[r]
    for q in range(2 * n_con if mixed else n_con):
        c = q if q < n_con else q - n_con
        k = con_shape[c]
        if mixed and (q < n_con) == (k >= 0 and not moves[k]):
            continue
        i = seg[c]
        j = i + 1
        s = con_s[c]
        a, b = 1.0 - s, s
        wi, wj = w[i], w[j]
        wsum = a * a * wi + b * b * wj
        if wsum == 0.0:
            continue
        if (wi == 0.0 and a > 0.5) or (wj == 0.0 and b > 0.5):
            # nearer a held particle than the segment's middle, the contact is the pin's: the free particle alone
            # would satisfy it with a lever of 1/share, a correction without bound as the point nears the pin
            continue
        inv_wsum = 1.0 / wsum
        if b == 0.0:  # at a particle (the query puts a contact this near a segment's end on the particle)
            px, py, pz = x[i, 0], x[i, 1], x[i, 2]
            ox, oy, oz = x0[i, 0], x0[i, 1], x0[i, 2]
        elif a == 0.0:
            px, py, pz = x[j, 0], x[j, 1], x[j, 2]
            ox, oy, oz = x0[j, 0], x0[j, 1], x0[j, 2]
        else:
            px = a * x[i, 0] + b * x[j, 0]
            py = a * x[i, 1] + b * x[j, 1]
            pz = a * x[i, 2] + b * x[j, 2]
            ox = a * x0[i, 0] + b * x0[j, 0]
            oy = a * x0[i, 1] + b * x0[j, 1]
            oz = a * x0[i, 2] + b * x0[j, 2]
        face = con_face[c]
        flat = is_flat(face)  # a static plane or face: the half-space below
        if k >= 0 and not flat:  # measured against the shape
            cval, nx, ny, nz = shape_distance(px, py, pz, shapes, k, con_normal[c, 0], con_normal[c, 1],
                                              con_normal[c, 2], con_offset[c], seg_radius[i], con_face[c])
        else:
            nx, ny, nz = con_normal[c, 0], con_normal[c, 1], con_normal[c, 2]
            cval = nx * px + ny * py + nz * pz - con_offset[c]
        if cval >= 0.0:
            continue
        start = 0.0  # C₀, the depth of the same point at the substep's start (a static obstacle's), C − n·(p − p₀)
        if flat or (k >= 0 and not moves[k]):
            start = min(cval - nx * (px - ox) - ny * (py - oy) - nz * (pz - oz), 0.0)
        excess = cval - min(start + recover, 0.0)  # C less its target: the depth this projection removes
        if excess >= 0.0:
            continue
        deepest = max(deepest, -excess)
        dlam = -excess * inv_wsum
        lam[c] += dlam
        mu = con_mu[c]
        for p, f, wp in ((i, a, wi), (j, b, wj)):
            if f == 0.0:  # the contact acts at the other particle: none of its load, μ or obstacle here
                continue
            g = f * dlam
            if wp > 0.0:
                m = wp * f * inv_wsum * excess  # −wₚ g, with C last: a short chain from x through C to Δx
                x[p, 0] -= m * nx
                x[p, 1] -= m * ny
                x[p, 2] -= m * nz
            else:
                react[p, 0] += g * nx
                react[p, 1] += g * ny
                react[p, 2] += g * nz
            if fric_n[p] == 0.0 or k == anchor_ob[p]:
                # the particle's friction obstacle: the one it is anchored on while it presses on it, else the
                # first it presses in the substep (a particle between two obstacles keeps one anchor)
                fric_ob[p] = k
            fric_n[p] += g
            fric_mu[p] = max(fric_mu[p], mu)
            if face == BOX_FACE_SOLE:  # the particle's one contact: its cone's normal is n (no sums to keep)
                continue
            # a normal against the particle's summed one (a cable squeezed between two faces) counts turned round:
            # the particle's cone is then Σ of both sides' normal impulses, not their cancelling vector sum
            turn = -1.0 if fric_normal[p, 0] * nx + fric_normal[p, 1] * ny + fric_normal[p, 2] * nz < 0.0 else 1.0
            fric_nsum[p, 0] += turn * g * nx
            fric_nsum[p, 1] += turn * g * ny
            fric_nsum[p, 2] += turn * g * nz
            fric_normal[p, 0] += turn * f * nx
            fric_normal[p, 1] += turn * f * ny
            fric_normal[p, 2] += turn * f * nz
    return deepest


@_inline
def _friction_cones(S):
    """The first pass of :func:`friction_sweep`: each pressed free particle's cone from its sums, its unit normal
    n̂ (``fric_unit``), the sums' tangential part t_c (``fric_push``) and the cone's radius μ λₙ (``fric_cone``; −1
    for a particle without friction this substep). The particles' cones do not depend on one another, so this pass
    runs without the second's chain through the positions. A particle whose one contact is flat (``fric_sole``) has
    its n̂ and t_c = 0 from the query (:func:`~mjcable.solvers.query_kernels.flatten_contacts`) and λₙ = Σ Δλₙ."""
    w, fric_n, fric_mu, fric_nsum, fric_normal, fric_ob = (S.w, S.fric_n, S.fric_mu, S.fric_nsum, S.fric_normal,
                                                           S.fric_ob)
    unit, push, cone, sole = S.fric_unit, S.fric_push, S.fric_cone, S.fric_sole
    for p in range(w.shape[0]):
        cone[p] = -1.0
        if fric_n[p] <= 0.0 or w[p] == 0.0 or fric_ob[p] < 0:
            continue
        if sole[p]:  # one flat contact: n̂ and t_c = 0 are the query's (flatten_contacts), λₙ = Σ Δλₙ
            cone[p] = fric_mu[p] * fric_n[p]
            continue
        sx, sy, sz = fric_nsum[p, 0], fric_nsum[p, 1], fric_nsum[p, 2]  # Σ Δλ_c n_c
        nx, ny, nz = fric_normal[p, 0], fric_normal[p, 1], fric_normal[p, 2]
        norm = math.sqrt(nx * nx + ny * ny + nz * nz)
        if norm <= 0.0:
            continue
        inv_norm = 1.0 / norm
        nx, ny, nz = nx * inv_norm, ny * inv_norm, nz * inv_norm
        lam_n = sx * nx + sy * ny + sz * nz
        if lam_n <= 0.0:
            continue
        unit[p, 0], unit[p, 1], unit[p, 2] = nx, ny, nz
        push[p, 0], push[p, 1], push[p, 2] = sx - lam_n * nx, sy - lam_n * ny, sz - lam_n * nz
        cone[p] = fric_mu[p] * lam_n


@_inline
def friction_sweep(S, finish):
    """Coulomb friction of every pressed particle against its anchor (module docstring): the friction sums
    (``fric_*``) from :func:`contact_sweep`, anchors ``anchor`` (N, 3) in the frame of obstacle ``anchor_ob`` (N,)
    (world coordinates on a static obstacle; −1: none; a new anchor is set at the particle's substep start ``x0``).
    Held particles are skipped. ``finish``: the substep's last sweep, which also ends each particle's substep
    (:func:`update_anchors`, in the same pass).

    The cone is the particle's (:func:`_friction_cones`): its normal n̂ is the mean of its pressing contacts'
    normals, weighted by the particle's share of each (the bisector of two chords on a curve), its normal impulse
    λₙ = n̂·Σ Δλ_c n_c, and the tangential part of the contact impulses, t_c = Σ Δλ_c n_c − λₙ n̂
    (chords touching a curved surface push a particle a little sideways), counts with the friction impulse f:
    |t_c + f| ≤ μ λₙ, with μ the largest of its contacts' coefficients. Friction only ever opposes the slip: f
    grows by the largest share α ≤ 1 of the impulse −Δx_t / w that stays in the cone (none if t_c alone is
    outside it). Returns the largest correction |Δx| (m)."""
    return _particle_sweep(S, variable(True), variable(finish))


@_inline
def update_anchors(S):
    """End of a substep: drop the anchors of particles that no longer press, move those of sliding particles to
    where they are now (in their obstacle's frame; the world's for a static one), and zero the substep's sums
    (:func:`reset_friction`) of the particles that had contacts. (The substep's last :func:`friction_sweep` does
    this in its own pass when nothing reads the sums after it.)"""
    _particle_sweep(S, variable(False), variable(True))


@_jit
def _particle_sweep(S, friction, finish):
    """One pass over the particles: with ``friction``, :func:`friction_sweep`'s (its cones first); with
    ``finish``, each particle's end of the substep (:func:`update_anchors`) right after its friction, in the same
    pass (one pass less over the particles per substep: ``docs/measurements.md``). Returns the largest friction
    correction |Δx| (m) of a pass that does not ``finish``."""
    if friction:
        _friction_cones(S)
    x, x0, w, anchor, anchor_ob, moves = S.x, S.x0, S.w, S.anchor, S.anchor_ob, S.shape_moves
    fric_n, fric_mu, fric_slid, fric_nsum, fric_impulse, fric_normal = (S.fric_n, S.fric_mu, S.fric_slid, S.fric_nsum,
                                                                        S.fric_impulse, S.fric_normal)
    fric_ob = S.fric_ob
    unit, push, cones = S.fric_unit, S.fric_push, S.fric_cone
    shapes = shapes_of(S)
    largest = 0.0  # the largest correction (m²: squared)
    for p in range(x.shape[0]):
        cone = cones[p] if friction else -1.0
        if cone >= 0.0:
            k = fric_ob[p]
            nx, ny, nz = unit[p, 0], unit[p, 1], unit[p, 2]
            tcx, tcy, tcz = push[p, 0], push[p, 1], push[p, 2]
            # a static obstacle's anchors are kept in world coordinates, a moving one's in its frame
            static = not moves[k]
            if anchor_ob[p] != k:
                if static:
                    anchor[p, 0], anchor[p, 1], anchor[p, 2] = x0[p, 0], x0[p, 1], x0[p, 2]
                else:
                    anchor[p, 0], anchor[p, 1], anchor[p, 2] = _to_local(shapes, k, x0[p, 0], x0[p, 1], x0[p, 2])
                anchor_ob[p] = k
            if static:
                ax, ay, az = anchor[p, 0], anchor[p, 1], anchor[p, 2]
            else:
                ax, ay, az = _to_world(shapes, k, anchor[p, 0], anchor[p, 1], anchor[p, 2])
            dx, dy, dz = x[p, 0] - ax, x[p, 1] - ay, x[p, 2] - az
            dn = dx * nx + dy * ny + dz * nz
            inv_w = 1.0 / w[p]
            fx0, fy0, fz0 = fric_impulse[p, 0], fric_impulse[p, 1], fric_impulse[p, 2]
            ex = -(dx - dn * nx) * inv_w  # the friction impulse that puts the particle back over its anchor
            ey = -(dy - dn * ny) * inv_w
            ez = -(dz - dn * nz) * inv_w
            ux, uy, uz = tcx + fx0, tcy + fy0, tcz + fz0  # the tangential impulse so far
            qa = ex * ex + ey * ey + ez * ez
            qb = ux * ex + uy * ey + uz * ez
            qc = ux * ux + uy * uy + uz * uz - cone * cone
            # the largest share α ∈ [0, 1] of that impulse inside the cone: |u + α e|² = qc + 2 α qb + α² qa ≤ 0
            if qc <= 0.0 and qa + 2.0 * qb + qc <= 0.0:  # all of it (the sticking particle: no root to take)
                alpha = 1.0
            elif qa <= 0.0:  # at its anchor already
                alpha = 0.0
            else:
                alpha = 0.0 if qc > 0.0 else (-qb + math.sqrt(max(qb * qb - qa * qc, 0.0))) / qa
                if alpha < 1.0:  # outside the cone: kinetic friction on its rim, and the particle slides
                    fric_slid[p] = True
                else:
                    alpha = 1.0
            fric_impulse[p, 0], fric_impulse[p, 1], fric_impulse[p, 2] = (fx0 + alpha * ex, fy0 + alpha * ey,
                                                                          fz0 + alpha * ez)
            g = w[p] * alpha
            x[p, 0] += g * ex
            x[p, 1] += g * ey
            x[p, 2] += g * ez
            if not finish:  # (read by the impact's iterations only)
                largest = max(largest, g * g * qa)
        if finish:  # (written out here: an inline helper taking these arrays would cost reference counting)
            if fric_n[p] <= 0.0:
                anchor_ob[p] = -1
                continue
            k = anchor_ob[p]
            if k >= 0 and fric_slid[p]:
                if moves[k]:
                    anchor[p, 0], anchor[p, 1], anchor[p, 2] = _to_local(shapes, k, x[p, 0], x[p, 1], x[p, 2])
                else:
                    anchor[p, 0], anchor[p, 1], anchor[p, 2] = x[p, 0], x[p, 1], x[p, 2]
            fric_n[p] = 0.0
            fric_mu[p] = 0.0
            fric_slid[p] = False
            for c in range(3):
                fric_nsum[p, c] = 0.0
                fric_impulse[p, c] = 0.0
                fric_normal[p, c] = 0.0
    return math.sqrt(largest)
