"""Junctions of the particle solvers, ``@njit`` (cached, see :mod:`mjcable.solvers._kernel_cache`): two particles
of the state (of two cables, or a cable's own two ends: a loop) held at one point, a ball joint.

Each junction k is the hard vector constraint C = x_b − x_a = 0 (``junction_p[k]`` = [a, b]), whose gradient is the
identity on b and its negative on a, so that its three components decouple and each is one [M16] Eq. 18 update
with α = 0: Δλ = −C / (w_a + w_b), Δx_b = w_b Δλ, Δx_a = −w_a Δλ (a held particle collects its share in ``react``,
so that a pin at a junction feels the junction's pull). The chains are solved first in each iteration (in any
order; the direct order's chains stay banded) and the junctions after them, Gauss-Seidel (:func:`junction_sweep`):
a tree of cables converges over the iterations and substeps as a chain does in the Gauss-Seidel order.

A clamped junction of point chains (no frames) keeps the angles between the segments that meet at it: a brace, the
hard distance constraint C = |x_p − x_q| − d₀ (d₀ their start distance), between each neighbour p of a and each
neighbour q of b along their cables, projected after the junctions ([M16] Eq. 18 with α = 0:
Δλ = −C / (w_p + w_q) along n = (x_p − x_q) / |x_p − x_q|). With the segments' lengths held, the triangle a–p–q
keeps its shape, so the two tangents keep their start angle (free to turn about each other: a chain of points has
no twist).

The junction's force on particle b is λ / h² ([M16]'s force estimate, λ summed over the substep's iterations);
``junction_sum`` adds it up over a step's substeps, as the pins' forces (:func:`junction_forces`), and
:meth:`mjcable.backends.particle.ParticleBackend.junction_forces` reads the mean.

References:
  [M16] M. Macklin, M. Müller, N. Chentanez, "XPBD: Position-Based Simulation of Compliant Constrained
        Dynamics", MIG 2016.
"""

from __future__ import annotations

from mjcable.solvers._kernel_cache import inline as _inline
from mjcable.solvers.constraint_kernels import push, stretch_step_rigid

__all__ = ["junction_sweep", "junction_begin", "junction_forces"]


@_inline
def junction_sweep(S):
    """Project every junction once (module docstring): x_a and x_b moved onto one point, mass-weighted."""
    x, w, react, junction_p, lam = S.x, S.w, S.react, S.junction_p, S.lam_j
    for k in range(junction_p.shape[0]):
        a, b = junction_p[k, 0], junction_p[k, 1]
        wa, wb = w[a], w[b]
        wsum = wa + wb
        if wsum == 0.0:
            continue
        for comp in range(3):
            dlam = (x[a, comp] - x[b, comp]) / wsum
            lam[k, comp] += dlam
            if wb > 0.0:
                x[b, comp] += wb * dlam
            else:
                react[b, comp] += dlam
            if wa > 0.0:
                x[a, comp] -= wa * dlam
            else:
                react[a, comp] -= dlam
    if S.brace_p.shape[0]:
        _brace_sweep(S)


@_inline
def _brace_sweep(S):
    """Project every brace of the clamped junctions once (module docstring): the chain's hard stretch step."""
    x, w, react, brace_p, brace_d = S.x, S.w, S.react, S.brace_p, S.brace_d
    for k in range(brace_p.shape[0]):
        p, q = brace_p[k, 0], brace_p[k, 1]
        d0, d1, d2 = x[p, 0] - x[q, 0], x[p, 1] - x[q, 1], x[p, 2] - x[q, 2]
        sigma, _ = stretch_step_rigid(d0, d1, d2, w[p] + w[q], brace_d[k])
        push(x, react, w[p], p, sigma * d0, sigma * d1, sigma * d2)
        push(x, react, w[q], q, -sigma * d0, -sigma * d1, -sigma * d2)


@_inline
def junction_begin(S):
    """A substep's start: the multipliers zeroed, and the force sums zeroed when they hold a whole step's substeps."""
    P = S.par[0]
    S.lam_j[:, :] = 0.0
    if P.junction_count >= P.substeps:
        S.junction_sum[:, :] = 0.0
        P.junction_count = 0


@_inline
def junction_forces(S):
    """A substep's end: each junction's force on its particle b, λ / h² (N), added to ``junction_sum``."""
    P = S.par[0]
    inv_h2 = 1.0 / (P.h * P.h)
    lam, total = S.lam_j, S.junction_sum
    for k in range(lam.shape[0]):
        for comp in range(3):
            total[k, comp] += lam[k, comp] * inv_h2
    P.junction_count += 1
