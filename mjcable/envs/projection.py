"""The workspace clamp in compiled code: signed distances to obstacles, the projection onto the allowed set and whole
gripper paths over a control step, as numba kernels (``cache=True``) with their drivers.

Obstacles are packed once per workspace by :func:`pack_obstacles` into flat arrays (a shape code, the pose and the
sizes); the kernels then reproduce :func:`mjcable.geometry.signed_distances` (MuJoCo's Euler convention, the same
branches for the box's faces and corners and the cylinder's rim) and :class:`mjcable.envs.Workspace`'s clamp: box,
tethers, obstacles, in that order, for at most ``PROJECTION_ROUNDS`` rounds per increment of at most
``INCREMENT_FRACTION`` of the clearance, stopping the gripper where a projection fails.

:func:`move_paths` computes where every commanded gripper is after each of the ``nstep`` Simulator steps of a control
step (each step moving it ``1 / nstep`` of its displacement, grippers in turn, each seeing the others' new
positions), in one call: exactly the per-step clamp of the Python loop it replaces, as long as no pin lets go
within the control step (the caller recomputes the rest of the path if one does).
"""

from __future__ import annotations

import math
from typing import Optional, Sequence, Tuple

import numba
import numpy as np

from mjcable.geometry import rotation

__all__ = [
    "SHAPES",
    "PROJECTION_ROUNDS",
    "TOLERANCE",
    "INCREMENT_FRACTION",
    "pack_obstacles",
    "signed_distances",
    "violation",
    "move_paths",
]

SHAPES = ("plane", "box", "sphere", "capsule", "cylinder")  # obstacle shapes, coded by their index
_PLANE, _BOX, _SPHERE, _CAPSULE, _CYLINDER = range(len(SHAPES))
PROJECTION_ROUNDS = 4  # alternating projections (box, tethers, obstacles) per increment
TOLERANCE = 1e-9  # m: slack when checking a projected point against the constraints
INCREMENT_FRACTION = 0.5  # of the clearance: the longest straight increment of a gripper motion


