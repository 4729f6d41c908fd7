"""Measurements on simulated cables: strain, shape error, penetration into obstacles, tunnelling, self-distance,
energy.

Every function works on positions alone (``(n, 3)`` float64 arrays in metres, as ``Simulator.positions`` returns
them), so all seven models are measured the same way. Penetration is geometric: the depth of each particle's
sphere (the cable radius) inside each obstacle of the scene, from exact signed distances to floors, boxes,
cylinders, capsules and spheres; :func:`contact_penetration` reads MuJoCo's own contact distances instead.

Example::

    sim = mjcable.Simulator(mjcable.scenes.get("table"), "xpbd")
    sim.step(1.0)
    metrics.max_strain(sim.positions, sim.scene.cable.segment_length)
    metrics.penetration(sim.positions, sim.scene)
"""

from __future__ import annotations

import math
from typing import Optional

import mujoco
import numpy as np

from mjcable import _validate, geometry
from mjcable.scene import GRAVITY, Box, Floor, Scene

__all__ = [
    "segment_lengths",
    "max_strain",
    "scene_strain",
    "particle_radii",
    "rms_distance",
    "max_distance",
    "signed_distances",
    "penetration",
    "contact_penetration",
    "crossed",
    "tunneled",
    "self_distance",
    "kinetic_energy",
    "potential_energy",
    "energy",
    "TUNNEL_DEPTH",
]

TUNNEL_DEPTH = 1.0  # in cable radii: a particle centre this deep inside an obstacle's surface has tunnelled


def _points(name: str, value) -> np.ndarray:
    p = np.asarray(value, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"{name} must be an (n, 3) array in metres, got shape {np.shape(value)}")
    return p


def segment_lengths(positions) -> np.ndarray:
    """``(n − 1,)`` lengths in metres of the segments between consecutive particles."""
    return np.linalg.norm(np.diff(_points("positions", positions), axis=0), axis=1)


def max_strain(positions, rest_length: float) -> float:
    """max |l / l₀ − 1| over the segments (dimensionless).

    Args:
      positions: ``(n, 3)`` particles in metres.
      rest_length: l₀ in metres (``scene.cable.segment_length``).
    """
    if not rest_length > 0:
        raise ValueError(f"rest_length must be > 0 metres, got {rest_length!r}")
    return float(np.max(np.abs(segment_lengths(positions) / rest_length - 1.0)))


def rms_distance(positions, reference) -> float:
    """RMS distance in metres between matching particles of two ``(n, 3)`` arrays."""
    a, b = _points("positions", positions), _points("reference", reference)
    if a.shape != b.shape:
        raise ValueError(f"positions and reference must have the same shape, got {a.shape} and {b.shape}")
    return float(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=1))))


def max_distance(positions, reference) -> float:
    """Largest distance in metres between matching particles of two ``(n, 3)`` arrays."""
    a, b = _points("positions", positions), _points("reference", reference)
    if a.shape != b.shape:
        raise ValueError(f"positions and reference must have the same shape, got {a.shape} and {b.shape}")
    return float(np.sqrt(np.max(np.sum((a - b) ** 2, axis=1))))


def _signed_distance(points: np.ndarray, ob) -> np.ndarray:
    """Signed distance in metres from each point to the obstacle's surface (negative inside)."""
    return geometry.signed_distances(points, ob)[0]


def signed_distances(positions, scene: Scene) -> np.ndarray:
    """``(n_obstacles, n)`` signed distances in metres from each particle centre to each obstacle's surface
    (negative inside)."""
    x = _points("positions", positions)
    if not scene.obstacles:
        return np.zeros((0, len(x)))
    return np.stack([_signed_distance(x, ob) for ob in scene.obstacles])


def particle_radii(scene: Scene):
    """m: the cables' radius (a float) where they share one, else ``(scene.n_particles,)`` each particle's cable's
    radius, in cable order."""
    radii = {c.radius for c in scene.cables}
    if len(radii) == 1:
        return radii.pop()
    return np.concatenate([np.full(c.n_particles, c.radius) for c in scene.cables])


def scene_strain(positions, scene: Scene) -> float:
    """:func:`max_strain` over every cable of ``scene`` (``positions``: ``(scene.n_particles, 3)`` m, in cable
    order), each against its own rest segment."""
    x = _points("positions", positions)
    return max(max_strain(x[part], cable.segment_length) for part, cable in zip(scene.cable_slices, scene.cables))


def penetration(positions, scene: Scene) -> float:
    """Deepest overlap in metres of a particle's sphere (its cable's radius) with any obstacle: max(r − d, 0);
    0.0 for a scene without obstacles."""
    d = signed_distances(positions, scene)
    if d.size == 0:
        return 0.0
    return float(max(np.max(particle_radii(scene) - d.min(axis=0)), 0.0))


def contact_penetration(mj_model: mujoco.MjModel, mj_data: mujoco.MjData) -> float:
    """Deepest penetration in metres among MuJoCo's current contacts (``-min(contact.dist)``, 0 without contacts).

    Runs ``mj_collision`` on a copy-free basis: it refreshes ``mj_data.contact`` from the current positions (after
    ``mj_kinematics``), which the next ``mj_step`` recomputes anyway.
    """
    mujoco.mj_kinematics(mj_model, mj_data)
    mujoco.mj_collision(mj_model, mj_data)
    if mj_data.ncon == 0:
        return 0.0
    return float(max(-np.min(mj_data.contact.dist[: mj_data.ncon]), 0.0))


def _thickness(ob) -> float:
    """Distance in metres from an obstacle's surface to its middle (inf for a floor)."""
    if isinstance(ob, Floor):
        return math.inf
    if isinstance(ob, Box):
        return float(min(ob.size))
    return float(ob.radius)


