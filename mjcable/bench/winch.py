"""The winch family: a winch lifts a box on a rope and lowers it again.

:func:`lift_scene` builds a user world with one free box of mass M hanging on a vertical rope of mass per metre ρ
below a winch fixed in the world (``Pin(index, "winch")``, the rope's spooled part straight above it, parked on the
winch), the rope's last particle a body pin at the box's top face. :func:`run_lift` holds it at rest for
:data:`SETTLE`, reels in at :data:`SPEED` for :data:`DURATION`, rests, pays the same length out and rests again
(:func:`speed_at`), recording the box's height, the winch's pull and the free length; :func:`measure` compares
them with the references:

* the box rises by the reeled length |speed| · duration (an inextensible rope);
* while the winch reels steadily the winch's pull is the weight it holds, (M + ρ L) g with L the free length: the
  rope moves at a constant speed, and the momentum the reeled rope carries onto the spool, ρ v², is 4e-4 of it
  at the design's speed;
* the rope's mass per metre from the pull at rest at the two free lengths, (F₁ − F₀) / (g (L₁ − L₀)), is ρ;
* paying the same length out puts the box back where it started.

Example::

    from mjcable.bench import winch
    result = winch.measure(winch.run_lift("xpbd"))
    result.rise_error, result.pull_error, result.density_error, result.return_error
"""

from __future__ import annotations

import dataclasses
from typing import Optional

import mujoco
import numpy as np

from mjcable import _validate, reference
from mjcable.scene import CableSpec, Pin, Scene
from mjcable.simulator import Simulator

__all__ = ["LiftScene", "lift_scene", "speed_at", "Record", "sample", "run_lift", "drive", "from_samples",
           "Measurement", "measure", "bench_drive", "travel_error", "pull_error", "BOX_MASS", "DENSITY",
           "FREE_LENGTH", "SPEED", "DURATION", "TOTAL"]

BOX_MASS = 1.0  # kg (the issue's)
DENSITY = 0.5  # kg/m of rope: its weight on the winch, 0.5 kg at the start, a third of the load
FREE_LENGTH = 1.0  # m below the winch at the start (the issue's)
SPOOLED = 0.4  # m on the spool at the start
SEGMENTS = 70  # the rope's: 2 cm each
SAMPLE_EVERY = 0.01  # s
SPEED = 0.1  # m/s (the issue's)
DURATION = 3.0  # s of reeling (the issue's): 0.3 m
SETTLE = 1.0  # s of rest before, between and after the reeling
WINCH_HEIGHT = 1.5  # m
ROPE_RADIUS = 0.003  # m
BOX_HALF = 0.04  # m, the box's half size (a cube)
DAMPING = 0.0  # 1/s: the rope moves without drag (a damped rope would pull c ρ L v more while it moves)
STEADY = 0.5  # s after a reel starts from which its pull is steady (the rope's start transient gone)
BOX_BODY = "box"


@dataclasses.dataclass(frozen=True)
class LiftScene(Scene):
    """A :class:`~mjcable.scene.Scene` of a winch above a box, with its design: the box's ``box_mass`` (kg), the
    rope's ``density`` (kg/m) and its ``free_length`` (m) below the winch at the start; ``runs``: scratch of one
    benchmark run (its samples, :func:`bench_drive`), not part of the scene."""

    box_mass: float = dataclasses.field(default=BOX_MASS, kw_only=True)
    density: float = dataclasses.field(default=DENSITY, kw_only=True)
    free_length: float = dataclasses.field(default=FREE_LENGTH, kw_only=True)
    runs: dict = dataclasses.field(default_factory=dict, kw_only=True, compare=False, repr=False)


def lift_scene(n_segments: int = SEGMENTS, *, box_mass: float = BOX_MASS, density: float = DENSITY) -> LiftScene:
    """A free box of ``box_mass`` kg hanging on a limp inextensible rope of ``density`` kg/m below a winch at
    (0, 0, :data:`WINCH_HEIGHT`): the rope, :data:`FREE_LENGTH` + :data:`SPOOLED` m long in ``n_segments`` segments,
    runs straight up from the box's top face, and the part above the winch (the nearest whole segments to
    :data:`SPOOLED` m) starts on the spool, parked on the winch. The box touches nothing."""
    n = _validate.integer("n_segments", n_segments, low=4)
    box_mass = _validate.number("box_mass", box_mass, low=0.0, low_open=True, unit="kg")
    density = _validate.number("density", density, low=0.0, low_open=True, unit="kg/m")
    length = FREE_LENGTH + SPOOLED
    spooled = min(max(round(n * SPOOLED / length), 1), n - 2)
    free = (n - spooled) * length / n
    top, bottom = WINCH_HEIGHT + spooled * length / n, WINCH_HEIGHT - free
    spec = mujoco.MjSpec()
    spec.option.gravity = [0.0, 0.0, -reference.G]
    box = spec.worldbody.add_body(name=BOX_BODY, pos=[0.0, 0.0, bottom - BOX_HALF])
    box.add_freejoint()
    box.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[BOX_HALF] * 3, mass=box_mass, contype=0, conaffinity=0,
                 rgba=[0.8, 0.4, 0.2, 1.0])
    cable = CableSpec([[0.0, 0.0, top], [0.0, 0.0, WINCH_HEIGHT], [0.0, 0.0, bottom]], n, ROPE_RADIUS,
                      density * length, damping=DAMPING)
    pins = (Pin(spooled, "winch"), Pin(-1, "body", body=BOX_BODY, offset=(0.0, 0.0, BOX_HALF)))
    return LiftScene(cable, pins, world=spec, name="winch", box_mass=box_mass, density=density, free_length=free)


