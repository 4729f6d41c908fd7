"""The pulley family: an Atwood machine whose rope turns a pulley on a frictionless hinge.

:func:`atwood_scene` builds a user world (:func:`mjcable.worlds.pulley.add_pulley`: a cylinder of radius R and
moment of inertia I on a hinge about y) with two free boxes of masses m₁ (left, heavier) and m₂ hanging on a
rope laid over the pulley's top half, held by body pins at the rope's ends; nothing else in the scene.
:func:`run_atwood` lets it go from rest and records the heavy box's drop and the pulley's spin;
:func:`measure` fits the drop's acceleration over a window after the start (a parabola, numpy's least squares)
and compares it with the heavy-rope Atwood machine (:func:`heavy_rope_drop`), and the rim's speed ω R_c with the
box's.

Reference (inextensible rope of linear density λ and length L, no slip, wrapped half a turn on the radius
R_c = R + r of its centreline; x the heavy box's drop, the legs L₁ = L₁⁰ + x and L₂ = L₂⁰ − x below the axis)::

    (m₁ + m₂ + λ L + I / R_c²) ẍ = g (m₁ − m₂ + λ (L₁ − L₂))

from Lagrange's equation: the kinetic energy ½ (m₁ + m₂ + λ L + I / R_c²) ẋ² (every piece of the rope moves at
ẋ, the pulley turns at ẋ / R_c) and the legs' potential −½ λ g (L₁² + L₂²). With A = g (m₁ − m₂ + λ (L₁⁰ − L₂⁰)) / M
and B = 2 λ g / M: x(t) = (A / B) (cosh(√B t) − 1); for a light rope (λ → 0) the textbook a = g (m₁ − m₂) /
(m₁ + m₂ + I / R_c²). The rope's centreline, not the rim, moves with the rim's points at R_c when it does not slip
(each wrapped particle turns with the pulley on its circle of radius R_c).

No slip needs the tension ratio across the half turn below the capstan law: T₁ / T₂ = m₁ (g − a) / (m₂ (g + a))
< e^{μπ} (:func:`capstan_margin`; the default design needs μ > 0.03 and has μ = 1).

Example::

    from mjcable.bench import pulley
    result = pulley.measure(pulley.run_atwood("xpbd"))
    result.acceleration_error, result.slip        # relative, both within 0.02 and 0.01
"""

from __future__ import annotations

import dataclasses
import math
from typing import Optional

import mujoco
import numpy as np

from mjcable import _validate, reference
from mjcable.scene import CableSpec, Pin, Scene
from mjcable.simulator import Simulator
from mjcable.worlds import pulley as pulley_world

__all__ = [
    "AtwoodScene",
    "atwood_scene",
    "heavy_rope_drop",
    "capstan_margin",
    "Record",
    "run_atwood",
    "record",
    "sampled",
    "sample",
    "from_samples",
    "fit_parabola",
    "bench_drive",
    "acceleration_error",
    "slip_error",
    "Measurement",
    "measure",
    "HEAVY_MASS",
    "LIGHT_MASS",
    "PULLEY_RADIUS",
    "PULLEY_INERTIA",
    "WINDOW",
]

HEAVY_MASS = 2.0  # kg, m₁ (the issue's)
LIGHT_MASS = 1.0  # kg, m₂
PULLEY_RADIUS = 0.1  # m, the rim's R
PULLEY_INERTIA = 5e-3  # kg·m² about the axis: I / R² = 0.5 kg, a sixth of the boxes' masses
PULLEY_MASS = 1.0  # kg (its inertia across the axis plays no part on the hinge)
PULLEY_WIDTH = 0.06  # m
PULLEY_HEIGHT = 1.0  # m, the axis's z
ROPE_RADIUS = 0.004  # m
ROPE_DENSITY = 0.02  # kg/m: a 1.5 m rope of 30 g, 1 % of the boxes
ROPE_FRICTION = 1.0  # μ of the rim on the rope: far above the 0.03 the design needs
HEAVY_LEG = 0.3  # m below the axis at the start: the heavy box falls, its leg grows
LIGHT_LEG = 0.9  # m
BOX_HALF = 0.04  # m, the boxes' half size (cubes)
SEGMENTS = 60
START_CLEARANCE = 5e-4  # m between the pulley and the start arc's chords (as the capstan's)
ARC_POINTS = 19  # control points on the start half circle
DURATION = 0.6  # s of fall: the heavy box drops about 0.5 m
WINDOW = (0.15, 0.6)  # s: the fit's window, after the start transient (the rope settling onto the rim)
SAMPLE_EVERY = 0.005  # s between samples of the boxes and the hinge
HEAVY_BODY, LIGHT_BODY = "heavy_box", "light_box"


