"""The rigid, static obstacles of a scene: floors, boxes, cylinders, capsules and spheres.

Frozen dataclasses in SI units, validated on construction; re-exported by :mod:`mjcable.scene`.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar, Optional, Tuple

from mjcable import _validate

__all__ = ["Obstacle", "Floor", "Box", "Cylinder", "Capsule", "Sphere"]

Vec3 = Tuple[float, float, float]


def _set(obj, name, value):
    object.__setattr__(obj, name, value)


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
