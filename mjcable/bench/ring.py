"""The ring family: an Atwood machine whose light rope runs through a small ring (a pinhole) fixed above two boxes.

:func:`atwood_scene` builds a user world with two free boxes of masses m₁ (left, heavier) and m₂ hanging from the
ends of a limp rope (body pins at their top faces' centres) that rises from each box to a ring at
(0, 0, :data:`RING_HEIGHT`) with its axis along x: the rope turns through θ = π − 2 atan(d / L) there (d the boxes'
half spacing, L a leg; nearly a half turn). Nothing touches. :func:`run_atwood` lets it go from rest and records the
heavy box's drop (the rope starts on a half circle of radius d through the ring's centre, 3 mm longer than its
taut legs: the boxes fall that far before it pulls); :func:`measure` fits its acceleration (a parabola over
:data:`WINDOW`, numpy's least squares).

References. Frictionless: the heavy-rope Atwood machine without a pulley (:func:`mjcable.bench.pulley.heavy_rope_drop`
at I = 0; light rope: a = g (m₁ − m₂) / (m₁ + m₂)). With rim friction μ (:mod:`mjcable.solvers.ring_kernels`): the
boxes hold while T₁ / T₂ = m₁ / m₂ ≤ e^{μθ} (at rest T = m g), and beyond it slide with the kinetic capstan law
T₁ = e^{μθ} T₂, m₁ (g − a) = e^{μθ} m₂ (g + a), so a = g (m₁ − e^{μθ} m₂) / (m₁ + e^{μθ} m₂) (:func:`sliding`).

Example::

    from mjcable.bench import ring
    ring.measure(ring.run_atwood("xpbd")).acceleration_error    # within 0.02
"""

from __future__ import annotations

import dataclasses
import math
from typing import Optional

import mujoco
import numpy as np

from mjcable import _validate, reference
from mjcable.bench import pulley
from mjcable.rings import Ring
from mjcable.scene import CableSpec, Pin, Scene
from mjcable.simulator import Simulator

__all__ = ["RingAtwoodScene", "atwood_scene", "hold_scene", "slide_scene", "run_atwood", "record", "Measurement",
           "measure", "sliding", "turn", "creep", "bench_drive", "acceleration_error", "hold_error"]

HEAVY_MASS, LIGHT_MASS = 2.0, 1.0  # kg (the issue's)
RING_HEIGHT = 1.0  # m, the ring's centre's z
LEG = 0.5  # m, each leg's length from the ring to a box's top at the start
SPACING = 0.01  # m, each box's top from the ring's vertical (the rope turns by about π − 2 atan(0.02) = 0.987 π)
ROPE_RADIUS = 0.002  # m
ROPE_DENSITY = 0.02  # kg/m: 20 g of rope, 1 % of the boxes
BOX_HALF = 0.04  # m (cubes; the boxes touch nothing)
SEGMENTS = 50
DURATION = 0.5  # s
WINDOW = (0.1, 0.5)  # s: the fit's window
SAMPLE_EVERY = pulley.SAMPLE_EVERY  # s between samples (pulley.sampled's)
HEAVY_BODY, LIGHT_BODY = "heavy_box", "light_box"
MU = 0.3  # the rim's friction of the threshold's runs (the issue's)
HOLD_RATIO, SLIDE_RATIO = 0.85, 1.15  # m₁ / m₂ over e^{μπ}: below the capstan law's threshold, above it
HOLD_DURATION = 1.0  # s: a held machine's run
HOLD_SETTLED = 0.7  # s: from when a held machine's creep is measured (the start's slack taken up)


@dataclasses.dataclass(frozen=True)
class RingAtwoodScene(Scene):
    """A :class:`~mjcable.scene.Scene` of the Atwood machine through a ring, with its design: ``masses`` (m₁, m₂)
    kg, the ring's ``mu``; ``inertia`` 0 and ``contact_radius`` 1 m make it :func:`pulley.heavy_rope_drop`'s machine
    without a pulley; ``runs`` is one benchmark run's scratch."""

    masses: tuple = dataclasses.field(default=(HEAVY_MASS, LIGHT_MASS), kw_only=True)
    mu: float = dataclasses.field(default=0.0, kw_only=True)
    inertia: float = dataclasses.field(default=0.0, kw_only=True)
    contact_radius: float = dataclasses.field(default=1.0, kw_only=True)
    runs: dict = dataclasses.field(default_factory=dict, kw_only=True, compare=False, repr=False)


