"""The lab world of the ``jaco_unplug`` task: a Kinova Jaco arm and three-finger hand on a bench, facing a wall with a
socket.

Built with :class:`mujoco.MjSpec` only. The arm and hand come from dm_control
(:mod:`dm_control.entities.manipulators.kinova`; imported when a world is built, and only its MJCF models are used,
so the world builds on MuJoCo 4 too, where dm_control's ``Physics`` does not run), exported as MJCF and attached under :data:`ARM_PREFIX`, so every
arm and hand name reads as it would in a dm_control composer arena (``jaco_arm/joint_1``,
``jaco_arm/jaco_hand/finger_1``, ...). Everything else (bench, wall, socket, sites, camera, lights, floor) is added
here with the names below.

Units: metres, radians, seconds, kilograms, newtons. World frame: z up, gravity −9.81 m/s² along −z; the arm's base
axis is the vertical line x = y = 0 and the wall faces it across the bench at x = :data:`WALL_X`.

Actuators. dm_control's ``JacoArm`` adds *velocity* servos (``kv = 500`` N·m·s/rad, ctrl in rad/s, limited to
±36 °/s on joints 1–3 and ±48 °/s on joints 4–6, torques clipped at the datasheet peaks 30.5 and 6.8 N·m);
``JacoHand`` adds velocity servos on the fingers (``kv = 10``, ctrl ±5 rad/s, force ±1). They survive the MJCF round
trip unchanged. A velocity servo only damps: at ``ctrl = 0`` the arm creeps under gravity at τ_g / kv. So
:func:`jaco_lab_spec` by default (``arm_control="position"``) replaces the six arm servos, keeping their names and
torque limits, by *position* servos (ctrl = joint target in rad):

* ``kp`` = :data:`KP_LARGE` on joints 1–3 and :data:`KP_SMALL` on joints 4–6 (N·m/rad): the heaviest gravity
  load at home, about 5 N·m on joint 2, then costs under 3 mrad of droop, about 1 mm at the grip;
* ``kv`` set by MuJoCo for critical damping (``dampratio = 1``) from each joint's inertia (armature included) at
  ``qpos0``;
* ctrl limited to the joint range on the limited joints 2 and 3; joints 1, 4, 5, 6 are unlimited, so are their
  targets.

``arm_control="velocity"`` keeps dm_control's velocity servos (at home with ``ctrl = 0`` the grip creeps about 6 mm
in 2 s, and on). The finger servos are dm_control's in both modes.

dm_control's attachment frame of the hand becomes a jointless body named ``jaco_arm/jaco_hand/`` between ``b_6`` and
:data:`GRIP_BODY`; its torque sensors (``jaco_arm/joint_k_torque``) and reference sites (``jaco_arm/jaco_hand/
gripsite``, ``pinchsite``, group 4) are kept.

Options: timestep 0.002 s, gravity (0, 0, −9.81), and the arm's own flag (``nativeccd`` disabled); everything else
is MuJoCo's default.

The keyframe :data:`HOME_KEY` holds the arm at :func:`home_qpos` (fingers half closed) with ctrl at those targets
(or zero velocity). Cable builders may append bodies and joints after the arm: MuJoCo pads a short keyframe with
``qpos0`` for them.
"""

from __future__ import annotations

from typing import Union

import mujoco
import numpy as np

__all__ = [
    "ARM_PREFIX",
    "HAND_PREFIX",
    "ARM_JOINTS",
    "ARM_ACTUATORS",
    "FINGER_JOINTS",
    "FINGER_ACTUATORS",
    "GRIP_BODY",
    "GRIP_SITE",
    "GRIP_OFFSET",
    "SOCKET_BODY",
    "SOCKET_SITE",
    "TARGET_SITE",
    "CAMERA",
    "HOME_KEY",
    "GRAVITY",
    "TARGET_RADIUS",
    "KP_LARGE",
    "KP_SMALL",
    "TIMESTEP",
    "TABLE_TOP_Z",
    "WALL_X",
    "ARM_BASE_POS",
    "SOCKET_POS",
    "TARGET_POS",
    "ARM_CONTROLS",
    "jaco_lab_spec",
    "home_qpos",
    "home_finger_qpos",
    "grip_and_socket",
]

