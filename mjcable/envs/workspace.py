"""Where a gripper may go: a box, outside every obstacle, and never overstretching the cable.

A :class:`Workspace` clamps each commanded gripper motion, whatever the actions, so that

* the gripper stays inside an axis-aligned box (``low`` … ``high``, metres);
* it keeps ``clearance`` metres from every obstacle's surface (MuJoCo gives mocap bodies no contacts with static
  geoms, so nothing else would stop a gripper inside a table);
* its distance to every other pin that still holds the cable (another gripper, a world pin, an engaged socket) stays
  below ``(1 - STRETCH_MARGIN)`` times the arc length of cable between the two, so no action can pull the cable taut
  beyond its rest length.

Motions are split into increments no longer than half the clearance, each projected onto the allowed set, so a
gripper cannot tunnel through a thin obstacle. A projection that fails to satisfy every constraint keeps the last
allowed position: the gripper stops instead of entering a forbidden region.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Optional, Sequence, Tuple

import numpy as np

from mjcable.geometry import signed_distance
from mjcable.scene import Scene

__all__ = ["Workspace", "Tether", "STRETCH_MARGIN", "signed_distance"]

STRETCH_MARGIN = 0.01  # fraction of the cable between two pins that their distance must stay short of
_PROJECTION_ROUNDS = 4  # alternating projections (box, tethers, obstacles) per increment
_TOLERANCE = 1e-9  # m: slack when checking a projected point against the constraints
_INCREMENT_FRACTION = 0.5  # of the clearance: the longest straight increment of a gripper motion


@dataclasses.dataclass(frozen=True)
class Tether:
    """A length of cable between a gripper and another pin: their distance must stay below ``max_distance`` metres.

    Args:
      pin: index into ``scene.pins`` of the other pin.
      max_distance: the allowed distance in metres, ``(1 - STRETCH_MARGIN)`` times the cable between them.
    """

    pin: int
    max_distance: float


@dataclasses.dataclass(frozen=True)
class Workspace:
    """The set of allowed gripper positions of a scene.

    Args:
      scene: the scene (its obstacles are kept out; its pins define the tethers).
      low: (3,) lower corner of the allowed box in metres.
      high: (3,) upper corner in metres (> ``low``).
      clearance: distance in metres (> 0) a gripper keeps from every obstacle surface.
    """

    scene: Scene
    low: tuple
    high: tuple
    clearance: float

    def __post_init__(self):
        low = np.asarray(self.low, dtype=np.float64)
        high = np.asarray(self.high, dtype=np.float64)
        if low.shape != (3,) or high.shape != (3,) or not np.all(np.isfinite(low)) or not np.all(np.isfinite(high)):
            raise ValueError(f"low and high must be 3 finite numbers each, got {self.low!r} and {self.high!r}")
        if not np.all(low < high):
            raise ValueError(f"low must lie below high on every axis, got low={self.low!r}, high={self.high!r}")
        if not (isinstance(self.clearance, (int, float)) and 0.0 < self.clearance < math.inf):
            raise ValueError(f"clearance must be a finite number > 0 (metres), got {self.clearance!r}")
        object.__setattr__(self, "low", tuple(low))
        object.__setattr__(self, "high", tuple(high))
        object.__setattr__(self, "clearance", float(self.clearance))
        object.__setattr__(self, "_low", low)
        object.__setattr__(self, "_high", high)
        object.__setattr__(self, "_tethers", {k: self._make_tethers(k) for k in self.scene.grippers})

    def _make_tethers(self, k: int) -> Tuple[Tether, ...]:
        scene = self.scene
        i = scene.pin_particle(k)
        tethers = []
        for j in range(len(scene.pins)):
            if j != k:
                segments = abs(scene.pin_particle(j) - i)
                tethers.append(Tether(j, (1.0 - STRETCH_MARGIN) * segments * scene.cable.segment_length))
        return tuple(tethers)

    def tethers(self, k: int) -> Tuple[Tether, ...]:
        """The tethers of gripper pin ``k`` (an index into ``scene.pins``)."""
        return self._tethers[k]

    def violation(self, k: int, position, pins: np.ndarray, engaged: Sequence[bool]) -> float:
        """How far (metres) gripper ``k`` at ``position`` lies outside the allowed set; 0 inside it.

        Args:
          k: gripper pin index.
          position: (3,) candidate position in metres.
          pins: (n_pins, 3) current positions of every pin's fixed side (grippers' and anchors' positions).
          engaged: per pin, whether it still holds the cable (a released socket does not).
        """
        p = np.asarray(position, dtype=np.float64)
        worst = float(max(np.max(self._low - p), np.max(p - self._high), 0.0))
        for t in self._tethers[k]:
            if engaged[t.pin]:
                worst = max(worst, float(np.linalg.norm(p - pins[t.pin])) - t.max_distance)
        for ob in self.scene.obstacles:
            worst = max(worst, self.clearance - signed_distance(ob, p)[0])
        return worst

    def _project(self, k: int, p: np.ndarray, pins: np.ndarray, engaged: Sequence[bool]) -> Optional[np.ndarray]:
        for _ in range(_PROJECTION_ROUNDS):
            p = np.clip(p, self._low, self._high)
            for t in self._tethers[k]:
                if engaged[t.pin]:
                    offset = p - pins[t.pin]
                    d = float(np.linalg.norm(offset))
                    if d > t.max_distance:
                        p = pins[t.pin] + offset * (t.max_distance / d)
            for ob in self.scene.obstacles:
                d, normal = signed_distance(ob, p)
                if d < self.clearance:
                    p = p + (self.clearance - d) * normal
            if self.violation(k, p, pins, engaged) <= _TOLERANCE:
                return p
        return None

    def move(self, k: int, start, displacement, pins: np.ndarray, engaged: Sequence[bool]) -> np.ndarray:
        """Where gripper ``k`` ends when commanded from ``start`` by ``displacement``, clamped to the allowed set.

        Args:
          k: gripper pin index (into ``scene.pins``).
          start: (3,) current, allowed position in metres.
          displacement: (3,) commanded motion in metres.
          pins: (n_pins, 3) current positions of every pin's fixed side, metres.
          engaged: per pin, whether it still holds the cable.

        Returns:
          (3,) the new position: the commanded one projected onto the allowed set, increment by increment; where a
          projection fails the gripper stays at its last allowed position.
        """
        p = np.asarray(start, dtype=np.float64).copy()
        displacement = np.asarray(displacement, dtype=np.float64)
        length = float(np.linalg.norm(displacement))
        if length == 0.0:
            return p
        count = max(1, math.ceil(length / (_INCREMENT_FRACTION * self.clearance)))
        step = displacement / count
        for _ in range(count):
            projected = self._project(k, p + step, pins, engaged)
            if projected is None:
                break
            p = projected
        return p
