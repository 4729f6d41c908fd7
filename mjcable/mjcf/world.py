"""The rigid world every cable model shares: options, obstacles, lights, camera, pin anchors.

Native models and the particle solvers' proxy all start from :func:`new_spec`, so obstacles, lights and cameras are
identical and videos compare like with like. Naming conventions used across :mod:`mjcable.mjcf`:

* site ``particle{i}``: centreline particle ``i`` (every model has one per particle; ``Simulator.positions`` reads
  them in one vectorised gather);
* body ``gripper{k}`` (mocap) with site ``anchor{k}``: the gripper of ``scene.pins[k]``;
* site ``anchor{k}`` in the world body: the fixed end of a world or socket pin ``k``;
* site ``anchor{k}`` in the user world's body ``pin.body``: the held point of a body pin ``k``;
* equality ``pin{k}`` (and ``pin{k}_clamp``): the constraint that realises pin ``k`` where a model needs one.

With a user world (``Scene(world=...)``, :mod:`mjcable.user_world`) :func:`new_spec` starts from a copy of the
user's spec: its options (timestep aside), assets, lights and cameras are kept, and only what the cable needs is
added after the user's elements (materials, the scene's own obstacles, an ``overview`` camera if the world has
none). :func:`finish` then gives the model the keyframe :data:`START_KEY` holding the world's start (its
``keyframe`` or default pose) with the cable's start appended, and :func:`user_names` turns MuJoCo's "repeated
name" into a ``ValueError`` that says which of the user's names clashes with the cable's.
"""

from __future__ import annotations

import contextlib
import math
from typing import Optional

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from mjcable import geometry
from mjcable.scene import BODY_PIN_REACH, GRAVITY, Box, Capsule, Cylinder, Floor, Scene, Sphere
from mjcable.user_world import CABLE_CONTYPE, OBSTACLE_CONTYPE

__all__ = [
    "new_spec",
    "finish",
    "reset_to_start",
    "user_names",
    "cable_geom",
    "add_anchor",
    "exclude_overlapping",
    "add_connect",
    "pin_solref",
    "add_clamp_anchor",
    "pinned_segments",
    "particle_site",
    "anchor_site",
    "gripper_body",
    "pin_equality",
    "CABLE_CONTYPE",
    "OBSTACLE_CONTYPE",
    "CAMERA",
    "CABLE_COLOURS",
    "START_KEY",
    "CONTACT_SOLREF_STEPS",
    "stiffen_obstacle_contacts",
]

CAMERA = "overview"
#: RGBA of each cable's material and drawing (cable c: ``CABLE_COLOURS[c % len(CABLE_COLOURS)]``)
CABLE_COLOURS = ((0.85, 0.25, 0.12, 1.0), (0.12, 0.45, 0.85, 1.0), (0.2, 0.65, 0.25, 1.0), (0.8, 0.6, 0.1, 1.0),
                 (0.55, 0.3, 0.75, 1.0), (0.1, 0.65, 0.65, 1.0))
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


def pin_equality(k: int, clamp: bool = False, roll: bool = False) -> str:
    return f"pin{k}_roll" if roll else (f"pin{k}_clamp" if clamp else f"pin{k}")


def roll_site(i: int) -> str:
    """The site beside particle ``i``, off the cable's axis, that a clamp's third connect holds."""
    return f"particle{i}_roll"


def clamp_site(i: int) -> str:
    """The site on the cable's axis, a segment in from particle ``i``, that the clamp body of a clamp at particle
    ``i`` holds with its second connect (:func:`mjcable.mjcf.joints.frame_clamps`)."""
    return f"particle{i}_clamp"


def new_spec(scene: Scene, *, timestep: float, base_xml: Optional[str] = None) -> mujoco.MjSpec:
    """A spec holding the scene's world: options, assets, lights, obstacles and the overview camera.

    Args:
      scene: the scene.
      timestep: MuJoCo's physics step in seconds.
      base_xml: MJCF to start from (for models that MuJoCo only generates from XML, such as ``composite`` and
        ``flexcomp``; ``MjSpec.attach`` would silently drop a flex).
    """
    if scene.world is not None:
        if base_xml:
            raise ValueError("this model is generated from MJCF text and cannot build into a user world yet")
        return _user_spec(scene, timestep)
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

    _add_materials(spec, grid=True)
    spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX, builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
                     rgb1=[0.93, 0.95, 0.98], rgb2=[0.75, 0.8, 0.88], width=256, height=1536)

    world = spec.worldbody
    center = spec.stat.center
    world.add_light(name="key", pos=center + np.array([0.5, -1.0, 2.5]), dir=[-0.2, 0.4, -1.0],
                    diffuse=[0.6, 0.6, 0.6], castshadow=True)
    for i, ob in enumerate(scene.obstacles):
        _add_obstacle(world, scene, i, ob)
    _add_camera(world, box)
    return spec


