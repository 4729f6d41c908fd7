"""The ``cosserat`` rod's welds, ``@njit`` (cached, see :mod:`mjcable.solvers._kernel_cache`): a clamped junction
(``Junction(..., clamp=True)``) of two cable ends holds the frames of the two segments at it at their start turn, a
rigid joint; of one cable's own two ends, it closes a loop (a ring) with the turn its start frames have there, so that
a twist the start frames carry (``CableSpec.start_twist``) stays in the ring. The junction's particles are one point
through :mod:`mjcable.solvers.junction_kernels`; the weld adds the frames.

Weld k between frames a and b (``weld_seg[k]``) is the hard vector constraint ([KS16]'s bend–twist constraint with
its rest turn r₀ = ``weld_r0[k]`` = q̄_a ⊗ q_b of the start frames taken out on the right, so that r₀ may be any turn):
C = (2 / l₀) Im(q̄_a ⊗ q_b ⊗ r̄₀) (w ≥ 0), α = 0. With q′_b = q_b ⊗ r̄₀, a turn δb of frame b in its body is a turn
R(r₀) δb of q′_b in its own, so that ∇_{b_a}C and ∇_{b′}C are :func:`mjcable.solvers.cosserat_kernels._relative`'s
for (q_a, q′_b) and ∇_{b_b}C = ∇_{b′}C R(r₀).

In the direct order (:func:`rod_direct_closed`) the welds and the junctions (C = x_b − x_a, α = 0, ∇ = ∓I on the
particles) join the rod's solve: a loop's closing rows would break the band ([D18] §4: a tree's elimination has no
fill-in, a loop's has), so they are eliminated through the band's Schur complement. With A_b the banded block (its
LDLᵀ factored once), C_e the extra rows' blocks of J W Jᵀ against the band's rows and A_e among themselves, the solve
takes Y = A_b⁻¹ C_eᵀ (one back-substitution per extra row), (A_e − C_e Y) Δλ_e = r_e − C_e A_b⁻¹ r_b (a small
Cholesky solve), and Δλ_b = A_b⁻¹ r_b − Y Δλ_e: the same Newton step as one solve of the whole system. Solved apart,
Gauss-Seidel after the band, the band's solve treats the loop's end segments as free ends every iteration and the weld
turns them back, which sheared them by tenths of a radian (``docs/measurements.md``). So a rod welds only in the
direct order and with bend–twist rows (E > 0): the Gauss-Seidel order and a limp rod's direct solve, which have no
such solve, refuse a clamped junction (:func:`mjcable.solvers.state.chain_arrays`). The junctions' rows are then
projected once more, Gauss-Seidel, in :mod:`mjcable.solvers.junction_kernels` (little is left to do), as in the
other orders and models.

References: [KS16], [M16], [D18] in :mod:`mjcable.solvers.cosserat_kernels` and :mod:`mjcable.solvers.kernels`.
"""

from __future__ import annotations

import math

import numpy as np

from mjcable.solvers._kernel_cache import inline as _inline, jit as _jit
from mjcable.solvers.cosserat_direct_kernels import block_ldlt_factor, block_ldlt_substitute
from mjcable.solvers.cosserat_kernels import (
    _REGULARIZATION, _assemble, _end_on, _frame_push, _qmul, _relative, _rotation, direct_commit,
    direct_rows,
)

__all__ = ["rod_direct_closed"]