@dataclasses.dataclass(frozen=True)
class AtwoodScene(Scene):
    """A :class:`~mjcable.scene.Scene` of the Atwood machine over a pulley, with its design.

    Attributes:
      masses: ``(m₁, m₂)`` kg, the heavy (first pin's) and the light box.
      inertia: kg·m², the pulley's about its axis.
      contact_radius: R_c = R + r in metres: the rope's centreline on the rim.
      mu: the rim's friction coefficient on the rope.
      pulley: the pulley body's name in the world.
      runs: scratch of one benchmark run (its samples, :func:`bench_drive`); not part of the scene.
    """

    masses: tuple = dataclasses.field(default=(HEAVY_MASS, LIGHT_MASS), kw_only=True)
    inertia: float = dataclasses.field(default=PULLEY_INERTIA, kw_only=True)
    contact_radius: float = dataclasses.field(default=PULLEY_RADIUS + ROPE_RADIUS, kw_only=True)
    mu: float = dataclasses.field(default=ROPE_FRICTION, kw_only=True)
    pulley: str = dataclasses.field(default="pulley", kw_only=True)
    runs: dict = dataclasses.field(default_factory=dict, kw_only=True, compare=False, repr=False)


def atwood_scene(n_segments: int = SEGMENTS, *, masses=(HEAVY_MASS, LIGHT_MASS), inertia: float = PULLEY_INERTIA,
                 radius: float = PULLEY_RADIUS, mu: float = ROPE_FRICTION, rope_density: float = ROPE_DENSITY,
                 legs=(HEAVY_LEG, LIGHT_LEG)) -> AtwoodScene:
    """Two free boxes hanging on a limp inextensible rope over a pulley on a frictionless hinge about y.

    The pulley's axis is at (0, 0, :data:`PULLEY_HEIGHT`); the rope starts on a half circle above it whose chords'
    middles are :data:`START_CLEARANCE` clear of the rim, with vertical legs below its ends (x = ∓ the arc's
    radius) whose ends are the boxes' top faces' centres (body pins: the first particle holds m₁, the last m₂).
    The boxes touch nothing.

    Args:
      n_segments: the rope's segments.
      masses: ``(m₁, m₂)`` kg, each > 0.
      inertia: kg·m² of the pulley about its axis (> 0).
      radius: m, the pulley's rim.
      mu: the rim's friction coefficient (>= 0).
      rope_density: kg per metre of rope (> 0).
      legs: ``(heavy, light)`` m, the legs' design lengths below the axis (each > the boxes' size); the start
        arc's excess over π R_c comes off them, half each.
    """
    m1 = _validate.number("masses[0]", masses[0], low=0.0, low_open=True, unit="kg")
    m2 = _validate.number("masses[1]", masses[1], low=0.0, low_open=True, unit="kg")
    legs = tuple(_validate.number(f"legs[{i}]", leg, low=2.0 * BOX_HALF, low_open=True, unit="m")
                 for i, leg in enumerate(legs))
    mu = _validate.number("mu", mu, low=0.0)
    density = _validate.number("rope_density", rope_density, low=0.0, low_open=True, unit="kg/m")
    rc = radius + ROPE_RADIUS
    spec = mujoco.MjSpec()
    spec.option.gravity = [0.0, 0.0, -reference.G]
    name = pulley_world.add_pulley(spec, pos=(0.0, 0.0, PULLEY_HEIGHT), radius=radius, width=PULLEY_WIDTH,
                                   mass=PULLEY_MASS, inertia=inertia, friction=mu)
    total = sum(legs) + math.pi * rc
    l0 = total / n_segments
    start = math.sqrt((rc + START_CLEARANCE) ** 2 + 0.25 * l0 * l0)
    chords = math.pi * start * (1.0 - l0 * l0 / (24.0 * start * start))
    half_excess = 0.5 * (chords - math.pi * rc)
    ends = []
    for body, mass, side, leg in ((HEAVY_BODY, m1, -1.0, legs[0]), (LIGHT_BODY, m2, 1.0, legs[1])):
        top = np.array([side * start, 0.0, PULLEY_HEIGHT - leg + half_excess])
        box = spec.worldbody.add_body(name=body, pos=top - [0.0, 0.0, BOX_HALF])
        box.add_freejoint()
        box.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[BOX_HALF] * 3, mass=mass, contype=0, conaffinity=0,
                     rgba=[0.8, 0.4, 0.2, 1.0])
        ends.append(top)
    step = start * math.pi / (ARC_POINTS - 1)

    def depths(top):  # leg control points doubling away from the arc: the spline stays straight
        leg = PULLEY_HEIGHT - top[2]
        return [d for d in step * 2.0 ** np.arange(1, 30) if d < leg - step] + [leg]

    left = [[-start, 0.0, PULLEY_HEIGHT - d] for d in reversed(depths(ends[0]))]
    arc = [[-start * math.cos(a), 0.0, PULLEY_HEIGHT + start * math.sin(a)]
           for a in np.linspace(0.0, math.pi, ARC_POINTS)]
    right = [[start, 0.0, PULLEY_HEIGHT - d] for d in depths(ends[1])]
    cable = CableSpec(left + arc + right, n_segments, ROPE_RADIUS, density * total, friction=mu)
    pins = (Pin(0, "body", body=HEAVY_BODY, offset=(0.0, 0.0, BOX_HALF)),
            Pin(-1, "body", body=LIGHT_BODY, offset=(0.0, 0.0, BOX_HALF)))
    return AtwoodScene(cable, pins, world=spec, name="pulley", masses=(m1, m2), inertia=inertia, contact_radius=rc,
                       mu=mu, pulley=name)


