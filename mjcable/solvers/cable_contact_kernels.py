"""Contacts between cable segments, ``@njit`` (cached, see :mod:`mjcable.solvers._kernel_cache`): a cable's self
contacts (``self_collision``) and the contacts between different cables of one scene (always on), found once per
step (:func:`self_contacts`) and projected in every iteration (:func:`self_contact_sweep`). Re-exported by
:mod:`mjcable.solvers.kernels`.

**Which pairs.** Two segments of one cable touch only with ``self_collision`` and only when they are far enough apart
along the cable that their capsules do not overlap at rest, (j − i − 1) l₀ ≥ 2 r
(:meth:`mjcable.scene.CableSpec.overlapping_neighbours`); segments of different cables always may. A junction makes
two particles one point, so the same rule holds through it: two segments whose path through a junction is shorter
than that never touch (they would push the junction apart). The gap segments between cables in the state
(``seg_cable`` < 0) are no segments.

**Projection.** A pair's contact, linearised once per step with the unit normal n from segment j to segment i, is
C = n·(pᵢ − pⱼ) − 2r ≥ 0 with the four particles moving with Jakobsen's segment weights ([J01]; the pairwise scheme of
the thesis, §4.2): a speculative contact, so that a segment found within the step's travel cannot pass through the
other within the step. Coulomb friction on the relative tangential slip of the two axis points since the substep
began ([M20]'s static friction, capped at μ λₙ: kinetic beyond), with μ the larger of the two cables' coefficients
(the stickier surface decides, as MuJoCo's default of the larger geom friction).

References:
  [E05] C. Ericson, "Real-Time Collision Detection", 2005, §5.1.9 (closest points of two segments).
  [J01] T. Jakobsen, "Advanced Character Physics", GDC 2001 (in ``shared/seeds``).
  [M20] M. Müller, M. Macklin, N. Chentanez, S. Jeschke, T.-Y. Kim, "Detailed Rigid Body Simulation with Extended
        Position Based Dynamics", SCA 2020.
"""

from __future__ import annotations

import math

import numpy as np

from mjcable.solvers._kernel_cache import inline as _inline, jit as _jit, nogil as _nogil
from mjcable.solvers.kernels_layout import _TINY_LENGTH, _TINY_SLIP

__all__ = ["segment_closest", "find_self_contacts", "self_contacts", "self_contact_sweep"]

_PARALLEL = 1e-12  # relative sin² below which two segments count as parallel
_ROUND_OFF = 1e-9  # relative: a radius equal to half a segment up to this does not overlap its neighbours


@_inline
def segment_closest(a, e, f, c, d1d2):
    """Fractions (s, t) of the closest points of two segments P(s) = p₀ + s d₁, Q(t) = q₀ + t d₂ from
    a = d₁·d₁, e = d₂·d₂, f = d₂·r, c = d₁·r, d1d2 = d₁·d₂, r = p₀ − q₀ ([E05] §5.1.9)."""
    denom = a * e - d1d2 * d1d2
    s = 0.0
    if denom > _PARALLEL * a * e:  # not parallel
        s = min(max((d1d2 * f - c * e) / denom, 0.0), 1.0)
    t = (d1d2 * s + f) / e if e > 0.0 else 0.0
    if t < 0.0:
        t = 0.0
        s = min(max(-c / a, 0.0), 1.0) if a > 0.0 else 0.0
    elif t > 1.0:
        t = 1.0
        s = min(max((d1d2 - c) / a, 0.0), 1.0) if a > 0.0 else 0.0
    return s, t


@_inline
def _segments_from(i, p, first, stop):
    """Whole segments between segment i (particles i, i + 1) and particle p, both of the chain whose particles are
    [first, stop] (−1: p is not on it)."""
    if p < first or p > stop:
        return -1
    if p > i + 1:
        return p - i - 1
    if p < i:
        return i - p
    return 0


@_inline
def _joined(i, j, ci, cj, chains, joined_p, first):
    """Whether segments i (of chain ``ci``) and j (of chain ``cj``) lie closer than ``first`` segments apart through a
    junction (``joined_p`` (M, 2): every pair of particles that junctions make one point; ``chains`` (C, 2) each
    cable's segments [first, stop)), which :func:`find_self_contacts` leaves out as it leaves out a chain's near
    neighbours."""
    for k in range(joined_p.shape[0]):
        for end in range(2):
            a, b = joined_p[k, end], joined_p[k, 1 - end]
            da = _segments_from(i, a, chains[ci, 0], chains[ci, 1])
            db = _segments_from(j, b, chains[cj, 0], chains[cj, 1])
            if da >= 0 and db >= 0 and da + db + 1 < first:
                return True
    return False


