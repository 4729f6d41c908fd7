"""Several cables, junctions and loops in one native ``MjSpec``.

A native generator builds one cable (:func:`mjcable.mjcf.springs.build`, ...). :func:`assemble` builds a scene of
several cables from it: each cable alone (:meth:`mjcable.scene.Scene.cable_scene`, without obstacles or world) into a
spec of its own, attached to the scene's world (:func:`mjcable.mjcf.world.new_spec`) with the name prefix
``c{c}_`` (:func:`prefix`: cable 1's particle 3 is the site ``c1_particle3``, its first pin's equality
``c1_pin0``); a scene of one cable keeps its names. Then:

* **contacts between the cables**: MuJoCo's own, between the cables' geoms. Without self-collision each cable's geoms
  get a contact bit of their own (:data:`FIRST_CABLE_BIT` + c) and collide with the other cables' bits, not their own;
  with self-collision every cable geom collides with every other as the generators set them. Friction is MuJoCo's
  (the larger of the two cables' μ); the cables' geoms get the stiff contact time constant the obstacles have
  (:data:`mjcable.mjcf.world.CONTACT_SOLREF_STEPS` steps), so a cable resting on another does not sink into it;
* **junctions**: a stiff site-to-site ``connect`` equality ``junction{j}`` between the two particles' sites
  (:func:`junction_equality`). ``clamp=True``: where the cable is segment bodies (``joints``, ``composite``) a
  ``weld`` of the two segment bodies at the point instead, holding their start pose to each other (the frames'
  relative turn); for point masses (``springs``, ``flexrod``) the connect and a tendon equality that holds the
  distance between the two particles' inward neighbours, so the angle between the tangents, at its start value.
  The references are the start's, whatever pose the model compiles in (:func:`_hold_start`). The geoms near a
  junction (within :meth:`~mjcable.scene.CableSpec.overlapping_neighbours` + 1 particles of it, on every cable that
  meets there) never collide, as neighbouring segments don't;
* **the start**: where a cable's spec has a start keyframe (a stiff ``joints`` chain compiles straight), the keyframe
  :data:`~mjcable.mjcf.world.START_KEY` of the whole model holds every cable's start pose, in attachment order.

Options that a generator sets for its cable (``joints``: the medium's viscosity that drags its segments, and the
integrator) are the model's: the most implicit integrator any cable needs, and one viscosity, which cables of
different drag per segment cannot share: the largest, with a :class:`~mjcable.errors.PhysicsWarning` that gives the
damping rates the others get (damping never changes a static equilibrium).
"""

from __future__ import annotations

import dataclasses
import warnings
from typing import Callable

import mujoco
import numpy as np

from mjcable.errors import PhysicsWarning
from mjcable.mjcf import snap, world
from mjcable.scene import Scene

__all__ = ["assemble", "check", "prefix", "junction_equality", "particle_name", "pin_name", "local_pin", "inward",
           "FIRST_CABLE_BIT", "MAX_CABLES"]

FIRST_CABLE_BIT = 2  # cable c's geoms carry contact bit 2 + c (bits 0 and 1: obstacles and every cable geom)
MAX_CABLES = 30  # contype is a 32-bit int: the bits left for the cables
_SAME = 1e-9  # relative: viscosities this close are one
_OPTIONS = ("timestep", "gravity", "integrator", "cone", "impratio", "viscosity", "jacobian")


def prefix(scene: Scene, c: int) -> str:
    """The name prefix of cable ``c``'s elements: none in a scene of one cable, else ``c{c}_``."""
    return "" if len(scene.cables) == 1 else f"c{c}_"


def junction_equality(j: int, clamp: bool = False) -> str:
    """The equality of junction ``j``: ``junction{j}`` (a connect, or a clamp's weld), and ``junction{j}_clamp``
    (a clamp's tendon equality, in models without frames)."""
    return f"junction{j}_clamp" if clamp else f"junction{j}"


