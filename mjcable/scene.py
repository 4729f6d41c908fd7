"""The scene description: one cable or several, their pins and junctions, and the obstacles around them.

Frozen dataclasses in SI units, validated on construction. Gravity is −9.81 m/s² along z. A :class:`Scene` is the
single source of truth from which every cable model (MuJoCo's native ones and the particle solvers) is built.

Construction checks what no model could simulate: a cable of more than :data:`MAX_SEGMENTS` segments, a cable that
starts inside an obstacle (deeper than :data:`START_CONTACT_TOLERANCE`), a junction whose particles start apart, and
warns about a cable thicker than its segments are long. Pins and junctions live in :mod:`mjcable.joins`, obstacles in
:mod:`mjcable.obstacles` (both re-exported here).
"""

from __future__ import annotations

import collections.abc
import dataclasses
import functools
import math
import warnings
from typing import Optional

import numpy as np

from mjcable import _validate, geometry, joins, spline
from mjcable._validate import set_field as _set
from mjcable import obstacles as obstacles_
from mjcable.joins import BODY_PIN_TOLERANCE, JUNCTION_TOLERANCE, PIN_KINDS, Gripper, Junction, Pin
from mjcable.obstacles import START_CONTACT_TOLERANCE, Box, Capsule, Cylinder, Floor, Obstacle, Sphere
from mjcable import rings as rings_
from mjcable.rings import Ring

__all__ = [
    "GRAVITY",
    "POISSON",
    "REST_SHAPES",
    "CableSpec",
    "Pin",
    "PIN_KINDS",
    "Gripper",
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
    "Junction",
    "JUNCTION_TOLERANCE",
    "BODY_PIN_REACH",
    "Ring",
]

