"""The direct order's block solve of a stretch chain with its geometric stiffness, ``@njit`` (cached, see
:mod:`mjcable.solvers._kernel_cache`): :func:`_chain_geometric_solve`, called by
:mod:`mjcable.solvers.direct_kernels` (whose module docstring tells the direct order) for a chain whose rows are its
stretch rows only. With several cables, the chains lie one after the other in the state and the gap segments between
them (``seg_cable`` < 0) carry no impulse: the block system falls apart into one block tridiagonal system per cable.
"""

from __future__ import annotations

import math

from mjcable.solvers._kernel_cache import inline as _inline, jit as _jit
from mjcable.solvers.kernels_layout import _TINY_LENGTH, ROW_CURVATURE, ROW_DISTANCE, ROW_STRETCH, ROW_TRANSVERSE

# Relative compliance added to every row of the direct solve: it keeps hard, redundant rows (e.g. inextensible
# stretch with hard curvature bending: more rows than degrees of freedom) solvable and is far below any physical one.
_DIRECT_REGULARIZATION = 1e-10
# The smallest relative residual ρ a direct solve need not shrink further (see direct_kernels' safeguard): a relative
# stretch that a solve moving particles across their segments leaves in any case and that is harmless; a chord step
# is taken only within it (Newton's region).
_DIRECT_RESIDUAL_FLOOR = 1e-4
# The block solve of a stretch chain's geometric stiffness (_chain_geometric_solve) leaves out a segment's transverse
# rows where their compliance exceeds _TRANSVERSE_NEGLIGIBLE times the segment's axial diagonal w_i + w_j + α̃ (a
# tension near zero): they would move the step by less than that fraction, and a world-frame block holding both
# would lose the axial row's digits to the transverse ones' (its entries carry both).
_TRANSVERSE_NEGLIGIBLE = 1e6


@_inline
def row_step(kind, dlam, k_s, k_b, k_c):
    """A row's step of its multiplier from the solve's Δλ: scaled by its kind's factor k (PBD, Jakobsen); a
    transverse row's Δλ unscaled (it moves the particles, but is no multiplier of its own)."""
    if kind == ROW_STRETCH:
        return k_s * dlam
    if kind == ROW_DISTANCE or kind == ROW_CURVATURE:
        return k_b * dlam
    if kind == ROW_TRANSVERSE:
        return dlam
    return k_c * dlam


@_inline
def _perpendicular(nx, ny, nz, k):
    """The k-th (0 or 1) of two unit vectors perpendicular to the unit vector n and to each other."""
    ax, ay, az = abs(nx), abs(ny), abs(nz)
    if ax <= ay and ax <= az:  # t₀ = n × e, e the axis least along n
        tx, ty, tz = 0.0, nz, -ny
    elif ay <= az:
        tx, ty, tz = -nz, 0.0, nx
    else:
        tx, ty, tz = ny, -nx, 0.0
    norm = math.sqrt(tx * tx + ty * ty + tz * tz)
    tx, ty, tz = tx / norm, ty / norm, tz / norm
    if k == 0:
        return tx, ty, tz
    return ny * tz - nz * ty, nz * tx - nx * tz, nx * ty - ny * tx


