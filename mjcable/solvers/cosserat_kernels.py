"""The ``cosserat`` model's kernels, ``@njit`` (cached, see :mod:`mjcable.solvers._kernel_cache`): a rod of
particles and one material frame (a unit quaternion q = (w, x, y, z), body to world) per segment, with the
stretch–shear and bend–twist constraints of Kugelstadt & Schömer [KS16] in XPBD form [M16], solved either
constraint by constraint (Gauss-Seidel, each constraint's three rows as one 3×3 block) or all at once as one banded
system over the rod (the direct solve of Deul et al. [D18]).

Frames are perturbed in their own body frame, q ← q ⊗ (1, δb/2) normalised ([KS16] Eq. 27 written for body
angular velocity). With R(q) the frame's rotation (columns d₁, d₂, d₃), l₀ the rest segment length and D = diag(1/I₁,
1/I₂, 1/I₃) the segment's inverse rotational inertia in its body frame:

* stretch–shear of segment i ([KS16] Eq. 31, in the material frame): C = Rᵀ (x_{i+1} − xᵢ) / l₀ − e₃ (shear along
  d₁, d₂; stretch along d₃), energy ½ l₀ (G·A C₁² + G·A C₂² + E·A C₃²), so α = (1/(G·A l₀), 1/(G·A l₀), 1/(E·A l₀))
  (0 for an inextensible rod). ∇_{x_{i+1}} C = Rᵀ / l₀ = −∇_{xᵢ} C, ∇_{bᵢ} C = [ū]× with ū = Rᵀ (x_{i+1} − xᵢ) / l₀.
* bend–twist between segments i, i + 1 ([KS16] Eqs. 32–34, the discrete Darboux vector): with r = q̄ᵢ ⊗ q_{i+1}
  (sign chosen so that r_w ≥ 0, [KS16] §4.2), C = (2 / l₀) Im(r) − Ω₀, Ω₀ the rest Darboux vector (zero for a straight
  rod), energy ½ l₀ (E·I₁ C₁² + E·I₂ C₂² + G·J C₃²), α = (1/(E·I₁ l₀), 1/(E·I₂ l₀), 1/(G·J l₀)).
  ∇_{b_{i+1}} C = (r_w I + [r_v]×) / l₀, ∇_{bᵢ} C = −(r_w I − [r_v]×) / l₀ ([D18] Eq. 16, its G matrix).

Each constraint's update is [M16] Eq. 18 for a vector constraint: (J W Jᵀ + α̃) Δλ = −C − α̃ λ, α̃ = α / h², then
Δx = w ∇ₓCᵀ Δλ and δb = D ∇_b Cᵀ Δλ. A held particle (w = 0) collects ∇ₓCᵀ Δλ in ``react``.

A clamp at the rod's start or end holds a frame at its particle (``clamp_q``): one more bend–twist constraint, over
half a segment, between that frame and its segment's (α = 2 α_bt, C = (4 / l₀) Im(q̄ q′); the clamp then holds the
tangent at the particle, as the beam's clamped boundary, rather than half a segment further in). The clamp's frame
collects R_c ∇_c Cᵀ Δλ in ``clamp_react`` (world), so that its torque on the rod is −clamp_react / h². A body
clamp's frame is not held: it is predicted where the body's free step takes it and turns with the body's inverse
inertia D_c = R_cᵀ J_r M⁻¹ J_rᵀ R_c (``clamp_wq``, from the world's rotational Jacobian J_r and mass matrix M:
:func:`mjcable.solvers.host_kernels.host_before`), so that the constraint's block of J W Jᵀ gains J_c D_c J_cᵀ and the
frame turns by δb_c = D_c J_cᵀ Δλ; the body then receives the torque +clamp_react / h² (implicit in the body's
rotational inertia as a body pin's particle is in its inertia along the cable, :mod:`mjcable.backends.host`).

The direct solve orders the rows per segment, [start clamp, ss₀, bt₀, ss₁, bt₁, …, end clamp] (three each), which makes J W Jᵀ a banded
matrix of half-bandwidth 8, 3 × 3 blocks with two below the diagonal ([D18] §4: a chain is a tree whose elimination
order has no fill-in), solved with :func:`mjcable.solvers.cosserat_direct_kernels.block_ldlt_solve` (a limp rod's,
without bend–twist rows, with :func:`mjcable.solvers.cosserat_direct_kernels.rod_direct_limp`); one solve per
iteration is Newton's step on the constraints (exact where they are linear). Several cables lie one after the
other; the gap segment between two (``seg_cable`` −1) has no rows, and its rows and the bend–twist rows beside it
are the identity with right-hand side 0 and no block off the diagonal, so that the factorisation falls apart into
one block per cable (:func:`_ss_on`, :func:`_bt_on`). Rows with α = 0 get a relative compliance of ``_REGULARIZATION``.

Frames are predicted with q ← q + (h/2) q ⊗ (0, ω) normalised (ω in the body frame, gyroscopic term
−D (ω × I ω) explicit), and ω = (2/h) Im(q₀̄ ⊗ q) after the solve ([KS16] Eqs. 27–28, [M20] Eq. 8 and Algorithm 2):
:mod:`mjcable.solvers.cosserat_step_kernels`, which also holds the iteration and the direct solve's nonlinear
safeguard.

References (and [M16], [M20], [D18] in :mod:`mjcable.solvers.kernels`):
  [KS16] T. Kugelstadt, E. Schömer, "Position and Orientation Based Cosserat Rods", SCA 2016.
"""

