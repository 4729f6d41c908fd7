"""The direct solve of a limp Cosserat rod, ``@njit`` (cached, see :mod:`mjcable.solvers._kernel_cache`): a rod
without bending or torsion stiffness (E·I = G·J = 0: a rope) has no bend–twist rows, as ``xpbd``'s chain has no
bending rows at E = 0, and its direct solve ([D18]) is over the stretch–shear rows alone.

Written in the world frame, those rows make a block-tridiagonal system with scalar off-diagonal blocks. With the
notation of :mod:`mjcable.solvers.cosserat_kernels` (R = R(qᵢ), ū = Rᵀ (x_{i+1} − xᵢ) / l₀, D = diag(wq[i]),
α̃ = α / h²), segment i's rows C = Rᵀ (x_{i+1} − xᵢ) / l₀ − e₃ are rotated by the constant R of their linearisation,
C′ = R C (the same Newton step: (J W Jᵀ + α̃) Δλ = −C − α̃ λ with J′ = R J, α̃′ = R α̃ Rᵀ, Δλ′ = R Δλ). Then
∇_{x_{i+1}} C′ = I / l₀ = −∇_{xᵢ} C′ and ∇_{bᵢ} C′ = R [ū]×, so that

* the diagonal block is Aᵢᵢ = R ((wᵢ + w_{i+1}) / l₀² I + [ū]× D [ū]×ᵀ + α̃) Rᵀ (the material block, regularised
  as in the banded solve, turned into the world frame), and
* the block of neighbouring segments i − 1, i (sharing particle i) is A_{i,i−1} = −wᵢ / l₀² I,

which block LU solves in one pass down the rod and one back, O(n) with 3 × 3 blocks: Sᵢ = Aᵢᵢ − cᵢ² S_{i−1}⁻¹,
gᵢ = Sᵢ⁻¹ (rᵢ + cᵢ g_{i−1}) (cᵢ = wᵢ / l₀², rᵢ = R (−C − α̃ λ)), then Δλ′ᵢ = gᵢ + c_{i+1} Sᵢ⁻¹ Δλ′_{i+1}. The rows are
then applied as in :func:`mjcable.solvers.cosserat_kernels.rod_direct`: λ += Rᵀ Δλ′, Δx_{i+1} = w_{i+1} Δλ′ / l₀,
Δxᵢ = −wᵢ Δλ′ / l₀ (a held particle collects ±Δλ′ / l₀ in ``react``), δbᵢ = D [ū]×ᵀ Rᵀ Δλ′.

Where the tension is stiff (``par.gs_stiff``: its transverse waves cross more than ``_GEOMETRIC_COURANT`` of a
segment per substep, as for ``xpbd``'s chain, :func:`mjcable.solvers.direct_kernels._tension_is_stiff`), each
segment in tension also carries its stretch row's geometric stiffness ([T15]), as ``xpbd``'s transverse rows do. In
the rod it is the mixed term of −λ₂ ∇²C₂ (C₂ = d₃(q) · (x_{i+1} − xᵢ) / l₀ − 1 is linear in x; its force turns with
the frame): with μ = −λ₂ > 0, u the ends' relative move and v = δφ × d₃ the frame's turn of d₃, the form
μ (|u⊥|² / l₀² − |v − u⊥ / l₀|²), whose second part, a negative shear stiffness, vanishes where the shear rows
hold (hard for a rope) and is dropped. The first is a pair of rows C⊥ = t · (x_{i+1} − xᵢ) / l₀ (t ⊥ n, the segment's
direction, C⊥ = 0 where linearised) of compliance α̃⊥ = 1 / μ on the particles only, ``xpbd``'s transverse rows in
the rod's scaling. They are condensed into the segment's block before the pass down the rod (the neighbours share
only particles): with B = Aᵢᵢ − s I the segment's own block, U = [t₀ t₁], V = B U and Σ = α̃⊥ I₂ + Uᵀ V, the
particles' impulse pᵢ = Δλ′ᵢ + U γᵢ (rod rows and transverse rows together) solves the same block tridiagonal
system with Aᵢᵢ = s I + B − V Σ⁻¹ Vᵀ and rᵢ ← rᵢ − V Σ⁻¹ Uᵀ rᵢ, and then Δλ′ᵢ = pᵢ − U Σ⁻¹ (Vᵀ pᵢ − Uᵀ rᵢ) turns the
frame and adds to λ while pᵢ moves the particles (a held one's reaction takes it, the turn of the tension's force
over the step). The multipliers μ are the last solve's (``lam_gs``, λ₂ / l₀: the previous substep's in a substep's
first solve).

The scratch lives in the banded solve's arrays (unused by this one): ``cs_band[i]`` holds Sᵢ⁻¹ (xx, yy, zz, xy, xz,
yz) and gᵢ, ``cs_band[n + i]`` R row by row, ``cs_band[2n + i, :3]`` ū, and a segment with transverse rows
``cs_band[3n + i]`` the map I − U Σ⁻¹ Vᵀ row by row and ``cs_band[4n + i]`` U Σ⁻¹ Uᵀ rᵢ and a 1 (none: 0).
"""

