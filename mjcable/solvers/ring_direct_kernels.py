"""A ring's length in the direct order's banded solve, ``@njit`` (cached, see :mod:`mjcable.solvers._kernel_cache`):
called by :mod:`mjcable.solvers.direct_kernels` where a frictionless ring holds a segment (:func:`in_solve`), and
after the substep's prediction (:mod:`mjcable.solvers.ring_kernels` tells the constraint, and projects a ring with
rim friction after the solve).

The length through the ring, C_Σ = a + b − l₀ on (xᵢ, c, xᵢ₊₁), takes the place of its segment's stretch row
(:func:`ring_row`): it touches the same two particles and the hub c no other row, so the band keeps its width, and
the loads at the cable's ends take part in the ring's row within one solve (a projection after the solve moves only
the ring's two light particles, and converges by about m_particle / m_load per iteration: ``docs/measurements.md``).
Three things a linear solve of C_Σ needs that a segment's does not:

* **the arms' geometric stiffness.** C_Σ's Hessian at a particle is (I − u uᵀ) / ℓ (ℓ, u its arm's length and
  direction from c): a short arm turns fast with the particle's sideways motion, and a solve without the term moves
  the particle sideways by about T h² w / ℓ, beyond the arm itself once ℓ < T h² w. The solve takes each arm's
  particle with the mass matrix M̃ = m I + k (I − u uᵀ), k = −λ / ℓ ([T15] Eq. 14: M − λ ∇²C, λ = −T h² the
  length's multiplier), i.e. the inverse mass W̃ = w u uᵀ + w / (1 + w k) (I − u uᵀ): :func:`ring_soften` corrects
  the assembled J W Jᵀ, :func:`ring_soft_move` the particle's move to Δx = W̃ Σ ∇C Δλ. λ is the substep's so far, or
  in its first solve the last substep's (``ring_tension``). A body ring's hub keeps its own share of the Hessian out
  (the solve's matrix changes, not what it converges to).
* **passing in the solve.** A particle that a solve carries through the centre, (x − c) · u < 0 along its arm's
  direction at the linearisation, passes (:func:`ring_crossings`); the solve then met a + (x − c) · u = l₀, so the
  particle's distance d beyond c is its distance along the next arm.
* **turning over.** A passed particle continues along its new arm: it and its substep's start x₀ are turned onto it
  (:func:`_turn_over`), the cable's material turning through the point ring. Left on the far side of its old arm, the
  next linearisation would take it for a longer arm and pull the cable back. A particle that the prediction carries
  through the centre (against its place at the substep's start) passes the same way before the first solve
  (:func:`ring_predicted`).

References:
  [T15] M. Tournier, M. Nesme, B. Gilles, F. Faure, "Stable Constrained Dynamics", ACM TOG 34(4), 2015.
"""

from __future__ import annotations

import math

from mjcable.solvers._kernel_cache import jit as _jit
from mjcable.solvers.chain_solve_kernels import row_step
from mjcable.solvers.kernels_layout import _TINY_LENGTH, RING_SLIDING
from mjcable.solvers.ring_kernels import _arm, _pass

__all__ = ["in_solve", "ring_row", "ring_soften", "ring_soft_move", "ring_crossings", "ring_predicted"]


@_jit
def in_solve(S, r):
    """Whether ring ``r``'s length is a row of the solve: a frictionless ring the cable slides through (a ring with
    rim friction keeps C_Σ beside its C_Δ in its projection after the solve, :mod:`mjcable.solvers.ring_kernels`)."""
    return S.ring_mode[r] == RING_SLIDING and S.ring_mu[r] == 0.0


@_jit
def _holding(S, seg):
    """The ring of the solve (:func:`in_solve`) that holds segment ``seg`` (its rest length negated), or −1."""
    for r in range(S.ring_p.shape[0]):
        if S.ring_seg[r] == seg and in_solve(S, r):
            return r
    return -1


