"""Knots in one cable: the overhand knot's start shape, and whether a cable is still knotted.

:func:`overhand_knot` gives the Catmull-Rom control points of an open cable tied in a loose overhand knot (an open
trefoil), whose strands keep a given clearance apart, for ``CableSpec(knot.points, ...)``. :func:`knot_determinant`
tells the knot a cable's centreline ties, from one projection: 1 for none, 3 for the overhand knot (a trefoil).

Example::

    knot = mjcable.knots.overhand_knot(0.012, tail=0.3)            # strands 12 mm apart, 30 cm tails
    cable = mjcable.CableSpec(knot.points, 120, 0.005, 0.1)
    mjcable.knots.knot_determinant(cable.particles)                  # 3
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from mjcable import _validate, geometry, spline

__all__ = ["OverhandKnot", "overhand_knot", "knot_determinant", "crossings"]

# The trefoil (sin t + 2 sin 2t, cos t − 2 cos 2t, −h sin 3t) in units of its lobes; h = 1.5 keeps its strands
# farthest apart for its length (h = 1: 22 clearances of curve, 1.5: 20.5, 2: 21.4).
_HEIGHT = 1.5
_TIP = math.pi / 3  # where the trefoil reaches farthest out (cos 3t = −1): it is cut open there
_GAP = 0.3  # the trefoil's parameter either side of the tip that the cut takes away (the ends' clearance)
_TURN = 1.2  # radius of the quarter turns from the cut ends onto the tails, in units (the lobes' own is 1 to 3)
_SAMPLES = 100  # control points on the trefoil's part
_SPACING = 0.3  # units between control points on the turns
_CHECK_POINTS = 1500  # points of the unit curve that measure its strands' clearance
_CHECK_TAIL = 6.0  # units of tail on that curve (longer tails leave the strands' clearance as it is)
_STRAND_ARC = 2.5  # units along the curve beyond which two parts are two strands (> π/2 of the clearance, 1.47)

_STRAIGHT = 1e-9  # relative: a direction this close to a line lies on it


@dataclasses.dataclass(frozen=True)
class OverhandKnot:
    """An open cable's start shape tied in a loose overhand knot.

    Attributes:
      points: ``(m, 3)`` Catmull-Rom control points in metres (``CableSpec(points, ...)``), from one tail's end to
        the other's; the ends lie on a line along +x through ``centre``.
      clearance: the least distance in metres between the centrelines of two strands (parts of the curve more
        than π·clearance/2 apart along it), which the curve keeps; its curvature radius is at least half of it.
      loop_length: arc length in metres of the knot: the curve between the two quarter turns onto the tails
        (the cut-open trefoil).
      length: arc length in metres of the whole curve.
    """

    points: np.ndarray
    clearance: float
    loop_length: float
    length: float


def _trefoil(t: np.ndarray) -> tuple:
    """The unit trefoil's points and tangents at the parameters ``t`` (k,): two ``(k, 3)`` arrays."""
    point = np.stack([np.sin(t) + 2 * np.sin(2 * t), np.cos(t) - 2 * np.cos(2 * t), -_HEIGHT * np.sin(3 * t)], -1)
    tangent = np.stack([np.cos(t) + 4 * np.cos(2 * t), -np.sin(t) + 4 * np.sin(2 * t),
                        -3 * _HEIGHT * np.cos(3 * t)], -1)
    return point, tangent / np.linalg.norm(tangent, axis=1)[:, None]


def _tail(end: np.ndarray, heading: np.ndarray, out: np.ndarray, length: float) -> np.ndarray:
    """Control points from a cut end heading along ``heading``: a quarter turn of radius :data:`_TURN` onto
    ``out`` (made perpendicular to the heading), then straight on for ``length`` units."""
    out = out - (out @ heading) * heading
    out /= np.linalg.norm(out)
    phi = np.linspace(0.0, 0.5 * math.pi, int(math.ceil(0.5 * math.pi * _TURN / _SPACING)) + 1)[1:]
    turn = end + _TURN * (np.sin(phi)[:, None] * heading + (1.0 - np.cos(phi))[:, None] * out)
    return np.concatenate([turn, [turn[-1] + length * out]])