@_jit
def _weld_jac(S, k, wjac, qb, R, inv_l0, slot):
    """Weld k's C (3 scalars) and its Jacobian blocks into wjac[slot, 0] (∇_{b_a}C) and wjac[slot, 1] (∇_{b_b}C;
    wjac[slot, 2] is scratch)."""
    q, r0 = S.q, S.weld_r0
    b = S.weld_seg[k, 1]
    qb[0, 0], qb[0, 1], qb[0, 2], qb[0, 3] = _qmul(q[b, 0], q[b, 1], q[b, 2], q[b, 3],
                                                   r0[k, 0], -r0[k, 1], -r0[k, 2], -r0[k, 3])
    c0, c1, c2 = _relative(q, S.weld_seg[k, 0], qb, 0, wjac[slot, 0], wjac[slot, 2], inv_l0)
    _rotation(r0, k, R)
    for i in range(3):
        for j in range(3):
            wjac[slot, 1, i, j] = (wjac[slot, 2, i, 0] * R[0, j] + wjac[slot, 2, i, 1] * R[1, j]
                                   + wjac[slot, 2, i, 2] * R[2, j])
    return c0, c1, c2


@_inline
def _frame_rows(S, f, r_out, j_out):
    """The band's row blocks that turn frame f: their first rows into ``r_out`` and their Jacobian blocks (indices
    into ``cs_jac``) into ``j_out``; returns how many (ss_f, bt_{f−1}, bt_f, a clamp's constraint)."""
    n = S.q.shape[0]
    m = 0
    r_out[m], j_out[m] = 3 + 6 * f, 4 * f + 1
    m += 1
    if f >= 1:
        r_out[m], j_out[m] = 6 * f, 4 * (f - 1) + 3
        m += 1
    if f <= n - 2:
        r_out[m], j_out[m] = 6 + 6 * f, 4 * f + 2
        m += 1
    if f == 0 and _end_on(S, 0):
        r_out[m], j_out[m] = 0, 4 * n
        m += 1
    if f == n - 1 and _end_on(S, 1):
        r_out[m], j_out[m] = 6 * n, 4 * n + 1
        m += 1
    return m


@_inline
def _cholesky_solve(A, r):
    """A⁻¹ r for a small symmetric positive definite A (K × K; A is overwritten by its Cholesky factor)."""
    K = r.shape[0]
    for j in range(K):
        for k in range(j):
            A[j, j] -= A[j, k] * A[j, k]
        A[j, j] = math.sqrt(A[j, j])
        for i in range(j + 1, K):
            for k in range(j):
                A[i, j] -= A[i, k] * A[j, k]
            A[i, j] /= A[j, j]
    y = r.copy()
    for i in range(K):
        for k in range(i):
            y[i] -= A[i, k] * y[k]
        y[i] /= A[i, i]
    for i in range(K - 1, -1, -1):
        for k in range(i + 1, K):
            y[i] -= A[k, i] * y[k]
        y[i] /= A[i, i]
    return y


