"""Rings of the particle solvers, ``@njit`` (cached, see :mod:`mjcable.solvers._kernel_cache`): a cable sliding
through a pinhole at the ring's centre, with Coulomb friction on its rim (Obi Rope's pinholes).

The ring's centre c is a hub particle of the state after the cables' (``ring_p``), held by a pin row: a world pin
(w_c = 0: it collects the ring's reaction in ``react``, so the pin's force is the ring's force on the cable) or a
body pin's coupling to the user's world (:mod:`mjcable.solvers.host_kernels`: w_c the body's inverse mass along
``ring_dir``, the body feels the pull). The ring holds the material point s = i + t of its cable (segment i =
``ring_seg``, fraction t = ``ring_t``) at c. While it does, segment i's own stretch constraint is off (its rest length
negated, ``rest[i] = −l₀``) and two constraints on (xᵢ, c, xᵢ₊₁) replace it, with a = |xᵢ − c|, b = |xᵢ₊₁ − c|, unit
vectors uₐ = (xᵢ − c) / a, u_b = (xᵢ₊₁ − c) / b:

* the length through the ring, C_Σ = a + b − l₀ (∇ᵢ = uₐ, ∇ᵢ₊₁ = u_b, ∇_c = −(uₐ + u_b)): the cable's two parts
  meet at c, the kink at c itself (not at a particle, as a point held on a straight segment would put it, where
  the segment turns into a lever about c). Alone it is the frictionless ring, an ideal pulley of zero radius: one
  multiplier, one tension T̄ = −λ_Σ / h² on both sides, and the material slides freely (t = a / (a + b));
* the material point, C_Δ = (a − b) − (2t − 1) l₀ (∇ᵢ = uₐ, ∇ᵢ₊₁ = −u_b, ∇_c = u_b − uₐ), with t the anchor held
  through the substep: its multiplier λ_Δ is half the tension jump across the ring, T₁ − T₂ = −2 λ_Δ / h² (T₁ on
  the side of xᵢ). Each [M16] Eq. 18 update, with the segment's compliance α and factor k; λ_Σ is the segment's
  own multiplier ``lam_s[i]``, λ_Δ ``ring_lam``. In the Gauss-Seidel and Jacobi orders both are projected after
  the chains and junctions in every iteration (a ring between heavy loads converges slowly so: the Simulator warns);
  the direct order solves a frictionless ring's C_Σ as the segment's row of its banded solve, with the loads
  (:mod:`mjcable.solvers.ring_direct_kernels`); with friction it projects both after the solve (C_Δ converges
  against the loads only beside C_Σ: ``docs/measurements.md``).

Friction (the capstan law for a point ring). A cable turning by θ through the ring, tensions T₁ and T₂ either side
along unit tangents t₁ (arriving) and t₂ (leaving), pulls the ring with F = T₁ t₁ − T₂ t₂ (the ring's force on it is
−F). With b̂ = (t₁ + t₂) / |t₁ + t₂| and n̂ = (t₁ − t₂) / |t₁ − t₂| (|t₁ ± t₂| = 2 cos(θ/2), 2 sin(θ/2)):
F = (T₁ − T₂) cos(θ/2) b̂ + (T₁ + T₂) sin(θ/2) n̂, so the ring's normal force is F_n = 2 T̄ sin(θ/2),
T̄ = (T₁ + T₂) / 2.
The force that drives the slide is the tension jump F_t = T₁ − T₂ (the work of a slide δs is (T₁ − T₂) δs; at θ = π
none of it is in F, which is why it is not read off F). A rope over a rim holds while T₁ / T₂ ≤ e^{μθ} (Euler's
capstan law), i.e. (T₁ − T₂) / (T₁ + T₂) ≤ (e^{μθ} − 1) / (e^{μθ} + 1) = tanh(μθ/2):

    |F_t| ≤ tanh(μθ/2) (T₁ + T₂) = μ_eff F_n,   μ_eff = tanh(μθ/2) / sin(θ/2),

Coulomb's law on the ring's own normal force with the effective coefficient μ_eff (→ μ as θ → 0: a cable barely
turned rubs with F_n = T θ). In multipliers (F_n = −2 λ_Σ sin(θ/2) / h², F_t = −2 λ_Δ / h²) the bound is
|λ_Δ| ≤ tanh(μθ/2) max(−λ_Σ, 0), exact at θ = π where μ_eff F_n stays finite. Each iteration projects C_Δ and clamps
λ_Δ to it (the substep's accumulated multipliers, as contact friction's cone); the ring sticks while the clamp
leaves λ_Δ inside (the anchor t stays), and slides once it reaches the bound: the anchor then moves to where the
cable passes c (t = a / (a + b)) at the substep's end, as friction anchors do. θ is the turn of the chords from the
particle :data:`TURN_SEGMENTS` before the ring to c and from c to the one as far after it. μ = 0 projects no C_Δ.

Passing. A particle that C_Σ's correction would carry through the centre (b + w_{i+1} Δλ < 0, likewise a) is
stopped on it (Δλ = −b / w_{i+1}): at b = 0 the ring on segment i (t = 1) and on segment i + 1 (t = 0) are the same
constraints, so the ring moves on without a jolt (segment i an ordinary one again, its length a = l₀); in the
direct order a particle that the solve or the prediction carries through a frictionless ring passes and turns onto
its new arm (:mod:`mjcable.solvers.ring_direct_kernels`). A cable end that reaches the centre slips out
(``RING_LET_GO``: for good); the stop particle does not pass (``RING_STOPPED``: the ring holds it at c, the hard
vector constraint x_q = c, as a junction holds its particles). (A test of the ring's plane instead misfires where the
cable turns by π: its particles near the ring lie in that plane.)

References:
  [M16] M. Macklin, M. Müller, N. Chentanez, "XPBD: Position-Based Simulation of Compliant Constrained
        Dynamics", MIG 2016.
  [O] Obi Rope (Virtual Method), pinhole constraints: a rope sliding through a point, with friction.

The substep's entry points (:func:`ring_begin`, :func:`ring_sweep`, :func:`ring_end`) and the small helpers they
repeat are compiled once and called, not inlined (less for the step loop to compile); a scene without rings skips
them (:mod:`mjcable.solvers.kernels`).
"""