@_nogil
def find_self_contacts(x, reach, first, pair, st, normal, chains, own, joined_p):
    """Pairs of segments whose axes are closer than ``reach`` metres: of one chain (with ``own``) at least ``first``
    (>= 2) apart (j − i ≥ first), of different chains any (``chains`` (C, 2): each cable's segments [first, stop)),
    none closer than ``first`` through a junction (``joined_p`` (M, 2): the pairs of particles that junctions make
    one point); each pair once, i < j. Fills ``pair``
    (cap, 2), the fractions (s, t) of their closest points into ``st`` (cap, 2) and the unit normal from segment j to
    segment i into ``normal`` (cap, 3).
    Returns the number found, or −1 if more than ``cap`` (the caller grows the buffers and asks again)."""
    nseg = x.shape[0] - 1
    n_chains = chains.shape[0]
    lo = np.empty((nseg, 3))
    hi = np.empty((nseg, 3))
    box = np.empty((n_chains, 6))  # each chain's bounds (lo, hi)
    for ch in range(n_chains):
        for comp in range(3):
            box[ch, comp], box[ch, 3 + comp] = math.inf, -math.inf
        for i in range(chains[ch, 0], chains[ch, 1]):
            for comp in range(3):
                lo[i, comp] = min(x[i, comp], x[i + 1, comp])
                hi[i, comp] = max(x[i, comp], x[i + 1, comp])
                box[ch, comp] = min(box[ch, comp], lo[i, comp])
                box[ch, 3 + comp] = max(box[ch, 3 + comp], hi[i, comp])
    count = 0
    cap = pair.shape[0]
    for ci in range(n_chains):
        for i in range(chains[ci, 0], chains[ci, 1]):
            for cj in range(ci, n_chains):
                if cj == ci and not own:
                    continue
                if (lo[i, 0] > box[cj, 3] + reach or box[cj, 0] > hi[i, 0] + reach or lo[i, 1] > box[cj, 4] + reach
                        or box[cj, 1] > hi[i, 1] + reach or lo[i, 2] > box[cj, 5] + reach
                        or box[cj, 2] > hi[i, 2] + reach):
                    continue
                for j in range(i + first if cj == ci else chains[cj, 0], chains[cj, 1]):
                    if (lo[i, 0] > hi[j, 0] + reach or lo[j, 0] > hi[i, 0] + reach or lo[i, 1] > hi[j, 1] + reach
                            or lo[j, 1] > hi[i, 1] + reach or lo[i, 2] > hi[j, 2] + reach
                            or lo[j, 2] > hi[i, 2] + reach):
                        continue
                    if joined_p.shape[0] and _joined(i, j, ci, cj, chains, joined_p, first):
                        continue
                    count = _take_pair(x, reach, i, j, pair, st, normal, count)
                    if count < 0:
                        return -1
    return count


@_inline
def _take_pair(x, reach, i, j, pair, st, normal, count):
    """Segments i and j into row ``count`` of the buffers if their axes are closer than ``reach`` (see
    :func:`find_self_contacts`). Returns the new count, or −1 if the buffers are full."""
    a = e = f = c = d1d2 = 0.0
    for comp in range(3):
        d1 = x[i + 1, comp] - x[i, comp]
        d2 = x[j + 1, comp] - x[j, comp]
        r = x[i, comp] - x[j, comp]
        a += d1 * d1
        e += d2 * d2
        f += d2 * r
        c += d1 * r
        d1d2 += d1 * d2
    s, t = segment_closest(a, e, f, c, d1d2)
    d0 = (1.0 - s) * x[i, 0] + s * x[i + 1, 0] - (1.0 - t) * x[j, 0] - t * x[j + 1, 0]
    d1 = (1.0 - s) * x[i, 1] + s * x[i + 1, 1] - (1.0 - t) * x[j, 1] - t * x[j + 1, 1]
    d2 = (1.0 - s) * x[i, 2] + s * x[i + 1, 2] - (1.0 - t) * x[j, 2] - t * x[j + 1, 2]
    dist = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    if dist >= reach or dist < _TINY_LENGTH:
        return count
    if count == pair.shape[0]:
        return -1
    pair[count, 0] = i
    pair[count, 1] = j
    st[count, 0] = s
    st[count, 1] = t
    normal[count, 0] = d0 / dist
    normal[count, 1] = d1 / dist
    normal[count, 2] = d2 / dist
    return count + 1


@_jit
def self_contacts(S, reach):
    """The segment pairs of the state's cables closer than ``reach`` metres (:func:`find_self_contacts`: a cable's own
    with ``par.self_collision``, those of different cables always) into ``S.self_pair``, ``S.self_st``,
    ``S.self_normal`` (the buffers, grown together until they hold them all); returns their number. Segments whose
    capsules overlap at rest never touch: those closer along a cable (or through a junction) than the cable's
    diameter, (j − i − 1) l₀ < 2 r (:meth:`mjcable.scene.CableSpec.overlapping_neighbours`), which would push each
    other apart and stretch the cable."""
    P = S.par[0]
    first = int(math.ceil(2.0 * P.radius / S.rest[S.chain_seg[0, 0]] * (1.0 - _ROUND_OFF))) + 1
    first = max(first, 2)
    args = (S.chain_seg, P.self_collision, S.joined_p)
    count = find_self_contacts(S.x, reach, first, S.self_pair, S.self_st, S.self_normal, *args)
    while count < 0:
        cap = max(2 * S.self_pair.shape[0], 1)
        S.self_pair = np.zeros((cap, 2), dtype=np.int64)
        S.self_st = np.zeros((cap, 2))
        S.self_normal = np.zeros((cap, 3))
        S.self_lam_n = np.zeros(cap)
        S.self_lam_t = np.zeros(cap)
        count = find_self_contacts(S.x, reach, first, S.self_pair, S.self_st, S.self_normal, *args)
    return count


