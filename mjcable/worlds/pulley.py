"""Pulleys for a user world: a cylinder on a frictionless hinge that a cable turns both ways.

:func:`add_pulley` adds one to a :class:`mujoco.MjSpec`; ``Scene(cable, pins, world=spec)`` then lays the cable
over it like over any geom of the world (README, *Cables in your own world*). The rope turns the pulley through its
contact friction, and the pulley's inertia acts back on the rope: with the particle solvers through the two-way
contact coupling (:mod:`mjcable.backends.host`), with the native models through MuJoCo's own contacts.

Example::

    import mujoco
    from mjcable.worlds import pulley

    spec = mujoco.MjSpec()
    body = pulley.add_pulley(spec, pos=(0, 0, 1), radius=0.1, width=0.04, inertia=5e-3, mass=1.0, friction=1.0)
    model = spec.compile()
    model.joint(pulley.hinge_name(body)).id      # the hinge: qvel is the pulley's spin in rad/s

Units: metres, kilograms, kg·m², radians.
"""

from __future__ import annotations

from typing import Optional

import mujoco
import numpy as np

from mjcable import _validate

__all__ = ["add_pulley", "hinge_name", "rim_name", "pulleys", "HINGE_SUFFIX", "RIM_SUFFIX", "MAX_RADIUS"]

HINGE_SUFFIX = "_hinge"  # the hinge joint's name is the body's name followed by this
RIM_SUFFIX = "_rim"  # the cylinder geom's name is the body's name followed by this
MAX_RADIUS = 10.0  # m: a larger pulley is no pulley a cable scene holds (the models' start checks reach 1 km)
_TORSION_ROLL_FRICTION = (0.005, 0.0001)  # MuJoCo's defaults for the torsional and rolling coefficients
_PRIORITY = 1  # above the cable's geoms (0): the pulley's μ is the one in force, like the scene's obstacles
# s: a contact time constant below any physics step, which MuJoCo's refsafe raises to its stable minimum of two steps
# (the scene's obstacles' CONTACT_SOLREF_STEPS): the native models' rope then holds on the rim under a heavy load
# instead of sinking through its default 20 ms contact (docs/measurements.md, 2026-11-27)
_STIFF_TIMECONST = 1e-6


def hinge_name(body: str) -> str:
    """The name of the hinge joint of the pulley body ``body`` (:func:`add_pulley`'s return value)."""
    return body + HINGE_SUFFIX


def rim_name(body: str) -> str:
    """The name of the cylinder geom (the rim) of the pulley body ``body``."""
    return body + RIM_SUFFIX


def pulleys(model: mujoco.MjModel) -> dict:
    """The pulleys :func:`add_pulley` made in a compiled ``model``: ``{body name: rim radius in m}`` (a body with a
    hinge named :func:`hinge_name` and a cylinder named :func:`rim_name`)."""
    found = {}
    for j in range(model.njnt):
        name = model.joint(j).name
        if model.jnt_type[j] != mujoco.mjtJoint.mjJNT_HINGE or not name.endswith(HINGE_SUFFIX):
            continue
        body = name[: -len(HINGE_SUFFIX)]
        rim = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, rim_name(body))
        if rim >= 0 and model.geom_type[rim] == mujoco.mjtGeom.mjGEOM_CYLINDER:
            found[body] = float(model.geom_size[rim, 0])
    return found


