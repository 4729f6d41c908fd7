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

**Projection.** A pair's contact, found once per step and renewed at the pair's closest points before every sweep
(:func:`_remeasure`), with the unit normal n from segment j to segment i, is
C = n·(pᵢ − pⱼ) − (rᵢ + rⱼ) ≥ 0 (each segment's cable's radius) with the four particles moving with Jakobsen's segment weights ([J01]; the pairwise scheme of
the thesis, §4.2): a speculative contact, so that a segment found within the step's travel cannot pass through the
other within the step. One pass over the pairs leaves depth where many of them compete (a cable whipping round
another): a sweep whose projections removed more than ``par.impact_speed`` · h (a strike, not a resting contact's
g h²) projects the normals again, without friction, until they hold within ``par.impact_tol``, at most
``par.impact_iterations`` times, so that the sweep ends with its contacts held.

**Friction.** Coulomb friction, capped at μ λₙ (kinetic beyond), with μ the larger of the two cables' coefficients
(the stickier surface decides, as MuJoCo's default of the larger geom friction): between two cables against an
anchor kept across substeps and steps (:func:`_anchored_friction`: the two material points that touched are held
together, so that a rope resting on a cable does not creep), in a cone of the normal load pooled over the contacts
on the contact's particles in the last sweep (:func:`_pooled_load`: a Gauss-Seidel sweep splits a particle's load
unevenly between its contacts, as it does on obstacles, :mod:`mjcable.solvers.contact_kernels`); within one cable on
the relative tangential slip of the two axis points since the substep began ([M20]'s static friction).

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
from mjcable.solvers.kernels_layout import _TINY_LENGTH, _TINY_SLIP, ANCHOR_COLUMNS, POOL_COLUMN

__all__ = ["segment_closest", "find_self_contacts", "self_contacts", "self_contact_sweep"]

_PARALLEL = 1e-12  # relative sin² below which two segments count as parallel
# m: the tangential offset a capped friction correction of two cables' contact may leave before its anchor moves
# (_anchored_friction): a substep's normal load scatters between a wrap's contacts, and one capped for a substep need
# not slide (docs/measurements.md, 2026-11-27)
ANCHOR_SLACK = 1e-3


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
def find_self_contacts(x, reach, near, pair, st, normal, chains, own, joined_p):
    """Pairs of segments whose axes are closer than ``reach`` metres: of one chain c (with ``own``) at least
    ``near[c]`` (>= 2) apart (j − i ≥ near[c]), of different chains any (``chains`` (C, 2): each cable's segments
    [first, stop)), none closer through a junction than the larger of the two chains' ``near`` (``joined_p`` (M, 2):
    the pairs of particles that junctions make one point); each pair once, i < j. Fills ``pair``
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
                for j in range(i + near[ci] if cj == ci else chains[cj, 0], chains[cj, 1]):
                    if (lo[i, 0] > hi[j, 0] + reach or lo[j, 0] > hi[i, 0] + reach or lo[i, 1] > hi[j, 1] + reach
                            or lo[j, 1] > hi[i, 1] + reach or lo[i, 2] > hi[j, 2] + reach
                            or lo[j, 2] > hi[i, 2] + reach):
                        continue
                    if joined_p.shape[0] and _joined(i, j, ci, cj, chains, joined_p, max(near[ci], near[cj])):
                        continue
                    count = _take_pair(x, reach, i, j, pair, st, normal, count)
                    if count < 0:
                        return -1
    return count


@_inline
def _closest_points(x, i, j):
    """The closest points of segments (i, i+1) and (j, j+1) of ``x`` ([E05] §5.1.9): their fractions (s, t), the
    vector d = pᵢ(s) − pⱼ(t) between them (three floats, m) and its length |d| (m)."""
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
    return s, t, d0, d1, d2, math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


@_inline
def _take_pair(x, reach, i, j, pair, st, normal, count):
    """Segments i and j into row ``count`` of the buffers if their axes are closer than ``reach`` (see
    :func:`find_self_contacts`). Returns the new count, or −1 if the buffers are full."""
    s, t, d0, d1, d2, dist = _closest_points(x, i, j)
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
    other apart and stretch the cable (each cable's ``near`` in ``cable_par``)."""
    P = S.par[0]
    near = np.empty(S.cable_par.shape[0], dtype=np.int64)
    for c in range(near.shape[0]):
        near[c] = S.cable_par[c].near
    args = (S.chain_seg, P.self_collision, S.joined_p)
    held = min(P.n_self, S.self_pair.shape[0]) if P.cable_contact else 0  # the last step's pairs, for their anchors
    last = (S.self_pair[:held].copy(), S.self_anchor[:held].copy(), S.self_lam_n[:held].copy())
    count = find_self_contacts(S.x, reach, near, S.self_pair, S.self_st, S.self_normal, *args)
    while count < 0:
        cap = max(2 * S.self_pair.shape[0], 1)
        S.self_pair = np.zeros((cap, 2), dtype=np.int64)
        S.self_st = np.zeros((cap, 2))
        S.self_normal = np.zeros((cap, 3))
        S.self_lam_n = np.zeros(cap)
        S.self_lam_t = np.zeros(cap)
        S.self_anchor = np.zeros((cap, ANCHOR_COLUMNS))
        count = find_self_contacts(S.x, reach, near, S.self_pair, S.self_st, S.self_normal, *args)
    if P.cable_contact:
        _keep_anchors(S, count, last)
    return count


@_inline
def _keep_anchors(S, count, last):
    """The friction anchors of the ``count`` pairs just found: a pair of two cables that the last step held too and
    that pressed in its last substep keeps its anchor (``last``: the last step's pairs, anchors and normal
    multipliers), every other starts at its closest points. Both lists are in :func:`find_self_contacts`' order,
    ascending (i, j): one merge pass."""
    pair, anchor, seg_cable = S.self_pair, S.self_anchor, S.seg_cable
    old_pair, old_anchor, old_lam = last
    k = 0
    for c in range(count):
        i, j = pair[c, 0], pair[c, 1]
        while k < old_pair.shape[0] and (old_pair[k, 0] < i or (old_pair[k, 0] == i and old_pair[k, 1] < j)):
            k += 1
        if (k < old_pair.shape[0] and old_pair[k, 0] == i and old_pair[k, 1] == j and old_lam[k] >= 0.0
                and seg_cable[i] != seg_cable[j]):
            for col in range(ANCHOR_COLUMNS):
                anchor[c, col] = old_anchor[k, col]
        else:
            _anchor_at(S, c)
            anchor[c, POOL_COLUMN] = 0.0


@_inline
def _remeasure(x, i, j, st, normal, c):
    """Pair ``c``'s closest points (``st[c]``) and normal (``normal[c]``) from segments i and j as they are now
    ([E05] §5.1.9, as the query): a chord turning on the other cable within a step, or a knot's loop running round
    the strand through it as it tightens (metres per second), keeps its contact where the two touch (as an obstacle
    contact's point on a round shape, :func:`mjcable.solvers.contact_kernels.contact_sweep`; kept at the query's
    points, the knot's segments met elsewhere, ``docs/measurements.md``). A pair that would turn its normal against the
    query's (the segments passed each other) keeps its last points and normal, so that the sweep pushes it back
    rather than through: the contact stays speculative."""
    s, t, d0, d1, d2, dist = _closest_points(x, i, j)
    if dist < _TINY_LENGTH or d0 * normal[c, 0] + d1 * normal[c, 1] + d2 * normal[c, 2] <= 0.0:
        return
    st[c, 0], st[c, 1] = s, t
    normal[c, 0], normal[c, 1], normal[c, 2] = d0 / dist, d1 / dist, d2 / dist


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
    (i, i+1) and (j, j+1) (``self_pair``) at fractions s, t (``self_st``) and the unit normal n from segment j to
    segment i (``self_normal``), found once per step and renewed before each projection (:func:`_remeasure`):
    C = n·(pᵢ − pⱼ) − gap ≥ 0, gap = rᵢ + rⱼ (the segments' cables' radii, ``seg_radius``), the four particles moving with Jakobsen's segment weights ([J01];
    the pairwise scheme of the thesis, §4.2). Coulomb friction μ (the larger of the two cables', ``cable_mu``):
    between two cables against the pair's anchor (:func:`_anchored_friction`) in a cone of the normal load pooled
    over the contacts on its particles in the last sweep (:func:`_pooled_load`; renewed when this sweep ends,
    :func:`_pool_loads`), within one on the relative tangential slip of the two axis points since
    the substep began ([M20]'s static friction, capped at μ λₙ: kinetic beyond), each right after the pair's normal.
    Multipliers ``self_lam_n``, ``self_lam_t``."""
    P = S.par[0]
    x, x0, w, react, seg_cable, cable_mu = S.x, S.x0, S.w, S.react, S.seg_cable, S.cable_mu
    pair, st, normal, lam_n, lam_t = S.self_pair, S.self_st, S.self_normal, S.self_lam_n, S.self_lam_t
    deepest = 0.0  # the most depth one projection removed
    for c in range(P.n_self):
        i = pair[c, 0]
        j = pair[c, 1]
        mu = max(cable_mu[seg_cable[i]], cable_mu[seg_cable[j]])
        wsum, removed = _project_normal(S, c)
        deepest = max(deepest, removed)
        if wsum == 0.0 or mu <= 0.0 or lam_n[c] <= 0.0:
            continue
        s, t = st[c, 0], st[c, 1]
        nx, ny, nz = normal[c, 0], normal[c, 1], normal[c, 2]
        a0, a1, b0, b1 = 1.0 - s, s, -(1.0 - t), -t
        weights = (a0, a1, b0, b1)
        if seg_cable[i] != seg_cable[j]:  # two cables: friction holds the anchored material points together
            cone = lam_n[c]  # pooled over the last sweep's contacts, where this one pressed in it too
            if S.self_anchor[c, POOL_COLUMN] > 0.0:
                cone = _pooled_load(S.cable_load, i, j, s, t, cone)
            _anchored_friction(S, c, mu * cone - lam_t[c], nx, ny, nz)
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
    if P.cable_contact:
        _pool_loads(S)
    if deepest > P.impact_speed * P.h:  # struck: the normals again until they hold (the module docstring)
        for _ in range(P.impact_iterations):
            removed = 0.0
            for c in range(P.n_self):
                removed = max(removed, _project_normal(S, c)[1])
            if removed <= P.impact_tol:
                break


@_inline
def _project_normal(S, c):
    """Contact ``c``'s normal projection at the pair's closest points now (:func:`_remeasure`), C = n·(pᵢ − pⱼ) − gap
    ≥ 0, gap = rᵢ + rⱼ, adding to ``self_lam_n[c]``. Returns (Σ w ∇C², 0 where both segments are held and nothing is done; the
    depth it removed, m)."""
    x, w, react, pair, st, normal = S.x, S.w, S.react, S.self_pair, S.self_st, S.self_normal
    i, j = pair[c, 0], pair[c, 1]
    _remeasure(x, i, j, st, normal, c)
    s, t = st[c, 0], st[c, 1]
    nx, ny, nz = normal[c, 0], normal[c, 1], normal[c, 2]
    a0, a1, b0, b1 = 1.0 - s, s, -(1.0 - t), -t
    wsum = a0 * a0 * w[i] + a1 * a1 * w[i + 1] + b0 * b0 * w[j] + b1 * b1 * w[j + 1]
    if wsum == 0.0:
        return 0.0, 0.0
    cval = -(S.seg_radius[i] + S.seg_radius[j])
    cval += nx * (a0 * x[i, 0] + a1 * x[i + 1, 0] + b0 * x[j, 0] + b1 * x[j + 1, 0])
    cval += ny * (a0 * x[i, 1] + a1 * x[i + 1, 1] + b0 * x[j, 1] + b1 * x[j + 1, 1])
    cval += nz * (a0 * x[i, 2] + a1 * x[i + 1, 2] + b0 * x[j, 2] + b1 * x[j + 1, 2])
    if cval >= 0.0:
        return wsum, 0.0
    dlam = -cval / wsum
    S.self_lam_n[c] += dlam
    _move_pair(x, w, react, i, j, (a0, a1, b0, b1), dlam, (nx, ny, nz))
    return wsum, -cval


@_jit
def _pool_loads(S):
    """At the end of a sweep: the particles' sums ``cable_load`` (N, 2), Σ share · λₙ and Σ share over their
    pressing contacts with other cables (shares (1 − s, s) and (1 − t, t)), and each such contact's λₙ in column
    ``POOL_COLUMN`` of ``self_anchor``: the next sweep's cones (:func:`_pooled_load`)."""
    pair, st, lam_n, seg_cable, load, anchor = (S.self_pair, S.self_st, S.self_lam_n, S.seg_cable, S.cable_load,
                                                S.self_anchor)
    load[:, :] = 0.0
    for c in range(S.par[0].n_self):
        i, j = pair[c, 0], pair[c, 1]
        if seg_cable[i] == seg_cable[j]:
            continue
        anchor[c, POOL_COLUMN] = max(lam_n[c], 0.0)
        if lam_n[c] <= 0.0:
            continue
        s, t = st[c, 0], st[c, 1]
        for p, f in ((i, 1.0 - s), (i + 1, s), (j, 1.0 - t), (j + 1, t)):
            load[p, 0] += f * lam_n[c]
            load[p, 1] += f


@_inline
def _pooled_load(load, i, j, s, t, own):
    """kg·m: the normal load of Coulomb's cone of a pressing contact of segments i and j at fractions s, t between
    two cables: the mean λₙ of the contacts on its particles, weighted by the particles' shares ((1 − s, s) on
    segment i, (1 − t, t) on j; ``load`` (N, 2), :func:`_pool_loads`), on the cable whose particles there carry the
    fewer contacts (both cables' mean on a tie).

    A Gauss-Seidel sweep splits the normal load of a particle between its two contacts unevenly (the first
    projected takes the most, its neighbour the rest: big and small in turn along a wrap), while the particle's sum
    is exact; a cone of the contact's own λₙ then lets the small ones slide while the big ones hold
    (``docs/measurements.md``). Along a chain of contacts this mean is ¼ λ_{c−1} + ½ λ_c + ¼ λ_{c+1}, which removes
    the alternation and keeps the sum and a steady change of the load along the wrap. On the other cable a particle
    can carry the whole wrap (a rope across a cable touches one or two of its segments with every chord), whose mean
    would be the wrap's, not the contact's. The sums are the last sweep's (the last iteration's, or the last
    substep's: friction follows each contact's normal in the sweep), and a contact that did not press in it has its
    own λₙ (``own``; a contact that just began to press would take its neighbours' loads), as has one whose point
    moved onto a particle without loads since (a fraction from 0 to 1)."""
    wa = (1.0 - s) * load[i, 1] + s * load[i + 1, 1]
    wb = (1.0 - t) * load[j, 1] + t * load[j + 1, 1]
    if wa <= 0.0 or wb <= 0.0:
        return own
    la = ((1.0 - s) * load[i, 0] + s * load[i + 1, 0]) / wa
    lb = ((1.0 - t) * load[j, 0] + t * load[j + 1, 0]) / wb
    if wa < wb:
        return la
    if wb < wa:
        return lb
    return 0.5 * (la + lb)


@_inline
def _anchored_friction(S, c, budget, nx, ny, nz):
    """Coulomb friction of contact ``c`` between two cables against its anchor (``self_anchor[c]``: the fractions
    s_a, t_a of the points on segments i and j that touched, and the unit normal n_a then): a chain of particles
    does not spin, so a cable's surface point there moves with its axis point, and the two surfaces hold together
    while p_i(s_a) − p_j(t_a) stays (r_i + r_j) n_a. Friction moves the two axis points to remove the tangential
    part (to the current normal n) of the offset p_i(s_a) − p_j(t_a) − (r_i + r_j) n_a, across substeps and steps
    ([M20]'s static friction against a kept anchor, as the obstacle contacts' anchors): the offset of a rope turning
    about a cable's axis too, which the closest points alone would not see. Δλ_t is at most ``budget`` (μ λₙ less what
    this substep's iterations applied); beyond it the surfaces slide (kinetic friction) and the anchor moves to the
    pair's closest points and normal now. Adds to ``self_lam_t[c]``."""
    x, w, react, pair, anchor = S.x, S.w, S.react, S.self_pair, S.self_anchor
    if budget <= 0.0:
        return
    i, j = pair[c, 0], pair[c, 1]
    sa, ta = anchor[c, 0], anchor[c, 1]
    gap = S.seg_radius[i] + S.seg_radius[j]
    a0, a1, b0, b1 = 1.0 - sa, sa, -(1.0 - ta), -ta
    wsum = a0 * a0 * w[i] + a1 * a1 * w[i + 1] + b0 * b0 * w[j] + b1 * b1 * w[j + 1]
    if wsum == 0.0:
        return
    dx = a0 * x[i, 0] + a1 * x[i + 1, 0] + b0 * x[j, 0] + b1 * x[j + 1, 0] - gap * anchor[c, 2]
    dy = a0 * x[i, 1] + a1 * x[i + 1, 1] + b0 * x[j, 1] + b1 * x[j + 1, 1] - gap * anchor[c, 3]
    dz = a0 * x[i, 2] + a1 * x[i + 1, 2] + b0 * x[j, 2] + b1 * x[j + 1, 2] - gap * anchor[c, 4]
    dn = dx * nx + dy * ny + dz * nz
    tx, ty, tz = dx - dn * nx, dy - dn * ny, dz - dn * nz
    slip = math.sqrt(tx * tx + ty * ty + tz * tz)
    if slip <= _TINY_SLIP:
        return
    dlam = min(slip / wsum, budget)
    S.self_lam_t[c] += dlam
    _move_pair(x, w, react, i, j, (a0, a1, b0, b1), -dlam / slip, (tx, ty, tz))
    if slip - dlam * wsum > ANCHOR_SLACK:  # they slid: the anchor moves to where they touch now
        _anchor_at(S, c)


@_inline
def _anchor_at(S, c):
    """Contact ``c``'s anchor at its closest points and normal (``self_st[c]``, ``self_normal[c]``)."""
    anchor, st, normal = S.self_anchor, S.self_st, S.self_normal
    anchor[c, 0], anchor[c, 1] = st[c, 0], st[c, 1]
    anchor[c, 2], anchor[c, 3], anchor[c, 4] = normal[c, 0], normal[c, 1], normal[c, 2]
