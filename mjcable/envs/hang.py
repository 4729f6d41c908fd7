"""``hang``: pick a cable up from the middle of a table and hang it on a hook.

A straight cable (:data:`LENGTH` metres, stiff enough to bend in a wide arc) lies along x on a table; a hook (a
horizontal capsule along y, :data:`HOOK_HEIGHT` metres above the table's top) stands over the table's far half. One
free gripper (``Scene(grippers=...)``, :class:`mjcable.Gripper`) starts above the table holding nothing. Each
episode draws the cable's place on the table and the hook's x from ``self.random``.

Actions: ``(4,)``, the gripper's displacement over the control step (metres, within ±``MAX_GRIPPER_SPEED`` times the
control timestep per axis) and a grip command in [-1, 1]: above 0 the gripper closes, grasping the cable's particle
nearest to it if that one lies within :data:`GRASP_REACH` (:meth:`mjcable.Simulator.grasp`; farther, it closes on
nothing and stays open), at or below 0 it opens and lets go (:meth:`mjcable.Simulator.release`). The grip acts
before the step's motion.

A gripper that lifts the cable by its middle carries it as an arch whose two halves hang apart (the cable's bending
stiffness holds them apart, about its bending length (E·I / w)^(1/3) each side), lowers the arch over the hook so
that the hook passes between the halves, and lets go: the cable then hangs on the hook with one half on each side.

Reward: ``rest × (sides + hang + off) / 3``, halved while the gripper holds the cable, each term a shaped
:func:`mjcable.envs.base.tolerance`: ``rest``, the cable's highest point rests on the hook's top; ``sides``, its
two halves hang on opposite sides of the hook's axis; ``hang``, both ends hang at least :data:`HANG_DROP` below the
hook's top; ``off``, the whole cable is at least :data:`TABLE_GAP` clear of the table. A cable hanging on the hook,
let go, earns 1.
"""

from __future__ import annotations

import math

import numpy as np
from dm_env import specs

from mjcable.envs import base
from mjcable.envs.drape import peg_measures
from mjcable.envs.workspace import Workspace
from mjcable.joins import Gripper
from mjcable.scene import Box, CableSpec, Capsule, Floor, Scene

__all__ = ["Physics", "Hang", "TABLE_TOP", "LENGTH", "SEGMENTS", "RADIUS", "HOOK_RADIUS", "HOOK_HEIGHT", "HOOK_X",
           "CABLE_X", "CABLE_Y", "GRIPPER_START", "GRASP_REACH", "HANG_DROP", "TABLE_GAP", "HELD_SHARE",
           "TIME_LIMIT"]

TABLE_TOP = 0.75  # m, height of the table's top
LENGTH = 0.6  # m
SEGMENTS = 30  # 20 mm segments; the middle particle is SEGMENTS // 2
RADIUS = 0.005  # m
MASS = 0.18  # kg: 0.3 kg/m
YOUNG = 5e6  # Pa: E·I = 2.5e-3 N·m², a bending length (E·I / w)^(1/3) of 9 cm: the lifted halves hang ~20 cm apart
DAMPING = 2.0  # 1/s
FRICTION = 0.5  # Coulomb μ of the cable
HOOK_RADIUS = 0.012  # m
HOOK_HALF_LENGTH = 0.12  # m, along y
HOOK_HEIGHT = 0.45  # m, the hook's axis above the table's top: the cable's 0.3 m halves hang clear of the table
HOOK_X = (0.15, 0.3)  # m, the hook's x (uniform); its y is 0
CABLE_X = (-0.2, -0.05)  # m, the cable's middle x (uniform): it lies along x, its ends on the table
CABLE_Y = (-0.15, 0.15)  # m, the cable's y (uniform)
GRIPPER_START = (0.0, 0.0, TABLE_TOP + 0.2)  # m
GRASP_REACH = 0.02  # m: a closing gripper grasps the nearest particle if its centre lies this close
HANG_DROP = 0.15  # m: full hang reward once both ends hang this far below the hook's top
TABLE_GAP = 0.02  # m: full off-table reward once the cable's lowest surface point is this far above the table
HELD_SHARE = 0.5  # the reward's factor while the gripper holds the cable
TIME_LIMIT = 12.0  # s: the scripted lift, carry, wait for the cable to come to rest, lower and let go takes 8-10 s
_TABLE_HALF = (0.6, 0.4, 0.02)  # m
_WORKSPACE = ((-0.6, -0.4, 0.3), (0.6, 0.4, 1.7))  # m, the allowed box of the gripper
_CLEARANCE = RADIUS  # m the gripper keeps from the table and the hook: it may sit on a particle lying on the table
_REST_TOLERANCE = 0.01  # m: full rest reward with the cable's highest point this close to resting on the hook
_REST_MARGIN = 0.3  # m
_SIDE_MARGIN = 0.03  # m: a half this far on the wrong side of the hook's axis earns a tenth of the side reward
_HANG_MARGIN = 0.2  # m
_TABLE_MARGIN = 0.05  # m
_GRIP_BOUND = 1.0  # the grip command's range: [-1, 1]
_GRIPPER = 0  # the free gripper (scene.grippers[0]); the scene has no pins, so it is moved as gripper 0 too


