"""The harness family of the benchmark: several cables joined at junctions (issue 22).

``harness``: the Y-harness, three cables of :data:`LEG` metres from three pins at different heights
(:data:`PINS`) to one junction (two ball :class:`~mjcable.joins.Junction` s joining their last particles), damped
to rest; error = the largest distance in metres of a particle from the discrete reference (three rigid-link chains
with the models' lumped masses, meeting where their tensions and the junction's weight balance,
:func:`mjcable.reference_harness.y_harness`). ``n_segments`` counts each leg's segments. Models that cannot hold
several cables with junctions are ``rejected`` (their ``ValueError`` says why).
"""

from __future__ import annotations

import numpy as np
from scipy import optimize

from mjcable import reference_harness
from mjcable.joins import Junction, Pin
from mjcable.scene import CableSpec, Scene

__all__ = ["LEG", "JUNCTION", "PINS", "RADIUS", "LEG_MASS", "DAMPING", "y_harness_scene", "y_harness_reference",
           "y_harness_error"]

LEG = 0.6  # m, each leg
JUNCTION = np.array([0.0, 0.0, 0.8])  # m, where the legs' start curves meet
PINS = np.array([[-0.45, 0.0, 1.0], [0.3, 0.3, 0.95], [0.1, -0.4, 0.85]])  # m, the legs' pins, at three heights
RADIUS = 0.004  # m
LEG_MASS = 0.05  # kg per leg
DAMPING = 3.0  # 1/s: settles the harness within a few seconds


def _leg(pin: np.ndarray, sag: float, n: int) -> CableSpec:
    return CableSpec([pin, pin + 0.5 * (JUNCTION - pin) + [0.0, 0.0, -sag], JUNCTION], n, RADIUS, LEG_MASS,
                     damping=DAMPING)


def y_harness_scene(n_segments: int) -> Scene:
    """The Y-harness: three legs of ``n_segments`` segments, each from its pin (index 0, pinned in the world) to
    the junction (index −1), starting on a sagging curve of exactly :data:`LEG` metres (to 1e-12 m)."""
    legs = [_leg(p, optimize.brentq(lambda s: _leg(p, s, n_segments).length - LEG, 0.0, 0.5, xtol=1e-14),
                 n_segments) for p in PINS]
    return Scene(legs, [Pin(0, cable=c) for c in range(len(legs))],
                 junctions=(Junction((0, -1), (1, -1)), Junction((0, -1), (2, -1))), name="y_harness")


def y_harness_reference(scene: Scene) -> reference_harness.Harness:
    """The discrete reference of :func:`y_harness_scene`'s ``scene`` (its legs' lengths, masses and segments)."""
    return reference_harness.y_harness(PINS, [c.length for c in scene.cables], [c.mass for c in scene.cables],
                                       [c.n_segments for c in scene.cables])


def y_harness_error(scene: Scene, positions, history=None) -> float:
    """m: the largest distance of ``positions`` (``(scene.n_particles, 3)``, metres, cable order) from
    :func:`y_harness_reference` (each leg read from its junction to its pin)."""
    x = np.asarray(positions, dtype=np.float64)
    return reference_harness.harness_error([x[part][::-1] for part in scene.cable_slices], y_harness_reference(scene))