def inward(scene: Scene, i: int) -> int:
    """The global particle next to global particle ``i`` towards its cable's inside (a clamp's neighbour)."""
    c = scene.cable_of(i)
    local = i - scene.cable_slices[c].start
    return i + 1 if local < scene.cables[c].n_segments else i - 1


def local_pin(scene: Scene, k: int) -> int:
    """``pins[k]``'s number among the pins of its cable (its pin number in :meth:`Scene.cable_scene`)."""
    c = scene.pins[k].cable
    return sum(1 for pin in scene.pins[:k] if pin.cable == c)


def particle_name(scene: Scene, i: int) -> str:
    """The site of global particle ``i``."""
    c = scene.cable_of(i)
    return prefix(scene, c) + world.particle_site(i - scene.cable_slices[c].start)


def pin_name(scene: Scene, k: int, name: Callable[..., str], *args, **kwargs) -> str:
    """``name(local pin, ...)`` of ``pins[k]`` with its cable's prefix (e.g. ``pin_name(scene, k,
    world.pin_equality, clamp=True)``)."""
    return prefix(scene, scene.pins[k].cable) + name(local_pin(scene, k), *args, **kwargs)


def check(scene: Scene, model: str) -> None:
    """What a scene of several cables or junctions asks that the native models can't do.

    Raises:
      ValueError: more than :data:`MAX_CABLES` cables, or a body pin on a scene of several."""
    if len(scene.cables) > MAX_CABLES:
        raise ValueError(f"{model}: a scene of at most {MAX_CABLES} cables (one contact bit each), got "
                         f"{len(scene.cables)}")
    if len(scene.cables) > 1:
        body = [k for k, pin in enumerate(scene.pins) if pin.on_body]
        if body:
            raise ValueError(f"{model}: pins[{body[0]}] is a body pin in a scene of several cables, which the native "
                             f"models don't build yet; pin the cable with a gripper or world pin, or use one cable")


def assemble(scene: Scene, generate: Callable[..., mujoco.MjSpec], model: str, *, timestep: float,
             self_collision: bool = False, frames: bool = False) -> mujoco.MjSpec:
    """The spec of ``scene`` (several cables, or junctions) with each cable built by ``generate(one-cable scene, *,
    timestep, self_collision)`` (see the module docstring); ``frames``: the cable is segment bodies (clamped
    junctions are welds)."""
    check(scene, model)
    if len(scene.cables) == 1:
        spec = generate(scene.cable_scene(0), timestep=timestep, self_collision=self_collision)
    else:
        spec = world.new_spec(scene, timestep=timestep)
        starts, options = [], []
        for c in range(len(scene.cables)):
            one = dataclasses.replace(scene.cable_scene(c), obstacles=(), world=None, keyframe=None)
            sub = generate(one, timestep=timestep, self_collision=self_collision)
            starts.append(_start(sub))
            options.append((sub.option.integrator, sub.option.viscosity))
            _own(sub, c, scene, timestep, self_collision)
            for name in _OPTIONS:  # the whole model's (set below): no "attach conflict" warnings
                setattr(sub.option, name, getattr(spec.option, name))
            spec.attach(sub, prefix=prefix(scene, c), frame=spec.worldbody.add_frame())
        _options(spec, scene, options, model)
        if any(has_key for has_key, *_ in starts):
            _start_key(spec, scene, starts)
        world.stiffen_obstacle_contacts(spec, scene, timestep)
    _junctions(spec, scene, timestep, frames)
    return snap.snap_spec(spec)