def add_pulley(spec: mujoco.MjSpec, *, pos, radius: float, width: float, mass: float,
               inertia: Optional[float] = None, axis=(0.0, 1.0, 0.0), friction: float = 1.0,
               name: str = "pulley") -> str:
    """Add a pulley to ``spec`` (mutated): a body at ``pos`` on a frictionless, undamped hinge about ``axis``
    through ``pos``, carrying one cylinder geom of ``radius`` and ``width`` centred on the hinge.

    The body's inertial is explicit, so its moment of inertia about the axis is ``inertia`` exactly (the geom adds
    nothing): across the axis it is that of a solid cylinder of ``mass``, or ``inertia`` when larger (it plays no
    part on a fixed hinge). The geom collides with the cable (MuJoCo's default ``contype``/``conaffinity`` of 1)
    and with the world's other geoms; its priority (1, as the scene's own obstacles) makes ``friction`` the μ of
    its contacts with the cable, and its contacts are as stiff as MuJoCo allows (a time constant of two physics
    steps, as the scene's own obstacles'): under MuJoCo's default 20 ms the native models' rope sinks through a rim
    that carries a heavy load.

    Args:
      spec: the world to add to; the pulley is a child of its ``worldbody``.
      pos: ``(3,)`` m, the hinge's centre (the cylinder's centre).
      radius: m, the rim's radius, in (0, :data:`MAX_RADIUS`].
      width: m, the cylinder's length along the axis, > 0.
      mass: kg, > 0 (MuJoCo needs a mass on a moving body; on a fixed hinge only ``inertia`` matters).
      inertia: kg·m² about the axis, > 0; ``None``: a solid disc's, ``mass`` · ``radius``² / 2.
      axis: ``(3,)`` the hinge's direction (normalised here; not zero).
      friction: Coulomb μ of the rim on the cable, >= 0. Without slip the rope turns the pulley while the tension
        ratio across it stays below the capstan law's e^{μ θ} (θ the wrap angle, π over a pulley between two
        hanging legs).
      name: the body's name (the geom is ``name +`` :data:`RIM_SUFFIX`, the hinge ``name +`` :data:`HINGE_SUFFIX`).

    Returns:
      The body's name.

    Raises:
      ValueError: a parameter outside its range (named, with its value and the range), or a name the spec
        already has.
    """
    if not isinstance(spec, mujoco.MjSpec):
        raise ValueError(f"spec must be a mujoco.MjSpec, got {type(spec).__name__}")
    pos = np.array(_validate.vec3("pos", pos, unit="m"))
    radius = _validate.number("radius", radius, low=0.0, high=MAX_RADIUS, low_open=True, unit="m")
    width = _validate.number("width", width, low=0.0, high=2.0 * MAX_RADIUS, low_open=True, unit="m")
    mass = _validate.number("mass", mass, low=0.0, low_open=True, unit="kg")
    inertia = 0.5 * mass * radius**2 if inertia is None else _validate.number(
        "inertia", inertia, low=0.0, low_open=True, unit="kg·m²")
    direction = np.array(_validate.vec3("axis", axis))
    norm = float(np.linalg.norm(direction))
    if not norm > 0.0:
        raise ValueError(f"axis must be a non-zero (3,) direction, got {tuple(direction.tolist())}")
    friction = _validate.number("friction", friction, low=0.0)
    if not isinstance(name, str) or not name:
        raise ValueError(f"name must be a non-empty string, got {name!r}")
    taken = [n for n in (name, rim_name(name), hinge_name(name)) if _named(spec, n)]
    if taken:
        raise ValueError(f"name {name!r}: the spec already has an element named {taken[0]!r}; pick another name")
    across = max(mass * (3.0 * radius**2 + width**2) / 12.0, inertia)  # >= inertia / 2: a valid inertia
    body = spec.worldbody.add_body(name=name, pos=pos, quat=_z_to(direction / norm))
    body.explicitinertial = True
    body.mass = mass
    body.inertia = [across, across, inertia]  # the body's z is the axis
    body.ipos = [0.0, 0.0, 0.0]
    body.iquat = [1.0, 0.0, 0.0, 0.0]
    body.add_joint(name=hinge_name(name), type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0.0, 0.0, 1.0], damping=0.0,
                   frictionloss=0.0, armature=0.0, stiffness=0.0)
    body.add_geom(name=rim_name(name), type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[radius, 0.5 * width, 0.0],
                  friction=[friction, *_TORSION_ROLL_FRICTION], priority=_PRIORITY, condim=3,
                  solref=[_STIFF_TIMECONST, 1.0],
                  rgba=[0.55, 0.55, 0.6, 1.0])
    return name


def _named(spec: mujoco.MjSpec, name: str) -> bool:
    """Whether a body, joint or geom of ``spec`` is called ``name``."""
    return any(e.name == name for e in (*spec.bodies, *spec.joints, *spec.geoms))


def _z_to(direction: np.ndarray) -> np.ndarray:
    """The unit quaternion (w, x, y, z) that turns +z onto the unit vector ``direction``."""
    z = np.array([0.0, 0.0, 1.0])
    c = float(z @ direction)
    if c < -1.0 + 1e-12:
        return np.array([0.0, 1.0, 0.0, 0.0])  # half a turn about x
    q = np.array([1.0 + c, *np.cross(z, direction)])
    return q / np.linalg.norm(q)
