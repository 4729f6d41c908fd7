"""The direct order of the particle solvers, ``@njit`` (cached, see :mod:`mjcable.solvers._kernel_cache`): all chain
constraints at once as one banded linear system (Deul et al. 2018, [D18] in :mod:`mjcable.solvers.kernels`), solved
by a banded LDLᵀ (a stretch chain with its geometric stiffness: 3 × 3 blocks, by block LDLᵀ), with the safeguard that
re-linearises a failed solve. Re-exported by :mod:`mjcable.solvers.kernels`.
"""

from __future__ import annotations

import math

from mjcable.solvers._kernel_cache import inline as _inline, jit as _jit
from mjcable.solvers.chain_solve_kernels import (_DIRECT_REGULARIZATION, _DIRECT_RESIDUAL_FLOOR,
                                                  _chain_geometric_solve, _perpendicular, row_step)
from mjcable.solvers.constraint_kernels import (_bend_clamp_sweeps, body_clamp_turn, body_turn_dot, stretch_sweep,
                                                 turns_body)
from mjcable.solvers.ring_direct_kernels import ring_crossings, ring_row, ring_soft_move, ring_soften
from mjcable.solvers.kernels_layout import (_TINY_LENGTH, BEND_DISTANCE, BEND_NONE, ROW_CLAMP, ROW_CURVATURE,
                                            ROW_DISTANCE, ROW_STRETCH, ROW_TRANSVERSE)

# [T15] M. Tournier, M. Nesme, B. Gilles, F. Faure, "Stable Constrained Dynamics", ACM TOG 34(4), 2015.

# The direct solve's safeguard against a failed linearisation (see direct_solve). A solve is accepted once the
# largest relative residual ρ = |C + α̃ λ| / rest of the distance rows has shrunk by _DIRECT_CONTRACTION (a Newton
# step within its region of convergence shrinks it far more: from about 1e-4 to 3e-9 per substep in the hanging
# cable), or is at most _DIRECT_RESIDUAL_FLOOR: a relative stretch that a solve moving particles across their
# segments leaves in any case (a stiff rod's bending correction of the sag g h² leaves (g h²)² / 2 l₀² ≈ 8e-5 at
# h = 5 ms) and that is harmless, far below a failed linearisation (0.65 in a yank). Else the rows are
# re-linearised and solved again, at most _DIRECT_MAX_SOLVES solves per iteration in all.
_DIRECT_CONTRACTION = 0.5
_DIRECT_MAX_SOLVES = 8
# The tension's transverse Courant number c h / l₀ (c = √(T / μ) the speed of transverse waves along the chain, h the
# substep, l₀ the segment length) from which a direct solve includes the stretch rows' geometric stiffness (transverse
# rows, see _direct_residuals). Without it the tension's sideways pull is explicit in position: stable only below
# about 1 (beyond, one solve per substep no longer converges and the chain runs away). Below 0.6 the chain's own rows
# keep an inextensible hang within 4e-7 of its length (the hang at 400-550 segments, 4 substeps of 0.5 ms: c h / l₀ up
# to 0.49-0.67 at its top); from 0.73 they leave 1e-4 (600 segments), so the transverse rows take over below that.
# Below it a coarse chain keeps the plain solve: with bending rows the extended rows cost several times the chain's
# own; a stretch chain's block solve (_chain_geometric_solve) costs about the same as its plain one
# (docs/measurements.md).
_GEOMETRIC_COURANT = 0.6


# ---------------------------------------------------------------------------------------------------------------
# The direct order: all chain constraints at once.


@_jit
def banded_ldlt_solve(band, rhs, bw):
    """Solve A y = rhs in place for a symmetric positive definite A in lower band storage band[i, i − j] = A[i, j]
    (half-bandwidth ``bw``), by LDLᵀ without pivoting, O(rows · bw²); ``band`` is overwritten by the factors.
    For bw = 1 (a chain of stretch constraints) this is the Thomas algorithm."""
    _banded_ldlt_factor(band, bw)
    _banded_ldlt_substitute(band, rhs, bw)