def speed_at(t: float) -> float:
    """m/s: the winch's speed at time ``t`` (s) of a lift: at rest for :data:`SETTLE`, reeling in at :data:`SPEED`
    for :data:`DURATION`, at rest, paying out as long at the same speed, at rest."""
    phase = (SETTLE, DURATION, SETTLE, DURATION)
    edges = np.cumsum(phase)
    k = int(np.searchsorted(edges, t + 1e-9, side="right"))
    return (0.0, -SPEED, 0.0, SPEED, 0.0)[k]


TOTAL = 3.0 * SETTLE + 2.0 * DURATION  # s: a lift's whole run


@dataclasses.dataclass(frozen=True)
class Record:
    """A lift, sampled every :data:`SAMPLE_EVERY`: ``times`` (m,) s, the box's height ``box`` (m,) m, the winch's
    ``pull`` (m,) N (its pin force's upward component), the ``free_length`` (m,) m, and the ``scene``."""

    times: np.ndarray
    box: np.ndarray
    pull: np.ndarray
    free_length: np.ndarray
    scene: LiftScene


def sample(sim: Simulator) -> tuple:
    """One sample of ``sim`` (a :func:`lift_scene`): ``(time s, box height m, pull N, free length m)``."""
    return (sim.time, float(sim.mj_data.body(BOX_BODY).xpos[2]), float(sim.pin_forces[0][2]), sim.free_length(0))


def run_lift(model: str, *, dt: float = 0.002, scene: Optional[LiftScene] = None, **settings) -> Record:
    """Lift the box of ``scene`` (default :func:`lift_scene`) with ``model`` (:func:`speed_at`), sampling every
    :data:`SAMPLE_EVERY` s."""
    sim = Simulator(lift_scene() if scene is None else scene, model, dt=dt, **settings)
    rows = []
    for _ in range(int(round(TOTAL / SAMPLE_EVERY))):
        drive(sim, rows)
        sim.step(SAMPLE_EVERY)
    rows.append(sample(sim))
    return from_samples(rows, sim.scene)


def drive(sim: Simulator, rows: list) -> None:
    """Set the winch's speed for the time ``sim`` is at (:func:`speed_at`) and append a :func:`sample` to ``rows``."""
    sim.reel(0, speed_at(sim.time))
    rows.append(sample(sim))


def from_samples(rows, scene: LiftScene) -> Record:
    t, box, pull, free = np.array(rows, dtype=np.float64).T
    return Record(times=t, box=box, pull=pull, free_length=free, scene=scene)


@dataclasses.dataclass(frozen=True)
class Measurement:
    """What :func:`measure` found.

    Attributes:
      rise: m, the box's rise from rest before the reeling to rest after it.
      rise_error: m, |rise − :data:`SPEED` · :data:`DURATION`|.
      pull_error: the largest |pull / ((M + ρ L) g) − 1| while the winch reels steadily (from :data:`STEADY` after
        a reel starts until it stops, reeling in and paying out).
      density: kg/m, the rope's mass per metre from the pull at rest before and after the reeling,
        (F₀ − F₁) / (g (L₀ − L₁)).
      density_error: |density / ρ − 1|.
      return_error: m, how far from its start the box comes to rest after paying out.
    """

    rise: float
    rise_error: float
    pull_error: float
    density: float
    density_error: float
    return_error: float


def measure(run: Record, *, g: float = reference.G) -> Measurement:
    """The errors of a :func:`run_lift` (module docstring)."""
    t = run.times
    ends = np.cumsum((SETTLE, DURATION, SETTLE, DURATION, SETTLE))

    def at(time):  # the sample at ``time``
        return int(np.argmin(np.abs(t - time)))

    before, after, last = at(ends[0]), at(ends[2]), len(t) - 1
    steady = np.zeros(len(t), dtype=bool)
    for start, stop in ((ends[0], ends[1]), (ends[2], ends[3])):
        steady |= (t >= start + STEADY - 1e-9) & (t <= stop + 1e-9)
    scene = run.scene
    expected = (scene.box_mass + scene.density * run.free_length[steady]) * g
    rise = run.box[after] - run.box[before]
    density = (run.pull[before] - run.pull[after]) / (g * (run.free_length[before] - run.free_length[after]))
    return Measurement(rise=rise, rise_error=abs(rise - SPEED * DURATION),
                       pull_error=float(np.max(np.abs(run.pull[steady] / expected - 1.0))), density=density,
                       density_error=abs(density / scene.density - 1.0),
                       return_error=abs(run.box[last] - run.box[before]))


# ------------------------------------------------------------------------------- the benchmark's scenarios' hooks


def bench_drive(sim: Simulator, t: float, params: dict) -> None:
    """The ``winch`` scenarios' drive (before each of the runner's samples): :func:`drive`, into the scene's
    ``runs``."""
    drive(sim, sim.scene.runs.setdefault("rows", []))


def _measured(scene: LiftScene) -> Measurement:
    return measure(from_samples(scene.runs.pop("rows"), scene))


def travel_error(scene: LiftScene, x: np.ndarray, history: dict) -> float:
    """The ``winch`` scenario's error (m): the larger of :attr:`Measurement.rise_error` and
    :attr:`Measurement.return_error` of the run's samples."""
    found = _measured(scene)
    return max(found.rise_error, found.return_error)


def pull_error(scene: LiftScene, x: np.ndarray, history: dict) -> float:
    """The ``winch_pull`` scenario's error (relative): the larger of :attr:`Measurement.pull_error` and
    :attr:`Measurement.density_error` of the run's samples."""
    found = _measured(scene)
    return max(found.pull_error, found.density_error)
