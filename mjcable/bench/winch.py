"""The winch family: a winch lifts a box on a rope and lowers it again.

:func:`lift_scene` builds a user world with one free box of mass M hanging on a vertical rope of mass per metre ρ
below a winch fixed in the world (``Pin(index, "winch")``, the rope's spooled part straight above it, parked on the
winch), the rope's last particle a body pin at the box's top face. :func:`run_lift` lets it settle, reels in at
``speed`` for ``duration`` seconds, lets it settle again, pays the same length out and settles once more, recording
the box's height, the winch's pin force and the free length; :func:`measure` compares them with the references:

* the box rises by the reeled length |speed| · duration (an inextensible rope);
* while the winch reels steadily the winch's pull is the weight it holds, (M + ρ L) g with L the free length: the
  rope moves at a constant speed, and the momentum the reeled rope carries onto the spool, ρ v², is below 1e-4 of
  it at the design's speed;
* the rope's mass per metre from the pull at rest at the two free lengths, (F₁ − F₀) / (g (L₁ − L₀)), is ρ;
* paying the same length out puts the box back where it started.

Example::

    from mjcable.bench import winch
    result = winch.measure(winch.run_lift("xpbd"))
    result.rise_error, result.pull_error, result.density_error, result.return_error
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from mjcable import _validate, reference
from mjcable.scene import CableSpec, Pin, Scene
from mjcable.simulator import Simulator

__all__ = ["LiftScene", "lift_scene", "Record", "run_lift", "Measurement", "measure", "bench_drive", "rise_error",
           "pull_error", "BOX_MASS", "DENSITY", "FREE_LENGTH", "SPEED", "DURATION"]

BOX_MASS = 1.0  # kg (the issue's)
DENSITY = 0.5  # kg/m of rope: its weight on the winch, 0.5 kg at the start, a third of the load
FREE_LENGTH = 1.0  # m below the winch at the start (the issue's)
SPOOLED = 0.4  # m on the spool at the start
SEGMENT = 0.02  # m
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
    rope's ``density`` (kg/m) and its ``free_length`` (m) below the winch at the start."""

    box_mass: float = dataclasses.field(default=BOX_MASS, kw_only=True)
    density: float = dataclasses.field(default=DENSITY, kw_only=True)
    free_length: float = dataclasses.field(default=FREE_LENGTH, kw_only=True)


def lift_scene(*, box_mass: float = BOX_MASS, density: float = DENSITY, free_length: float = FREE_LENGTH,
               segment: float = SEGMENT) -> LiftScene:
    """A free box of ``box_mass`` kg hanging on a limp inextensible rope of ``density`` kg/m, ``free_length`` m of
    it below a winch at (0, 0, :data:`WINCH_HEIGHT`), :data:`SPOOLED` m more on the spool (straight above the winch
    in the rope's points, parked on the winch from the start); segments of ``segment`` m (the lengths rounded to
    whole segments). The box touches nothing."""
    box_mass = _validate.number("box_mass", box_mass, low=0.0, low_open=True, unit="kg")
    density = _validate.number("density", density, low=0.0, low_open=True, unit="kg/m")
    segment = _validate.number("segment", segment, low=0.0, low_open=True, unit="m")
    free = _validate.number("free_length", free_length, low=2.0 * segment, unit="m")
    n_free, n_spool = round(free / segment), round(SPOOLED / segment)
    free = n_free * segment
    top, winch, bottom = WINCH_HEIGHT + n_spool * segment, WINCH_HEIGHT, WINCH_HEIGHT - free
    spec = mujoco.MjSpec()
    spec.option.gravity = [0.0, 0.0, -reference.G]
    box = spec.worldbody.add_body(name=BOX_BODY, pos=[0.0, 0.0, bottom - BOX_HALF])
    box.add_freejoint()
    box.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[BOX_HALF] * 3, mass=box_mass, contype=0, conaffinity=0,
                 rgba=[0.8, 0.4, 0.2, 1.0])
    n = n_free + n_spool
    cable = CableSpec([[0.0, 0.0, top], [0.0, 0.0, winch], [0.0, 0.0, bottom]], n, ROPE_RADIUS,
                      density * n * segment, damping=DAMPING)
    pins = (Pin(n_spool, "winch"), Pin(-1, "body", body=BOX_BODY, offset=(0.0, 0.0, BOX_HALF)))
    return LiftScene(cable, pins, world=spec, name="winch", box_mass=box_mass, density=density, free_length=free)
