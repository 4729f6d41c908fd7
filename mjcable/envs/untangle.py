"""``untangle``: pull a cable out from over another one and lay it in a target zone without dragging the other.

Two cables lie crossed on a table: cable B (index 1, :data:`LENGTH_B` metres) along y, and cable A (index 0,
:data:`LENGTH_A` metres) along x, across B's middle, resting on it (A starts straight at B's top; away from the
crossing it settles onto the table). A gripper holds A's end 0, on the zone's side of B. The agent pulls A off B and
lays it in a target zone on the table (an axis-aligned box :data:`ZONE_HEIGHT` metres tall on the table's top)
without dragging B along. Each episode draws B's place along x, A's place along y and the zone's place along y from
``self.random``. The reward is the product of two shaped terms: A's particles in the zone (their mean distance from
the box) and B's stillness (the largest displacement of B's particles from their start).

The task needs a model that simulates several cables (``catalog.get(model).several_cables``,
:func:`mjcable.envs.models`); on the others loading it is a ``ValueError`` naming the reason.
"""

from __future__ import annotations

import numpy as np

from mjcable.envs import base
from mjcable.envs.workspace import Workspace
from mjcable.scene import Box, CableSpec, Floor, Pin, Scene

__all__ = ["Physics", "Untangle", "TABLE_TOP", "LENGTH_A", "LENGTH_B", "RADIUS", "B_X", "A_Y", "ZONE_Y",
           "ZONE_HALF", "ZONE_HEIGHT", "STILL_TOLERANCE", "TIME_LIMIT"]

TABLE_TOP = 0.75  # m, height of the table's top
LENGTH_A = 0.4  # m, the cable to move (index 0)
LENGTH_B = 0.5  # m, the cable to leave in place (index 1)
RADIUS = 0.005  # m, both cables
SEGMENTS_A, SEGMENTS_B = 20, 25  # 20 mm segments
MASS_A, MASS_B = 0.12, 0.15  # kg: two cables of one kind, 0.3 kg/m (a light, limp B was dragged along by A)
FRICTION = 0.3  # Coulomb μ of the cables (and of the table, which sets none of its own)
YOUNG_A = YOUNG_B = 1e6  # Pa: cables that bend (E·I = 4.9e-4 N·m²)
DAMPING_A = DAMPING_B = 1.0  # 1/s
B_X = (0.05, 0.15)  # m, B's x (uniform); A's middle crosses it
A_Y = (-0.1, 0.1)  # m, A's y (uniform); B's middle is at y = 0
ZONE_Y = (-0.1, 0.1)  # m, the zone's centre y (uniform)
ZONE_X = -0.3  # m, the zone's centre x: on the side of B where the gripper holds A
ZONE_HALF = (0.22, 0.12)  # m, the zone's half extents along x and y
ZONE_HEIGHT = 0.03  # m above the table's top: a particle higher up is not laid in the zone
STILL_TOLERANCE = 0.01  # m: full stillness reward while no particle of B has moved farther from its start
TIME_LIMIT = 10.0  # s
_ZONE_MARGIN = 0.15  # m: A's particles this far from the zone on average earn a tenth of the zone reward
_STILL_MARGIN = 0.05  # m
_TABLE_HALF = (0.6, 0.35, 0.02)  # m, the table's half extents
_CLEARANCE = 0.008  # m the gripper keeps from the table and the floor (it starts 1.5 cm over the table)
_WORKSPACE = ((-0.65, -0.4, 0.3), (0.65, 0.4, 1.2))  # m, the allowed box of the gripper


class Physics(base.CablePhysics):
    """Adds read-outs of the two cables (A: cable 0, B: cable 1) and of B's displacement."""

    def cable_a(self) -> np.ndarray:
        """(n_A + 1, 3) cable A's particles, metres."""
        return self.cable_centreline(0)

    def cable_b(self) -> np.ndarray:
        """(n_B + 1, 3) cable B's particles, metres."""
        return self.cable_centreline(1)

    def b_displacement(self) -> float:
        """The largest distance in metres of a particle of B from its start (the scene's)."""
        start = self.scene.particles[self.scene.cable_slices[1]]
        return float(np.sqrt(np.max(np.sum((self.cable_b() - start) ** 2, axis=1))))


@base.register(TIME_LIMIT, "benchmarking")
class Untangle(base.CableTask):
    """Pull cable A, held by one end, off cable B and lay it in the target zone without dragging B."""

    name = "untangle"
    physics_class = Physics
    controlled = (0,)
    requires = ("several_cables",)

    def __init__(self, *, random=None, control_timestep: float = base.DEFAULT_CONTROL_TIMESTEP):
        super().__init__(random=random, control_timestep=control_timestep)
        self._zone = _zone(np.mean(ZONE_Y))  # (2, 3) m, the zone's low and high corners, until an episode draws one

    def make_scene(self) -> Scene:
        x_b = self.random.uniform(*B_X)
        y_a = self.random.uniform(*A_Y)
        z_b = TABLE_TOP + RADIUS  # B lies on the table
        z_a = z_b + 2.0 * RADIUS  # A lies on B
        b = CableSpec([[x_b, -0.5 * LENGTH_B, z_b], [x_b, 0.5 * LENGTH_B, z_b]], SEGMENTS_B, RADIUS, MASS_B,
                      friction=FRICTION, damping=DAMPING_B, young=YOUNG_B)
        a = CableSpec([[x_b - 0.5 * LENGTH_A, y_a, z_a], [x_b + 0.5 * LENGTH_A, y_a, z_a]], SEGMENTS_A, RADIUS,
                      MASS_A, friction=FRICTION, damping=DAMPING_A, young=YOUNG_A)
        table = Box(size=_TABLE_HALF, pos=(0.0, 0.0, TABLE_TOP - _TABLE_HALF[2]))
        return Scene((a, b), pins=(Pin(0, "gripper", cable=0),), obstacles=(Floor(), table), name="untangle")

    def make_workspace(self, scene: Scene) -> Workspace:
        return Workspace(scene, *_WORKSPACE, clearance=_CLEARANCE)

    def sample_episode(self, physics: Physics) -> None:
        self._zone = _zone(self.random.uniform(*ZONE_Y))

    @property
    def zone(self) -> np.ndarray:
        """(2, 3) m: the target zone's low and high corners (drawn at the start of each episode)."""
        return self._zone.copy()

    def zone_distance(self, physics: Physics) -> float:
        """The mean distance in metres of A's particles from the zone (0 when every one lies in it)."""
        x = physics.cable_a()
        outside = np.maximum(np.maximum(self._zone[0] - x, x - self._zone[1]), 0.0)
        return float(np.mean(np.sqrt(np.sum(outside * outside, axis=1))))

    def task_observations(self, physics: Physics) -> dict:
        return {"zone": self._zone.copy(), "b_displacement": np.array([physics.b_displacement()])}

    def get_reward(self, physics: Physics) -> float:
        laid = base.tolerance(self.zone_distance(physics), 0.0, 0.0, _ZONE_MARGIN)
        still = base.tolerance(physics.b_displacement(), 0.0, STILL_TOLERANCE, _STILL_MARGIN)
        return laid * still


def _zone(y: float) -> np.ndarray:
    """(2, 3) m: the low and high corners of the zone centred at (:data:`ZONE_X`, ``y``) on the table."""
    return np.array([[ZONE_X - ZONE_HALF[0], y - ZONE_HALF[1], TABLE_TOP],
                     [ZONE_X + ZONE_HALF[0], y + ZONE_HALF[1], TABLE_TOP + ZONE_HEIGHT]])