def heavy_rope_drop(times, scene: AtwoodScene, *, g: float = reference.G) -> np.ndarray:
    """The heavy box's drop x(t) in metres at ``times`` (s, ``(m,)``) from rest: the heavy-rope Atwood machine with
    a pulley (module docstring), its legs' difference L₁⁰ − L₂⁰ that of the scene's start (the pins' heights)."""
    m1, m2 = scene.masses
    cable = scene.cable
    density = cable.mass / cable.length
    rc = scene.contact_radius
    inertial = m1 + m2 + cable.mass + scene.inertia / rc**2
    z = np.asarray(cable.particles)[[0, -1], 2]
    difference = z[1] - z[0]  # L₁ − L₂: the heavy end lower is a longer heavy leg
    a0 = g * (m1 - m2 + density * difference) / inertial
    b = 2.0 * density * g / inertial
    t = np.asarray(times, dtype=np.float64)
    return a0 / b * (np.cosh(np.sqrt(b) * t) - 1.0)


def capstan_margin(scene: AtwoodScene, *, g: float = reference.G) -> float:
    """How far below the capstan law the light-rope tension ratio across the half turn lies:
    (T₁ / T₂) / e^{μπ}, T₁ = m₁ (g − a), T₂ = m₂ (g + a); below 1, the rope turns the pulley without slip."""
    m1, m2 = scene.masses
    a = g * (m1 - m2) / (m1 + m2 + scene.inertia / scene.contact_radius**2)
    return (m1 * (g - a)) / (m2 * (g + a)) / reference.capstan_ratio(scene.mu)


@dataclasses.dataclass(frozen=True)
class Record:
    """A run of the Atwood machine: ``times`` (m,) s, the heavy box's ``drop`` (m,) m (its centre's fall from
    the start), its downward speed ``speed`` (m,) m/s, the pulley's ``rim_speed`` (m,) m/s (the hinge's
    ω · R_c, positive when it turns with the heavy box falling), the rope's ``rope_speed`` (m,) m/s along the rim
    (its particles' on the pulley's upper half, averaged), and the ``scene``."""

    times: np.ndarray
    drop: np.ndarray
    speed: np.ndarray
    rim_speed: np.ndarray
    rope_speed: np.ndarray
    scene: AtwoodScene


def run_atwood(model: str, *, dt: float = 0.002, scene: Optional[AtwoodScene] = None, duration: float = DURATION,
               **settings) -> Record:
    """Simulate ``scene`` (default :func:`atwood_scene`) from rest with ``model`` for ``duration`` s, sampling
    every :data:`SAMPLE_EVERY`."""
    scene = atwood_scene() if scene is None else scene
    return record(Simulator(scene, model, dt=dt, **settings), duration)


def record(sim: Simulator, duration: float) -> Record:
    """Run ``sim`` (an :func:`atwood_scene`) for ``duration`` s from where it is, sampling every
    :data:`SAMPLE_EVERY`."""
    return from_samples(sampled(sim, duration, sample), sim.scene)


def sampled(sim: Simulator, duration: float, sample_of) -> list:
    """Run ``sim`` for ``duration`` s from where it is: the rows ``sample_of(sim)`` at the start and every
    :data:`SAMPLE_EVERY` (whole steps)."""
    every = max(1, int(round(SAMPLE_EVERY / sim.dt)))
    rows = [sample_of(sim)]
    for _ in range(int(round(duration / (every * sim.dt)))):
        sim.step(every * sim.dt)
        rows.append(sample_of(sim))
    return rows


