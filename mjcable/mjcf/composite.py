"""``composite``: MuJoCo's ``<composite type="cable">`` with the ``mujoco.elasticity.cable`` plugin.

MuJoCo 4 removed the cable plugin: :func:`missing_plugin` says whether the installed MuJoCo lacks it (and why that
matters), the catalogue registers ``composite`` only where it is there, and :func:`add_cable` refuses to build
without it (a chain without the plugin would silently be ``joints`` without bending).

The model that MuJoCo's ``<composite type="cable" initial="none">`` generates, built directly with the MjSpec API
(:func:`add_cable`) so that it can be added into any spec, a user's world included (a composite is XML only, and
attaching a parsed one into another spec leaves an unnamed default class that ``to_xml`` cannot reload): a chain of
capsule bodies ``cableB_first``, ``cableB_1`` … ``cableB_{n-2}``, ``cableB_last`` linked by ball joints
``cableJ_1`` … ``cableJ_{n-2}``, ``cableJ_last`` (group 3), body ``i``'s frame at the tree's ``i``-th particle
with its x axis along the segment (frames transported without twist, :func:`mjcable.mjcf.joints.segment_frames`),
capsule geoms ``cableG{i}``, sites ``cableS_first`` / ``cableS_last`` (group 3), the text ``composite_cable``
(``rope_cable``) that tags a composite cable, and for E > 0 one instance ``compositecable`` of the plugin on every
body (with its ``<extension>`` declaration), configured like the composite's ``<plugin>``. As the composite with
``initial="none"`` the root gets no joint of its own; the root's joints are added as ``joints`` does
(:func:`mjcable.mjcf.joints.add_root_joints`, ``cableJ_first``), so that its rotation carries the same armature.
Also: the ``particle{i}`` sites (at the origin of the body that starts at particle ``i``; the tree's last particle
at the end of the last capsule), contact attributes, armature, pins and the neighbour excludes. The same capsule
chain as ``joints``, with MuJoCo's rod model for bending and twist instead of joint springs.

Spec-wide settings: :func:`add_cable` sets ``option.viscosity``, ``option.integrator`` and ``option.jacobian``
(below) on the whole spec, overriding a user world's own; the medium viscosity drags every body in the world, not
only the cable. A keyframe of the world written before the cable was added is shorter than the model: MuJoCo 3.17
pads it at compile with ``qpos0`` (the cable's start shape, see the plugin below) and the mocap grippers' start
poses.

Mapping from the physical cable:

* mass: each of the n segment bodies weighs m/n (the composite's ``<geom mass=...>``);
* length: the segments are the equal chords l₀ of the start particles; the chain is inextensible (E·A,
  ``stretch_stiffness``, is not modelled);
* bending and twist: the cable plugin (only when E > 0) with ``bend`` = E and ``twist`` = G, the cable's
  ``shear_modulus`` or E / (2 (1 + ν)) with ν = ``POISSON`` = 0.5 (an incompressible, rubber-like jacket). The plugin computes I = π r⁴ / 4 and J = π r⁴ / 2
  from the capsule radius (the same I as ``CableSpec.second_moment``) and applies torques (E·I/l₀)·θ per joint,
  l₀ the distance between body origins: the same discrete rod as ``joints``, with the rod's own torsional
  stiffness G·J / l₀ = E·I / ((1 + ν) l₀). Its reference shape is straight: with the plugin's ``flat`` = true the
  curvature is measured from the straight chain, whatever shape it compiled in, so the cable compiles directly in
  its start shape (every pin constraint holds at qpos0) and needs no start keyframe;
* damping rate c (1/s), integrator, armature, obstacle contacts and Jacobian layout exactly as in ``joints`` (see
  its module docstring): a medium drag c·(m/n)·v on every segment, ball-joint armature
  A = ``WHIP_ARMATURE``·(m/n)·l₀² + (E·I/l₀)·h² (the plugin's torques are explicit too) and damping
  A·(c + 1/(20 h)) against the free-end whip, semi-implicit Euler, obstacles at a contact time constant of 2
  physics steps. None of these changes a static equilibrium;
* friction and contacts: ``world.cable_geom`` on every capsule; neighbouring capsules never collide.

Pins as in ``joints``: the chain is generated from the pinned end the tree is rooted at
(:func:`mjcable.mjcf.joints.tree_order`: particle 0, or particle n when only the far end has a world or gripper
pin, so ``cableB_first`` then sits at particle n); the root pin through the root's joints (none: free; world pin:
ball, clamped: none; gripper: ball or none, the chain a child of the mocap body ``gripper{k}``),
every other pin (sockets always) with site-to-site connect equalities ``pin{k}`` / ``pin{k}_clamp`` /
``pin{k}_roll``. A moving gripper held by an equality at the far leaf of the chain diverges (see ``joints``). A
stiff cable's end clamp is a clamp body ``clamp{k}`` as in ``joints``
(:func:`mjcable.mjcf.joints.frame_clamps`), on the plugin too: the plugin's first body (the root's clamp) or last
(the far end's), its origin half a segment from the particle, so that the plugin bends and twists the end segment
from the clamp's frame over half a segment (E·I / (l₀/2), G·J / (l₀/2)). MuJoCo's ``<composite>`` has no such
body: a clamped stiff cable is ours alone.
"""