@_inline
def _move_pair(x, w, react, i, j, weights, g, v):
    """Δxₚ = wₚ fₚ g v for the four particles of a segment pair, (i, i+1, j, j+1) with ``weights`` (a0, a1, b0, b1),
    ``v`` a vector (3 floats); a held particle collects fₚ g v in ``react``."""
    a0, a1, b0, b1 = weights
    vx, vy, vz = v
    for p, f in ((i, a0), (i + 1, a1), (j, b0), (j + 1, b1)):
        if w[p] > 0.0:
            x[p, 0] += w[p] * f * g * vx
            x[p, 1] += w[p] * f * g * vy
            x[p, 2] += w[p] * f * g * vz
        else:
            react[p, 0] += f * g * vx
            react[p, 1] += f * g * vy
            react[p, 2] += f * g * vz


@_jit
def self_contact_sweep(S):
    """The state's segment contacts (``par.n_self`` of them: a cable's own and those between cables) of segments
    (i, i+1) and (j, j+1) (``self_pair``) at fractions s, t (``self_st``), linearised once per step with the unit
    normal n from segment j to segment i (``self_normal``): C = n·(pᵢ − pⱼ) − gap ≥ 0, gap = 2 · radius, the four
    particles moving with Jakobsen's segment weights ([J01]; the pairwise scheme of the thesis, §4.2). Coulomb
    friction μ (the larger of the two cables', ``cable_mu``) on the relative tangential slip of the two axis points
    since the substep began ([M20]'s static friction, capped at μ λₙ: kinetic beyond). Multipliers ``self_lam_n``,
    ``self_lam_t``."""
    P = S.par[0]
    gap = 2.0 * P.radius
    x, x0, w, react, seg_cable, cable_mu = S.x, S.x0, S.w, S.react, S.seg_cable, S.cable_mu
    pair, st, normal, lam_n, lam_t = S.self_pair, S.self_st, S.self_normal, S.self_lam_n, S.self_lam_t
    for c in range(P.n_self):
        i = pair[c, 0]
        j = pair[c, 1]
        mu = max(cable_mu[seg_cable[i]], cable_mu[seg_cable[j]])
        s, t = st[c, 0], st[c, 1]
        nx, ny, nz = normal[c, 0], normal[c, 1], normal[c, 2]
        a0, a1, b0, b1 = 1.0 - s, s, -(1.0 - t), -t
        weights = (a0, a1, b0, b1)
        wsum = a0 * a0 * w[i] + a1 * a1 * w[i + 1] + b0 * b0 * w[j] + b1 * b1 * w[j + 1]
        if wsum == 0.0:
            continue
        cval = -gap
        cval += nx * (a0 * x[i, 0] + a1 * x[i + 1, 0] + b0 * x[j, 0] + b1 * x[j + 1, 0])
        cval += ny * (a0 * x[i, 1] + a1 * x[i + 1, 1] + b0 * x[j, 1] + b1 * x[j + 1, 1])
        cval += nz * (a0 * x[i, 2] + a1 * x[i + 1, 2] + b0 * x[j, 2] + b1 * x[j + 1, 2])
        if cval < 0.0:
            dlam = -cval / wsum
            lam_n[c] += dlam
            _move_pair(x, w, react, i, j, weights, dlam, (nx, ny, nz))
        if mu <= 0.0 or lam_n[c] <= 0.0:
            continue
        ux = uy = uz = 0.0  # relative slip of the two axis points since the substep began
        for p, f in ((i, a0), (i + 1, a1), (j, b0), (j + 1, b1)):
            ux += f * (x[p, 0] - x0[p, 0])
            uy += f * (x[p, 1] - x0[p, 1])
            uz += f * (x[p, 2] - x0[p, 2])
        un = ux * nx + uy * ny + uz * nz
        tx, ty, tz = ux - un * nx, uy - un * ny, uz - un * nz
        slip = math.sqrt(tx * tx + ty * ty + tz * tz)
        budget = mu * lam_n[c] - lam_t[c]
        if slip <= _TINY_SLIP or budget <= 0.0:
            continue
        dlam_t = min(slip / wsum, budget)
        lam_t[c] += dlam_t
        _move_pair(x, w, react, i, j, weights, -dlam_t / slip, (tx, ty, tz))
