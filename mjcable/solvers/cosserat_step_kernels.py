"""The ``cosserat`` rod's substep around its constraints, ``@njit`` (cached, see
:mod:`mjcable.solvers._kernel_cache`): one iteration in the configured order (:func:`rod_iterate`, the direct solve
with its nonlinear safeguard), the frames' prediction and angular velocities, and the clamps' frames.

The direct solve's safeguard, as ``xpbd``'s (:func:`mjcable.solvers.direct_kernels.direct_solve`). One direct solve
is Newton's step on the constraints C(x, q) + α̃ λ = 0 ([D18]; :mod:`mjcable.solvers.cosserat_kernels`), exact where
they are linear. They are not: a frame that turns by δb and a segment whose ends move by Δx leave second-order
terms, up to |δb|² + 2 |δb| |Δx| / l₀ in the rows' residuals (each as a strain or an angle: the stretch–shear rows
as they are, the bend–twist rows times l₀ / 2, the clamps' times l₀ / 4). When a gripper yanks the rod's end (a
limp rope's at 20 m/s, dt = 2 ms, 4 substeps) one solve turns frames by radians and moves particles by segments,
the residual grows from solve to solve, and the rope is torn apart (strain 5 within three steps). So each solve
returns that bound:

* bound ≤ ρ_floor (``_RESIDUAL_FLOOR``): the solve is accepted without looking further (the normal case: a hanging
  or falling rod's solves turn its frames by milliradians; the check costs two sums over the solve's moves). A limp
  rod's solve, whose loop is a third as long, computes no bound (the sums measured 18 % of a rope's step): its
  solve is accepted unless a pin moves by more than ``_ROPE_YANK`` segments in the substep (a yank), or it touches
  another cable of the scene (a cable struck by another stretched 79 % under one solve per substep at dt = 5 ms);
* else the rows' residual after the solve, ρ (one pass over the rod, :func:`rod_residual`): at most ρ_floor, the
  solve is accepted; otherwise another Newton step (a re-linearised solve) follows, accepted on the same terms, and
  more while each shrinks the residual to at most κ (``_CONTRACTION``) of the one before, at most ``_MAX_SOLVES``
  solves in all. Where a step does not shrink it so, Newton stalls, and the last solve stands, except on a limp rod
  (a rope: no bend–twist rows, hard stretch–shear rows), whose frames are then turned onto their segments by the
  least rotation (the shear rows' exact projection onto frames that turn hundreds of times more easily than the
  particles move, which a linearisation about frames turned far from their segments misses), once, before Newton
  goes on;
* if ρ is then above the first solve's (Newton diverging), one Gauss-Seidel sweep of the same constraints follows
  (:func:`mjcable.solvers.cosserat_kernels.rod_gauss_seidel`), each constraint's block solved on its own.

Where a limp rod's tension is stiff (its solve then carries the tension's geometric stiffness,
:mod:`mjcable.solvers.cosserat_direct_kernels`), its frames are first turned onto their segments in the same way,
in every substep: the stretch row pulls along d₃, so that a frame lagging its segment (predicted by its own angular
velocity while a contact bends the segment within the substep) measures the segment shorter than it is, the
transverse rows hold the particles where they are, and the solve lengthens the segment; in the rope lying over a
cable pinned taut (``tests/test_several_cables.py``) the cable's tension went from 2 kN to 38 MN within four steps of
the rope's landing (docs/measurements.md).

``xpbd``'s safeguard accepts a solve that halves the residual before it; the rod's Newton steps go on to the floor
while they converge, since one solve that halves a yank's residual still leaves it at tens of percent, and they
need no residual before the solve (a pass over the rows in every solve: measured 10–20 % of a rod's step;
``docs/measurements.md``). Converging the same implicit step further leaves XPBD's stiffness as it is.
"""

from __future__ import annotations

import math

