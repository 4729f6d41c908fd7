"""``reach_sag``: both cable ends are held by grippers; move one so that the mid-span sag reaches a target.

The cable of the built-in ``hang`` scene (1 m over a 0.8 m span at 1 m height), both ends held by grippers. The
action moves the right-hand gripper (pin 1); the left one stays put. The mid-span sag is the mean height of the two
ends minus the height of the cable's middle; each episode draws its target uniformly from ``SAG_RANGE``.
"""

from __future__ import annotations

import numpy as np

from mjcable.envs import base
from mjcable.envs.workspace import Workspace
from mjcable.scene import Pin, Scene

__all__ = ["Physics", "ReachSag", "SAG_RANGE", "SAG_TOLERANCE", "SAG_MARGIN", "TIME_LIMIT"]

SAG_RANGE = (0.1, 0.4)  # m, targets are drawn uniformly from it (a 1 m cable between the ends' reachable spans)
SAG_TOLERANCE = 0.01  # m: full reward within this of the target
SAG_MARGIN = 0.2  # m: the reward falls to 0.1 this far outside the tolerance
TIME_LIMIT = 10.0  # s
_WORKSPACE = ((-0.5, -0.3, 0.6), (0.95, 0.3, 1.4))  # m, the allowed box of the grippers
_CLEARANCE = 0.01  # m from obstacles (the scene has none)


class Physics(base.CablePhysics):
    """Adds the mid-span sag read-out."""

    def sag(self) -> float:
        """Mean height of the two ends minus the height of the cable's middle, metres (positive when it hangs)."""
        x = self.centreline()
        n = len(x) - 1
        middle = 0.5 * (x[n // 2, 2] + x[(n + 1) // 2, 2])
        return float(0.5 * (x[0, 2] + x[-1, 2]) - middle)


@base.register(TIME_LIMIT, "benchmarking")
class ReachSag(base.CableTask):
    """Move the right-hand gripper until the cable's mid-span sag matches a random target."""

    name = "reach_sag"
    physics_class = Physics
    controlled = (1,)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self._target = 0.5 * (SAG_RANGE[0] + SAG_RANGE[1])  # until the first episode draws one

    def make_scene(self) -> Scene:
        return base.scene_with_pins("hang", (Pin(0, "gripper"), Pin(-1, "gripper")))

    def make_workspace(self, scene: Scene) -> Workspace:
        return Workspace(scene, *_WORKSPACE, clearance=_CLEARANCE)

    def sample_episode(self, physics: Physics) -> None:
        self._target = float(self.random.uniform(*SAG_RANGE))

    def task_observations(self, physics: Physics) -> dict:
        return {"sag": np.array([physics.sag()]), "target_sag": np.array([self._target])}

    def get_reward(self, physics: Physics) -> float:
        error = physics.sag() - self._target
        return base.tolerance(error, -SAG_TOLERANCE, SAG_TOLERANCE, SAG_MARGIN)