GRAVITY = np.array([0.0, 0.0, -9.81])  # m/s²
POISSON = 0.5  # Poisson's ratio ν of a cable whose shear_modulus is not given (an incompressible, rubber-like jacket)
REST_SHAPES = ("straight", "start")
# particles either side of a body pin that never touch the pin's body: the cable's end starts touching (or inside)
# the body it is fastened to
BODY_PIN_REACH = 2
# The most segments a cable may have. The start state is resampled at construction (about 4 s for 10⁵ segments on
# one core, linear in n) and its equal chords hold to n·ε·|x| (1e-11 m, 1e-6 of a chord, for a 1 m cable of 10⁵
# segments): beyond that resampling is slow and its round-off starts to show as strain. No model is practical
# there anyway (the ``joints`` chain's mass matrix has ~(3n)²/2 entries: 3.6 GB at 10⁴ segments). Without a limit
# a typo such as 10**9 allocates tens of GB before anything is built.
MAX_SEGMENTS = 100_000
_ROUND_OFF = 1e-9  # relative: lengths equal to this are equal


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
      start_twist: Φ in rad, a uniform twist of the start frames (segment i turned about its tangent by
        Φ (i + ½) / n), while the rest shape stays untwisted: Φ is elastic twist (Michell's ring is a cable closed by
        a clamped junction with its ends turned by Φ). Only models that honour it (``cosserat``) take Φ ≠ 0.

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
    start_twist: float = dataclasses.field(default=0.0, kw_only=True)

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
        _set(self, "start_twist", _validate.number("start_twist", self.start_twist, unit="rad"))
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
class Scene:
    """Cables with their pins, junctions and obstacles. A scene has exactly the obstacles it lists: no implicit floor.

    Args:
      cable: the cable, or a non-empty sequence of cables. One cable (a ``CableSpec``, or a sequence of one) is kept
        as the ``CableSpec`` itself; several are kept as a tuple. :attr:`cables` is always the tuple.
      pins: a sequence of pins on distinct particles; ``Pin(index, cable=c)`` holds particle ``index`` of cable ``c``.
      obstacles: a sequence of static obstacles; every cable's start (its particles, grown by its radius) must lie
        outside every one of them, up to :data:`START_CONTACT_TOLERANCE` (lying on a surface is fine).
      junctions: a sequence of :class:`Junction` joining two particles of the cables into one point (a harness's
        branch point; one cable's two ends: a loop); they must start within :data:`JUNCTION_TOLERANCE` of each
        other.
      name: optional label (the built-in scenes set it).
      world: the user's MuJoCo world around the cable: an MJCF path (``str`` or ``os.PathLike``; relative asset
        paths resolve against its folder) or a ``mujoco.MjSpec`` (copied, never mutated); loaded once into a
        :class:`mjcable.user_world.World`. Its gravity is the scene's; every model builds its cable into it, keeping
        the user's names, joint, actuator and sensor order, keyframes and options (see :mod:`mjcable.user_world`).
        ``None``: only the listed obstacles.
      keyframe: the world's keyframe the simulation starts from (``None``: its default pose); only with ``world``.
      rings: a sequence of :class:`Ring` s (pinholes) that a cable passes through at the start and slides through;
        the cable's centreline must cross each ring's plane inside its hole (clear of the rim by the cable's radius).
      grippers: a sequence of free :class:`Gripper` s, mocap bodies that hold nothing at the start and grasp a
        particle at run time (:meth:`mjcable.Simulator.grasp`); free gripper ``g`` is numbered ``len(pins) + g``
        where a Simulator numbers grippers (``move_gripper``, ``step_along``). :attr:`gripper_pins` are the gripper
        pins.

    Particles of several cables are numbered in cable order: cable ``c``'s particle ``i`` is the global particle
    ``cable_slices[c].start + i`` of :attr:`particles` (and of a Simulator's positions).

    Raises:
      ValueError: a bad cable, pin, junction or obstacle sequence, a pin or junction out of range, two pins on one
        particle, a junction whose particles start apart, two cables that start inside each other (away from their
        junctions), a cable that starts inside an obstacle (naming the obstacle, the particle and the depth), an unreadable world, an unknown keyframe or body, or a body pin whose
        point starts more than :data:`BODY_PIN_TOLERANCE` from its particle.

    Example::

        harness = Scene((trunk, leg), pins=(Pin(0), Pin(-1, cable=1)), junctions=(Junction((0, -1), (1, 0)),))
    """

    cable: CableSpec
    pins: tuple = ()
    obstacles: tuple = ()
    junctions: tuple = dataclasses.field(default=(), kw_only=True)
    name: str = dataclasses.field(default="scene", kw_only=True)
    world: object = dataclasses.field(default=None, kw_only=True)
    keyframe: Optional[str] = dataclasses.field(default=None, kw_only=True)
    grippers: tuple = dataclasses.field(default=(), kw_only=True)
    rings: tuple = dataclasses.field(default=(), kw_only=True)

    def __post_init__(self):
        _set(self, "cable", _cables(self.cable))
        pins = _sequence("pins", self.pins, Pin, "Pin instances, e.g. (Pin(0),)")
        _set(self, "pins", pins)  # before pin_particle
        seen = {}
        for k, pin in enumerate(pins):
            self._check_end(f"pins[{k}]", pin.cable, pin.index)
            i = self.pin_particle(k)
            if i in seen:
                raise ValueError(f"two pins on one particle: pins[{seen[i]}] and pins[{k}] both hold particle "
                                 f"{i}{self._which(i)}")
            seen[i] = k
        _set(self, "junctions", _sequence("junctions", self.junctions, Junction,
                                          "Junction instances, e.g. (Junction((0, -1), (1, 0)),)"))
        self._check_junctions()
        joins.check_cables_apart(self)
        joins.check_winches(self)
        _set(self, "grippers", _sequence("grippers", self.grippers, Gripper,
                                         "Gripper instances, e.g. (Gripper((0.0, 0.0, 1.0)),)"))
        obstacles = _sequence("obstacles", self.obstacles, Obstacle,
                              "Floor, Box, Cylinder, Capsule or Sphere instances, e.g. (Floor(),)")
        for c, cable in enumerate(self.cables):
            obstacles_.check_start_clear(cable, obstacles, self._named(c))
        _set(self, "obstacles", obstacles)
        _set(self, "rings", _sequence("rings", self.rings, Ring, "Ring instances, e.g. (Ring((0, 0, 1), (1, 0, 0)),)"))
        if not isinstance(self.name, str):
            raise ValueError(f"name must be a str, got {self.name!r}")
        if self.world is None:
            if self.keyframe is not None:
                raise ValueError(f"keyframe applies only to a scene with a world, got keyframe={self.keyframe!r}")
            body_rings = [k for k, ring in enumerate(self.rings) if ring.body is not None]
            if body_rings:
                k = body_rings[0]
                raise ValueError(f"rings[{k}] is on body {self.rings[k].body!r}, but the scene has no world; give "
                                 f"Scene(..., world=MJCF path or MjSpec)")
            body_pins = [k for k, pin in enumerate(pins) if pin.on_body]
            if body_pins:
                k = body_pins[0]
                raise ValueError(f"pins[{k}] holds body {pins[k].body!r}, but the scene has no world; give "
                                 f"Scene(..., world=MJCF path or MjSpec)")
        else:
            from mjcable import user_world  # scene.py is imported by everything; the world module only here

            _set(self, "world", user_world.load(self.world, keyframe=self.keyframe))
            self._check_body_pins()
            for c in range(len(self.cables)):
                self._check_start_clear_of_world(c)
        self._check_rings()

    # -- cables ---------------------------------------------------------------------------------------------------

    @property
    def cables(self) -> tuple:
        """The scene's cables, a tuple of :class:`CableSpec` (one or more)."""
        return (self.cable,) if isinstance(self.cable, CableSpec) else self.cable

    @functools.cached_property
    def cable_slices(self) -> tuple:
        """One ``slice`` per cable into the particles of all cables in cable order (:attr:`particles`, a Simulator's
        positions), e.g. ``(slice(0, 51), slice(51, 102))``."""
        ends = np.cumsum([0] + [c.n_particles for c in self.cables]).tolist()
        return tuple(slice(a, b) for a, b in zip(ends[:-1], ends[1:]))

    @property
    def n_particles(self) -> int:
        """Σ (nᵢ + 1): the particles of all cables."""
        return self.cable_slices[-1].stop

    @functools.cached_property
    def particles(self) -> np.ndarray:
        """``(n_particles, 3)`` m: every cable's start positions, in cable order (read-only)."""
        if isinstance(self.cable, CableSpec):
            return self.cable.particles
        p = np.concatenate([c.particles for c in self.cables])
        p.setflags(write=False)
        return p

    def cable_of(self, i: int) -> int:
        """The cable (an index into :attr:`cables`) of global particle ``i`` (0 <= i < :attr:`n_particles`)."""
        return next(c for c, s in enumerate(self.cable_slices) if i < s.stop)

    def _global(self, cable: int, index: int) -> int:
        """The global particle index of particle ``index`` (negative from the end) of cable ``cable``."""
        return self.cable_slices[cable].start + index % self.cables[cable].n_particles

    def _named(self, c: int) -> str:
        """``" of cable c"`` in a scene of several cables, nothing for one."""
        return "" if isinstance(self.cable, CableSpec) else f" of cable {c}"

    def _which(self, i: int) -> str:
        """`` (cable c, index k)`` for global particle ``i`` in a scene of several cables, nothing for one."""
        if isinstance(self.cable, CableSpec):
            return ""
        c = self.cable_of(i)
        return f" (cable {c}, index {i - self.cable_slices[c].start})"

    def _check_end(self, what: str, cable: int, index: int) -> None:
        """Raise unless cable ``cable`` exists and has a particle ``index``."""
        count = len(self.cables)
        if cable >= count:
            raise ValueError(f"{what}.cable must lie in [0, {count - 1}] (the scene's {count} cable(s)), got {cable}")
        n = self.cables[cable].n_particles
        if not -n <= index < n:
            which = "a cable" if isinstance(self.cable, CableSpec) else f"cable {cable}"
            raise ValueError(f"{what}.index must lie in [{-n}, {n - 1}] for {which} of {n} particles, got {index}")

    # -- pins and junctions ---------------------------------------------------------------------------------------

    def pin_particle(self, k: int) -> int:
        """The global particle index (non-negative, into :attr:`particles`) held by ``pins[k]``."""
        pin = self.pins[k]
        return self._global(pin.cable, pin.index)

    def pin_cable(self, k: int) -> int:
        """The cable (an index into :attr:`cables`) that ``pins[k]`` holds."""
        return self.pins[k].cable

    def clamp_neighbour(self, k: int) -> int:
        """The global particle next to a clamped pin, towards its cable's inside, that fixes its tangent."""
        pin = self.pins[k]
        i = pin.index % self.cables[pin.cable].n_particles
        return self._global(pin.cable, i + 1 if i < self.cables[pin.cable].n_segments else i - 1)

    def junction_particles(self, j: int) -> tuple:
        """``(a, b)``: the global particle indices that ``junctions[j]`` joins."""
        junction = self.junctions[j]
        return self._global(*junction.a), self._global(*junction.b)

    def _check_junctions(self) -> None:
        pairs = {}
        for j, junction in enumerate(self.junctions):
            for end in ("a", "b"):
                self._check_end(f"junctions[{j}].{end}", *getattr(junction, end))
            a, b = self.junction_particles(j)
            if a == b:
                raise ValueError(f"junctions[{j}] joins particle {a}{self._which(a)} to itself: a junction joins two "
                                 f"distinct particles")
            if (min(a, b), max(a, b)) in pairs:
                raise ValueError(f"junctions[{pairs[min(a, b), max(a, b)]}] and junctions[{j}] both join particles "
                                 f"{a} and {b}: give each pair once")
            pairs[min(a, b), max(a, b)] = j
            p = self.particles
            gap = float(np.linalg.norm(p[a] - p[b]))
            if gap > JUNCTION_TOLERANCE:
                raise ValueError(
                    f"junctions[{j}]: its particles {junction.a} at {np.round(p[a], 6).tolist()} and {junction.b} at "
                    f"{np.round(p[b], 6).tolist()} start {gap:.4g} m apart (allowed: {JUNCTION_TOLERANCE:g} m); "
                    f"start the two cables' points there at one point")

    def junction_points(self) -> tuple:
        """The points that junctions make: a tuple of sorted tuples of the global particles joined into each
        (a Y-harness's two junctions ``(0, -1)–(1, -1)`` and ``(0, -1)–(2, -1)`` make one point of three)."""
        return joins.points([self.junction_particles(j) for j in range(len(self.junctions))])

    def _check_rings(self) -> None:
        """Raise unless every ring's cable and stop particle exist and the cable starts threaded through it
        (:func:`mjcable.rings.check_threaded`; a ring on a body where the world is loaded)."""
        for k, ring in enumerate(self.rings):
            self._check_end(f"rings[{k}]", ring.cable, 0)
            if ring.stop is not None:
                self._check_end(f"rings[{k}] stop", ring.cable, ring.stop)
            if ring.body is None or self.world is not None:
                rings_.check_threaded(k, ring, self.cables[ring.cable], *self.ring_frame(k))

    def ring_frame(self, k: int) -> tuple:
        """``(centre, axis)``: ring ``k``'s centre (m) and unit axis in the world frame at the start."""
        return rings_.start_frame(self.rings[k], self.world)

    def _check_body_pins(self) -> None:
        p = self.particles
        for k, pin in enumerate(self.pins):
            if not pin.on_body:
                continue
            point = self.world.body_point(pin.body, pin.offset)
            i = self.pin_particle(k)
            miss = float(np.linalg.norm(point - p[i]))
            if miss > BODY_PIN_TOLERANCE:
                raise ValueError(
                    f"pins[{k}]: the point offset={pin.offset} of body {pin.body!r} starts at "
                    f"{np.round(point, 6).tolist()}, {miss:.4g} m from particle {i}{self._which(i)} at "
                    f"{np.round(p[i], 6).tolist()} (allowed: {BODY_PIN_TOLERANCE:g} m); move the cable's end or "
                    f"change the offset")

    def _check_start_clear_of_world(self, c: int) -> None:
        """Raise if cable ``c``'s surface starts more than :data:`START_CONTACT_TOLERANCE` inside a geom of the world
        that it can collide with. A pinned particle may start inside a geom (a plug in its socket: its pin holds it),
        and the particles within :data:`BODY_PIN_REACH` of a body pin never touch its body."""
        cable = self.cables[c]
        n = cable.n_particles
        ours = [k for k, pin in enumerate(self.pins) if pin.cable == c]
        local = {k: self.pins[k].index % n for k in ours}
        ignore = [(self.pins[k].body, range(max(local[k] - BODY_PIN_REACH, 0), min(local[k] + BODY_PIN_REACH + 1, n)))
                  for k in ours if self.pins[k].on_body]
        deepest = self.world.start_depth(cable.particles, cable.radius, ignore, local.values())
        if deepest is not None and deepest.depth > START_CONTACT_TOLERANCE:
            i = deepest.particle
            raise ValueError(
                f"world geom {deepest.geom!r} (body {deepest.body!r}) holds the cable's start: particle {i}"
                f"{self._named(c)} at {np.round(cable.particles[i], 6).tolist()} is {deepest.depth:.4g} m deep (the "
                f"cable's radius {cable.radius:g} m included; up to {START_CONTACT_TOLERANCE:g} m is allowed); move "
                f"the geom, the world's start pose (keyframe) or the cable's points")

    @functools.cached_property
    def hanging_weights(self) -> np.ndarray:
        """``(len(pins),)`` N: the weight each body pin's body hangs on the cable at the start
        (:meth:`mjcable.user_world.World.hanging_weight`; 0 for the other pins). The models' stability rules count it
        in the cable's tension."""
        return np.array([self.world.hanging_weight(pin.body, pin.offset) if pin.on_body else 0.0
                         for pin in self.pins], dtype=np.float64)

    @property
    def max_tension(self) -> float:
        """N: a bound on the cables' static tension, their weight |g| Σ m plus what bodies hang on their pins
        (:attr:`hanging_weights`); the models' stability rules use it."""
        mass = sum(c.mass for c in self.cables)
        return float(np.linalg.norm(self.gravity)) * mass + float(np.sum(self.hanging_weights))

    @property
    def gravity(self) -> np.ndarray:
        """``(3,)`` m/s²: the world's ``<option gravity>``, or :data:`GRAVITY` without a world."""
        return GRAVITY.copy() if self.world is None else self.world.gravity.copy()

    @property
    def gripper_pins(self) -> tuple:
        """Indices into ``pins`` of the gripper pins (the free grippers of :attr:`grippers` follow them as
        ``len(pins) + g`` wherever a Simulator numbers grippers)."""
        return tuple(k for k, p in enumerate(self.pins) if p.kind == "gripper")

    def cable_scene(self, c: int) -> "Scene":
        """Cable ``c`` alone: a one-cable scene with its pins (``Pin.cable`` 0, in ``pins`` order), the obstacles and
        the world, without junctions (the scene itself where it is one cable without junctions). Per-cable rules
        (stability, warnings) and the native models' per-cable builds use it; what the other cables and the junctions
        add to its load is not in it."""
        if isinstance(self.cable, CableSpec) and not self.junctions:
            return self
        pins = tuple(dataclasses.replace(pin, cable=0) for pin in self.pins if pin.cable == c)
        return Scene(self.cables[c], pins, self.obstacles, name=f"{self.name}_cable{c}", world=self.world,
                     keyframe=self.keyframe)

    def with_cable(self, **overrides) -> "Scene":
        """A copy with ``CableSpec`` fields replaced (e.g. ``n_segments=100``); one-cable scenes only.

        Raises:
          ValueError: the scene has several cables (replace them with ``dataclasses.replace``)."""
        if not isinstance(self.cable, CableSpec):
            raise ValueError(f"with_cable applies to a scene of one cable, this one has {len(self.cables)}; use "
                             f"dataclasses.replace(scene, cable=tuple(dataclasses.replace(c, ...) for c in "
                             f"scene.cables))")
        return dataclasses.replace(self, cable=dataclasses.replace(self.cable, **overrides))