def _user_spec(scene: Scene, timestep: float) -> mujoco.MjSpec:
    """A copy of the user's world with what every model needs added: the timestep, materials, obstacles and an
    ``overview`` camera (only if the world has none)."""
    spec = scene.world.spec()
    spec.option.timestep = timestep
    spec.visual.global_.offwidth = max(spec.visual.global_.offwidth, 1280)
    spec.visual.global_.offheight = max(spec.visual.global_.offheight, 720)
    with user_names(scene):
        _add_materials(spec, grid=any(isinstance(ob, Floor) for ob in scene.obstacles),
                       have={m.name for m in spec.materials})
        for i, ob in enumerate(scene.obstacles):
            _add_obstacle(spec.worldbody, scene, i, ob)
        if CAMERA not in {c.name for c in spec.cameras}:
            _add_camera(spec.worldbody, _cable_box(scene))
    return spec


def _add_materials(spec: mujoco.MjSpec, *, grid: bool, have: frozenset = frozenset()) -> None:
    """The materials the cable's elements use (``obstacle``, ``cable``, ``gripper``, and with ``grid`` a Floor's
    checker ``grid`` and its texture), but those named in ``have`` (a user world's own)."""
    if grid and "grid" not in have:
        spec.add_texture(name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
                         rgb1=[0.82, 0.84, 0.86], rgb2=[0.72, 0.74, 0.77], width=300, height=300)
        material = spec.add_material(name="grid", texrepeat=[8, 8], reflectance=0.05)
        material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "grid"
    for name, rgba in (("obstacle", [0.62, 0.5, 0.38, 1.0]), ("cable", list(CABLE_COLOURS[0])),
                       ("gripper", [0.2, 0.4, 0.9, 0.6])):
        if name not in have:
            spec.add_material(name=name, rgba=rgba)


@contextlib.contextmanager
def user_names(scene: Scene):
    """Inside: MuJoCo's "repeated name" from adding the cable's elements to a user world becomes a ``ValueError``
    naming the clash (MjSpec raises it as soon as a second element of a name is added)."""
    try:
        yield
    except ValueError as error:
        if scene.world is None or "repeated name" not in str(error):
            raise
        raise ValueError(f"world: the cable needs an element your world already has ({error}); mjcable names "
                         f"its elements cable*, particle*, segment*, anchor*, gripper*, grasp*, pin*, obstacle*, spring*, "
                         f"ring*, {CAMERA!r} and {START_KEY!r}: rename yours") from None


def finish(spec: mujoco.MjSpec, scene: Scene) -> mujoco.MjSpec:
    """In a user world, the keyframe :data:`START_KEY` that a Simulator resets to: the world's start (its
    ``keyframe`` or default pose: qpos, qvel, act, ctrl and its mocap bodies) followed by the cable's start (the
    model's own start key if it made one, else the cable's default pose). The user's keyframes need nothing:
    MuJoCo pads a keyframe's qpos with the default pose of the joints added after them. Returns ``spec``."""
    if scene.world is None:
        return spec
    _exclude_pinned_bodies(spec, scene)
    start = scene.world.start_state()
    ours = next((k for k in spec.keys if k.name == START_KEY), None)
    if ours is None:
        with user_names(scene):
            spec.add_key(name=START_KEY, qpos=start["qpos"], qvel=start["qvel"], act=start["act"],
                         ctrl=start["ctrl"], mpos=start["mpos"].ravel(), mquat=start["mquat"].ravel())
        return spec
    # the model's own start key begins with the world's default pose (it was made in the world's spec: flexrod's
    # start shape); put the world's start there
    qpos, mpos, mquat = np.array(ours.qpos), np.array(ours.mpos), np.array(ours.mquat)
    nq, nm = len(start["qpos"]), 3 * len(start["mpos"])
    qpos[:nq] = start["qpos"]
    if nm:
        mpos[:nm], mquat[:4 * len(start["mpos"])] = start["mpos"].ravel(), start["mquat"].ravel()
        ours.mpos, ours.mquat = mpos, mquat
    ours.qpos = qpos
    ours.qvel = start["qvel"]  # MuJoCo pads it with the cable's zero velocities
    ours.act, ours.ctrl = start["act"], start["ctrl"]
    return spec


