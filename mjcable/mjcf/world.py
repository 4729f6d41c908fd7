"""The rigid world every cable model shares: options, obstacles, lights, camera, pin anchors.

Native models and the particle solvers' proxy all start from :func:`new_spec`, so obstacles, lights and cameras are
identical and videos compare like with like. Naming conventions used across :mod:`mjcable.mjcf`:

* site ``particle{i}``: centreline particle ``i`` (every model has one per particle; ``Simulator.positions`` reads
  them in one vectorised gather);
* body ``gripper{k}`` (mocap) with site ``anchor{k}``: the gripper of ``scene.pins[k]``;
* site ``anchor{k}`` in the world body: the fixed end of a world or socket pin ``k``;
* equality ``pin{k}`` (and ``pin{k}_clamp``): the constraint that realises pin ``k`` where a model needs one.
"""

from __future__ import annotations

import math
from typing import Optional

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from mjcable import geometry
from mjcable.scene import GRAVITY, Box, Capsule, Cylinder, Floor, Scene, Sphere

__all__ = [
    "new_spec",
    "cable_geom",
    "add_anchor",
    "add_connect",
    "particle_site",
    "anchor_site",
    "gripper_body",
    "pin_equality",
    "CABLE_CONTYPE",
    "OBSTACLE_CONTYPE",
    "CAMERA",
    "START_KEY",
    "CONTACT_SOLREF_STEPS",
    "stiffen_obstacle_contacts",
]

CABLE_CONTYPE = 2  # cable geoms collide with obstacles (conaffinity 1), not with each other unless asked
OBSTACLE_CONTYPE = 1
CAMERA = "overview"
START_KEY = "start"  # keyframe holding the scene's start pose where a model compiles in another (straight) pose
_TORSION_ROLL_FRICTION = (0.005, 0.0001)
_FLOOR_HALF_SIZE = 5.0  # m, rendered extent of a Floor plane
_CAMERA_FOVY = 45.0  # degrees
_CAMERA_MARGIN = 1.35  # frame the cable's bounding box with this much room
CONTACT_SOLREF_STEPS = 2.0  # stiff obstacle contact time constant in physics steps (MuJoCo's stable minimum)
_PIN_SOLREF_STEPS = 2.0  # equality time constant in physics steps (MuJoCo's stable minimum)
_IMPRATIO = 10.0  # frictional-to-normal impedance ratio (MuJoCo's remedy for contact slip)
PIN_SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)


def particle_site(i: int) -> str:
    return f"particle{i}"


def anchor_site(k: int) -> str:
    return f"anchor{k}"


def gripper_body(k: int) -> str:
    return f"gripper{k}"


def pin_equality(k: int, clamp: bool = False) -> str:
    return f"pin{k}_clamp" if clamp else f"pin{k}"


def new_spec(scene: Scene, *, timestep: float, base_xml: Optional[str] = None) -> mujoco.MjSpec:
    """A spec holding the scene's world: options, assets, lights, obstacles and the overview camera.

    Args:
      scene: the scene.
      timestep: MuJoCo's physics step in seconds.
      base_xml: MJCF to start from (for models that MuJoCo only generates from XML, such as ``composite`` and
        ``flexcomp``; ``MjSpec.attach`` would silently drop a flex).
    """
    spec = mujoco.MjSpec.from_string(base_xml) if base_xml else mujoco.MjSpec()
    spec.modelname = f"mjcable_{scene.name}"
    spec.option.timestep = timestep
    spec.option.gravity = GRAVITY
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC  # with impratio: static friction holds without creep
    spec.option.impratio = _IMPRATIO
    spec.visual.global_.offwidth = 1280
    spec.visual.global_.offheight = 720
    spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
    spec.visual.headlight.diffuse = [0.5, 0.5, 0.5]
    box = _cable_box(scene)
    spec.stat.center = box.mean(axis=0)
    spec.stat.extent = max(float(np.ptp(box, axis=0).max()), 0.2)

    spec.add_texture(name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
                     rgb1=[0.82, 0.84, 0.86], rgb2=[0.72, 0.74, 0.77], width=300, height=300)
    spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX, builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
                     rgb1=[0.93, 0.95, 0.98], rgb2=[0.75, 0.8, 0.88], width=256, height=1536)
    grid = spec.add_material(name="grid", texrepeat=[8, 8], reflectance=0.05)
    grid.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "grid"
    spec.add_material(name="obstacle", rgba=[0.62, 0.5, 0.38, 1.0])
    spec.add_material(name="cable", rgba=[0.85, 0.25, 0.12, 1.0])
    spec.add_material(name="gripper", rgba=[0.2, 0.4, 0.9, 0.6])

    world = spec.worldbody
    center = spec.stat.center
    world.add_light(name="key", pos=center + np.array([0.5, -1.0, 2.5]), dir=[-0.2, 0.4, -1.0],
                    diffuse=[0.6, 0.6, 0.6], castshadow=True)
    for i, ob in enumerate(scene.obstacles):
        _add_obstacle(world, scene, i, ob)
    _add_camera(world, box)
    return spec


def stiffen_obstacle_contacts(spec: mujoco.MjSpec, scene: Scene, timestep: float) -> None:
    """Give the scene's obstacles (whose contact parameters take precedence) the contact time constant
    ``CONTACT_SOLREF_STEPS`` physics steps instead of MuJoCo's default 20 ms. Measured at dt = 2 ms
    (``mjcable stress``'s plate and ``incline`` families): it stops ``springs`` sinking through a 4 mm plate (4 of 4
    runs before, 0 after) and its contacts chattering as it slides down a slope (sliding acceleration 34 % too fast
    before, 1 % after), and the ``joints`` chain draping over a peg pulling through it. ``flexrod`` keeps the
    default: its flex contacts still tunnel with it, and slide 2 % off Coulomb across a slope (0.3 % with the
    default)."""
    for i in range(len(scene.obstacles)):
        spec.geom(f"obstacle{i}").solref = [CONTACT_SOLREF_STEPS * timestep, 1.0]


