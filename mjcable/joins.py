"""What holds the scene's cables: pins (a particle held by the world, a gripper, a socket or a body), junctions
(two particles of the scene's cables joined into one point) and free grippers (that grasp any particle at run time).

Frozen dataclasses validated on construction; :class:`mjcable.scene.Scene` checks them against its cables (an index
in range, the two particles of a junction starting at one point). Re-exported by :mod:`mjcable.scene`.
"""

from __future__ import annotations

import dataclasses
from typing import Optional

import numpy as np

from mjcable import _validate, geometry
from mjcable.obstacles import START_CONTACT_TOLERANCE
from mjcable._validate import Vec3, set_field as _set

__all__ = ["Pin", "PIN_KINDS", "BODY_PIN_TOLERANCE", "Junction", "JUNCTION_TOLERANCE", "Gripper", "check_cables_apart",
           "check_winches"]

PIN_KINDS = ("world", "gripper", "socket", "body", "winch")
BODY_PIN_TOLERANCE = 1e-3  # m: how far a body pin's point may start from its particle
# m: how far apart a junction's two particles may start (round-off of two cables' ends laid on one point); farther,
# the junction would pull them together on the first step
JUNCTION_TOLERANCE = 1e-6



@dataclasses.dataclass(frozen=True)
class Pin:
    """Holds one cable particle.

    Args:
      index: particle index within cable ``cable``; negative values count from that cable's end (``Pin(-1)`` is the
        last particle).
      kind: ``"world"`` (fixed at its start position, free to rotate), ``"gripper"`` (attached to a mocap body moved
        with :meth:`mjcable.Simulator.move_gripper`), ``"socket"`` (fixed until the pin's force exceeds
        ``release_force``, then released for good) or ``"body"`` (held at the point ``offset`` fixed in the frame
        of the scene world's body ``body``, which then feels the cable: see :class:`Scene`) or ``"winch"`` (reels
        the cable in or pays it out at run time, :meth:`mjcable.Simulator.reel`: fixed at its start position, or
        with ``body`` at a point of that body, which then feels the pull; the particles between the cable's end and
        ``index`` start on its spool, those after a non-negative ``index``'s cable start, before a negative one's
        end: :mod:`mjcable.solvers.winches`).
      body: the world body of a ``"body"`` pin (required), or of a ``"winch"`` (optional).
      offset: ``(3,)`` m, the held point in ``body``'s frame; only with ``body``. At the start it must lie
        within :data:`BODY_PIN_TOLERANCE` of the pinned particle.
      clamp: also hold the cable's tangent at the pin (a cantilever root); a body clamp holds the direction the
        tangent has at the start, expressed in the body's frame (a rod with frames, ``cosserat``: the whole frame,
        and the body feels the rod's torque).
      release_force: force in newtons above which a socket lets go (> 0); only for ``kind="socket"``.
      cable: which of the scene's cables (an index into ``Scene.cables``, >= 0) the pin holds.
    """

    index: int
    kind: str = "world"
    body: Optional[str] = dataclasses.field(default=None, kw_only=True)
    offset: Vec3 = dataclasses.field(default=(0.0, 0.0, 0.0), kw_only=True)
    clamp: bool = dataclasses.field(default=False, kw_only=True)
    release_force: Optional[float] = dataclasses.field(default=None, kw_only=True)
    cable: int = dataclasses.field(default=0, kw_only=True)

    def __post_init__(self):
        _set(self, "index", _validate.integer("index", self.index))
        _set(self, "cable", _validate.integer("cable", self.cable, low=0))
        _validate.choice("kind", self.kind, PIN_KINDS)
        _set(self, "clamp", _validate.boolean("clamp", self.clamp))
        _set(self, "offset", _validate.vec3("offset", self.offset, unit="m"))
        if self.kind == "body" or (self.kind == "winch" and self.body is not None):
            if not isinstance(self.body, str) or not self.body:
                raise ValueError(f"body is required for kind='body': the name of a body of the scene's world, "
                                 f"got {self.body!r}" if self.kind == "body" else
                                 f"body of a winch must be the name of a body of the scene's world (or None: a "
                                 f"winch fixed in the world), got {self.body!r}")
        else:
            if self.body is not None:
                raise ValueError(f"body applies only to kind='body' or 'winch', got body={self.body!r} for "
                                 f"kind={self.kind!r}")
            if any(self.offset):
                raise ValueError(f"offset applies only to a pin with a body (kind='body' or 'winch'), got "
                                 f"offset={self.offset!r} for kind={self.kind!r} without a body")
        if self.kind == "winch" and self.clamp:
            raise ValueError("clamp applies to no winch (a winch holds its cable as a hinge at the winch point), got "
                             "clamp=True for kind='winch'")
        if self.kind == "socket":
            if self.release_force is None:
                raise ValueError("release_force is required for a socket pin: the force in N above which it lets go")
            _set(self, "release_force",
                 _validate.number("release_force", self.release_force, low=0.0, low_open=True, unit="N"))
        elif self.release_force is not None:
            raise ValueError(f"release_force applies only to kind='socket', got {self.release_force!r} "
                             f"for kind={self.kind!r}")


    @property
    def on_body(self) -> bool:
        """Whether a body of the scene's world holds the pin (a ``"body"`` pin, or a ``"winch"`` with ``body``)."""
        return self.body is not None