def crossed(positions, scene: Scene, start_positions=None) -> np.ndarray:
    """Which particles are going through an obstacle now: ``(n,)`` bool.

    A particle is going through when its centre is past the obstacle's middle (deeper than the box's smallest
    half-extent or the round obstacle's radius: contact will push it out on the far side), or, given
    ``start_positions``, when it has crossed a box: it started outside the box's slab along one of the box's
    axes, within its extent along the other two, and is now on the far side of that slab, still within the other
    two extents (a cable fallen through a table).

    Args:
      positions: ``(n, 3)`` particles now, metres.
      scene: the scene (obstacles).
      start_positions: ``(n, 3)`` particles at the start, metres (default: ``scene.particles``).
    """
    x = _points("positions", positions)
    out = np.zeros(len(x), dtype=bool)
    if not scene.obstacles:
        return out
    x0 = _points("start_positions", scene.particles if start_positions is None else start_positions)
    for ob in scene.obstacles:
        out |= _signed_distance(x, ob) < -_thickness(ob)
        if isinstance(ob, Box):
            q, q0 = geometry.to_local(x, ob), geometry.to_local(x0, ob)
            size = np.asarray(ob.size)
            for axis in range(3):
                others = [k for k in range(3) if k != axis]
                within = np.all(np.abs(q[:, others]) <= size[others], axis=1)
                within0 = np.all(np.abs(q0[:, others]) <= size[others], axis=1)
                flipped = np.sign(q[:, axis]) * np.sign(q0[:, axis]) < 0
                outside0 = np.abs(q0[:, axis]) > size[axis]
                outside = np.abs(q[:, axis]) > size[axis]
                out |= within & within0 & flipped & outside0 & outside
    return out


def tunneled(positions, scene: Scene, start_positions=None) -> np.ndarray:
    """Which particles went through or stay stuck in an obstacle: ``(n,)`` bool.

    :func:`crossed`, or a centre more than :data:`TUNNEL_DEPTH` cable radii inside an obstacle (below a floor).
    Meant for a cable at rest: during an impact soft contacts may let a particle that deep for a moment, which
    ``max_penetration`` records; :func:`crossed` is the test to apply during a run.

    Args:
      positions: ``(n, 3)`` particles now, metres.
      scene: the scene (obstacles, cable radii).
      start_positions: ``(n, 3)`` particles at the start, metres (default: ``scene.particles``).
    """
    x = _points("positions", positions)
    out = crossed(x, scene, start_positions)
    depth = TUNNEL_DEPTH * particle_radii(scene)
    for ob in scene.obstacles:
        out |= _signed_distance(x, ob) < -depth
    return out


def self_distance(positions, *, skip: int = 1) -> tuple:
    """The closest approach of a cable to itself: ``(distance, i, j)``, the smallest distance in metres between the
    centrelines of two segments i < j at least ``skip`` + 1 apart along the cable (j − i > ``skip``; ``skip`` = 1
    leaves out the neighbours that share a particle, :meth:`mjcable.scene.CableSpec.overlapping_neighbours` the
    segments whose capsules overlap at rest), and which two. ``(inf, -1, -1)`` when no pair is that far apart.

    Every pair is measured (:func:`mjcable.geometry.segment_distances`, n² of them): for tests and benchmarks, not
    for a solver's hot loop.

    Example::

        d, i, j = metrics.self_distance(sim.positions, skip=sim.scene.cable.overlapping_neighbours())
    """
    x = _points("positions", positions)
    skip = _validate.integer("skip", skip, low=1)
    if len(x) - 1 <= skip + 1:
        return math.inf, -1, -1
    d = geometry.segment_distances(x, x)
    d[np.tril_indices(len(x) - 1, k=skip)] = math.inf  # each pair once, those skip or fewer apart left out
    i, j = np.unravel_index(int(np.argmin(d)), d.shape)
    return float(d[i, j]), int(i), int(j)


def kinetic_energy(positions, previous, dt: float, masses) -> float:
    """Kinetic energy in joules from the finite-difference velocities (positions − previous) / dt.

    Args:
      positions, previous: ``(n, 3)`` particles in metres, ``dt`` seconds apart.
      dt: seconds (> 0).
      masses: ``(n,)`` particle masses in kg (``scene.cable.particle_masses``).
    """
    x, x0 = _points("positions", positions), _points("previous", previous)
    if not dt > 0:
        raise ValueError(f"dt must be > 0 seconds, got {dt!r}")
    v2 = np.sum((x - x0) ** 2, axis=1) / dt**2
    return float(0.5 * np.dot(np.asarray(masses, dtype=np.float64), v2))


def potential_energy(positions, masses, *, gravity=GRAVITY) -> float:
    """Gravitational potential energy in joules, −Σ mᵢ g·xᵢ (zero at the origin; ``gravity`` (3,) m/s², a scene's
    :attr:`~mjcable.scene.Scene.gravity`)."""
    x = _points("positions", positions)
    return float(-np.dot(np.asarray(masses, dtype=np.float64), x @ np.asarray(gravity, dtype=np.float64)))


def energy(positions, previous: Optional[np.ndarray], dt: float, masses, *, gravity=GRAVITY) -> float:
    """Kinetic plus gravitational energy in joules (kinetic energy 0 when ``previous`` is ``None``).

    Elastic energy is left out on purpose: it is model-specific, small for a near-inextensible cable, and a
    diverging simulation shows up in the kinetic term.
    """
    kinetic = 0.0 if previous is None else kinetic_energy(positions, previous, dt, masses)
    return kinetic + potential_energy(positions, masses, gravity=gravity)