from __future__ import annotations

import functools
from typing import Optional

import mujoco
import numpy as np

from mjcable.mjcf import joints, snap, world
from mjcable import scene as scene_module
from mjcable.scene import Scene

__all__ = ["build", "add_cable", "missing_plugin", "body_name", "joint_name", "plugin_moduli", "POISSON", "PREFIX",
           "PLUGIN", "INSTANCE", "BENDING_ALTERNATIVES", "IGNORES"]

#: the cable's properties this model does not use (:attr:`mjcable.catalog.ModelEntry.ignores`)
IGNORES = joints.IGNORES  # the same rigid segments
POISSON = scene_module.POISSON  # Poisson's ratio ν of a cable without shear_modulus: G = E / (2 (1 + ν))
PREFIX = "cable"
PLUGIN = "mujoco.elasticity.cable"
INSTANCE = f"composite{PREFIX}"  # the plugin instance's name, as <composite> names it
_HIDDEN_GROUP = 3  # the group of the composite's own joints and sites (hidden in viewers by default)
BENDING_ALTERNATIVES = "flexrod, joints, and xpbd, pbd or jakobsen with bending (young > 0)"
"""The models that bend a cable where the cable plugin is missing."""


@functools.cache
def missing_plugin() -> Optional[str]:
    """``None`` where the installed MuJoCo has the cable plugin; otherwise why ``composite`` cannot be built there,
    as a message naming the models that bend instead (found by compiling a spec that activates the plugin, so it
    holds whatever MuJoCo's version)."""
    probe = mujoco.MjSpec()
    probe.activate_plugin(PLUGIN)
    probe.add_plugin(name=INSTANCE, plugin_name=PLUGIN, active=True)
    try:
        probe.compile()
    except ValueError as error:
        return (f"model 'composite' needs MuJoCo's cable plugin {PLUGIN!r}, which MuJoCo 4 removed (installed: "
                f"MuJoCo {mujoco.__version__}: {str(error).splitlines()[0]}); models that bend a cable on it: "
                f"{BENDING_ALTERNATIVES}. For composite, install MuJoCo 3.x: pip install \"mujoco>=3.17,<4\"")
    return None


def body_name(i: int, n_segments: int) -> str:
    """Name of the composite's body ``i`` of ``n_segments``."""
    if i == 0:
        return f"{PREFIX}B_first"
    if i == n_segments - 1:
        return f"{PREFIX}B_last"
    return f"{PREFIX}B_{i}"