@_jit
def _chain_geometric_solve(S):
    """:func:`_direct_once_geometric` for a chain whose rows are its stretch rows only, solved block by block: the
    same linear system, O(n) with a small constant. Returns ρ before the solve.

    A segment i's three rows (stretch along n = d / |d|, d = xᵢ − xᵢ₊₁, and its two transverse rows) have the
    gradients ±R = ±[n t₀ t₁] (orthonormal) on particles i and i + 1, so with the segment's impulse in world axes,
    fᵢ = R Δλᵢ, the Schur system (J W Jᵀ + α̃) Δλ = rhs becomes block tridiagonal with 3 × 3 blocks:

    * Aᵢᵢ = (w_i + w_{i+1} + α̃⊥) I + (α̃ − α̃⊥) n nᵀ (times 1 + ``_DIRECT_REGULARIZATION``, as every row's diagonal),
    * Aᵢ,ᵢ₊₁ = −w_{i+1} I (the particle they share),
    * bᵢ = n (−C − α̃ λ) (a transverse row's right-hand side is 0),

    and Δx_p = w_p (f_p − f_{p−1}), Δλᵢ = n · fᵢ. A segment without transverse rows (compressed, or a tension so small
    that they are negligible, ``_TRANSVERSE_NEGLIGIBLE``) keeps f ∥ n, one without a direction or a hard one between
    held particles f = 0 (Δλ = 0, as a hard row on held particles in :func:`_schur_assemble`): with Πᵢ the projector
    on the allowed impulses, the system is the same on Π's range. Block LDLᵀ (block Thomas) keeps Eᵢ = Πᵢ Dᵢ⁻¹ Πᵢ,
    Dᵢ = Aᵢᵢ − w_i² Πᵢ Eᵢ₋₁ Πᵢ, and yᵢ = bᵢ + w_i Eᵢ₋₁ yᵢ₋₁ in one forward pass that also linearises the rows; the
    backward pass fᵢ = Eᵢ (yᵢ + w_{i+1} fᵢ₊₁) moves the particles (a held one's share goes to its reaction). A chord
    step with the same factors follows where :func:`_chord_rhs`'s rule takes one."""
    x, w, rest, lam_s, lam_gs, blk = S.x, S.w, S.rest, S.lam_s, S.lam_gs, S.gs_blocks
    seg_cable, cables = S.seg_cable, S.cable_par
    reg = 1.0 + _DIRECT_REGULARIZATION
    rho = 0.0
    e00 = e11 = e22 = e01 = e02 = e12 = 0.0  # E of the previous segment
    y0 = y1 = y2 = 0.0
    for i in range(rest.shape[0]):
        if seg_cable[i] < 0:  # a gap between two cables: no impulse (f = 0), the next chain starts afresh
            e00 = e11 = e22 = e01 = e02 = e12 = y0 = y1 = y2 = 0.0
            blk[i, :] = 0.0
            continue
        alpha_s_t = cables[seg_cable[i]].at_s  # (its cable's)
        dx, dy, dz = x[i, 0] - x[i + 1, 0], x[i, 1] - x[i + 1, 1], x[i, 2] - x[i + 1, 2]
        length = math.sqrt(dx * dx + dy * dy + dz * dz)
        lam = lam_s[i]
        wi = w[i]
        ws = wi + w[i + 1]
        diag = (ws + alpha_s_t) * reg  # the stretch row's Schur diagonal
        cval = length - rest[i]
        nx = ny = nz = 0.0
        if length > _TINY_LENGTH:
            nx, ny, nz = dx / length, dy / length, dz / length
        else:
            cval = 0.0
        rho = max(rho, abs(cval + alpha_s_t * lam) / rest[i])
        r = -cval - alpha_s_t * lam
        y0, y1, y2 = (nx * r + wi * (e00 * y0 + e01 * y1 + e02 * y2), ny * r + wi * (e01 * y0 + e11 * y1 + e12 * y2),
                      nz * r + wi * (e02 * y0 + e12 * y1 + e22 * y2))
        w2 = wi * wi
        at = math.inf  # the transverse rows' compliance α̃⊥ (inf: left out)
        if lam_gs[i] < 0.0 and length > _TINY_LENGTH:
            at = length / -lam_gs[i]
        if length <= _TINY_LENGTH or diag == 0.0:  # Π = 0
            if length <= _TINY_LENGTH and alpha_s_t > 0.0:  # a compliant row without a direction: its λ alone
                lam_s[i] = lam + r / (alpha_s_t * reg)
            e00 = e11 = e22 = e01 = e02 = e12 = 0.0
        elif at > _TRANSVERSE_NEGLIGIBLE * (ws + alpha_s_t):  # Π = n nᵀ: E = n nᵀ / (nᵀ D n)
            en = (nx * (e00 * nx + e01 * ny + e02 * nz) + ny * (e01 * nx + e11 * ny + e12 * nz)
                  + nz * (e02 * nx + e12 * ny + e22 * nz))
            q = 1.0 / (diag - w2 * en)
            e00, e11, e22, e01, e02, e12 = q * nx * nx, q * ny * ny, q * nz * nz, q * nx * ny, q * nx * nz, q * ny * nz
        else:  # Π = I: E = D⁻¹, D symmetric positive definite
            a = (ws + at) * reg
            b = diag - a
            d00, d11, d22 = a + b * nx * nx - w2 * e00, a + b * ny * ny - w2 * e11, a + b * nz * nz - w2 * e22
            d01, d02, d12 = b * nx * ny - w2 * e01, b * nx * nz - w2 * e02, b * ny * nz - w2 * e12
            c00, c11, c22 = d11 * d22 - d12 * d12, d00 * d22 - d02 * d02, d00 * d11 - d01 * d01
            c01, c02, c12 = d02 * d12 - d01 * d22, d01 * d12 - d11 * d02, d01 * d02 - d00 * d12
            inv_det = 1.0 / (d00 * c00 + d01 * c01 + d02 * c02)
            e00, e11, e22 = c00 * inv_det, c11 * inv_det, c22 * inv_det
            e01, e02, e12 = c01 * inv_det, c02 * inv_det, c12 * inv_det
        blk[i, 0], blk[i, 1], blk[i, 2] = nx, ny, nz
        blk[i, 3], blk[i, 4], blk[i, 5], blk[i, 6], blk[i, 7], blk[i, 8] = e00, e11, e22, e01, e02, e12
        blk[i, 9], blk[i, 10], blk[i, 11] = y0, y1, y2
    _chain_back_substitute(S)
    if _chain_chord_forward(S) <= _DIRECT_RESIDUAL_FLOOR:  # a chord step (see _chord_rhs)
        _chain_back_substitute(S)
    return rho


