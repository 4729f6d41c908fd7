"""``composite``: MuJoCo's ``<composite type="cable">`` with the ``mujoco.elasticity.cable`` plugin.

MuJoCo generates the cable from a minimal XML fragment (``vertex=`` the scene's start particles in tree order, see
the pins below): a chain of capsule bodies ``cableB_first``, ``cableB_1`` … ``cableB_{n-2}``, ``cableB_last``
linked by ball joints ``cableJ_1`` … ``cableJ_last``, body ``i``'s frame at the tree's ``i``-th particle with its x
axis along the segment (frames transported without twist), capsule geoms ``cableG{i}``, sites ``cableS_first`` /
``cableS_last``. MuJoCo 3.17's ``initial`` sets the root joint ``cableJ_first`` (``"free"``: a free joint,
``"ball"``, ``"none"``: welded to its parent); we ask for ``"none"`` and add the root's joints as ``joints`` does
(:func:`mjcable.mjcf.joints.add_root_joints`), so that its rotation carries the same armature. Everything else is
added with the MjSpec API after parsing: the ``particle{i}`` sites (at the origin of the body that starts at
particle ``i``; the tree's last particle at the end of the last capsule), exact frames (the composite computes its
own from single-precision vertices, 1e-6 m off), contact attributes, armature, pins, and the neighbour excludes
(the composite's own name a missing body for 2 segments). The same capsule chain as ``joints``, with MuJoCo's rod
model for bending and twist instead of joint springs.

Mapping from the physical cable:

* mass: each of the n segment bodies weighs m/n (the composite's ``<geom mass=...>``);
* length: the segments are the equal chords l₀ of the start particles; the chain is inextensible (E·A,
  ``stretch_stiffness``, is not modelled);
* bending and twist: the cable plugin (only when E > 0) with ``bend`` = E and ``twist`` = G = E / (2 (1 + ν)),
  ν = ``POISSON`` = 0.5 (an incompressible, rubber-like jacket). The plugin computes I = π r⁴ / 4 and J = π r⁴ / 2
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
ball, clamped: none; gripper: ball or none, the generated chain re-parented under the mocap body ``gripper{k}``),
every other pin (sockets always) with site-to-site connect equalities ``pin{k}`` / ``pin{k}_clamp``. A moving
gripper held by an equality at the far leaf of the chain diverges (see ``joints``).
"""

from __future__ import annotations

import mujoco
import numpy as np

from mjcable.mjcf import joints, snap, world
from mjcable.scene import Scene

__all__ = ["build", "body_name", "plugin_moduli", "POISSON", "PREFIX", "PLUGIN"]

POISSON = 0.5  # Poisson's ratio ν of the cable, for the plugin's shear modulus G = E / (2 (1 + ν))
PREFIX = "cable"
PLUGIN = "mujoco.elasticity.cable"

_XML = """<mujoco>
  {extension}
  <worldbody>
    <composite prefix="{prefix}" type="cable" initial="none" vertex="{vertex}">
      {plugin}
      <geom type="capsule" size="{radius!r}" mass="{mass!r}"/>
    </composite>
  </worldbody>
</mujoco>
"""
_PLUGIN_XML = ('<plugin plugin="{name}"><config key="bend" value="{bend!r}"/><config key="twist" value="{twist!r}"/>'
               '<config key="flat" value="true"/></plugin>')


def body_name(i: int, n_segments: int) -> str:
    """Name of the composite's body ``i`` of ``n_segments``."""
    if i == 0:
        return f"{PREFIX}B_first"
    if i == n_segments - 1:
        return f"{PREFIX}B_last"
    return f"{PREFIX}B_{i}"


def plugin_moduli(scene: Scene) -> tuple:
    """``(bend, twist)`` of the cable plugin in Pa: E and G = E / (2 (1 + ν))."""
    young = scene.cable.young
    return young, young / (2.0 * (1.0 + POISSON))


def _base_xml(scene: Scene) -> str:
    cable = scene.cable
    bend, twist = plugin_moduli(scene)
    stiff = bend > 0.0
    return _XML.format(
        extension=f'<extension><plugin plugin="{PLUGIN}"/></extension>' if stiff else "",
        prefix=PREFIX,
        vertex=" ".join(repr(float(x)) for x in cable.particles[joints.tree_order(scene)].ravel()),
        plugin=_PLUGIN_XML.format(name=PLUGIN, bend=bend, twist=twist) if stiff else "",
        radius=cable.radius, mass=cable.mass / cable.n_segments,
    )


def build(scene: Scene, *, timestep: float, self_collision: bool = False) -> mujoco.MjSpec:
    """The ``composite`` spec of ``scene`` (see the module docstring); MuJoCo steps at ``timestep`` seconds."""
    cable = scene.cable
    n = cable.n_segments
    l0 = cable.segment_length
    kind, tree_pin = joints.root_joint(scene)
    order = joints.tree_order(scene)
    p = cable.particles[order]  # tree order: body i's origin is p[i], particle order[i]
    spec = world.new_spec(scene, timestep=timestep, base_xml=_base_xml(scene))
    spec.option.viscosity = joints.segment_viscosity(scene)
    spec.option.integrator = joints.integrator(scene, timestep)
    spec.option.jacobian = joints.jacobian(scene)
    for exclude in list(spec.excludes):  # the composite's own neighbour excludes (wrong for n = 2): ours below
        spec.delete(exclude)

    joints.add_anchors(spec, scene)
    if tree_pin is not None and scene.pins[tree_pin].kind == "gripper":
        _reparent(spec, spec.body(body_name(0, n)), spec.body(world.gripper_body(tree_pin)), p[0])

    geom = world.cable_geom(scene, self_collision=self_collision)
    world.stiffen_obstacle_contacts(spec, scene, timestep)
    options = joints.ball_options(scene, timestep)
    # The composite computes its frames from single-precision vertices; put in exact ones of the same convention
    # (twist-free, x along each segment; only the root's roll about its axis differs, which nothing depends on).
    frames = joints.segment_frames(p)
    rel = joints.relative_quats(frames)
    for i in range(n):
        body = spec.body(body_name(i, n))
        body.pos, body.quat = (p[0], frames[0]) if i == 0 else ([l0, 0.0, 0.0], rel[i - 1])
        body.add_site(name=world.particle_site(order[i]))
        for g in body.geoms:
            g.fromto = [0.0, 0.0, 0.0, l0, 0.0, 0.0]
            for key, value in geom.items():
                setattr(g, key, value)
        for j in body.joints:
            if j.type == mujoco.mjtJoint.mjJNT_BALL:
                j.armature, j.damping = options["armature"], options["damping"]
    joints.add_root_joints(spec.body(body_name(0, n)), kind, name=f"{PREFIX}J_first", options=options)
    spec.body(body_name(n - 1, n)).add_site(name=world.particle_site(order[n]), pos=[l0, 0.0, 0.0])
    for i in range(n - 1):
        spec.add_exclude(bodyname1=body_name(i, n), bodyname2=body_name(i + 1, n))

    joints.add_pin_equalities(spec, scene, timestep=timestep, skip=tree_pin)
    return snap.snap_spec(spec)


def _reparent(spec: mujoco.MjSpec, root, parent, origin: np.ndarray) -> None:
    """Move the generated chain under ``parent`` (a body at world position ``origin`` with identity orientation):
    MjSpec attaches a deep copy (names, plugin and all), then the original is deleted."""
    spec.copy_during_attach = True  # write-only flag
    parent.add_frame(pos=-np.asarray(origin)).attach_body(root, "", "")
    spec.copy_during_attach = False
    spec.delete(root)