def joint_name(i: int, n_segments: int) -> str:
    """Name of the ball joint between bodies ``i - 1`` and ``i`` (``i >= 1``); the root's are ``cableJ_first``
    (and ``cableJ_first_x`` … ``_z`` for a free root, see :func:`mjcable.mjcf.joints.add_root_joints`)."""
    return f"{PREFIX}J_last" if i == n_segments - 1 else f"{PREFIX}J_{i}"


def plugin_moduli(scene: Scene) -> tuple:
    """``(bend, twist)`` of the cable plugin in Pa: E and G (the cable's ``shear_modulus``, or E / (2 (1 + ν)))."""
    return scene.cable.young, scene.cable.shear


def build(scene: Scene, *, timestep: float, self_collision: bool = False) -> mujoco.MjSpec:
    """The ``composite`` spec of ``scene`` (see the module docstring); MuJoCo steps at ``timestep`` seconds."""
    spec = world.new_spec(scene, timestep=timestep)
    add_cable(spec, scene, timestep=timestep, self_collision=self_collision)
    return snap.snap_spec(spec)


def add_cable(spec: mujoco.MjSpec, scene: Scene, *, timestep: float, self_collision: bool = False) -> None:
    """Add the scene's cable, its pins and the plugin to ``spec`` in place (see the module docstring).

    ``spec`` holds the scene's world (:func:`mjcable.mjcf.world.new_spec`: the obstacles, the ``cable`` and
    ``gripper`` materials) and may hold anything else (bodies, joints, actuators, plugins, keyframes): the cable is
    appended to the world body (or to its gripper's mocap body, also appended), so the spec's own elements keep
    their names and ids. The cable's names (``cableB_*``, ``cableJ_*``, ``cableG*``, ``cableS_*``, plugin
    instance ``compositecable``, text ``composite_cable``, ``particle{i}``, ``anchor{k}``, ``gripper{k}``,
    ``pin{k}``) must be free. Overrides spec-wide settings: ``option.viscosity`` (the cable's drag, which drags
    every other body too), ``option.integrator`` and ``option.jacobian`` (:mod:`mjcable.mjcf.joints`), and the
    obstacles' contact ``solref``.

    Keyframes: MuJoCo 3.17 pads a keyframe shorter than the model at compile, at the end, with ``qpos0`` and the
    mocap bodies' body positions, and writes the padded values back into the spec's ``keys``. The cable's
    joints and grippers come after the spec's own and the cable compiles in its start shape, so a keyframe written
    before the cable was added keeps its values and puts the cable at its start and the grippers at their pins.

    Callers snap the spec (:func:`mjcable.mjcf.snap.snap_spec`) before compiling or saving it, as :func:`build`
    does.

    Raises:
      ValueError: the installed MuJoCo has no cable plugin (MuJoCo 4; :func:`missing_plugin` says why).
    """
    reason = missing_plugin()
    if reason is not None:
        raise ValueError(reason)
    cable = scene.cable
    n = cable.n_segments
    l0 = cable.segment_length
    kind, tree_pin = joints.root_joint(scene)
    order = joints.tree_order(scene)
    p = cable.particles[order]  # tree order: body i's origin is p[i], particle order[i]
    spec.option.viscosity = joints.segment_viscosity(scene)
    spec.option.integrator = joints.integrator(scene, timestep)
    spec.option.jacobian = joints.jacobian(scene)

    # Element order as MuJoCo's <composite> generated it before the world and pins: the chain is the first body
    # unless a gripper roots it (then the chain is the gripper's child, after the anchors).
    gripper_root = tree_pin is not None and scene.pins[tree_pin].kind == "gripper"
    if gripper_root:
        joints.add_anchors(spec, scene)
        parent, origin = spec.body(world.gripper_body(tree_pin)), np.zeros(3)
    else:
        parent, origin = spec.worldbody, p[0]
    _add_chain(spec, scene, parent, origin, p, order, kind, timestep=timestep, self_collision=self_collision)
    if not gripper_root:
        joints.add_anchors(spec, scene)
    world.stiffen_obstacle_contacts(spec, scene, timestep)
    spec.body(body_name(n - 1, n)).add_site(name=world.particle_site(order[n]), pos=[l0, 0.0, 0.0])
    for i in range(n - 1):
        spec.add_exclude(bodyname1=body_name(i, n), bodyname2=body_name(i + 1, n))
    if self_collision:
        world.exclude_overlapping(spec, scene, [body_name(i, n) for i in range(n)], start=2)
    joints.add_pin_equalities(spec, scene, timestep=timestep, body_name=lambda i: body_name(i, n), skip=tree_pin)


