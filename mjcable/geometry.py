"""Obstacle geometry in one place: poses (MuJoCo's Euler convention), signed distances and outward normals; and
the distances between two polylines' segments (cables near each other).

Used by the MJCF world (obstacle quaternions), the metrics (penetration, tunnelling), the scene's start check and
the environments' workspaces. Euler angles are MuJoCo's default: intrinsic x-y-z rotations in degrees.
"""

from __future__ import annotations

import functools
from typing import Tuple

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = ["rotation", "quaternion", "to_local", "signed_distance", "signed_distances", "segment_distances"]


@functools.lru_cache(maxsize=1024)
def _rotation(euler: Tuple[float, float, float]) -> np.ndarray:
    rot = Rotation.from_euler("XYZ", euler, degrees=True).as_matrix()
    rot.setflags(write=False)
    return rot


def rotation(euler_deg) -> np.ndarray:
    """``(3, 3)`` world-from-body rotation matrix of MuJoCo's intrinsic xyz Euler angles in degrees (read-only)."""
    return _rotation(tuple(float(a) for a in euler_deg))


def quaternion(euler_deg) -> np.ndarray:
    """``(4,)`` unit quaternion (w, x, y, z) of MuJoCo's intrinsic xyz Euler angles in degrees."""
    return Rotation.from_euler("XYZ", [float(a) for a in euler_deg], degrees=True).as_quat(scalar_first=True)


def to_local(points, ob) -> np.ndarray:
    """``(n, 3)`` world points in the frame of obstacle ``ob`` (its ``pos`` and ``euler``)."""
    return (np.asarray(points, dtype=np.float64) - np.asarray(ob.pos)) @ rotation(ob.euler)


def _round(q: np.ndarray, radius: float) -> Tuple[np.ndarray, np.ndarray]:
    r = np.linalg.norm(q, axis=1)
    safe = np.where(r > 0.0, r, 1.0)[:, None]
    normal = np.where((r > 0.0)[:, None], q / safe, [0.0, 0.0, 1.0])
    return r - radius, normal


def _local_distances(q: np.ndarray, ob) -> Tuple[np.ndarray, np.ndarray]:
    """Signed distances ``(n,)`` (m, negative inside) of local points ``q`` (n, 3) and outward unit normals (n, 3)."""
    n = len(q)
    shape = ob.shape
    if shape == "plane":
        return q[:, 2].copy(), np.tile([0.0, 0.0, 1.0], (n, 1))
    if shape == "box":
        size = np.asarray(ob.size)
        excess = np.abs(q) - size
        outside = np.any(excess > 0.0, axis=1)
        offset = q - np.clip(q, -size, size)
        d_out = np.linalg.norm(offset, axis=1)
        axis = np.argmax(excess, axis=1)
        d = np.where(outside, d_out, excess[np.arange(n), axis])
        face = np.zeros((n, 3))
        face[np.arange(n), axis] = np.where(q[np.arange(n), axis] >= 0.0, 1.0, -1.0)
        normal = np.where(outside[:, None], offset / np.where(d_out > 0.0, d_out, 1.0)[:, None], face)
        return d, normal
    if shape == "sphere":
        return _round(q, ob.radius)
    if shape == "capsule":
        axial = np.zeros_like(q)
        axial[:, 2] = np.clip(q[:, 2], -ob.half_length, ob.half_length)
        return _round(q - axial, ob.radius)
    if shape == "cylinder":
        radial = np.hypot(q[:, 0], q[:, 1])
        d_radial, d_axial = radial - ob.radius, np.abs(q[:, 2]) - ob.half_length
        outward = np.zeros_like(q)
        outward[:, :2] = q[:, :2] / np.where(radial > 0.0, radial, 1.0)[:, None]
        outward[radial == 0.0] = [1.0, 0.0, 0.0]
        cap = np.zeros_like(q)
        cap[:, 2] = np.where(q[:, 2] >= 0.0, 1.0, -1.0)
        rim = (d_radial > 0.0) & (d_axial > 0.0)  # beyond the rim: nearest point on the circular edge
        offset = d_radial[:, None] * outward + d_axial[:, None] * cap
        d_rim = np.linalg.norm(offset, axis=1)
        side = d_radial >= d_axial
        d = np.where(rim, d_rim, np.where(side, d_radial, d_axial))
        normal = np.where(rim[:, None], offset / np.where(d_rim > 0.0, d_rim, 1.0)[:, None],
                          np.where(side[:, None], outward, cap))
        return d, normal
    raise ValueError(f"unsupported obstacle {ob!r}")  # pragma: no cover - Scene validates obstacle types