class Physics(base.CablePhysics):
    """Adds read-outs of the hook, the cable's ends, its lowest point and the gripper's grasp, and the grip."""

    def hook(self) -> Capsule:
        return next(ob for ob in self.scene.obstacles if isinstance(ob, Capsule))

    def hook_top(self) -> np.ndarray:
        """(3,) the highest point of the hook's middle, metres."""
        hook = self.hook()
        return np.array([hook.pos[0], hook.pos[1], hook.pos[2] + hook.radius])

    def holding(self) -> bool:
        """Whether the gripper holds the cable."""
        return self.simulator.grasped[_GRIPPER] is not None

    def grip(self, close: bool) -> None:
        """Close the gripper (grasping the nearest particle if its centre lies within :data:`GRASP_REACH`, else
        nothing) or open it (letting go of what it holds); a gripper already so stays as it is."""
        sim = self.simulator
        if close and not self.holding():
            gripper = sim.gripper_positions[len(self.scene.gripper_pins) + _GRIPPER]
            if np.min(np.sum((sim.positions - gripper) ** 2, axis=1)) <= GRASP_REACH**2:
                sim.grasp(_GRIPPER)
        elif not close and self.holding():
            sim.release(_GRIPPER)

    def measures(self) -> tuple:
        """``(rest_gap, leg_positions, ends, lowest)`` of one read of the centreline: metres, (2,) metres (the mean x
        of each half's particles below the hook's top, or its end's x), (2, 3) metres, and the height in metres of
        the cable's lowest particle (:func:`mjcable.envs.drape.peg_measures` for the first two)."""
        x = self.centreline()
        top = self.hook_top()
        gap, legs = peg_measures(x, top[0], top[2], self.scene.cable.radius)
        return gap, legs, x[[0, -1]], float(np.min(x[:, 2]))


@base.register(TIME_LIMIT, "benchmarking")
class Hang(base.CableTask):
    """Pick the cable up from the table with the free gripper and hang it on the hook, both halves down."""

    name = "hang"
    physics_class = Physics
    controlled = (_GRIPPER,)

    def __init__(self, *, random=None, control_timestep: float = base.DEFAULT_CONTROL_TIMESTEP):
        super().__init__(random=random, control_timestep=control_timestep)
        self._bounds = np.array([self._max_step] * 3 + [_GRIP_BOUND])
        self._bounds.setflags(write=False)
        self._action_spec = specs.BoundedArray((4,), np.float64, -self._bounds, self._bounds,
                                               name="gripper_displacement_and_grip")
        self._action_words = dict(
            what="x, y, z displacement in metres of the free gripper, then its grip command (> 0 closes)",
            per=f" (gripper speed <= {base.MAX_GRIPPER_SPEED:g} m/s; grip in [-1, 1])")

    def make_scene(self) -> Scene:
        x = self.random.uniform(*CABLE_X)
        y = self.random.uniform(*CABLE_Y)
        hook_x = self.random.uniform(*HOOK_X)
        z = TABLE_TOP + RADIUS  # lying on the table
        cable = CableSpec([[x - 0.5 * LENGTH, y, z], [x + 0.5 * LENGTH, y, z]], SEGMENTS, RADIUS, MASS,
                          friction=FRICTION, damping=DAMPING, young=YOUNG)
        table = Box(size=_TABLE_HALF, pos=(0.0, 0.0, TABLE_TOP - _TABLE_HALF[2]))
        hook = Capsule(radius=HOOK_RADIUS, half_length=HOOK_HALF_LENGTH, pos=(hook_x, 0.0, TABLE_TOP + HOOK_HEIGHT),
                       euler=(90.0, 0.0, 0.0))
        return Scene(cable, obstacles=(Floor(), table, hook), grippers=(Gripper(GRIPPER_START),), name="hang")

    def make_workspace(self, scene: Scene) -> Workspace:
        return Workspace(scene, *_WORKSPACE, clearance=_CLEARANCE)

    def action_spec(self, physics: Physics) -> specs.BoundedArray:
        """The gripper's displacement over one control step (3 entries, metres) and its grip command (> 0: close)."""
        return self._action_spec

    def before_step(self, action, physics: Physics) -> None:
        a = base.checked_action(action, self._action_spec, self._bounds, unit="(m, m, m, 1)", **self._action_words)
        physics.grip(a[3] > 0.0)
        physics.command_grippers({_GRIPPER: a[:3]})

    def task_observations(self, physics: Physics) -> dict:
        return {"hook_top": physics.hook_top(), "holding": np.array([float(physics.holding())]),
                "gripper_force": physics.simulator.gripper_forces[_GRIPPER]}

    def get_reward(self, physics: Physics) -> float:
        gap, legs, ends, lowest = physics.measures()
        top = physics.hook_top()
        rest = base.tolerance(gap, 0.0, _REST_TOLERANCE, _REST_MARGIN)
        apart = min(top[0] - min(legs), max(legs) - top[0])
        sides = base.tolerance(apart, 0.5 * HOOK_RADIUS, math.inf, _SIDE_MARGIN)
        hang = base.tolerance(top[2] - max(ends[0, 2], ends[1, 2]), HANG_DROP, math.inf, _HANG_MARGIN)
        off = base.tolerance(lowest - RADIUS - TABLE_TOP, TABLE_GAP, math.inf, _TABLE_MARGIN)
        return rest * (sides + hang + off) / 3.0 * (HELD_SHARE if physics.holding() else 1.0)