from mjcable.solvers._kernel_cache import inline as _inline, jit as _jit
from mjcable.solvers.cosserat_direct_kernels import rod_direct_limp
from mjcable.solvers.cosserat_weld_kernels import rod_direct_closed
from mjcable.solvers.cosserat_kernels import (
    _bt_on, _end_on, _linearise_bt, _linearise_end, _linearise_ss, _qmul, _rotate_body, _ss_on, rod_direct,
    rod_gauss_seidel,
)
from mjcable.solvers.kernels_layout import ORDER_DIRECT

__all__ = ["rod_iterate", "rod_residual", "rod_direct_safeguarded", "frames_begin", "frames_end", "clamp_frames"]

# The safeguard (see the module docstring): a solve whose bound on the residual after it, or whose residual, is at
# most _RESIDUAL_FLOOR (a strain, or an angle in rad) is accepted; else another follows, and more while each shrinks
# the residual to at most _CONTRACTION of the one before; at most _MAX_SOLVES solves per iteration in all.
_RESIDUAL_FLOOR = 1e-3
_CONTRACTION = 0.5
_MAX_SOLVES = 8
# A limp rod's solve returns no bound (its two sums in the solve's loop cost 18 % of a rope's step, measured on
# ``hang``): its safeguard runs in the substeps whose pins move by more than _ROPE_YANK segment lengths each.
_ROPE_YANK = 0.1


@_jit
def rod_residual(S, h2):
    """The rod's largest residual |C + α̃ λ| over its rows (a limp rod's: its stretch–shear rows'), each as a
    strain or an angle (see the module docstring; ``h2`` = h², s²)."""
    P = S.par[0]
    inv_l0 = math.sqrt(S.cable_par[0].inv_l0sq)
    l0 = 1.0 / inv_l0
    a_ss = (P.ss_alpha1 / h2, P.ss_alpha2 / h2, P.ss_alpha3 / h2)
    a_bt = (P.bt_alpha1 / h2, P.bt_alpha2 / h2, P.bt_alpha3 / h2)
    lam_ss, lam_bt, lam_end = S.lam_ss, S.lam_bt, S.lam_end
    full = not P.rod_limp
    n = lam_ss.shape[0]
    rho = 0.0
    for i in range(n):
        if not _ss_on(S, i):  # a gap between cables: no rows
            continue
        c0, c1, c2 = _linearise_ss(S, i, inv_l0)
        rho = max(rho, abs(c0 + a_ss[0] * lam_ss[i, 0]), abs(c1 + a_ss[1] * lam_ss[i, 1]),
                  abs(c2 + a_ss[2] * lam_ss[i, 2]))
        if full and i < n - 1 and _bt_on(S, i):
            c0, c1, c2 = _linearise_bt(S, i, inv_l0)
            rho = max(rho, 0.5 * l0 * abs(c0 + a_bt[0] * lam_bt[i, 0]), 0.5 * l0 * abs(c1 + a_bt[1] * lam_bt[i, 1]),
                      0.5 * l0 * abs(c2 + a_bt[2] * lam_bt[i, 2]))
    for e in range(2):
        if full and _end_on(S, e):
            c0, c1, c2 = _linearise_end(S, e, 2.0 * inv_l0)
            rho = max(rho, 0.25 * l0 * abs(c0 + 2.0 * a_bt[0] * lam_end[e, 0]),
                      0.25 * l0 * abs(c1 + 2.0 * a_bt[1] * lam_end[e, 1]),
                      0.25 * l0 * abs(c2 + 2.0 * a_bt[2] * lam_end[e, 2]))
    return rho


@_inline
def _solve(S, h2):
    """One direct solve (a limp rod's over its stretch–shear rows); returns the bound on the residual after it (a
    limp rod's: none, inf)."""
    if S.par[0].rod_limp:
        rod_direct_limp(S, h2)
        return math.inf
    return _rod_direct(S, h2)


@_inline
def _rod_direct(S, h2):
    """One direct solve of a rod with bend–twist rows: with its welds and junctions where it has them
    (:mod:`mjcable.solvers.cosserat_weld_kernels`), else the band alone."""
    if S.weld_seg.shape[0] or S.junction_p.shape[0]:
        return rod_direct_closed(S, h2)
    return rod_direct(S, h2)