from __future__ import annotations

import math

from mjcable.solvers._kernel_cache import inline as _inline, jit as _jit
from mjcable.solvers.chain_solve_kernels import _perpendicular
from mjcable.solvers.constraint_kernels import push as _push
from mjcable.solvers.direct_kernels import _tension_is_stiff

# [T15] M. Tournier, M. Nesme, B. Gilles, F. Faure, "Stable Constrained Dynamics", ACM TOG 34(4), 2015.

__all__ = ["rod_direct_limp", "block_ldlt_solve", "block_ldlt_factor", "block_ldlt_substitute"]

# Relative compliance added to the diagonal of every row, as in the banded solve (cosserat_kernels._REGULARIZATION)
_REGULARIZATION = 1e-10


@_jit
def rod_direct_limp(S, h2):
    """One direct solve of a limp rod's stretch–shear rows (see the module docstring; ``h2`` = h², s²)."""
    P = S.par[0]
    inv_l0sq = S.cable_par[0].inv_l0sq
    inv_l0 = math.sqrt(inv_l0sq)
    stiff = P.gs_stiff
    a0, a1, a2 = P.ss_alpha1 / h2, P.ss_alpha2 / h2, P.ss_alpha3 / h2
    x, w, q, wq, lam, react, sc = S.x, S.w, S.q, S.wq, S.lam_ss, S.react, S.cs_band
    n = q.shape[0]
    gx = gy = gz = 0.0  # g_{i−1}
    i00 = i11 = i22 = i01 = i02 = i12 = 0.0  # S_{i−1}⁻¹
    for i in range(n):
        qw, qx, qy, qz = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        r00, r01, r02 = 1.0 - 2.0 * (qy * qy + qz * qz), 2.0 * (qx * qy - qw * qz), 2.0 * (qx * qz + qw * qy)
        r10, r11, r12 = 2.0 * (qx * qy + qw * qz), 1.0 - 2.0 * (qx * qx + qz * qz), 2.0 * (qy * qz - qw * qx)
        r20, r21, r22 = 2.0 * (qx * qz - qw * qy), 2.0 * (qy * qz + qw * qx), 1.0 - 2.0 * (qx * qx + qy * qy)
        ux = (x[i + 1, 0] - x[i, 0]) * inv_l0
        uy = (x[i + 1, 1] - x[i, 1]) * inv_l0
        uz = (x[i + 1, 2] - x[i, 2]) * inv_l0
        b0 = r00 * ux + r10 * uy + r20 * uz
        b1 = r01 * ux + r11 * uy + r21 * uz
        b2 = r02 * ux + r12 * uy + r22 * uz
        m0 = -b0 - a0 * lam[i, 0]  # −C − α̃ λ (material)
        m1 = -b1 - a1 * lam[i, 1]
        m2 = -(b2 - 1.0) - a2 * lam[i, 2]
        rx = r00 * m0 + r01 * m1 + r02 * m2
        ry = r10 * m0 + r11 * m1 + r12 * m2
        rz = r20 * m0 + r21 * m1 + r22 * m2
        d0, d1, d2 = wq[i, 0], wq[i, 1], wq[i, 2]
        s = (w[i] + w[i + 1]) * inv_l0sq
        k00, k11, k22 = d1 * b2 * b2 + d2 * b1 * b1, d0 * b2 * b2 + d2 * b0 * b0, d0 * b1 * b1 + d1 * b0 * b0
        k01, k02, k12 = -d2 * b0 * b1, -d1 * b0 * b2, -d0 * b1 * b2  # [ū]× D [ū]×ᵀ
        k00 += a0 + _REGULARIZATION * (s + k00)  # + α̃ + the regularisation; s I is added after the turn
        k11 += a1 + _REGULARIZATION * (s + k11)
        k22 += a2 + _REGULARIZATION * (s + k22)
        t00 = r00 * k00 + r01 * k01 + r02 * k02  # T = R K
        t01 = r00 * k01 + r01 * k11 + r02 * k12
        t02 = r00 * k02 + r01 * k12 + r02 * k22
        t10 = r10 * k00 + r11 * k01 + r12 * k02
        t11 = r10 * k01 + r11 * k11 + r12 * k12
        t12 = r10 * k02 + r11 * k12 + r12 * k22
        t20 = r20 * k00 + r21 * k01 + r22 * k02
        t21 = r20 * k01 + r21 * k11 + r22 * k12
        t22 = r20 * k02 + r21 * k12 + r22 * k22
        A00 = s + t00 * r00 + t01 * r01 + t02 * r02  # A = s I + T Rᵀ
        A11 = s + t10 * r10 + t11 * r11 + t12 * r12
        A22 = s + t20 * r20 + t21 * r21 + t22 * r22
        A01 = t00 * r10 + t01 * r11 + t02 * r12
        A02 = t00 * r20 + t01 * r21 + t02 * r22
        A12 = t10 * r20 + t11 * r21 + t12 * r22
        if stiff:
            sc[4 * n + i, 3] = 0.0
            if S.lam_gs[i] < 0.0 and S.seg_cable[i] >= 0:  # the transverse rows of its tension (module docstring)
                A00, A11, A22, A01, A02, A12, rx, ry, rz = _condense_transverse(
                    sc, n, i, (A00 - s, A11 - s, A22 - s, A01, A02, A12), (rx, ry, rz), (ux, uy, uz),
                    inv_l0 / -S.lam_gs[i])
                A00, A11, A22 = A00 + s, A11 + s, A22 + s
        if i > 0:  # the Schur complement of the segment before (sharing particle i)
            c = w[i] * inv_l0sq
            cc = c * c
            A00 -= cc * i00
            A11 -= cc * i11
            A22 -= cc * i22
            A01 -= cc * i01
            A02 -= cc * i02
            A12 -= cc * i12
            rx += c * gx
            ry += c * gy
            rz += c * gz
        c00 = A11 * A22 - A12 * A12  # S⁻¹ by cofactors; 0 where S is singular (a fully held segment)
        c01 = A12 * A02 - A01 * A22
        c02 = A01 * A12 - A11 * A02
        det = A00 * c00 + A01 * c01 + A02 * c02
        # (a gap between cables has no rows: S⁻¹ = 0 and g = 0 leave both of its neighbours uncoupled through it)
        inv = 0.0 if det == 0.0 or S.seg_cable[i] < 0 else 1.0 / det
        i00, i01, i02 = c00 * inv, c01 * inv, c02 * inv
        i11 = (A00 * A22 - A02 * A02) * inv
        i12 = (A02 * A01 - A00 * A12) * inv
        i22 = (A00 * A11 - A01 * A01) * inv
        gx = i00 * rx + i01 * ry + i02 * rz
        gy = i01 * rx + i11 * ry + i12 * rz
        gz = i02 * rx + i12 * ry + i22 * rz
        sc[i, 0], sc[i, 1], sc[i, 2], sc[i, 3], sc[i, 4], sc[i, 5] = i00, i11, i22, i01, i02, i12
        sc[i, 6], sc[i, 7], sc[i, 8] = gx, gy, gz
        j = n + i
        sc[j, 0], sc[j, 1], sc[j, 2], sc[j, 3], sc[j, 4] = r00, r01, r02, r10, r11
        sc[j, 5], sc[j, 6], sc[j, 7], sc[j, 8] = r12, r20, r21, r22
        j += n
        sc[j, 0], sc[j, 1], sc[j, 2] = b0, b1, b2
    lx = ly = lz = 0.0  # Δλ′_{i+1}
    px = py = pz = 0.0  # Δλ′_{i+1} / l₀: particle i + 1's share from segment i + 1
    for i in range(n - 1, -1, -1):
        if i < n - 1:
            c = w[i + 1] * inv_l0sq
            lx, ly, lz = c * lx, c * ly, c * lz
            lx, ly, lz = (sc[i, 6] + sc[i, 0] * lx + sc[i, 3] * ly + sc[i, 4] * lz,
                          sc[i, 7] + sc[i, 3] * lx + sc[i, 1] * ly + sc[i, 5] * lz,
                          sc[i, 8] + sc[i, 4] * lx + sc[i, 5] * ly + sc[i, 2] * lz)
        else:
            lx, ly, lz = sc[i, 6], sc[i, 7], sc[i, 8]
        ax, ay, az = lx, ly, lz  # Δλ′: the particles' impulse, less the transverse rows' where it has them
        if stiff and sc[4 * n + i, 3] != 0.0:
            j, k = 3 * n + i, 4 * n + i
            ax = sc[j, 0] * lx + sc[j, 1] * ly + sc[j, 2] * lz + sc[k, 0]
            ay = sc[j, 3] * lx + sc[j, 4] * ly + sc[j, 5] * lz + sc[k, 1]
            az = sc[j, 6] * lx + sc[j, 7] * ly + sc[j, 8] * lz + sc[k, 2]
        j = n + i
        m0 = sc[j, 0] * ax + sc[j, 3] * ay + sc[j, 6] * az  # Δλ = Rᵀ Δλ′ (material)
        m1 = sc[j, 1] * ax + sc[j, 4] * ay + sc[j, 7] * az
        m2 = sc[j, 2] * ax + sc[j, 5] * ay + sc[j, 8] * az
        lam[i, 0] += m0
        lam[i, 1] += m1
        lam[i, 2] += m2
        fx, fy, fz = lx * inv_l0, ly * inv_l0, lz * inv_l0
        _push(x, react, w[i + 1], i + 1, fx - px, fy - py, fz - pz)  # segments i and i + 1 share particle i + 1
        px, py, pz = fx, fy, fz
        j += n
        b0, b1, b2 = sc[j, 0], sc[j, 1], sc[j, 2]
        bx = wq[i, 0] * (b2 * m1 - b1 * m2)  # δb = D [ū]×ᵀ Δλ
        by = wq[i, 1] * (b0 * m2 - b2 * m0)
        bz = wq[i, 2] * (b1 * m0 - b0 * m1)
        qw, qx, qy, qz = q[i, 0], q[i, 1], q[i, 2], q[i, 3]  # q ← q ⊗ (1, δb/2), normalised
        hx, hy, hz = 0.5 * bx, 0.5 * by, 0.5 * bz
        nw = qw - qx * hx - qy * hy - qz * hz
        nx = qx + qw * hx + qy * hz - qz * hy
        ny = qy + qw * hy - qx * hz + qz * hx
        nz = qz + qw * hz + qx * hy - qy * hx
        inv = 1.0 / math.sqrt(nw * nw + nx * nx + ny * ny + nz * nz)
        q[i, 0], q[i, 1], q[i, 2], q[i, 3] = nw * inv, nx * inv, ny * inv, nz * inv
    _push(x, react, w[0], 0, -px, -py, -pz)
    if P.geometric:  # the next solve's transverse rows, from these multipliers as xpbd's chain's (λ₂ / l₀)
        for i in range(n):
            S.lam_gs[i] = lam[i, 2] * inv_l0
        P.gs_stiff = _tension_is_stiff(S.lam_gs, S.rest, w)
    P.direct_solves += 1


