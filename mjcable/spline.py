"""Catmull-Rom curves and equal-chord resampling: the cable's initial state.

A :class:`CatmullRom` curve passes through its control points. It is stored as cubic Bézier pieces, one per
pair of consecutive control points, with the curve parameter ``t`` normalised to ``[0, 1]`` (piece ``i`` covers
``t ∈ [i / (m - 1), (i + 1) / (m - 1)]`` for ``m`` control points).

:func:`resample` places particles on the curve at exactly equal chords, so that the start state satisfies the
cable's distance constraints exactly (a start state off the constraints kicks velocities by C/dt on the first step).
"""

from __future__ import annotations

import numba
import numpy as np
from scipy import optimize

__all__ = ["CatmullRom", "resample", "KINDS"]

KINDS = ("centripetal", "uniform")

_CENTRIPETAL_ALPHA = 0.5
_THESIS_HANDLE = 0.25  # the thesis's extended Catmull-Rom: handles ±¼·(p[i+1] − p[i−1])
_GAUSS_NODES, _GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(10)
_ARC_SUBDIVISIONS = 16  # Gauss-Legendre panels per Bézier piece for arc lengths
_DENSE_SAMPLES = 64  # samples per piece used to bracket equal-chord roots
_CHORD_XTOL = 1e-15
_NEWTON_MAX_ITER = 100
_CHORD_RTOL = 1e-9  # equal chords are promised to this relative accuracy, or to the march's round-off below
_MARCH_ROUND_OFF = 4.0  # ulps of the coordinates that each marched chord may add to the last one (measured: <= 1.2)
_BRACKET_SHRINKS = (1e-3, 3e-2, 0.3, 0.9, 0.999)
_ARC_MARGIN = 1e-9  # covers the quadrature error of the arc length on a straight curve
_CLOSED_MIN_SEGMENTS = 3  # a closed curve of fewer equal chords folds back on itself (one chord: of length 0)


def _as_control_points(points) -> np.ndarray:
    try:
        p = np.array(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"points must be an (m, 3) array of numbers, got {points!r}") from exc
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"points must have shape (m, 3) with m >= 2, got shape {p.shape}")
    if p.shape[0] < 2:
        raise ValueError(f"points needs at least 2 control points, got {p.shape[0]}")
    if not np.all(np.isfinite(p)):
        bad = np.argwhere(~np.isfinite(p))[0]
        raise ValueError(f"points must be finite, got {p[bad[0], bad[1]]} at points[{bad[0]}, {bad[1]}]")
    chords = np.linalg.norm(np.diff(p, axis=0), axis=1)
    scale = max(float(np.abs(p).max()), 1.0)
    repeated = np.flatnonzero(chords <= 1e-12 * scale)
    if repeated.size:
        i = int(repeated[0])
        raise ValueError(
            f"points must not repeat consecutively, but points[{i}] == points[{i + 1}] == {p[i].tolist()}"
        )
    p.setflags(write=False)
    return p


def _bezier_uniform(p: np.ndarray) -> np.ndarray:
    """The thesis's extended Catmull-Rom (§2.1.7): handles ±¼·(p[i+1] − p[i−1]), ¼ of the end chord at the ends."""
    tangents = np.empty_like(p)
    tangents[1:-1] = p[2:] - p[:-2]
    tangents[0] = p[1] - p[0]
    tangents[-1] = p[-1] - p[-2]
    b = np.empty((len(p) - 1, 4, 3))
    b[:, 0] = p[:-1]
    b[:, 1] = p[:-1] + _THESIS_HANDLE * tangents[:-1]
    b[:, 2] = p[1:] - _THESIS_HANDLE * tangents[1:]
    b[:, 3] = p[1:]
    return b


def _bezier_centripetal(p: np.ndarray) -> np.ndarray:
    """Centripetal Catmull-Rom (α = 0.5) as Bézier pieces, ends extended by reflected phantom points.

    Tangents of the Barry-Goldman pyramid (Yuksel et al. 2011, "Parameterization and applications of
    Catmull-Rom curves", eq. for the non-uniform Hermite tangents).
    """
    ext = np.concatenate([2 * p[:1] - p[1:2], p, 2 * p[-1:] - p[-2:-1]])
    dt = np.linalg.norm(np.diff(ext, axis=0), axis=1) ** _CENTRIPETAL_ALPHA  # knot spacings, (m + 1,)
    p0, p1, p2, p3 = ext[:-3], ext[1:-2], ext[2:-1], ext[3:]
    d0, d1, d2 = dt[:-2, None], dt[1:-1, None], dt[2:, None]
    m1 = (p1 - p0) / d0 - (p2 - p0) / (d0 + d1) + (p2 - p1) / d1
    m2 = (p2 - p1) / d1 - (p3 - p1) / (d1 + d2) + (p3 - p2) / d2
    b = np.empty((len(p) - 1, 4, 3))
    b[:, 0] = p1
    b[:, 1] = p1 + m1 * d1 / 3.0
    b[:, 2] = p2 - m2 * d1 / 3.0
    b[:, 3] = p2
    return b