@_inline
def _pins_travel(S):
    """The farthest a pin's target moves in one of the step's substeps, in segment lengths: |pin_to − pin_from| /
    substeps / l₀."""
    P = S.par[0]
    top = 0.0
    for k in range(S.pin_p.shape[0]):
        d0 = S.pin_to[k, 0] - S.pin_from[k, 0]
        d1 = S.pin_to[k, 1] - S.pin_from[k, 1]
        d2 = S.pin_to[k, 2] - S.pin_from[k, 2]
        top = max(top, d0 * d0 + d1 * d1 + d2 * d2)
    return math.sqrt(top * S.cable_par[0].inv_l0sq) / P.substeps


@_jit
def _align_frames(S):
    """Turn each segment's frame by the least rotation that takes its d₃ onto the segment (a limp rod's stretch–shear
    rows are hard and its frames turn far more easily than its particles move: the shear rows' exact projection
    onto the frames alone)."""
    x, q = S.x, S.q
    for i in range(q.shape[0]):
        if not _ss_on(S, i):  # a gap's frame: no constraint turns it
            continue
        w, a, b, c = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        t0, t1, t2 = 2.0 * (a * c + w * b), 2.0 * (b * c - w * a), 1.0 - 2.0 * (a * a + b * b)  # d₃
        e0, e1, e2 = x[i + 1, 0] - x[i, 0], x[i + 1, 1] - x[i, 1], x[i + 1, 2] - x[i, 2]
        length = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
        if length == 0.0:
            continue
        e0, e1, e2 = e0 / length, e1 / length, e2 / length
        rw = 1.0 + t0 * e0 + t1 * e1 + t2 * e2  # r = (1 + d₃·e, d₃ × e), normalised: the turn from d₃ to e
        if rw < 1e-9:  # (opposite: no least turn; the solve turns it)
            continue
        rx, ry, rz = t1 * e2 - t2 * e1, t2 * e0 - t0 * e2, t0 * e1 - t1 * e0
        inv = 1.0 / math.sqrt(rw * rw + rx * rx + ry * ry + rz * rz)
        q[i, 0], q[i, 1], q[i, 2], q[i, 3] = _qmul(rw * inv, rx * inv, ry * inv, rz * inv, w, a, b, c)


@_inline
def rod_direct_safeguarded(S, h2):
    """One direct iteration with the nonlinear safeguard of the module docstring (``h2`` = h², s²): the first solve,
    and where its bound is above the floor (a limp rod: where a pin moves more than ``_ROPE_YANK`` segments in a
    substep), :func:`_newton`."""
    P = S.par[0]
    if P.rod_limp:
        if P.gs_stiff:  # a taut rope: its frames put along their segments first (see the module docstring)
            _align_frames(S)
        rod_direct_limp(S, h2)
        if _pins_travel(S) > _ROPE_YANK or (P.cable_contact and P.n_self > 0):
            _newton(S, h2)
    elif _rod_direct(S, h2) > _RESIDUAL_FLOOR:
        _newton(S, h2)


@_jit
def _newton(S, h2):
    """The safeguard's further Newton steps after a first solve whose bound is above the floor (see the module
    docstring)."""
    first = rho = rod_residual(S, h2)
    prev = math.inf  # (the first solve is always followed by another where its residual is above the floor)
    aligned = not S.par[0].rod_limp
    for _ in range(_MAX_SOLVES - 1):
        if rho <= _RESIDUAL_FLOOR:
            return
        if rho > _CONTRACTION * prev:  # Newton stalls: a limp rod's frames are put along their segments, once
            if aligned:
                break
            _align_frames(S)
            aligned = True
        prev = rho
        bound = _solve(S, h2)
        if bound <= _RESIDUAL_FLOOR:
            return
        rho = rod_residual(S, h2)
    if rho > first:  # Newton diverging: the constraints one by one
        rod_gauss_seidel(S, h2)


@_inline
def rod_iterate(S):
    """One iteration of the rod's constraints in the configured order (the safeguarded direct solve, with the
    welds and junctions where it has them, or a Gauss-Seidel sweep)."""
    P = S.par[0]
    if P.order == ORDER_DIRECT:
        rod_direct_safeguarded(S, P.h * P.h)
    else:
        rod_gauss_seidel(S, P.h * P.h)