@_inline
def _condense_transverse(sc, n, i, b, r, u, alpha):
    """Condense segment i's two transverse rows (compliance ``alpha`` = α̃⊥ = 1 / μ, across ``u`` = ū) into its
    block (see the module docstring): from B (``b``: xx, yy, zz, xy, xz, yz) and r (``r``) returns B − V Σ⁻¹ Vᵀ
    (the same six) and r − V Σ⁻¹ Uᵀ r, and stores I − U Σ⁻¹ Vᵀ in ``sc[3n + i]`` and U Σ⁻¹ Uᵀ r, 1 in
    ``sc[4n + i]``."""
    b00, b11, b22, b01, b02, b12 = b
    rx, ry, rz = r
    norm = math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
    t0 = _perpendicular(u[0] / norm, u[1] / norm, u[2] / norm, 0)
    t1 = _perpendicular(u[0] / norm, u[1] / norm, u[2] / norm, 1)
    v0 = (b00 * t0[0] + b01 * t0[1] + b02 * t0[2], b01 * t0[0] + b11 * t0[1] + b12 * t0[2],
          b02 * t0[0] + b12 * t0[1] + b22 * t0[2])  # V = B U
    v1 = (b00 * t1[0] + b01 * t1[1] + b02 * t1[2], b01 * t1[0] + b11 * t1[1] + b12 * t1[2],
          b02 * t1[0] + b12 * t1[1] + b22 * t1[2])
    s00 = alpha + t0[0] * v0[0] + t0[1] * v0[1] + t0[2] * v0[2]  # Σ = α̃⊥ I₂ + Uᵀ B U
    s11 = alpha + t1[0] * v1[0] + t1[1] * v1[1] + t1[2] * v1[2]
    s01 = t0[0] * v1[0] + t0[1] * v1[1] + t0[2] * v1[2]
    inv = 1.0 / (s00 * s11 - s01 * s01)
    i00, i11, i01 = s11 * inv, s00 * inv, -s01 * inv
    w0 = (v0[0] * i00 + v1[0] * i01, v0[1] * i00 + v1[1] * i01, v0[2] * i00 + v1[2] * i01)  # V Σ⁻¹
    w1 = (v0[0] * i01 + v1[0] * i11, v0[1] * i01 + v1[1] * i11, v0[2] * i01 + v1[2] * i11)
    ur0 = t0[0] * rx + t0[1] * ry + t0[2] * rz
    ur1 = t1[0] * rx + t1[1] * ry + t1[2] * rz
    q0, q1 = i00 * ur0 + i01 * ur1, i01 * ur0 + i11 * ur1  # Σ⁻¹ Uᵀ r
    j, k = 3 * n + i, 4 * n + i
    for a in range(3):
        for c in range(3):  # I − U Σ⁻¹ Vᵀ = I − t₀ w₀ᵀ − t₁ w₁ᵀ (Σ symmetric)
            sc[j, 3 * a + c] = (1.0 if a == c else 0.0) - t0[a] * w0[c] - t1[a] * w1[c]
        sc[k, a] = t0[a] * q0 + t1[a] * q1
    sc[k, 3] = 1.0
    return (b00 - w0[0] * v0[0] - w1[0] * v1[0], b11 - w0[1] * v0[1] - w1[1] * v1[1],
            b22 - w0[2] * v0[2] - w1[2] * v1[2], b01 - w0[0] * v0[1] - w1[0] * v1[1],
            b02 - w0[0] * v0[2] - w1[0] * v1[2], b12 - w0[1] * v0[2] - w1[1] * v1[2],
            rx - v0[0] * q0 - v1[0] * q1, ry - v0[1] * q0 - v1[1] * q1, rz - v0[2] * q0 - v1[2] * q1)


