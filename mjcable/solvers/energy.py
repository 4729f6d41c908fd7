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

Rows (of every cable; the gaps between cables have none): stretch C = |xᵢ₊₁ − xᵢ| − l (W = wᵢ + wᵢ₊₁); curvature
C = (xᵢ₋₁ − 2xᵢ + xᵢ₊₁) / l₀², per component (W = (wᵢ₋₁ + 4wᵢ + wᵢ₊₁) / l₀⁴); distance bending C = |xᵢ₊₂ − xᵢ| − 2 l₀ (W = wᵢ + wᵢ₊₂); an active clamp's two
rows C = (2 / l₀²) d·(x_q − x_p) (W = 4 (w_p + w_q) / l₀⁴), counted as bending. Contacts, pins and PBD's user
constraints are hard and store none.

The Cosserat rod (``cosserat``, :func:`rod_energy`) stores ½ Cᵀ α⁻¹ C of its rows ([KS16] in XPBD form,
:mod:`mjcable.solvers.cosserat_kernels`): stretch–shear C = Rᵢᵀ (xᵢ₊₁ − xᵢ) / l₀ − e₃ with α = (1/(G·A·l₀),
1/(G·A·l₀), 1/(E·A·l₀)) (the stretch part; 0 for an inextensible rod: hard), bend–twist C = (2 / l₀) Im(q̄ᵢ ⊗ qᵢ₊₁) −
Ω₀ with α = (1/(E·I·l₀), 1/(E·I·l₀), 1/(G·J·l₀)) (bending, bending, twist), and a clamp's half-segment constraint
C = (4 / l₀) Im(q̄ q′) with twice those compliances.
"""

from __future__ import annotations

import numpy as np

from mjcable.solvers import kernels_layout as layout

__all__ = ["elastic_energy", "rod_energy", "row_compliance"]


def row_compliance(alpha, k_iteration, iterations: int, h: float, wsum: np.ndarray) -> np.ndarray:
    """``(R,)`` the compliance (the row's unit / N) each row of generalised inverse mass ``wsum`` (R,) acts with:
    XPBD's ``alpha`` plus the per-iteration factor's h² W (1 − k_s) / k_s, k_s = 1 − (1 − k)^iterations (``alpha``
    and ``k_iteration`` per row (R,), or one for all); ``inf`` for a row switched off (k_s = 0), 0 for a hard one."""
    k_sub = 1.0 - (1.0 - np.asarray(k_iteration, dtype=np.float64)) ** iterations
    on = k_sub > 0.0
    soft = np.divide(1.0 - k_sub, k_sub, out=np.zeros_like(k_sub), where=on)
    out = alpha + h * h * np.asarray(wsum) * soft
    return np.where(on, out, np.inf)


def _potential(c2: np.ndarray, alpha: np.ndarray) -> float:
    """Σ ½ C² / α over rows with 0 < α < ∞ (``c2``: C² per row, summed over a vector row's components)."""
    soft = (alpha > 0.0) & np.isfinite(alpha)
    return float(0.5 * np.sum(c2[soft] / alpha[soft]))


def elastic_energy(a) -> tuple:
    """``(stretch, bending)`` in joules of the particle state ``a`` (:class:`mjcable.solvers.state.StateArrays`:
    ``x``, ``w``, ``rest``, ``rest_d``, the clamps and the parameter record ``par``)."""
    x, w = a["x"], a["w"]
    P = a["par"][0]
    h, n_it = float(P["h"]), int(P["iterations"])
    cp = a["cable_par"][np.maximum(a["seg_cable"], 0)]  # (n,) each segment's cable's parameters
    link = (a["seg_cable"] >= 0) & (a["rest"] > 0.0)  # the cables' segments (not the gaps, nor those rings hold)
    triplet = link[:-1] & link[1:]
    seg = np.linalg.norm(np.diff(x, axis=0), axis=1)
    stretch = _potential(((seg - a["rest"]) ** 2)[link], row_compliance(
        cp["alpha_s"][link], cp["k_s"][link], n_it, h, (w[:-1] + w[1:])[link]))
    triplet &= cp["bends"][:-1]  # (a limp cable beside bending ones has no bending rows)
    bend = cp[:-1][triplet]  # each bending row's cable's
    bending = 0.0
    if P["bending"] == layout.BEND_CURVATURE and len(x) > 2:
        inv_l0sq = bend["inv_l0sq"][:, None]
        c = ((x[:-2] - 2.0 * x[1:-1] + x[2:])[triplet] * inv_l0sq)
        wsum = (w[:-2] + 4.0 * w[1:-1] + w[2:])[triplet] * bend["inv_l0sq"] ** 2
        bending += _potential(np.einsum("ij,ij->i", c, c), row_compliance(bend["alpha_b"], bend["k_b"], n_it, h, wsum))
    elif P["bending"] == layout.BEND_DISTANCE and len(x) > 2:
        c = (np.linalg.norm(x[2:] - x[:-2], axis=1) - a["rest_d"])[triplet]
        bending += _potential(c * c, row_compliance(bend["alpha_b"], bend["k_b"], n_it, h, (w[:-2] + w[2:])[triplet]))
    active = a["pin_active"][a["clamp_pin"]]
    if np.any(active):
        p, q = a["clamp_pq"][active, 0], a["clamp_pq"][active, 1]
        held = cp[np.minimum(p, q)]  # each clamp's cable's
        scale = 2.0 * held["inv_l0sq"]
        c = scale[:, None] * np.einsum("kmj,kj->km", a["clamp_dir"][active], x[q] - x[p])
        wsum = (w[p] + w[q]) * scale * scale
        bending += _potential(np.sum(c * c, axis=1), row_compliance(held["alpha_c"], held["k_c"], n_it, h, wsum))
    return stretch, bending


def _rotate_back(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rᵀ v for unit quaternions ``q`` (n, 4) (w, x, y, z) and vectors ``v`` (n, 3): v in the frames."""
    w, u = q[:, :1], -q[:, 1:]  # the conjugate's rotation
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _relative(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Im(r) of r = ā ⊗ b with r_w ≥ 0, for quaternions (n, 4)."""
    aw, av, bw, bv = a[:, :1], -a[:, 1:], b[:, :1], b[:, 1:]
    rw = aw * bw - np.sum(av * bv, axis=1, keepdims=True)
    rv = aw * bv + bw * av + np.cross(av, bv)
    return np.where(rw < 0.0, -rv, rv)


def _quadratic(c: np.ndarray, alpha) -> np.ndarray:
    """½ Σ c_k² / α_k per column k (3,) of ``c`` (n, 3); a hard (α = 0) column stores none."""
    out = np.zeros(3)
    for k in range(3):
        if alpha[k] > 0.0 and np.isfinite(alpha[k]):
            out[k] = 0.5 * float(np.sum(c[:, k] ** 2)) / alpha[k]
    return out


def rod_energy(a) -> tuple:
    """``(stretch, bending, twist)`` in joules of a Cosserat rod's state ``a`` (module docstring; ``x``, ``q``,
    ``darboux0``, the clamps, ``par``)."""
    x, q = a["x"], a["q"]
    P = a["par"][0]
    l0 = float(a["cable_par"][0]["l0"])  # (a rod's cables share one segment length)
    a_ss = (float(P["ss_alpha1"]), float(P["ss_alpha2"]), float(P["ss_alpha3"]))
    a_bt = (float(P["bt_alpha1"]), float(P["bt_alpha2"]), float(P["bt_alpha3"]))
    link = a["seg_cable"] >= 0  # the segments of the cables (not the gaps between them, which store nothing)
    c_ss = _rotate_back(q, np.diff(x, axis=0) / l0) - np.array([0.0, 0.0, 1.0])
    stretch = float(np.sum(_quadratic(c_ss[link], a_ss)))
    bt = (_quadratic((2.0 / l0 * _relative(q[:-1], q[1:]) - a["darboux0"])[link[:-1] & link[1:]], a_bt)
          if len(q) > 1 else np.zeros(3))
    halves = (2.0 * a_bt[0], 2.0 * a_bt[1], 2.0 * a_bt[2])
    for e, k in enumerate(a["end_clamp"]):
        if k >= 0 and a["pin_active"][a["clamp_pin"][k]]:
            held, seg = a["clamp_q"][k:k + 1], q[-1:] if e else q[:1]
            rel = _relative(seg, held) if e else _relative(held, seg)
            bt = bt + _quadratic(4.0 / l0 * rel, halves)
    return stretch, float(bt[0] + bt[1]), float(bt[2])