@_inline
def _banded_ldlt_factor(band, bw):
    """The LDLᵀ factors of :func:`banded_ldlt_solve`, in place: band[j, 0] ← d_j, band[i, i − j] ← L_ij."""
    nrow = band.shape[0]
    for j in range(nrow):
        d = band[j, 0]
        for kk in range(max(0, j - bw), j):
            ljk = band[j, j - kk]
            d -= ljk * ljk * band[kk, 0]
        band[j, 0] = d
        for i in range(j + 1, min(nrow, j + bw + 1)):
            acc = band[i, i - j]
            for kk in range(max(0, i - bw), j):
                acc -= band[i, i - kk] * band[j, j - kk] * band[kk, 0]
            band[i, i - j] = acc / d


@_inline
def _banded_ldlt_substitute(band, rhs, bw):
    """y = L⁻ᵀ D⁻¹ L⁻¹ rhs in place, from the factors of :func:`_banded_ldlt_factor`."""
    nrow = rhs.shape[0]
    for i in range(nrow):  # L z = rhs
        acc = rhs[i]
        for kk in range(max(0, i - bw), i):
            acc -= band[i, i - kk] * rhs[kk]
        rhs[i] = acc
    for i in range(nrow):  # D
        rhs[i] /= band[i, 0]
    for i in range(nrow - 1, -1, -1):  # Lᵀ y = z
        acc = rhs[i]
        for kk in range(i + 1, min(nrow, i + bw + 1)):
            acc -= band[kk, kk - i] * rhs[kk]
        rhs[i] = acc


