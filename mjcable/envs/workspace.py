"""Where a gripper may go: a box, outside every obstacle, and never overstretching the cable.

A :class:`Workspace` clamps each commanded gripper motion, whatever the actions, so that

* the gripper stays inside an axis-aligned box (``low`` … ``high``, metres);
* it keeps ``clearance`` metres from every obstacle's surface (MuJoCo gives mocap bodies no contacts with static
  geoms, so nothing else would stop a gripper inside a table);
* its distance to every other pin that still holds the cable (another gripper, a world pin, an engaged socket) stays
  below ``(1 - STRETCH_MARGIN)`` times the arc length of cable between the two, so no action can pull the cable taut
  beyond its rest length. In a scene of several cables the arc runs along the cable the gripper holds, and through
  the junctions into the others (the shortest way, over a loop's either side); a pin on a cable that no junction
  joins to the gripper's holds no tether on it.

Free grippers (``scene.grippers``, which grasp and release particles at run time) are clamped as gripper pins are,
numbered as :meth:`mjcable.Simulator.move_gripper` numbers them (``len(scene.pins) + g``, the rows after the pins'
in ``pins``), to the box and the obstacles' clearance only: what a free gripper holds changes at run time, so no
tether binds it, nor binds a gripper pin to it.

Motions are split into increments no longer than half the clearance, each projected onto the allowed set, so a
gripper cannot tunnel through a thin obstacle. A projection that fails to satisfy every constraint keeps the last
allowed position: the gripper stops instead of entering a forbidden region. The clamp runs compiled
(:mod:`mjcable.envs.projection`); :meth:`Workspace.paths` clamps every step of a control step in one call.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Mapping, Optional, Sequence, Tuple

import numpy as np

from mjcable import _validate
from mjcable.envs import projection
from mjcable.geometry import signed_distance
from mjcable.scene import Scene

__all__ = ["Workspace", "Tether", "STRETCH_MARGIN", "signed_distance"]

STRETCH_MARGIN = 0.01  # fraction of the cable between two pins that their distance must stay short of


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
        object.__setattr__(self, "_box", np.array([low, high]))  # (2, 3) m
        tethers = {k: self._make_tethers(k) for k in self.scene.gripper_pins}
        n_pins = len(self.scene.pins)
        n_rows = n_pins + len(self.scene.grippers)
        tethers.update({k: () for k in range(n_pins, n_rows)})  # free grippers: no tethers
        tether_max = np.full((n_rows, n_rows), np.inf)
        for k, ts in tethers.items():
            for t in ts:
                tether_max[k, t.pin] = t.max_distance
        object.__setattr__(self, "_tethers", tethers)
        object.__setattr__(self, "_tether_max", tether_max)  # (n_rows, n_rows) m, row k gripper k's; inf: none
        object.__setattr__(self, "_holding_by", {})  # engaged pins (bytes) -> _holding's answer
        object.__setattr__(self, "_obstacles", projection.pack_obstacles(self.scene.obstacles))

    def _make_tethers(self, k: int) -> Tuple[Tether, ...]:
        scene = self.scene
        i = scene.pin_particle(k)
        arcs = _arc_lengths(scene, i) if scene.junctions else None
        tethers = []
        for j in range(len(scene.pins)):
            if j == k:
                continue
            if arcs is not None:
                arc = arcs[scene.pin_particle(j)]
            elif scene.pin_cable(j) == scene.pin_cable(k):  # along one cable: segments times their length
                arc = abs(scene.pin_particle(j) - i) * scene.cables[scene.pin_cable(k)].segment_length
            else:
                continue  # another cable, not joined to this one
            if math.isfinite(arc):
                tethers.append(Tether(j, (1.0 - STRETCH_MARGIN) * arc))
        return tuple(tethers)

    def tethers(self, k: int) -> Tuple[Tether, ...]:
        """The tethers of gripper ``k`` (a gripper pin's index into ``scene.pins``; a free gripper's ``len(scene.pins)
        + g``, which has none)."""
        return self._tethers[k]

    def tether(self, k: int, j: int) -> float:
        """The longest allowed distance in metres between gripper pin ``k`` and pin ``j`` (while ``j`` holds the
        cable): its :class:`Tether`'s ``max_distance`` (``inf`` where no cable joins the two).

        Raises:
          ValueError: ``k`` is not a gripper pin, or ``j`` is ``k`` or not a pin.
        """
        self._check_grippers((k,))
        if isinstance(j, bool) or j not in range(len(self.scene.pins)) or j == k:
            raise ValueError(f"j must be another pin than {k}, one of 0..{len(self.scene.pins) - 1}, got {j!r}")
        return float(self._tether_max[k, j])

    def _check_grippers(self, grippers: Sequence[int]) -> None:
        for k in grippers:
            if isinstance(k, bool) or k not in self._tethers:
                raise ValueError(f"k must be a gripper (a gripper pin, or a free gripper as len(scene.pins) + g), "
                                 f"one of {tuple(self._tethers)}, got {k!r}")

    def _holding(self, grippers: Sequence[int], engaged: Sequence[bool]) -> np.ndarray:
        """``(n_rows, n_rows)`` m: the tethers that hold (rows of grippers, columns of engaged pins), ``inf`` where
        none does."""
        self._check_grippers(grippers)
        engaged = np.asarray(engaged, dtype=bool)
        if engaged.shape != (len(self.scene.pins),):
            raise ValueError(f"engaged must hold one bool per pin ({len(self.scene.pins)}), got {engaged!r}")
        key = engaged.tobytes()
        tethers = self._holding_by.get(key)
        if tethers is None:  # once per pattern of engaged pins (the free grippers' columns hold no tether anyway)
            columns = np.ones(len(self._tether_max), dtype=bool)
            columns[:len(engaged)] = engaged
            tethers = np.where(columns, self._tether_max, np.inf)  # (kept writable: numba types read-only apart)
            self._holding_by[key] = tethers
        return tethers

    def violation(self, k: int, position, pins: np.ndarray, engaged: Sequence[bool]) -> float:
        """How far (metres) gripper ``k`` at ``position`` lies outside the allowed set; 0 inside it.

        Args:
          k: gripper (a gripper pin's index; free gripper ``g``: ``len(scene.pins) + g``).
          position: (3,) candidate position in metres.
          pins: (n_pins + n_free_grippers, 3) current positions of every pin's fixed side (grippers' and anchors'
            positions), then of the free grippers (:meth:`mjcable.envs.CablePhysics.pin_positions`).
          engaged: per pin, whether it still holds the cable (a released socket does not).
        """
        tethers = self._holding((k,), engaged)
        return projection.violation(position, self._box, self.clearance, np.asarray(pins, dtype=np.float64),
                                    tethers[k], self._obstacles)

    def paths(self, displacements: Mapping[int, np.ndarray], nstep: int, pins: np.ndarray,
              engaged: Sequence[bool], *, steps: Optional[int] = None) -> Tuple[np.ndarray, np.ndarray]:
        """Where the grippers ``displacements`` commands are after each of ``nstep`` steps, each step moving every
        one of them (in the mapping's order, each seeing the others' new positions) by ``1 / nstep`` of its
        displacement with :meth:`move`; computed in one compiled call.

        Args:
          displacements: {gripper (as in :meth:`violation`): (3,) whole displacement in metres}.
          nstep: number of steps (an integer >= 1).
          pins: (n_pins + n_free_grippers, 3) positions of every pin's fixed side, then of the free grippers, at the
            start, metres.
          engaged: per pin, whether it holds the cable (fixed over the steps).
          steps: how many of the ``nstep`` steps to take (an integer in [1, nstep]; default ``nstep``): the rest of
            a control step whose path is recomputed part way, after a socket let go.

        Returns:
          ``(positions, moved)``: ``(steps, len(displacements), 3)`` gripper positions in metres, and
          ``(steps, len(displacements))`` bool, whether each gripper's position changed in that step (bit for bit;
          a gripper that stays need not be sent anywhere).
        """
        nstep = _validate.integer("nstep", nstep, low=1)
        steps = nstep if steps is None else _validate.integer("steps", steps, low=1, high=nstep)
        grippers = list(displacements)
        tethers = self._holding(grippers, engaged)
        d = np.array([displacements[k] for k in grippers], dtype=np.float64).reshape(len(grippers), 3)
        return projection.move_paths(pins, np.array(grippers, dtype=np.int64), d, nstep, self._box, self.clearance,
                                     tethers, self._obstacles, steps=steps)

    def move(self, k: int, start, displacement, pins: np.ndarray, engaged: Sequence[bool]) -> np.ndarray:
        """Where gripper ``k`` ends when commanded from ``start`` by ``displacement``, clamped to the allowed set.

        Args:
          k: gripper (as in :meth:`violation`).
          start: (3,) current, allowed position in metres.
          displacement: (3,) commanded motion in metres.
          pins: (n_pins + n_free_grippers, 3) current positions of every pin's fixed side, then of the free
            grippers, metres.
          engaged: per pin, whether it still holds the cable.

        Returns:
          (3,) the new position: the commanded one projected onto the allowed set, increment by increment; where a
          projection fails the gripper stays at its last allowed position.
        """
        pins = np.array(pins, dtype=np.float64)
        pins[k] = start
        return self.paths({k: displacement}, 1, pins, engaged)[0][0, 0]


def _arc_lengths(scene: Scene, start: int) -> np.ndarray:
    """``(scene.n_particles,)`` m: the shortest arc length along the cables from global particle ``start`` to every
    particle, through the junctions (whose particles are one point); ``inf`` where no cable leads."""
    from scipy.sparse.csgraph import dijkstra

    n = scene.n_particles
    node = np.arange(n)  # each particle's node: a junction point's particles share its first one's
    for point in scene.junction_points():
        node[list(point)] = point[0]
    graph = np.full((n, n), np.inf)
    for cable, s in zip(scene.cables, scene.cable_slices):
        a, b = node[s.start:s.stop - 1], node[s.start + 1:s.stop]
        np.minimum.at(graph, (a, b), cable.segment_length)  # two cables joined at both ends: the shorter
        np.minimum.at(graph, (b, a), cable.segment_length)
    graph[~np.isfinite(graph)] = 0.0  # a dense graph's zeros are no edges
    return dijkstra(graph, directed=False, indices=node[start])[node]
