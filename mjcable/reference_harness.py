"""Independent physical reference for a cable harness: several legs joined at one junction, their far ends pinned.

The rest state of k ≥ 2 inextensible legs (a Y-harness for k = 3), none of which runs a cable model:

* :func:`y_harness`: leg i, of length L_i and mass m_i, hangs from its pin P_i to the junction J. For the discrete
  reference each leg is a chain of n_i rigid links with its mass lumped on its particles as
  :attr:`mjcable.scene.CableSpec.particle_masses` lumps it (m_i / n_i inside, half that at the ends; the legs' end
  particles at J are one point carrying their summed mass), the limit every particle model with those segments
  converges to; for the continuous reference each leg is an inextensible catenary and J carries no mass. J lies
  where the legs' end tensions and the junction's own weight balance.
* :func:`harness_error`: the largest distance in metres of a model's particles from the reference.

The unknowns are J and the force F_i each leg exerts on J. Given F_i a leg's shape follows from statics alone: its
tension at arc length s is F_i − g⃗ × (the leg's mass between J and s), and its tangent points along that tension,
so a chain's link j is l_i (F_i − g⃗ c_j) / |F_i − g⃗ c_j| with c_j the mass of its particles 1..j, and a catenary
is the closed-form integral of the same. ``scipy.optimize.root`` solves the 3 + 3k equations: each leg, walked from
J, ends at its pin, and Σ F_i + m_J g⃗ = 0 at the junction, from the point where the legs meet with the most slack
(the legs' catenaries from there giving the forces), the catenaries first and the chains from their solution. Every
link of such a root is in tension, so it is the minimum of the potential energy (the optimality condition of the
convex problem "lowest mass-weighted height with every link no longer than l_i"): the stable rest state. A coarse
chain may have no such state (a leg folding back up to J whose bottom link must push); then a Newton solve over every
particle and every link's signed tension, started from the closest attempt, finds the rest state nearby and checks
that it is stable.

For k = 2 the harness is one cable of length L_1 + L_2 hanging between the two pins (:func:`mjcable.reference.
catenary`; with equal links and masses per metre, :func:`mjcable.reference.discrete_catenary`).

All functions take SI units; gravity is any non-zero vector, ``(0, 0, −9.81)`` m/s² unless given.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Optional, Sequence

import numpy as np
from scipy import linalg, optimize

from mjcable import _validate
from mjcable.reference import G, _check_points, catenary, distance_to_curve

__all__ = ["Harness", "y_harness", "harness_error"]

LEG_SAMPLES = 1001  # points per leg of a continuous reference, at equal arc length
_MIN_SLACK = 1e-6  # the legs must be able to meet with each |J − P_i| at most (1 − this) L_i
_ROOT_XTOL = 1e-14  # relative tolerance of optimize.root on the scaled unknowns
_RESIDUAL_TOLERANCE = 1e-10  # largest scaled residual (metres / longest leg, newtons / harness weight) accepted
_STABILITY_TOLERANCE = 1e-10  # a rigid-link rest state's smallest curvature may dip this far below 0 (relative)
_UP = np.array([0.0, 0.0, 1.0])
_MINIMAX_GRADIENT = np.array([0.0, 0.0, 0.0, 1.0])  # gradient of the minimax objective x[3] in _meeting_point


@dataclasses.dataclass(frozen=True)
class Harness:
    """The rest state of a harness of k legs joined at one junction.

    Attributes:
      junction: ``(3,)`` the junction J in metres.
      legs: k arrays in metres, leg i from J (row 0) to its pin (last row): ``(n_i + 1, 3)`` particle positions of
        a discrete reference, ``(LEG_SAMPLES, 3)`` points at equal arc length on a continuous one.
      pin_forces: ``(k, 3)`` the force in newtons each pin exerts on the cable; they sum to the harness' weight,
        pointing up (−g⃗ Σ m_i).
      tensions: ``(k,)`` each leg's tension in newtons at J (its first link's, for a discrete reference; negative
        where that link pushes).
      n_segments: the legs' segment counts (discrete reference), or ``None`` (continuous reference).
    """

    junction: np.ndarray
    legs: tuple
    pin_forces: np.ndarray
    tensions: np.ndarray
    n_segments: Optional[tuple]


def _up_frame(gravity: np.ndarray) -> np.ndarray:
    """``(3, 3)`` rotation R taking world vectors into a frame whose z axis is −gravity (the identity for gravity
    along −z)."""
    up = -gravity / np.linalg.norm(gravity)
    seed = np.array([1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = seed - (seed @ up) * up
    e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(up, e1), up])


def _lumped_masses(mass: float, n: int) -> np.ndarray:
    """``(n + 1,)`` kg: the particle masses of a leg, lumped as :attr:`mjcable.scene.CableSpec.particle_masses`."""
    m = np.full(n + 1, mass / n)
    m[[0, -1]] *= 0.5
    return m


def _reach(force: np.ndarray, length: float, weight: float, lifts: Optional[np.ndarray],
           s: Optional[np.ndarray] = None) -> np.ndarray:
    """Points of a leg relative to J in the up-frame (gravity along −z), given the force it exerts on J.

    Args:
      force: ``(3,)`` N, F = the leg's tension vector at J, pointing into the leg.
      length: the leg's length in metres.
      weight: its weight in N.
      lifts: discrete leg: ``(n,)`` N, the weight of particles 1..j that link j carries on top of F; ``None``:
        continuous leg.
      s: continuous leg: arc lengths in metres of the points wanted (ignored for a discrete leg).

    Returns:
      ``(n + 1, 3)`` the particles (discrete), or ``(len(s), 3)`` points (continuous), in metres from J.
    """
    if lifts is not None:
        t = force[None, :] + lifts[:, None] * _UP
        steps = (length / len(lifts)) * t / np.linalg.norm(t, axis=1)[:, None]
        return np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)])
    w = weight / length  # N/m
    h = math.hypot(force[0], force[1])  # horizontal tension, the same all along the leg
    v = force[2] + w * s  # vertical tension at s
    vertical = (np.hypot(h, v) - math.hypot(h, force[2])) / w
    if h == 0.0:  # a vertical leg
        return vertical[:, None] * _UP
    horizontal = (h / w) * (np.arcsinh(v / h) - math.asinh(force[2] / h))
    return horizontal[:, None] * np.array([force[0] / h, force[1] / h, 0.0]) + vertical[:, None] * _UP


def _meeting_point(pins: np.ndarray, lengths: np.ndarray) -> tuple:
    """The point J minimising max_i |J − P_i| / L_i, and that maximum (< 1: the legs can meet with slack)."""
    k = len(pins)
    centre = np.average(pins, axis=0, weights=1.0 / lengths)
    start = np.append(centre, np.max(np.linalg.norm(centre - pins, axis=1) / lengths))

    def reach(x):  # >= 0 where every leg reaches J = x[:3] with at most the fraction x[3] of its length
        return x[3] - np.linalg.norm(x[:3] - pins, axis=1) / lengths

    def reach_jacobian(x):
        d = x[:3] - pins
        norm = np.maximum(np.linalg.norm(d, axis=1), np.finfo(float).tiny)
        return np.hstack([-d / (norm * lengths)[:, None], np.ones((k, 1))])

    res = optimize.minimize(lambda x: x[3], start, jac=lambda x: _MINIMAX_GRADIENT, method="SLSQP",
                            constraints=[{"type": "ineq", "fun": reach, "jac": reach_jacobian}],
                            options={"ftol": 1e-14, "maxiter": 500})
    # SLSQP may stop short of its tight ftol ("positive directional derivative") at a point still better than
    # the start: keep whichever of the two reaches further.
    best = min((start[:3], res.x[:3]), key=lambda j: np.max(np.linalg.norm(j - pins, axis=1) / lengths))
    return best, float(np.max(np.linalg.norm(best - pins, axis=1) / lengths))


def _start_force(junction: np.ndarray, pin: np.ndarray, length: float, weight: float) -> np.ndarray:
    """The force on J of a continuous leg hanging from ``pin`` to ``junction`` (up-frame): the starting guess."""
    d = pin - junction
    span = math.hypot(d[0], d[1])
    if span <= _MIN_SLACK * length:  # (nearly) above or below J: a vertical guess
        return np.array([0.0, 0.0, math.copysign(weight, d[2])])
    c = catenary(junction, pin, length)
    h = weight / length * c.a  # horizontal tension H = w a
    return np.array([h * d[0] / span, h * d[1] / span, h * math.sinh(-c.x0 / c.a)])


def _balance(pins: np.ndarray, lengths: np.ndarray, weights: np.ndarray, lifts: list, junction_weight: float,
             start: np.ndarray, scale: np.ndarray) -> tuple:
    """Solve for J and the legs' forces on it (up-frame): each leg, walked from J, ends at its pin, and the forces
    balance the junction's weight. ``start``: ``(3 + 3k,)`` J in metres, then the forces in newtons; ``scale``:
    (metres, newtons) that make the unknowns and residuals of order one. Returns (solution like ``start``, largest
    scaled residual, the root-finder's message)."""
    k = len(pins)
    units = np.concatenate([np.full(3, scale[0]), np.full(3 * k, scale[1])])

    def residual(x):
        junction, forces = x[:3] * scale[0], x[3:].reshape(k, 3) * scale[1]
        out = np.empty(3 * k + 3)
        for i in range(k):
            end = junction + _reach(forces[i], lengths[i], weights[i], lifts[i], lengths[i:i + 1])[-1]
            out[3 * i:3 * i + 3] = (end - pins[i]) / scale[0]
        out[3 * k:] = (forces.sum(axis=0) - junction_weight * _UP) / scale[1]
        return out

    sol = optimize.root(residual, start / units, method="hybr", options={"xtol": _ROOT_XTOL})
    return sol.x * units, float(np.max(np.abs(residual(sol.x)))), sol.message


def _rigid_links(pins: np.ndarray, lumped: list, lengths: np.ndarray, g: float, legs: list, link_tensions: list
                 ) -> tuple:
    """The chains' rest state when a link must push (up-frame): Newton on every particle and every link's tension.

    Where no state with every link in tension exists (a coarse leg folding back up to the junction may need its
    bottom link to push) the force walk of :func:`_balance` cannot represent it. Here the unknowns are the free
    particles (J first, then each leg's inner ones) and one signed tension per link; the equations are each free
    particle's balance (weight plus link forces) and each link's length. Started from ``legs`` and
    ``link_tensions`` (the walk's closest attempt), the root is checked to be stable: the potential's Hessian on the
    links' constraint surface (Σ λ (I − u uᵀ) / l over the links) must be positive definite.

    Returns:
      (legs, link_tensions): per leg ``(n_i + 1, 3)`` positions in metres and ``(n_i,)`` tensions in newtons
      (negative: the link pushes).
    """
    k = len(pins)
    n = [len(m) - 1 for m in lumped]
    n_free = 1 + sum(n) - k
    first = 1 + np.concatenate([[0], np.cumsum(np.subtract(n, 1))[:-1]])  # each leg's first inner particle
    index = [np.concatenate([[0], first[i] + np.arange(n[i] - 1), [n_free + i]]) for i in range(k)]
    a = np.concatenate([ix[:-1] for ix in index])  # links a → b
    b = np.concatenate([ix[1:] for ix in index])
    rest = np.concatenate([np.full(n[i], lengths[i] / n[i]) for i in range(k)])
    weight = np.zeros(n_free)
    weight[0] = g * sum(m[0] for m in lumped)
    for i in range(k):
        weight[first[i]:first[i] + n[i] - 1] = g * lumped[i][1:-1]
    x_scale, f_scale = float(lengths.max()), float(weight.sum())
    n_links = len(a)
    eye = np.eye(3)

    def unpack(z):
        return np.vstack([z[:3 * n_free].reshape(n_free, 3) * x_scale, pins]), z[3 * n_free:] * f_scale

    def residual(z):
        x, tension = unpack(z)
        d = x[b] - x[a]
        length = np.linalg.norm(d, axis=1)
        u = d / length[:, None]
        force = np.zeros((n_free + k, 3))
        np.add.at(force, a, tension[:, None] * u)
        np.add.at(force, b, -tension[:, None] * u)
        force[:n_free, 2] -= weight
        stiffness = tension[:, None, None] * (eye - u[:, :, None] * u[:, None, :]) / length[:, None, None]
        jac = np.zeros((3 * n_free + n_links, 3 * n_free + n_links))
        rows3, links = np.arange(3), np.arange(n_links)
        for p, q, sign in ((a, a, -1.0), (a, b, 1.0), (b, a, 1.0), (b, b, -1.0)):  # d force_p / d x_q
            free = (p < n_free) & (q < n_free)
            np.add.at(jac, (3 * p[free, None, None] + rows3[:, None], 3 * q[free, None, None] + rows3),
                      sign * stiffness[free] * (x_scale / f_scale))
        for p, sign in ((a, 1.0), (b, -1.0)):  # d force_p / d tension and d length / d x_p (= -sign u)
            free = p < n_free
            np.add.at(jac, (3 * p[free, None] + rows3, 3 * n_free + links[free, None]), sign * u[free])
            np.add.at(jac, (3 * n_free + links[free, None], 3 * p[free, None] + rows3), -sign * u[free])
        out = np.concatenate([force[:n_free].ravel() / f_scale, (length - rest) / x_scale])
        return out, jac

    start = np.concatenate([np.vstack([legs[0][:1]] + [leg[1:-1] for leg in legs]).ravel() / x_scale,
                            np.concatenate(link_tensions) / f_scale])
    sol = optimize.root(residual, start, jac=True, method="hybr", options={"xtol": _ROOT_XTOL})
    out, jac = residual(sol.x)
    worst = float(np.max(np.abs(out)))
    if not worst < _RESIDUAL_TOLERANCE:
        raise RuntimeError(f"y_harness did not converge (largest scaled residual {worst:.3g}): {sol.message}")
    # Stability: -d force / d x is the Hessian of the Lagrangian; on the links' tangent space it must be > 0.
    tangent = linalg.null_space(jac[3 * n_free:, :3 * n_free])
    curvature = linalg.eigvalsh(tangent.T @ -jac[:3 * n_free, :3 * n_free] @ tangent)
    if curvature.size and not curvature[0] > -_STABILITY_TOLERANCE * np.abs(curvature).max():
        raise RuntimeError("y_harness found only an unstable rest state near the catenaries (a link pushes and the "
                           "chain would buckle); use more segments on the legs that fold back to the junction")
    x, tension = unpack(sol.x)
    splits = np.cumsum(n)[:-1]
    return [x[ix] for ix in index], np.split(tension, splits)


def _check_per_leg(name: str, value, k: int, unit: str) -> np.ndarray:
    v = np.asarray(value, dtype=np.float64) if np.ndim(value) == 1 else None
    if v is None or v.shape != (k,) or not np.all(np.isfinite(v)) or not np.all(v > 0):
        raise ValueError(f"{name} must be {k} finite numbers > 0 in {unit}, one per pin, got {value!r}")
    return v


def y_harness(pins, lengths, masses, n_segments: Optional[Sequence[int]] = None, *,
              gravity=(0.0, 0.0, -G)) -> Harness:
    """The rest state of k ≥ 2 heavy inextensible legs joined at one junction, leg i's far end pinned at P_i.

    Args:
      pins: ``(k, 3)`` the pins P_i in metres.
      lengths: ``(k,)`` leg lengths L_i in metres; the legs must be able to meet at one point with slack.
      masses: ``(k,)`` leg masses m_i in kg, uniform along each leg.
      n_segments: ``None`` for the continuous reference (catenaries, no mass at J), or k segment counts n_i ≥ 1
        for the discrete one (chains of rigid links, masses lumped on the particles).
      gravity: ``(3,)`` m/s², non-zero.

    Returns:
      The :class:`Harness`.

    Raises:
      ValueError: a bad argument, or legs too short to meet.
      RuntimeError: the root-finder did not converge.

    Example::

        pins = [[0.5, 0, 1.0], [-0.25, 0.433, 0.9], [-0.25, -0.433, 0.8]]
        h = y_harness(pins, [0.6, 0.6, 0.6], [0.05, 0.05, 0.05], [30, 30, 30])
        h.junction                # (3,) m
        h.pin_forces.sum(axis=0)  # (0, 0, 1.4715) N: the harness' weight, up
    """
    pins = _check_points("pins", pins)
    k = len(pins)
    if k < 2:
        raise ValueError(f"pins must hold at least 2 points (one per leg), got shape {pins.shape}")
    lengths = _check_per_leg("lengths", lengths, k, "metres")
    masses = _check_per_leg("masses", masses, k, "kg")
    if n_segments is not None:
        if isinstance(n_segments, (str, bytes)) or np.ndim(n_segments) != 1 or len(n_segments) != k:
            raise ValueError(f"n_segments must be None or {k} integers >= 1, one per pin, got {n_segments!r}")
        n_segments = tuple(_validate.integer(f"n_segments[{i}]", n, low=1) for i, n in enumerate(n_segments))
    g_vec = np.asarray(_validate.vec3("gravity", gravity, unit="m/s²"))
    g = float(np.linalg.norm(g_vec))
    if g == 0.0:
        raise ValueError(f"gravity must be non-zero (a weightless harness has no unique rest shape), got {gravity!r}")

    rotation = _up_frame(g_vec)
    p = pins @ rotation.T
    meet, reach = _meeting_point(p, lengths)
    if not reach < 1.0 - _MIN_SLACK:
        gaps = np.linalg.norm(meet - p, axis=1) - lengths
        raise ValueError(f"lengths {lengths.tolist()} m are too short for the legs to meet at one point: at the best "
                         f"junction the legs lack {np.round(gaps, 9).tolist()} m; each leg must reach a common point "
                         f"from its pin with slack (|J - P_i| < L_i)")

    weights = g * masses
    if n_segments is None:
        lifts = [None] * k
        junction_weight = 0.0
    else:
        lumped = [_lumped_masses(m, n) for m, n in zip(masses, n_segments)]
        lifts = [g * np.concatenate([[0.0], np.cumsum(mj[1:-1])]) for mj in lumped]
        junction_weight = g * sum(mj[0] for mj in lumped)
    scale = np.array([lengths.max(), weights.sum()])
    start = np.concatenate([meet] + [_start_force(meet, p[i], lengths[i], weights[i]) for i in range(k)])
    # The catenaries first (smooth in the forces), then the chains from there.
    x, worst, message = _balance(p, lengths, weights, [None] * k, 0.0, start, scale)
    if n_segments is None:
        if not worst < _RESIDUAL_TOLERANCE:
            raise RuntimeError(f"y_harness did not converge (largest scaled residual {worst:.3g}): {message}")
        junction, forces = x[:3], x[3:].reshape(k, 3)
        s = np.linspace(0.0, 1.0, LEG_SAMPLES)
        legs = [junction + _reach(forces[i], lengths[i], weights[i], None, lengths[i] * s) for i in range(k)]
        tensions = np.linalg.norm(forces, axis=1)
        pin_forces = forces + weights[:, None] * _UP
    else:
        x, worst, message = _balance(p, lengths, weights, lifts, junction_weight,
                                     x if worst < _RESIDUAL_TOLERANCE else start, scale)
        junction, forces = x[:3], x[3:].reshape(k, 3)
        legs = [junction + _reach(forces[i], lengths[i], weights[i], lifts[i]) for i in range(k)]
        link_tensions = [np.linalg.norm(forces[i] + lifts[i][:, None] * _UP, axis=1) for i in range(k)]
        if not worst < _RESIDUAL_TOLERANCE:  # no rest state with every link in tension: let links push
            legs, link_tensions = _rigid_links(p, lumped, lengths, g, legs, link_tensions)
        tensions = np.array([t[0] for t in link_tensions])
        pin_forces = np.array([t[-1] * (leg[-1] - leg[-2]) / np.linalg.norm(leg[-1] - leg[-2]) + g * mj[-1] * _UP
                               for t, leg, mj in zip(link_tensions, legs, lumped)])
    return Harness(junction=legs[0][0] @ rotation, legs=tuple(leg @ rotation for leg in legs),
                   pin_forces=pin_forces @ rotation, tensions=tensions, n_segments=n_segments)


def harness_error(positions_per_leg, harness: Harness) -> float:
    """The largest distance in metres of a model's particles from the reference.

    Args:
      positions_per_leg: k arrays of particle positions in metres, leg i ordered like ``harness.legs[i]`` (from
        the junction to the pin; reverse a cable that runs the other way).
      harness: the reference; a discrete one (:func:`y_harness` with ``n_segments``) compares particle i with
        particle i (the arrays must have its legs' shapes), a continuous one measures each particle's distance to
        its leg's curve (:func:`mjcable.reference.distance_to_curve`).

    Returns:
      The largest distance in metres over every particle of every leg.
    """
    if isinstance(positions_per_leg, np.ndarray) or len(positions_per_leg) != len(harness.legs):
        raise ValueError(f"positions_per_leg must be a sequence of {len(harness.legs)} (n, 3) arrays, one per leg, "
                         f"got {type(positions_per_leg).__name__} of length {len(positions_per_leg)}")
    worst = 0.0
    for i, (x, leg) in enumerate(zip(positions_per_leg, harness.legs)):
        x = _check_points(f"positions_per_leg[{i}]", x)
        if harness.n_segments is None:
            worst = max(worst, float(distance_to_curve(x, leg).max()))
            continue
        if x.shape != leg.shape:
            raise ValueError(f"positions_per_leg[{i}] must have shape {leg.shape} (leg {i}'s particles), got {x.shape}")
        worst = max(worst, float(np.linalg.norm(x - leg, axis=1).max()))
    return worst