def _rotation_onto_x(e: np.ndarray) -> np.ndarray:
    """The rotation matrix turning the unit vector ``e`` onto +x (Rodrigues)."""
    x = np.array([1.0, 0.0, 0.0])
    axis = np.cross(e, x)
    s, c = np.linalg.norm(axis), float(e @ x)
    if s < _STRAIGHT:  # e along ±x already
        return np.eye(3) if c > 0 else np.diag([-1.0, -1.0, 1.0])
    k = axis / s
    cross = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + s * cross + (1.0 - c) * cross @ cross


def overhand_knot(clearance: float, *, tail: float = 0.3, centre=(0.0, 0.0, 1.0)) -> OverhandKnot:
    """A loose overhand knot: a trefoil cut open at its outermost point, each cut end turned by a quarter circle
    onto a straight tail, the two tails leaving on opposite sides of the knot's plane (so that no tail crosses the
    knot), scaled so that its strands keep ``clearance`` apart, turned so that its ends lie on a line along +x,
    their midpoint at ``centre``.

    Args:
      clearance: least distance in metres between two strands' centrelines (> 0): at least the cable's diameter
        plus a margin, so that its surface starts clear of itself.
      tail: length in metres of each straight tail (> 0).
      centre: ``(3,)`` metres, the midpoint of the two ends.

    Returns:
      The :class:`OverhandKnot` (its loop takes about 20 clearances of cable).

    Raises:
      ValueError: a clearance or tail that is not a positive number, or a centre that is not 3 finite numbers.
    """
    clearance = _validate.number("clearance", clearance, low=0.0, low_open=True, unit="m")
    tail = _validate.number("tail", tail, low=0.0, low_open=True, unit="m")
    centre = np.array(_validate.vec3("centre", centre, unit="m"))
    scale = clearance / _unit_clearance()  # metres per unit
    points, start, stop = _unit_knot(tail / scale)
    points = points * scale
    rotation = _rotation_onto_x((points[-1] - points[0]) / np.linalg.norm(points[-1] - points[0]))
    points = (points - 0.5 * (points[0] + points[-1])) @ rotation.T + centre
    curve = spline.CatmullRom(points)
    m = len(points)
    loop_length = float(curve.arc_length(start / (m - 1), stop / (m - 1)))
    points.setflags(write=False)
    return OverhandKnot(points=points, clearance=clearance, loop_length=loop_length, length=curve.length)


def _unit_knot(tail: float) -> tuple:
    """The knot's control points in units of the trefoil's lobes, with straight tails ``tail`` units long:
    ``(points (m, 3), start, stop)``, the trefoil's part running from control point ``start`` to ``stop``."""
    loop, tangent = _trefoil(np.linspace(_TIP + _GAP, _TIP + 2.0 * math.pi - _GAP, _SAMPLES))
    normal = np.array([0.0, 0.0, 1.0])  # the tails leave along ± the trefoil's axis
    first = _tail(loop[0], -tangent[0], normal, tail)[::-1]
    last = _tail(loop[-1], tangent[-1], -normal, tail)
    return np.concatenate([first, loop, last]), len(first), len(first) + len(loop) - 1


@functools.cache
def _unit_clearance() -> float:
    """The least distance between the strands of the unit knot (tails of :data:`_CHECK_TAIL`), measured on the
    polyline through :data:`_CHECK_POINTS` points of its Catmull-Rom curve (strands: parts more than
    :data:`_STRAND_ARC` apart along it)."""
    x = spline.CatmullRom(_unit_knot(_CHECK_TAIL)[0]).position(np.linspace(0.0, 1.0, _CHECK_POINTS))
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(x, axis=0), axis=1))])
    apart = arc[None, :-1] - arc[1:, None]  # along the curve from the end of segment i to the start of segment j
    return float(geometry.segment_distances(x, x)[apart > _STRAND_ARC].min())