from __future__ import annotations

import math

from mjcable.solvers._kernel_cache import inline as _inline, jit as _jit
from mjcable.solvers.constraint_kernels import push, xpbd_multiplier
from mjcable.solvers.kernels_layout import _TINY_LENGTH, ORDER_DIRECT, RING_LET_GO, RING_SLIDING, RING_STOPPED

__all__ = ["ring_begin", "ring_sweep", "ring_end", "TURN_SEGMENTS"]

TURN_SEGMENTS = 3  # segments either side of a ring over which its turn θ is measured (chords)
_SLID = 1e-9  # relative: a multiplier this close to the friction bound reached it (the ring slid)


@_jit
def _arm(x, p, c):
    """(length, unit vector) from particle ``c`` to particle ``p`` of ``x`` (0 and a zero vector when shorter than
    ``_TINY_LENGTH``)."""
    dx, dy, dz = x[p, 0] - x[c, 0], x[p, 1] - x[c, 1], x[p, 2] - x[c, 2]
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    if length < _TINY_LENGTH:
        return 0.0, 0.0, 0.0, 0.0
    return length, dx / length, dy / length, dz / length


@_jit
def _turn(S, r, i):
    """rad: the cable's turn θ through ring ``r`` holding segment ``i``: the angle between the chord from the particle
    :data:`TURN_SEGMENTS` before it (or the cable's first) to the centre and the chord from the centre to the one
    as far after it (or the last)."""
    x, c = S.x, S.ring_p[r]
    first, stop = S.chain_seg[S.ring_cable[r], 0], S.chain_seg[S.ring_cable[r], 1]
    la, ax, ay, az = _arm(x, max(first, i - TURN_SEGMENTS), c)
    lb, bx, by, bz = _arm(x, min(stop, i + 1 + TURN_SEGMENTS), c)
    if la == 0.0 or lb == 0.0:
        return 0.0
    cos_turn = -(ax * bx + ay * by + az * bz)  # t₁ · t₂ with t₁ = −(chord to the earlier particle)
    return math.acos(min(1.0, max(-1.0, cos_turn)))