def signed_distances(points, ob) -> Tuple[np.ndarray, np.ndarray]:
    """Signed distances from world points to the surface of obstacle ``ob``, with outward normals.

    Args:
      points: ``(n, 3)`` points in metres, world frame.
      ob: an obstacle with ``pos``, ``euler`` and a ``shape`` (``"plane"``, ``"box"``, ``"sphere"``, ``"capsule"``,
        ``"cylinder"``) with its sizes: :class:`~mjcable.scene.Floor`, ``Box``, ``Sphere``, ``Capsule``, ``Cylinder``.

    Returns:
      ``(distances, normals)``: ``(n,)`` metres, negative inside; ``(n, 3)`` unit normals in the world frame,
      pointing away from the obstacle (the direction that increases the distance fastest).
    """
    q = to_local(np.atleast_2d(points), ob)
    d, normal = _local_distances(q, ob)
    return d, normal @ rotation(ob.euler).T


def signed_distance(ob, point) -> Tuple[float, np.ndarray]:
    """Signed distance from ``point`` (3,), metres, world frame, to the surface of ``ob`` and the outward unit normal.

    Example::

        d, n = signed_distance(mjcable.Sphere(radius=0.1), [0.0, 0.0, 0.3])  # d = 0.2, n = (0, 0, 1)
    """
    d, normal = signed_distances(np.asarray(point, dtype=np.float64)[None], ob)
    return float(d[0]), normal[0]


_PARALLEL = 1e-12  # relative: segments whose cross product is this small are parallel
_CHUNK = 256  # segments of the first polyline per block of segment_distances (bounds its memory to 256 × m pairs)


def segment_distances(a, b) -> np.ndarray:
    """Distances between every segment of polyline ``a`` and every segment of polyline ``b``: the closest points of
    each pair, clamped to the segments.

    Args:
      a: ``(n + 1, 3)`` points in metres (n >= 1 segments).
      b: ``(m + 1, 3)`` points in metres (m >= 1 segments).

    Returns:
      ``(n, m)`` distances in metres.

    Example::

        segment_distances([[-1, 0, 0], [1, 0, 0]], [[0, -1, 0.3], [0, 1, 0.3]])   # [[0.3]]
    """
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return np.concatenate([_segment_block(a[i:i + _CHUNK + 1], b) for i in range(0, len(a) - 1, _CHUNK)])


def _segment_block(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:func:`segment_distances` of at most ``_CHUNK`` segments of ``a``: the closest points of two segments
    (Ericson, Real-Time Collision Detection, 5.1.9), the parameters clamped to [0, 1] in turn."""
    p, u = a[:-1, None, :], (a[1:] - a[:-1])[:, None, :]
    q, v = b[None, :-1, :], (b[1:] - b[:-1])[None, :, :]
    w = p - q
    uu, vv, uv = (u * u).sum(-1), (v * v).sum(-1), (u * v).sum(-1)
    uw, vw = (u * w).sum(-1), (v * w).sum(-1)
    den = uu * vv - uv * uv
    parallel = den <= _PARALLEL * uu * vv  # parallel segments: any point of a's, start at its first
    s = np.clip(np.where(parallel, 0.0, (uv * vw - vv * uw) / np.where(parallel, 1.0, den)), 0.0, 1.0)
    t = np.clip((uv * s + vw) / vv, 0.0, 1.0)
    s = np.clip((uv * t - uw) / uu, 0.0, 1.0)
    d = w + s[..., None] * u - t[..., None] * v
    return np.sqrt((d * d).sum(-1))