def _cable_box(scene: Scene) -> np.ndarray:
    """(2, 3) bounds of where the cable can be: its start particles, grown downwards by its slack."""
    p = scene.cable.particles
    lo, hi = p.min(axis=0), p.max(axis=0)
    slack = max(scene.cable.length - float(np.linalg.norm(p[-1] - p[0])), 0.0)
    if not scene.pins:
        slack = 0.0
    lo = lo - np.array([0.0, 0.0, 0.5 * slack])
    if any(isinstance(ob, (Box, Cylinder, Sphere)) for ob in scene.obstacles):
        tops = [ob.pos[2] for ob in scene.obstacles if not isinstance(ob, Floor)]
        lo[2] = min(lo[2], min(tops))
    return np.stack([lo, hi])


def _add_camera(world, box: np.ndarray) -> None:
    """A fixed camera in front of (−y) and above the (2, 3) bounds ``box`` that frames them."""
    center = box.mean(axis=0)
    half = 0.5 * np.ptp(box, axis=0) * _CAMERA_MARGIN
    radius = max(float(np.hypot(half[0], half[2])), float(half[1]), 0.15)
    distance = radius / math.tan(math.radians(_CAMERA_FOVY / 2)) + half[1]
    elevation = math.radians(20.0)
    pos = center + distance * np.array([0.0, -math.cos(elevation), math.sin(elevation)])
    forward = (center - pos) / np.linalg.norm(center - pos)
    x_axis = np.array([1.0, 0.0, 0.0])
    y_axis = np.cross(-forward, x_axis)
    world.add_camera(name=CAMERA, pos=pos, fovy=_CAMERA_FOVY,
                     quat=_axes_quat(x_axis, y_axis / np.linalg.norm(y_axis)))


def _axes_quat(x_axis, y_axis) -> np.ndarray:
    z_axis = np.cross(x_axis, y_axis)
    return Rotation.from_matrix(np.stack([x_axis, y_axis, z_axis], axis=1)).as_quat(scalar_first=True)


def _add_obstacle(world, scene: Scene, i: int, ob) -> None:
    mu = scene.cable.friction if ob.friction is None else ob.friction
    common = dict(
        name=f"obstacle{i}", pos=ob.pos, quat=geometry.quaternion(ob.euler),
        friction=[mu, *_TORSION_ROLL_FRICTION], priority=1,  # higher priority: this μ is the one in force
        contype=OBSTACLE_CONTYPE, conaffinity=OBSTACLE_CONTYPE, condim=3,
    )
    if isinstance(ob, Floor):
        world.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[_FLOOR_HALF_SIZE, _FLOOR_HALF_SIZE, 0.05],
                       material="grid", **common)
    elif isinstance(ob, Box):
        world.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=ob.size, material="obstacle", **common)
    elif isinstance(ob, Capsule):
        world.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, size=[ob.radius, ob.half_length, 0],
                       material="obstacle", **common)
    elif isinstance(ob, Cylinder):
        world.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[ob.radius, ob.half_length, 0],
                       material="obstacle", **common)
    elif isinstance(ob, Sphere):
        world.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[ob.radius, 0, 0], material="obstacle", **common)
    else:  # pragma: no cover - Scene validates obstacle types
        raise ValueError(f"unsupported obstacle {ob!r}")


def cable_geom(scene: Scene, *, self_collision: bool = False) -> dict:
    """Contact attributes for the cable's geoms: the cable's μ, condim 3, collisions with obstacles only unless
    ``self_collision`` (neighbouring segments are then excluded by each model)."""
    return dict(
        friction=[scene.cable.friction, *_TORSION_ROLL_FRICTION], condim=3, material="cable",
        contype=CABLE_CONTYPE, conaffinity=OBSTACLE_CONTYPE | (CABLE_CONTYPE if self_collision else 0),
    )


def add_anchor(spec: mujoco.MjSpec, scene: Scene, k: int, position=None) -> str:
    """Create the fixed side of pin ``k`` at ``position`` (default: its particle's start position) and return the
    name of its site: a world site for world and socket pins, a mocap body ``gripper{k}`` for gripper pins."""
    pin = scene.pins[k]
    pos = scene.cable.particles[scene.pin_particle(k)] if position is None else np.asarray(position)
    name = anchor_site(k)
    if pin.kind == "gripper":
        body = spec.worldbody.add_body(name=gripper_body(k), pos=pos, mocap=True)
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[2.5 * scene.cable.radius, 0, 0], contype=0,
                      conaffinity=0, density=0.0, material="gripper", group=1)  # visual only: no mass, no contacts
        body.add_site(name=name)
    else:
        spec.worldbody.add_site(name=name, pos=pos)
    return name


def add_connect(spec: mujoco.MjSpec, name: str, site1: str, site2: str, *, timestep: float) -> None:
    """A stiff site-to-site ``connect`` equality (independent of qpos0, so models may compile straight)."""
    spec.add_equality(name=name, type=mujoco.mjtEq.mjEQ_CONNECT, objtype=mujoco.mjtObj.mjOBJ_SITE,
                      name1=site1, name2=site2, solref=[_PIN_SOLREF_STEPS * timestep, 1.0], solimp=PIN_SOLIMP)