def pinned_segments(scene: Scene, body: str) -> set:
    """The cable segments (i between particles i and i + 1) that never touch user body ``body``: those within
    ``BODY_PIN_REACH`` particles of a body pin on it (the cable's end starts touching the body it is fastened
    to)."""
    near = set()
    n = scene.n_particles - 1
    for k, pin in enumerate(scene.pins):
        if pin.on_body and pin.body == body:
            i = scene.pin_particle(k)
            near.update(range(max(i - BODY_PIN_REACH, 0), min(i + BODY_PIN_REACH, n)))
    return near


def _exclude_pinned_bodies(spec: mujoco.MjSpec, scene: Scene) -> None:
    """No contacts between a body pin's body and the cable bodies holding the particles within
    ``BODY_PIN_REACH`` of its particle: the cable's end starts touching the body it is fastened to."""
    n = scene.n_particles
    pairs = set()
    for k, pin in enumerate(scene.pins):
        if not pin.on_body:
            continue
        i = scene.pin_particle(k)
        for j in range(max(i - BODY_PIN_REACH, 0), min(i + BODY_PIN_REACH, n - 1) + 1):
            site = spec.site(particle_site(j))
            body = site.parent.name if site is not None else ""
            if body and body != pin.body and (pin.body, body) not in pairs:
                pairs.add((pin.body, body))
                spec.add_exclude(bodyname1=pin.body, bodyname2=body)


def reset_to_start(m: mujoco.MjModel, d: mujoco.MjData) -> None:
    """Reset ``d`` to the model's start: the keyframe :data:`START_KEY` where the model has one (a stiff
    ``flexrod``, any model in a user world), else the default pose. Kinematics are left to the caller."""
    key = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, START_KEY)
    if key >= 0:
        mujoco.mj_resetDataKeyframe(m, d, key)
    else:
        mujoco.mj_resetData(m, d)


def stiffen_obstacle_contacts(spec: mujoco.MjSpec, scene: Scene, timestep: float) -> None:
    """Give the scene's obstacles (whose contact parameters take precedence) the contact time constant
    ``CONTACT_SOLREF_STEPS`` physics steps instead of MuJoCo's default 20 ms: ``springs`` then no longer sinks
    through a thin plate nor chatters down a slope, and the ``joints`` chain no longer pulls through a peg.
    ``flexrod`` keeps the default, which slides closer to Coulomb (``docs/measurements.md``)."""
    for i in range(len(scene.obstacles)):
        spec.geom(f"obstacle{i}").solref = [CONTACT_SOLREF_STEPS * timestep, 1.0]


def _cable_box(scene: Scene) -> np.ndarray:
    """(2, 3) bounds of where the cables can be: their start particles, grown downwards by the slackest's slack."""
    p = scene.particles
    lo, hi = p.min(axis=0), p.max(axis=0)
    slack = max(max(c.length - float(np.linalg.norm(c.particles[-1] - c.particles[0])) for c in scene.cables), 0.0)
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
    mu = _cable_friction(scene) if ob.friction is None else ob.friction
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


def _cable_friction(scene: Scene) -> float:
    """The cables' μ: the larger of several cables' (one cable's own)."""
    return max(c.friction for c in scene.cables)


def cable_geom(scene: Scene, *, self_collision: bool = False) -> dict:
    """Contact attributes for the cable's geoms: the cable's μ, condim 3, collisions with obstacles only unless
    ``self_collision`` (neighbouring segments are then excluded by each model)."""
    return dict(
        friction=[_cable_friction(scene), *_TORSION_ROLL_FRICTION], condim=3, material="cable",
        contype=CABLE_CONTYPE, conaffinity=OBSTACLE_CONTYPE | (CABLE_CONTYPE if self_collision else 0),
    )