def _cables(value):
    """``value`` (a CableSpec, or a non-empty sequence of them) as one ``CableSpec`` or a tuple of several."""
    if isinstance(value, CableSpec):
        return value
    if isinstance(value, (str, bytes)) or not isinstance(value, collections.abc.Iterable):
        raise ValueError(f"cable must be a CableSpec or a non-empty sequence of them, got {type(value).__name__}")
    items = tuple(value)
    if not items:
        raise ValueError("cable must be a CableSpec or a non-empty sequence of them, got an empty sequence")
    for c, item in enumerate(items):
        if not isinstance(item, CableSpec):
            raise ValueError(f"cable[{c}] must be a CableSpec, got {type(item).__name__}")
    return items[0] if len(items) == 1 else items


def _sequence(name: str, value, kind: type, what: str) -> tuple:
    """``value`` as a tuple of ``kind`` instances (a single instance, or anything else, is rejected)."""
    if isinstance(value, (str, bytes, kind)) or not isinstance(value, collections.abc.Iterable):
        raise ValueError(f"{name} must be a sequence of {what}, got {value!r}")
    items = tuple(value)
    for k, item in enumerate(items):
        if not isinstance(item, kind):
            raise ValueError(f"{name}[{k}] must be one of {what}, got {item!r}")
    return items
