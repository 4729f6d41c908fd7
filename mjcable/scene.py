"""The scene description: one cable, its pins and the obstacles around it.

Frozen dataclasses in SI units, validated on construction. Gravity is −9.81 m/s² along z. A :class:`Scene` is the
single source of truth from which every cable model (MuJoCo's native ones and the particle solvers) is built.

Construction checks what no model could simulate: a cable of more than :data:`MAX_SEGMENTS` segments, a cable that
starts inside an obstacle (deeper than :data:`START_CONTACT_TOLERANCE`), and warns about a cable thicker than its
segments are long.
"""

from __future__ import annotations

import collections.abc
import dataclasses
import functools
import math
import warnings
from typing import ClassVar, Optional, Tuple

import numpy as np

from mjcable import _validate, geometry, spline

__all__ = [
    "GRAVITY",
    "POISSON",
    "REST_SHAPES",
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
    "MAX_SEGMENTS",
    "START_CONTACT_TOLERANCE",
    "BODY_PIN_TOLERANCE",
    "BODY_PIN_REACH",
]

GRAVITY = np.array([0.0, 0.0, -9.81])  # m/s²
POISSON = 0.5  # Poisson's ratio ν of a cable whose shear_modulus is not given (an incompressible, rubber-like jacket)
REST_SHAPES = ("straight", "start")
PIN_KINDS = ("world", "gripper", "socket", "body")
BODY_PIN_TOLERANCE = 1e-3  # m: how far a body pin's point may start from its particle
# particles either side of a body pin that never touch the pin's body: the cable's end starts touching (or inside)
# the body it is fastened to
BODY_PIN_REACH = 2
# The most segments a cable may have. The start state is resampled at construction (about 4 s for 10⁵ segments on
# one core, linear in n) and its equal chords hold to n·ε·|x| (1e-11 m, 1e-6 of a chord, for a 1 m cable of 10⁵
# segments): beyond that resampling is slow and its round-off starts to show as strain. No model is practical
# there anyway (the ``joints`` chain's mass matrix has ~(3n)²/2 entries: 3.6 GB at 10⁴ segments). Without a limit
# a typo such as 10**9 allocates tens of GB before anything is built.
MAX_SEGMENTS = 100_000
# m: how far the cable's surface may start inside an obstacle (round-off of a cable laid exactly on a surface,
# far below any contact margin); deeper, MuJoCo's contacts and the solvers' projections throw it out at up to
# 1000 m/s on the first step.
START_CONTACT_TOLERANCE = 1e-6
_ROUND_OFF = 1e-9  # relative: lengths equal to this are equal

Vec3 = Tuple[float, float, float]


def _set(obj, name, value):
    object.__setattr__(obj, name, value)