from __future__ import annotations

import math

import numpy as np

from mjcable.solvers._kernel_cache import inline as _inline, jit as _jit
from mjcable.solvers.cosserat_direct_kernels import block_ldlt_solve

__all__ = ["rod_gauss_seidel", "rod_direct", "direct_rows", "direct_commit"]

# Relative compliance added to the diagonal of every row of the direct solve (an inextensible rod's α = 0 rows):
# far below any physical compliance, it keeps J W Jᵀ positive definite where a held end makes rows redundant.
_REGULARIZATION = 1e-10


# ---------------------------------------------------------------------------------------------------------------
# Quaternions (w, x, y, z) as scalars.


@_inline
def _qmul(aw, ax, ay, az, bw, bx, by, bz):
    """The Hamilton product a ⊗ b."""
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


@_inline
def _rotate_body(q, i, bx, by, bz):
    """q[i] ← q[i] ⊗ (1, b/2), normalised: a rotation by the small body-frame vector b (rad)."""
    w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
    dw, dx, dy, dz = _qmul(w, x, y, z, 0.0, 0.5 * bx, 0.5 * by, 0.5 * bz)
    w, x, y, z = w + dw, x + dx, y + dy, z + dz
    inv = 1.0 / math.sqrt(w * w + x * x + y * y + z * z)
    q[i, 0], q[i, 1], q[i, 2], q[i, 3] = w * inv, x * inv, y * inv, z * inv


@_inline
def _rotation(q, i, R):
    """R ← the rotation matrix of q[i] (body to world; columns d₁, d₂, d₃)."""
    w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
    R[0, 0], R[0, 1], R[0, 2] = 1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)
    R[1, 0], R[1, 1], R[1, 2] = 2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)
    R[2, 0], R[2, 1], R[2, 2] = 2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)


# ---------------------------------------------------------------------------------------------------------------
# Linearisation: C and ∇C of one constraint; the Jacobian blocks go to S.cs_jac (4 per segment: R, [ū]×, ∇_{bᵢ} of
# the bend–twist constraint i, ∇_{b_{i+1}} of it; then the clamps' half-segment constraints at the rod's start and
# end: ∇ of the segment's frame (4n, 4n + 1), ∇ of the clamp's frame (4n + 2, 4n + 3)).


@_inline
def _linearise_ss(S, i, inv_l0):
    """Stretch–shear constraint of segment i: cs_jac[4i] ← R, cs_jac[4i + 1] ← [ū]×. Returns C (3 scalars)."""
    x, jac = S.x, S.cs_jac
    R = jac[4 * i]
    _rotation(S.q, i, R)
    ux, uy, uz = ((x[i + 1, 0] - x[i, 0]) * inv_l0, (x[i + 1, 1] - x[i, 1]) * inv_l0,
                  (x[i + 1, 2] - x[i, 2]) * inv_l0)
    b0 = R[0, 0] * ux + R[1, 0] * uy + R[2, 0] * uz
    b1 = R[0, 1] * ux + R[1, 1] * uy + R[2, 1] * uz
    b2 = R[0, 2] * ux + R[1, 2] * uy + R[2, 2] * uz
    K = jac[4 * i + 1]
    K[0, 0], K[0, 1], K[0, 2] = 0.0, -b2, b1
    K[1, 0], K[1, 1], K[1, 2] = b2, 0.0, -b0
    K[2, 0], K[2, 1], K[2, 2] = -b1, b0, 0.0
    return b0, b1, b2 - 1.0