def sample(sim: Simulator) -> tuple:
    """One sample of ``sim`` (an :func:`atwood_scene`): ``(time s, the heavy box's height m, its downward speed
    m/s, the rim's speed m/s, the rope's speed on the rim m/s)`` (:class:`Record`)."""
    m, d = sim.mj_model, sim.mj_data
    box = m.body(HEAVY_BODY).id
    dof = int(m.joint(pulley_world.hinge_name(sim.scene.pulley)).dofadr[0])
    linear = int(m.jnt_dofadr[m.body_jntadr[box]])  # the free joint's first three: the linear velocity
    # the hinge's axis is +y: the heavy box on the left (−x) falls as the pulley turns by −ω about y
    return (sim.time, float(d.xpos[box, 2]), -float(d.qvel[linear + 2]), -float(d.qvel[dof]) * sim.scene.contact_radius,
            _wrap_speed(sim.positions, sim.velocities))


def from_samples(rows, scene: AtwoodScene) -> Record:
    """The :class:`Record` of :func:`sample`'s ``rows`` (the first one at the start) of ``scene``."""
    t, z, speed, rim, rope = np.array(rows, dtype=np.float64).T
    return Record(times=t, drop=z[0] - z, speed=speed, rim_speed=rim, rope_speed=rope, scene=scene)


def _wrap_speed(x: np.ndarray, v: np.ndarray) -> float:
    """m/s: the mean speed along the rim (towards −x over the top: with the heavy box falling) of the rope's
    particles on the pulley's upper half, (n, 3) positions ``x`` and velocities ``v``."""
    r = x[:, [0, 2]] - [0.0, PULLEY_HEIGHT]
    on = r[:, 1] > 0.0
    tangent = np.stack([-r[on, 1], r[on, 0]], axis=1) / np.linalg.norm(r[on], axis=1)[:, None]
    return float(np.mean(np.sum(v[on][:, [0, 2]] * tangent, axis=1))) if on.any() else math.nan


@dataclasses.dataclass(frozen=True)
class Measurement:
    """What :func:`measure` found.

    Attributes:
      acceleration: m/s², the heavy box's, fitted over the window.
      expected: m/s², the heavy-rope reference's, fitted alike over the same window.
      acceleration_error: |acceleration / expected − 1|.
      slip: |mean rim speed / mean box speed − 1| over the window's second half (0: the rope turns the pulley
        without slip).
    """

    acceleration: float
    expected: float
    acceleration_error: float
    slip: float


def fit_parabola(times, values) -> float:
    """The second derivative in m/s² of the least-squares parabola c₀ + c₁ t + c₂ t² through ``values(times)``."""
    return 2.0 * float(np.polyfit(np.asarray(times, dtype=np.float64), np.asarray(values, dtype=np.float64), 2)[0])


def measure(run: Record, *, window=WINDOW) -> Measurement:
    """The acceleration error and the slip of ``run`` over ``window`` (s, ``(start, end)``)."""
    inside = (run.times >= window[0] - 1e-9) & (run.times <= window[1] + 1e-9)
    if np.count_nonzero(inside) < 5:
        raise ValueError(f"window must hold at least 5 samples of the run (times {run.times[0]:g} to "
                         f"{run.times[-1]:g} s), got {window!r}")
    t = run.times[inside]
    a = fit_parabola(t, run.drop[inside])
    expected = fit_parabola(t, heavy_rope_drop(t, run.scene))
    late = t >= 0.5 * (t[0] + t[-1])
    slip = abs(float(np.mean(run.rim_speed[inside][late])) / float(np.mean(run.speed[inside][late])) - 1.0)
    return Measurement(acceleration=a, expected=expected, acceleration_error=abs(a / expected - 1.0), slip=slip)


# ------------------------------------------------------------------------------- the benchmark's scenarios' hooks


def bench_drive(sim: Simulator, t: float, params: dict) -> None:
    """The ``pulley`` scenarios' drive: it drives nothing, and records a :func:`sample` before each of the runner's
    samples (every 5 ms) into the scene's ``runs``."""
    sim.scene.runs.setdefault("rows", []).append(sample(sim))


def _measured(scene: AtwoodScene) -> Measurement:
    return measure(from_samples(scene.runs.pop("rows"), scene))


def acceleration_error(scene: AtwoodScene, x: np.ndarray, history: dict) -> float:
    """The ``pulley`` scenario's error: :attr:`Measurement.acceleration_error` of the run's samples."""
    return _measured(scene).acceleration_error


def slip_error(scene: AtwoodScene, x: np.ndarray, history: dict) -> float:
    """The ``pulley_slip`` scenario's error: :attr:`Measurement.slip` of the run's samples."""
    return _measured(scene).slip