# --- names -----------------------------------------------------------------------------------------------------------

ARM_PREFIX = "jaco_arm/"
"""Prefix of every element that comes from dm_control's arm (the arm's composer name, as in a dm_control arena)."""
HAND_PREFIX = ARM_PREFIX + "jaco_hand/"
"""Prefix of every element of dm_control's hand (dm_control prefixes attached entities by their model name)."""

ARM_JOINTS = tuple(f"{ARM_PREFIX}joint_{k}" for k in range(1, 7))
"""The six arm hinges, base to wrist. 2 and 3 are limited (0.820–5.463 and 0.332–5.952 rad); 1, 4, 5, 6 are not."""
ARM_ACTUATORS = ARM_JOINTS
"""Arm actuators, one per joint and named like it (position targets in rad, or velocities in rad/s)."""
FINGER_JOINTS = tuple(f"{HAND_PREFIX}finger_{k}" for k in range(1, 4))
"""The three finger hinges (0.15 rad open to 1.35 rad closed)."""
FINGER_ACTUATORS = FINGER_JOINTS
"""dm_control's finger velocity servos (rad/s), named like their joints."""

GRIP_BODY = HAND_PREFIX + "hand"
"""The hand (palm) body: the grip site and a cable pin live in its frame."""
GRIP_SITE = "grip"
"""Site on :data:`GRIP_BODY` between the distal phalanges of the closed fingers: where the hand holds the cable."""
GRIP_OFFSET = (0.0, 0.0, -0.170)
"""Position of :data:`GRIP_SITE` in the :data:`GRIP_BODY` frame (m). The fingers point along the palm's −z; closed
(1.35 rad) the centroids of the distal phalanx meshes sit at z ≈ −0.170 m, finger 1 at y ≈ +0.016 m and fingers 2,
3 at y ≈ −0.011 m, x = ±0.019 m. dm_control's ``gripsite`` (z = −0.159) is nearer the palm, its ``pinchsite``
(z = −0.193) beyond the fingertips."""
SOCKET_BODY = "socket"
"""Static body of the wall socket (faceplate and recess), fixed to the wall."""
SOCKET_SITE = "socket_plug"
"""Site at the centre of the socket opening, on the faceplate's front face; its z axis points out of the wall."""
TARGET_SITE = "target"
"""Translucent green sphere (group 0) on the bench: where the plug must be carried."""
CAMERA = "overview"
"""Fixed camera that sees the arm, the socket and the space between them."""
HOME_KEY = "home"
"""Keyframe with the arm at :func:`home_qpos` and the actuators holding it."""

ARM_CONTROLS = ("position", "velocity")
"""Accepted values of ``arm_control`` in :func:`jaco_lab_spec`."""

# --- physics ---------------------------------------------------------------------------------------------------------

TIMESTEP = 0.002
"""MuJoCo timestep (s)."""
GRAVITY = (0.0, 0.0, -9.81)
"""Gravity (m/s²)."""
KP_LARGE = 2000.0
"""Position gain of joints 1–3 (N·m/rad)."""
KP_SMALL = 500.0
"""Position gain of joints 4–6 (N·m/rad)."""
_LARGE_TORQUE = 30.5  # N·m, dm_control's (Kinova datasheet) peak torque of joints 1-3
_SMALL_TORQUE = 6.8  # N·m, joints 4-6

# --- layout (m) ------------------------------------------------------------------------------------------------------