@_inline
def _chain_back_substitute(S):
    """The backward pass of :func:`_chain_geometric_solve` from the factors and forward-substituted right-hand side
    in ``gs_blocks``: fᵢ = Eᵢ (yᵢ + w_{i+1} fᵢ₊₁), λᵢ += n · fᵢ, Δx_p = w_p (f_p − f_{p−1}) (a held particle's
    reaction += f_p − f_{p−1})."""
    x, w, react, lam_s, blk = S.x, S.w, S.react, S.lam_s, S.gs_blocks
    n = lam_s.shape[0]
    g0 = g1 = g2 = 0.0  # f of the next segment (none after the last)
    for i in range(n - 1, -1, -1):
        wn = w[i + 1]
        u0, u1, u2 = blk[i, 9] + wn * g0, blk[i, 10] + wn * g1, blk[i, 11] + wn * g2
        e00, e11, e22, e01, e02, e12 = blk[i, 3], blk[i, 4], blk[i, 5], blk[i, 6], blk[i, 7], blk[i, 8]
        f0 = e00 * u0 + e01 * u1 + e02 * u2
        f1 = e01 * u0 + e11 * u1 + e12 * u2
        f2 = e02 * u0 + e12 * u1 + e22 * u2
        lam_s[i] += blk[i, 0] * f0 + blk[i, 1] * f1 + blk[i, 2] * f2
        p0, p1, p2 = g0 - f0, g1 - f1, g2 - f2
        if wn > 0.0:
            x[i + 1, 0] += wn * p0
            x[i + 1, 1] += wn * p1
            x[i + 1, 2] += wn * p2
        else:
            react[i + 1, 0] += p0
            react[i + 1, 1] += p1
            react[i + 1, 2] += p2
        g0, g1, g2 = f0, f1, f2
    if n > 0 and w[0] > 0.0:
        x[0, 0] += w[0] * g0
        x[0, 1] += w[0] * g1
        x[0, 2] += w[0] * g2
    elif n > 0:
        react[0, 0] += g0
        react[0, 1] += g1
        react[0, 2] += g2


@_inline
def _chain_chord_forward(S):
    """The forward pass of a chord step of :func:`_chain_geometric_solve`: :func:`_chord_rhs`'s right-hand side
    (−C − α̃ λ of the stretch rows at the new x, 0 between held particles) along the factors' directions, forward
    substituted into ``gs_blocks``. Returns its ρ = max |C + α̃ λ| / rest."""
    x, w, rest, lam_s, blk = S.x, S.w, S.rest, S.lam_s, S.gs_blocks
    seg_cable, cables = S.seg_cable, S.cable_par
    rho = 0.0
    y0 = y1 = y2 = 0.0
    for i in range(rest.shape[0]):
        r = 0.0
        wi = w[i]
        if seg_cable[i] >= 0 and (wi != 0.0 or w[i + 1] != 0.0):
            dx, dy, dz = x[i, 0] - x[i + 1, 0], x[i, 1] - x[i + 1, 1], x[i, 2] - x[i + 1, 2]
            r = -(math.sqrt(dx * dx + dy * dy + dz * dz) - rest[i]) - cables[seg_cable[i]].at_s * lam_s[i]
            rho = max(rho, abs(r) / rest[i])
        if i > 0:
            e00, e11, e22, e01, e02, e12 = blk[i - 1, 3], blk[i - 1, 4], blk[i - 1, 5], blk[i - 1, 6], \
                blk[i - 1, 7], blk[i - 1, 8]
            y0, y1, y2 = (wi * (e00 * y0 + e01 * y1 + e02 * y2), wi * (e01 * y0 + e11 * y1 + e12 * y2),
                          wi * (e02 * y0 + e12 * y1 + e22 * y2))
        y0 += blk[i, 0] * r
        y1 += blk[i, 1] * r
        y2 += blk[i, 2] * r
        blk[i, 9], blk[i, 10], blk[i, 11] = y0, y1, y2
    return rho
