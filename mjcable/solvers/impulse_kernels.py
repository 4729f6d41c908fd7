"""Two-way contacts of the particle solvers with a user world's bodies, ``@njit`` (cached, see
:mod:`mjcable.solvers._kernel_cache`): the impulses a substep's obstacle contacts gave the cable, per obstacle
(:func:`collect_impulses`), and the wrenches they put on the world's bodies (:func:`body_wrenches`). The contacts
themselves are :mod:`mjcable.solvers.contact_kernels`'."""

from __future__ import annotations

from mjcable.solvers._kernel_cache import inline as _inline, jit as _jit
from mjcable.solvers.contact_kernels import shape_distance, shapes_of

__all__ = ["collect_impulses", "body_wrenches"]


@_inline
def _add_impulse(force, moment, k, px, py, pz, jx, jy, jz):
    """Add the impulse j (kg·m) at the point p to obstacle row ``k`` of ``force`` (B, 3) (Σ j) and ``moment``
    (B, 3) (Σ p × j)."""
    force[k, 0] += jx
    force[k, 1] += jy
    force[k, 2] += jz
    moment[k, 0] += py * jz - pz * jy
    moment[k, 1] += pz * jx - px * jz
    moment[k, 2] += px * jy - py * jx


@_jit
def collect_impulses(S):
    """End of a substep, before :func:`~mjcable.solvers.contact_kernels.update_anchors`: add each obstacle's contact
    impulses on the cable in this substep to its row of ``impulse_force`` (Σ j, kg·m) and ``impulse_moment`` (Σ point ×
    j, kg·m², about the world origin; the caller zeroes them). Normal: contact c's Σ Δλₙ (``con_lam``) along its normal
    n_c at the axis point now (the cable side's ∇C Δλ summed over both particles, held ones included). Friction: each
    free particle's friction impulse f (``fric_impulse``) is shared among the contacts that pressed it in proportion to
    their normal impulses on it, g_c / Σ g (``fric_n``), each share at the particle's contact point x − r n_c: a cable
    squeezed between a table and a weight drags both by the friction of each side. Σ j / h is the momentum the obstacle
    gave the cable (Σ m Δx for free particles), −Σ j / h² the force on the obstacle. Self contacts are internal and give
    nothing."""
    P = S.par[0]
    x, w, fric_n, fric_impulse = S.x, S.w, S.fric_n, S.fric_impulse
    seg, con_s, con_normal, con_offset, con_shape, lam = (S.con_seg, S.con_s, S.con_normal, S.con_offset,
                                                          S.con_shape, S.con_lam)
    force, moment = S.impulse_force, S.impulse_moment
    shapes = shapes_of(S)
    for c in range(P.n_con):
        k = con_shape[c]
        if k < 0 or lam[c] == 0.0:
            continue
        i = seg[c]
        s = con_s[c]
        radius = S.seg_radius[i]  # (its cable's)
        px = (1.0 - s) * x[i, 0] + s * x[i + 1, 0]
        py = (1.0 - s) * x[i, 1] + s * x[i + 1, 1]
        pz = (1.0 - s) * x[i, 2] + s * x[i + 1, 2]
        _, nx, ny, nz = shape_distance(px, py, pz, shapes, k, con_normal[c, 0], con_normal[c, 1], con_normal[c, 2],
                                       con_offset[c], radius)
        g = lam[c]
        _add_impulse(force, moment, k, px, py, pz, g * nx, g * ny, g * nz)
        for p, f in ((i, 1.0 - s), (i + 1, s)):
            if f == 0.0 or w[p] == 0.0 or fric_n[p] <= 0.0:
                continue
            share = f * g / fric_n[p]
            jx, jy, jz = share * fric_impulse[p, 0], share * fric_impulse[p, 1], share * fric_impulse[p, 2]
            if jx != 0.0 or jy != 0.0 or jz != 0.0:
                _add_impulse(force, moment, k, x[p, 0] - radius * nx, x[p, 1] - radius * ny, x[p, 2] - radius * nz,
                             jx, jy, jz)


@_jit
def body_wrenches(S, scale):
    """The bodies' side of :func:`collect_impulses`: ``contact_wrench`` (nbody, 6) zeroed, then for obstacle row
    ``wrench_rows[r]`` on body ``wrench_bodies[r]`` the force F = ``scale`` · Σ j (scale = −1/h²) and its moment
    about the body's centre of mass ``xipos[b]``, scale · Σ p × j − xipos × F, added to ``contact_wrench`` and to
    ``xfrc_applied`` (MuJoCo's)."""
    force, moment, rows, bodies, xipos = S.impulse_force, S.impulse_moment, S.wrench_rows, S.wrench_bodies, S.xipos
    wrench, xfrc = S.contact_wrench, S.xfrc_applied
    wrench[:] = 0.0
    for r in range(rows.shape[0]):
        k, b = rows[r], bodies[r]
        fx, fy, fz = scale * force[k, 0], scale * force[k, 1], scale * force[k, 2]
        cx, cy, cz = xipos[b, 0], xipos[b, 1], xipos[b, 2]
        wrench[b, 0] += fx
        wrench[b, 1] += fy
        wrench[b, 2] += fz
        wrench[b, 3] += scale * moment[k, 0] - (cy * fz - cz * fy)
        wrench[b, 4] += scale * moment[k, 1] - (cz * fx - cx * fz)
        wrench[b, 5] += scale * moment[k, 2] - (cx * fy - cy * fx)
    for r in range(rows.shape[0]):
        b = bodies[r]
        first = True
        for q in range(r):  # a body with several obstacle rows gets its wrench once
            first = first and bodies[q] != b
        if first:
            for col in range(6):
                xfrc[b, col] += wrench[b, col]
