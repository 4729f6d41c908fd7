"""Impacts of the particle solvers' point chains on obstacles, ``@njit`` (cached, see
:mod:`mjcable.solvers._kernel_cache`). Re-exported through :mod:`mjcable.solvers.kernels`.

**Why.** One iteration per substep projects the chain, then the contacts, then friction. When a rope lands on an
obstacle, the contacts stop its touching points after the chain was solved, so the impact is absorbed by a stretch
of the (inextensible) chain that the next substeps' chain solves give back as velocity: the rope bounces (about half
its impact speed without friction), and the friction that the impact's normal load should give comes substeps
after the legs' pull. A rope dropped 2 cm onto a peg slid off at every substep count.

**The rule.** A substep is an impact when a contact that pressed in its iterations (Σ Δλₙ > 0) approached its
obstacle faster than v_i = ``par.impact_speed``: −n₀·((1 − s) vᵢ + s vᵢ₊₁) > v_i, with v the predicted velocity and
n₀ the detection normal (:func:`struck`). Such a substep gets up to ``par.impact_iterations`` more iterations
(:func:`resolve_impact`), each

1. the stretch chain held at its lengths at the substep's start, all rows at once: Cᵢ = |xᵢ₊₁ − xᵢ| − |x₀ᵢ₊₁ − x₀ᵢ|
   = 0, one Newton step of the tridiagonal Schur complement A λ = −C, Aᵢᵢ = wᵢ + wᵢ₊₁, Aᵢ,ᵢ₋₁ = −wᵢ uᵢ·uᵢ₋₁,
   Δxⱼ = wⱼ Σᵢ ∇ⱼCᵢ λᵢ (uᵢ the unit segment; [D18]'s direct solve for a chain, :func:`held_chain_solve`);
2. the model's bending and clamps, the contacts and friction (their multipliers and the friction sums go on
   accumulating over the substep, as in any iteration),

until an iteration's largest contact or friction correction is at most ``par.impact_tol`` (v_tol h). Holding the
chain at its substep-start lengths, rather than at its rest lengths, makes the impact inelastic without releasing
the stretch that the model's own iterations keep (a Gauss-Seidel chain's stretch depends on its iteration count:
a converged solve in one substep would throw it back as a kick of stretch / h), so substeps that are impacts and
substeps that are not can follow one another. A cable at rest or sliding pays a comparison per iteration: a struck
contact is at least v_i h deep after the prediction, so :func:`struck` runs only in a substep whose contact sweeps
removed that much (the most of any of its iterations, ``par.substep_depth``: the first sweep removes the approach;
``docs/measurements.md``, 2026-11-27).

References:
  [D18] C. Deul, T. Kugelstadt, M. Weiler, J. Bender, "Direct Position-Based Solver for Stiff Rods", CGF 2018.
"""

from __future__ import annotations

import math

import numpy as np

from mjcable.solvers._kernel_cache import inline as _inline, jit as _jit, variable
from mjcable.solvers.cable_contact_kernels import self_contact_sweep
from mjcable.solvers.constraint_kernels import _bend_clamp_sweeps
from mjcable.solvers.contact_kernels import contact_sweep, friction_sweep
from mjcable.solvers.junction_kernels import junction_sweep
from mjcable.solvers.kernels_layout import _TINY_LENGTH, BEND_NONE

__all__ = ["struck", "held_chain_solve", "resolve_impact"]


@_inline
def struck(S):
    """Whether a contact that pressed in this substep's iterations (``con_lam`` > 0) approached its obstacle faster
    than ``par.impact_speed``: its point's predicted velocity along the detection normal."""
    P = S.par[0]
    v, seg, con_s, normal, lam = S.v, S.con_seg, S.con_s, S.con_normal, S.con_lam
    limit = -P.impact_speed
    for c in range(P.n_con):
        if lam[c] <= 0.0:
            continue
        i = seg[c]
        s = con_s[c]
        a = 1.0 - s
        vn = 0.0
        for comp in range(3):
            vn += normal[c, comp] * (a * v[i, comp] + s * v[i + 1, comp])
        if vn < limit:
            return True
    return False