def _own(sub: mujoco.MjSpec, c: int, scene: Scene, timestep: float, self_collision: bool) -> None:
    """Make cable ``c``'s spec ``sub`` one of the scene's cables: its colour, contact bits and contact stiffness; no
    camera, lights or textures of its own (the scene's world has them). A flex (``flexrod``) does not collide with
    the flexes of the cables that meet it at a junction: excludes act on bodies, not on a flex's elements, so those
    meeting at the junction would push each other apart."""
    for element in [*sub.cameras, *sub.lights, *sub.textures]:
        sub.delete(element)
    for material in sub.materials:
        material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = ""
    sub.material("cable").rgba = list(world.CABLE_COLOURS[c % len(world.CABLE_COLOURS)])
    own = 1 << (FIRST_CABLE_BIT + c)
    joined = {scene.cable_of(i) for group in scene.junction_points() if c in {scene.cable_of(i) for i in group}
              for i in group} | {c}
    for element in [*sub.geoms, *sub.flexes]:  # the capsules or spheres, or the flex (flexrod)
        if element.contype & world.CABLE_CONTYPE:
            element.solref = [world.CONTACT_SOLREF_STEPS * timestep, 1.0]
            if not self_collision:
                skip = joined if isinstance(element, mujoco.MjsFlex) else {c}
                element.contype |= own
                element.conaffinity |= sum(1 << (FIRST_CABLE_BIT + d) for d in range(len(scene.cables))
                                           if d not in skip)


def _start(sub: mujoco.MjSpec) -> tuple:
    """``(has a start key, qpos, mocap_pos, mocap_quat)`` of a cable's spec at its start (its start key or its
    default pose)."""
    m = sub.compile()
    d = mujoco.MjData(m)
    world.reset_to_start(m, d)
    has_key = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, world.START_KEY) >= 0
    if has_key:
        sub.delete(sub.key(world.START_KEY))
    return has_key, d.qpos.copy(), d.mocap_pos.copy(), d.mocap_quat.copy()


def _start_key(spec: mujoco.MjSpec, scene: Scene, starts: list) -> None:
    """The keyframe ``START_KEY``: the cables' start poses in attachment order, after a user world's own joints and
    mocap bodies (zeros here: :func:`mjcable.mjcf.world.finish` puts the world's start there)."""
    start = scene.world.start_state() if scene.world is not None else None
    nq, nm = (len(start["qpos"]), len(start["mpos"])) if start is not None else (0, 0)
    qpos = np.concatenate([np.zeros(nq)] + [q for _, q, _, _ in starts])
    mpos = np.concatenate([np.zeros((nm, 3))] + [p for _, _, p, _ in starts])
    mquat = np.concatenate([np.tile([1.0, 0.0, 0.0, 0.0], (nm, 1))] + [q for _, _, _, q in starts])
    key = spec.add_key(name=world.START_KEY, qpos=qpos)
    if len(mpos):
        key.mpos, key.mquat = mpos.ravel(), mquat.ravel()


def _options(spec: mujoco.MjSpec, scene: Scene, options: list, model: str) -> None:
    """The model's integrator (the most implicit any cable's needs), viscosity (one for all) and, with the cables'
    contacts, MuJoCo's automatic Jacobian layout."""
    euler = mujoco.mjtIntegrator.mjINT_EULER
    integrators = {int(i) for i, _ in options}
    spec.option.integrator = euler if integrators == {int(euler)} else mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    viscosities = [v for _, v in options]
    spec.option.viscosity = max(viscosities)
    if max(viscosities) - min(viscosities) > _SAME * max(viscosities):
        rates = [c.damping * max(viscosities) / v if v > 0.0 else 0.0 for c, v in zip(scene.cables, viscosities)]
        warnings.warn(f"{model}: the cables' damping needs medium viscosities {np.round(viscosities, 6).tolist()} Pa·s "
                      f"(the drag of each cable's segments), but a MuJoCo model has one: with the largest, the cables "
                      f"damp at {np.round(rates, 4).tolist()} 1/s instead of "
                      f"{[c.damping for c in scene.cables]} (statics are not changed); give the cables the same "
                      f"damping, mass per segment, radius and segment length for exact rates", PhysicsWarning,
                      stacklevel=6)
    spec.option.jacobian = mujoco.mjtJacobian.mjJAC_AUTO


