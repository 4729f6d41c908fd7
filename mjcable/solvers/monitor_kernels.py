"""The physics checks every model's steps pass, ``@njit`` (cached, see :mod:`mjcable.solvers._kernel_cache`): the
particle solvers' compiled step loop calls :func:`step_check` (and :func:`contact_depth`) after each step, the native
backend calls :func:`step_check` after each ``dt`` of ``mj_step``s, so that every model stops on the same tests in the
same arithmetic. The limits come from :mod:`mjcable.monitor` (what each model promises); the messages and fixes too.
"""

from __future__ import annotations

import math

from mjcable.solvers._kernel_cache import jit as _jit
from mjcable.solvers.contact_kernels import shape_distance, shapes_of
from mjcable.solvers.kernels_layout import (CHECK_DISTANCE, CHECK_NON_FINITE, CHECK_OK, CHECK_PIN, CHECK_SPEED,
                                            CHECK_STRAIN, CHECK_VELOCITY, WARN_DEPTH, WARN_STRAIN)

__all__ = ["step_check", "contact_depth", "CHECK_OK", "CHECK_NON_FINITE", "CHECK_DISTANCE", "CHECK_SPEED",
           "CHECK_VELOCITY", "CHECK_PIN", "CHECK_STRAIN", "WARN_STRAIN", "WARN_DEPTH"]


@_jit
def step_check(x, v, prev, rest, pin_p, pin_to, pin_active, lim):
    """(check, measured value, where) of a step that moved the particles from ``prev`` to ``x`` (N, 3) m with the
    model's own velocities ``v`` (N, 3) m/s, in order of precedence:

    * ``CHECK_NON_FINITE``: a NaN or inf in x or v (value NaN, where −1);
    * ``CHECK_DISTANCE``: the largest |coordinate| of x (m), beyond ``lim.max_distance``;
    * ``CHECK_SPEED``: the fastest particle's travel / dt (m/s), beyond ``lim.max_speed``;
    * ``CHECK_VELOCITY``: the fastest of the model's own velocities |vᵢ| (m/s), beyond ``lim.max_speed``;
    * ``CHECK_PIN``: the farthest active pin's |x[pin_p[q]] − pin_to[q]| (m), beyond ``lim.tear`` (where: q);
    * ``CHECK_STRAIN``: the largest segment strain |xᵢ₊₁ − xᵢ| / restᵢ − 1, beyond ``lim.strain_fail`` (where: i);
    * ``WARN_STRAIN``: the same strain beyond ``lim.strain_warn`` (a warning, the run goes on);
    * else ``CHECK_OK`` (0.0, −1).

    ``rest`` (n,) m: segment rest lengths; ``pin_p`` (P,) pinned particles, ``pin_to`` (P, 3) m their targets,
    ``pin_active`` (P,) which still hold; ``lim``: a length-1 record array with fields ``dt`` (s), ``max_distance``,
    ``max_speed``, ``strain_fail``, ``strain_warn``, ``tear`` (the particle state's ``par``, or
    :data:`mjcable.monitor.LIMITS`)."""
    L = lim[0]
    far, top, own, bad = 0.0, 0.0, 0.0, 0.0  # bad: NaN once any x or v is non-finite (0 · z), without a branch
    for p in range(x.shape[0]):  # (each particle's terms summed first: one add per particle on bad's chain)
        x0, x1, x2, v0, v1, v2 = x[p, 0], x[p, 1], x[p, 2], v[p, 0], v[p, 1], v[p, 2]
        bad += ((x0 + x1) + (x2 + v0) + (v1 + v2)) * 0.0
        a = max(abs(x0), abs(x1), abs(x2))
        far = a if a > far else far
        d0, d1, d2 = x0 - prev[p, 0], x1 - prev[p, 1], x2 - prev[p, 2]
        a = d0 * d0 + d1 * d1 + d2 * d2
        top = a if a > top else top
        a = v0 * v0 + v1 * v1 + v2 * v2
        own = a if a > own else own
    if bad != 0.0:
        return CHECK_NON_FINITE, math.nan, -1
    if far > L.max_distance:
        return CHECK_DISTANCE, far, -1
    speed = math.sqrt(top) / L.dt
    if speed > L.max_speed:
        return CHECK_SPEED, speed, -1
    own = math.sqrt(own)
    if own > L.max_speed:
        return CHECK_VELOCITY, own, -1
    torn, at = 0.0, -1
    for q in range(pin_p.shape[0]):
        if pin_active[q]:
            p = pin_p[q]
            d = math.sqrt((x[p, 0] - pin_to[q, 0]) ** 2 + (x[p, 1] - pin_to[q, 1]) ** 2 + (x[p, 2] - pin_to[q, 2]) ** 2)
            if d > torn:
                torn, at = d, q
    if torn > L.tear:
        return CHECK_PIN, torn, at
    # first whether any segment may be past the lower limit, |Δx|² > (1 + limit)² rest², without a root or a
    # division per segment; only then each segment's strain
    reach = (1.0 + min(L.strain_warn, L.strain_fail)) ** 2
    over = 0.0
    for i in range(rest.shape[0]):
        d2 = (x[i + 1, 0] - x[i, 0]) ** 2 + (x[i + 1, 1] - x[i, 1]) ** 2 + (x[i + 1, 2] - x[i, 2]) ** 2
        over = max(over, d2 - reach * rest[i] * rest[i])
    if over <= 0.0:
        return CHECK_OK, 0.0, -1
    strain, seg = -1.0, -1
    for i in range(rest.shape[0]):
        d = math.sqrt((x[i + 1, 0] - x[i, 0]) ** 2 + (x[i + 1, 1] - x[i, 1]) ** 2 + (x[i + 1, 2] - x[i, 2]) ** 2)
        e = d / rest[i] - 1.0
        if e > strain:
            strain, seg = e, i
    if strain > L.strain_fail:
        return CHECK_STRAIN, strain, seg
    if strain > L.strain_warn:
        return WARN_STRAIN, strain, seg
    return CHECK_OK, 0.0, -1