def atwood_scene(n_segments: int = SEGMENTS, *, masses=(HEAVY_MASS, LIGHT_MASS), mu: float = 0.0,
                 rope_density: float = ROPE_DENSITY) -> RingAtwoodScene:
    """Two free boxes (``masses`` m₁, m₂ kg, each > 0) on a limp rope of ``n_segments`` segments
    (``rope_density`` kg/m) through a ring with rim friction ``mu`` (module docstring)."""
    m1 = _validate.number("masses[0]", masses[0], low=0.0, low_open=True, unit="kg")
    m2 = _validate.number("masses[1]", masses[1], low=0.0, low_open=True, unit="kg")
    mu = _validate.number("mu", mu, low=0.0)
    density = _validate.number("rope_density", rope_density, low=0.0, low_open=True, unit="kg/m")
    spec = mujoco.MjSpec()
    spec.option.gravity = [0.0, 0.0, -reference.G]
    arc_top = RING_HEIGHT - SPACING  # the start's half circle of radius d through the ring's centre
    top = arc_top - LEG  # the boxes' top faces
    for body, mass, side in ((HEAVY_BODY, m1, -1.0), (LIGHT_BODY, m2, 1.0)):
        box = spec.worldbody.add_body(name=body, pos=[side * SPACING, 0.0, top - BOX_HALF])
        box.add_freejoint()
        box.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[BOX_HALF] * 3, mass=mass, contype=0, conaffinity=0,
                     rgba=[0.8, 0.4, 0.2, 1.0])
    depths = (LEG, LEG / 2, LEG / 4, LEG / 8, LEG / 25)
    left = [[-SPACING, 0.0, arc_top - d] for d in depths]
    arc = [[-SPACING * math.cos(a), 0.0, arc_top + SPACING * math.sin(a)] for a in np.linspace(0.0, math.pi, 9)]
    right = [[SPACING, 0.0, arc_top - d] for d in reversed(depths)]
    cable = CableSpec(left + arc + right, n_segments, ROPE_RADIUS, density * (2.0 * LEG + math.pi * SPACING))
    pins = (Pin(0, "body", body=HEAVY_BODY, offset=(0.0, 0.0, BOX_HALF)),
            Pin(-1, "body", body=LIGHT_BODY, offset=(0.0, 0.0, BOX_HALF)))
    rings = (Ring((0.0, 0.0, RING_HEIGHT), (1.0, 0.0, 0.0), friction=mu),)
    return RingAtwoodScene(cable, pins, world=spec, rings=rings,
                           name="ring", masses=(m1, m2), mu=mu)


def turn(scene: RingAtwoodScene) -> float:
    """rad: the rope's turn through the ring once taut, θ = π − 2 atan(d / (L + d))."""
    return math.pi - 2.0 * math.atan(SPACING / (LEG + SPACING))


def sliding(scene: RingAtwoodScene, *, g: float = reference.G) -> float:
    """m/s²: the light-rope acceleration of the heavy box sliding against the ring's friction, g (m₁ − E m₂) /
    (m₁ + E m₂), E = e^{μθ} (0 while m₁ ≤ E m₂: the boxes hold)."""
    m1, m2 = scene.masses
    e = math.exp(scene.mu * turn(scene))
    return max(0.0, g * (m1 - e * m2) / (m1 + e * m2))


def run_atwood(model: str, *, dt: float = 0.002, scene: Optional[RingAtwoodScene] = None,
               duration: float = DURATION, **settings) -> pulley.Record:
    """Simulate ``scene`` (default :func:`atwood_scene`) from rest with ``model`` for ``duration`` s."""
    scene = atwood_scene() if scene is None else scene
    return record(Simulator(scene, model, dt=dt, **settings), duration)