@_jit
def held_chain_solve(S, scratch):
    """One Newton step of the stretch chain held at its lengths at the substep's start: Cᵢ = |xᵢ₊₁ − xᵢ| − |x₀ᵢ₊₁ −
    x₀ᵢ| = 0 for every segment, all at once (tridiagonal Schur complement, Thomas algorithm), hard. ``scratch``
    (n, 6): unit vectors, diagonal, off-diagonal, right-hand side."""
    x, x0, w, react = S.x, S.x0, S.w, S.react
    n = x.shape[0] - 1
    for i in range(n):
        dx, dy, dz = x[i + 1, 0] - x[i, 0], x[i + 1, 1] - x[i, 1], x[i + 1, 2] - x[i, 2]
        length = math.sqrt(dx * dx + dy * dy + dz * dz)
        ex, ey, ez = x0[i + 1, 0] - x0[i, 0], x0[i + 1, 1] - x0[i, 1], x0[i + 1, 2] - x0[i, 2]
        held = math.sqrt(ex * ex + ey * ey + ez * ez)
        diag = w[i] + w[i + 1]
        if length < _TINY_LENGTH or diag == 0.0 or S.seg_cable[i] < 0:  # (a gap between cables: no row)
            scratch[i, 0] = scratch[i, 1] = scratch[i, 2] = 0.0
            scratch[i, 3], scratch[i, 5] = 1.0, 0.0
        else:
            scratch[i, 0], scratch[i, 1], scratch[i, 2] = dx / length, dy / length, dz / length
            scratch[i, 3], scratch[i, 5] = diag, held - length
        scratch[i, 4] = 0.0
        if i > 0:
            scratch[i, 4] = -w[i] * (scratch[i, 0] * scratch[i - 1, 0] + scratch[i, 1] * scratch[i - 1, 1]
                                     + scratch[i, 2] * scratch[i - 1, 2])  # A[i, i − 1]
    for i in range(1, n):  # forward elimination
        f = scratch[i, 4] / scratch[i - 1, 3]
        scratch[i, 3] -= f * scratch[i, 4]
        scratch[i, 5] -= f * scratch[i - 1, 5]
    for i in range(n - 1, -1, -1):  # back substitution: λ into scratch[:, 5]
        if i < n - 1:
            scratch[i, 5] -= scratch[i + 1, 4] * scratch[i + 1, 5]
        scratch[i, 5] /= scratch[i, 3]
    for i in range(n):
        lam = scratch[i, 5]
        for p, sign in ((i, -1.0), (i + 1, 1.0)):
            g = sign * lam
            if w[p] > 0.0:
                x[p, 0] += w[p] * g * scratch[i, 0]
                x[p, 1] += w[p] * g * scratch[i, 1]
                x[p, 2] += w[p] * g * scratch[i, 2]
            else:
                react[p, 0] += g * scratch[i, 0]
                react[p, 1] += g * scratch[i, 1]
                react[p, 2] += g * scratch[i, 2]


@_jit
def resolve_impact(S):
    """Up to ``par.impact_iterations`` more iterations of the substep: :func:`held_chain_solve`, the model's bending
    and clamps, the contacts and friction, until an iteration's contact and friction corrections are at most
    ``par.impact_tol`` (m). Returns the iterations taken."""
    P = S.par[0]
    bend_or_clamp = P.bending != BEND_NONE or S.clamp_pq.shape[0] > 0
    scratch = np.empty((S.x.shape[0] - 1, 6))
    P.impacts += 1
    taken = 0
    for _ in range(P.impact_iterations):
        taken += 1
        held_chain_solve(S, scratch)
        if bend_or_clamp:
            _bend_clamp_sweeps(S, S.x, False)
        if S.junction_p.shape[0]:
            junction_sweep(S)
        moved = max(contact_sweep(S), friction_sweep(S, variable(False)))
        if P.n_self:
            self_contact_sweep(S)
        if moved <= P.impact_tol:
            break
    return taken
