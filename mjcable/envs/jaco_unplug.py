"""``jaco_unplug``: a Kinova Jaco arm pulls a cable's plug out of a wall socket and carries it to a target.

The world is :func:`mjcable.worlds.jaco.jaco_lab_spec` (arm and three-finger hand on a bench, a wall with a socket,
the ``overview`` camera, start keyframe ``home``). The hand holds the cable's first particle at the grip site (a
two-way body pin: the arm feels the cable); the last particle is the plug, held by a socket pin that lets go for
good once the pull on it exceeds :data:`RELEASE_FORCE` newtons. The plug starts :data:`PLUG_STANDOFF` metres plus
one cable radius out of the socket's faceplate along the ``socket_plug`` site's z axis (out of the wall), so the
cable does not touch the plate at the start. The cable: :data:`SEGMENTS` segments, radius :data:`CABLE_RADIUS`,
mass :data:`CABLE_MASS`, damping rate :data:`CABLE_DAMPING`, limp, laid from the grip through a point
:data:`START_SAG` below the midpoint to the plug.

Units: metres, radians, seconds, kilograms, newtons.

Action: ``(6,)`` float64, the arm's joint position targets as offsets from the home pose in radians,
``ctrl = home_qpos() + action`` for the six position servos of :data:`mjcable.worlds.jaco.ARM_ACTUATORS`, bounded
to ``[-ACTION_RANGE, ACTION_RANGE]`` per joint. The offsets are absolute (not accumulated): a zero action holds the
home pose. The fingers keep their home angles (their velocity servos at zero speed).

Observation (ordered, float64): ``centreline`` (n+1, 3) m and ``centreline_velocity`` (n+1, 3) m/s of the cable
(particle 0 at the grip, particle n the plug), ``arm_qpos`` (6,) rad and ``arm_qvel`` (6,) rad/s of the arm joints,
``grip`` (3,) m the grip site, ``plug`` (3,) m the last particle, ``socket`` (3,) m the plug's start (where the
socket holds it), ``released`` (1,) 1.0 once the plug is out, ``target`` (3,) m.

Reward in [0, 1]: ``0.5 * released + 0.5 * tolerance(|plug - target|, bounds=(0, TARGET_RADIUS), margin=0.3)``,
dm_control's ``rewards.tolerance`` (Gaussian, 0.1 at the margin; :func:`mjcable.envs.base.tolerance`). The target
is drawn uniformly from :data:`TARGET_BOX` each episode (the world's green ``target`` site is moved there).
A scripted solution, :func:`retreat_action`: the shoulder and elbow targets ramp linearly over :data:`RETREAT_RAMP`
seconds to :data:`RETREAT`, which draws the grip about 0.24 m back from the wall along −x; the cable is then longer
than its slack path, so the pull exceeds :data:`RELEASE_FORCE` and the plug comes out (on every model).

Episodes last :data:`TIME_LIMIT` seconds; the control step is 0.02 s (10 Simulator steps of the default ``dt`` =
:data:`DT` = 0.002 s; with the undamped cable, at 0.004 s the ``joints`` model diverged within seconds under random
arm actions).

Why the cable is damped (:data:`CABLE_DAMPING` = 1/s; the built-in scenes use 0.2/s). Undamped, it diverged under
a random policy (uniform arm targets, each held 0.2 s, 1000 control steps from seed ``random=7``, action seeds 0 to
30). Once the plug is out, the arm (grip up to about 2 m/s, reversing within tenths of a second) keeps feeding
energy into a limp cable with a free end, and nothing drains it: its speeds climb over seconds from about 5 m/s to
10 to 30 m/s, it whips round the hand and strikes the fingers, and the integrator fails. ``joints`` diverged on 5
of 31 action seeds, a ball joint near the hand spinning at over 100 rad/s (``composite`` at the very same steps on
the 3 of them tried); ``springs`` on 3 of 3 seeds tried, its stretch vibrations growing until its hand pin pulled 20
to 60 N on the 0.05 kg cable. At 0.2/s ``springs`` still diverged (2 of 2 seeds). At 1/s no model diverged on any
seed tried: ``joints`` 31 of 31, ``springs``, ``composite``, ``flexrod`` and ``xpbd`` 2 of 2, ``pbd`` and
``jakobsen`` 1 of 1 (``tests/test_jaco_unplug.py`` runs most of them). The damping acts on velocities only (zero at
rest), so the resting pull is unchanged, and at the retreat's 0.24 m/s its drag is about 0.01 N. On ``joints`` and
``composite`` it is MuJoCo's medium viscosity (0.017 Pa·s here), which drags the arm's links too: about 0.03 N on a
link 0.1 m across at 2 m/s, against servos of up to 30 N·m. (A ``joints`` step of 1 ms, or twice its whip damping,
also kept the undamped ``joints`` finite on its failing seeds, 31 of 31 at 1 ms; but ``springs`` already steps
MuJoCo every 0.2 ms (10 substeps) and still diverged, and a real cable's internal friction does damp it.)
"""

