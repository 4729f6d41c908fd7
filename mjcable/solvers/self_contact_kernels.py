"""The self contacts' linearisation, renewed every iteration, ``@njit`` (cached, see
:mod:`mjcable.solvers._kernel_cache`).

The step's query (:func:`mjcable.solvers.query_kernels.self_contacts`) finds the pairs of segments that can touch
within the step and linearises each at its closest points then: fractions (s, t) and the unit normal n from segment
j to segment i. Strands that slide along each other within the step (a knot pulled taut: its loop runs round the
strand through it at metres per second while it tightens) leave those points behind, and a constraint kept at the
query's points lets the segments meet elsewhere (``docs/measurements.md``, the knot). :func:`relinearise` moves each
pair's points to its closest points now, before every sweep, keeping the query's side: the normal follows the pair's
closest direction while that points to the side the query saw (d·n > 0), and stays the query's when the pair has
crossed over, so that the sweep pushes it back rather than through.

References:
  [E05] C. Ericson, "Real-Time Collision Detection", 2005, §5.1.9 (closest points of two segments).
"""

from __future__ import annotations

import math

from mjcable.solvers._kernel_cache import jit as _jit
from mjcable.solvers.contact_kernels import self_contact_sweep
from mjcable.solvers.query_kernels import segment_closest

__all__ = ["relinearise", "sweep_self_contacts"]

_TINY_DISTANCE = 1e-12  # m: closest points this near have no direction (the query's normal is kept)


@_jit
def relinearise(S):
    """Each of the state's ``par.n_self`` self contacts at its pair's closest points now: ``self_st`` the fractions
    (s, t) of the closest points of segments (i, i+1) and (j, j+1) of ``S.x`` ([E05] §5.1.9, as the query), and
    ``self_normal`` the unit direction between them while it points to the query's side (module docstring)."""
    x = S.x
    pair, st, normal = S.self_pair, S.self_st, S.self_normal
    for c in range(S.par[0].n_self):
        i, j = pair[c, 0], pair[c, 1]
        a = e = f = g = d1d2 = 0.0
        for comp in range(3):
            d1 = x[i + 1, comp] - x[i, comp]
            d2 = x[j + 1, comp] - x[j, comp]
            r = x[i, comp] - x[j, comp]
            a += d1 * d1
            e += d2 * d2
            f += d2 * r
            g += d1 * r
            d1d2 += d1 * d2
        s, t = segment_closest(a, e, f, g, d1d2)
        st[c, 0], st[c, 1] = s, t
        d0 = (1.0 - s) * x[i, 0] + s * x[i + 1, 0] - (1.0 - t) * x[j, 0] - t * x[j + 1, 0]
        d1 = (1.0 - s) * x[i, 1] + s * x[i + 1, 1] - (1.0 - t) * x[j, 1] - t * x[j + 1, 1]
        d2 = (1.0 - s) * x[i, 2] + s * x[i + 1, 2] - (1.0 - t) * x[j, 2] - t * x[j + 1, 2]
        dist = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        if dist > _TINY_DISTANCE and d0 * normal[c, 0] + d1 * normal[c, 1] + d2 * normal[c, 2] > 0.0:
            normal[c, 0], normal[c, 1], normal[c, 2] = d0 / dist, d1 / dist, d2 / dist


@_jit
def sweep_self_contacts(S):
    """:func:`relinearise`, then the self contacts' projection and friction
    (:func:`~mjcable.solvers.contact_kernels.self_contact_sweep`)."""
    relinearise(S)
    self_contact_sweep(S)