@_inline
def _relative(qa, a, qb, b, A, B, inv_len):
    """The bend–twist linearisation between frame a of ``qa`` and frame b of ``qb`` at distance 1/``inv_len``:
    r = q̄_a ⊗ q_b (r_w ≥ 0), A ← ∇_{b_a}C = −(r_w I − [r_v]×) / len, B ← ∇_{b_b}C = (r_w I + [r_v]×) / len.
    Returns (2 / len) r_v, the Darboux vector."""
    rw, rx, ry, rz = _qmul(qa[a, 0], -qa[a, 1], -qa[a, 2], -qa[a, 3], qb[b, 0], qb[b, 1], qb[b, 2], qb[b, 3])
    if rw < 0.0:  # q and −q are one rotation: take the relative rotation nearer the (small) rest one
        rw, rx, ry, rz = -rw, -rx, -ry, -rz
    w = rw * inv_len
    vx, vy, vz = rx * inv_len, ry * inv_len, rz * inv_len
    B[0, 0], B[0, 1], B[0, 2] = w, -vz, vy
    B[1, 0], B[1, 1], B[1, 2] = vz, w, -vx
    B[2, 0], B[2, 1], B[2, 2] = -vy, vx, w
    A[0, 0], A[0, 1], A[0, 2] = -w, -vz, vy
    A[1, 0], A[1, 1], A[1, 2] = vz, -w, -vx
    A[2, 0], A[2, 1], A[2, 2] = -vy, vx, -w
    return 2.0 * vx, 2.0 * vy, 2.0 * vz


@_inline
def _linearise_bt(S, i, inv_l0):
    """Bend–twist constraint between segments i, i + 1: cs_jac[4i + 2] ← ∇_{bᵢ}C, cs_jac[4i + 3] ← ∇_{b_{i+1}}C.
    Returns C (3 scalars)."""
    jac, om0 = S.cs_jac, S.darboux0
    c0, c1, c2 = _relative(S.q, i, S.q, i + 1, jac[4 * i + 2], jac[4 * i + 3], inv_l0)
    return c0 - om0[i, 0], c1 - om0[i, 1], c2 - om0[i, 2]


@_inline
def _linearise_end(S, e, inv_half):
    """The half-segment bend–twist constraint of the clamp at the rod's start (e = 0: between the clamp's frame at
    particle 0 and segment 0's) or end (e = 1: segment n − 1's and the clamp's at particle n), l₀ / 2 apart
    (``inv_half`` = 2 / l₀): the clamp holds the frame at its particle, not half a segment further in. Its rest
    Darboux vector is zero (the clamp's frame starts as its segment's). Returns C; ∇ to cs_jac[4n + e] (the
    segment's frame) and cs_jac[4n + 2 + e] (the clamp's)."""
    q, cq, jac = S.q, S.clamp_q, S.cs_jac
    n = q.shape[0]
    k = S.end_clamp[e]
    if e == 0:
        return _relative(cq, k, q, 0, jac[4 * n + 2], jac[4 * n], inv_half)
    return _relative(q, n - 1, cq, k, jac[4 * n + 1], jac[4 * n + 3], inv_half)


@_inline
def _end_on(S, e):
    """Whether the rod's start (e = 0) or end (e = 1) has a clamp that holds."""
    k = S.end_clamp[e]
    return k >= 0 and S.pin_active[S.clamp_pin[k]]


@_inline
def _ss_on(S, i):
    """Whether segment i carries stretch–shear rows: a cable's segment, not the gap from one cable's last particle
    to the next one's first (``seg_cable`` −1), which carries no rows and whose frame no constraint turns."""
    return S.seg_cable[i] >= 0


@_inline
def _bt_on(S, i):
    """Whether the bend–twist rows between segments i and i + 1 are on: both of one cable (not beside a gap)."""
    return S.seg_cable[i] >= 0 and S.seg_cable[i + 1] >= 0


@_inline
def _block(out, jac, k1, wq, i, k2):
    """out ← out + J₁ diag(wq[i]) J₂ᵀ (3×3), J₁ = jac[k1], J₂ = jac[k2] (indices, not views: no reference counts
    in the loops)."""
    d0, d1, d2 = wq[i, 0], wq[i, 1], wq[i, 2]
    for a in range(3):
        for b in range(3):
            out[a, b] += jac[k1, a, 0] * d0 * jac[k2, b, 0] + jac[k1, a, 1] * d1 * jac[k2, b, 1] + \
                jac[k1, a, 2] * d2 * jac[k2, b, 2]