from __future__ import annotations

import collections
import math

import mujoco
import numpy as np
from dm_env import specs

from mjcable.envs import base
from mjcable.envs.workspace import Workspace
from mjcable.scene import CableSpec, Pin, Scene
from mjcable.worlds import jaco

__all__ = ["Physics", "JacoUnplug", "ACTION_RANGE", "RELEASE_FORCE", "TARGET_BOX", "TARGET_RADIUS", "TIME_LIMIT",
           "SEGMENTS", "CABLE_RADIUS", "CABLE_MASS", "CABLE_DAMPING", "PLUG_STANDOFF", "START_SAG", "DT", "RETREAT",
           "RETREAT_RAMP", "make_scene", "retreat_action"]

ACTION_RANGE = 0.6  # rad: each joint target within home ± this
RELEASE_FORCE = 5.0  # N: the socket lets go above this pull (the resting cable pulls about 0.3 N)
TIME_LIMIT = 10.0  # s
SEGMENTS = 25
CABLE_RADIUS = 0.004  # m
CABLE_MASS = 0.05  # kg
CABLE_DAMPING = 1.0  # 1/s: the cable's velocity damping rate (see the module docstring)
PLUG_STANDOFF = 0.001  # m between the faceplate and the cable's surface at the plug
START_SAG = 0.15  # m the start curve's middle point lies below the grip-plug midpoint
DT = 0.002  # s, the Simulator step the environments use by default (base.load)
TARGET_RADIUS = 0.03  # m: full reward with the plug this close to the target (the target sphere's radius)
_TARGET_MARGIN = 0.3  # m: the distance reward falls to 0.1 this far outside TARGET_RADIUS
TARGET_BOX = ((0.20, 0.25, jaco.TABLE_TOP_Z + 0.05), (0.40, 0.45, jaco.TABLE_TOP_Z + 0.20))  # m
# Joint target offsets (rad) that draw the grip about 0.24 m back from the wall along -x (joints 2 and 3, the shoulder
# and the elbow; from the grip site's Jacobian at home); read-only
RETREAT = np.array([0.0, -0.6, -0.6, 0.0, 0.0, 0.0])
RETREAT.setflags(write=False)
RETREAT_RAMP = 1.0  # s over which retreat_action reaches RETREAT
_SPACE = ((-2.0, -2.0, -1.0), (2.0, 2.0, 3.0))  # m: a nominal workspace (this task has no gripper to clamp)
_HAND, _PLUG = 0, 1  # pin indices


def make_scene() -> Scene:
    """The task's scene: the lab world with the cable from the hand's grip to the socket (see the module docstring)."""
    world = jaco.jaco_lab_spec()
    model = world.compile()
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key(jaco.HOME_KEY).id)
    mujoco.mj_kinematics(model, data)
    grip = data.site(jaco.GRIP_SITE).xpos.copy()
    site = data.site(jaco.SOCKET_SITE)
    out = site.xmat.reshape(3, 3)[:, 2]  # the site's z axis: out of the wall
    plug = site.xpos + (CABLE_RADIUS + PLUG_STANDOFF) * out
    middle = (grip + plug) / 2 - [0.0, 0.0, START_SAG]
    cable = CableSpec([grip, middle, plug], SEGMENTS, CABLE_RADIUS, CABLE_MASS, damping=CABLE_DAMPING)
    pins = (Pin(0, "body", body=jaco.GRIP_BODY, offset=jaco.GRIP_OFFSET),
            Pin(-1, "socket", release_force=RELEASE_FORCE))
    return Scene(cable, pins, world=world, keyframe=jaco.HOME_KEY)


def retreat_action(time: float) -> np.ndarray:
    """The scripted unplugging policy: the action ``(6,)`` rad for a control step that ends at episode time ``time``
    (s), ``RETREAT * clip(time / RETREAT_RAMP, 0, 1)``: the targets ramp linearly to :data:`RETREAT` over
    :data:`RETREAT_RAMP` seconds and stay there, at any control step."""
    return RETREAT * min(1.0, max(0.0, float(time) / RETREAT_RAMP))


