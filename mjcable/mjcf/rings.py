"""Rings (``Scene.rings``) in a native model's spec: a torus of capsules that the cable slides through.

Ring ``k`` is a polygon of :data:`SIDES` capsule geoms ``ring{k}_{j}`` around the ring's axis, in the world body or,
for a ring on a body (``Ring.body``), in that body of the user's world, so that it moves with the body and feels the
cable through MuJoCo's contacts (both ways). Its shape:

* the rim (the tube) has the radius ρ = :data:`RIM_RADII` × the threaded cable's radius r, or more, so that the
  cable's centreline wraps the rim on a circle (ρ + r) of at least :data:`RIM_SEGMENTS` segments: a chain of straight
  segments over a tighter rim goes round on a corner or two, bumps what hangs on it at every joint that passes and
  holds less than the capstan law (``docs/measurements.md``);
* the hole's radius ``Ring.hole(r)`` is the polygon's narrowest: the distance from the ring's centre to the
  capsules' inner surface at their middles (at the polygon's corners the hole is wider by a factor of about
  1 / cos(π / SIDES), under 2 %);
* the polygon is turned about the axis so that the middle of one capsule lies where gravity pulls the cable (the
  lowest point of the ring at the start): a cable hanging through the ring wraps a straight stretch of the tube, a
  round post of radius ρ.

Contacts: the capsules collide with the cables' geoms (and a ``flexrod`` flex) and nothing else (``contype`` 0,
``conaffinity`` :data:`~mjcable.mjcf.world.CABLE_CONTYPE`: not with the body they are on, nor with obstacles or the
user's geoms), whatever a model excludes between its own bodies. They have a higher ``priority`` than the cable's
geoms, so that MuJoCo takes the ring's contact parameters for a contact: friction μ = ``Ring.friction`` exactly
(``condim`` 3; a frictionless ring ``condim`` 1, normal forces alone), the obstacles' stiff contact time constant
:data:`~mjcable.mjcf.world.CONTACT_SOLREF_STEPS` physics steps, and the pins' impedance
:data:`~mjcable.mjcf.world.PIN_SOLIMP` (:data:`SOLIMP`): MuJoCo's softness scales with the inverse of a segment's
mass, and a light rope carrying a load sinks through a rim at the default impedance.

A stop (``Ring.stop``, a particle index): a sphere ``ring{k}_stop`` of :data:`STOP_RADII` × the hole's radius at
that particle, on the model's body that carries the particle's site (every native model has one per particle or
segment), that collides with the ring's capsules alone (explicit contact pairs; ``contype`` and ``conaffinity`` 0),
so the particle cannot pass the hole. Without a stop, a cable end that reaches the ring slips out of it.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from mjcable import geometry
from mjcable.mjcf import cables, world
from mjcable.scene import Scene

__all__ = ["add_rings", "check_clear", "ring_geom", "stop_geom", "rim_radius", "SIDES", "RIM_RADII", "RIM_SEGMENTS",
           "STOP_RADII", "START_OVERLAP", "PRIORITY", "SOLIMP"]

SIDES = 16  # capsules in a ring's polygon
RIM_RADII = 1.0  # the rim's (tube's) radius ρ, in the threaded cable's radii
RIM_SEGMENTS = 3.0  # the smallest radius the cable's centreline wraps the rim on, in the cable's segments
STOP_RADII = 1.5  # a stop's sphere radius, in the hole's radii: it cannot pass through
START_OVERLAP = 0.1  # how deep a cable may start in a rim, in its radii (round-off and a start laid on the rim)
PRIORITY = 2  # contact priority of a ring's geoms: above the cable's (0) and obstacles' (1); its μ is the one in force
SOLIMP = world.PIN_SOLIMP  # the ring's contacts' impedance (module docstring)
_RGBA = (0.55, 0.55, 0.6, 1.0)


def ring_geom(k: int, j: int) -> str:
    """The name of capsule ``j`` of ring ``k``."""
    return f"ring{k}_{j}"


def stop_geom(k: int) -> str:
    """The name of ring ``k``'s stop sphere."""
    return f"ring{k}_stop"


def rim_radius(scene: Scene, k: int) -> float:
    """m: the rim's (tube's) radius ρ of ring ``k``: :data:`RIM_RADII` cable radii, or more, so that the cable's
    centreline wraps the rim on a circle of at least :data:`RIM_SEGMENTS` segments' radius."""
    cable = scene.cables[scene.rings[k].cable]
    return max(RIM_RADII * cable.radius, RIM_SEGMENTS * cable.segment_length - cable.radius)


