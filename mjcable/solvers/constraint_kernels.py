"""Constraint projections of the particle solvers, ``@njit`` (cached, see :mod:`mjcable.solvers._kernel_cache`):
one small pure scalar function per constraint type (citing its paper and equation) and one sweep that applies it to
all constraints of that type: stretch, curvature and distance bending, clamps (contacts:
:mod:`mjcable.solvers.contact_kernels`).
References and the shared XPBD formula: :mod:`mjcable.solvers.kernels`. Re-exported by that module.
"""

from __future__ import annotations

import math

from mjcable.solvers._kernel_cache import inline as _inline, jit as _jit
from mjcable.solvers.kernels_layout import _TINY_LENGTH, BEND_CURVATURE, BEND_DISTANCE


@_inline
def push(x, react, wp, p, fx, fy, fz):
    """Particle p moves by wp f; a held particle (wp = 0) also collects f in ``react`` (no else branch: measured
    slower)."""
    x[p, 0] += wp * fx
    x[p, 1] += wp * fy
    x[p, 2] += wp * fz
    if wp == 0.0:
        react[p, 0] += fx
        react[p, 1] += fy
        react[p, 2] += fz


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
def stretch_step_rigid(dx, dy, dz, wsum, rest):
    """:func:`stretch_step` with α̃ = 0 and k = 1 (XPBD with zero compliance; PBD at k = 1; Jakobsen's stick):
    σ = (rest − |d|) / (Σw |d|), Δλ = σ |d|. The same numbers as :func:`stretch_step`'s (there its terms α̃ λ = 0
    and the factor k = 1 are exact for finite λ), with two floating-point operations fewer on the Gauss-Seidel
    sweep's serial chain (each constraint waits for the previous one's correction of their shared particle)."""
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    if length < _TINY_LENGTH or wsum == 0.0:
        return 0.0, 0.0
    sigma = (rest - length) / (wsum * length)
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
# Gauss-Seidel, a delta buffer for Jacobi); a held particle (w = 0) collects ∇C Δλ in ``react`` instead. ``relax``:
# empty for Gauss-Seidel, else Jacobi's ω / count per particle (:func:`jacobi_relax`).


@_jit
def jacobi_relax(S):
    """Jacobi's relaxation into ``S.relax``: ω / count per particle, count the active chain constraints on it
    (stretch, bending, clamps). A constraint takes the smallest of its particles' (:func:`share`): every particle
    then moves by at most ω times the mean of its constraints' corrections ([M14]'s averaging), and
    each constraint's pushes stay equal and opposite (the multiplier it accumulates is the one it applied), so that
    a converged Jacobi iteration reaches the statics of the other orders and a held particle's ``react`` is the
    push its neighbours actually got. (Scaling each particle's summed corrections by its own ω / count instead made
    the pushes on a constraint's two ends unequal: the statics of a chain whose particles weigh count / ω times
    their mass, a hanging chain's pins reporting 1.95 times its weight.)"""
    relax = S.relax
    relax[:] = 0.0
    bending = S.par[0].bending
    chains, cables = S.chain_seg, S.cable_par
    for chain in range(chains.shape[0]):  # each cable's segments [first, stop); the gaps between cables have none
        first, stop = chains[chain, 0], chains[chain, 1]
        for i in range(first, stop):
            relax[i] += 1.0
            relax[i + 1] += 1.0
        if not cables[chain].bends:  # (a limp cable beside bending ones)
            continue
        if bending == BEND_CURVATURE:
            for b in range(first, stop - 1):
                relax[b] += 1.0
                relax[b + 1] += 1.0
                relax[b + 2] += 1.0
        elif bending == BEND_DISTANCE:
            for b in range(first, stop - 1):
                relax[b] += 1.0
                relax[b + 2] += 1.0
    for kc in range(S.clamp_pq.shape[0]):
        if S.pin_active[S.clamp_pin[kc]]:
            relax[S.clamp_pq[kc, 0]] += 1.0
            relax[S.clamp_pq[kc, 1]] += 1.0
    omega = S.par[0].omega
    for p in range(relax.shape[0]):
        relax[p] = omega / relax[p] if relax[p] > 0.0 else 0.0


@_inline
def share(relax, i, j, k):
    """The share of its correction that a constraint on particles i, j, k (repeat one for two) applies: 1 for
    Gauss-Seidel (``relax`` empty), else the smallest ω / count of the three (:func:`jacobi_relax`)."""
    if relax.shape[0] == 0:
        return 1.0
    return min(relax[i], relax[j], relax[k])