# ---------------------------------------------------------------------------------------------------------------
# The frames' substep: prediction and clamps, then angular velocities.


@_inline
def _slerp(a, b, t, out, k):
    """out[k] ← the unit quaternion a fraction t of the way from a to b (shortest arc)."""
    dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
    sign = 1.0
    if dot < 0.0:
        dot, sign = -dot, -1.0
    if dot > 0.9995:
        s0, s1 = 1.0 - t, t
    else:
        theta = math.acos(dot)
        s0, s1 = math.sin((1.0 - t) * theta) / math.sin(theta), math.sin(t * theta) / math.sin(theta)
    norm = 0.0
    for c in range(4):
        out[k, c] = s0 * a[c] + sign * s1 * b[c]
        norm += out[k, c] * out[k, c]
    inv = 1.0 / math.sqrt(norm)
    for c in range(4):
        out[k, c] *= inv


@_jit
def clamp_frames(S, frac):
    """The clamps' frames ``clamp_q`` a fraction ``frac`` of the way through the step: a slerp from ``clamp_qfrom``
    to ``clamp_qto`` (grippers and the world's clamps, like the pins' positions; the host then sets a body clamp's
    frame from its body, :func:`mjcable.solvers.host_kernels.host_before`)."""
    for k in range(S.clamp_q.shape[0]):
        _slerp(S.clamp_qfrom[k], S.clamp_qto[k], frac, S.clamp_q, k)


@_jit
def frames_begin(S, sub, n_sub):
    """Predict the frames (q₀ ← q; ω ← e^{−c h} ω − h D (ω × I ω); q ← q + (h/2) q ⊗ (0, ω), normalised), move the
    clamps' frames to their targets (:func:`clamp_frames`; in a user world the host did), and reset the rod's
    multipliers and the clamps' reactions."""
    P = S.par[0]
    h = P.h
    q, q0, om, inertia, wq = S.q, S.q0, S.omega, S.inertia, S.wq
    for i in range(q.shape[0]):
        damp = S.damp[i]  # (its cable's, as its first particle's)
        q0[i, 0], q0[i, 1], q0[i, 2], q0[i, 3] = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        wx, wy, wz = om[i, 0], om[i, 1], om[i, 2]
        lx, ly, lz = inertia[i, 0] * wx, inertia[i, 1] * wy, inertia[i, 2] * wz
        om[i, 0] = damp * wx - h * wq[i, 0] * (wy * lz - wz * ly)
        om[i, 1] = damp * wy - h * wq[i, 1] * (wz * lx - wx * lz)
        om[i, 2] = damp * wz - h * wq[i, 2] * (wx * ly - wy * lx)
        _rotate_body(q, i, h * om[i, 0], h * om[i, 1], h * om[i, 2])
    if not P.host and S.clamp_q.shape[0]:  # (in a user world the host turned the clamps' frames: clamp_frames)
        clamp_frames(S, (sub + 1.0) / n_sub)
    for k in range(S.clamp_q.shape[0]):
        S.clamp_react[k, 0] = S.clamp_react[k, 1] = S.clamp_react[k, 2] = 0.0
    S.lam_ss[:, :] = 0.0
    S.lam_bt[:, :] = 0.0
    S.lam_end[:, :] = 0.0
    S.lam_weld[:, :] = 0.0


@_jit
def frames_end(S):
    """The frames' angular velocities ω = (2/h) Im(q̄₀ ⊗ q) (body frame, sign of the shorter arc)."""
    q, q0, om = S.q, S.q0, S.omega
    k = 2.0 / S.par[0].h
    for i in range(q.shape[0]):
        rw, rx, ry, rz = _qmul(q0[i, 0], -q0[i, 1], -q0[i, 2], -q0[i, 3], q[i, 0], q[i, 1], q[i, 2], q[i, 3])
        if rw < 0.0:
            rx, ry, rz = -rx, -ry, -rz
        om[i, 0], om[i, 1], om[i, 2] = k * rx, k * ry, k * rz