@dataclasses.dataclass(frozen=True)
class Junction:
    """Joins two particles of the scene's cables into one point: a ball joint (a harness's branch point, or a loop
    when they are one cable's two ends).

    Args:
      a: ``(cable, index)``, the first particle: an index into ``Scene.cables`` (>= 0) and a particle index of that
        cable (negative counts from its end).
      b: ``(cable, index)``, the second particle. The two must be distinct particles and start within
        :data:`JUNCTION_TOLERANCE` of each other (checked by :class:`mjcable.scene.Scene`).
      clamp: also keep the angle between the two cables' tangents at the junction at its start value (a rigid
        joint; models with frames keep the frames' relative turn).

    Example::

        Junction((0, -1), (1, 0))    # cable 0's last particle is cable 1's first
    """

    a: tuple
    b: tuple
    clamp: bool = dataclasses.field(default=False, kw_only=True)

    def __post_init__(self):
        _set(self, "a", _end("a", self.a))
        _set(self, "b", _end("b", self.b))
        _set(self, "clamp", _validate.boolean("clamp", self.clamp))


@dataclasses.dataclass(frozen=True)
class Gripper:
    """A free gripper: a mocap body that holds nothing at the start and grasps any particle at run time
    (:meth:`mjcable.Simulator.grasp`, :meth:`mjcable.Simulator.release`).

    Args:
      position: ``(3,)`` m, where it starts, world frame (finite).

    Free gripper ``g`` of ``Scene.grippers`` is moved like a gripper pin, as ``move_gripper(len(scene.pins) + g,
    position)``.

    Example::

        scene = Scene(cable, obstacles=(table,), grippers=(Gripper((0.0, 0.0, 0.8)),))
    """

    position: Vec3

    def __post_init__(self):
        _set(self, "position", _validate.vec3("position", self.position, unit="m"))


def _end(name: str, value) -> tuple:
    """``value`` as a ``(cable, index)`` pair of ints (cable >= 0)."""
    try:
        cable, index = value
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a (cable, index) pair of integers, got {value!r}") from None
    return (_validate.integer(f"{name}[0] (cable)", cable, low=0), _validate.integer(f"{name}[1] (index)", index))


def points(pairs) -> tuple:
    """The points that junctions joining the particle ``pairs`` (``(a, b)`` global indices) make: a tuple of sorted
    tuples of the particles joined into each (union-find)."""
    root = {}

    def find(i):
        while root.setdefault(i, i) != i:
            i = root[i]
        return i

    for a, b in pairs:
        root[find(a)] = find(b)
    groups = {}
    for i in sorted(root):
        groups.setdefault(find(i), []).append(i)
    return tuple(tuple(g) for g in groups.values())