def _closed(positions: np.ndarray) -> tuple:
    """The centreline closed far away, in the plane coordinates of a projection along a direction perpendicular
    to its ends' line: ``(xy (k, 2), height (k,))``, the closed polyline's points (the last joins the first). The
    ends go on along their line, away from each other, for twice the cable's extent, and meet over a detour far to
    one side: a closure that adds no crossing while the ends are the cable's outermost points along their line
    (a pulled knot) and the detour leaves on the side away from the cable's centre of mass (which a disc between
    the closure and the pulled cable then keeps out of)."""
    e = positions[-1] - positions[0]
    e = e / np.linalg.norm(e)
    side = 0.5 * (positions[0] + positions[-1]) - positions.mean(axis=0)  # away from the knot
    side -= (side @ e) * e
    if np.linalg.norm(side) < _STRAIGHT * np.linalg.norm(positions[-1] - positions[0]):  # nothing to go round
        side = np.cross(e, [0.0, 0.0, 1.0]) if abs(e[2]) < 0.9 else np.cross(e, [1.0, 0.0, 0.0])
    side /= np.linalg.norm(side)
    view = np.cross(e, side)  # the projection's direction: heights along it
    extent = 2.0 * float(np.ptp(positions, axis=0).max()) + 1.0
    far = positions[[-1, 0]] + np.array([[extent], [-extent]]) * e
    detour = far + 3.0 * extent * side
    closed = np.concatenate([positions, far[:1], detour, far[1:]])
    return np.stack([closed @ e, closed @ side], axis=1), closed @ view


def crossings(positions) -> np.ndarray:
    """The crossings of a cable's centreline (``(n, 3)`` metres) closed far away (see :func:`knot_determinant`), in
    one projection: ``(c, 4)`` rows (i, s, j, t), the over-strand's segment i and its fraction s, the
    under-strand's segment j and fraction t (segments of the closed polyline: the cable's, then the closure's)."""
    x = np.asarray(positions, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 3 or len(x) < 2:
        raise ValueError(f"positions must be an (n, 3) array in metres with n >= 2, got shape {np.shape(positions)}")
    xy, height = _closed(x)
    k = len(xy)
    a, b = xy, np.roll(xy, -1, axis=0)  # segment m: point m to point m + 1 (the last closes the loop)
    i, j = np.triu_indices(k, k=2)
    keep = ~((i == 0) & (j == k - 1))  # the closing segment's neighbour
    i, j = i[keep], j[keep]
    d1, d2, r = b[i] - a[i], b[j] - a[j], a[j] - a[i]
    denom = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (r[:, 0] * d2[:, 1] - r[:, 1] * d2[:, 0]) / denom
        t = (r[:, 0] * d1[:, 1] - r[:, 1] * d1[:, 0]) / denom
    hit = (denom != 0.0) & (s >= 0.0) & (s < 1.0) & (t >= 0.0) & (t < 1.0)
    i, j, s, t = i[hit], j[hit], s[hit], t[hit]
    hb = np.roll(height, -1)
    zi = (1.0 - s) * height[i] + s * hb[i]
    zj = (1.0 - t) * height[j] + t * hb[j]
    over = zi > zj
    return np.stack([np.where(over, i, j), np.where(over, s, t), np.where(over, j, i), np.where(over, t, s)],
                    axis=1)


def knot_determinant(positions) -> int:
    """The determinant of the knot a cable's centreline ties (``(n, 3)`` metres, its ends closed far away along
    the line through them): |Δ(−1)|, the Alexander polynomial at −1, from the projection's crossings (the Fox
    colouring matrix of its arcs with one row and one column struck out; Lickorish, *An Introduction to Knot
    Theory*, 1997, §3 and §6). 1 for an unknotted cable, 3 for an overhand knot (a trefoil), 5 for a figure-eight.
    The closure is the knot's own while the ends are the cable's outermost points along their line (tails pulled
    away from the knot); a cable that crosses itself in a closer approach than round-off has no defined knot."""
    rows = crossings(positions)
    if len(rows) == 0:
        return 1
    over_at = rows[:, 0] + rows[:, 1]  # positions along the closed polyline: segment + fraction
    under_at = rows[:, 2] + rows[:, 3]
    breaks = np.sort(under_at)  # the arcs run from one under-crossing to the next
    n = len(rows)
    arc_of_over = np.searchsorted(breaks, over_at) % n  # the arc that holds each over-strand
    before = np.searchsorted(breaks, under_at)  # the arc that ends at each under-crossing; the next one starts there
    incoming, outgoing = before % n, (before + 1) % n
    matrix = np.zeros((n, n))
    np.add.at(matrix, (np.arange(n), arc_of_over), 2.0)
    np.add.at(matrix, (np.arange(n), incoming), -1.0)
    np.add.at(matrix, (np.arange(n), outgoing), -1.0)
    return int(round(abs(np.linalg.det(matrix[1:, 1:]))))