# ---------------------------------------------------------------------------------------------------------------
# The general rod's system: 3 × 3 blocks with two blocks below the diagonal.


@_inline
def _mul_t(out, A, B):
    """out ← A Bᵀ (3 × 3)."""
    for a in range(3):
        for b in range(3):
            out[a, b] = A[a, 0] * B[b, 0] + A[a, 1] * B[b, 1] + A[a, 2] * B[b, 2]


@_inline
def _sub_mul_t(out, A, B):
    """out ← out − A Bᵀ (3 × 3)."""
    for a in range(3):
        for b in range(3):
            out[a, b] -= A[a, 0] * B[b, 0] + A[a, 1] * B[b, 1] + A[a, 2] * B[b, 2]


@_inline
def _load(out, band, r, off):
    """out ← the 3 × 3 block at rows r.. whose (a, b) entry is band[r + a, off + a − b] (off = 3 (k − j))."""
    for a in range(3):
        for b in range(3):
            out[a, b] = band[r + a, off + a - b]


@_inline
def _store(band, r, off, M):
    for a in range(3):
        for b in range(3):
            band[r + a, off + a - b] = M[a, b]


@_jit
def block_ldlt_solve(band, rhs, t):
    """Solve A y = rhs in place for a symmetric positive definite A of 3 × 3 blocks (k, j) that vanish for
    k − j > 2, in lower band storage of half-bandwidth 8 (:func:`mjcable.solvers.direct_kernels.banded_ldlt_solve`'s),
    by block LDLᵀ without pivoting (O(blocks), about half the scalar banded LDLᵀ's work: no zeros inside the
    blocks' band are visited). ``band`` is overwritten by L's blocks L_{k,k−1}, L_{k,k−2} and, in the diagonal
    block's lower triangle, D_k⁻¹; ``t`` is (8, 3, 3) scratch. With W_{k,j} = L_{k,j} D_j (D_j symmetric):
    W_{k,k−2} = A_{k,k−2}, W_{k,k−1} = A_{k,k−1} − W_{k,k−2} L_{k−1,k−2}ᵀ, D_k = A_kk − Σ_j W_{k,j} L_{k,j}ᵀ."""
    block_ldlt_factor(band, t)
    block_ldlt_substitute(band, rhs)


