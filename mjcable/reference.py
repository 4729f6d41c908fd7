"""Independent physical references for the cable benchmarks.

Closed forms and well-posed boundary-value problems, none of which runs a cable model:

* :func:`catenary`: the inextensible catenary between two points (``scipy.optimize.brentq`` on its parameter);
  :func:`distance_to_curve` measures particles against it.
* :func:`discrete_catenary`: the exact static shape of the *discrete* chain (``n`` rigid links, lumped masses), the
  limit every particle model with ``n_segments`` segments converges to; it tends to :func:`catenary` as ``n`` grows.
* :func:`chain_frequency`: the hanging chain's mode-1 angular frequency ω₁ = (z₁ / 2) √(g / L), with z₁ the first zero
  of the Bessel function J₀; :func:`discrete_chain_frequencies` gives the lumped-mass chain's modes.
* :func:`cantilever`: the heavy cantilever (Euler elastica under its own weight, clamped horizontally), solved with
  ``scipy.integrate.solve_bvp``; it tends to beam theory's tip deflection q L⁴ / (8 E I) for small loads.
* :func:`free_fall`: z(t) = z₀ + v₀ t − g t² / 2.
* :func:`capstan_ratio`, :func:`heavy_capstan_beta`, :func:`heavy_capstan_ratio` and
  :func:`heavy_capstan_long_leg`: the capstan law e^{μθ} and its heavy-rope form for a rope hanging over a
  horizontal peg, (L_long − β) / (L_short + β) < e^{μπ} with β = 2 μ R_c / (1 + μ²).
* :func:`incline_acceleration`: Coulomb's sliding acceleration on an incline, g (sin θ − μ cos θ), or 0 while
  tan θ ≤ μ (it sticks).
* :func:`table_rest` and :func:`drape_rest_distance`: the ideal rest states of the ``table`` and ``drape`` scenes
  (a uniform fall with sticking friction; two vertical strands hanging from the peg), and :func:`converged`, which
  shows a model's finest setting converged by halving ``dt``.

All functions take SI units; gravity is ``g = 9.81`` m/s² along −z unless given.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable

import numpy as np
from scipy import integrate, optimize, special

from mjcable import _validate

__all__ = [
    "G",
    "BESSEL_Z1",
    "Catenary",
    "catenary",
    "catenary_sag",
    "discrete_catenary",
    "distance_to_curve",
    "chain_frequency",
    "discrete_chain_frequencies",
    "chain_mode_shape",
    "Cantilever",
    "cantilever",
    "beam_tip_deflection",
    "free_fall",
    "capstan_ratio",
    "heavy_capstan_beta",
    "heavy_capstan_ratio",
    "heavy_capstan_long_leg",
    "incline_acceleration",
    "table_rest",
    "drape_rest_curve",
    "drape_rest_distance",
    "Convergence",
    "converged",
]

G = 9.81  # m/s², the magnitude of mjcable.scene.GRAVITY
BESSEL_Z1 = float(special.jn_zeros(0, 1)[0])  # first zero of J₀, 2.404825557695773
_ROOT_XTOL = 1e-15  # absolute tolerance of the brentq root-finds (dimensionless or metres)
_BVP_TOL = 1e-8  # residual tolerance of solve_bvp
_BVP_NODES = 201  # initial mesh of solve_bvp
_CURVE_SAMPLES = 4001  # points on a reference curve when measuring distances to it
_DISTANCE_CHUNK = 64  # particles per vectorised block in distance_to_curve
_LEVEL_TOLERANCE = 1e-9  # m: ends of a discrete catenary this close in height count as level
_LOG_TENSION_RANGE = 60.0  # brentq bracket of log(horizontal tension / link weight) for the discrete catenary


def _check_positive(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number > 0, got {value!r}")
    v = float(value)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    return v


def _check_points(name: str, value) -> np.ndarray:
    p = np.asarray(value, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or not np.all(np.isfinite(p)):
        raise ValueError(f"{name} must be an (n, 3) array of finite metres, got shape {np.shape(value)}")
    return p


# --------------------------------------------------------------------------------------------------- catenary


@dataclasses.dataclass(frozen=True)
class Catenary:
    """An inextensible catenary in the vertical plane through its two ends.

    Attributes:
      start, end: ``(3,)`` end points in metres.
      length: arc length in metres.
      a: catenary parameter H / w in metres (horizontal tension over weight per metre).
      x0: horizontal distance in metres from ``start`` to the lowest point of the full catenary (may lie outside
        the span when the ends are at different heights).
    """

    start: np.ndarray
    end: np.ndarray
    length: float
    a: float
    x0: float

    @property
    def span(self) -> float:
        """Horizontal distance between the ends in metres."""
        return float(np.hypot(*(self.end - self.start)[:2]))

    def _height(self, u: np.ndarray) -> np.ndarray:
        """Height above ``start`` at horizontal distance ``u`` from it."""
        return self.a * (np.cosh((u - self.x0) / self.a) - np.cosh(self.x0 / self.a))

    def _to_world(self, u: np.ndarray) -> np.ndarray:
        d = self.end - self.start
        horizontal = np.array([d[0], d[1], 0.0])
        norm = np.linalg.norm(horizontal)
        direction = horizontal / norm if norm > 0 else np.array([1.0, 0.0, 0.0])
        return self.start + u[:, None] * direction + self._height(u)[:, None] * np.array([0.0, 0.0, 1.0])

    def points(self, n: int = 101) -> np.ndarray:
        """``(n, 3)`` points at equal arc length from ``start`` to ``end`` (metres)."""
        return self.at_arclength(np.linspace(0.0, self.length, int(n)))

    def at_arclength(self, s) -> np.ndarray:
        """``(len(s), 3)`` points at arc lengths ``s`` (metres, 0 ≤ s ≤ length) from ``start``."""
        s = np.asarray(s, dtype=np.float64)
        u = self.x0 + self.a * np.arcsinh(s / self.a - np.sinh(self.x0 / self.a))
        return self._to_world(u)

    @property
    def sag(self) -> float:
        """Depth in metres of the lowest point below the lower end (below both ends when they are level)."""
        u_low = min(max(self.x0, 0.0), self.span)
        low = self._height(np.array([u_low]))[0]
        return float(min(0.0, self.end[2] - self.start[2]) - low)

    @property
    def lowest(self) -> np.ndarray:
        """``(3,)`` the lowest point in metres."""
        u_low = min(max(self.x0, 0.0), self.span)
        return self._to_world(np.array([u_low]))[0]


def catenary(start, end, length: float) -> Catenary:
    """The inextensible catenary of arc length ``length`` hanging between ``start`` and ``end``.

    Solves ``√(L² − v²) = 2 a sinh(h / (2a))`` for the parameter ``a`` (``h`` the horizontal and ``v`` the vertical
    distance between the ends) with ``scipy.optimize.brentq``.

    Args:
      start, end: ``(3,)`` end points in metres, not on one vertical line.
      length: arc length in metres, longer than the straight distance between the ends.

    Returns:
      The :class:`Catenary`.

    Example::

        c = catenary([-0.4, 0, 1], [0.4, 0, 1], 1.0)
        c.sag  # 0.2654 m
    """
    p0 = np.asarray(start, dtype=np.float64)
    p1 = np.asarray(end, dtype=np.float64)
    if p0.shape != (3,) or p1.shape != (3,) or not (np.all(np.isfinite(p0)) and np.all(np.isfinite(p1))):
        raise ValueError(f"start and end must be 3 finite numbers in metres, got {start!r} and {end!r}")
    length = _check_positive("length", length)
    h = float(np.hypot(*(p1 - p0)[:2]))
    v = float(p1[2] - p0[2])
    chord = math.hypot(h, v)
    if h <= 0:
        raise ValueError(f"start and end must not lie on one vertical line, got {start!r} and {end!r}")
    if length <= chord:
        raise ValueError(f"length must exceed the straight distance {chord:.6g} m between the ends, got {length!r}")
    target = math.sqrt(length**2 - v**2)
    # b = h / (2a): sinh(b) / b = target / h > 1 has one positive root.
    ratio = target / h
    hi = 1.0
    while math.sinh(hi) / hi < ratio:
        hi *= 2.0
    b = optimize.brentq(lambda b: math.sinh(b) / b - ratio, 1e-12, hi, xtol=_ROOT_XTOL, rtol=4 * np.finfo(float).eps)
    a = h / (2.0 * b)
    # The lowest point's horizontal offset: v = a (cosh((h − x0)/a) − cosh(x0/a)).
    x0 = h / 2.0 - a * math.asinh(v / (2.0 * a * math.sinh(b)))
    return Catenary(start=p0, end=p1, length=length, a=a, x0=x0)


def catenary_sag(length: float, span: float) -> float:
    """Sag in metres of an inextensible catenary of ``length`` between two level points ``span`` apart.

    Example::

        catenary_sag(1.0, 0.8)  # 0.2654 m
    """
    span = _check_positive("span", span)
    return catenary([0.0, 0.0, 0.0], [span, 0.0, 0.0], length).sag


def discrete_catenary(start, end, length: float, n_segments: int, masses=None) -> np.ndarray:
    """Static shape of the inextensible discrete chain: ``n_segments`` rigid links of ``length / n_segments``
    between the level points ``start`` and ``end``, with lumped masses on its joints.

    The link from joint i to i + 1 carries the horizontal tension H and the vertical force V − Σ_{0<j≤i} m_j g; its
    direction follows. By symmetry of the supports V is half the weight of the free joints; H is found with
    ``brentq`` so that the links span the distance between the ends. As ``n_segments`` grows the joints approach
    :func:`catenary`.

    Args:
      start, end: ``(3,)`` end points in metres at equal height.
      length: chain length in metres, longer than the span.
      n_segments: number of links (>= 2).
      masses: ``(n_segments + 1,)`` joint masses (any scale: the shape depends only on their ratios; the pinned
        ends' masses do not matter); default equal.

    Returns:
      ``(n_segments + 1, 3)`` joint positions in metres.
    """
    p0 = np.asarray(start, dtype=np.float64)
    p1 = np.asarray(end, dtype=np.float64)
    length = _check_positive("length", length)
    if isinstance(n_segments, bool) or not isinstance(n_segments, (int, np.integer)) or n_segments < 2:
        raise ValueError(f"n_segments must be an integer >= 2, got {n_segments!r}")
    n = int(n_segments)
    span = float(np.linalg.norm(p1 - p0))
    if abs(p1[2] - p0[2]) > _LEVEL_TOLERANCE:
        raise ValueError(f"discrete_catenary needs level ends, got heights {p0[2]!r} and {p1[2]!r}")
    if not span < length:
        raise ValueError(f"length must exceed the span {span:.6g} m, got {length!r}")
    m = np.ones(n + 1) if masses is None else np.asarray(masses, dtype=np.float64)
    if m.shape != (n + 1,) or not np.all(m > 0):
        raise ValueError(f"masses must be {n + 1} positive numbers, got shape {m.shape}")
    w = m[1:-1]  # weights of the free joints (g cancels)
    vertical = 0.5 * w.sum() - np.concatenate([[0.0], np.cumsum(w)])  # (n,) upward force carried by each link
    l0 = length / n

    def span_of(log_h):
        h = math.exp(log_h)
        return float(np.sum(l0 * h / np.hypot(h, vertical))) - span

    log_h = optimize.brentq(span_of, -_LOG_TENSION_RANGE, _LOG_TENSION_RANGE, xtol=_ROOT_XTOL)
    h = math.exp(log_h)
    norm = np.hypot(h, vertical)
    dx = l0 * h / norm
    dz = -l0 * vertical / norm
    direction = (p1 - p0) / span
    steps = dx[:, None] * direction + dz[:, None] * np.array([0.0, 0.0, 1.0])
    return p0 + np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)])


def distance_to_curve(positions, curve, *, samples: int = _CURVE_SAMPLES) -> np.ndarray:
    """Distance in metres of each particle to a reference curve (nearest point on the densely sampled polyline).

    Args:
      positions: ``(n, 3)`` particles in metres.
      curve: a :class:`Catenary`, or an ``(m, 3)`` polyline in metres.
      samples: points on a :class:`Catenary` (ignored for a polyline).

    Returns:
      ``(n,)`` distances in metres.
    """
    x = _check_points("positions", positions)
    poly = curve.points(samples) if isinstance(curve, Catenary) else _check_points("curve", curve)
    a, b = poly[:-1], poly[1:]
    ab = b - a
    denom = np.maximum(np.einsum("ij,ij->i", ab, ab), np.finfo(float).tiny)
    out = np.empty(len(x))
    for start in range(0, len(x), _DISTANCE_CHUNK):  # bounded memory: a chunk of particles × m segments at a time
        chunk = x[start:start + _DISTANCE_CHUNK]
        t = np.einsum("pij,ij->pi", chunk[:, None, :] - a[None], ab) / denom
        t = np.clip(t, 0.0, 1.0)
        nearest = a[None] + t[..., None] * ab[None]
        out[start:start + _DISTANCE_CHUNK] = np.sqrt(np.min(np.sum((chunk[:, None, :] - nearest) ** 2, axis=2), axis=1))
    return out


# ----------------------------------------------------------------------------------------------- hanging chain


def chain_frequency(length: float, *, g: float = G) -> float:
    """Mode-1 angular frequency ω₁ = (z₁ / 2) √(g / L) in rad/s of a uniform chain of ``length`` metres hanging
    from one end (z₁ = 2.40483, the first zero of J₀).

    Example::

        2 * math.pi / chain_frequency(1.0)  # period 1.672 s
    """
    return 0.5 * BESSEL_Z1 * math.sqrt(_check_positive("g", g) / _check_positive("length", length))


def chain_mode_shape(s, length: float) -> np.ndarray:
    """Mode-1 lateral displacement (unit amplitude at the free end) at arc length ``s`` from the top:
    J₀(z₁ √((L − s) / L)) (Bernoulli's hanging chain)."""
    s = np.asarray(s, dtype=np.float64)
    length = _check_positive("length", length)
    return special.j0(BESSEL_Z1 * np.sqrt(np.clip((length - s) / length, 0.0, 1.0)))


def discrete_chain_frequencies(masses, length: float, *, g: float = G) -> np.ndarray:
    """Angular frequencies in rad/s of small swings of a chain of point masses joined by rigid massless links of
    equal length, hanging from a fixed top joint (``masses[0]``, which does not move).

    Linearised: link i carries the tension T_i = g Σ_{j>i} m_j; the lateral motion obeys
    m_j ẍ_j = T_j (x_{j+1} − x_j) / l − T_{j−1} (x_j − x_{j−1}) / l, a symmetric generalised eigenproblem.

    Args:
      masses: ``(n_segments + 1,)`` joint masses in kg, top first.
      length: chain length in metres.

    Returns:
      ``(n_segments,)`` angular frequencies in rad/s, ascending.
    """
    m = np.asarray(masses, dtype=np.float64)
    if m.ndim != 1 or len(m) < 2 or not np.all(m > 0):
        raise ValueError(f"masses must be >= 2 positive numbers in kg, got {masses!r}")
    length = _check_positive("length", length)
    n = len(m) - 1
    l0 = length / n
    free = m[1:]
    tension = g * np.cumsum(free[::-1])[::-1]  # tension[i]: link from joint i to i+1 carries joints i+1..n
    k = np.zeros((n, n))
    for i in range(n):  # link i joins joint i (fixed when i == 0) and joint i + 1
        c = tension[i] / l0
        k[i, i] += c
        if i > 0:
            k[i - 1, i - 1] += c
            k[i - 1, i] -= c
            k[i, i - 1] -= c
    # K x = ω² M x  →  M^{-1/2} K M^{-1/2} y = ω² y
    s = 1.0 / np.sqrt(free)
    eig = np.linalg.eigvalsh(s[:, None] * k * s[None, :])
    return np.sqrt(np.clip(eig, 0.0, None))


# -------------------------------------------------------------------------------------------------- cantilever


@dataclasses.dataclass(frozen=True)
class Cantilever:
    """The heavy cantilever's static shape.

    Attributes:
      s: ``(m,)`` arc length from the clamp in metres.
      x: ``(m,)`` horizontal distance from the clamp in metres.
      z: ``(m,)`` height relative to the clamp in metres (negative: below).
      theta: ``(m,)`` tangent angle in radians from the horizontal.
      load: the dimensionless load q L³ / (E I).
    """

    s: np.ndarray
    x: np.ndarray
    z: np.ndarray
    theta: np.ndarray
    load: float

    @property
    def tip_deflection(self) -> float:
        """Vertical drop of the free end in metres (positive downwards)."""
        return float(-self.z[-1])

    def points(self, origin=(0.0, 0.0, 0.0), direction=(1.0, 0.0, 0.0)) -> np.ndarray:
        """``(m, 3)`` the shape in world coordinates: clamp at ``origin``, pointing along horizontal ``direction``."""
        d = np.asarray(direction, dtype=np.float64)
        d = d / np.linalg.norm(d)
        return np.asarray(origin, dtype=np.float64) + self.x[:, None] * d + self.z[:, None] * np.array([0, 0, 1.0])

    def at_arclength(self, s) -> np.ndarray:
        """``(len(s), 2)`` (x, z) at arc lengths ``s`` in metres, by interpolation on the solver's mesh."""
        s = np.asarray(s, dtype=np.float64)
        return np.stack([np.interp(s, self.s, self.x), np.interp(s, self.s, self.z)], axis=1)


def beam_tip_deflection(length: float, weight_per_length: float, bending_stiffness: float) -> float:
    """Euler-Bernoulli tip deflection q L⁴ / (8 E I) in metres of a horizontal cantilever under its own weight."""
    return (_check_positive("weight_per_length", weight_per_length) * _check_positive("length", length) ** 4
            / (8.0 * _check_positive("bending_stiffness", bending_stiffness)))


def cantilever(length: float, weight_per_length: float, bending_stiffness: float, *,
               nodes: int = _BVP_NODES) -> Cantilever:
    """The inextensible heavy elastica: a rod clamped horizontally at s = 0, free at s = L, bent by its own weight.

    With θ(s) the tangent angle from the horizontal, moment balance of the rod beyond s gives
    E I θ''(s) = q (L − s) cos θ(s), with θ(0) = 0 (clamp) and θ'(L) = 0 (free end, no moment); x' = cos θ,
    z' = sin θ. Solved in the dimensionless arc length σ = s / L with ``scipy.integrate.solve_bvp``, continuing
    the load from beam theory's shape so large loads converge.

    Args:
      length: rod length L in metres.
      weight_per_length: q = ρ A g in N/m.
      bending_stiffness: E I in N·m².
      nodes: initial mesh size.

    Returns:
      The :class:`Cantilever` (its ``tip_deflection`` → q L⁴ / (8 E I) as q L³ / (E I) → 0).

    Example::

        cantilever(1.0, 0.981, 9.81).tip_deflection  # ≈ 0.0124 m (beam theory: 0.0125 m)
    """
    length = _check_positive("length", length)
    beta = (_check_positive("weight_per_length", weight_per_length) * length**3
            / _check_positive("bending_stiffness", bending_stiffness))
    sigma = np.linspace(0.0, 1.0, int(nodes))

    def rhs(sig, y, b):
        theta, kappa, _, _ = y
        return np.vstack([kappa, b * (1.0 - sig) * np.cos(theta), np.cos(theta), np.sin(theta)])

    def bc(ya, yb):
        return np.array([ya[0], yb[1], ya[2], ya[3]])

    # Start from beam theory at a small load and continue geometrically up to beta.
    steps = max(1, int(math.ceil(math.log2(max(beta, 1.0)))) + 1)
    loads = beta * np.logspace(-steps, 0, steps + 1, base=2.0) if beta > 1.0 else np.array([beta])
    b0 = loads[0]
    theta = -b0 / 6.0 * (1.0 - (1.0 - sigma) ** 3)
    y = np.vstack([theta, -b0 / 2.0 * (1.0 - sigma) ** 2, sigma, np.zeros_like(sigma)])
    y[2] = integrate.cumulative_trapezoid(np.cos(theta), sigma, initial=0.0)
    y[3] = integrate.cumulative_trapezoid(np.sin(theta), sigma, initial=0.0)
    mesh = sigma
    for b in loads:
        sol = integrate.solve_bvp(lambda s_, y_: rhs(s_, y_, b), bc, mesh, y, tol=_BVP_TOL, max_nodes=100_000)
        if not sol.success:
            raise RuntimeError(f"solve_bvp did not converge for the load q L³/(E I) = {b:.6g}: {sol.message}")
        mesh, y = sol.x, sol.y
    return Cantilever(s=mesh * length, x=y[2] * length, z=y[3] * length, theta=y[0], load=float(beta))


# -------------------------------------------------------------------------------------------------- free fall


def free_fall(t, z0: float, v0: float = 0.0, *, g: float = G) -> np.ndarray:
    """Height z(t) = z₀ + v₀ t − g t² / 2 in metres at times ``t`` (seconds)."""
    t = np.asarray(t, dtype=np.float64)
    return z0 + v0 * t - 0.5 * g * t**2


# ------------------------------------------------------------------------------------------------ friction laws


def capstan_ratio(mu: float, theta: float = math.pi) -> float:
    """The capstan (Euler-Eytelwein) law for a weightless rope: e^{μθ}, the largest ratio of the tensions at the
    two ends of a rope wrapped ``theta`` radians (>= 0) around a fixed round post with friction ``mu`` (>= 0)."""
    return math.exp(_validate.number("mu", mu, low=0.0) * _validate.number("theta", theta, low=0.0, unit="rad"))


def heavy_capstan_beta(mu: float, radius: float) -> float:
    """β = 2 μ R_c / (1 + μ²) in metres: the heavy-rope capstan's correction of the leg lengths.

    A uniform rope of weight w per metre hangs over a horizontal round peg, in contact over the upper half circle
    of centreline radius R_c (the peg's radius plus the rope's), both legs vertical. With φ the angle from the
    horizontal through the peg's axis (−π/2 at the short leg's tangent point, π/2 at the long one's), the tension on
    the arc at the point of slipping obeys dT/dφ = μ (T + w R_c cos φ) − w R_c sin φ (normal force per angle
    T + w R_c cos φ, tangential weight w R_c sin φ). Its solution T = C e^{μφ} + w R_c ((1 − μ²) cos φ + 2 μ sin φ)
    / (1 + μ²) gives T(π/2) − wβ = e^{μπ} (T(−π/2) + wβ), with T = w L at each tangent point.

    Args:
      mu: Coulomb friction coefficient (>= 0).
      radius: R_c in metres, the radius of the rope's centreline around the peg's axis (> 0).
    """
    mu = _validate.number("mu", mu, low=0.0)
    return 2.0 * mu * _check_positive("radius", radius) / (1.0 + mu * mu)


def heavy_capstan_ratio(long: float, short: float, mu: float, radius: float) -> float:
    """(L_long − β) / (L_short + β) (:func:`heavy_capstan_beta`) for legs ``long`` and ``short`` in metres below
    the peg's axis, ``mu`` and R_c = ``radius`` (m): the rope holds while this is below e^{μπ}."""
    beta = heavy_capstan_beta(mu, radius)
    return (_check_positive("long", long) - beta) / (_check_positive("short", short) + beta)


def heavy_capstan_long_leg(short: float, mu: float, radius: float, *, factor: float = 1.0) -> float:
    """The long leg in metres at which :func:`heavy_capstan_ratio` equals ``factor`` · e^{μπ} (``short`` and R_c =
    ``radius`` in metres): for ``factor`` = 1 the longest that holds, L_long = e^{μπ} (L_short + β) + β."""
    beta = heavy_capstan_beta(mu, radius)
    return _check_positive("factor", factor) * capstan_ratio(mu) * (_check_positive("short", short) + beta) + beta


def incline_acceleration(mu: float, tilt: float, *, g: float = G) -> float:
    """Coulomb's acceleration in m/s² of a body released at rest on a plane tilted ``tilt`` radians from the
    horizontal: g (sin θ − μ cos θ) when tan θ > μ (it slides down the slope), else 0 (static friction holds it).

    Args:
      mu: friction coefficient (>= 0).
      tilt: θ in radians, in [0, π/2).
      g: gravity in m/s².
    """
    mu = _validate.number("mu", mu, low=0.0)
    tilt = _validate.number("tilt", tilt, low=0.0, high=math.pi / 2, high_open=True, unit="rad")
    return max(_check_positive("g", g) * (math.sin(tilt) - mu * math.cos(tilt)), 0.0)


# ---------------------------------------------------------------------------------------- scenes with contact


def table_rest(start_positions, table_top: float, radius: float) -> np.ndarray:
    """Ideal rest state of a cable dropped flat onto a table.

    A cable released at rest in a horizontal plane falls uniformly (no internal forces), lands everywhere at once
    and sticks (friction, no tangential velocity): its rest shape is the start shape lowered until the cable's
    surface touches the table top.

    Args:
      start_positions: ``(n, 3)`` start particles in metres, all at one height (else ``ValueError``).
      table_top: height of the table's top face in metres.
      radius: cable radius in metres.

    Returns:
      ``(n, 3)`` rest positions in metres.
    """
    p = _check_points("start_positions", start_positions).copy()
    if np.ptp(p[:, 2]) > _LEVEL_TOLERANCE:
        raise ValueError(f"start_positions must all lie at one height for this reference, got heights from "
                         f"{p[:, 2].min():.6g} to {p[:, 2].max():.6g} m")
    p[:, 2] = table_top + radius
    return p


def drape_rest_curve(peg_center, peg_radius: float, cable_radius: float, *, strand_length: float,
                     samples: int = 401) -> np.ndarray:
    """The ideal rest set of a limp cable draped over a horizontal peg along y: a half circle of radius
    ``peg_radius + cable_radius`` over the top of the peg, continued by two vertical strands of ``strand_length``.

    Args:
      peg_center: ``(3,)`` the peg's axis point in the cable's plane (metres).
      peg_radius, cable_radius: metres.
      strand_length: length of each vertical strand in metres (at least the longer hanging part).
      samples: points on the arc.

    Returns:
      ``(m, 3)`` polyline in metres, from the bottom of the −x strand over the peg to the bottom of the +x strand.
    """
    c = np.asarray(peg_center, dtype=np.float64)
    r = _check_positive("peg_radius", peg_radius) + _check_positive("cable_radius", cable_radius)
    strand = _check_positive("strand_length", strand_length)
    phi = np.linspace(math.pi, 0.0, int(samples))
    arc = c + r * np.stack([np.cos(phi), np.zeros_like(phi), np.sin(phi)], axis=1)
    left = np.array([c + [-r, 0.0, -strand]])
    right = np.array([c + [r, 0.0, -strand]])
    return np.concatenate([left, arc, right])


def drape_rest_distance(positions, peg_center, peg_radius: float, cable_radius: float) -> np.ndarray:
    """Distance in metres of each particle to :func:`drape_rest_curve` (strands long enough for the cable)."""
    x = _check_points("positions", positions)
    strand = float(np.ptp(x[:, 2])) + 1.0
    return distance_to_curve(x, drape_rest_curve(peg_center, peg_radius, cable_radius, strand_length=strand))


@dataclasses.dataclass(frozen=True)
class Convergence:
    """A reference computed with a model's finest setting, and its change when ``dt`` is halved.

    Attributes:
      positions: ``(n, 3)`` the result at ``dt / 2`` (metres).
      coarse: ``(n, 3)`` the result at ``dt``.
      change: RMS distance in metres between the two (the reference's own uncertainty).
      dt: the coarser step in seconds.
    """

    positions: np.ndarray
    coarse: np.ndarray
    change: float
    dt: float


def converged(run: Callable[[float], np.ndarray], dt: float) -> Convergence:
    """Run ``run(dt)`` and ``run(dt / 2)`` and report how much halving ``dt`` changed the result.

    Args:
      run: maps a step in seconds to ``(n, 3)`` final positions in metres (e.g. a closure over a scene and a
        model's finest settings).
      dt: the step in seconds.

    Returns:
      The :class:`Convergence`; a reference is converged for a comparison when ``change`` is below the errors
      it is used to report.
    """
    dt = _check_positive("dt", dt)
    coarse = _check_points("run(dt)", run(dt))
    fine = _check_points("run(dt / 2)", run(dt / 2.0))
    change = float(np.sqrt(np.mean(np.sum((fine - coarse) ** 2, axis=1))))
    return Convergence(positions=fine, coarse=coarse, change=change, dt=dt)