def _sample(sim: Simulator) -> tuple:
    """``(time s, the heavy box's height m, its downward speed m/s)``."""
    m, d = sim.mj_model, sim.mj_data
    box = m.body(HEAVY_BODY).id
    linear = int(m.jnt_dofadr[m.body_jntadr[box]])
    return sim.time, float(d.xpos[box, 2]), -float(d.qvel[linear + 2])


def record(sim: Simulator, duration: float) -> pulley.Record:
    """Run ``sim`` (an :func:`atwood_scene`) for ``duration`` s, sampling every :data:`SAMPLE_EVERY`: a
    :class:`pulley.Record` whose rim and rope speeds are NaN (no pulley)."""
    return _record(pulley.sampled(sim, duration, _sample), sim.scene)


def _record(rows, scene) -> pulley.Record:
    t, z, speed = np.array(rows, dtype=np.float64).T
    return pulley.Record(times=t, drop=z[0] - z, speed=speed, rim_speed=np.full_like(t, math.nan),
                         rope_speed=np.full_like(t, math.nan), scene=scene)


@dataclasses.dataclass(frozen=True)
class Measurement:
    """What :func:`measure` found: the heavy box's ``acceleration`` (m/s², fitted over the window), the ``expected``
    one (the frictionless heavy-rope reference's, or :func:`sliding`'s), their ``acceleration_error``
    (|a / expected − 1|), and the heavy box's ``speed`` at the run's end (m/s)."""

    acceleration: float
    expected: float
    acceleration_error: float
    speed: float


def measure(run: pulley.Record, *, window=WINDOW) -> Measurement:
    """The acceleration of ``run`` over ``window`` (s) against the reference of its scene's friction."""
    inside = (run.times >= window[0] - 1e-9) & (run.times <= window[1] + 1e-9)
    t = run.times[inside]
    a = pulley.fit_parabola(t, run.drop[inside])
    if run.scene.mu == 0.0:
        expected = pulley.fit_parabola(t, pulley.heavy_rope_drop(t, run.scene))
    else:
        expected = sliding(run.scene)
    error = abs(a / expected - 1.0) if expected > 0.0 else abs(a)
    return Measurement(acceleration=a, expected=expected, acceleration_error=error, speed=float(run.speed[-1]))


# ------------------------------------------------------------------------------- the benchmark's scenarios' hooks


def bench_drive(sim: Simulator, t: float, params: dict) -> None:
    """The ``ring`` scenarios' drive: drives nothing, records a sample before each of the runner's samples."""
    sim.scene.runs.setdefault("rows", []).append(_sample(sim))


def acceleration_error(scene: RingAtwoodScene, x: np.ndarray, history: dict) -> float:
    """The ``ring`` and ``ring_slide`` scenarios' error: :attr:`Measurement.acceleration_error` of the run's
    samples (against the frictionless reference, or :func:`sliding`)."""
    return measure(_record(scene.runs.pop("rows"), scene)).acceleration_error


def creep(run: pulley.Record, since: float = HOLD_SETTLED) -> float:
    """m/s: the heavy box's mean speed from ``since`` (s) to the run's end (its drop over that time)."""
    late = run.times >= since - 1e-9
    return float((run.drop[late][-1] - run.drop[late][0]) / (run.times[late][-1] - run.times[late][0]))


def hold_error(scene: RingAtwoodScene, x: np.ndarray, history: dict) -> float:
    """The ``ring_hold`` scenario's error: |:func:`creep`| in m/s (0: the ring's friction holds the boxes)."""
    return abs(creep(_record(scene.runs.pop("rows"), scene)))


def hold_scene(n_segments: int = SEGMENTS) -> RingAtwoodScene:
    """The ``ring_hold`` scenario's machine: μ = :data:`MU`, m₁ / m₂ = 0.85 e^{μπ} (it must hold)."""
    return atwood_scene(n_segments, mu=MU, masses=(HOLD_RATIO * math.exp(MU * math.pi), 1.0))


def slide_scene(n_segments: int = SEGMENTS) -> RingAtwoodScene:
    """The ``ring_slide`` scenario's machine: μ = :data:`MU`, m₁ / m₂ = 1.15 e^{μπ} (it slides, :func:`sliding`)."""
    return atwood_scene(n_segments, mu=MU, masses=(SLIDE_RATIO * math.exp(MU * math.pi), 1.0))
