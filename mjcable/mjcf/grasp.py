"""Free grippers (``Scene.grippers``) in a model's spec: what grasps a particle at run time.

Free gripper ``g`` is the mocap body ``gripper{P + g}`` (P = ``len(scene.pins)``: it is numbered after the pins'
grippers, as :meth:`mjcable.Simulator.move_gripper` numbers it) with a visual sphere and the site ``grasp{g}``. The
native models also get the equality ``grasp{g}``: a stiff site-to-site ``connect`` from a particle's site to
``grasp{g}``, inactive at the start. :class:`mjcable.backends.grasp.NativeGrasps` re-targets it at run time (its
first site becomes the grasped particle's, ``grasp{g}`` moves to where that particle is in the gripper's frame) and
switches it with ``mjData.eq_active``; the particle solvers switch a pin row instead and use only the body.
"""

from __future__ import annotations

from typing import Optional

import mujoco

from mjcable.mjcf import cables, world
from mjcable.scene import Scene

__all__ = ["add_free_grippers", "grasp_site", "grasp_equality", "free_gripper_body"]

_VISUAL_RADII = 2.5  # a free gripper's sphere, in cable radii (as a gripper pin's)


def grasp_site(g: int) -> str:
    """The site of free gripper ``g`` that holds its grasped particle."""
    return f"grasp{g}"


def grasp_equality(g: int) -> str:
    """The connect equality of free gripper ``g`` (native models)."""
    return f"grasp{g}"


def free_gripper_body(scene: Scene, g: int) -> str:
    """The mocap body of free gripper ``g``: ``gripper{len(scene.pins) + g}``."""
    return world.gripper_body(len(scene.pins) + g)


def add_free_grippers(spec: mujoco.MjSpec, scene: Scene, *, timestep: Optional[float] = None) -> mujoco.MjSpec:
    """Add ``scene``'s free grippers to ``spec`` (after everything else, so no other element's id changes): each
    one's mocap body at its start position with its site, and with ``timestep`` (the physics step, s; native models)
    its inactive connect equality. Returns ``spec``."""
    radius = _VISUAL_RADII * max(c.radius for c in scene.cables)
    for g, gripper in enumerate(scene.grippers):
        body = spec.worldbody.add_body(name=free_gripper_body(scene, g), pos=gripper.position, mocap=True)
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[radius, 0, 0], contype=0, conaffinity=0,
                      density=0.0, material="gripper", group=1)  # visual only: no mass, no contacts
        body.add_site(name=grasp_site(g))
        if timestep is not None:
            spec.add_equality(name=grasp_equality(g), type=mujoco.mjtEq.mjEQ_CONNECT,
                              objtype=mujoco.mjtObj.mjOBJ_SITE, name1=cables.particle_name(scene, 0),
                              name2=grasp_site(g), solref=world.pin_solref(timestep), solimp=world.PIN_SOLIMP,
                              active=False)
    return spec