def exclude_overlapping(spec: mujoco.MjSpec, scene: Scene, bodies: list, *, spheres: bool = False,
                        start: int = 1) -> None:
    """No contacts between the cable's bodies ``bodies`` (names in chain order) whose geoms overlap at rest:
    neighbours ``start`` .. :meth:`~mjcable.scene.CableSpec.overlapping_neighbours` apart (capsules, or spheres at
    the particles). For self-collision: overlapping geoms would push each other apart and stretch the cable."""
    for k in range(start, scene.cable.overlapping_neighbours(spheres=spheres) + 1):
        for i in range(len(bodies) - k):
            spec.add_exclude(bodyname1=bodies[i], bodyname2=bodies[i + k])


def add_anchor(spec: mujoco.MjSpec, scene: Scene, k: int, position=None) -> str:
    """Create the fixed side of pin ``k`` at ``position`` (default: its particle's start position) and return the
    name of its site: a world site for world and socket pins, a mocap body ``gripper{k}`` for gripper pins, a site
    at the pin's offset in the user's body for body pins (``position`` ignored)."""
    pin = scene.pins[k]
    pos = scene.particles[scene.pin_particle(k)] if position is None else np.asarray(position)
    name = anchor_site(k)
    if pin.on_body:  # the held point, fixed in the user's body
        spec.body(pin.body).add_site(name=name, pos=pin.offset)
    elif pin.kind == "gripper":
        body = spec.worldbody.add_body(name=gripper_body(k), pos=pos, mocap=True)
        radius = scene.cables[scene.pin_cable(k)].radius
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[2.5 * radius, 0, 0], contype=0,
                      conaffinity=0, density=0.0, material="gripper", group=1)  # visual only: no mass, no contacts
        body.add_site(name=name)
    else:
        spec.worldbody.add_site(name=name, pos=pos)
    return name


def add_clamp_anchor(spec: mujoco.MjSpec, scene: Scene, k: int) -> str:
    """The site ``anchor{k}_clamp`` that holds the clamp neighbour of pin ``k`` at its start position, in the same
    body as ``anchor{k}`` (:func:`add_anchor`: the world, the gripper's mocap body, or the user's body, where it
    keeps the tangent's start direction in that body's frame). Returns its name."""
    pin = scene.pins[k]
    p = scene.particles
    i, j = scene.pin_particle(k), scene.clamp_neighbour(k)
    name = f"{anchor_site(k)}_clamp"
    if pin.on_body:
        _, rot = scene.world.body_pose(pin.body)
        spec.body(pin.body).add_site(name=name, pos=np.asarray(pin.offset) + rot.T @ (p[j] - p[i]))
    elif pin.kind == "gripper":
        spec.body(gripper_body(k)).add_site(name=name, pos=p[j] - p[i])
    else:
        spec.worldbody.add_site(name=name, pos=p[j])
    return name


def add_roll_anchor(spec: mujoco.MjSpec, scene: Scene, k: int, position: np.ndarray) -> str:
    """The site ``anchor{k}_roll`` at the world point ``position`` (a point off the cable's axis beside pin ``k``'s
    particle, held by a third connect so that a clamp of a model with segment bodies also holds the turn about the
    tangent), in the same body as ``anchor{k}`` (:func:`add_anchor`). Returns its name."""
    pin = scene.pins[k]
    p = scene.particles[scene.pin_particle(k)]
    name = f"{anchor_site(k)}_roll"
    if pin.on_body:
        _, rot = scene.world.body_pose(pin.body)
        spec.body(pin.body).add_site(name=name, pos=np.asarray(pin.offset) + rot.T @ (position - p))
    elif pin.kind == "gripper":
        spec.body(gripper_body(k)).add_site(name=name, pos=position - p)
    else:
        spec.worldbody.add_site(name=name, pos=position)
    return name


def pin_solref(timestep: float) -> list:
    """The stiff equalities' ``solref``: a time constant of ``_PIN_SOLREF_STEPS`` physics steps, critically damped."""
    return [_PIN_SOLREF_STEPS * timestep, 1.0]


def add_connect(spec: mujoco.MjSpec, name: str, site1: str, site2: str, *, timestep: float,
                solimp: tuple = PIN_SOLIMP) -> None:
    """A stiff site-to-site ``connect`` equality (independent of qpos0, so models may compile straight)."""
    spec.add_equality(name=name, type=mujoco.mjtEq.mjEQ_CONNECT, objtype=mujoco.mjtObj.mjOBJ_SITE,
                      name1=site1, name2=site2, solref=pin_solref(timestep), solimp=solimp)