@_inline
def _block_ss_ss(out, jac, k1, k2, w):
    """out ← out − w R1ᵀ R2 with R1 = jac[k1], R2 = jac[k2] (the stretch–shear rows of neighbouring segments share
    a particle of inverse mass w; the 1/l₀² is in w)."""
    for a in range(3):
        for b in range(3):
            out[a, b] -= w * (jac[k1, 0, a] * jac[k2, 0, b] + jac[k1, 1, a] * jac[k2, 1, b]
                              + jac[k1, 2, a] * jac[k2, 2, b])


@_inline
def _diag_ss(jac, w, wq, i, M, inv_l0sq):
    """M ← the stretch–shear block of J W Jᵀ, (wᵢ + w_{i+1}) / l₀² I + [ū]× D [ū]×ᵀ (without α̃)."""
    M[:, :] = 0.0
    ws = (w[i] + w[i + 1]) * inv_l0sq
    M[0, 0] = M[1, 1] = M[2, 2] = ws
    _block(M, jac, 4 * i + 1, wq, i, 4 * i + 1)


@_inline
def _diag_bt(jac, wq, i, M):
    """M ← the bend–twist block of J W Jᵀ, ∇_{bᵢ}C Dᵢ ∇_{bᵢ}Cᵀ + ∇_{b_{i+1}}C D_{i+1} ∇_{b_{i+1}}Cᵀ (without α̃)."""
    M[:, :] = 0.0
    _block(M, jac, 4 * i + 2, wq, i, 4 * i + 2)
    _block(M, jac, 4 * i + 3, wq, i + 1, 4 * i + 3)


@_inline
def _diag_end(S, e, M):
    """M ← the clamp constraint's block of J W Jᵀ (without α̃): its segment's frame's, plus a body clamp's frame's
    J_c D_c J_cᵀ (``clamp_wq``, a full 3 × 3: the body's inverse inertia in the clamp's frame; 0 for a held frame)."""
    jac, wq = S.cs_jac, S.wq
    n = wq.shape[0]
    M[:, :] = 0.0
    _block(M, jac, 4 * n + e, wq, 0 if e == 0 else n - 1, 4 * n + e)
    D = S.clamp_wq[S.end_clamp[e]]
    if D[0, 0] + D[1, 1] + D[2, 2] > 0.0:  # a body clamp: its frame turns with the body's inverse inertia
        k = 4 * n + 2 + e
        for a in range(3):
            for b in range(3):
                acc = 0.0
                for c in range(3):
                    acc += jac[k, a, c] * (D[c, 0] * jac[k, b, 0] + D[c, 1] * jac[k, b, 1] + D[c, 2] * jac[k, b, 2])
                M[a, b] += acc


@_inline
def _solve3(M, r0, r1, r2):
    """M⁻¹ r for a symmetric positive definite 3×3 M (Cramer's rule); 0 where M is singular (a fully held
    constraint)."""
    c00 = M[1, 1] * M[2, 2] - M[1, 2] * M[2, 1]
    c01 = M[1, 2] * M[2, 0] - M[1, 0] * M[2, 2]
    c02 = M[1, 0] * M[2, 1] - M[1, 1] * M[2, 0]
    det = M[0, 0] * c00 + M[0, 1] * c01 + M[0, 2] * c02
    if det == 0.0:
        return 0.0, 0.0, 0.0
    c11 = M[0, 0] * M[2, 2] - M[0, 2] * M[2, 0]
    c12 = M[0, 2] * M[1, 0] - M[0, 0] * M[1, 2]
    c22 = M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]
    inv = 1.0 / det
    return ((c00 * r0 + c01 * r1 + c02 * r2) * inv, (c01 * r0 + c11 * r1 + c12 * r2) * inv,
            (c02 * r0 + c12 * r1 + c22 * r2) * inv)


# ---------------------------------------------------------------------------------------------------------------
# Applying Δλ: positions into ``out`` (x itself, or S.dx), body rotations into ``dq`` (applied now or later).


@_inline
def _frame_push(S, i, J, l0, l1, l2, dq, now):
    """Segment i's share δb = D Jᵀ Δλ of a constraint with block J (3×3, rows: the constraint, columns: δb) into
    ``dq[i]`` (or, ``now``, rotated into q at once)."""
    D = S.wq[i]
    bx = D[0] * (J[0, 0] * l0 + J[1, 0] * l1 + J[2, 0] * l2)
    by = D[1] * (J[0, 1] * l0 + J[1, 1] * l1 + J[2, 1] * l2)
    bz = D[2] * (J[0, 2] * l0 + J[1, 2] * l1 + J[2, 2] * l2)
    if now:
        _rotate_body(S.q, i, bx, by, bz)
    else:
        dq[i, 0] += bx
        dq[i, 1] += by
        dq[i, 2] += bz


