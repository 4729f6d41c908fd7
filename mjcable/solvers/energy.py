"""The particle solvers' elastic energy: the potential of each constraint row as the solver applies it.

Every row (a scalar constraint C, or one component of the curvature vector) is projected with XPBD's update
Δλ = k (−C − α̃ λ) / (W + α̃), α̃ = α / h², W = Σ wⱼ |∇ⱼC|² (:mod:`mjcable.solvers.kernels`). Its potential:

* ``xpbd`` (k = 1): the compliance's, ½ C² / α ([M16] Eq. 4). α = 0 (an inextensible cable, a rigid clamp) is a
  hard constraint: it stores no energy (C stays at round-off and solver error);
* ``pbd`` and ``jakobsen`` (α = 0): the factor k removes, per substep, the fraction k_s = 1 − (1 − k)^iterations of a
  lone row's violation (PBD's per-iteration k′ = 1 − (1 − k)^(1/iterations) makes k_s the user's k; Jakobsen applies
  k as is). XPBD's first iteration removes W / (W + α̃) of it, so the factor acts as the compliance
  α = h² W (1 − k_s) / k_s, and the row's potential is ½ C² / α, that spring's. k_s = 1 (the default
  ``stretch_factor``, and clamps) is a hard row: zero potential; k_s = 0 switches a row off: zero. A ``bend_factor``
  derived from E·I (:func:`mjcable.solvers.pbd.derived_bend_factor`) gives an interior particle's row exactly
  α = 1 / (E·I·l₀), the cable's bending energy ½ E·I κ² l₀; a factor given by hand gives the spring it stands for
  at that h (the thesis's timescale-stiffness effect: the same k is stiffer at a smaller step). Iterations fighting
  over shared particles make a Gauss-Seidel chain softer than its lone rows (the accuracy-stiffness effect): the
  potential is the rows', not what the unconverged sweep achieves.

Rows: stretch C = |xᵢ₊₁ − xᵢ| − l (W = wᵢ + wᵢ₊₁); curvature C = (xᵢ₋₁ − 2xᵢ + xᵢ₊₁) / l₀², per component
(W = (wᵢ₋₁ + 4wᵢ + wᵢ₊₁) / l₀⁴); distance bending C = |xᵢ₊₂ − xᵢ| − 2 l₀ (W = wᵢ + wᵢ₊₂); an active clamp's two
rows C = (2 / l₀²) d·(x_q − x_p) (W = 4 (w_p + w_q) / l₀⁴), counted as bending. Contacts, pins and PBD's user
constraints are hard and store none.
"""

from __future__ import annotations

import numpy as np

from mjcable.solvers import kernels_layout as layout

__all__ = ["elastic_energy", "row_compliance"]


def row_compliance(alpha: float, k_iteration: float, iterations: int, h: float, wsum: np.ndarray) -> np.ndarray:
    """``(R,)`` the compliance (the row's unit / N) each row of generalised inverse mass ``wsum`` (R,) acts with:
    XPBD's ``alpha`` plus the per-iteration factor's h² W (1 − k_s) / k_s, k_s = 1 − (1 − k)^iterations; ``inf``
    for a row switched off (k_s = 0), 0 for a hard one."""
    k_sub = 1.0 - (1.0 - k_iteration) ** iterations
    if k_sub <= 0.0:
        return np.full(np.shape(wsum), np.inf)
    return alpha + h * h * np.asarray(wsum) * (1.0 - k_sub) / k_sub


def _potential(c2: np.ndarray, alpha: np.ndarray) -> float:
    """Σ ½ C² / α over rows with 0 < α < ∞ (``c2``: C² per row, summed over a vector row's components)."""
    soft = (alpha > 0.0) & np.isfinite(alpha)
    return float(0.5 * np.sum(c2[soft] / alpha[soft]))


def elastic_energy(a) -> tuple:
    """``(stretch, bending)`` in joules of the particle state ``a`` (:class:`mjcable.solvers.state.StateArrays`:
    ``x``, ``w``, ``rest``, ``rest_d``, the clamps and the parameter record ``par``)."""
    x, w = a["x"], a["w"]
    P = a["par"][0]
    h, n_it, inv_l0sq = float(P["h"]), int(P["iterations"]), float(P["inv_l0sq"])
    seg = np.linalg.norm(np.diff(x, axis=0), axis=1)
    stretch = _potential((seg - a["rest"]) ** 2,
                         row_compliance(float(P["alpha_s"]), float(P["k_s"]), n_it, h, w[:-1] + w[1:]))
    alpha_b, k_b = float(P["alpha_b"]), float(P["k_b"])
    bending = 0.0
    if P["bending"] == layout.BEND_CURVATURE and len(x) > 2:
        c = (x[:-2] - 2.0 * x[1:-1] + x[2:]) * inv_l0sq
        wsum = (w[:-2] + 4.0 * w[1:-1] + w[2:]) * inv_l0sq**2
        bending += _potential(np.einsum("ij,ij->i", c, c), row_compliance(alpha_b, k_b, n_it, h, wsum))
    elif P["bending"] == layout.BEND_DISTANCE and len(x) > 2:
        c = np.linalg.norm(x[2:] - x[:-2], axis=1) - a["rest_d"]
        bending += _potential(c * c, row_compliance(alpha_b, k_b, n_it, h, w[:-2] + w[2:]))
    active = a["pin_active"][a["clamp_pin"]]
    if np.any(active):
        p, q = a["clamp_pq"][active, 0], a["clamp_pq"][active, 1]
        scale = 2.0 * inv_l0sq
        c = scale * np.einsum("kmj,kj->km", a["clamp_dir"][active], x[q] - x[p])
        wsum = (w[p] + w[q]) * scale * scale
        bending += _potential(np.sum(c * c, axis=1),
                              row_compliance(float(P["alpha_c"]), float(P["k_c"]), n_it, h, wsum))
    return stretch, bending
