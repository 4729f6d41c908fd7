"""The knot family (issue 22): one rope tied in a loose overhand knot, its ends pulled apart by grippers until taut.

The rope (r = 5 mm, 0.1 kg/m, the cable's own defaults otherwise: limp, μ = 1) starts in the knot of
:func:`mjcable.knots.overhand_knot` (strands 2 r + 2 mm apart, 30 cm tails, about 0.87 m of rope), its two ends held
by grippers, gravity on (a rope in a room: its knot hangs loose until the pull takes it up). The grippers move apart
along the ends' line at :data:`PULL_SPEED` each, slowed as the rope's tension (the grippers' mean pin force over the
last :data:`FORCE_WINDOW` steps) nears :data:`TENSION`, about 2.4 times the rope's weight, and backed off above it
(:func:`pull`): a puller that holds the tension, not a position, so a knot that locks is not pulled through
itself by a gripper that keeps going. The run lasts :data:`DURATION`; every step measures the rope's closest approach
to itself (:func:`mjcable.metrics.self_distance`, segments whose capsules do not overlap at rest).

What it reports (:func:`knot_error`, :func:`knot_verdict`): error = the least distance between two segments' centrelines
over the run, in cable radii (≥ 1: no segment passed through another; 2: they only touched); the outcome is
``tunneled`` when it fell below one radius, when the knot came undone (the knot determinant of the final centreline,
:func:`mjcable.knots.knot_determinant`, is no longer 3) or when the ends lie farther apart than the rope's rest length
less the knot's length (:func:`knot_length`).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Optional

import numpy as np

from mjcable import knots, metrics
from mjcable.scene import CableSpec, Pin, Scene

__all__ = ["KnotScene", "knot_scene", "knot_length", "pull", "knot_setup", "knot_drive", "knot_error",
           "knot_verdict", "RADIUS", "CLEARANCE", "TENSION", "PULL_SPEED", "DURATION", "FORCE_WINDOW"]

RADIUS = 0.005  # m
CLEARANCE = 2.0 * RADIUS + 0.002  # m between the start's strands: the rope's diameter and 2 mm
TAIL = 0.3  # m of straight rope either side of the knot
DENSITY = 0.1  # kg/m
TENSION = 2.0  # N: taut (the rope's weight is 0.85 N)
PULL_SPEED = 0.1  # m/s of each gripper while the rope is slack
FORCE_WINDOW = 10  # steps over which the pin force is averaged (a tightening knot's force jumps step to step)
DURATION = 3.0  # s: the knot is taut after about 2 s at 0.1 m/s and held the rest


@dataclasses.dataclass(frozen=True)
class KnotScene(Scene):
    """A knot-family scene with ``runs``: scratch of one run (its drive's record), not part of the scene."""

    runs: dict = dataclasses.field(default_factory=dict, kw_only=True, compare=False, repr=False)


def knot_scene(n_segments: int = 100, **fields) -> KnotScene:
    """The rope tied in the loose overhand knot, both ends held by grippers (pins 0 and 1)."""
    knot = knots.overhand_knot(CLEARANCE, tail=TAIL)
    cable = CableSpec(knot.points, n_segments, RADIUS, DENSITY * knot.length, **fields)
    return KnotScene(cable, pins=(Pin(0, "gripper"), Pin(-1, "gripper")), name="knot")


def knot_length(cable: CableSpec) -> float:
    """The least rope in metres that an overhand knot of ``cable`` takes up: 2π · 2r, the loop that goes once round
    another strand of the rope at the contact distance 2r (a circle of radius 2r about that strand's axis; the
    tight open trefoil takes more, and the loose start about 0.24 m). A knot whose ends lie farther apart than the
    rest length less this has come undone or stretched the rope beyond it."""
    return 2.0 * math.pi * 2.0 * cable.radius


def pull(sim, force: float, *, speed: float = PULL_SPEED, tension: float = TENSION) -> None:
    """Command the next step's gripper positions: each gripper away from the other along the line through them by
    ``speed · dt · clip(1 − force / tension, −1, 1)`` (``force``: the rope's tension now, N)."""
    g = sim.gripper_positions
    axis = (g[1] - g[0]) / np.linalg.norm(g[1] - g[0])
    move = speed * sim.dt * float(np.clip(1.0 - force / tension, -1.0, 1.0)) * axis
    sim.move_gripper(0, g[0] - move)
    sim.move_gripper(1, g[1] + move)


def knot_setup(sim, params: dict) -> None:
    """Start the drive's record in ``sim.scene.runs``."""
    sim.scene.runs.update(distance=[], force=[])


def knot_drive(sim, t: float, params: dict) -> None:
    """Before the step at ``t`` (s): record the rope's closest approach to itself and the grippers' pin force, and
    :func:`pull` at the ``speed`` of ``params`` (m/s, default :data:`PULL_SPEED`)."""
    run = sim.scene.runs
    skip = sim.scene.cable.overlapping_neighbours()
    run["distance"].append(metrics.self_distance(sim.positions, skip=skip)[0])
    run["force"].append(float(np.linalg.norm(sim.pin_forces, axis=1).mean()))
    pull(sim, float(np.mean(run["force"][-FORCE_WINDOW:])), speed=float(params.get("speed", PULL_SPEED)))


def knot_error(scene: KnotScene, x: np.ndarray, history: dict) -> float:
    """The least distance between two segments' centrelines over the run (the final state too), in radii."""
    skip = scene.cable.overlapping_neighbours()
    least = min(min(scene.runs["distance"], default=math.inf), metrics.self_distance(x, skip=skip)[0])
    return least / scene.cable.radius


def knot_verdict(scene: KnotScene, x: np.ndarray) -> Optional[tuple]:
    """``("tunneled", reason)`` when a segment passed within one radius of another (:func:`knot_error` < 1), the
    final centreline's knot determinant is not 3, or its ends lie farther apart than the rest length less
    :func:`knot_length`; ``None`` when the knot held."""
    cable = scene.cable
    least = knot_error(scene, x, {})
    if least < 1.0:
        return "tunneled", f"two segments' centrelines came within {least:.3g} r of each other (a pass-through)"
    determinant = knots.knot_determinant(x)
    if determinant != 3:
        return "tunneled", f"the knot came undone: knot determinant {determinant} at the end (an overhand knot: 3)"
    span = float(np.linalg.norm(x[-1] - x[0]))
    if span > cable.length - knot_length(cable):
        return "tunneled", (f"the ends are {span:.4g} m apart, more than the rest length {cable.length:.4g} m less "
                            f"the knot's {knot_length(cable):.3g} m")
    return None