@_jit
def rod_direct_closed(S, h2):
    """:func:`mjcable.solvers.cosserat_kernels.rod_direct` of a rod with welds and junctions (module docstring):
    the band's rows and the extra rows (three per weld, then three per junction) solved together through the Schur
    complement of the band. Returns the same bound."""
    P = S.par[0]
    inv_l0 = math.sqrt(S.cable_par[0].inv_l0sq)
    t = np.empty((8, 3, 3))
    _assemble(S, h2, t[0])
    band, rhs, jac, wq, w, x = S.cs_band, S.cs_rhs, S.cs_jac, S.wq, S.w, S.x
    nw, nj = S.weld_seg.shape[0], S.junction_p.shape[0]
    K, nb = 3 * (nw + nj), rhs.shape[0]
    C = np.zeros((K, nb))  # the extra rows' blocks of J W Jᵀ against the band's rows
    A = np.zeros((K, K))  # among themselves
    r = np.zeros(K)
    wjac = np.empty((max(nw, 1), 3, 3, 3))
    qb, R = np.empty((1, 4)), np.empty((3, 3))
    rows, blocks = np.empty(4, dtype=np.int64), np.empty(4, dtype=np.int64)
    for k in range(nw):
        c0, c1, c2 = _weld_jac(S, k, wjac, qb, R, inv_l0, k)
        r[3 * k], r[3 * k + 1], r[3 * k + 2] = -c0, -c1, -c2
        for side in range(2):
            f = S.weld_seg[k, side]
            for m in range(_frame_rows(S, f, rows, blocks)):
                for a in range(3):
                    for b in range(3):
                        C[3 * k + a, rows[m] + b] += (wjac[k, side, a, 0] * wq[f, 0] * jac[blocks[m], b, 0]
                                                      + wjac[k, side, a, 1] * wq[f, 1] * jac[blocks[m], b, 1]
                                                      + wjac[k, side, a, 2] * wq[f, 2] * jac[blocks[m], b, 2])
            for k2 in range(nw):
                for side2 in range(2):
                    if S.weld_seg[k2, side2] == f:
                        for a in range(3):
                            for b in range(3):
                                A[3 * k + a, 3 * k2 + b] += (
                                    wjac[k, side, a, 0] * wq[f, 0] * wjac[k2, side2, b, 0]
                                    + wjac[k, side, a, 1] * wq[f, 1] * wjac[k2, side2, b, 1]
                                    + wjac[k, side, a, 2] * wq[f, 2] * wjac[k2, side2, b, 2])
    n = S.q.shape[0]
    for j in range(nj):
        e = 3 * (nw + j)
        for side in range(2):
            p = S.junction_p[j, side]
            sign = 1.0 if side == 1 else -1.0  # C = x_b − x_a
            for a in range(3):
                r[e + a] -= sign * x[p, a]  # (−C)
            for j2 in range(nj):
                for side2 in range(2):
                    if S.junction_p[j2, side2] == p:
                        for a in range(3):
                            A[e + a, 3 * (nw + j2) + a] += sign * (1.0 if side2 == 1 else -1.0) * w[p]
            for seg in range(max(p - 1, 0), min(p, n - 1) + 1):  # the stretch–shear rows at particle p
                if S.seg_cable[seg] < 0:  # (a gap between cables has none)
                    continue
                s_ss = 1.0 if seg == p - 1 else -1.0
                for a in range(3):
                    for b in range(3):
                        C[e + a, 3 + 6 * seg + b] += sign * s_ss * w[p] * inv_l0 * jac[4 * seg, a, b]
    for a in range(K):
        A[a, a] *= 1.0 + _REGULARIZATION
        if A[a, a] == 0.0:  # a junction of two held particles, or a weld of two held frames: nothing to move
            A[a, a], r[a] = 1.0, 0.0
    block_ldlt_factor(band, t)
    block_ldlt_substitute(band, rhs)
    Y = C.copy()
    for a in range(K):
        block_ldlt_substitute(band, Y[a])
    for i in range(nb):  # the Schur complement A − C A_b⁻¹ Cᵀ and its right-hand side r − C A_b⁻¹ rhs
        for a in range(K):
            r[a] -= C[a, i] * rhs[i]
            for b in range(K):
                A[a, b] -= C[a, i] * Y[b, i]
    y = _cholesky_solve(A, r)
    for i in range(nb):
        for a in range(K):
            rhs[i] -= y[a] * Y[a, i]
    direct_rows(S)
    for k in range(nw):
        d0, d1, d2 = y[3 * k], y[3 * k + 1], y[3 * k + 2]
        S.lam_weld[k, 0] += d0
        S.lam_weld[k, 1] += d1
        S.lam_weld[k, 2] += d2
        _frame_push(S, S.weld_seg[k, 0], wjac[k, 0], d0, d1, d2, S.cs_db, False)
        _frame_push(S, S.weld_seg[k, 1], wjac[k, 1], d0, d1, d2, S.cs_db, False)
    for j in range(nj):
        for side in range(2):
            p = S.junction_p[j, side]
            sign = 1.0 if side == 1 else -1.0
            for a in range(3):
                d = y[3 * (nw + j) + a]
                if side == 1:
                    S.lam_j[j, a] += d
                S.dx[p, a] += sign * w[p] * d
                if w[p] == 0.0:
                    S.react[p, a] += sign * d
    return direct_commit(S)