@_jit
def block_ldlt_factor(band, t):
    """The factorisation of :func:`block_ldlt_solve`, in place (``band`` (3B, 9), ``t`` (8, 3, 3) scratch)."""
    nb = band.shape[0] // 3
    w2, w1, l2, l1, d, e2, e1, p1 = t[0], t[1], t[2], t[3], t[4], t[5], t[6], t[7]  # e: D⁻¹; p1: L_{k−1,k−2}
    for k in range(nb):
        r = 3 * k
        for a in range(3):
            for b in range(a + 1):
                d[a, b] = d[b, a] = band[r + a, a - b]
        if k >= 2:
            _load(w2, band, r, 6)
            _mul_t(l2, w2, e2)  # (e2 symmetric: W D⁻¹ = W D⁻ᵀ)
            _sub_mul_t(d, w2, l2)
            _store(band, r, 6, l2)
        if k >= 1:
            _load(w1, band, r, 3)
            if k >= 2:
                _sub_mul_t(w1, w2, p1)
            _mul_t(l1, w1, e1)
            _sub_mul_t(d, w1, l1)
            _store(band, r, 3, l1)
            p1[:, :] = l1
        e2[:, :] = e1
        c00 = d[1, 1] * d[2, 2] - d[2, 1] * d[2, 1]
        c01 = d[2, 1] * d[2, 0] - d[1, 0] * d[2, 2]
        c02 = d[1, 0] * d[2, 1] - d[1, 1] * d[2, 0]
        inv = 1.0 / (d[0, 0] * c00 + d[1, 0] * c01 + d[2, 0] * c02)
        e1[0, 0], e1[0, 1], e1[0, 2] = c00 * inv, c01 * inv, c02 * inv
        e1[1, 1] = (d[0, 0] * d[2, 2] - d[2, 0] * d[2, 0]) * inv
        e1[1, 2] = (d[2, 0] * d[1, 0] - d[0, 0] * d[2, 1]) * inv
        e1[2, 2] = (d[0, 0] * d[1, 1] - d[1, 0] * d[1, 0]) * inv
        e1[1, 0], e1[2, 0], e1[2, 1] = e1[0, 1], e1[0, 2], e1[1, 2]
        for a in range(3):
            for b in range(a + 1):
                band[r + a, a - b] = e1[a, b]