def pack_obstacles(obstacles: Sequence) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The obstacles as arrays for the kernels.

    Args:
      obstacles: scene obstacles (``shape`` one of :data:`SHAPES`, ``pos``, ``euler`` and their sizes).

    Returns:
      ``(kind, pos, rot, size)``: ``(m,)`` int64 shape codes (indices into :data:`SHAPES`), ``(m, 3)`` positions in
      metres, ``(m, 3, 3)`` world-from-body rotations, ``(m, 3)`` sizes in metres (a box's half-extents; ``radius``
      and ``half_length`` of the round shapes).

    Raises:
      ValueError: an obstacle of another shape.
    """
    m = len(obstacles)
    kind = np.zeros(m, dtype=np.int64)
    pos = np.zeros((m, 3))
    rot = np.zeros((m, 3, 3))
    size = np.zeros((m, 3))
    for i, ob in enumerate(obstacles):
        shape = getattr(ob, "shape", None)
        if shape not in SHAPES:
            raise ValueError(f"obstacles[{i}] must have a shape in {SHAPES}, got {ob!r}")
        kind[i] = SHAPES.index(shape)
        pos[i] = ob.pos
        rot[i] = rotation(ob.euler)
        if shape == "box":
            size[i] = ob.size
        elif shape != "plane":
            size[i, 0] = ob.radius
            size[i, 1] = getattr(ob, "half_length", 0.0)
    return kind, pos, rot, size


# --- kernels --------------------------------------------------------------------------------------------------------


@numba.njit(cache=True, inline="always")
def _norm3(x, y, z):
    return math.sqrt(x * x + y * y + z * z)


@numba.njit(cache=True)
def _signed_distance(kind, pos, rot, size, p, normal):
    """Signed distance (m) of world point ``p`` (3,) to one obstacle; its outward unit normal written to ``normal``."""
    ox, oy, oz = p[0] - pos[0], p[1] - pos[1], p[2] - pos[2]
    q0 = ox * rot[0, 0] + oy * rot[1, 0] + oz * rot[2, 0]  # to the obstacle's frame: (p - pos) @ rot
    q1 = ox * rot[0, 1] + oy * rot[1, 1] + oz * rot[2, 1]
    q2 = ox * rot[0, 2] + oy * rot[1, 2] + oz * rot[2, 2]
    n0, n1, n2 = 0.0, 0.0, 1.0
    if kind == _PLANE:
        d = q2
    elif kind == _BOX:
        e0, e1, e2 = abs(q0) - size[0], abs(q1) - size[1], abs(q2) - size[2]
        if e0 > 0.0 or e1 > 0.0 or e2 > 0.0:  # outside: towards the nearest point of the surface
            f0 = q0 - min(max(q0, -size[0]), size[0])
            f1 = q1 - min(max(q1, -size[1]), size[1])
            f2 = q2 - min(max(q2, -size[2]), size[2])
            d = _norm3(f0, f1, f2)
            s = d if d > 0.0 else 1.0
            n0, n1, n2 = f0 / s, f1 / s, f2 / s
        else:  # inside: out through the nearest face (the first of equals, as numpy's argmax)
            n2 = 0.0
            if e0 >= e1 and e0 >= e2:
                d = e0
                n0 = 1.0 if q0 >= 0.0 else -1.0
            elif e1 >= e2:
                d = e1
                n1 = 1.0 if q1 >= 0.0 else -1.0
            else:
                d = e2
                n2 = 1.0 if q2 >= 0.0 else -1.0
    elif kind == _SPHERE or kind == _CAPSULE:
        if kind == _CAPSULE:
            q2 = q2 - min(max(q2, -size[1]), size[1])
        r = _norm3(q0, q1, q2)
        d = r - size[0]
        if r > 0.0:
            n0, n1, n2 = q0 / r, q1 / r, q2 / r
    else:  # cylinder
        radial = math.hypot(q0, q1)
        d_radial, d_axial = radial - size[0], abs(q2) - size[1]
        if radial > 0.0:
            u0, u1 = q0 / radial, q1 / radial
        else:
            u0, u1 = 1.0, 0.0
        c2 = 1.0 if q2 >= 0.0 else -1.0
        if d_radial > 0.0 and d_axial > 0.0:  # beyond the rim: the nearest point on the circular edge
            f0, f1, f2 = d_radial * u0, d_radial * u1, d_axial * c2
            d = _norm3(f0, f1, f2)
            s = d if d > 0.0 else 1.0
            n0, n1, n2 = f0 / s, f1 / s, f2 / s
        elif d_radial >= d_axial:
            d = d_radial
            n0, n1, n2 = u0, u1, 0.0
        else:
            d = d_axial
            n2 = c2
    normal[0] = rot[0, 0] * n0 + rot[0, 1] * n1 + rot[0, 2] * n2  # back to the world: rot @ n
    normal[1] = rot[1, 0] * n0 + rot[1, 1] * n1 + rot[1, 2] * n2
    normal[2] = rot[2, 0] * n0 + rot[2, 1] * n1 + rot[2, 2] * n2
    return d


@numba.njit(cache=True)
def _signed_distances(points, kind, pos, rot, size, d, normals):
    for i in range(points.shape[0]):
        d[i] = _signed_distance(kind, pos, rot, size, points[i], normals[i])


@numba.njit(cache=True)
def _violation(p, box, clearance, pins, tether, obstacles, normal):
    """How far (m) ``p`` lies outside the allowed set: the box, the tethers, the obstacles' clearance (``obstacles``:
    ``(kind, pos, rot, size)`` of :func:`pack_obstacles`)."""
    kind, pos, rot, size = obstacles
    worst = 0.0
    for a in range(3):
        worst = max(worst, box[0, a] - p[a], p[a] - box[1, a])
    for j in range(pins.shape[0]):
        if tether[j] < math.inf:
            worst = max(worst, _norm3(p[0] - pins[j, 0], p[1] - pins[j, 1], p[2] - pins[j, 2]) - tether[j])
    for o in range(kind.shape[0]):
        worst = max(worst, clearance - _signed_distance(kind[o], pos[o], rot[o], size[o], p, normal))
    return worst


@numba.njit(cache=True)
def _project(p, box, clearance, pins, tether, obstacles, normal):
    """Project ``p`` (3,) onto the allowed set in place; whether it got there within the rounds."""
    kind, pos, rot, size = obstacles
    for _ in range(PROJECTION_ROUNDS):
        for a in range(3):
            p[a] = min(max(p[a], box[0, a]), box[1, a])
        for j in range(pins.shape[0]):
            if tether[j] < math.inf:
                f0, f1, f2 = p[0] - pins[j, 0], p[1] - pins[j, 1], p[2] - pins[j, 2]
                dist = _norm3(f0, f1, f2)
                if dist > tether[j]:
                    s = tether[j] / dist
                    p[0], p[1], p[2] = pins[j, 0] + f0 * s, pins[j, 1] + f1 * s, pins[j, 2] + f2 * s
        for o in range(kind.shape[0]):
            dist = _signed_distance(kind[o], pos[o], rot[o], size[o], p, normal)
            if dist < clearance:
                push = clearance - dist
                for a in range(3):
                    p[a] = p[a] + push * normal[a]
        if _violation(p, box, clearance, pins, tether, obstacles, normal) <= TOLERANCE:
            return True
    return False


@numba.njit(cache=True)
def _move(p, sx, sy, sz, box, clearance, pins, tether, obstacles, trial, normal):
    """Move ``p`` (3,) in place by the displacement (``sx``, ``sy``, ``sz``), increment by increment, clamped;
    ``trial`` and ``normal`` are (3,) scratch arrays."""
    length = _norm3(sx, sy, sz)
    if length == 0.0:
        return
    count = max(1, math.ceil(length / (INCREMENT_FRACTION * clearance)))
    ix, iy, iz = sx / count, sy / count, sz / count
    for _ in range(count):
        trial[0], trial[1], trial[2] = p[0] + ix, p[1] + iy, p[2] + iz
        if not _project(trial, box, clearance, pins, tether, obstacles, normal):
            return  # the gripper stops at its last allowed position
        p[0], p[1], p[2] = trial[0], trial[1], trial[2]


@numba.njit(cache=True)
def _move_paths(pins, grippers, displacements, nstep, box, clearance, tethers, obstacles, out, moved):
    trial, normal = np.empty(3), np.empty(3)
    for i in range(out.shape[0]):
        for g in range(grippers.shape[0]):
            k = grippers[g]
            x, y, z = pins[k, 0], pins[k, 1], pins[k, 2]
            _move(pins[k], displacements[g, 0] / nstep, displacements[g, 1] / nstep, displacements[g, 2] / nstep,
                  box, clearance, pins, tethers[k], obstacles, trial, normal)
            moved[i, g] = pins[k, 0] != x or pins[k, 1] != y or pins[k, 2] != z
            out[i, g] = pins[k]


# --- drivers --------------------------------------------------------------------------------------------------------


def signed_distances(points, obstacles) -> Tuple[np.ndarray, np.ndarray]:
    """Signed distances of world points to the surface of each packed obstacle, with outward unit normals.

    Args:
      points: ``(n, 3)`` points in metres.
      obstacles: ``(kind, pos, rot, size)`` of :func:`pack_obstacles`.

    Returns:
      ``(d, normals)``: ``(m, n)`` metres (negative inside) and ``(m, n, 3)`` unit normals, for the ``m``
      obstacles; the same values as :func:`mjcable.geometry.signed_distances` to round-off.
    """
    points = np.ascontiguousarray(np.atleast_2d(points), dtype=np.float64)
    kind, pos, rot, size = obstacles
    d = np.empty((len(kind), len(points)))
    normals = np.empty((len(kind), len(points), 3))
    for o in range(len(kind)):
        _signed_distances(points, kind[o], pos[o], rot[o], size[o], d[o], normals[o])
    return d, normals


def violation(p, box, clearance: float, pins, tether, obstacles) -> float:
    """How far (m) point ``p`` (3,) lies outside the allowed set; 0 inside it.

    Args:
      p: (3,) position in metres.
      box: (2, 3) lower and upper corners of the allowed box in metres.
      clearance: metres kept from every obstacle.
      pins: (n_pins, 3) pin positions in metres.
      tether: (n_pins,) the longest allowed distance to each pin in metres (``inf``: no tether).
      obstacles: ``(kind, pos, rot, size)`` of :func:`pack_obstacles`.
    """
    return float(_violation(np.asarray(p, dtype=np.float64), box, clearance, pins, tether, tuple(obstacles),
                            np.empty(3)))


def move_paths(pins, grippers, displacements, nstep: int, box, clearance: float, tethers, obstacles, *,
               steps: Optional[int] = None) -> Tuple[np.ndarray, np.ndarray]:
    """Where the commanded grippers are after each of ``steps`` steps moving each ``1 / nstep`` of its displacement.

    Args:
      pins: (n_pins, 3) start positions of every pin in metres (not modified).
      grippers: (c,) int, the pins to move, in the order they move within a step.
      displacements: (c, 3) their whole displacements in metres.
      nstep: number of steps the whole displacements are split into (>= 1).
      box: (2, 3) lower and upper corners of the allowed box in metres.
      clearance: metres kept from every obstacle.
      tethers: (n_pins, n_pins) the longest allowed distance from pin ``k`` (row) to pin ``j`` (column), metres
        (``inf``: no tether, or one that does not hold).
      obstacles: ``(kind, pos, rot, size)`` of :func:`pack_obstacles`.
      steps: how many of those steps to take (default ``nstep``): the rest of a path recomputed part way.

    Returns:
      ``(path, moved)``: ``(steps, c, 3)`` positions in metres and ``(steps, c)`` bool, whether each gripper's
      position changed in that step (bit for bit).
    """
    pins = np.array(pins, dtype=np.float64)
    grippers = np.asarray(grippers, dtype=np.int64)
    displacements = np.ascontiguousarray(displacements, dtype=np.float64).reshape(len(grippers), 3)
    count = nstep if steps is None else steps
    out = np.empty((count, len(grippers), 3))
    moved = np.empty((count, len(grippers)), dtype=np.bool_)
    _move_paths(pins, grippers, displacements, nstep, box, clearance, tethers, tuple(obstacles), out, moved)
    return out, moved