@_jit
def ring_row(S, seg, row, grad, row_p, prow, pslot):
    """The length through the ring holding segment ``seg`` as row ``row`` of the banded solve (the segment's stretch
    row): ∇C into ``grad[row]`` (xᵢ: uₐ, xᵢ₊₁: u_b, the hub c: −(uₐ + u_b)), the hub into ``row_p[row, 2]`` and
    its row list (``prow``, ``pslot``). Returns (whether a ring of the solve holds it, C_Σ); none: the row is left
    out."""
    r = _holding(S, seg)
    if r < 0:
        return False, 0.0
    c = S.ring_p[r]
    la, ax, ay, az = _arm(S.x, seg, c)
    lb, bx, by, bz = _arm(S.x, seg + 1, c)
    grad[row, 0, 0], grad[row, 0, 1], grad[row, 0, 2] = ax, ay, az
    grad[row, 1, 0], grad[row, 1, 1], grad[row, 1, 2] = bx, by, bz
    grad[row, 2, 0], grad[row, 2, 1], grad[row, 2, 2] = -(ax + bx), -(ay + by), -(az + bz)
    row_p[row, 2] = c
    prow[c, 0], pslot[c, 0] = row, 2
    nx, ny, nz = ax + bx, ay + by, az + bz
    norm = math.sqrt(nx * nx + ny * ny + nz * nz)
    if norm > _TINY_LENGTH:  # the pull's direction (a body ring's inverse mass)
        S.ring_dir[r, 0], S.ring_dir[r, 1], S.ring_dir[r, 2] = nx / norm, ny / norm, nz / norm
    return True, la + lb + S.rest[seg]


@_jit
def _softening(S, r, end):
    """(particle p, w − w̃ (1/kg), u): the arm of ring ``r``'s particle ``end`` (0: xᵢ, 1: xᵢ₊₁) and how much its
    geometric stiffness lowers the particle's inverse mass across the arm (module docstring; 0: none)."""
    p = S.ring_seg[r] + end
    length, ux, uy, uz = _arm(S.x, p, S.ring_p[r])
    lam = S.lam_s[S.ring_seg[r]]
    if lam == 0.0:
        lam = S.ring_tension[r]
    wp = S.w[p]
    if length == 0.0 or lam >= 0.0 or wp == 0.0:
        return p, 0.0, ux, uy, uz
    k = -lam / length
    return p, wp * wp * k / (1.0 + wp * k), ux, uy, uz


@_jit
def _across(g, ux, uy, uz):
    """The part of the 3-vector ``g`` across the unit vector u."""
    along = g[0] * ux + g[1] * uy + g[2] * uz
    return g[0] - along * ux, g[1] - along * uy, g[2] - along * uz


@_jit
def ring_soften(S, rows):
    """J W̃ Jᵀ from J W Jᵀ in ``rows``' band (before its regularisation): −(w − w̃) (P⊥ gₐ) · (P⊥ g_b) for every
    pair of rows at each sliding ring's two particles (module docstring)."""
    _, _, _, prow, pslot, band, grad, _, _ = rows
    for r in range(S.ring_p.shape[0]):
        if not in_solve(S, r):
            continue
        for end in range(2):
            p, soft, ux, uy, uz = _softening(S, r, end)
            if soft == 0.0:
                continue
            for ka in range(prow.shape[1]):
                ra = prow[p, ka]
                if ra < 0:
                    break
                a0, a1, a2 = _across(grad[ra, pslot[p, ka]], ux, uy, uz)
                for kb in range(ka + 1):
                    rb = prow[p, kb]
                    b0, b1, b2 = _across(grad[rb, pslot[p, kb]], ux, uy, uz)
                    band[max(ra, rb), abs(ra - rb)] -= soft * (a0 * b0 + a1 * b1 + a2 * b2)