@_inline
def stretch_sweep(x, out, w, react, rest, gap, cables, lam, sqrt_approx, relax, chains):
    """Stretch constraints c between particles c and c + ``gap`` within each chain (gap 1: the segments; gap 2: the
    thesis's next-neighbour bending stick of rest length 2 l₀, [T20] §3.4.1 Fig. 3.23): ``chains`` (C, 2) holds
    each cable's segments [first, stop), so c runs from first to stop − gap (the gap segments between cables have
    none; a negative rest length marks a segment that a ring holds: :mod:`~mjcable.solvers.ring_kernels` projects it).
    Each chain's α̃ and k are its cable's (``cables`` (C,) CABLE_PARAMS: the stretch's, or with gap 2 the bending's).
    α̃ = 0 and k = 1 take :func:`stretch_step_rigid`; ``relax`` non-empty: Jacobi's share of each (:func:`share`)."""
    jacobi = relax.shape[0] > 0
    for chain in range(chains.shape[0]):
        if gap == 1:
            alpha_tilde, k = cables[chain].at_s, cables[chain].k_s
        elif not cables[chain].bends:  # a limp cable beside bending ones: no bending stick
            continue
        else:
            alpha_tilde, k = cables[chain].at_b, cables[chain].k_b
        rigid = alpha_tilde == 0.0 and k == 1.0
        for c in range(chains[chain, 0], chains[chain, 1] + 1 - gap):
            if rest[c] < 0.0:  # a segment a ring holds (ring_kernels)
                continue
            i = c
            j = c + gap
            dx = x[i, 0] - x[j, 0]
            dy = x[i, 1] - x[j, 1]
            dz = x[i, 2] - x[j, 2]
            wi = w[i]
            wj = w[j]
            if sqrt_approx:
                sigma, dlam = stretch_step_sqrt(dx, dy, dz, wi + wj, rest[c], k)
            elif rigid:
                sigma, dlam = stretch_step_rigid(dx, dy, dz, wi + wj, rest[c])
            else:
                sigma, dlam = stretch_step(dx, dy, dz, wi + wj, rest[c], alpha_tilde, lam[c], k)
            if jacobi:
                f = share(relax, i, j, j)
                sigma *= f
                dlam *= f
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
def curvature_sweep(x, out, w, react, cables, lam, relax, chains):
    """Curvature bending at every interior particle i = b + 1 of each chain (``chains`` (C, 2): each cable's
    segments [first, stop); its l₀, α̃ and k its cable's, ``cables`` (C,) CABLE_PARAMS): the vector constraint
    C = (x_{i−1} − 2xᵢ + x_{i+1}) / l₀², the discrete curvature of a rod that is straight at rest, with energy
    ½ E·I |C|² l₀, i.e. α = 1 / (E·I·l₀). C is linear in x: its gradient is (1, −2, 1)/l₀² times the identity, so
    the three components decouple and each is one [M16] Eq. 18 update (Jacobi: its :func:`share`)."""
    for chain in range(chains.shape[0]):
        cp = cables[chain]
        if not cp.bends:  # a limp cable beside bending ones
            continue
        inv_l0sq = cp.inv_l0sq
        _curvature_chain(x, out, w, react, inv_l0sq, inv_l0sq * inv_l0sq, cp.at_b, lam, cp.k_b, relax, chains[chain])


@_inline
def _curvature_chain(x, out, w, react, inv_l0sq, g2, alpha_tilde, lam, k, relax, chain):
    """:func:`curvature_sweep` over one chain's interior particles (its segments [first, stop) = ``chain``)."""
    for b in range(chain[0], chain[1] - 1):
        i = b + 1
        wa = w[i - 1]
        wb = w[i]
        wc = w[i + 1]
        wsum = (wa + 4.0 * wb + wc) * g2
        s = share(relax, i - 1, i, i + 1)
        for comp in range(3):
            cval = (x[i - 1, comp] - 2.0 * x[i, comp] + x[i + 1, comp]) * inv_l0sq
            dlam = s * xpbd_multiplier(cval, wsum, alpha_tilde, lam[b, comp], k)
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


@_inline
def body_turn_dot(S, kc, m0, m1, ex, ey, ez):
    """(d_m0 × e)ᵀ W (d_m1 × e) of clamp ``kc`` (e = x_q − x_p, W = ``clamp_wq[kc]`` its body's inverse rotational
    inertia in the world): the body's turn in J W Jᵀ of the clamp's rows m0 and m1 (times scale²)."""
    d, W = S.clamp_dir[kc], S.clamp_wq[kc]
    ax, ay, az = d[m0, 1] * ez - d[m0, 2] * ey, d[m0, 2] * ex - d[m0, 0] * ez, d[m0, 0] * ey - d[m0, 1] * ex
    bx, by, bz = d[m1, 1] * ez - d[m1, 2] * ey, d[m1, 2] * ex - d[m1, 0] * ez, d[m1, 0] * ey - d[m1, 1] * ex
    return (ax * (W[0, 0] * bx + W[0, 1] * by + W[0, 2] * bz) + ay * (W[1, 0] * bx + W[1, 1] * by + W[1, 2] * bz)
            + az * (W[2, 0] * bx + W[2, 1] * by + W[2, 2] * bz))


@_inline
def turns_body(S, kc):
    """Whether clamp ``kc`` is held by a body that turns (its ``clamp_wq`` set by the host: a chain's body clamp)."""
    W = S.clamp_wq[kc]
    return W[0, 0] + W[1, 1] + W[2, 2] > 0.0


