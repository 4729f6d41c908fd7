"""Hot loops of the particle solvers: constraint projections and the substep driver, all ``@njit(cache=True)``.

Every constraint type has one small pure scalar function (differences of positions, inverse masses, rest value,
compliance, λ → Δλ and the correction scale) citing its paper and equation, and one sweep that applies it to
all constraints of that type. One formula serves the three solvers, the XPBD update of Macklin et al. 2016,
Eqs. (17)–(18)::

    Δλ = k · (−C − α̃ λ) / (Σⱼ wⱼ |∇ⱼC|² + α̃),   Δxⱼ = wⱼ ∇ⱼC Δλ,   α̃ = α / h²

with k = 1 for XPBD; α = 0 gives PBD's projection (thesis Eqs. 2.11–2.12; Müller et al. 2007) with its
stiffness k, and Jakobsen's mass-weighted stick (Jakobsen 2001, "Cloth simulation", the ``invmass`` form).
Held particles (pins) have w = 0; the ∇C Δλ they would receive is summed in ``react`` so that the pin force is
known (XPBD's constraint force estimate ∇Cᵀ λ / h², Macklin et al. 2016).

Performance notes (measured, numba 0.68, 100 particles): a per-constraint helper that takes arrays ran 3× slower
than the same arithmetic written inline, even with ``inline="always"``, and every call passing the 33-array state
costs microseconds (reference counting per array argument). So the per-constraint functions take and return
scalars only, the hot sweeps and the substep pieces are inlined into the drivers, the rarely used sweeps are called
only when they have work, and the drivers take the arrays as separate arguments: ``run_substeps_flat`` (one step)
and ``run_steps_flat`` (many whole steps with the Simulator's divergence checks: one call per ``step(T)`` that
needs no contact query). ``error_model="numpy"``: a division by zero gives inf/NaN (caught as divergence). Numba
caches per file: every jitted function the drivers call lives here (a callee elsewhere would leave a stale cache).

References:
  [J01] T. Jakobsen, "Advanced Character Physics", GDC 2001 (in ``shared/seeds``).
  [M07] M. Müller, B. Heidelberger, M. Hennix, J. Ratcliff, "Position Based Dynamics", JVCIR 18(2), 2007.
  [M16] M. Macklin, M. Müller, N. Chentanez, "XPBD: Position-Based Simulation of Compliant Constrained
        Dynamics", MIG 2016.
  [M20] M. Müller, M. Macklin, N. Chentanez, S. Jeschke, T.-Y. Kim, "Detailed Rigid Body Simulation with Extended
        Position Based Dynamics", SCA 2020.
  [M14] M. Macklin, M. Müller, N. Chentanez, T.-Y. Kim, "Unified Particle Physics for Real-Time Applications",
        SIGGRAPH 2014 (Jacobi iterations with constraint averaging and over-relaxation ω).
  [D18] C. Deul, T. Kugelstadt, M. Weiler, J. Bender, "Direct Position-Based Solver for Stiff Rods", CGF 2018.
  [T20] the thesis "Physical Experiments in School with Unity: Cable Simulation", Mainz 2020 (``shared/seeds``).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numba

__all__ = ["Chain", "Contacts", "run_substeps", "run_substeps_flat", "run_steps_flat", "step_margin", "begin_substep",
           "iterate", "end_substep", "xpbd_multiplier", "stretch_step", "stretch_step_sqrt", "stretch_sweep",
           "curvature_sweep", "clamp_sweep", "contact_sweep", "self_contact_sweep", "direct_solve",
           "banded_ldlt_solve", "FP", "IP", "LIM"]

_jit = numba.njit(cache=True, error_model="numpy")
_inline = numba.njit(cache=True, error_model="numpy", inline="always")

# Indices into Chain.fp (floats) and Chain.ip (integers): named, so that driver and kernels agree.
FP = dict(h=0, damp=1, gx=2, gy=3, gz=4, alpha_s=5, alpha_b=6, alpha_c=7, k_s=8, k_b=9, k_c=10, inv_l0sq=11,
          omega=12, radius=13)
IP = dict(iterations=0, order=1, bending=2, sqrt=3, bandwidth=4, direct_all=5)
# Indices into run_steps_flat's ``lim`` (floats): step (s), divergence limits (m, m/s), the contact query's terms.
LIM = dict(dt=0, max_distance=1, max_speed=2, contact_margin=3, fall=4, radius=5)
N_FP = len(FP)
N_IP = len(IP)
_F_H, _F_DAMP, _F_GX, _F_GY, _F_GZ = 0, 1, 2, 3, 4
_F_ALPHA_S, _F_ALPHA_B, _F_ALPHA_C, _F_K_S, _F_K_B, _F_K_C = 5, 6, 7, 8, 9, 10
_F_INV_L0SQ, _F_OMEGA, _F_RADIUS = 11, 12, 13
_I_ITER, _I_ORDER, _I_BEND, _I_SQRT, _I_BW, _I_DIRECT_ALL = 0, 1, 2, 3, 4, 5
_L_DT, _L_DISTANCE, _L_SPEED, _L_MARGIN, _L_FALL, _L_RADIUS = 0, 1, 2, 3, 4, 5

ORDER_GAUSS_SEIDEL, ORDER_JACOBI, ORDER_DIRECT = 0, 1, 2
BEND_NONE, BEND_CURVATURE, BEND_DISTANCE = 0, 1, 2
ROW_STRETCH, ROW_CURVATURE, ROW_DISTANCE, ROW_CLAMP = 0, 1, 2, 3
PHASE_ALL, PHASE_BEGIN, PHASE_ITERATE, PHASE_END = 0, 1, 2, 3

_TINY_LENGTH = 1e-12  # m: a segment shorter than this has no direction; its projection is skipped
_TINY_SLIP = 1e-15  # m: tangential slip below this needs no friction correction
# Relative compliance added to every row of the direct solve: it keeps hard, redundant rows (e.g. inextensible
# stretch with hard curvature bending: more rows than degrees of freedom) solvable and is far below any physical one.
_DIRECT_REGULARIZATION = 1e-10
# The direct solve's safeguard against a failed linearisation (see direct_solve). A solve is accepted once the
# largest relative residual ρ = |C + α̃ λ| / rest of the distance rows has shrunk by _DIRECT_CONTRACTION (a Newton
# step within its region of convergence shrinks it far more: from about 1e-4 to 3e-9 per substep in the hanging
# cable), or is at most _DIRECT_RESIDUAL_FLOOR: a relative stretch that a solve moving particles across their
# segments leaves in any case (a stiff rod's bending correction of the sag g h² leaves (g h²)² / 2 l₀² ≈ 8e-5 at
# h = 5 ms) and that is harmless, far below a failed linearisation (0.65 in a yank). Else the rows are
# re-linearised and solved again, at most _DIRECT_MAX_SOLVES solves per iteration in all.
_DIRECT_CONTRACTION = 0.5
_DIRECT_RESIDUAL_FLOOR = 1e-4
_DIRECT_MAX_SOLVES = 8

# The solver state, owned by the driver (mjcable.solvers.state) and passed whole to the driver kernels.
Chain = namedtuple("Chain", [
    "x", "v", "x0", "w", "mass", "react", "dx", "count",  # particles (N, 3) / (N,)
    "rest", "lam_s",  # stretch constraint i joins particles i, i+1: rest length (n,), multiplier (n,)
    "rest_d", "lam_d",  # distance bending b joins b, b+2: rest 2 l₀ (n-1,), multiplier (n-1,)
    "lam_b",  # curvature bending at particle b+1: multipliers (n-1, 3)
    "clamp_pq", "clamp_pin", "clamp_dir", "lam_c",  # clamps (K, 2) [pin particle, neighbour], (K,), (K, 2, 3), (K, 2)
    "pin_p", "pin_from", "pin_to", "pin_active", "pin_release", "pin_force",  # pins (P,), (P, 3), ..., (P, 3)
    "row_kind", "row_idx", "row_p", "prow", "pslot", "band", "grad", "rhs",  # direct order: the banded system
    "fp", "ip",  # parameters (N_FP,), (N_IP,)
])
# Contacts found once per step: obstacle contacts and self contacts, re-projected in every substep and iteration.
Contacts = namedtuple("Contacts", [
    "seg", "geo", "lam",  # obstacle contacts: segment (C,), [s, nx, ny, nz, offset, mu] (C, 6), [λn, λt] (C, 2)
    "pair", "sgeo", "slam",  # self contacts: segments (S, 2), [s, t, nx, ny, nz] (S, 5), λ (S,)
])


# ---------------------------------------------------------------------------------------------------------------
# Per-constraint projections: pure scalar functions.


@_inline
def xpbd_multiplier(cval, wsum, alpha_tilde, lam, k):
    """Δλ = k (−C − α̃ λ) / (Σ w |∇C|² + α̃) ([M16] Eq. 18; α̃ = 0 and k: PBD, [T20] Eq. 2.12, [M07])."""
    denom = wsum + alpha_tilde
    if denom == 0.0:
        return 0.0
    return k * (-cval - alpha_tilde * lam) / denom


@_inline
def stretch_step(dx, dy, dz, wsum, rest, alpha_tilde, lam, k):
    """Distance constraint C = |d| − rest, d = xᵢ − xⱼ (thesis Eq. 2.9), ∇ᵢC = d/|d| = −∇ⱼC.

    Returns (σ, Δλ) with σ = Δλ / |d|, so that Δxᵢ = wᵢ σ d and Δxⱼ = −wⱼ σ d ([M16] Eqs. 17–18): one square root
    and one division. With α̃ = 0 and k = 1 it is Jakobsen's mass-weighted stick ([J01]; [T20] Eq. 2.8).
    """
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    denom = wsum + alpha_tilde
    if length < _TINY_LENGTH or denom == 0.0:
        return 0.0, 0.0
    sigma = k * (rest - length - alpha_tilde * lam) / (denom * length)
    return sigma, sigma * length


@_inline
def stretch_step_sqrt(dx, dy, dz, wsum, rest, k):
    """Jakobsen's stick with the square root replaced by its first-order Taylor expansion at the rest length
    ([J01], "Cloth simulation": ``delta *= r²/(delta·delta + r²) − 0.5``), mass-weighted: (|d| − r)/|d| becomes
    (|d|² − r²)/(|d|² + r²), no square root, one division. Returns (σ, Δλ) as :func:`stretch_step`, with
    |d| ≈ (|d|² + r²)/2r for Δλ."""
    if wsum == 0.0:
        return 0.0, 0.0
    d2 = dx * dx + dy * dy + dz * dz
    r2 = rest * rest
    sigma = -k * (d2 - r2) / ((d2 + r2) * wsum)
    return sigma, sigma * 0.5 * (d2 + r2) / rest


# ---------------------------------------------------------------------------------------------------------------
# Sweeps: one call per iteration applies all constraints of one type. Corrections go to ``out`` (``x`` itself for
# Gauss-Seidel, a delta buffer for Jacobi); a held particle (w = 0) collects ∇C Δλ in ``react`` instead.


@_inline
def stretch_sweep(x, out, w, react, rest, gap, alpha_tilde, lam, k, sqrt_approx):
    """Stretch constraints c = 0..len(rest)−1 between particles c and c + ``gap`` (gap 1: the segments; gap 2: the
    thesis's next-neighbour bending stick of rest length 2 l₀, [T20] §3.4.1 Fig. 3.23)."""
    for c in range(rest.shape[0]):
        i = c
        j = c + gap
        dx = x[i, 0] - x[j, 0]
        dy = x[i, 1] - x[j, 1]
        dz = x[i, 2] - x[j, 2]
        wi = w[i]
        wj = w[j]
        if sqrt_approx:
            sigma, dlam = stretch_step_sqrt(dx, dy, dz, wi + wj, rest[c], k)
        else:
            sigma, dlam = stretch_step(dx, dy, dz, wi + wj, rest[c], alpha_tilde, lam[c], k)
        lam[c] += dlam
        if wi > 0.0:
            out[i, 0] += wi * sigma * dx
            out[i, 1] += wi * sigma * dy
            out[i, 2] += wi * sigma * dz
        else:
            react[i, 0] += sigma * dx
            react[i, 1] += sigma * dy
            react[i, 2] += sigma * dz
        if wj > 0.0:
            out[j, 0] -= wj * sigma * dx
            out[j, 1] -= wj * sigma * dy
            out[j, 2] -= wj * sigma * dz
        else:
            react[j, 0] -= sigma * dx
            react[j, 1] -= sigma * dy
            react[j, 2] -= sigma * dz


@_jit
def curvature_sweep(x, out, w, react, inv_l0sq, alpha_tilde, lam, k):
    """Curvature bending at every interior particle i = b + 1: the vector constraint
    C = (x_{i−1} − 2xᵢ + x_{i+1}) / l₀², the discrete curvature of a rod that is straight at rest, with energy
    ½ E·I |C|² l₀, i.e. α = 1 / (E·I·l₀). C is linear in x: its gradient is (1, −2, 1)/l₀² times the identity, so
    the three components decouple and each is one [M16] Eq. 18 update."""
    g2 = inv_l0sq * inv_l0sq
    for b in range(lam.shape[0]):
        i = b + 1
        wa = w[i - 1]
        wb = w[i]
        wc = w[i + 1]
        wsum = (wa + 4.0 * wb + wc) * g2
        for comp in range(3):
            cval = (x[i - 1, comp] - 2.0 * x[i, comp] + x[i + 1, comp]) * inv_l0sq
            dlam = xpbd_multiplier(cval, wsum, alpha_tilde, lam[b, comp], k)
            lam[b, comp] += dlam
            g = inv_l0sq * dlam
            if wa > 0.0:
                out[i - 1, comp] += wa * g
            else:
                react[i - 1, comp] += g
            if wb > 0.0:
                out[i, comp] -= 2.0 * wb * g
            else:
                react[i, comp] -= 2.0 * g
            if wc > 0.0:
                out[i + 1, comp] += wc * g
            else:
                react[i + 1, comp] += g


@_jit
def clamp_sweep(x, out, w, react, clamp_pq, clamp_pin, pin_active, clamp_dir, scale, alpha_tilde, lam, k):
    """Clamps: the tangent at pinned particle p is held along the clamp axis by the finite-difference clamped
    boundary (w'(0) = 0 through a mirrored ghost particle): two scalar constraints C_m = scale · d_m · (x_q − x_p),
    d_m ⟂ axis, scale = 2 / l₀², carrying half a Voronoi cell of bending energy (α = 2 / (E·I·l₀)); α = 0 holds
    the tangent rigidly. A cantilever of n segments then bends as beam theory to O(1/n²), where fixing the
    neighbour particle instead would clamp half a segment further out (2 % stiff at n = 100)."""
    for kc in range(clamp_pq.shape[0]):
        if not pin_active[clamp_pin[kc]]:
            continue
        p = clamp_pq[kc, 0]
        q = clamp_pq[kc, 1]
        wp = w[p]
        wq = w[q]
        wsum = (wp + wq) * scale * scale
        for m in range(2):
            dx = clamp_dir[kc, m, 0]
            dy = clamp_dir[kc, m, 1]
            dz = clamp_dir[kc, m, 2]
            cval = scale * (dx * (x[q, 0] - x[p, 0]) + dy * (x[q, 1] - x[p, 1]) + dz * (x[q, 2] - x[p, 2]))
            dlam = xpbd_multiplier(cval, wsum, alpha_tilde, lam[kc, m], k)
            lam[kc, m] += dlam
            g = scale * dlam
            if wq > 0.0:
                out[q, 0] += wq * g * dx
                out[q, 1] += wq * g * dy
                out[q, 2] += wq * g * dz
            else:
                react[q, 0] += g * dx
                react[q, 1] += g * dy
                react[q, 2] += g * dz
            if wp > 0.0:
                out[p, 0] -= wp * g * dx
                out[p, 1] -= wp * g * dy
                out[p, 2] -= wp * g * dz
            else:
                react[p, 0] -= g * dx
                react[p, 1] -= g * dy
                react[p, 2] -= g * dz


@_inline
def contact_sweep(x, x0, w, react, seg, geo, lam):
    """Contacts of segments (i, i+1) with static obstacles at fraction s along them, each linearised once per step
    as the half-space n·p ≥ offset for the axis point p = (1 − s) xᵢ + s x_{i+1} (offset = n·q + radius, q on the
    obstacle's surface). Both particles move with weights (1 − s, s) as in Jakobsen's segment collision ([J01],
    "c1, c2"), mass-weighted: ∇ᵢC = (1 − s) n, ∇ᵢ₊₁C = s n. Inequality: projected only while C < 0.

    Friction, Coulomb with one μ, positional (the static friction of [M20]'s contact handling): the contact point's tangential slip since the substep
    began is cancelled while the tangential multiplier stays within μ λₙ (static friction); beyond, the correction
    is capped at μ λₙ, i.e. the kinetic friction force μ·N (both forces λ / h²).
    """
    for c in range(seg.shape[0]):
        i = seg[c]
        j = i + 1
        s = geo[c, 0]
        nx, ny, nz = geo[c, 1], geo[c, 2], geo[c, 3]
        a, b = 1.0 - s, s
        wi, wj = w[i], w[j]
        wsum = a * a * wi + b * b * wj
        if wsum == 0.0:
            continue
        px = a * x[i, 0] + b * x[j, 0]
        py = a * x[i, 1] + b * x[j, 1]
        pz = a * x[i, 2] + b * x[j, 2]
        cval = nx * px + ny * py + nz * pz - geo[c, 4]
        if cval < 0.0:
            dlam = -cval / wsum
            lam[c, 0] += dlam
            for p, f, wp in ((i, a, wi), (j, b, wj)):
                if wp > 0.0:
                    x[p, 0] += wp * f * dlam * nx
                    x[p, 1] += wp * f * dlam * ny
                    x[p, 2] += wp * f * dlam * nz
                else:
                    react[p, 0] += f * dlam * nx
                    react[p, 1] += f * dlam * ny
                    react[p, 2] += f * dlam * nz
        mu = geo[c, 5]
        if mu > 0.0 and lam[c, 0] > 0.0:
            sx = a * (x[i, 0] - x0[i, 0]) + b * (x[j, 0] - x0[j, 0])
            sy = a * (x[i, 1] - x0[i, 1]) + b * (x[j, 1] - x0[j, 1])
            sz = a * (x[i, 2] - x0[i, 2]) + b * (x[j, 2] - x0[j, 2])
            sn = sx * nx + sy * ny + sz * nz
            tx, ty, tz = sx - sn * nx, sy - sn * ny, sz - sn * nz
            slip = math.sqrt(tx * tx + ty * ty + tz * tz)
            budget = mu * lam[c, 0] - lam[c, 1]
            if slip > _TINY_SLIP and budget > 0.0:
                dlam_t = min(slip / wsum, budget)
                lam[c, 1] += dlam_t
                g = -dlam_t / slip
                for p, f, wp in ((i, a, wi), (j, b, wj)):
                    if wp > 0.0:
                        x[p, 0] += wp * f * g * tx
                        x[p, 1] += wp * f * g * ty
                        x[p, 2] += wp * f * g * tz
                    else:
                        react[p, 0] += f * g * tx
                        react[p, 1] += f * g * ty
                        react[p, 2] += f * g * tz


@_jit
def self_contact_sweep(x, w, react, pair, sgeo, gap, lam):
    """Self contacts of non-adjacent segments (i, i+1) and (j, j+1) at fractions s, t, linearised once per step
    with the unit normal n from segment j to segment i: C = n·(pᵢ − pⱼ) − gap ≥ 0, gap = 2 · radius. Frictionless;
    the four particles move with Jakobsen's segment weights ([J01]; the pairwise scheme of [T20] §4.2)."""
    for c in range(pair.shape[0]):
        i = pair[c, 0]
        j = pair[c, 1]
        s, t = sgeo[c, 0], sgeo[c, 1]
        nx, ny, nz = sgeo[c, 2], sgeo[c, 3], sgeo[c, 4]
        a0, a1, b0, b1 = 1.0 - s, s, -(1.0 - t), -t
        wsum = a0 * a0 * w[i] + a1 * a1 * w[i + 1] + b0 * b0 * w[j] + b1 * b1 * w[j + 1]
        if wsum == 0.0:
            continue
        cval = -gap
        cval += nx * (a0 * x[i, 0] + a1 * x[i + 1, 0] + b0 * x[j, 0] + b1 * x[j + 1, 0])
        cval += ny * (a0 * x[i, 1] + a1 * x[i + 1, 1] + b0 * x[j, 1] + b1 * x[j + 1, 1])
        cval += nz * (a0 * x[i, 2] + a1 * x[i + 1, 2] + b0 * x[j, 2] + b1 * x[j + 1, 2])
        if cval >= 0.0:
            continue
        dlam = -cval / wsum
        lam[c] += dlam
        for p, f in ((i, a0), (i + 1, a1), (j, b0), (j + 1, b1)):
            wp = w[p]
            if wp > 0.0:
                x[p, 0] += wp * f * dlam * nx
                x[p, 1] += wp * f * dlam * ny
                x[p, 2] += wp * f * dlam * nz
            else:
                react[p, 0] += f * dlam * nx
                react[p, 1] += f * dlam * ny
                react[p, 2] += f * dlam * nz


# ---------------------------------------------------------------------------------------------------------------
# The direct order: all chain constraints at once.


@_jit
def banded_ldlt_solve(band, rhs, bw):
    """Solve A y = rhs in place for a symmetric positive definite A in lower band storage band[i, i − j] = A[i, j]
    (half-bandwidth ``bw``), by LDLᵀ without pivoting, O(rows · bw²); ``band`` is overwritten by the factors.
    For bw = 1 (a chain of stretch constraints) this is the Thomas algorithm."""
    nrow = rhs.shape[0]
    for j in range(nrow):  # band[j, 0] ← d_j, band[i, i − j] ← L_ij
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
def _direct_linearise(S, alpha_s_t, alpha_b_t, alpha_c_t):
    """Linearise every row at the current x: ∇C into ``grad``, −C − α̃ λ into ``rhs`` and J W Jᵀ + α̃ into
    ``band`` ([M16] Eq. 18 for all rows at once). Returns ρ = max |C + α̃ λ| / rest over the distance rows."""
    x, w = S.x, S.w
    band, rhs, grad, row_p = S.band, S.rhs, S.grad, S.row_p
    row_kind, row_idx = S.row_kind, S.row_idx
    lam_s, lam_d, lam_b, lam_c = S.lam_s, S.lam_d, S.lam_b, S.lam_c
    rest, rest_d = S.rest, S.rest_d
    clamp_dir, clamp_pin, pin_active = S.clamp_dir, S.clamp_pin, S.pin_active
    inv_l0sq = S.fp[_F_INV_L0SQ]
    nrow = rhs.shape[0]
    band[:] = 0.0
    grad[:] = 0.0
    rho = 0.0
    for r in range(nrow):  # C, ∇C and α̃ of every row
        kind = row_kind[r]
        idx = row_idx[r]
        cval = 0.0
        lam = 0.0
        at = alpha_b_t
        if kind == ROW_STRETCH or kind == ROW_DISTANCE:
            i, j = row_p[r, 0], row_p[r, 1]
            dx, dy, dz = x[i, 0] - x[j, 0], x[i, 1] - x[j, 1], x[i, 2] - x[j, 2]
            length = math.sqrt(dx * dx + dy * dy + dz * dz)
            if kind == ROW_STRETCH:
                at = alpha_s_t
                lam = lam_s[idx]
                rl = rest[idx]
            else:
                lam = lam_d[idx]
                rl = rest_d[idx]
            cval = length - rl
            if length > _TINY_LENGTH:
                grad[r, 0, 0], grad[r, 0, 1], grad[r, 0, 2] = dx / length, dy / length, dz / length
                grad[r, 1, 0], grad[r, 1, 1], grad[r, 1, 2] = -dx / length, -dy / length, -dz / length
            else:
                cval = 0.0
            rho = max(rho, abs(cval + at * lam) / rl)
        elif kind == ROW_CURVATURE:
            b, comp = idx // 3, idx % 3
            i = b + 1
            lam = lam_b[b, comp]
            cval = (x[i - 1, comp] - 2.0 * x[i, comp] + x[i + 1, comp]) * inv_l0sq
            grad[r, 0, comp], grad[r, 1, comp], grad[r, 2, comp] = inv_l0sq, -2.0 * inv_l0sq, inv_l0sq
        else:  # ROW_CLAMP
            at = alpha_c_t
            kc, m = idx // 2, idx % 2
            if pin_active[clamp_pin[kc]]:
                p, q = row_p[r, 0], row_p[r, 1]
                lam = lam_c[kc, m]
                scale = 2.0 * inv_l0sq
                for comp in range(3):
                    d = scale * clamp_dir[kc, m, comp]
                    grad[r, 0, comp] = -d
                    grad[r, 1, comp] = d
                    cval += d * (x[q, comp] - x[p, comp])
            else:
                at = 0.0
        band[r, 0] = at
        rhs[r] = -cval - at * lam
    prow, pslot = S.prow, S.pslot
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
    for r in range(nrow):
        if band[r, 0] == 0.0:  # a hard row on held particles only (or a released clamp): Δλ = 0
            band[r, 0] = 1.0
            rhs[r] = 0.0
        else:
            band[r, 0] *= 1.0 + _DIRECT_REGULARIZATION
    return rho


@_inline
def _direct_apply(S, k_s, k_b, k_c):
    """λ += k Δλ and x += W Jᵀ k Δλ ([M16] Eq. 17) for the Δλ that :func:`banded_ldlt_solve` left in ``rhs``."""
    x, w, react, grad, row_p, rhs = S.x, S.w, S.react, S.grad, S.row_p, S.rhs
    row_kind, row_idx = S.row_kind, S.row_idx
    lam_s, lam_d, lam_b, lam_c = S.lam_s, S.lam_d, S.lam_b, S.lam_c
    for r in range(rhs.shape[0]):
        kind = row_kind[r]
        idx = row_idx[r]
        if kind == ROW_STRETCH:
            dlam = k_s * rhs[r]
            lam_s[idx] += dlam
        elif kind == ROW_DISTANCE:
            dlam = k_b * rhs[r]
            lam_d[idx] += dlam
        elif kind == ROW_CURVATURE:
            dlam = k_b * rhs[r]
            lam_b[idx // 3, idx % 3] += dlam
        else:
            dlam = k_c * rhs[r]
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
def _distance_rows_within(x, rest, gap, alpha_tilde, lam, tol):
    """Whether every distance constraint C = |xᵢ − xᵢ₊gap| − rest (thesis Eq. 2.9) has |C + α̃ λ| ≤ tol · rest, the
    XPBD residual ([M16] Eq. 18's numerator) that a converged solve drives to zero. Without a square root or a
    division: with the target length t = rest − α̃ λ and margin e = tol · rest, |d| − t ∈ [−e, e] iff
    |d|² ≤ (t + e)² and |d|² ≥ (t − e)² (the latter always true when t ≤ e)."""
    for c in range(rest.shape[0]):
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
def _direct_within(S, alpha_s_t, alpha_b_t, tol):
    """Whether the direct solve's distance rows (stretch, and distance bending if solved) have relative residuals
    |C + α̃ λ| / rest ≤ tol."""
    if not _distance_rows_within(S.x, S.rest, 1, alpha_s_t, S.lam_s, tol):
        return False
    if S.ip[_I_DIRECT_ALL] and S.ip[_I_BEND] == BEND_DISTANCE:
        return _distance_rows_within(S.x, S.rest_d, 2, alpha_b_t, S.lam_d, tol)
    return True


@_jit
def direct_solve(S, alpha_s_t, alpha_b_t, alpha_c_t, k_s, k_b, k_c):
    """One direct iteration over all chain constraints (stretch, bending, clamps) at once: the linearised XPBD
    system (J W Jᵀ + α̃) Δλ = −C − α̃ λ ([M16]'s linearised system with its g term dropped, as there) is banded
    for a chain and is solved exactly by :func:`banded_ldlt_solve` ([D18]); Δx = W Jᵀ Δλ. With stretch rows only
    it is tridiagonal. A single iteration then gives XPBD's stated stiffness; PBD and Jakobsen scale Δλ by their k.

    A safeguard for large rotations within a substep. The curvature and clamp rows are linear in x, so the solve
    meets them exactly; the distance rows (stretch, distance bending; C = |d| − rest) are not: a segment whose end
    moves across it by Δd⊥ stretches by |Δd⊥|² / 2|d|, which the linearisation misses. Moving a light particle
    across a straight neighbour costs nothing to first order, so when a gripper yanks the end of a straight cable
    (20 m/s at dt = 2 ms, 4 substeps) the solve flings the next particle sideways and leaves the cable more
    stretched than before (largest strain 45 % → 65 %); the positions carry this as velocity, and the cable blows
    up. So the relative residual of the distance rows, ρ = max |C + α̃ λ| / rest, before the solve (ρ₀, from the
    linearisation) is compared with its value after (one pass over the distance rows, without a square root):

    * ρ ≤ max(ρ_floor, (1 − k (1 − κ)) ρ₀), κ = ``_DIRECT_CONTRACTION``, ρ_floor = ``_DIRECT_RESIDUAL_FLOOR``:
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
    rho0 = _direct_linearise(S, alpha_s_t, alpha_b_t, alpha_c_t)
    banded_ldlt_solve(S.band, S.rhs, S.ip[_I_BW])
    _direct_apply(S, k_s, k_b, k_c)
    tol = max(_DIRECT_RESIDUAL_FLOOR, (1.0 - k_s * (1.0 - _DIRECT_CONTRACTION)) * rho0)
    if not _direct_within(S, alpha_s_t, alpha_b_t, tol):
        _direct_relinearise(S, alpha_s_t, alpha_b_t, alpha_c_t, k_s, k_b, k_c, rho0, tol)


@_jit
def _direct_relinearise(S, alpha_s_t, alpha_b_t, alpha_c_t, k_s, k_b, k_c, rho0, tol):
    """The safeguard of :func:`direct_solve` after a rejected solve: further Newton steps (re-linearised solves)
    until every relative residual is within ``tol``, at most ``_DIRECT_MAX_SOLVES`` solves in all; then, if some
    is still above ρ₀, one Gauss-Seidel sweep of the same rows ([M16] Eq. 18 per constraint)."""
    for _ in range(_DIRECT_MAX_SOLVES - 1):
        _direct_linearise(S, alpha_s_t, alpha_b_t, alpha_c_t)
        banded_ldlt_solve(S.band, S.rhs, S.ip[_I_BW])
        _direct_apply(S, k_s, k_b, k_c)
        if _direct_within(S, alpha_s_t, alpha_b_t, tol):
            return
    if not _direct_within(S, alpha_s_t, alpha_b_t, rho0):  # Newton diverging: project the rows one by one
        x = S.x
        stretch_sweep(x, x, S.w, S.react, S.rest, 1, alpha_s_t, S.lam_s, k_s, S.ip[_I_SQRT] != 0)
        if S.ip[_I_DIRECT_ALL] and (S.ip[_I_BEND] != BEND_NONE or S.clamp_pq.shape[0] > 0):
            _bend_clamp_sweeps(S, x, alpha_b_t, alpha_c_t, k_b, k_c)


# ---------------------------------------------------------------------------------------------------------------
# The substep: predict, iterate, update velocities.


@_inline
def begin_substep(S, C, sub, n_sub):
    """Predict (semi-implicit Euler in velocity form: v ← e^{−c h} v + h g, x ← x + h v; Verlet is the same
    recurrence with v read as (x − x_prev)/h, [T20] Eq. 2.7 with Jakobsen's damping), move held particles to their
    pin targets (interpolated linearly across the step), reset multipliers (every substep, [M16] Algorithm 1) and reactions."""
    fp = S.fp
    h, damp = fp[_F_H], fp[_F_DAMP]
    gx, gy, gz = fp[_F_GX], fp[_F_GY], fp[_F_GZ]
    x, v, x0, w, react = S.x, S.v, S.x0, S.w, S.react
    for p in range(x.shape[0]):
        x0[p, 0] = x[p, 0]
        x0[p, 1] = x[p, 1]
        x0[p, 2] = x[p, 2]
        react[p, 0] = 0.0
        react[p, 1] = 0.0
        react[p, 2] = 0.0
        if w[p] > 0.0:
            # damping multiplies the velocity before gravity is added: it never changes a static equilibrium
            v[p, 0] = damp * v[p, 0] + h * gx
            v[p, 1] = damp * v[p, 1] + h * gy
            v[p, 2] = damp * v[p, 2] + h * gz
            x[p, 0] += h * v[p, 0]
            x[p, 1] += h * v[p, 1]
            x[p, 2] += h * v[p, 2]
    frac = (sub + 1.0) / n_sub
    pin_from, pin_to = S.pin_from, S.pin_to
    for k in range(S.pin_p.shape[0]):
        if S.pin_active[k]:
            p = S.pin_p[k]
            for comp in range(3):
                x[p, comp] = pin_from[k, comp] + frac * (pin_to[k, comp] - pin_from[k, comp])
    S.lam_s[:] = 0.0
    S.lam_d[:] = 0.0
    S.lam_b[:] = 0.0
    S.lam_c[:] = 0.0
    C.lam[:] = 0.0
    C.slam[:] = 0.0


@_jit
def _bend_clamp_sweeps(S, out, at_b, at_c, k_b, k_c):
    """Bending and clamp sweeps, corrections into ``out``."""
    x, w, react, fp = S.x, S.w, S.react, S.fp
    bending = S.ip[_I_BEND]
    if bending == BEND_CURVATURE:
        curvature_sweep(x, out, w, react, fp[_F_INV_L0SQ], at_b, S.lam_b, k_b)
    elif bending == BEND_DISTANCE:
        stretch_sweep(x, out, w, react, S.rest_d, 2, at_b, S.lam_d, k_b, False)
    if S.clamp_pq.shape[0]:
        clamp_sweep(x, out, w, react, S.clamp_pq, S.clamp_pin, S.pin_active, S.clamp_dir, 2.0 * fp[_F_INV_L0SQ],
                    at_c, S.lam_c, k_c)


@_jit
def _jacobi_counts(S):
    """Number of active chain constraints on each particle (Jacobi constraint averaging, [M14])."""
    cnt = S.count
    cnt[:] = 0.0
    n = S.rest.shape[0]
    for i in range(n):
        cnt[i] += 1.0
        cnt[i + 1] += 1.0
    bending = S.ip[_I_BEND]
    if bending == BEND_CURVATURE:
        for b in range(n - 1):
            cnt[b] += 1.0
            cnt[b + 1] += 1.0
            cnt[b + 2] += 1.0
    elif bending == BEND_DISTANCE:
        for b in range(n - 1):
            cnt[b] += 1.0
            cnt[b + 2] += 1.0
    for kc in range(S.clamp_pq.shape[0]):
        if S.pin_active[S.clamp_pin[kc]]:
            cnt[S.clamp_pq[kc, 0]] += 1.0
            cnt[S.clamp_pq[kc, 1]] += 1.0


@_inline
def iterate(S, C):
    """One constraint iteration in the configured order; contacts are projected sequentially last, so that they
    hold exactly when the iteration ends."""
    fp = S.fp
    h2 = fp[_F_H] * fp[_F_H]
    at_s, at_b, at_c = fp[_F_ALPHA_S] / h2, fp[_F_ALPHA_B] / h2, fp[_F_ALPHA_C] / h2
    k_s, k_b, k_c = fp[_F_K_S], fp[_F_K_B], fp[_F_K_C]
    order = S.ip[_I_ORDER]
    x, w = S.x, S.w
    bend_or_clamp = S.ip[_I_BEND] != BEND_NONE or S.clamp_pq.shape[0] > 0
    if order == ORDER_DIRECT:
        direct_solve(S, at_s, at_b, at_c, k_s, k_b, k_c)
        if not S.ip[_I_DIRECT_ALL] and bend_or_clamp:  # PBD/Jakobsen: only the stretch chain is solved directly
            _bend_clamp_sweeps(S, x, at_b, at_c, k_b, k_c)
    elif order == ORDER_JACOBI:
        dx = S.dx
        dx[:] = 0.0
        stretch_sweep(x, dx, w, S.react, S.rest, 1, at_s, S.lam_s, k_s, S.ip[_I_SQRT] != 0)
        if bend_or_clamp:
            _bend_clamp_sweeps(S, dx, at_b, at_c, k_b, k_c)
        _jacobi_counts(S)
        omega = fp[_F_OMEGA]
        cnt = S.count
        for p in range(x.shape[0]):
            if cnt[p] > 0.0 and w[p] > 0.0:
                f = omega / cnt[p]
                x[p, 0] += f * dx[p, 0]
                x[p, 1] += f * dx[p, 1]
                x[p, 2] += f * dx[p, 2]
    else:
        stretch_sweep(x, x, w, S.react, S.rest, 1, at_s, S.lam_s, k_s, S.ip[_I_SQRT] != 0)
        if bend_or_clamp:  # a call passing S costs microseconds: skip it when there is nothing to do
            _bend_clamp_sweeps(S, x, at_b, at_c, k_b, k_c)
    if C.seg.shape[0]:
        contact_sweep(x, S.x0, w, S.react, C.seg, C.geo, C.lam)
    if C.pair.shape[0]:
        self_contact_sweep(x, w, S.react, C.pair, C.sgeo, 2.0 * fp[_F_RADIUS], C.slam)


@_inline
def end_substep(S):
    """v = (x − x₀)/h; pin forces from the reactions, F = −Σ ∇C λ / h² − m g (the force that holds the particle,
    [M16]'s force estimate); sockets whose force exceeds their release force let go (with their clamp). Returns the number
    released."""
    fp = S.fp
    inv_h = 1.0 / fp[_F_H]
    inv_h2 = inv_h * inv_h
    x, v, x0 = S.x, S.v, S.x0
    for p in range(x.shape[0]):
        v[p, 0] = (x[p, 0] - x0[p, 0]) * inv_h
        v[p, 1] = (x[p, 1] - x0[p, 1]) * inv_h
        v[p, 2] = (x[p, 2] - x0[p, 2]) * inv_h
    released = 0
    for k in range(S.pin_p.shape[0]):
        if not S.pin_active[k]:
            continue
        p = S.pin_p[k]
        m = S.mass[p]
        fx = -S.react[p, 0] * inv_h2 - m * fp[_F_GX]
        fy = -S.react[p, 1] * inv_h2 - m * fp[_F_GY]
        fz = -S.react[p, 2] * inv_h2 - m * fp[_F_GZ]
        S.pin_force[k, 0], S.pin_force[k, 1], S.pin_force[k, 2] = fx, fy, fz
        if math.sqrt(fx * fx + fy * fy + fz * fz) > S.pin_release[k]:
            S.pin_active[k] = False
            S.w[p] = 1.0 / m
            released += 1
    return released


@_inline
def run_substeps(S, C, n_sub, phase, sub):
    """Substeps of ``iterations`` iterations each. Returns (all positions and velocities finite, number of sockets
    released).

    ``phase`` ``PHASE_ALL`` runs ``n_sub`` whole substeps (``sub`` ignored); the other phases run one piece of
    substep ``sub`` of ``n_sub``, so that a Python caller (PBD's user constraints) can act between iterations
    without a second compiled entry point: ``PHASE_BEGIN`` (predict), ``PHASE_ITERATE`` (one iteration),
    ``PHASE_END`` (velocities and pins)."""
    released = 0
    iterations = S.ip[_I_ITER] if phase == PHASE_ALL else 1
    first, last = (0, n_sub) if phase == PHASE_ALL else (sub, sub + 1)
    for k in range(first, last):
        if phase == PHASE_ALL or phase == PHASE_BEGIN:
            begin_substep(S, C, k, n_sub)
        if phase == PHASE_ALL or phase == PHASE_ITERATE:
            for _ in range(iterations):
                iterate(S, C)
        if phase == PHASE_ALL or phase == PHASE_END:
            released += end_substep(S)
    finite = True
    x, v = S.x, S.v
    for p in range(x.shape[0]):
        for comp in range(3):
            if not (math.isfinite(x[p, comp]) and math.isfinite(v[p, comp])):
                finite = False
    return finite, released


@_jit
def run_substeps_flat(x, v, x0, w, mass, react, dx, count, rest, lam_s, rest_d, lam_d, lam_b, clamp_pq, clamp_pin,
                      clamp_dir, lam_c, pin_p, pin_from, pin_to, pin_active, pin_release, pin_force, row_kind,
                      row_idx, row_p, prow, pslot, band, grad, rhs, fp, ip, seg, geo, lam, pair, sgeo, slam, n_sub,
                      phase, sub):
    """:func:`run_substeps` with the state's arrays as separate arguments (``*chain, *contacts, n_sub, phase,
    sub``): numba types plain array arguments in C but a named tuple of 40 arrays in Python (about 25 µs a call)."""
    S = Chain(x, v, x0, w, mass, react, dx, count, rest, lam_s, rest_d, lam_d, lam_b, clamp_pq, clamp_pin,
              clamp_dir, lam_c, pin_p, pin_from, pin_to, pin_active, pin_release, pin_force, row_kind, row_idx,
              row_p, prow, pslot, band, grad, rhs, fp, ip)
    C = Contacts(seg, geo, lam, pair, sgeo, slam)
    return run_substeps(S, C, n_sub, phase, sub)


# ---------------------------------------------------------------------------------------------------------------
# Whole steps: the Simulator's steps without returning to Python while nothing needs it.


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


@_inline
def touches_obstacles(x, reach, box_lo, box_hi, plane_n, plane_p):
    """Whether the bounding box of particles ``x`` (N, 3), grown by ``reach`` metres, touches an obstacle: a world
    bounding box (``box_lo``, ``box_hi`` (B, 3)) or the solid side of a plane (unit normal ``plane_n``, point
    ``plane_p`` (F, 3)). The step driver and :meth:`mjcable.solvers.contacts.ObstacleContacts.touching` share it."""
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
def _step_checks(x, v, prev, lim):
    """(x, v finite; runaway: |coordinate| > lim[max_distance] or |x − prev| / dt > lim[max_speed]), as Simulator."""
    far, top, bad = 0.0, 0.0, 0.0  # bad: NaN once any x or v is non-finite (z − z), without a branch
    for p in range(x.shape[0]):
        d2 = 0.0
        for comp in range(3):
            bad += (x[p, comp] - x[p, comp]) + (v[p, comp] - v[p, comp])
            far = max(far, abs(x[p, comp]))
            d = x[p, comp] - prev[p, comp]
            d2 += d * d
        top = max(top, d2)
    return bad == 0.0, far > lim[_L_DISTANCE] or math.sqrt(top) / lim[_L_DT] > lim[_L_SPEED]


@_jit
def run_steps_flat(x, v, x0, w, mass, react, dx, count, rest, lam_s, rest_d, lam_d, lam_b, clamp_pq, clamp_pin,
                   clamp_dir, lam_c, pin_p, pin_from, pin_to, pin_active, pin_release, pin_force, row_kind, row_idx,
                   row_p, prow, pslot, band, grad, rhs, fp, ip, seg, geo, lam, pair, sgeo, slam, n_sub, n_steps, solo,
                   lim, box_lo, box_hi, plane_n, plane_p, prev, rows, out_x, out_v, clock):
    """Up to ``n_steps`` whole steps of ``n_sub`` substeps (:func:`run_substeps`) in one call (``*chain,
    *contacts, n_sub, n_steps, ...``); the first step uses the given contacts, the later ones none. After each
    step, as the Python step: the pins' start moves to their target (a gripper move spreads over one step),
    ``clock[0] += lim[dt]`` (``mj_data.time``), x and v go to ``out_x[r]``, ``out_v[r]`` (R, N, 3) when the
    step's number in this call is ``rows[r]`` (ascending). Returns (steps taken, finite, sockets released, stopped
    by a check, rows stored), early:

    * after a step whose state is non-finite or runs away (:func:`_step_checks`; ``prev`` (N, 3) holds the
      positions before it), so that the caller raises naming that step;
    * before a step whose reach (:func:`step_margin` + ``lim[radius]``) touches an obstacle (``box_lo``, ``box_hi``,
      ``plane_n``, ``plane_p``: empty for none), or any step after the first if ``solo`` (self-collision): the
      caller queries its contacts."""
    S = Chain(x, v, x0, w, mass, react, dx, count, rest, lam_s, rest_d, lam_d, lam_b, clamp_pq, clamp_pin,
              clamp_dir, lam_c, pin_p, pin_from, pin_to, pin_active, pin_release, pin_force, row_kind, row_idx,
              row_p, prow, pslot, band, grad, rhs, fp, ip)
    given = Contacts(seg, geo, lam, pair, sgeo, slam)
    none = Contacts(seg[:0], geo[:0], lam[:0], pair[:0], sgeo[:0], slam[:0])
    obstacles = box_lo.shape[0] + plane_n.shape[0] > 0
    released, stored = 0, 0
    for k in range(n_steps):
        if k > 0 and (solo or (obstacles and touches_obstacles(
                x, step_margin(v, lim[_L_MARGIN], lim[_L_DT], lim[_L_FALL]) + lim[_L_RADIUS], box_lo, box_hi,
                plane_n, plane_p))):
            return k, True, released, False, stored
        C = given if k == 0 else none
        for p in range(x.shape[0]):  # (explicit copies: faster than slice assignments here)
            prev[p, 0], prev[p, 1], prev[p, 2] = x[p, 0], x[p, 1], x[p, 2]
        for sub in range(n_sub):  # run_substeps(S, C, n_sub, PHASE_ALL, 0), its finite check below
            begin_substep(S, C, sub, n_sub)
            for _ in range(ip[_I_ITER]):
                iterate(S, C)
            released += end_substep(S)
        for q in range(pin_to.shape[0]):
            pin_from[q, 0], pin_from[q, 1], pin_from[q, 2] = pin_to[q, 0], pin_to[q, 1], pin_to[q, 2]
        clock[0] += lim[_L_DT]
        if stored < rows.shape[0] and rows[stored] == k + 1:
            out_x[stored, :, :] = x
            out_v[stored, :, :] = v
            stored += 1
        finite, runaway = _step_checks(x, v, prev, lim)
        if not finite or runaway:
            return k + 1, finite, released, True, stored
    return n_steps, True, released, False, stored