@_inline
def _particle_push(S, out, p, sign, R, l0, l1, l2, inv_l0):
    """Particle p's share sign · w R Δλ / l₀ of a stretch–shear update (a held particle: into ``react``)."""
    gx = sign * (R[0, 0] * l0 + R[0, 1] * l1 + R[0, 2] * l2) * inv_l0
    gy = sign * (R[1, 0] * l0 + R[1, 1] * l1 + R[1, 2] * l2) * inv_l0
    gz = sign * (R[2, 0] * l0 + R[2, 1] * l1 + R[2, 2] * l2) * inv_l0
    wp = S.w[p]
    out[p, 0] += wp * gx  # (no else branch for the held particle: measured slower)
    out[p, 1] += wp * gy
    out[p, 2] += wp * gz
    if wp == 0.0:
        S.react[p, 0] += gx
        S.react[p, 1] += gy
        S.react[p, 2] += gz


@_inline
def _apply_ss(S, i, l0, l1, l2, out, dq, now, inv_l0):
    R = S.cs_jac[4 * i]
    _particle_push(S, out, i, -1.0, R, l0, l1, l2, inv_l0)
    _particle_push(S, out, i + 1, 1.0, R, l0, l1, l2, inv_l0)
    _frame_push(S, i, S.cs_jac[4 * i + 1], l0, l1, l2, dq, now)


@_inline
def _apply_bt(S, i, l0, l1, l2, dq, now):
    _frame_push(S, i, S.cs_jac[4 * i + 2], l0, l1, l2, dq, now)
    _frame_push(S, i + 1, S.cs_jac[4 * i + 3], l0, l1, l2, dq, now)


@_inline
def _apply_end(S, e, l0, l1, l2, dq, now):
    """A clamp constraint's Δλ: its segment's frame turns; the clamp's frame collects R_c J_cᵀ Δλ in
    ``clamp_react`` (world), so that the clamp's torque on the rod is −clamp_react / h² (and the rod's on a body
    clamp's body +clamp_react / h²); a body clamp's frame turns by D_c J_cᵀ Δλ."""
    n = S.q.shape[0]
    _frame_push(S, 0 if e == 0 else n - 1, S.cs_jac[4 * n + e], l0, l1, l2, dq, now)
    J = S.cs_jac[4 * n + 2 + e]
    k = S.end_clamp[e]
    gx = J[0, 0] * l0 + J[1, 0] * l1 + J[2, 0] * l2
    gy = J[0, 1] * l0 + J[1, 1] * l1 + J[2, 1] * l2
    gz = J[0, 2] * l0 + J[1, 2] * l1 + J[2, 2] * l2
    w, x, y, z = S.clamp_q[k, 0], S.clamp_q[k, 1], S.clamp_q[k, 2], S.clamp_q[k, 3]
    rq = S.clamp_react
    rq[k, 0] += (1.0 - 2.0 * (y * y + z * z)) * gx + 2.0 * (x * y - w * z) * gy + 2.0 * (x * z + w * y) * gz
    rq[k, 1] += 2.0 * (x * y + w * z) * gx + (1.0 - 2.0 * (x * x + z * z)) * gy + 2.0 * (y * z - w * x) * gz
    rq[k, 2] += 2.0 * (x * z - w * y) * gx + 2.0 * (y * z + w * x) * gy + (1.0 - 2.0 * (x * x + y * y)) * gz
    D = S.clamp_wq[k]
    if D[0, 0] + D[1, 1] + D[2, 2] > 0.0:  # a body clamp's frame turns by D_c J_cᵀ Δλ (its only constraint: now)
        _rotate_body(S.clamp_q, k, D[0, 0] * gx + D[0, 1] * gy + D[0, 2] * gz,
                     D[1, 0] * gx + D[1, 1] * gy + D[1, 2] * gz, D[2, 0] * gx + D[2, 1] * gy + D[2, 2] * gz)


# ---------------------------------------------------------------------------------------------------------------
# The solves.


@_inline
def _block_update(M, a0, a1, a2, lam, k, c0, c1, c2):
    """[M16] Eq. 18 for one vector constraint: with ``M`` its block of J W Jᵀ, (M + α̃) Δλ = −C − α̃ λ (α̃ =
    diag(a0, a1, a2)); λ = ``lam[k]`` grows by Δλ, which is returned (3 scalars)."""
    M[0, 0] += a0
    M[1, 1] += a1
    M[2, 2] += a2
    d0, d1, d2 = _solve3(M, -c0 - a0 * lam[k, 0], -c1 - a1 * lam[k, 1], -c2 - a2 * lam[k, 2])
    lam[k, 0] += d0
    lam[k, 1] += d1
    lam[k, 2] += d2
    return d0, d1, d2