@dataclasses.dataclass(frozen=True)
class CableSpec:
    """A cable: its start shape and physical properties.

    Args:
      points: ``(m, 3)`` Catmull-Rom control points in metres (m >= 2, finite, no consecutive repeats). The cable
        starts on the curve through them; its rest length is that curve resampled into ``n_segments`` equal chords.
      n_segments: number of segments (1 to :data:`MAX_SEGMENTS`); every model reports ``n_segments + 1``
        centreline particles.
      radius: cable radius in metres (> 0); a radius larger than a segment warns (neighbouring capsules overlap).
      mass: total cable mass in kg (> 0).
      young: Young's modulus in Pa for bending (>= 0; 0 is a limp rope). E·I uses I = π r⁴ / 4.
      stretch_stiffness: axial stiffness E·A in newtons (> 0), or ``None`` for an inextensible cable.
      damping: velocity damping rate in 1/s (>= 0); it never changes static equilibria.
      friction: Coulomb coefficient μ of the cable's contacts (>= 0), used for cable-obstacle contacts unless the
        obstacle sets its own.
      kind: Catmull-Rom kind, ``"centripetal"`` (default) or ``"uniform"`` (the thesis's form).
      shear_modulus: G in Pa (> 0) for twist (G·J, J = π r⁴ / 2) and shear (G·A); ``None``: E / (2 (1 + ν)) with
        ν = :data:`POISSON` = 0.5. Models without twist warn when it is given.
      rest_shape: ``"straight"`` (default: the unstressed cable is straight) or ``"start"`` (the start curve, with
        its twist-free frames, is the unstressed shape: a permanently bent cable); only models with a curved rest
        shape (``cosserat``) take ``"start"``, the others raise a ``ValueError``.
      section: ``(a, b)``, the semi-axes in metres (> 0) of an elliptic cross-section, ``a`` along the material
        frame's d₁ and ``b`` along d₂ (a flat cable: E·I₁ = E π a b³ / 4 about d₁, E·I₂ = E π a³ b / 4 about d₂,
        G·J with J = π a³ b³ / (a² + b²), A = π a b); ``None`` (default): the circle of ``radius``. ``radius``
        stays the contact radius. Only models with anisotropic bending (``cosserat``) take a section with a ≠ b;
        the others raise a ``ValueError``.
      section_axis: ``(3,)`` the direction of d₁ (the ``a`` semi-axis) at the cable's start, taken perpendicular
        to the first segment (and carried along the cable without twist); ``None``: the twist-free frames' own.

    Raises:
      ValueError: a parameter outside its range, or a curve that cannot be resampled into ``n_segments`` equal
        chords (the start state is resampled on construction).
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
    shear_modulus: Optional[float] = dataclasses.field(default=None, kw_only=True)
    rest_shape: str = dataclasses.field(default="straight", kw_only=True)
    section: Optional[tuple] = dataclasses.field(default=None, kw_only=True)
    section_axis: Optional[tuple] = dataclasses.field(default=None, kw_only=True)

    def __post_init__(self):
        curve = spline.CatmullRom(self.points, kind=self.kind)  # validates points and kind
        _set(self, "shear_modulus", _validate.optional_number("shear_modulus", self.shear_modulus, low=0.0,
                                                               low_open=True, unit="Pa"))
        _validate.choice("rest_shape", self.rest_shape, REST_SHAPES)
        if self.section is not None:
            try:
                a, b = self.section
            except (TypeError, ValueError):
                raise ValueError(f"section must be (a, b), two semi-axes in metres (> 0), or None, got "
                                 f"{self.section!r}") from None
            _set(self, "section", (_validate.number("section[0]", a, low=0.0, low_open=True, unit="m"),
                                   _validate.number("section[1]", b, low=0.0, low_open=True, unit="m")))
        if self.section_axis is not None:
            axis = _validate.vec3("section_axis", self.section_axis)
            if math.hypot(*axis) == 0.0:
                raise ValueError(f"section_axis must be a non-zero direction (3 numbers), got {self.section_axis!r}")
            _set(self, "section_axis", axis)
        _set(self, "points", tuple(tuple(float(x) for x in p) for p in curve.points))
        _set(self, "n_segments", _validate.integer("n_segments", self.n_segments, low=1))
        if self.n_segments > MAX_SEGMENTS:
            raise ValueError(f"n_segments must be at most mjcable.scene.MAX_SEGMENTS = {MAX_SEGMENTS} (no model is "
                             f"practical beyond it, and resampling the start state would take minutes to hours and "
                             f"gigabytes), got {self.n_segments}")
        _set(self, "radius", _validate.number("radius", self.radius, low=0.0, low_open=True, unit="m"))
        _set(self, "mass", _validate.number("mass", self.mass, low=0.0, low_open=True, unit="kg"))
        _set(self, "young", _validate.number("young", self.young, low=0.0, unit="Pa"))
        _set(self, "stretch_stiffness", _validate.optional_number("stretch_stiffness", self.stretch_stiffness,
                                                                   low=0.0, low_open=True, unit="N"))
        _set(self, "damping", _validate.number("damping", self.damping, low=0.0, unit="1/s"))
        _set(self, "friction", _validate.number("friction", self.friction, low=0.0))
        # segment_length resamples the start state (a curve that cannot be resampled raises here); a radius equal
        # to a segment up to round-off is not larger
        if self.radius > self.segment_length * (1.0 + _ROUND_OFF):
            warnings.warn(f"radius = {self.radius:g} m is larger than a segment ({self.segment_length:.3g} m, "
                          f"{self.n_segments} segments): neighbouring capsules overlap, so contacts are "
                          f"unreliable; use fewer segments or a thinner cable", stacklevel=3)

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

    def overlapping_neighbours(self, *, spheres: bool = False) -> int:
        """How far along the straight cable at rest its geoms overlap their neighbours: the largest k for which
        capsules of segments i and i + k overlap ((k − 1) l₀ < 2 r), or with ``spheres`` those at particles i and
        i + k (k l₀ < 2 r); at least 1 (the direct neighbour, which always touches). Self-collision skips these
        pairs: contacts of geoms that overlap at rest would push them apart and stretch the cable."""
        gap = 2.0 * self.radius / self.segment_length * (1.0 - _ROUND_OFF)
        return max(1, math.ceil(gap) - 1 if spheres else math.ceil(gap))

    @property
    def length(self) -> float:
        """Rest length of the whole cable in metres."""
        return self.segment_length * self.n_segments

    @property
    def semi_axes(self) -> tuple:
        """``(a, b)`` in metres: the cross-section's semi-axes along d₁ and d₂ (``section``, or the circle's)."""
        return self.section if self.section is not None else (self.radius, self.radius)

    @property
    def anisotropic(self) -> bool:
        """Whether the cross-section bends unequally about d₁ and d₂ (a ``section`` with a ≠ b)."""
        a, b = self.semi_axes
        return a != b

    @property
    def area(self) -> float:
        """Cross-section area π a b in m² (π r² for a circle)."""
        if self.section is None:
            return math.pi * self.radius**2
        a, b = self.section
        return math.pi * a * b

    @property
    def second_moments(self) -> tuple:
        """``(I₁, I₂)`` in m⁴, the second moments of area about d₁ and d₂: (π a b³ / 4, π a³ b / 4)."""
        a, b = self.semi_axes
        return (math.pi * a * b**3 / 4.0, math.pi * a**3 * b / 4.0)

    @property
    def second_moment(self) -> float:
        """Second moment of area I = π r⁴ / 4 in m⁴ (of an elliptic section: the mean of I₁ and I₂)."""
        if self.section is None:
            return math.pi * self.radius**4 / 4.0
        return 0.5 * sum(self.second_moments)

    @property
    def bending_stiffness(self) -> float:
        """E·I in N·m²."""
        return self.young * self.second_moment

    @property
    def bending_stiffnesses(self) -> tuple:
        """``(E·I₁, E·I₂)`` in N·m², about d₁ and d₂."""
        return tuple(self.young * i for i in self.second_moments)

    @property
    def polar_moment(self) -> float:
        """Torsion constant J in m⁴: π r⁴ / 2 (the polar second moment) for a circle, π a³ b³ / (a² + b²) for an
        ellipse (Saint-Venant)."""
        if self.section is None:
            return math.pi * self.radius**4 / 2.0
        a, b = self.section
        return math.pi * a**3 * b**3 / (a * a + b * b)

    @property
    def shear(self) -> float:
        """The shear modulus G in Pa: ``shear_modulus``, or E / (2 (1 + ν)) with ν = :data:`POISSON`."""
        return self.shear_modulus if self.shear_modulus is not None else self.young / (2.0 * (1.0 + POISSON))

    @property
    def torsion_stiffness(self) -> float:
        """G·J in N·m²."""
        return self.shear * self.polar_moment

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
        with :meth:`mjcable.Simulator.move_gripper`), ``"socket"`` (fixed until the pin's force exceeds
        ``release_force``, then released for good) or ``"body"`` (held at the point ``offset`` fixed in the frame
        of the scene world's body ``body``, which then feels the cable: see :class:`Scene`).
      body: the world body of a ``"body"`` pin.
      offset: ``(3,)`` m, the held point in ``body``'s frame; only for ``kind="body"``. At the start it must lie
        within :data:`BODY_PIN_TOLERANCE` of the pinned particle.
      clamp: also hold the cable's tangent at the pin (a cantilever root); a body clamp holds the direction the
        tangent has at the start, expressed in the body's frame (a rod with frames, ``cosserat``: the whole frame,
        and the body feels the rod's torque).
      release_force: force in newtons above which a socket lets go (> 0); only for ``kind="socket"``.
    """

    index: int
    kind: str = "world"
    body: Optional[str] = dataclasses.field(default=None, kw_only=True)
    offset: Vec3 = dataclasses.field(default=(0.0, 0.0, 0.0), kw_only=True)
    clamp: bool = dataclasses.field(default=False, kw_only=True)
    release_force: Optional[float] = dataclasses.field(default=None, kw_only=True)

    def __post_init__(self):
        _set(self, "index", _validate.integer("index", self.index))
        _validate.choice("kind", self.kind, PIN_KINDS)
        _set(self, "clamp", _validate.boolean("clamp", self.clamp))
        _set(self, "offset", _validate.vec3("offset", self.offset, unit="m"))
        if self.kind == "body":
            if not isinstance(self.body, str) or not self.body:
                raise ValueError(f"body is required for kind='body': the name of a body of the scene's world, "
                                 f"got {self.body!r}")
        else:
            if self.body is not None:
                raise ValueError(f"body applies only to kind='body', got body={self.body!r} for kind={self.kind!r}")
            if any(self.offset):
                raise ValueError(f"offset applies only to kind='body', got offset={self.offset!r} for "
                                 f"kind={self.kind!r}")
        if self.kind == "socket":
            if self.release_force is None:
                raise ValueError("release_force is required for a socket pin: the force in N above which it lets go")
            _set(self, "release_force",
                 _validate.number("release_force", self.release_force, low=0.0, low_open=True, unit="N"))
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