class CatmullRom:
    """A Catmull-Rom curve through ``m >= 2`` control points.

    Args:
      points: ``(m, 3)`` control points in metres; consecutive points must differ.
      kind: ``"centripetal"`` (α = 0.5: no cusps or self-intersections within a piece; the default) or
        ``"uniform"``, the thesis's extended form (Bézier handles ±¼·(p[i+1] − p[i−1]), end handles ¼ of the end
        chord), kept on purpose although it differs from the textbook ⅙ handles.

    Two control points give a straight line. Example::

        curve = CatmullRom([[0, 0, 1], [0.4, 0, 0.8], [0.8, 0, 1]])
        curve.position(0.5), curve.length
    """

    def __init__(self, points, kind: str = "centripetal"):
        if kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
        self.points = _as_control_points(points)
        self.kind = kind
        self._bezier = _bezier_centripetal(self.points) if kind == "centripetal" else _bezier_uniform(self.points)
        self._bezier.setflags(write=False)

    def __repr__(self) -> str:
        return f"CatmullRom({len(self.points)} points, kind={self.kind!r}, length={self.length:.6g})"

    @property
    def n_pieces(self) -> int:
        return len(self._bezier)

    def _locate(self, t):
        t = np.asarray(t, dtype=np.float64)
        if np.any(~np.isfinite(t)) or np.any(t < 0.0) or np.any(t > 1.0):
            raise ValueError(f"t must lie in [0, 1], got {t}")
        s = t * self.n_pieces
        i = np.minimum(np.floor(s).astype(np.int64), self.n_pieces - 1)
        return i, (s - i)[..., None]

    def position(self, t) -> np.ndarray:
        """Point(s) on the curve at parameter ``t`` (scalar or array in [0, 1]); shape ``t.shape + (3,)``, metres."""
        i, u = self._locate(t)
        b = self._bezier[i]
        v = 1.0 - u
        return (v**3) * b[..., 0, :] + 3 * (v**2) * u * b[..., 1, :] + 3 * v * (u**2) * b[..., 2, :] + (u**3) * b[..., 3, :]

    def derivative(self, t) -> np.ndarray:
        """dP/dt at ``t``; shape ``t.shape + (3,)``, metres per unit parameter."""
        i, u = self._locate(t)
        b = self._bezier[i]
        v = 1.0 - u
        d = 3 * ((v**2) * (b[..., 1, :] - b[..., 0, :]) + 2 * u * v * (b[..., 2, :] - b[..., 1, :])
                 + (u**2) * (b[..., 3, :] - b[..., 2, :]))
        return d * self.n_pieces

    def tangent(self, t) -> np.ndarray:
        """Unit tangent at ``t``; shape ``t.shape + (3,)``."""
        d = self.derivative(t)
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def arc_length(self, t0: float = 0.0, t1: float = 1.0) -> float:
        """Arc length in metres between parameters ``t0 <= t1`` (Gauss-Legendre, 10 nodes × 16 panels per piece)."""
        if not 0.0 <= t0 <= t1 <= 1.0:
            raise ValueError(f"need 0 <= t0 <= t1 <= 1, got t0={t0}, t1={t1}")
        panels = max(1, int(np.ceil((t1 - t0) * self.n_pieces * _ARC_SUBDIVISIONS)))
        edges = np.linspace(t0, t1, panels + 1)
        half = 0.5 * np.diff(edges)[:, None]
        nodes = (0.5 * (edges[:-1] + edges[1:]))[:, None] + half * _GAUSS_NODES[None, :]
        speed = np.linalg.norm(self.derivative(np.clip(nodes, 0.0, 1.0)), axis=-1)
        return float(np.sum(half * _GAUSS_WEIGHTS[None, :] * speed))

    @property
    def length(self) -> float:
        """Total arc length in metres."""
        return self.arc_length(0.0, 1.0)


@numba.njit(cache=True)
def _bezier_eval(bezier, t):
    """Position and dP/dt of the Bézier-piece curve at scalar t ∈ [0, 1]."""
    n = bezier.shape[0]
    s = t * n
    i = min(int(np.floor(s)), n - 1)
    u = s - i
    v = 1.0 - u
    pos = np.empty(3)
    der = np.empty(3)
    for k in range(3):
        b0, b1, b2, b3 = bezier[i, 0, k], bezier[i, 1, k], bezier[i, 2, k], bezier[i, 3, k]
        pos[k] = v * v * v * b0 + 3.0 * v * v * u * b1 + 3.0 * v * u * u * b2 + u * u * u * b3
        der[k] = 3.0 * n * (v * v * (b1 - b0) + 2.0 * u * v * (b2 - b1) + u * u * (b3 - b2))
    return pos, der


