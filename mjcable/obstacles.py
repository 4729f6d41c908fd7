"""The rigid, static obstacles of a scene: floors, boxes, cylinders, capsules and spheres, and the check that a cable
starts outside them (:func:`check_start_clear`).

Frozen dataclasses in SI units, validated on construction; re-exported by :mod:`mjcable.scene`.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar, Optional

import numpy as np

from mjcable import _validate, geometry
from mjcable._validate import Vec3, set_field as _set

__all__ = ["Obstacle", "Floor", "Box", "Cylinder", "Capsule", "Sphere", "START_CONTACT_TOLERANCE", "check_start_clear"]

# m: how far a cable's surface may start inside an obstacle (round-off of a cable laid exactly on a surface,
# far below any contact margin); deeper, MuJoCo's contacts and the solvers' projections throw it out at up to
# 1000 m/s on the first step.
START_CONTACT_TOLERANCE = 1e-6



@dataclasses.dataclass(frozen=True)
class Obstacle:
    """Base of the rigid, static obstacles. ``pos`` in metres, ``euler`` in degrees (MuJoCo's xyz convention),
    ``friction`` the Coulomb μ of contacts with this obstacle (``None``: the cable's μ)."""

    pos: Vec3 = dataclasses.field(default=(0.0, 0.0, 0.0), kw_only=True)
    euler: Vec3 = dataclasses.field(default=(0.0, 0.0, 0.0), kw_only=True)
    friction: Optional[float] = dataclasses.field(default=None, kw_only=True)

    def __post_init__(self):
        _set(self, "pos", _validate.vec3("pos", self.pos, unit="m"))
        _set(self, "euler", _validate.vec3("euler", self.euler, unit="degrees"))
        _set(self, "friction", _validate.optional_number("friction", self.friction, low=0.0))


@dataclasses.dataclass(frozen=True)
class Floor(Obstacle):
    """An infinite plane through ``pos``, normal along the rotated z axis."""

    shape: ClassVar[str] = "plane"


@dataclasses.dataclass(frozen=True)
class Box(Obstacle):
    """A box with half-extents ``size`` in metres (a table is a box)."""

    shape: ClassVar[str] = "box"
    size: Vec3 = (0.5, 0.5, 0.05)

    def __post_init__(self):
        super().__post_init__()
        size = _validate.vec3("size", self.size, unit="m")
        if min(size) <= 0:
            raise ValueError(f"size must be 3 positive half-extents in metres, got {self.size!r}")
        _set(self, "size", size)


@dataclasses.dataclass(frozen=True)
class _Round(Obstacle):
    radius: float = 0.05

    def __post_init__(self):
        super().__post_init__()
        _set(self, "radius", _validate.number("radius", self.radius, low=0.0, low_open=True, unit="m"))


@dataclasses.dataclass(frozen=True)
class Sphere(_Round):
    """A sphere of ``radius`` metres."""

    shape: ClassVar[str] = "sphere"


@dataclasses.dataclass(frozen=True)
class Cylinder(_Round):
    """A cylinder of ``radius`` and ``half_length`` metres along its local z axis."""

    shape: ClassVar[str] = "cylinder"
    half_length: float = 0.25

    def __post_init__(self):
        super().__post_init__()
        _set(self, "half_length", _validate.number("half_length", self.half_length, low=0.0, low_open=True, unit="m"))


@dataclasses.dataclass(frozen=True)
class Capsule(Cylinder):
    """A capsule of ``radius`` and cylinder ``half_length`` metres along its local z axis."""

    shape: ClassVar[str] = "capsule"


def check_start_clear(cable, obstacles: tuple, named: str = "") -> None:
    """Raise if ``cable`` (a :class:`mjcable.scene.CableSpec`) starts with its surface more than
    :data:`START_CONTACT_TOLERANCE` inside one of ``obstacles`` (``named``: which cable, for the message)."""
    for k, ob in enumerate(obstacles):
        distances, _ = geometry.signed_distances(cable.particles, ob)
        depth = cable.radius - distances  # how far the cable's surface reaches into the obstacle, m
        i = int(np.argmax(depth))
        if depth[i] > START_CONTACT_TOLERANCE:
            raise ValueError(
                f"obstacles[{k}] ({type(ob).__name__} at pos={ob.pos}) holds the cable's start: particle {i}{named} "
                f"at {np.round(cable.particles[i], 6).tolist()} is {depth[i]:.4g} m deep (the cable's radius "
                f"{cable.radius:g} m included; up to {START_CONTACT_TOLERANCE:g} m is allowed); move the obstacle or "
                f"the cable's points")