def check_cables_apart(scene) -> None:
    """Raise if two cables of ``scene`` (a :class:`mjcable.scene.Scene`) start inside each other (their surfaces
    deeper than :data:`START_CONTACT_TOLERANCE`), but for the segments near a point where junctions join them (within
    :meth:`mjcable.scene.CableSpec.overlapping_neighbours` + 1 particles of it)."""
    near = {}  # (point, cable) -> the cable's segments near that junction point
    for g, point in enumerate(scene.junction_points()):
        for i in point:
            c = scene.cable_of(i)
            local, reach = i - scene.cable_slices[c].start, scene.cables[c].overlapping_neighbours() + 1
            near.setdefault((g, c), set()).update(range(max(local - reach, 0),
                                                        min(local + reach, scene.cables[c].n_segments)))
    for c, d in ((c, d) for c in range(len(scene.cables)) for d in range(c + 1, len(scene.cables))):
        one, other = scene.cables[c], scene.cables[d]
        gap = one.radius + other.radius
        lo = np.maximum(one.particles.min(axis=0), other.particles.min(axis=0)) - gap
        if np.any(lo > np.minimum(one.particles.max(axis=0), other.particles.max(axis=0)) + gap):
            continue  # their boxes, grown by the radii, don't meet
        depth = gap - geometry.segment_distances(one.particles, other.particles)
        for (g, e), segments in near.items():
            if e == c and (g, d) in near:
                depth[np.ix_(sorted(segments), sorted(near[g, d]))] = -np.inf
        i, j = np.unravel_index(int(np.argmax(depth)), depth.shape)
        if depth[i, j] > START_CONTACT_TOLERANCE:
            raise ValueError(
                f"cables {c} and {d} start inside each other: segment {i} of cable {c} and segment {j} of cable "
                f"{d} are {gap - depth[i, j]:.4g} m apart, {depth[i, j]:.4g} m less than their radii's sum "
                f"{gap:g} m (up to {START_CONTACT_TOLERANCE:g} m is allowed); move the cables' points apart, or "
                f"join them at a point with a Junction")


def check_winches(scene) -> None:
    """Raise unless each winch of ``scene`` (a :class:`mjcable.scene.Scene`) leaves its cable at least one free
    segment, is its cable's only winch, and no other pin or junction holds a particle on its spool (those between the
    cable's end and the winch's index, :mod:`mjcable.solvers.winches`)."""
    spooled = {}  # global particle -> the winch whose spool holds it
    for k, pin in enumerate(scene.pins):
        if pin.kind != "winch":
            continue
        n = scene.cables[pin.cable].n_segments
        part = scene.cable_slices[pin.cable]
        local = scene.pin_particle(k) - part.start
        if local == (n if pin.index >= 0 else 0):
            raise ValueError(f"pins[{k}]: a winch at index {pin.index} leaves cable {pin.cable} no free segment (its "
                             f"spool holds the particles {'before' if pin.index >= 0 else 'after'} the index); use an "
                             f"index in [0, {n - 1}] (spool at the cable's start) or [-{n}, -2] (spool at its end)")
        if any(p.kind == "winch" and p.cable == pin.cable for p in scene.pins[:k]):
            raise ValueError(f"pins[{k}]: cable {pin.cable} has a winch already; give each cable one winch")
        ends = range(part.start, part.start + local) if pin.index >= 0 else range(part.start + local + 1, part.stop)
        spooled.update({i: k for i in ends})
    held = [(f"pins[{k}]", scene.pin_particle(k)) for k in range(len(scene.pins))]
    held += [(f"junctions[{j}]", i) for j in range(len(scene.junctions)) for i in scene.junction_particles(j)]
    for what, i in held:
        if i in spooled:
            raise ValueError(f"{what} holds particle {i}, which starts on the spool of winch pins[{spooled[i]}]; "
                             f"hold a particle of the free cable, or move the winch's index")


def free_gripper(scene, g) -> int:
    """``g`` checked as the number of a free gripper of ``scene`` (a :class:`mjcable.scene.Scene`)."""
    if not scene.grippers:
        raise ValueError("g: the scene has no free grippers; give Scene(..., grippers=(mjcable.Gripper(position),))")
    return _validate.integer("g", g, low=0, high=len(scene.grippers) - 1)


def grasp_target(n_particles: int, held: dict, index, positions, gripper) -> int:
    """The particle a free gripper closes on: ``index`` (global, negative from the end) checked in range and free, or
    for ``index=None`` the free particle nearest to ``gripper`` (3,) m among ``positions`` (n_particles, 3) m.
    ``held`` maps each held particle to what holds it (for the message).

    Raises:
      ValueError: ``index`` out of range or held, or (``None``) every particle held."""
    if index is None:
        free = np.setdiff1d(np.arange(n_particles), list(held))
        if not len(free):
            raise ValueError("index=None: every particle is held already; release one first")
        return int(free[np.argmin(np.linalg.norm(np.asarray(positions)[free] - gripper, axis=1))])
    index = _validate.integer("index", index, low=-n_particles, high=n_particles - 1) % n_particles
    if index in held:
        raise ValueError(f"index: particle {index} is held by {held[index]} already; grasp another particle")
    return index