@numba.njit(cache=True)
def _march(bezier, chord, count, t_dense, x_dense, xtol, max_iter):
    """Walk ``count`` chords of length ``chord`` from t = 0, each to the first curve point at that distance.

    Each root of |P(t) − x_k| = chord is bracketed on the dense samples, then found by safeguarded Newton.
    Returns ``(ts, made)``: the ``count + 1`` parameters and the steps made (``made < count``: the curve ended).
    """
    ts = np.zeros(count + 1)
    x = x_dense[0].copy()
    j = 1
    m = t_dense.shape[0]
    for k in range(count):
        while j < m:
            d = x_dense[j] - x
            if np.sqrt(d @ d) >= chord:
                break
            j += 1
        if j == m:
            return ts, k
        lo = max(t_dense[j - 1], ts[k])
        hi = t_dense[j]
        t = hi
        for _ in range(max_iter):
            p, dp = _bezier_eval(bezier, t)
            r = p - x
            dist = np.sqrt(r @ r)
            g = dist - chord
            if g > 0.0:
                hi = t
            else:
                lo = t
            if abs(g) <= xtol * chord or hi - lo <= xtol:
                break
            slope = (r @ dp) / dist
            step = t - g / slope if slope > 0.0 else -1.0
            t = step if lo < step < hi else 0.5 * (lo + hi)
        ts[k + 1] = t
        x, _ = _bezier_eval(bezier, t)
    return ts, count


def resample(curve: CatmullRom, n_segments: int) -> np.ndarray:
    """Particles on ``curve`` at exactly equal chords.

    Args:
      curve: the cable's centreline.
      n_segments: number of segments, ``>= 1``.

    Returns:
      ``(n_segments + 1, 3)`` particles in metres, all on the curve, the first and last exactly at its ends, all
      consecutive distances equal to 1e-9 relative, or, where that is finer than floating point allows, to the
      round-off of marching ``n_segments`` chords, ``4 n ε |x|`` (|x| the largest coordinate): the last chord
      absorbs it (a straight 1 m cable of 100,000 segments: chords equal to about 1e-11 m, 1e-6 relative). The
      cable's rest length is that chord × ``n_segments``.

    Raises:
      ValueError: ``n_segments`` is not an integer >= 1, the curve's ends coincide (a closed curve, whose ends a
        junction joins into a loop) and it has fewer than 3 segments, or no equal chords exist (the curve folds back
        on itself at this resolution).
    """
    if isinstance(n_segments, bool) or not isinstance(n_segments, (int, np.integer)) or n_segments < 1:
        raise ValueError(f"n_segments must be an integer >= 1, got {n_segments!r}")
    n = int(n_segments)
    start, end = curve.position(0.0), curve.position(1.0)
    if n < _CLOSED_MIN_SEGMENTS and np.linalg.norm(end - start) <= 0.0:
        raise ValueError(f"the curve's ends coincide: a closed cable (a loop) needs n_segments >= "
                         f"{_CLOSED_MIN_SEGMENTS}, got {n}")
    if n == 1:
        return np.stack([start, end])
    t_dense = np.linspace(0.0, 1.0, curve.n_pieces * _DENSE_SAMPLES * max(1, int(np.ceil(n / 32))) + 1)
    x_dense = np.ascontiguousarray(curve.position(t_dense))
    x_dense[-1] = end

    def residual(chord):
        ts, made = _march(curve._bezier, chord, n - 1, t_dense, x_dense, _CHORD_XTOL, _NEWTON_MAX_ITER)
        if made < n - 1:  # the curve ran out: the chord is too long
            return -chord * (n - made)
        return float(np.linalg.norm(end - curve.position(ts[-1]))) - chord

    c_hi = curve.length / n * (1.0 + _ARC_MARGIN)  # chords are shorter than arcs: residual(c_hi) <= 0
    for shrink in _BRACKET_SHRINKS:  # chords fall short of arcs by O(κ²h²): try a tight bracket first
        c_lo = c_hi * (1.0 - shrink)
        if residual(c_lo) > 0.0:
            break
    else:
        raise ValueError("could not resample the curve into equal chords; use fewer segments or smoother points")
    chord = optimize.toms748(residual, c_lo, c_hi, xtol=_CHORD_XTOL * c_hi, rtol=4 * np.finfo(float).eps)
    ts, made = _march(curve._bezier, chord, n - 1, t_dense, x_dense, _CHORD_XTOL, _NEWTON_MAX_ITER)
    particles = curve.position(ts)
    particles = np.concatenate([particles, end[None]])
    particles[0] = start
    chords = np.linalg.norm(np.diff(particles, axis=0), axis=1)
    round_off = _MARCH_ROUND_OFF * n * np.finfo(float).eps * float(np.abs(particles).max())
    if made < n - 1 or np.max(np.abs(chords - chord)) > max(_CHORD_RTOL * chord, round_off):
        raise ValueError(f"could not resample the curve into n_segments={n} equal chords (it folds back on "
                         "itself at this resolution); use more or fewer segments or other control points")
    return particles