def _add_chain(spec: mujoco.MjSpec, scene: Scene, parent, origin: np.ndarray, p: np.ndarray, order: np.ndarray,
               kind, *, timestep: float, self_collision: bool) -> None:
    """The capsule bodies, ball joints, geoms and sites of the chain under ``parent`` (root body at ``origin`` in
    it, with the root's joints ``kind``) and, for E > 0, the plugin instance on every body: what ``<composite
    type="cable" initial="none">`` makes, with exact frames and our contact attributes, armature and damping; and
    the clamp bodies at its ends (:func:`mjcable.mjcf.joints.frame_clamps`), on the plugin too."""
    cable = scene.cable
    n = cable.n_segments
    l0 = cable.segment_length
    bend, twist = plugin_moduli(scene)
    plugin = None
    if bend > 0.0:
        spec.activate_plugin(PLUGIN)  # <extension><plugin plugin="mujoco.elasticity.cable"/>
        plugin = spec.add_plugin(name=INSTANCE, plugin_name=PLUGIN, active=True)
        plugin.config = {"twist": repr(float(twist)), "bend": repr(float(bend)), "flat": "true"}
    spec.add_text(name=f"composite_{PREFIX}", data=f"rope_{PREFIX}")  # the composite's tag

    geom = world.cable_geom(scene, self_collision=self_collision)
    options = joints.ball_options(scene, timestep)
    # Exact frames in the composite's convention: twist-free, x along each segment.
    frames = joints.segment_frames(p)
    rel = joints.relative_quats(frames)
    first, last = joints.frame_clamps(scene)
    for i in range(n):
        if i == 0:
            body = joints.add_first_body(parent, scene, kind, pos=origin, quat=frames[0], timestep=timestep,
                                         name=body_name(0, n), root_name=f"{PREFIX}J_first")
            if first is not None and plugin is not None:
                spec.body(joints.clamp_body_name(first)).plugin = plugin
        else:
            body = body.add_body(name=body_name(i, n), pos=[l0, 0.0, 0.0], quat=rel[i - 1])
            body.add_joint(name=joint_name(i, n), type=mujoco.mjtJoint.mjJNT_BALL, group=_HIDDEN_GROUP, **options)
        body.add_geom(name=f"{PREFIX}G{i}", type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0.0, 0.0, 0.0, l0, 0.0, 0.0],
                      size=[cable.radius, 0.0, 0.0], mass=cable.mass / n, **geom)
        if i == 0:  # a single segment is first and last: its one site at the end, as the composite does
            body.add_site(name=f"{PREFIX}S_first", pos=[l0 if n == 1 else 0.0, 0.0, 0.0], group=_HIDDEN_GROUP)
        elif i == n - 1:
            body.add_site(name=f"{PREFIX}S_last", pos=[l0, 0.0, 0.0], group=_HIDDEN_GROUP)
        body.add_site(name=world.particle_site(order[i]))
        if plugin is not None:
            body.plugin = plugin
    clamp = joints.add_last_clamp(body, scene, timestep=timestep)
    if clamp is not None and plugin is not None:
        clamp.plugin = plugin