TABLE_TOP_Z = 0.45
"""Height of the bench top; the arm's base stands on it."""
ARM_BASE_POS = (0.0, 0.0, TABLE_TOP_Z)
"""World position of the arm's base frame (the bottom of the base)."""
WALL_X = 0.60
"""x of the wall's face (the wall fills x > WALL_X)."""
_SOCKET_PROUD = 0.012  # how far the faceplate stands out of the wall
SOCKET_POS = (WALL_X, -0.25, TABLE_TOP_Z + 0.30)
"""World position of the socket body's origin (on the wall face, at the centre of the faceplate)."""
TARGET_POS = (0.30, 0.35, TABLE_TOP_Z + 0.15)
"""World position of :data:`TARGET_SITE`."""
TARGET_RADIUS = 0.03
"""Radius of the target sphere (m)."""

_TABLE_X = (-0.35, WALL_X)  # the bench runs from behind the arm to the wall
_TABLE_Y = (-0.60, 0.60)
_TABLE_THICKNESS = 0.04
_WALL_THICKNESS = 0.10
_WALL_HEIGHT = 1.60
_WALL_HALF_WIDTH = 1.20

_CAMERA_EYE = (-0.45, -1.25, 1.38)
_CAMERA_LOOKAT = (0.28, -0.06, TABLE_TOP_Z + 0.33)
_CAMERA_FOVY = 50.0  # degrees

# --- home pose (rad) -------------------------------------------------------------------------------------------------

# Found by least squares (scipy) on the forward kinematics of this world: grip site at (0.35, 0.00, TABLE_TOP_Z + 0.30)
# m with the fingers pointing straight down, from an elbow-up seed, rounded to 1e-4 rad. Touches nothing.
_HOME_ARM = (2.97, 3.3847, 1.3226, -0.3527, 1.2704, 0.0)
_HOME_FINGERS = 0.75  # rad: fingers half closed, each of the three


def home_qpos() -> np.ndarray:
    """Arm joint angles at home (rad), in :data:`ARM_JOINTS` order: the grip site at (0.35, 0, TABLE_TOP_Z + 0.30) m
    with the fingers pointing straight down, level with the socket and 0.345 m from its opening (see
    :func:`grip_and_socket`), elbow up."""
    return np.array(_HOME_ARM, dtype=float)


def home_finger_qpos() -> np.ndarray:
    """Finger joint angles at home (rad), in :data:`FINGER_JOINTS` order (half closed)."""
    return np.full(len(FINGER_JOINTS), _HOME_FINGERS)


def _arm_spec() -> mujoco.MjSpec:
    """dm_control's Jaco arm with the hand attached at the wrist, as a fresh :class:`mujoco.MjSpec` (velocity servos,
    torque sensors, meshes in ``spec.assets``)."""
    try:
        from dm_control.entities.manipulators import kinova  # heavy import, only when a world is built
    except ImportError as error:
        raise ImportError(f"the Jaco world takes its arm and hand from dm_control's Kinova models, and dm_control "
                          f"cannot be imported ({error}); install it with python -m pip install dm-control (the "
                          f"world needs only its MJCF models, which load on MuJoCo 3.17 to 4.x; the environments "
                          f"of mjcable.envs need pip install \"mjcable[envs]\")") from error

    arm = kinova.JacoArm()
    arm.attach(kinova.JacoHand())
    assets = arm.mjcf_model.get_assets()
    return mujoco.MjSpec.from_string(arm.mjcf_model.to_xml_string(), assets=assets)


def _to_position_servos(spec: mujoco.MjSpec) -> None:
    """Turn the six arm velocity servos of the attached arm into position servos (see the module docstring)."""
    for k, name in enumerate(ARM_ACTUATORS):
        act = spec.actuator(name)
        joint = spec.joint(name)
        act.set_to_position(kp=KP_LARGE if k < 3 else KP_SMALL, dampratio=1.0)
        torque = _LARGE_TORQUE if k < 3 else _SMALL_TORQUE
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = [-torque, torque]
        if joint.limited == mujoco.mjtLimited.mjLIMITED_TRUE:
            act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
            act.ctrlrange = list(joint.range)
        else:
            act.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
            act.ctrlrange = [0.0, 0.0]