def _polygon(scene: Scene, k: int) -> np.ndarray:
    """``(SIDES + 1, 3)`` world points at the start: the corners of ring ``k``'s polygon (the tube's centreline),
    the first repeated at the end, one side's middle towards gravity."""
    ring = scene.rings[k]
    centre, axis = scene.ring_frame(k)
    hole = ring.hole(scene.cables[ring.cable].radius)
    down = scene.gravity - (scene.gravity @ axis) * axis
    if not np.linalg.norm(down) > 1e-9 * (1.0 + np.linalg.norm(scene.gravity)):  # gravity along the axis, or none
        down = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    down = down / np.linalg.norm(down)
    side = np.cross(axis, down)
    corner = (hole + rim_radius(scene, k)) / math.cos(math.pi / SIDES)  # side middles at hole + ρ
    angles = 2.0 * math.pi * (np.arange(SIDES + 1) - 0.5) / SIDES  # side 0's middle at angle 0: down
    return centre + corner * (np.cos(angles)[:, None] * down + np.sin(angles)[:, None] * side)


def add_rings(spec: mujoco.MjSpec, scene: Scene, model: str, *, timestep: float) -> mujoco.MjSpec:
    """Add ``scene``'s rings (and their stops) to ``spec``, model ``model``'s whole spec (see the module docstring);
    MuJoCo steps at ``timestep`` seconds. Returns ``spec``.

    Raises:
      ValueError: a cable starts inside a ring's rim (:func:`check_clear`)."""
    for k, ring in enumerate(scene.rings):
        check_clear(scene, k, model)
        if ring.body is None:
            host, to_host = spec.worldbody, (lambda x: x)
        else:
            host = spec.body(ring.body)
            pos, rot = scene.world.body_pose(ring.body)
            to_host = (lambda x, pos=pos, rot=rot: (x - pos) @ rot)
        corners = to_host(_polygon(scene, k))
        contact = _contact(ring.friction, timestep)
        for j in range(SIDES):
            host.add_geom(name=ring_geom(k, j), type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                          fromto=np.concatenate([corners[j], corners[j + 1]]), size=[rim_radius(scene, k), 0.0, 0.0],
                          contype=0, conaffinity=world.CABLE_CONTYPE, priority=PRIORITY, density=0.0,
                          rgba=_RGBA, **contact)
        if ring.stop is not None:
            _add_stop(spec, scene, k, contact)
    return spec


def check_clear(scene: Scene, k: int, model: str) -> None:
    """Raise unless ring ``k``'s cable starts clear of its rim: the cable's surface no deeper than
    :data:`START_OVERLAP` cable radii in the rim (MuJoCo would throw it out in the first steps).

    Raises:
      ValueError: naming the model, the ring, the depth and what gives the rim room."""
    ring = scene.rings[k]
    cable = scene.cables[ring.cable]
    rim = rim_radius(scene, k)
    depth = rim + cable.radius - float(np.min(geometry.segment_distances(cable.particles, _polygon(scene, k))))
    if depth > START_OVERLAP * cable.radius:
        raise ValueError(f"{model}: rings[{k}]: cable {ring.cable} starts {depth:.4g} m deep in the ring's rim (a tube "
                         f"of radius {rim:.4g} m around a hole of {ring.hole(cable.radius):.4g} m: the native models' "
                         f"rim wraps the cable on at least {RIM_SEGMENTS:g} segments of {cable.segment_length:.4g} m); "
                         f"start the cable straighter through the ring, give the ring a larger radius, or the cable "
                         f"more segments")


def _contact(mu: float, timestep: float) -> dict:
    """A ring's contact attributes: friction μ (condim 3) or none (condim 1), stiff."""
    return dict(friction=[mu, 0.0, 0.0], condim=3 if mu > 0.0 else 1,
                solref=[world.CONTACT_SOLREF_STEPS * timestep, 1.0], solimp=SOLIMP)


def _add_stop(spec: mujoco.MjSpec, scene: Scene, k: int, contact: dict) -> None:
    """Ring ``k``'s stop: a sphere at its particle on the body holding the particle's site, in contact pairs with
    the ring's capsules alone."""
    ring = scene.rings[k]
    n = scene.cables[ring.cable].n_particles
    i = scene.cable_slices[ring.cable].start + (ring.stop % n)
    site = spec.site(cables.particle_name(scene, i))
    radius = STOP_RADII * ring.hole(scene.cables[ring.cable].radius)
    site.parent.add_geom(name=stop_geom(k), type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=site.pos, size=[radius, 0, 0],
                         contype=0, conaffinity=0, density=0.0, rgba=_RGBA)
    for j in range(SIDES):
        spec.add_pair(geomname1=ring_geom(k, j), geomname2=stop_geom(k), condim=contact["condim"],
                      friction=[contact["friction"][0]] * 2 + [0.0] * 3, solref=contact["solref"],
                      solimp=contact["solimp"])