@_jit
def ring_soft_move(S, rows, unit):
    """Before the solve's Δλ (``rows``' right-hand side) moves the particles by W Jᵀ Δλ: each sliding ring's two
    particles' share −(w − w̃) P⊥ Σ ∇C Δλ, so that they move by W̃ Jᵀ Δλ (module docstring); Δλ scaled by each
    row's cable's factors k (``cable_par``; with ``unit``, 1)."""
    row_kind, _, _, prow, pslot, _, grad, rhs, row_cable = rows
    x = S.x
    for r in range(S.ring_p.shape[0]):
        if not in_solve(S, r):
            continue
        for end in range(2):
            p, soft, ux, uy, uz = _softening(S, r, end)
            if soft == 0.0:
                continue
            s0 = s1 = s2 = 0.0
            for ka in range(prow.shape[1]):
                ra = prow[p, ka]
                if ra < 0:
                    break
                cp = S.cable_par[row_cable[ra]]
                if unit:
                    dlam = row_step(row_kind[ra], rhs[ra], 1.0, 1.0, 1.0)
                else:
                    dlam = row_step(row_kind[ra], rhs[ra], cp.k_s, cp.k_b, cp.k_c)
                g = grad[ra, pslot[p, ka]]
                s0, s1, s2 = s0 + g[0] * dlam, s1 + g[1] * dlam, s2 + g[2] * dlam
            a0, a1, a2 = _across((s0, s1, s2), ux, uy, uz)
            x[p, 0] -= soft * a0
            x[p, 1] -= soft * a1
            x[p, 2] -= soft * a2


@_jit
def _turn_over(S, p, q, c):
    """Particle ``p`` passes the centre ``c`` onto the arm of particle ``q``: it and its substep's start x₀ turn with
    the cable, x ← c + |x − c| û, x₀ ← c − |x₀ − c| û (û from c to q), so that it goes on at its speed along its new
    arm (the cable's material turning through the point ring) rather than on through the ring."""
    x, x0 = S.x, S.x0
    lq, ux, uy, uz = _arm(x, q, c)
    if lq == 0.0:
        return
    d = _arm(x, p, c)[0]
    d0 = _arm(x0, p, c)[0]
    x[p, 0], x[p, 1], x[p, 2] = x[c, 0] + d * ux, x[c, 1] + d * uy, x[c, 2] + d * uz
    x0[p, 0], x0[p, 1], x0[p, 2] = x[c, 0] - d0 * ux, x[c, 1] - d0 * uy, x[c, 2] - d0 * uz


@_jit
def ring_crossings(S, grad, prow):
    """After a solve (its rows' gradients ``grad``, the hubs' rows in ``prow``): a particle of a ring's segment that
    it carried through the centre passes onto the other arm (:func:`_turn_over`; module docstring)."""
    x = S.x
    for r in range(S.ring_p.shape[0]):
        if not in_solve(S, r):
            continue
        i, c = S.ring_seg[r], S.ring_p[r]
        row = prow[c, 0]
        if row < 0:
            continue
        for end in range(2):
            p = i + end
            along = 0.0
            norm = 0.0
            for comp in range(3):
                along += (x[p, comp] - x[c, comp]) * grad[row, end, comp]
                norm += grad[row, end, comp] * grad[row, end, comp]
            if norm > 0.5 and along < 0.0:
                _turn_over(S, p, i + 1 - end, c)
                _pass(S, r, 1 if end == 1 else -1)
                break


@_jit
def ring_predicted(S):
    """After the substep's prediction: a particle of a ring's segment that its own motion carried through the
    centre, (x − c) · (x₀ − c) < 0 against where it started the substep, passes onto the other arm (a solve would
    take it for the far side of its own arm and pull the cable back)."""
    x, x0 = S.x, S.x0
    for r in range(S.ring_p.shape[0]):
        if not in_solve(S, r):
            continue
        i, c = S.ring_seg[r], S.ring_p[r]
        for end in range(2):
            p = i + end
            along = 0.0
            for comp in range(3):
                along += (x[p, comp] - x[c, comp]) * (x0[p, comp] - x[c, comp])
            if along < 0.0:
                _turn_over(S, p, i + 1 - end, c)
                _pass(S, r, 1 if end == 1 else -1)
                break