@_jit
def ring_begin(S):
    """A substep's start: the rings' material-point multipliers zeroed."""
    S.ring_lam[:] = 0.0


@_inline
def _slide(S, r, alpha_tilde, k):
    """Ring ``r`` (sliding): C_Σ (unless the direct order's solve holds it, frictionless:
    :mod:`mjcable.solvers.ring_direct_kernels`), then (μ > 0) C_Δ with λ_Δ clamped to the capstan bound (module
    docstring). A particle that C_Σ's correction would carry through the centre stops on it and passes
    (:func:`_pass`)."""
    if (S.par[0].order != ORDER_DIRECT or S.ring_mu[r] > 0.0) and _slide_length(S, r, alpha_tilde, k):
        return
    _slide_friction(S, r, alpha_tilde, k)


@_inline
def _slide_length(S, r, alpha_tilde, k):
    """C_Σ of ring ``r``: one projection, a particle it would carry through the centre stopped on it (:func:`_pass`).
    Returns whether one passed."""
    x, w, react, rest, lam_s = S.x, S.w, S.react, S.rest, S.lam_s
    i, c = S.ring_seg[r], S.ring_p[r]
    j = i + 1
    l0 = -rest[i]
    la, ax, ay, az = _arm(x, i, c)
    lb, bx, by, bz = _arm(x, j, c)
    if la == 0.0 and lb == 0.0:
        return False
    wi, wj, wc = w[i], w[j], w[c]
    nx, ny, nz = ax + bx, ay + by, az + bz
    wsum = (wi if la > 0.0 else 0.0) + (wj if lb > 0.0 else 0.0) + wc * (nx * nx + ny * ny + nz * nz)
    dlam = xpbd_multiplier(la + lb - l0, wsum, alpha_tilde, lam_s[i], k)
    step = 0
    if wj > 0.0 and lb > 0.0 and lb + wj * dlam < 0.0:  # x_j reaches the centre
        dlam, step = -lb / wj, 1
    if wi > 0.0 and la > 0.0 and la + wi * dlam < 0.0:  # x_i does, first
        dlam, step = -la / wi, -1
    lam_s[i] += dlam
    push(x, react, w[i], i, ax * dlam, ay * dlam, az * dlam)
    push(x, react, w[j], j, bx * dlam, by * dlam, bz * dlam)
    push(x, react, w[c], c, -nx * dlam, -ny * dlam, -nz * dlam)
    norm = math.sqrt(nx * nx + ny * ny + nz * nz)
    if norm > _TINY_LENGTH:
        S.ring_dir[r, 0], S.ring_dir[r, 1], S.ring_dir[r, 2] = nx / norm, ny / norm, nz / norm
    if step != 0:
        _pass(S, r, step)
        return True
    return False


@_inline
def _slide_friction(S, r, alpha_tilde, k):
    """C_Δ of ring ``r`` with λ_Δ clamped to the capstan bound (μ > 0), else its anchor follows the cable."""
    x, w, react, rest, lam_s = S.x, S.w, S.react, S.rest, S.lam_s
    i, c = S.ring_seg[r], S.ring_p[r]
    j = i + 1
    l0 = -rest[i]
    wi, wj, wc = w[i], w[j], w[c]
    mu = S.ring_mu[r]
    if mu == 0.0:
        _follow(S, r)
        return
    la, ax, ay, az = _arm(x, i, c)
    lb, bx, by, bz = _arm(x, j, c)
    if la == 0.0 or lb == 0.0:
        return
    bound = math.tanh(0.5 * mu * _turn(S, r, i)) * max(-lam_s[i], 0.0)
    dx, dy, dz = ax - bx, ay - by, az - bz
    cval = (la - lb) - (2.0 * S.ring_t[r] - 1.0) * l0
    lam = S.ring_lam
    dlam = xpbd_multiplier(cval, wi + wj + wc * (dx * dx + dy * dy + dz * dz), alpha_tilde, lam[r], k)
    dlam = min(bound, max(-bound, lam[r] + dlam)) - lam[r]
    if wi > 0.0 and la + wi * dlam < 0.0:  # (no particle through the centre: it stops on it)
        dlam = -la / wi
    if wj > 0.0 and lb - wj * dlam < 0.0:
        dlam = lb / wj
    lam[r] += dlam
    push(x, react, w[i], i, ax * dlam, ay * dlam, az * dlam)
    push(x, react, w[j], j, -bx * dlam, -by * dlam, -bz * dlam)
    push(x, react, w[c], c, -dx * dlam, -dy * dlam, -dz * dlam)