@_inline
def _gs_end(S, e, M, a0, a1, a2, inv_half):
    """One Gauss-Seidel update of the clamp constraint at the rod's start (e = 0) or end (e = 1)."""
    lam = S.lam_end
    c0, c1, c2 = _linearise_end(S, e, inv_half)
    _diag_end(S, e, M)
    d0, d1, d2 = _block_update(M, a0, a1, a2, lam, e, c0, c1, c2)
    _apply_end(S, e, d0, d1, d2, S.cs_db, True)


@_jit
def rod_gauss_seidel(S, h2):
    """One Gauss-Seidel sweep along the rod: the start's clamp constraint, then per segment i its stretch–shear
    block and the bend–twist block between segments i and i + 1, then the end's clamp constraint, each a 3×3 [M16]
    Eq. 18 update applied at once (``h2`` = h², s²)."""
    P = S.par[0]
    inv_l0 = math.sqrt(S.cable_par[0].inv_l0sq)
    M = np.empty((3, 3))
    a_ss = (P.ss_alpha1 / h2, P.ss_alpha2 / h2, P.ss_alpha3 / h2)
    a_bt = (P.bt_alpha1 / h2, P.bt_alpha2 / h2, P.bt_alpha3 / h2)
    lam_ss, lam_bt, jac, w, wq = S.lam_ss, S.lam_bt, S.cs_jac, S.w, S.wq
    n = lam_ss.shape[0]
    if _end_on(S, 0):
        _gs_end(S, 0, M, 2.0 * a_bt[0], 2.0 * a_bt[1], 2.0 * a_bt[2], 2.0 * inv_l0)
    for i in range(n):
        if not _ss_on(S, i):  # a gap between cables: no rows
            continue
        c0, c1, c2 = _linearise_ss(S, i, inv_l0)
        _diag_ss(jac, w, wq, i, M, S.cable_par[0].inv_l0sq)
        d0, d1, d2 = _block_update(M, a_ss[0], a_ss[1], a_ss[2], lam_ss, i, c0, c1, c2)
        _apply_ss(S, i, d0, d1, d2, S.x, S.cs_db, True, inv_l0)
        if i < n - 1 and _bt_on(S, i):
            c0, c1, c2 = _linearise_bt(S, i, inv_l0)
            _diag_bt(jac, wq, i, M)
            d0, d1, d2 = _block_update(M, a_bt[0], a_bt[1], a_bt[2], lam_bt, i, c0, c1, c2)
            _apply_bt(S, i, d0, d1, d2, S.cs_db, True)
    if _end_on(S, 1):
        _gs_end(S, 1, M, 2.0 * a_bt[0], 2.0 * a_bt[1], 2.0 * a_bt[2], 2.0 * inv_l0)


@_inline
def _put(band, r0, c0, M, diagonal):
    """band (lower band storage, band[i, i − j] = A[i, j]) ← the 3×3 block M at rows r0.., columns c0.. (r0 ≥ c0;
    ``diagonal``: only its lower triangle)."""
    for a in range(3):
        for b in range(3):
            if diagonal and b > a:
                continue
            band[r0 + a, r0 + a - c0 - b] = M[a, b]


@_inline
def _put_diag(band, r, M, a0, a1, a2):
    """The diagonal block M + α̃ (and the relative regularisation) at rows r.."""
    M[0, 0] += a0 + _REGULARIZATION * M[0, 0]
    M[1, 1] += a1 + _REGULARIZATION * M[1, 1]
    M[2, 2] += a2 + _REGULARIZATION * M[2, 2]
    _put(band, r, r, M, True)