@_jit
def block_ldlt_substitute(band, rhs):
    """A = L D Lᵀ factored by :func:`block_ldlt_factor` in ``band``: rhs ← A⁻¹ rhs, in place."""
    nb = rhs.shape[0] // 3
    for k in range(nb):  # L y = rhs
        r = 3 * k
        for j in range(max(0, k - 2), k):
            off, rj = r - 3 * j, 3 * j
            for a in range(3):
                rhs[r + a] -= (band[r + a, off + a] * rhs[rj] + band[r + a, off + a - 1] * rhs[rj + 1]
                               + band[r + a, off + a - 2] * rhs[rj + 2])
    for k in range(nb - 1, -1, -1):  # y ← D⁻¹ y − Σ L_{m,k}ᵀ y_m (m = k + 1, k + 2)
        r = 3 * k
        y0, y1, y2 = rhs[r], rhs[r + 1], rhs[r + 2]
        z0 = band[r, 0] * y0 + band[r + 1, 1] * y1 + band[r + 2, 2] * y2
        z1 = band[r + 1, 1] * y0 + band[r + 1, 0] * y1 + band[r + 2, 1] * y2
        z2 = band[r + 2, 2] * y0 + band[r + 2, 1] * y1 + band[r + 2, 0] * y2
        for m in range(k + 1, min(nb, k + 3)):
            rm, off = 3 * m, 3 * (m - k)
            x0, x1, x2 = rhs[rm], rhs[rm + 1], rhs[rm + 2]
            z0 -= band[rm, off] * x0 + band[rm + 1, off + 1] * x1 + band[rm + 2, off + 2] * x2
            z1 -= band[rm, off - 1] * x0 + band[rm + 1, off] * x1 + band[rm + 2, off + 1] * x2
            z2 -= band[rm, off - 2] * x0 + band[rm + 1, off - 1] * x1 + band[rm + 2, off] * x2
        rhs[r], rhs[r + 1], rhs[r + 2] = z0, z1, z2