@_jit
def contact_depth(S):
    """(``WARN_DEPTH``, depth in m, segment) if the centreline of a segment in an obstacle contact of the step lies
    inside the obstacle (the cable's surface deeper than its radius, measured against the obstacle's own shape,
    :func:`~mjcable.solvers.contact_kernels.shape_distance`, where the detection's half-space, which holds the convex
    obstacle, says it may be), else (``CHECK_OK``, 0.0, −1); the deepest such."""
    P = S.par[0]
    x, seg_radius = S.x, S.seg_radius
    shapes = shapes_of(S)
    con_seg, con_s, con_normal, con_offset, con_shape, con_face = (S.con_seg, S.con_s, S.con_normal, S.con_offset,
                                                                   S.con_shape, S.con_face)
    deepest, seg = 0.0, -1
    for c in range(P.n_con):
        i, s = con_seg[c], con_s[c]
        radius = seg_radius[i]  # (its cable's)
        px = (1.0 - s) * x[i, 0] + s * x[i + 1, 0]
        py = (1.0 - s) * x[i, 1] + s * x[i + 1, 1]
        pz = (1.0 - s) * x[i, 2] + s * x[i + 1, 2]
        n0x, n0y, n0z = con_normal[c, 0], con_normal[c, 1], con_normal[c, 2]
        gap = n0x * px + n0y * py + n0z * pz - con_offset[c]  # the detection's half-space
        if gap >= -radius:  # a convex obstacle lies inside its tangent half-space: not deep (the usual case)
            continue
        row = con_shape[c]
        if row >= 0:
            gap, _, _, _ = shape_distance(px, py, pz, shapes, row, n0x, n0y, n0z, con_offset[c], radius, con_face[c])
        depth = -gap  # how far the cable's surface reaches into the obstacle, m
        if depth > radius and depth > deepest:
            deepest, seg = depth, i
    if seg >= 0:
        return WARN_DEPTH, deepest, seg
    return CHECK_OK, 0.0, -1