def _look_at_quat(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Quaternion (w, x, y, z) of a MuJoCo camera at ``eye`` looking at ``target`` (m, world frame); a camera looks
    along its −z with its y up."""
    z = np.asarray(eye, float) - np.asarray(target, float)
    z /= np.linalg.norm(z)
    x = np.cross(up, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.column_stack([x, y, z]).ravel())
    return quat


def _add_scene(spec: mujoco.MjSpec) -> None:
    """Floor, bench, wall, socket, target, lights and camera (everything but the arm)."""
    spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX, builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
                     rgb1=[0.55, 0.62, 0.70], rgb2=[0.12, 0.13, 0.15], width=256, height=1536)
    spec.add_texture(name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
                     rgb1=[0.32, 0.34, 0.38], rgb2=[0.26, 0.28, 0.31], width=512, height=512)
    floor_mat = spec.add_material(name="floor", texrepeat=[8, 8], reflectance=0.05)
    floor_mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "grid"
    spec.add_material(name="bench", rgba=[0.62, 0.48, 0.33, 1.0])
    spec.add_material(name="wall", rgba=[0.86, 0.85, 0.80, 1.0])
    spec.add_material(name="socket", rgba=[0.96, 0.96, 0.94, 1.0])
    spec.add_material(name="socket_hole", rgba=[0.05, 0.05, 0.05, 1.0])

    world = spec.worldbody
    world.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[3.0, 3.0, 0.1], material="floor")

    table = world.add_body(name="table")
    half = [(_TABLE_X[1] - _TABLE_X[0]) / 2, (_TABLE_Y[1] - _TABLE_Y[0]) / 2, _TABLE_THICKNESS / 2]
    centre = [(_TABLE_X[0] + _TABLE_X[1]) / 2, (_TABLE_Y[0] + _TABLE_Y[1]) / 2, TABLE_TOP_Z - half[2]]
    table.add_geom(name="table_top", type=mujoco.mjtGeom.mjGEOM_BOX, size=half, pos=centre, material="bench")
    leg_h = (TABLE_TOP_Z - _TABLE_THICKNESS) / 2
    for i, (sx, sy) in enumerate([(-1, -1), (-1, 1), (1, -1), (1, 1)]):
        pos = [centre[0] + sx * (half[0] - 0.04), centre[1] + sy * (half[1] - 0.04), leg_h]
        table.add_geom(name=f"table_leg_{i}", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.025, 0.025, leg_h], pos=pos,
                       material="bench")

    wall = world.add_body(name="wall")
    wall.add_geom(name="wall", type=mujoco.mjtGeom.mjGEOM_BOX,
                  size=[_WALL_THICKNESS / 2, _WALL_HALF_WIDTH, _WALL_HEIGHT / 2],
                  pos=[WALL_X + _WALL_THICKNESS / 2, 0.0, _WALL_HEIGHT / 2], material="wall")

    # The socket: a faceplate standing _SOCKET_PROUD out of the wall, with a dark (visual only) recess on its face.
    socket = world.add_body(name=SOCKET_BODY, pos=list(SOCKET_POS))
    socket.add_geom(name="socket_plate", type=mujoco.mjtGeom.mjGEOM_BOX, size=[_SOCKET_PROUD / 2, 0.04, 0.04],
                    pos=[-_SOCKET_PROUD / 2, 0.0, 0.0], material="socket")
    out_of_wall = [np.sqrt(0.5), 0.0, -np.sqrt(0.5), 0.0]  # rotates +z onto −x, out of the wall
    socket.add_geom(name="socket_hole", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.014, 0.0008],
                    pos=[-_SOCKET_PROUD - 0.0008, 0.0, 0.0], quat=out_of_wall, material="socket_hole",
                    contype=0, conaffinity=0, group=1)
    socket.add_site(name=SOCKET_SITE, pos=[-_SOCKET_PROUD, 0.0, 0.0], quat=out_of_wall, size=[0.006, 0, 0],
                    rgba=[0.9, 0.2, 0.1, 1.0], group=4)

    world.add_site(name=TARGET_SITE, type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=list(TARGET_POS),
                   size=[TARGET_RADIUS, 0, 0], rgba=[0.1, 0.85, 0.2, 0.4], group=0)

    world.add_light(name="sun", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, pos=[0.0, 0.0, 3.0],
                    dir=[0.3, 0.4, -1.0], castshadow=True, diffuse=[0.6, 0.6, 0.6], specular=[0.2, 0.2, 0.2])
    world.add_light(name="lamp", pos=[-0.4, -0.6, 2.0], dir=[0.5, 0.5, -1.2], castshadow=False,
                    diffuse=[0.4, 0.4, 0.4], specular=[0.1, 0.1, 0.1])

    world.add_camera(name=CAMERA, pos=list(_CAMERA_EYE), quat=list(_look_at_quat(_CAMERA_EYE, _CAMERA_LOOKAT)),
                     fovy=_CAMERA_FOVY)


def jaco_lab_spec(arm_control: str = "position") -> mujoco.MjSpec:
    """A fresh spec of the lab: floor, bench, the Jaco arm and hand on it, the wall and its socket, the target site,
    lights, the :data:`CAMERA` camera and the :data:`HOME_KEY` keyframe.

    ``arm_control`` is ``"position"`` (default: arm ctrl = joint targets in rad, gains :data:`KP_LARGE`,
    :data:`KP_SMALL`, critically damped) or ``"velocity"`` (dm_control's servos: arm ctrl = joint velocities in
    rad/s). Each call builds a new, independent spec.
    """
    if arm_control not in ARM_CONTROLS:
        raise ValueError(f"arm_control must be one of {ARM_CONTROLS}, got {arm_control!r}")
    arm = _arm_spec()
    spec = mujoco.MjSpec()
    spec.modelname = "jaco_lab"
    spec.compiler.degree = False
    spec.option.timestep = TIMESTEP
    spec.option.gravity = list(GRAVITY)
    spec.option.disableflags |= arm.option.disableflags  # the arm's own flag: nativeccd off
    spec.visual.global_.offwidth = 1280
    spec.visual.global_.offheight = 960
    spec.assets = dict(arm.assets)  # the meshes: attach does not carry the child's in-memory files
    _add_scene(spec)

    mount = spec.worldbody.add_frame(name="arm_mount", pos=list(ARM_BASE_POS))
    spec.attach(arm, prefix=ARM_PREFIX, frame=mount)
    spec.body(GRIP_BODY).add_site(name=GRIP_SITE, pos=list(GRIP_OFFSET), size=[0.008, 0, 0],
                                  rgba=[0.1, 0.4, 1.0, 1.0], group=4)
    if arm_control == "position":
        _to_position_servos(spec)

    arm_ctrl = home_qpos() if arm_control == "position" else np.zeros(len(ARM_JOINTS))
    spec.add_key(name=HOME_KEY, qpos=list(home_qpos()) + list(home_finger_qpos()),
                 ctrl=list(arm_ctrl) + [0.0] * len(FINGER_ACTUATORS))
    return spec


def grip_and_socket(spec_or_model: Union[mujoco.MjSpec, mujoco.MjModel]) -> tuple[np.ndarray, np.ndarray]:
    """World positions (m) of :data:`GRIP_SITE` and :data:`SOCKET_SITE` at the :data:`HOME_KEY` keyframe: compiles
    a spec (without changing it), resets to the keyframe and runs ``mj_forward``. The cable is laid out between
    them."""
    model = spec_or_model.compile() if isinstance(spec_or_model, mujoco.MjSpec) else spec_or_model
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key(HOME_KEY).id)
    mujoco.mj_forward(model, data)
    return data.site(GRIP_SITE).xpos.copy(), data.site(SOCKET_SITE).xpos.copy()