@_jit
def _follow(S, r):
    """Ring ``r``'s anchor where the cable passes its centre now, t = a / (a + b) on its segment."""
    i, c = S.ring_seg[r], S.ring_p[r]
    la = _arm(S.x, i, c)[0]
    lb = _arm(S.x, i + 1, c)[0]
    if la + lb > 0.0:
        S.ring_t[r] = la / (la + lb)


@_inline
def _release(S, r, mode):
    """Ring ``r`` stops sliding (``mode``: let go, or holding its stop): its segment an ordinary one again."""
    i = S.ring_seg[r]
    S.rest[i] = -S.rest[i]
    S.ring_seg[r] = -1
    S.ring_mode[r] = mode


@_inline
def _pass(S, r, step):
    """The particle of ring ``r``'s segment ahead (``step`` = 1: x_{i+1}) or behind (−1: xᵢ) reached the centre: the
    ring moves on to the next segment (t = 0) or the previous one (t = 1), both constraint sets then the same; it
    lets go of a cable end, and holds its stop particle."""
    i = S.ring_seg[r]
    q = i + 1 if step > 0 else i
    cable = S.ring_cable[r]
    if q == S.ring_stop[r]:
        _release(S, r, RING_STOPPED)
    elif q == (S.chain_seg[cable, 1] if step > 0 else S.chain_seg[cable, 0]):
        _release(S, r, RING_LET_GO)
    else:
        S.rest[i] = -S.rest[i]
        S.rest[i + step] = -S.rest[i + step]
        S.ring_seg[r] = i + step
        S.ring_t[r] = 0.0 if step > 0 else 1.0


@_inline
def _hold_stop(S, r):
    """Ring ``r`` holds its stop particle q at its centre c: C = x_q − x_c = 0, per component Δλ = −C / (w_q + w_c)."""
    x, w, react, q, c = S.x, S.w, S.react, S.ring_stop[r], S.ring_p[r]
    wsum = w[q] + w[c]
    if wsum == 0.0:
        return
    for comp in range(3):
        dlam = (x[c, comp] - x[q, comp]) / wsum
        if w[q] > 0.0:
            x[q, comp] += w[q] * dlam
        else:
            react[q, comp] += dlam
        if w[c] > 0.0:
            x[c, comp] -= w[c] * dlam
        else:
            react[c, comp] -= dlam


@_jit
def ring_sweep(S):
    """Project every ring once (after the chains and junctions of an iteration; module docstring)."""
    for r in range(S.ring_p.shape[0]):
        mode = S.ring_mode[r]
        if mode == RING_SLIDING:
            cp = S.cable_par[S.ring_cable[r]]  # the stretch of the cable through it
            _slide(S, r, cp.at_s, cp.k_s)
        elif mode == RING_STOPPED:
            _hold_stop(S, r)


@_jit
def ring_end(S):
    """A substep's end: each sliding ring's length multiplier kept (``ring_tension``: the next substep's first direct
    solve's geometric stiffness, :mod:`mjcable.solvers.ring_direct_kernels`); a ring with friction whose λ_Δ reached
    the capstan bound slid: its anchor moves to where the cable passes its centre."""
    for r in range(S.ring_p.shape[0]):
        if S.ring_mode[r] == RING_SLIDING:
            S.ring_tension[r] = S.lam_s[S.ring_seg[r]]
        if S.ring_mode[r] != RING_SLIDING or S.ring_mu[r] == 0.0:
            continue
        i = S.ring_seg[r]
        bound = math.tanh(0.5 * S.ring_mu[r] * _turn(S, r, i)) * max(-S.lam_s[i], 0.0)
        if abs(S.ring_lam[r]) >= bound * (1.0 - _SLID):
            _follow(S, r)