@_jit
def _assemble(S, h2, M):
    """Linearise every constraint of the rod (C into ``cs_rhs`` as −C − α̃ λ, ∇C into ``cs_jac``) and assemble
    J W Jᵀ + α̃ into ``cs_band``: rows [start clamp, ss₀, bt₀, ss₁, …, ss_{n−1}, end clamp] (3 each, row of ssᵢ
    3 + 6i, of btᵢ 6 + 6i, the clamps' 0 and 6n; an absent clamp's rows are the identity with rhs 0)."""
    P = S.par[0]
    inv_l0 = math.sqrt(S.cable_par[0].inv_l0sq)
    inv_l0sq = S.cable_par[0].inv_l0sq
    band, rhs, jac, w, wq = S.cs_band, S.cs_rhs, S.cs_jac, S.w, S.wq
    lam_ss, lam_bt, lam_end = S.lam_ss, S.lam_bt, S.lam_end
    n = lam_ss.shape[0]
    a_ss = (P.ss_alpha1 / h2, P.ss_alpha2 / h2, P.ss_alpha3 / h2)
    a_bt = (P.bt_alpha1 / h2, P.bt_alpha2 / h2, P.bt_alpha3 / h2)
    band[:, :] = 0.0
    rhs[:] = 0.0
    for i in range(n):  # C and the Jacobian blocks of every constraint first: the off-diagonal blocks need both sides
        if not _ss_on(S, i):  # a gap between cables: its rows and those beside it are the identity, rhs 0
            continue
        c0, c1, c2 = _linearise_ss(S, i, inv_l0)
        r = 3 + 6 * i
        rhs[r] = -c0 - a_ss[0] * lam_ss[i, 0]
        rhs[r + 1] = -c1 - a_ss[1] * lam_ss[i, 1]
        rhs[r + 2] = -c2 - a_ss[2] * lam_ss[i, 2]
        if i < n - 1 and _bt_on(S, i):
            c0, c1, c2 = _linearise_bt(S, i, inv_l0)
            r = 6 + 6 * i
            rhs[r] = -c0 - a_bt[0] * lam_bt[i, 0]
            rhs[r + 1] = -c1 - a_bt[1] * lam_bt[i, 1]
            rhs[r + 2] = -c2 - a_bt[2] * lam_bt[i, 2]
    for e in range(2):
        r = 0 if e == 0 else 6 * n
        if _end_on(S, e):
            c0, c1, c2 = _linearise_end(S, e, 2.0 * inv_l0)
            rhs[r] = -c0 - 2.0 * a_bt[0] * lam_end[e, 0]
            rhs[r + 1] = -c1 - 2.0 * a_bt[1] * lam_end[e, 1]
            rhs[r + 2] = -c2 - 2.0 * a_bt[2] * lam_end[e, 2]
            _diag_end(S, e, M)
            _put_diag(band, r, M, 2.0 * a_bt[0], 2.0 * a_bt[1], 2.0 * a_bt[2])
        else:
            band[r, 0] = band[r + 1, 0] = band[r + 2, 0] = 1.0
    for i in range(n):
        r = 3 + 6 * i
        if not _ss_on(S, i):  # a gap: the identity for its rows and the bend–twist rows on either side of it,
            for a in range(3):  # no block off the diagonal, so that the band falls apart into one per cable
                band[r + a, 0] = 1.0
                band[r + 3 + a, 0] = 1.0
                band[r - 3 + a, 0] = 1.0  # (a gap is never segment 0 or n − 1)
            continue
        _diag_ss(jac, w, wq, i, M, inv_l0sq)
        _put_diag(band, r, M, a_ss[0], a_ss[1], a_ss[2])
        if i > 0 and _bt_on(S, i - 1):  # ss_{i−1} shares particle i; bt_{i−1} shares frame i
            M[:, :] = 0.0
            _block_ss_ss(M, jac, 4 * i, 4 * (i - 1), w[i] * inv_l0sq)
            _put(band, r, r - 6, M, False)
            M[:, :] = 0.0
            _block(M, jac, 4 * i + 1, wq, i, 4 * (i - 1) + 3)
            _put(band, r, r - 3, M, False)
        if i < n - 1 and _bt_on(S, i):
            rb = 6 + 6 * i
            _diag_bt(jac, wq, i, M)
            _put_diag(band, rb, M, a_bt[0], a_bt[1], a_bt[2])
            M[:, :] = 0.0
            _block(M, jac, 4 * i + 2, wq, i, 4 * i + 1)  # bt_i with ss_i (frame i)
            _put(band, rb, r, M, False)
            if i > 0 and _bt_on(S, i - 1):  # bt_i with bt_{i−1} (frame i)
                M[:, :] = 0.0
                _block(M, jac, 4 * i + 2, wq, i, 4 * (i - 1) + 3)
                _put(band, rb, rb - 6, M, False)
    if _end_on(S, 0):  # the start clamp's constraint shares frame 0 with ss₀ and bt₀
        M[:, :] = 0.0
        _block(M, jac, 1, wq, 0, 4 * n)
        _put(band, 3, 0, M, False)
        if n > 1 and _bt_on(S, 0):
            M[:, :] = 0.0
            _block(M, jac, 2, wq, 0, 4 * n)
            _put(band, 6, 0, M, False)
    if _end_on(S, 1):  # the end clamp's shares frame n − 1 with ss_{n−1}, bt_{n−2} (and, n = 1, the start's)
        r = 6 * n
        M[:, :] = 0.0
        _block(M, jac, 4 * n + 1, wq, n - 1, 4 * (n - 1) + 1)
        _put(band, r, r - 3, M, False)
        if n > 1 and _bt_on(S, n - 2):
            M[:, :] = 0.0
            _block(M, jac, 4 * n + 1, wq, n - 1, 4 * (n - 2) + 3)
            _put(band, r, r - 6, M, False)
        elif _end_on(S, 0):
            M[:, :] = 0.0
            _block(M, jac, 4 * n + 1, wq, 0, 4 * n)
            _put(band, r, 0, M, False)


