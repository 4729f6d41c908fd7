"""``unplug``: pull the plug end of a cable out of its socket and carry it to a target.

The built-in ``socket`` scene (a wall with a socket at 0.6 m, a floor), its plug end held by a socket that lets go
for good once the pull on it exceeds ``RELEASE_FORCE`` newtons; a gripper holds the other end. The socket holds the
plug's position only (no clamp: a clamp's neighbour equality would carry the cable's pull, which the native models'
release test does not count). The agent yanks the cable, or pulls it nearly taut (the workspace keeps the gripper
within 99 % of the cable's length of the socket while the plug is in), to release the plug, then carries it,
dangling, to a target drawn uniformly from ``TARGET_BOX`` each episode.
Reward: up to 0.25 for pulling the cable taut while the plug is in; 0.5 once it is out, plus up to 0.5 as the plug
nears the target.
"""

from __future__ import annotations

import math

import numpy as np

from mjcable.envs import base
from mjcable.envs.workspace import Workspace
from mjcable.scene import Pin, Scene

__all__ = ["Physics", "Unplug", "RELEASE_FORCE", "TARGET_BOX", "TARGET_RADIUS", "TIME_LIMIT"]

RELEASE_FORCE = 2.5  # N: above the swinging start pose's pull (<= 1.7 N); a yank or a steady pull near taut exceeds it
TARGET_BOX = ((-0.1, -0.15, 0.1), (0.35, 0.15, 0.4))  # m: the plug's targets, in reach of the dangling plug
TARGET_RADIUS = 0.05  # m: full reward with the plug this close to the target
TIME_LIMIT = 10.0  # s
_TARGET_MARGIN = 0.5  # m
_TAUT_TOLERANCE = 0.02  # m short of the workspace's limit: full pulling reward
_TAUT_MARGIN = 0.3  # m
_PULL_SHARE = 0.25  # of the reward: pulling while the plug is in
_CLEARANCE = 0.01  # m the gripper keeps from the wall and the floor
_WORKSPACE = ((-0.35, -0.4, 0.05), (0.8, 0.4, 1.3))  # m, the allowed box of the gripper
_PLUG, _GRIPPER = 0, 1  # pin indices


class Physics(base.CablePhysics):
    """Adds read-outs of the plug, the socket and whether the plug is out."""

    def plug(self) -> np.ndarray:
        """(3,) the plug (the cable's first particle), metres."""
        return self.centreline()[0]

    def socket(self) -> np.ndarray:
        """(3,) the socket's anchor, metres (the plug's start particle: a socket does not move)."""
        return self.anchors()[_PLUG]

    def released(self) -> bool:
        return _PLUG in self.simulator.released


@base.register(TIME_LIMIT, "benchmarking")
class Unplug(base.CableTask):
    """Pull the plug out of its socket (it lets go above RELEASE_FORCE) and carry it to a random target."""

    name = "unplug"
    physics_class = Physics
    controlled = (_GRIPPER,)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self._target = np.mean(TARGET_BOX, axis=0)  # until the first episode draws one

    def make_scene(self) -> Scene:
        return base.scene_with_pins("socket", (Pin(0, "socket", release_force=RELEASE_FORCE), Pin(-1, "gripper")))

    def make_workspace(self, scene: Scene) -> Workspace:
        return Workspace(scene, *_WORKSPACE, clearance=_CLEARANCE)

    def sample_episode(self, physics: Physics) -> None:
        self._target = self.random.uniform(*TARGET_BOX)

    def task_observations(self, physics: Physics) -> dict:
        return {"plug": physics.plug(), "socket": physics.socket(), "released": np.array([float(physics.released())]),
                "target": self._target.copy()}

    def get_reward(self, physics: Physics) -> float:
        if physics.released():
            distance = math.dist(physics.plug(), self._target)
            return 0.5 + 0.5 * base.tolerance(distance, 0.0, TARGET_RADIUS, _TARGET_MARGIN)
        reach = physics.workspace.tether(_GRIPPER, _PLUG)
        slack = reach - math.dist(physics.gripper_positions()[0], physics.socket())
        return _PULL_SHARE * base.tolerance(slack, 0.0, _TAUT_TOLERANCE, _TAUT_MARGIN)