@dataclasses.dataclass(frozen=True)
class Scene:
    """A cable with its pins and obstacles. A scene has exactly the obstacles it lists: no implicit floor.

    Args:
      cable: the cable.
      pins: a sequence of pins on distinct particles.
      obstacles: a sequence of static obstacles; the cable's start (its particles, grown by its radius) must lie
        outside every one of them, up to :data:`START_CONTACT_TOLERANCE` (lying on a surface is fine).
      name: optional label (the built-in scenes set it).
      world: the user's MuJoCo world around the cable: an MJCF path (``str`` or ``os.PathLike``; relative asset
        paths resolve against its folder) or a ``mujoco.MjSpec`` (copied, never mutated); loaded once into a
        :class:`mjcable.user_world.World`. Its gravity is the scene's; every model builds its cable into it, keeping
        the user's names, joint, actuator and sensor order, keyframes and options (see :mod:`mjcable.user_world`).
        ``None``: only the listed obstacles.
      keyframe: the world's keyframe the simulation starts from (``None``: its default pose); only with ``world``.

    Raises:
      ValueError: a bad pin or obstacle sequence, a pin out of range or two on one particle, a cable that starts
        inside an obstacle (naming the obstacle, the particle and the depth), an unreadable world, an unknown
        keyframe or body, or a body pin whose point starts more than :data:`BODY_PIN_TOLERANCE` from its particle.
    """

    cable: CableSpec
    pins: tuple = ()
    obstacles: tuple = ()
    name: str = dataclasses.field(default="scene", kw_only=True)
    world: object = dataclasses.field(default=None, kw_only=True)
    keyframe: Optional[str] = dataclasses.field(default=None, kw_only=True)

    def __post_init__(self):
        if not isinstance(self.cable, CableSpec):
            raise ValueError(f"cable must be a CableSpec, got {type(self.cable).__name__}")
        pins = _sequence("pins", self.pins, Pin, "Pin instances, e.g. (Pin(0),)")
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
        obstacles = _sequence("obstacles", self.obstacles, Obstacle,
                              "Floor, Box, Cylinder, Capsule or Sphere instances, e.g. (Floor(),)")
        _check_start_clear(self.cable, obstacles)
        _set(self, "pins", pins)
        _set(self, "obstacles", obstacles)
        if not isinstance(self.name, str):
            raise ValueError(f"name must be a str, got {self.name!r}")
        if self.world is None:
            if self.keyframe is not None:
                raise ValueError(f"keyframe applies only to a scene with a world, got keyframe={self.keyframe!r}")
            body_pins = [k for k, pin in enumerate(pins) if pin.kind == "body"]
            if body_pins:
                k = body_pins[0]
                raise ValueError(f"pins[{k}] holds body {pins[k].body!r}, but the scene has no world; give "
                                 f"Scene(..., world=MJCF path or MjSpec)")
        else:
            from mjcable import user_world  # scene.py is imported by everything; the world module only here

            _set(self, "world", user_world.load(self.world, keyframe=self.keyframe))
            self._check_body_pins()
            self._check_start_clear_of_world()

    def _check_body_pins(self) -> None:
        p = self.cable.particles
        for k, pin in enumerate(self.pins):
            if pin.kind != "body":
                continue
            point = self.world.body_point(pin.body, pin.offset)
            i = self.pin_particle(k)
            miss = float(np.linalg.norm(point - p[i]))
            if miss > BODY_PIN_TOLERANCE:
                raise ValueError(
                    f"pins[{k}]: the point offset={pin.offset} of body {pin.body!r} starts at "
                    f"{np.round(point, 6).tolist()}, {miss:.4g} m from particle {i} at {np.round(p[i], 6).tolist()} "
                    f"(allowed: {BODY_PIN_TOLERANCE:g} m); move the cable's end or change the offset")

    def _check_start_clear_of_world(self) -> None:
        """Raise if the cable's surface starts more than :data:`START_CONTACT_TOLERANCE` inside a geom of the world
        that it can collide with. A pinned particle may start inside a geom (a plug in its socket: its pin holds it),
        and the particles within :data:`BODY_PIN_REACH` of a body pin never touch its body."""
        n = self.cable.n_particles
        ignore = [(pin.body, range(max(self.pin_particle(k) - BODY_PIN_REACH, 0),
                                   min(self.pin_particle(k) + BODY_PIN_REACH + 1, n)))
                  for k, pin in enumerate(self.pins) if pin.kind == "body"]
        held = [self.pin_particle(k) for k in range(len(self.pins))]
        deepest = self.world.start_depth(self.cable.particles, self.cable.radius, ignore, held)
        if deepest is not None and deepest.depth > START_CONTACT_TOLERANCE:
            i = deepest.particle
            raise ValueError(
                f"world geom {deepest.geom!r} (body {deepest.body!r}) holds the cable's start: particle {i} at "
                f"{np.round(self.cable.particles[i], 6).tolist()} is {deepest.depth:.4g} m deep (the cable's radius "
                f"{self.cable.radius:g} m included; up to {START_CONTACT_TOLERANCE:g} m is allowed); move the geom, "
                f"the world's start pose (keyframe) or the cable's points")

    @functools.cached_property
    def hanging_weights(self) -> np.ndarray:
        """``(len(pins),)`` N: the weight each body pin's body hangs on the cable at the start
        (:meth:`mjcable.user_world.World.hanging_weight`; 0 for the other pins). The models' stability rules count it
        in the cable's tension."""
        return np.array([self.world.hanging_weight(pin.body, pin.offset) if pin.kind == "body" else 0.0
                         for pin in self.pins], dtype=np.float64)

    @property
    def max_tension(self) -> float:
        """N: a bound on the cable's static tension, its weight |g| m plus what bodies hang on its pins
        (:attr:`hanging_weights`); the models' stability rules use it."""
        return float(np.linalg.norm(self.gravity)) * self.cable.mass + float(np.sum(self.hanging_weights))

    @property
    def gravity(self) -> np.ndarray:
        """``(3,)`` m/s²: the world's ``<option gravity>``, or :data:`GRAVITY` without a world."""
        return GRAVITY.copy() if self.world is None else self.world.gravity.copy()

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