@_jit
def rod_direct(S, h2):
    """One direct solve of all the rod's constraints ([D18]): linearise and assemble (:func:`_assemble`), solve for
    Δλ with a block LDLᵀ, and apply Δx = W Jᵀ Δλ, δb = D Jᵀ Δλ together (``h2`` = h², s²). Returns a bound on the
    rows' largest residual after it, |δb|² + 2 |δb| |Δx| / l₀ (the constraints' second-order terms, which the
    linearisation leaves; |δb|² and |Δx|² summed over the frames and particles, which bounds the largest without a
    branch; :mod:`mjcable.solvers.cosserat_step_kernels`)."""
    t = np.empty((8, 3, 3))
    _assemble(S, h2, t[0])
    block_ldlt_solve(S.cs_band, S.cs_rhs, t)
    direct_rows(S)
    return direct_commit(S)


@_jit
def direct_rows(S):
    """The direct solve's Δλ (in ``cs_rhs``) added to the multipliers, and its moves W Jᵀ Δλ and turns D Jᵀ Δλ
    into ``dx`` and ``cs_db`` (zeroed first), not yet applied (:func:`direct_commit`)."""
    inv_l0 = math.sqrt(S.cable_par[0].inv_l0sq)
    rhs = S.cs_rhs
    lam_ss, lam_bt, lam_end = S.lam_ss, S.lam_bt, S.lam_end
    n = lam_ss.shape[0]
    dx, db = S.dx, S.cs_db
    dx[:, :] = 0.0
    db[:, :] = 0.0
    for i in range(n):
        if not _ss_on(S, i):  # a gap between cables: no rows
            continue
        r = 3 + 6 * i
        lam_ss[i, 0] += rhs[r]
        lam_ss[i, 1] += rhs[r + 1]
        lam_ss[i, 2] += rhs[r + 2]
        _apply_ss(S, i, rhs[r], rhs[r + 1], rhs[r + 2], dx, db, False, inv_l0)
        if i < n - 1 and _bt_on(S, i):
            r = 6 + 6 * i
            lam_bt[i, 0] += rhs[r]
            lam_bt[i, 1] += rhs[r + 1]
            lam_bt[i, 2] += rhs[r + 2]
            _apply_bt(S, i, rhs[r], rhs[r + 1], rhs[r + 2], db, False)
    for e in range(2):
        if _end_on(S, e):
            r = 0 if e == 0 else 6 * n
            lam_end[e, 0] += rhs[r]
            lam_end[e, 1] += rhs[r + 1]
            lam_end[e, 2] += rhs[r + 2]
            _apply_end(S, e, rhs[r], rhs[r + 1], rhs[r + 2], db, False)


@_jit
def direct_commit(S):
    """Apply a direct solve's moves ``dx`` and turns ``cs_db``; returns :func:`rod_direct`'s bound."""
    P = S.par[0]
    inv_l0 = math.sqrt(S.cable_par[0].inv_l0sq)
    x, dx, db = S.x, S.dx, S.cs_db
    n = db.shape[0]
    s2x = s2b = 0.0  # Σ of the squared particle moves (m²) and frame turns (rad²): bounds of the largest
    for p in range(x.shape[0]):
        x[p, 0] += dx[p, 0]
        x[p, 1] += dx[p, 1]
        x[p, 2] += dx[p, 2]
        s2x += dx[p, 0] * dx[p, 0] + dx[p, 1] * dx[p, 1] + dx[p, 2] * dx[p, 2]
    for i in range(n):
        _rotate_body(S.q, i, db[i, 0], db[i, 1], db[i, 2])
        s2b += db[i, 0] * db[i, 0] + db[i, 1] * db[i, 1] + db[i, 2] * db[i, 2]
    P.direct_solves += 1
    return s2b + 2.0 * math.sqrt(s2b * s2x) * inv_l0