def _junctions(spec: mujoco.MjSpec, scene: Scene, timestep: float, frames: bool) -> None:
    """Each junction's equalities (:func:`junction_equality`), and no contacts between the bodies near the particles
    that junctions join into one point."""
    clamps = []
    for j, junction in enumerate(scene.junctions):
        a, b = scene.junction_particles(j)
        site_a, site_b = particle_name(scene, a), particle_name(scene, b)
        if junction.clamp and frames:  # the two segment bodies at the point keep their start pose to each other
            weld = spec.add_equality(name=junction_equality(j), type=mujoco.mjtEq.mjEQ_WELD,
                                     objtype=mujoco.mjtObj.mjOBJ_BODY, name1=spec.site(site_b).parent.name,
                                     name2=spec.site(site_a).parent.name, solref=world.pin_solref(timestep),
                                     solimp=world.PIN_SOLIMP)
            clamps.append((weld, site_a))
            continue
        world.add_connect(spec, junction_equality(j), site_b, site_a, timestep=timestep)
        if junction.clamp:  # the neighbours' distance, so the angle between the two tangents, at its start value
            tendon = spec.add_tendon(name=f"{junction_equality(j)}_clamp", rgba=[0.0, 0.0, 0.0, 0.0])
            for i in (a, b):
                tendon.wrap_site(particle_name(scene, inward(scene, i)))
            clamps.append((spec.add_equality(name=junction_equality(j, clamp=True), type=mujoco.mjtEq.mjEQ_TENDON,
                                             name1=tendon.name, solref=world.pin_solref(timestep),
                                             solimp=world.PIN_SOLIMP), None))
    if clamps:
        _hold_start(spec, clamps)
    excluded = set()
    for group in scene.junction_points():
        near = []  # per joined particle: the bodies holding the particles within reach of it on its cable
        for i in group:
            c = scene.cable_of(i)
            cable, start = scene.cables[c], scene.cable_slices[c].start
            reach = cable.overlapping_neighbours() + 1
            local = range(max(i - start - reach, 0), min(i - start + reach, cable.n_segments) + 1)
            near.append({spec.site(prefix(scene, c) + world.particle_site(q)).parent.name for q in local})
        for x in range(len(near)):
            for y in range(x + 1, len(near)):
                for b1 in near[x]:
                    for b2 in near[y] - {b1}:
                        if (b1, b2) not in excluded and (b2, b1) not in excluded:
                            excluded.add((b1, b2))
                            spec.add_exclude(bodyname1=b1, bodyname2=b2)


def _hold_start(spec: mujoco.MjSpec, clamps: list) -> None:
    """Set the clamps' equalities to hold the start (their references are otherwise the compiled pose, ``qpos0``,
    which a stiff ``joints`` chain or ``flexrod`` takes straight): a weld's anchor (the junction's point, site
    ``anchor``) in each body's frame and the second body's turn in the first's; a tendon equality's offset from the
    tendon's ``qpos0`` length."""
    m = spec.compile()
    d = mujoco.MjData(m)
    world.reset_to_start(m, d)
    mujoco.mj_forward(m, d)
    for equality, anchor in clamps:
        if anchor is None:
            tendon = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_TENDON, equality.name1)
            equality.data[:5] = [d.ten_length[tendon] - m.tendon_length0[tendon], 0.0, 0.0, 0.0, 0.0]
            continue
        b1, b2 = (mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name) for name in (equality.name1, equality.name2))
        r1, r2 = d.xmat[b1].reshape(3, 3), d.xmat[b2].reshape(3, 3)
        relative = np.empty(4)
        mujoco.mju_mulQuat(relative, d.xquat[b1] * [1.0, -1.0, -1.0, -1.0], d.xquat[b2])
        point = d.site_xpos[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, anchor)]
        # MuJoCo holds x₁ + R₁ relpos on x₂ + R₂ anchor: both are the point, in either body
        equality.data[:11] = np.concatenate([r2.T @ (point - d.xpos[b2]), r1.T @ (point - d.xpos[b1]), relative,
                                             [1.0]])
