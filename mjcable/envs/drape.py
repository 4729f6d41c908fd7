"""``drape``: lay the cable over a peg so that both ends hang down on either side.

The built-in ``drape`` scene (a horizontal peg of radius 3 cm at 0.8 m over a floor), but the 1 m cable now hangs
straight down from a gripper holding one end. Each episode starts the gripper on a random side of the peg,
``START_OFFSET`` metres from its axis. The agent carries the cable over the peg and lowers the gripper on the far
side, so that the peg carries the cable with one end hanging on each side. The reward averages three shaped terms:
the cable's highest point rests on the peg's top, its two halves hang on opposite sides of the peg's axis, and
both ends hang at least ``HANG_DROP`` below the peg's top.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mjcable import scenes
from mjcable.envs import base
from mjcable.envs.workspace import Workspace
from mjcable.scene import Cylinder, Pin, Scene

__all__ = ["Physics", "Drape", "peg_measures", "START_OFFSET", "START_HEIGHT", "HANG_DROP", "TIME_LIMIT"]

START_OFFSET = (0.3, 0.45)  # m, horizontal distance of the gripper from the peg's axis at the start (uniform)
START_HEIGHT = 1.35  # m, gripper height at the start; the 1 m cable hangs straight down from it
HANG_DROP = 0.2  # m: full reward once both ends hang this far below the peg's top
TIME_LIMIT = 10.0  # s
_CLEARANCE = 0.01  # m the gripper keeps from the peg and the floor
_WORKSPACE = ((-0.7, -0.25, 0.3), (0.8, 0.25, 1.6))  # m, the allowed box of the gripper
_REST_TOLERANCE = 0.01  # m: full support reward with the cable's highest point this close to resting on the peg
_REST_MARGIN = 0.3  # m
_SIDE_MARGIN = 0.03  # m: a leg this far on the wrong side of the peg's axis earns a tenth of the side reward
_HANG_MARGIN = 0.2  # m
_CABLE_LENGTH = 1.0  # m: the cable starts straight down from the gripper, this long
_PEG = next(ob for ob in scenes.get("drape").obstacles if isinstance(ob, Cylinder))  # the built-in scene's peg


@numba.njit(cache=True)
def peg_measures(x, top_x, top_z, radius):
    """The reward's measures of centreline ``x`` (n+1, 3) over a peg whose top is at (``top_x``, ·, ``top_z``):
    the rest gap (m) and the two legs' mean x (m), as :meth:`Physics.rest_gap` and :meth:`Physics.leg_positions`."""
    highest = 0
    for i in range(1, x.shape[0]):
        if x[i, 2] > x[highest, 2]:  # the first of equals, as numpy's argmax
            highest = i
    gap = math.hypot(x[highest, 0] - top_x, x[highest, 2] - (top_z + radius))
    middle = x.shape[0] // 2
    legs = np.empty(2)
    for leg, (first, last, end) in enumerate(((0, middle + 1, 0), (middle, x.shape[0], x.shape[0] - 1))):
        total, count = 0.0, 0
        for i in range(first, last):
            if x[i, 2] < top_z:
                total += x[i, 0]
                count += 1
        legs[leg] = total / count if count else x[end, 0]
    return gap, legs


class Physics(base.CablePhysics):
    """Adds read-outs of the peg, the cable's ends and its legs."""

    def peg(self) -> Cylinder:
        return next(ob for ob in self.scene.obstacles if isinstance(ob, Cylinder))

    def peg_top(self) -> np.ndarray:
        """(3,) the highest point of the peg's middle, metres."""
        peg = self.peg()
        return np.array([peg.pos[0], peg.pos[1], peg.pos[2] + peg.radius])

    def ends(self) -> np.ndarray:
        """(2, 3) the cable's two ends, metres."""
        return self.centreline()[[0, -1]]

    def measures(self) -> tuple:
        """``(rest_gap, leg_positions, ends)`` of one read of the centreline (compiled): metres, (2,) metres,
        (2, 3) metres; see :meth:`rest_gap`, :meth:`leg_positions` and :meth:`ends`."""
        x = self.centreline()
        top = self.peg_top()
        gap, legs = peg_measures(x, top[0], top[2], self.scene.cable.radius)
        return gap, legs, x[[0, -1]]

    def leg_positions(self) -> np.ndarray:
        """(2,) where the cable's two halves hang: the mean x (metres) of each half's particles below the peg's top,
        or its end's x if none is. Draped over the peg, the halves hang on either side of its axis."""
        return self.measures()[1]

    def rest_gap(self) -> float:
        """Distance in metres from the cable's highest point to where it would rest on the peg's top (the top line
        raised by the cable's radius, at the same y)."""
        return self.measures()[0]


@base.register(TIME_LIMIT, "benchmarking")
class Drape(base.CableTask):
    """Carry the cable, held by one end, over the peg so that both ends hang down on either side."""

    name = "drape"
    physics_class = Physics
    controlled = (0,)

    def make_scene(self) -> Scene:
        side = 1.0 if self.random.uniform() < 0.5 else -1.0
        x0 = _PEG.pos[0] + side * self.random.uniform(*START_OFFSET)
        points = [[x0, 0.0, START_HEIGHT], [x0, 0.0, START_HEIGHT - _CABLE_LENGTH]]
        return base.scene_with_pins("drape", (Pin(0, "gripper"),), points=points)

    def make_workspace(self, scene: Scene) -> Workspace:
        return Workspace(scene, *_WORKSPACE, clearance=_CLEARANCE)

    def task_observations(self, physics: Physics) -> dict:
        return {"peg_top": physics.peg_top(), "ends": physics.ends()}

    def get_reward(self, physics: Physics) -> float:
        gap, legs, ends = physics.measures()
        top = physics.peg_top()
        rest = base.tolerance(gap, 0.0, _REST_TOLERANCE, _REST_MARGIN)
        apart = min(top[0] - min(legs), max(legs) - top[0])
        sides = base.tolerance(apart, 0.5 * physics.peg().radius, math.inf, _SIDE_MARGIN)
        hang = base.tolerance(top[2] - max(ends[0, 2], ends[1, 2]), HANG_DROP, math.inf, _HANG_MARGIN)
        return (rest + sides + hang) / 3.0