class Physics(base.CablePhysics):
    """Adds read-outs of the arm, the grip, the plug and the socket."""

    def _attach(self, simulator) -> None:
        super()._attach(simulator)
        m = simulator.mj_model
        self._qpos_adr = np.array([m.joint(j).qposadr[0] for j in jaco.ARM_JOINTS])
        self._dof_adr = np.array([m.joint(j).dofadr[0] for j in jaco.ARM_JOINTS])
        self._ctrl_adr = np.array([m.actuator(a).id for a in jaco.ARM_ACTUATORS])
        self._grip_site = m.site(jaco.GRIP_SITE).id
        self._target_site = m.site(jaco.TARGET_SITE).id

    def set_arm_targets(self, targets: np.ndarray) -> None:
        """Set the six arm position servos' targets (rad)."""
        self.simulator.mj_data.ctrl[self._ctrl_adr] = targets

    def arm_targets(self) -> np.ndarray:
        """(6,) the arm servos' current targets, rad."""
        return self.simulator.mj_data.ctrl[self._ctrl_adr].copy()

    def arm_qpos(self) -> np.ndarray:
        """(6,) arm joint angles, rad."""
        return self.simulator.mj_data.qpos[self._qpos_adr].copy()

    def arm_qvel(self) -> np.ndarray:
        """(6,) arm joint velocities, rad/s."""
        return self.simulator.mj_data.qvel[self._dof_adr].copy()

    def grip(self) -> np.ndarray:
        """(3,) the grip site (where the hand holds the cable), metres."""
        return self.simulator.mj_data.site_xpos[self._grip_site].copy()

    def plug(self) -> np.ndarray:
        """(3,) the plug (the cable's last particle), metres."""
        return self.centreline()[-1]

    def socket(self) -> np.ndarray:
        """(3,) where the socket holds the plug (the plug's start particle), metres."""
        return self.anchors()[_PLUG]

    def released(self) -> bool:
        return _PLUG in self.simulator.released

    def place_target(self, target: np.ndarray) -> None:
        """Move the world's ``target`` site (a child of the world body) to ``target`` (3,) metres."""
        self.simulator.mj_model.site_pos[self._target_site] = target
        self.simulator.mj_data.site_xpos[self._target_site] = target


@base.register(TIME_LIMIT, "arm")
class JacoUnplug(base.CableTask):
    """A Jaco arm holding one end of a cable pulls its plug out of a wall socket and carries it to a target."""

    name = "jaco_unplug"
    physics_class = Physics
    controlled = ()

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self._scene = None
        self._home = jaco.home_qpos()
        self._target = np.mean(TARGET_BOX, axis=0)  # until the first episode draws one
        self._action_spec = specs.BoundedArray((len(jaco.ARM_JOINTS),), np.float64, -ACTION_RANGE, ACTION_RANGE,
                                               name="arm_joint_target_offset")

    def make_scene(self) -> Scene:
        if self._scene is None:  # the same scene every episode: the Simulator is reset, not rebuilt
            self._scene = make_scene()
        return self._scene

    def make_workspace(self, scene: Scene) -> Workspace:
        return Workspace(scene, *_SPACE, clearance=0.01)

    def sample_episode(self, physics: Physics) -> None:
        self._target = self.random.uniform(*TARGET_BOX)
        physics.place_target(self._target)

    def action_spec(self, physics: Physics) -> specs.BoundedArray:
        """Arm joint targets as offsets from home, rad: ``(6,)`` in ``[-ACTION_RANGE, ACTION_RANGE]``."""
        return self._action_spec

    def before_step(self, action, physics: Physics) -> None:
        a = base.checked_action(action, self._action_spec, ACTION_RANGE, unit="rad",
                           what=f"joint target offsets from home in rad of {jaco.ARM_JOINTS}")
        physics.set_arm_targets(self._home + a)

    def get_observation(self, physics: Physics) -> collections.OrderedDict:
        obs = collections.OrderedDict()
        obs["centreline"] = physics.centreline()
        obs["centreline_velocity"] = physics.centreline_velocity()
        obs["arm_qpos"] = physics.arm_qpos()
        obs["arm_qvel"] = physics.arm_qvel()
        obs["grip"] = physics.grip()
        obs["plug"] = physics.plug()
        obs["socket"] = physics.socket()
        obs["released"] = np.array([float(physics.released())])
        obs["target"] = self._target.copy()
        return obs

    def get_reward(self, physics: Physics) -> float:
        distance = math.dist(physics.plug(), self._target)
        near = base.tolerance(distance, 0.0, TARGET_RADIUS, _TARGET_MARGIN)
        return 0.5 * float(physics.released()) + 0.5 * near
