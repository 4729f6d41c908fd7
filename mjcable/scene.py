"""The scene description: one cable, its pins and the obstacles around it.

Frozen dataclasses in SI units, validated on construction. Gravity is −9.81 m/s² along z. A :class:`Scene` is the
single source of truth from which every cable model (MuJoCo's native ones and the particle solvers) is built.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import ClassVar, Optional, Tuple

import numpy as np

from mjcable import spline

__all__ = [
    "GRAVITY",
    "CableSpec",
    "Pin",
    "PIN_KINDS",
    "Obstacle",
    "Floor",
    "Box",
    "Cylinder",
    "Capsule",
    "Sphere",
    "Scene",
]

GRAVITY = np.array([0.0, 0.0, -9.81])  # m/s²
PIN_KINDS = ("world", "gripper", "socket")

Vec3 = Tuple[float, float, float]


def _finite_number(name: str, value, *, low: float = -math.inf, low_inclusive: bool = True) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number, got {value!r}")
    v = float(value)
    ok = math.isfinite(v) and (v >= low if low_inclusive else v > low)
    if not ok:
        bound = f">= {low:g}" if low_inclusive else f"> {low:g}"
        raise ValueError(f"{name} must be finite and {bound}, got {value!r}")
    return v


def _vec3(name: str, value) -> Vec3:
    try:
        v = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be 3 finite numbers, got {value!r}") from exc
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be 3 finite numbers, got {value!r}")
    return tuple(float(x) for x in v)


def _set(obj, name, value):
    object.__setattr__(obj, name, value)


@dataclasses.dataclass(frozen=True)
class CableSpec:
    """A cable: its start shape and physical properties.

    Args:
      points: ``(m, 3)`` Catmull-Rom control points in metres (m >= 2, finite, no consecutive repeats). The cable
        starts on the curve through them; its rest length is that curve resampled into ``n_segments`` equal chords.
      n_segments: number of segments (>= 1); every model reports ``n_segments + 1`` centreline particles.
      radius: cable radius in metres (> 0).
      mass: total cable mass in kg (> 0).
      young: Young's modulus in Pa for bending (>= 0; 0 is a limp rope). E·I uses I = π r⁴ / 4.
      stretch_stiffness: axial stiffness E·A in newtons (> 0), or ``None`` for an inextensible cable.
      damping: velocity damping rate in 1/s (>= 0); it never changes static equilibria.
      friction: Coulomb coefficient μ of the cable's contacts (>= 0), used for cable-obstacle contacts unless the
        obstacle sets its own.
      kind: Catmull-Rom kind, ``"centripetal"`` (default) or ``"uniform"`` (the thesis's form).
    """

    points: tuple
    n_segments: int
    radius: float
    mass: float
    young: float = dataclasses.field(default=0.0, kw_only=True)
    stretch_stiffness: Optional[float] = dataclasses.field(default=None, kw_only=True)
    damping: float = dataclasses.field(default=0.0, kw_only=True)
    friction: float = dataclasses.field(default=1.0, kw_only=True)
    kind: str = dataclasses.field(default="centripetal", kw_only=True)

    def __post_init__(self):
        curve = spline.CatmullRom(self.points, kind=self.kind)  # validates points and kind
        _set(self, "points", tuple(tuple(float(x) for x in p) for p in curve.points))
        n = self.n_segments
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ValueError(f"n_segments must be an integer >= 1, got {n!r}")
        _set(self, "n_segments", int(n))
        _set(self, "radius", _finite_number("radius", self.radius, low=0.0, low_inclusive=False))
        _set(self, "mass", _finite_number("mass", self.mass, low=0.0, low_inclusive=False))
        _set(self, "young", _finite_number("young", self.young, low=0.0))
        if self.stretch_stiffness is not None:
            _set(self, "stretch_stiffness",
                 _finite_number("stretch_stiffness", self.stretch_stiffness, low=0.0, low_inclusive=False))
        _set(self, "damping", _finite_number("damping", self.damping, low=0.0))
        _set(self, "friction", _finite_number("friction", self.friction, low=0.0))

    @functools.cached_property
    def curve(self) -> spline.CatmullRom:
        return spline.CatmullRom(self.points, kind=self.kind)

    @functools.cached_property
    def particles(self) -> np.ndarray:
        """``(n_segments + 1, 3)`` start positions in metres at exactly equal chords (read-only)."""
        p = spline.resample(self.curve, self.n_segments)
        p.setflags(write=False)
        return p

    @property
    def n_particles(self) -> int:
        return self.n_segments + 1

    @functools.cached_property
    def segment_length(self) -> float:
        """Rest length of one segment in metres (the equal chord)."""
        return float(np.mean(np.linalg.norm(np.diff(self.particles, axis=0), axis=1)))

    @property
    def length(self) -> float:
        """Rest length of the whole cable in metres."""
        return self.segment_length * self.n_segments

    @property
    def area(self) -> float:
        """Cross-section area π r² in m²."""
        return math.pi * self.radius**2

    @property
    def second_moment(self) -> float:
        """Second moment of area I = π r⁴ / 4 in m⁴."""
        return math.pi * self.radius**4 / 4.0

    @property
    def bending_stiffness(self) -> float:
        """E·I in N·m²."""
        return self.young * self.second_moment

    @property
    def linear_density(self) -> float:
        """Mass per metre in kg/m."""
        return self.mass / self.length

    @property
    def particle_masses(self) -> np.ndarray:
        """``(n_segments + 1,)`` lumped masses in kg: m/n inside, m/2n at the ends (each segment's mass split
        between its two particles); they sum to ``mass``."""
        m = np.full(self.n_particles, self.mass / self.n_segments)
        m[[0, -1]] *= 0.5
        return m


@dataclasses.dataclass(frozen=True)
class Pin:
    """Holds one cable particle.

    Args:
      index: particle index; negative values count from the end (``Pin(-1)`` is the last particle).
      kind: ``"world"`` (fixed at its start position, free to rotate), ``"gripper"`` (attached to a mocap body moved
        with :meth:`mjcable.Simulator.move_gripper`) or ``"socket"`` (fixed until the pin's force exceeds
        ``release_force``, then released for good).
      clamp: also hold the cable's tangent at the pin (a cantilever root).
      release_force: force in newtons above which a socket lets go (> 0); only for ``kind="socket"``.
    """

    index: int
    kind: str = "world"
    clamp: bool = dataclasses.field(default=False, kw_only=True)
    release_force: Optional[float] = dataclasses.field(default=None, kw_only=True)

    def __post_init__(self):
        if isinstance(self.index, bool) or not isinstance(self.index, (int, np.integer)):
            raise ValueError(f"index must be an integer, got {self.index!r}")
        _set(self, "index", int(self.index))
        if self.kind not in PIN_KINDS:
            raise ValueError(f"kind must be one of {PIN_KINDS}, got {self.kind!r}")
        if not isinstance(self.clamp, (bool, np.bool_)):
            raise ValueError(f"clamp must be a bool, got {self.clamp!r}")
        _set(self, "clamp", bool(self.clamp))
        if self.kind == "socket":
            if self.release_force is None:
                raise ValueError("release_force is required for a socket pin: the force in N above which it lets go")
            _set(self, "release_force",
                 _finite_number("release_force", self.release_force, low=0.0, low_inclusive=False))
        elif self.release_force is not None:
            raise ValueError(f"release_force applies only to kind='socket', got {self.release_force!r} "
                             f"for kind={self.kind!r}")


@dataclasses.dataclass(frozen=True)
class Obstacle:
    """Base of the rigid, static obstacles. ``pos`` in metres, ``euler`` in degrees (MuJoCo's xyz convention),
    ``friction`` the Coulomb μ of contacts with this obstacle (``None``: the cable's μ)."""

    pos: Vec3 = dataclasses.field(default=(0.0, 0.0, 0.0), kw_only=True)
    euler: Vec3 = dataclasses.field(default=(0.0, 0.0, 0.0), kw_only=True)
    friction: Optional[float] = dataclasses.field(default=None, kw_only=True)

    def __post_init__(self):
        _set(self, "pos", _vec3("pos", self.pos))
        _set(self, "euler", _vec3("euler", self.euler))
        if self.friction is not None:
            _set(self, "friction", _finite_number("friction", self.friction, low=0.0))


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
        size = _vec3("size", self.size)
        if min(size) <= 0:
            raise ValueError(f"size must be 3 positive half-extents in metres, got {self.size!r}")
        _set(self, "size", size)


@dataclasses.dataclass(frozen=True)
class _Round(Obstacle):
    radius: float = 0.05

    def __post_init__(self):
        super().__post_init__()
        _set(self, "radius", _finite_number("radius", self.radius, low=0.0, low_inclusive=False))


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
        _set(self, "half_length", _finite_number("half_length", self.half_length, low=0.0, low_inclusive=False))


@dataclasses.dataclass(frozen=True)
class Capsule(Cylinder):
    """A capsule of ``radius`` and cylinder ``half_length`` metres along its local z axis."""

    shape: ClassVar[str] = "capsule"


@dataclasses.dataclass(frozen=True)
class Scene:
    """A cable with its pins and obstacles. A scene has exactly the obstacles it lists: no implicit floor.

    Args:
      cable: the cable.
      pins: pins on distinct particles.
      obstacles: static obstacles.
      name: optional label (the built-in scenes set it).
    """

    cable: CableSpec
    pins: tuple = ()
    obstacles: tuple = ()
    name: str = dataclasses.field(default="scene", kw_only=True)

    def __post_init__(self):
        if not isinstance(self.cable, CableSpec):
            raise ValueError(f"cable must be a CableSpec, got {type(self.cable).__name__}")
        pins = tuple(self.pins)
        for pin in pins:
            if not isinstance(pin, Pin):
                raise ValueError(f"pins must be Pin instances, got {pin!r}")
        n = self.cable.n_particles
        seen = {}
        for k, pin in enumerate(pins):
            if not -n <= pin.index < n:
                raise ValueError(f"pins[{k}].index must lie in [{-n}, {n - 1}] for a cable of {n} particles, "
                                 f"got {pin.index}")
            i = pin.index % n
            if i in seen:
                raise ValueError(f"two pins on one particle: pins[{seen[i]}] and pins[{k}] both hold particle {i}")
            seen[i] = k
        obstacles = tuple(self.obstacles)
        for ob in obstacles:
            if not isinstance(ob, Obstacle):
                raise ValueError(f"obstacles must be Floor, Box, Cylinder, Capsule or Sphere, got {ob!r}")
        _set(self, "pins", pins)
        _set(self, "obstacles", obstacles)

    def pin_particle(self, k: int) -> int:
        """The particle index (non-negative) held by ``pins[k]``."""
        return self.pins[k].index % self.cable.n_particles

    def clamp_neighbour(self, k: int) -> int:
        """The particle next to a clamped pin, towards the cable's inside, that fixes its tangent."""
        i = self.pin_particle(k)
        return i + 1 if i < self.cable.n_segments else i - 1

    @property
    def grippers(self) -> tuple:
        """Indices into ``pins`` of the gripper pins."""
        return tuple(k for k, p in enumerate(self.pins) if p.kind == "gripper")

    def with_cable(self, **overrides) -> "Scene":
        """A copy with ``CableSpec`` fields replaced (e.g. ``n_segments=100``)."""
        return dataclasses.replace(self, cable=dataclasses.replace(self.cable, **overrides))
