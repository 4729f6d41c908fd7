"""Rings: small rings (pinholes) that a cable passes through at the start and slides through at run time, fixed in
the world or on a body of the scene's world, with Coulomb friction on their rim.

A frozen dataclass validated on construction; :class:`mjcable.scene.Scene` checks it against its cables and world.
Re-exported by :mod:`mjcable.scene`.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Optional

import numpy as np

from mjcable import _validate
from mjcable._validate import Vec3, set_field as _set

__all__ = ["Ring", "check_threaded", "start_frame"]


@dataclasses.dataclass(frozen=True)
class Ring:
    """A ring (a pinhole) that cable ``cable`` passes through at the start and slides through.

    Args:
      pos: ``(3,)`` m, the ring's centre: in the world frame, or in ``body``'s frame when ``body`` is given.
      axis: ``(3,)``, the ring's axis (the normal of its plane; any length > 0, kept as a unit vector), in the same
        frame as ``pos``.
      radius: m, the radius of the ring's hole (> 0); ``None``: twice the threaded cable's radius.
      body: the name of a body of the scene's world that carries the ring (it then feels the cable); ``None``: fixed
        in the world.
      friction: Coulomb coefficient μ of the ring's rim (>= 0): a cable turning through the ring by an angle θ holds
        while the tensions either side differ by less than the capstan ratio e^{μθ}.
      cable: which of the scene's cables (an index into ``Scene.cables``, >= 0) passes through the ring.
      stop: a particle index of that cable (negative counts from its end) that cannot pass the ring (a bead on the
        cable); ``None``: an end that reaches the ring slips out, and the ring lets go of the cable.

    Example::

        Ring((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), friction=0.3)   # a hole in the y-z plane at 1 m
    """

    pos: Vec3
    axis: Vec3
    radius: Optional[float] = dataclasses.field(default=None, kw_only=True)
    body: Optional[str] = dataclasses.field(default=None, kw_only=True)
    friction: float = dataclasses.field(default=0.0, kw_only=True)
    cable: int = dataclasses.field(default=0, kw_only=True)
    stop: Optional[int] = dataclasses.field(default=None, kw_only=True)

    def __post_init__(self):
        _set(self, "pos", _validate.vec3("pos", self.pos, unit="m"))
        axis = np.asarray(_validate.vec3("axis", self.axis))
        norm = float(np.linalg.norm(axis))
        if not norm > 0.0:
            raise ValueError(f"axis must be a non-zero vector, got {self.axis!r}")
        _set(self, "axis", tuple(float(a) for a in axis / norm))
        _set(self, "radius", _validate.optional_number("radius", self.radius, low=0.0, low_open=True, unit="m"))
        if self.body is not None and (not isinstance(self.body, str) or not self.body):
            raise ValueError(f"body must be the name of a body of the scene's world or None, got {self.body!r}")
        _set(self, "friction", _validate.number("friction", self.friction, low=0.0))
        _set(self, "cable", _validate.integer("cable", self.cable, low=0))
        if self.stop is not None:
            _set(self, "stop", _validate.integer("stop", self.stop))

    def hole(self, cable_radius: float) -> float:
        """m: the hole's radius for a cable of radius ``cable_radius`` (``radius``, or twice the cable's)."""
        return 2.0 * cable_radius if self.radius is None else self.radius


def start_frame(ring: Ring, world) -> tuple:
    """``(centre, axis)``: ``ring``'s centre (3,) m and unit axis (3,) in the world frame at the start (a ring on a
    body placed by ``world``'s start pose, a :class:`mjcable.user_world.World`)."""
    if ring.body is None:
        return np.asarray(ring.pos, dtype=np.float64), np.asarray(ring.axis, dtype=np.float64)
    pos, rot = world.body_pose(ring.body)
    return pos + rot @ np.asarray(ring.pos), rot @ np.asarray(ring.axis)


def check_threaded(k: int, ring: Ring, cable, centre: np.ndarray, axis: np.ndarray) -> None:
    """Raise unless ``cable`` (a :class:`mjcable.scene.CableSpec`) starts threaded through ``ring`` (``rings[k]`` of
    a scene) at ``centre`` (3,) m with unit ``axis`` (3,): its centreline crosses the ring's plane within the hole's
    radius less the cable's radius of the centre, and the hole is wider than the cable."""
    hole = ring.hole(cable.radius)
    if hole <= cable.radius:
        raise ValueError(f"rings[{k}].radius must exceed the cable's radius {cable.radius:g} m (the cable passes "
                         f"through the hole), got {hole:g} m")
    p = cable.particles
    side = (p - centre) @ axis
    ahead = side >= 0.0
    cross = np.flatnonzero(ahead[:-1] != ahead[1:])
    a, b = side[cross], side[cross + 1]
    t = np.where(a == b, 0.5, a / np.where(a == b, 1.0, a - b))[:, None]
    points = p[cross] + t * (p[cross + 1] - p[cross])
    best = float(np.min(np.linalg.norm(points - centre, axis=1))) if len(cross) else math.inf
    if not best <= hole - cable.radius:
        where = "never crosses the ring's plane" if not len(cross) else (
            f"crosses the ring's plane {best:.4g} m from its centre")
        raise ValueError(f"rings[{k}]: cable {ring.cable}'s start {where}; it must pass through the hole, within "
                         f"{hole - cable.radius:.4g} m of the centre (the hole's radius {hole:g} m less the cable's "
                         f"radius)")