@_inline
def _in_gap(seg_cable, kind, idx):
    """Whether row ``idx`` of kind ``kind`` touches a gap segment (``seg_cable`` < 0): the rows are built once,
    for the cables' segments, but a winch turns the segments on its spool into gaps at run time
    (:mod:`mjcable.solvers.winch_kernels`)."""
    if kind == ROW_STRETCH:
        return seg_cable[idx] < 0
    if kind == ROW_TRANSVERSE:
        return seg_cable[idx // 2] < 0
    if kind == ROW_DISTANCE:
        return seg_cable[idx] < 0 or seg_cable[idx + 1] < 0
    if kind == ROW_CURVATURE:
        return seg_cable[idx // 3] < 0 or seg_cable[idx // 3 + 1] < 0
    return False


@_inline
def _direct_residuals(S, rows):
    """Linearise every row of ``rows`` (``row_kind``, ``row_idx``, ``row_p``, ``prow``, ``pslot``, ``band``,
    ``grad``, ``rhs``, ``row_cable`` of the state, or their ``gs_`` twins) at the current x: ∇C into ``grad``,
    −C − α̃ λ into ``rhs`` and α̃ into ``band[:, 0]`` (the rest of ``band`` zeroed), each row's α̃ and l₀ its
    cable's (``cable_par``). Returns ρ = max |C + α̃ λ| / rest over the distance rows.

    A transverse row (ROW_TRANSVERSE, two per stretch row i of tension T = −λ / h² in ``lam_gs``) is the stretch
    row's geometric stiffness −λ ∇²C = −λ (I − n nᵀ) / |d| (on the blocks [[1, −1], [−1, 1]]) written as a compliant
    row: C⊥ = t · (xᵢ − xⱼ) with t ⊥ n (the two rows' t and n orthonormal), α̃⊥ = |d| / −λ, C⊥ = 0 where it is
    linearised. Its Schur complement (eliminating its multiplier) adds t tᵀ / α̃⊥ to the mass matrix: with both rows,
    M̃ = M − λ ∇²C, the implicit step's Hessian ([T15] Eq. 14, [M16] Eq. 10 without XPBD's approximation M̃ ≈ M),
    while the system keeps the Schur form (J W Jᵀ + α̃) Δλ = rhs over the extended rows, banded. A compressed row
    (λ ≥ 0) has none (its rows are left out: M̃ stays positive definite)."""
    x, w = S.x, S.w
    row_kind, row_idx, row_p, prow, pslot, band, grad, rhs, row_cable = rows
    lam_gs = S.lam_gs
    lam_s, lam_d, lam_b, lam_c = S.lam_s, S.lam_d, S.lam_b, S.lam_c
    rest, rest_d = S.rest, S.rest_d
    clamp_dir, clamp_pin, pin_active = S.clamp_dir, S.clamp_pin, S.pin_active
    nrow = rhs.shape[0]
    band[:] = 0.0
    grad[:] = 0.0
    rho = 0.0
    seg_cable, spools, cables = S.seg_cable, S.winch_pin.shape[0] > 0, S.cable_par
    for r in range(nrow):  # C, ∇C and α̃ of every row
        kind = row_kind[r]
        idx = row_idx[r]
        if spools and _in_gap(seg_cable, kind, idx):  # a row on a winch's spool: none (Δλ = 0, _schur_assemble)
            rhs[r] = 0.0
            continue
        cval = 0.0
        lam = 0.0
        cp = cables[row_cable[r]]
        at = cp.at_b
        if kind == ROW_STRETCH or kind == ROW_DISTANCE:
            i, j = row_p[r, 0], row_p[r, 1]
            dx, dy, dz = x[i, 0] - x[j, 0], x[i, 1] - x[j, 1], x[i, 2] - x[j, 2]
            length = math.sqrt(dx * dx + dy * dy + dz * dz)
            if kind == ROW_STRETCH:
                at = cp.at_s
                lam = lam_s[idx]
                rl = rest[idx]
                row_p[r, 2] = -1  # (a ring's hub, while a ring holds the segment)
            else:
                lam = lam_d[idx]
                rl = rest_d[idx]
            cval = length - rl
            if rl < 0.0:  # a segment a ring holds: the length through the ring (ring_direct_kernels.ring_row)
                held, cval = ring_row(S, idx, r, grad, row_p, prow, pslot)
                rl = -rl
                if not held:  # left out (a ring with friction projects it after the solve)
                    at = 0.0
            elif length > _TINY_LENGTH:
                grad[r, 0, 0], grad[r, 0, 1], grad[r, 0, 2] = dx / length, dy / length, dz / length
                grad[r, 1, 0], grad[r, 1, 1], grad[r, 1, 2] = -dx / length, -dy / length, -dz / length
            else:
                cval = 0.0
            rho = max(rho, abs(cval + at * lam) / rl)
        elif kind == ROW_TRANSVERSE:
            seg, k = idx // 2, idx % 2
            i, j = row_p[r, 0], row_p[r, 1]
            dx, dy, dz = x[i, 0] - x[j, 0], x[i, 1] - x[j, 1], x[i, 2] - x[j, 2]
            length = math.sqrt(dx * dx + dy * dy + dz * dz)
            if lam_gs[seg] < 0.0 and length > _TINY_LENGTH and rest[seg] > 0.0:  # (none through a ring)
                at = length / -lam_gs[seg]
                tx, ty, tz = _perpendicular(dx / length, dy / length, dz / length, k)
                grad[r, 0, 0], grad[r, 0, 1], grad[r, 0, 2] = tx, ty, tz
                grad[r, 1, 0], grad[r, 1, 1], grad[r, 1, 2] = -tx, -ty, -tz
            else:
                at = 0.0  # no stiffness: the row is left out (Δλ = 0, see _schur_assemble)
        elif kind == ROW_CURVATURE:
            b, comp = idx // 3, idx % 3
            i = b + 1
            lam = lam_b[b, comp]
            inv_l0sq = cp.inv_l0sq
            cval = (x[i - 1, comp] - 2.0 * x[i, comp] + x[i + 1, comp]) * inv_l0sq
            grad[r, 0, comp], grad[r, 1, comp], grad[r, 2, comp] = inv_l0sq, -2.0 * inv_l0sq, inv_l0sq
        else:  # ROW_CLAMP
            at = cp.at_c
            kc, m = idx // 2, idx % 2
            if pin_active[clamp_pin[kc]]:
                p, q = row_p[r, 0], row_p[r, 1]
                lam = lam_c[kc, m]
                scale = 2.0 * cp.inv_l0sq
                for comp in range(3):
                    d = scale * clamp_dir[kc, m, comp]
                    grad[r, 0, comp] = -d
                    grad[r, 1, comp] = d
                    cval += d * (x[q, comp] - x[p, comp])
            else:
                at = 0.0
        band[r, 0] = at
        rhs[r] = -cval - at * lam
    return rho


@_inline
def _schur_assemble(S, rows):
    """J W Jᵀ + α̃ into ``rows``' band ([M16] Eq. 18 for all rows at once), after :func:`_direct_residuals`."""
    x, w = S.x, S.w
    row_kind, row_idx, row_p, prow, pslot, band, grad, rhs, row_cable = rows
    nrow = rhs.shape[0]
    for p in range(x.shape[0]):  # J W Jᵀ, particle by particle
        wp = w[p]
        if wp == 0.0:
            continue
        for ka in range(prow.shape[1]):
            ra = prow[p, ka]
            if ra < 0:
                break
            sa = pslot[p, ka]
            for kb in range(ka + 1):
                rb = prow[p, kb]
                sb = pslot[p, kb]
                dot = grad[ra, sa, 0] * grad[rb, sb, 0] + grad[ra, sa, 1] * grad[rb, sb, 1] \
                    + grad[ra, sa, 2] * grad[rb, sb, 2]
                if ra >= rb:
                    band[ra, ra - rb] += wp * dot
                else:
                    band[rb, rb - ra] += wp * dot
    for r in range(nrow if S.clamp_pq.shape[0] else 0):  # (a chain without clamps has no clamp rows)
        kc = row_idx[r] // 2  # a body clamp's rows: its body's turn, scale² (d_a × e)ᵀ W (d_b × e), m = 1 after 0
        if row_kind[r] == ROW_CLAMP and turns_body(S, kc) and S.pin_active[S.clamp_pin[kc]]:
            inv_l0sq = S.cable_par[row_cable[r]].inv_l0sq
            scale2 = 4.0 * inv_l0sq * inv_l0sq
            m, p, q = row_idx[r] % 2, row_p[r, 0], row_p[r, 1]
            e0, e1, e2 = x[q, 0] - x[p, 0], x[q, 1] - x[p, 1], x[q, 2] - x[p, 2]
            band[r, 0] += scale2 * body_turn_dot(S, kc, m, m, e0, e1, e2)
            if m == 1:
                band[r, 1] += scale2 * body_turn_dot(S, kc, 1, 0, e0, e1, e2)
    if S.ring_p.shape[0]:  # the rings' particles: their arms' geometric stiffness (ring_direct_kernels)
        ring_soften(S, rows)
    for r in range(nrow):
        if band[r, 0] == 0.0:  # a hard row on held particles only (or a released clamp): Δλ = 0
            band[r, 0] = 1.0
            rhs[r] = 0.0
        else:
            band[r, 0] *= 1.0 + _DIRECT_REGULARIZATION


@_inline
def _direct_apply(S, rows, unit):
    """λ += k Δλ and x += W Jᵀ k Δλ ([M16] Eq. 17) for the Δλ that :func:`banded_ldlt_solve` left in ``rows``'
    ``rhs``, k the row's cable's factor (``cable_par``; with ``unit``, 1). A transverse row's Δλ moves the particles
    (and adds to a held one's reaction: its share of the geometric stiffness, the turn of the stretch row's force
    over the step) but is no multiplier of its own."""
    x, w, react = S.x, S.w, S.react
    row_kind, row_idx, row_p, _, _, _, grad, rhs, row_cable = rows
    lam_s, lam_d, lam_b, lam_c = S.lam_s, S.lam_d, S.lam_b, S.lam_c
    for r in range(rhs.shape[0] if S.clamp_pq.shape[0] else 0):  # (a chain without clamps has no clamp rows)
        # a body clamp's share, τ = ∇_θ C Δλ at the linearisation's x: its body turns
        if row_kind[r] == ROW_CLAMP and rhs[r] != 0.0 and turns_body(S, row_idx[r] // 2):
            p, q = row_p[r, 0], row_p[r, 1]
            cp = S.cable_par[row_cable[r]]
            k_c = 1.0 if unit else cp.k_c
            body_clamp_turn(S, row_idx[r] // 2, row_idx[r] % 2, 2.0 * cp.inv_l0sq * k_c * rhs[r],
                            x[q, 0] - x[p, 0], x[q, 1] - x[p, 1], x[q, 2] - x[p, 2])
    if S.ring_p.shape[0]:  # the rings' particles: their arms' geometric stiffness (ring_direct_kernels)
        ring_soft_move(S, rows, unit)
    cables = S.cable_par
    for r in range(rhs.shape[0]):
        kind = row_kind[r]
        idx = row_idx[r]
        k_s = k_b = k_c = 1.0
        if not unit:
            cp = cables[row_cable[r]]
            k_s, k_b, k_c = cp.k_s, cp.k_b, cp.k_c
        dlam = row_step(kind, rhs[r], k_s, k_b, k_c)
        if kind == ROW_STRETCH:
            lam_s[idx] += dlam
        elif kind == ROW_DISTANCE:
            lam_d[idx] += dlam
        elif kind == ROW_CURVATURE:
            lam_b[idx // 3, idx % 3] += dlam
        elif kind == ROW_CLAMP:
            lam_c[idx // 2, idx % 2] += dlam
        if dlam == 0.0:
            continue
        for a in range(3):
            p = row_p[r, a]
            if p < 0:
                continue
            wp = w[p]
            if wp > 0.0:
                for comp in range(3):
                    x[p, comp] += wp * grad[r, a, comp] * dlam
            else:
                for comp in range(3):
                    react[p, comp] += grad[r, a, comp] * dlam


@_inline
def _tension_is_stiff(lam, rest, w):
    """Whether the tension of some stretch row, from its multiplier λ (``lam`` (n,), λ = −T h² in tension), has a
    transverse Courant number c h / l₀ above ``_GEOMETRIC_COURANT``: (c h / l₀)² = −λ (wᵢ + wⱼ) / 2 l₀, c² = T / μ
    with the mean of the two particles' masses per length (``rest`` (n,) m, ``w`` (N,) 1/kg)."""
    limit = 2.0 * _GEOMETRIC_COURANT * _GEOMETRIC_COURANT
    for i in range(rest.shape[0]):
        if rest[i] > 0.0 and -lam[i] * (w[i] + w[i + 1]) > limit * rest[i]:
            return True
    return False


@_inline
def _chord_rhs(S, rows):
    """The right-hand side of a chord step (a Newton step with the last solve's factors) after a solve over
    ``rows``: −C − α̃ λ of the distance rows (stretch, distance bending) at the new x, 0 for the rows that the solve
    met exactly (curvature and clamps are linear in x; a transverse row's C⊥ is its linearisation) and for a hard
    row on held particles only. A distance row's residual after a solve is second order: a segment whose ends moved
    across it by Δd⊥ stretches by |Δd⊥|² / 2|d| (0.3 µm, a strain of 4e-6, in the hang's 1600 segments at 0.5 ms
    substeps); the chord step leaves a fraction of it of the order of the segments' turn within the substep. Returns
    ρ = max |C + α̃ λ| / rest over the distance rows: a chord step is taken only within Newton's region (ρ at most
    ``_DIRECT_RESIDUAL_FLOOR``), where it converges; beyond it (a yank) the safeguard of :func:`direct_solve`
    decides."""
    x, w = S.x, S.w
    row_kind, row_idx, row_p, _, _, _, _, rhs, row_cable = rows
    cables, seg_cable, rest, rest_d, lam_s, lam_d = S.cable_par, S.seg_cable, S.rest, S.rest_d, S.lam_s, S.lam_d
    spools = S.winch_pin.shape[0] > 0
    rho = 0.0
    for r in range(rhs.shape[0]):
        kind = row_kind[r]
        rhs[r] = 0.0
        if kind != ROW_STRETCH and kind != ROW_DISTANCE:
            continue
        i, j = row_p[r, 0], row_p[r, 1]
        if (w[i] == 0.0 and w[j] == 0.0) or (spools and _in_gap(seg_cable, kind, row_idx[r])):
            continue
        dx, dy, dz = x[i, 0] - x[j, 0], x[i, 1] - x[j, 1], x[i, 2] - x[j, 2]
        length = math.sqrt(dx * dx + dy * dy + dz * dz)
        idx = row_idx[r]
        cp = cables[row_cable[r]]
        if kind == ROW_STRETCH:
            if rest[idx] < 0.0:  # a segment a ring holds (no chord step with rings: _direct_once_geometric)
                continue
            rhs[r] = -(length - rest[idx]) - cp.at_s * lam_s[idx]
            rho = max(rho, abs(rhs[r]) / rest[idx])
        else:
            rhs[r] = -(length - rest_d[idx]) - cp.at_b * lam_d[idx]
            rho = max(rho, abs(rhs[r]) / rest_d[idx])
    return rho


@_inline
def _direct_once(S):
    """One direct solve at the current x over the chain's rows, or, where the model's multipliers are forces
    (``par.geometric``) and the last solve found the tension stiff (``par.gs_stiff``, :func:`_tension_is_stiff`),
    the same rows with their geometric stiffness: block by block for a chain of stretch rows only (``par.gs_chain``,
    :func:`_chain_geometric_solve`), else over the extended rows (:func:`_direct_once_geometric`). Returns ρ before
    it."""
    P = S.par[0]
    if P.gs_stiff and P.gs_chain:
        rho = _chain_geometric_solve(S)
    elif P.gs_stiff:
        rho = _direct_once_geometric(S)
    else:
        rows = (S.row_kind, S.row_idx, S.row_p, S.prow, S.pslot, S.band, S.grad, S.rhs, S.row_cable)
        rho = _direct_residuals(S, rows)
        _schur_assemble(S, rows)
        banded_ldlt_solve(S.band, S.rhs, P.bandwidth)
        _direct_apply(S, rows, False)
        if S.ring_p.shape[0]:
            ring_crossings(S, S.grad, S.prow)
    if P.geometric:  # the next solve's rows (in the next substep from these multipliers, reset by then)
        P.gs_stiff = _tension_is_stiff(S.lam_s, S.rest, S.w)
        if P.gs_stiff:
            S.lam_gs[:] = S.lam_s
    P.direct_solves += 1
    return rho


@_jit
def _direct_once_geometric(S):
    """One direct solve over the rows with the stretch rows' geometric stiffness (the ``gs_`` rows, see
    :func:`_direct_residuals`) from the last solve's multipliers (``lam_gs``), followed by a chord step
    (:func:`_chord_rhs`; none with rings, :mod:`mjcable.solvers.ring_direct_kernels`); XPBD's (k = 1). In a
    substep's first solve the multipliers are the previous substep's (λ is reset every substep, and would give
    M̃ = M), in a later one (the safeguard's, or a second iteration) this substep's so far, which makes it Newton's
    step. Returns ρ before it."""
    rows = (S.gs_row_kind, S.gs_row_idx, S.gs_row_p, S.gs_prow, S.gs_pslot, S.gs_band, S.gs_grad, S.gs_rhs,
            S.gs_row_cable)
    bandwidth = S.par[0].gs_bandwidth
    rho = _direct_residuals(S, rows)
    _schur_assemble(S, rows)
    _banded_ldlt_factor(S.gs_band, bandwidth)
    _banded_ldlt_substitute(S.gs_band, S.gs_rhs, bandwidth)
    _direct_apply(S, rows, True)
    if S.ring_p.shape[0]:  # a particle carried through a ring passes; no chord step (its C_Σ has a kink at c)
        ring_crossings(S, S.gs_grad, S.gs_prow)
        return rho
    if _chord_rhs(S, rows) <= _DIRECT_RESIDUAL_FLOOR:  # a chord step (see _chord_rhs)
        _banded_ldlt_substitute(S.gs_band, S.gs_rhs, bandwidth)
        _direct_apply(S, rows, True)
    return rho


@_inline
def _distance_rows_within(x, rest, gap, cables, lam, tol, chains):
    """Whether every distance constraint C = |xᵢ − xᵢ₊gap| − rest (thesis Eq. 2.9) of each chain (``chains`` (C, 2):
    each cable's segments [first, stop)) has |C + α̃ λ| ≤ tol · rest, the XPBD residual ([M16] Eq. 18's numerator)
    that a converged solve drives to zero. Without a square root or a division: with the target length
    t = rest − α̃ λ and margin e = tol · rest, |d| − t ∈ [−e, e] iff |d|² ≤ (t + e)² and |d|² ≥ (t − e)² (the
    latter always true when t ≤ e). α̃ is each chain's cable's (``cables`` (C,) CABLE_PARAMS: the stretch's, or with
    gap 2 the bending's)."""
    for chain in range(chains.shape[0]):
        if gap == 2 and not cables[chain].bends:  # (a limp cable beside bending ones has no bending rows)
            continue
        alpha_tilde = cables[chain].at_s if gap == 1 else cables[chain].at_b
        if not _chain_rows_within(x, rest, gap, alpha_tilde, lam, tol, chains[chain, 0], chains[chain, 1]):
            return False
    return True


@_inline
def _chain_rows_within(x, rest, gap, alpha_tilde, lam, tol, first, stop):
    """:func:`_distance_rows_within` for one chain's constraints c in [first, stop + 1 − gap)."""
    for c in range(first, stop + 1 - gap):
        dx = x[c, 0] - x[c + gap, 0]
        dy = x[c, 1] - x[c + gap, 1]
        dz = x[c, 2] - x[c + gap, 2]
        d2 = dx * dx + dy * dy + dz * dz
        target = rest[c] - alpha_tilde * lam[c]
        margin = tol * rest[c]
        high = target + margin
        low = target - margin
        if d2 > high * high or d2 < low * abs(low):
            return False
    return True


@_inline
def _direct_within(S, tol):
    """Whether the direct solve's distance rows (stretch, and distance bending if solved) have relative residuals
    |C + α̃ λ| / rest ≤ tol."""
    if not _distance_rows_within(S.x, S.rest, 1, S.cable_par, S.lam_s, tol, S.chain_seg):
        return False
    if S.par[0].direct_all and S.par[0].bending == BEND_DISTANCE:
        return _distance_rows_within(S.x, S.rest_d, 2, S.cable_par, S.lam_d, tol, S.chain_seg)
    return True


@_jit
def direct_solve(S):
    """One direct iteration over all chain constraints (stretch, bending, clamps) at once: the linearised XPBD
    system (J W Jᵀ + α̃) Δλ = −C − α̃ λ ([M16]'s linearised system with its g term dropped, as there) is banded
    for a chain and is solved exactly by :func:`banded_ldlt_solve` ([D18]); Δx = W Jᵀ Δλ. With stretch rows only
    it is tridiagonal. A single iteration then gives XPBD's stated stiffness; PBD and Jakobsen scale Δλ by their k.
    Where the tension is stiff (transverse waves faster than a fifth of a segment per substep; ``par.geometric``:
    XPBD, and PBD and Jakobsen at k = 1), the system also
    carries the stretch rows' geometric stiffness, which makes the tension's sideways pull implicit
    (:func:`_direct_once`).

    A safeguard for large rotations within a substep. The curvature and clamp rows are linear in x, so the solve
    meets them exactly; the distance rows (stretch, distance bending; C = |d| − rest) are not: a segment whose end
    moves across it by Δd⊥ stretches by |Δd⊥|² / 2|d|, which the linearisation misses. Moving a light particle
    across a straight neighbour costs nothing to first order, so when a gripper yanks the end of a straight cable
    (20 m/s at dt = 2 ms, 4 substeps) the solve flings the next particle sideways and leaves the cable more
    stretched than before (largest strain 45 % → 65 %); the positions carry this as velocity, and the cable blows
    up. So the relative residual of the distance rows, ρ = max |C + α̃ λ| / rest, before the solve (ρ₀, from the
    linearisation) is compared with its value after (one pass over the distance rows, without a square root):

    * ρ ≤ max(ρ_floor, (1 − k (1 − κ)) ρ₀), κ = ``_DIRECT_CONTRACTION``, ρ_floor = ``_DIRECT_RESIDUAL_FLOOR``, k
      the smallest of the cables' stretch factors:
      the solve is accepted. It is a Newton step on C(x) + α̃ λ = 0 along Δx = W Jᵀ Δλ (each XPBD iteration is
      such a step, with the geometric stiffness and [M16]'s g dropped), which within its region of convergence
      shrinks ρ to second order; with k < 1 only k of the residual is removed. This is the normal case: one solve
      per iteration with the same result as without the safeguard, plus the check (0.4 µs of a 50-segment
      substep's 3 µs).
    * otherwise the linearisation has failed: re-linearise at the new x and solve again (another Newton step, i.e.
      another direct XPBD iteration) until accepted, at most ``_DIRECT_MAX_SOLVES`` solves in all. Converging the
      same implicit step further leaves XPBD's stiffness as it is.
    * if ρ is still above ρ₀ after the last solve (Newton not converging, e.g. when a pin moves more than a
      segment within a substep), one nonlinear Gauss-Seidel sweep of the same rows follows ([M16] Eq. 18 per
      constraint, as ``order="gauss-seidel"``): each projection solves its own constraint exactly, without overshoot.
    """
    rho0 = _direct_once(S)
    k_s = S.cable_par[0].k_s
    for c in range(1, S.cable_par.shape[0]):
        k_s = min(k_s, S.cable_par[c].k_s)
    tol = max(_DIRECT_RESIDUAL_FLOOR, (1.0 - k_s * (1.0 - _DIRECT_CONTRACTION)) * rho0)
    if not _direct_within(S, tol):
        _direct_relinearise(S, rho0, tol)


@_jit
def _direct_relinearise(S, rho0, tol):
    """The safeguard of :func:`direct_solve` after a rejected solve: further Newton steps (re-linearised solves)
    until every relative residual is within ``tol``, at most ``_DIRECT_MAX_SOLVES`` solves in all; then, if some
    is still above ρ₀, one Gauss-Seidel sweep of the same rows ([M16] Eq. 18 per constraint)."""
    for _ in range(_DIRECT_MAX_SOLVES - 1):
        _direct_once(S)
        if _direct_within(S, tol):
            return
    if not _direct_within(S, rho0):  # Newton diverging: project the rows one by one
        x = S.x
        stretch_sweep(x, x, S.w, S.react, S.rest, 1, S.cable_par, S.lam_s, S.par[0].sqrt_approx, S.relax[:0],
                      S.chain_seg)
        if S.par[0].direct_all and (S.par[0].bending != BEND_NONE or S.clamp_pq.shape[0] > 0):
            _bend_clamp_sweeps(S, x, False)