def _sequence(name: str, value, kind: type, what: str) -> tuple:
    """``value`` as a tuple of ``kind`` instances (a single instance, or anything else, is rejected)."""
    if isinstance(value, (str, bytes, kind)) or not isinstance(value, collections.abc.Iterable):
        raise ValueError(f"{name} must be a sequence of {what}, got {value!r}")
    items = tuple(value)
    for k, item in enumerate(items):
        if not isinstance(item, kind):
            raise ValueError(f"{name}[{k}] must be one of {what}, got {item!r}")
    return items


def _check_start_clear(cable: CableSpec, obstacles: tuple) -> None:
    """Raise if the cable's surface starts more than :data:`START_CONTACT_TOLERANCE` inside an obstacle."""
    for k, ob in enumerate(obstacles):
        distances, _ = geometry.signed_distances(cable.particles, ob)
        depth = cable.radius - distances  # how far the cable's surface reaches into the obstacle, m
        i = int(np.argmax(depth))
        if depth[i] > START_CONTACT_TOLERANCE:
            raise ValueError(
                f"obstacles[{k}] ({type(ob).__name__} at pos={ob.pos}) holds the cable's start: particle {i} at "
                f"{np.round(cable.particles[i], 6).tolist()} is {depth[i]:.4g} m deep (the cable's radius "
                f"{cable.radius:g} m included; up to {START_CONTACT_TOLERANCE:g} m is allowed); move the obstacle or "
                f"the cable's points")


# TEMP shim (dropped when branch `cables` is merged): the several-cable API for one cable
Scene.cables = property(lambda self: (self.cable,))
Scene.n_particles = property(lambda self: self.cable.n_particles)
Scene.cable_slices = property(lambda self: (slice(0, self.cable.n_particles),))
Scene.particles = property(lambda self: self.cable.particles)
Scene.junctions = ()