@_inline
def body_clamp_turn(S, kc, m, g, ex, ey, ez):
    """A body clamp's share of its row m's correction g = scale Δλ: the body's generalized impulse
    τ = ∇_θ C Δλ = g (d_m × e) (C = scale d_m · e with d_m = R d_local turning with the body, e = x_q − x_p) goes to
    ``clamp_react[kc]`` (the host hands the body τ / h²), and both clamp directions turn by δθ = W τ (Rodrigues)."""
    d, W, react = S.clamp_dir[kc], S.clamp_wq[kc], S.clamp_react[kc]
    tx = g * (d[m, 1] * ez - d[m, 2] * ey)
    ty = g * (d[m, 2] * ex - d[m, 0] * ez)
    tz = g * (d[m, 0] * ey - d[m, 1] * ex)
    react[0] += tx
    react[1] += ty
    react[2] += tz
    rx = W[0, 0] * tx + W[0, 1] * ty + W[0, 2] * tz
    ry = W[1, 0] * tx + W[1, 1] * ty + W[1, 2] * tz
    rz = W[2, 0] * tx + W[2, 1] * ty + W[2, 2] * tz
    angle = math.sqrt(rx * rx + ry * ry + rz * rz)
    if angle == 0.0:
        return
    ux, uy, uz = rx / angle, ry / angle, rz / angle
    c, s = math.cos(angle), math.sin(angle)
    for a in range(2):
        vx, vy, vz = d[a, 0], d[a, 1], d[a, 2]
        along = (ux * vx + uy * vy + uz * vz) * (1.0 - c)
        d[a, 0] = vx * c + (uy * vz - uz * vy) * s + ux * along
        d[a, 1] = vy * c + (uz * vx - ux * vz) * s + uy * along
        d[a, 2] = vz * c + (ux * vy - uy * vx) * s + uz * along


@_jit
def clamp_sweep(S, out, relax):
    """Clamps: the tangent at pinned particle p is held along the clamp axis by the finite-difference clamped
    boundary (w'(0) = 0 through a mirrored ghost particle): two scalar constraints C_m = scale · d_m · (x_q − x_p),
    d_m ⟂ axis, scale = 2 / l₀², carrying half a Voronoi cell of bending energy (α = 2 / (E·I·l₀)); α = 0 holds
    the tangent rigidly. A cantilever of n segments then bends as beam theory to O(1/n²), where fixing the
    neighbour particle instead would clamp half a segment further out (2 % stiff at n = 100). A body clamp's
    directions turn with its body (:func:`body_clamp_turn`: the body's inverse inertia W joins the row's
    Σ w |∇C|², scale² (d_m × e)ᵀ W (d_m × e)), so that the body feels the clamp's moment. l₀, α̃ and k are the
    clamped cable's (``cable_par``). ``relax`` non-empty: Jacobi's :func:`share` of each row, for its particles and
    its body alike."""
    x, w, react, lam, cables, seg_cable = S.x, S.w, S.react, S.lam_c, S.cable_par, S.seg_cable
    clamp_pq, clamp_pin, pin_active, clamp_dir = S.clamp_pq, S.clamp_pin, S.pin_active, S.clamp_dir
    for kc in range(clamp_pq.shape[0]):
        if not pin_active[clamp_pin[kc]]:
            continue
        p = clamp_pq[kc, 0]
        q = clamp_pq[kc, 1]
        cp = cables[seg_cable[min(p, q)]]
        scale, alpha_tilde, k = 2.0 * cp.inv_l0sq, cp.at_c, cp.k_c
        wp = w[p]
        wq = w[q]
        turns = turns_body(S, kc)
        s = share(relax, p, q, q)
        for m in range(2):
            dx = clamp_dir[kc, m, 0]
            dy = clamp_dir[kc, m, 1]
            dz = clamp_dir[kc, m, 2]
            ex, ey, ez = x[q, 0] - x[p, 0], x[q, 1] - x[p, 1], x[q, 2] - x[p, 2]
            wsum = wp + wq
            if turns:
                wsum += body_turn_dot(S, kc, m, m, ex, ey, ez)
            cval = scale * (dx * ex + dy * ey + dz * ez)
            dlam = s * xpbd_multiplier(cval, wsum * scale * scale, alpha_tilde, lam[kc, m], k)
            lam[kc, m] += dlam
            g = scale * dlam
            if turns:
                body_clamp_turn(S, kc, m, g, ex, ey, ez)
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


@_jit
def _bend_clamp_sweeps(S, out, jacobi):
    """Bending and clamp sweeps, corrections into ``out`` (with ``jacobi``, Jacobi's shares: ``S.relax``)."""
    x, w, react = S.x, S.w, S.react
    relax = S.relax if jacobi else S.relax[:0]
    bending = S.par[0].bending
    if bending == BEND_CURVATURE:
        curvature_sweep(x, out, w, react, S.cable_par, S.lam_b, relax, S.chain_seg)
    elif bending == BEND_DISTANCE:
        stretch_sweep(x, out, w, react, S.rest_d, 2, S.cable_par, S.lam_d, False, relax, S.chain_seg)
    if S.clamp_pq.shape[0]:
        clamp_sweep(S, out, relax)
