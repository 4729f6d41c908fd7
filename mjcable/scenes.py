"""Built-in scenes, registered once: ``hang``, ``table``, ``drape``, ``socket``.

``mjcable.scenes.get(name, **overrides)`` returns a :class:`~mjcable.scene.Scene`; overrides are
:class:`~mjcable.scene.CableSpec` fields (e.g. ``n_segments=100``, ``young=1e7``).
"""

from __future__ import annotations

import dataclasses
from typing import Callable, Dict

import numpy as np
from scipy import optimize

from mjcable import spline
from mjcable.scene import Box, CableSpec, Cylinder, Floor, Pin, Scene

__all__ = ["get", "names", "HANG_LENGTH", "HANG_SPAN", "HANG_HEIGHT"]

HANG_LENGTH = 1.0  # m
HANG_SPAN = 0.8  # m
HANG_HEIGHT = 1.0  # m, height of both pins
TABLE_TOP = 0.75  # m
TABLE_DROP = 0.25  # m, start height of the table scene's cable above the top

_DEFAULTS = dict(n_segments=50, radius=0.005, mass=0.1, damping=0.2, friction=1.0)
_REGISTRY: Dict[str, Callable[..., Scene]] = {}


def _register(fn):
    _REGISTRY[fn.__name__.lstrip("_")] = fn
    return fn


def names() -> tuple:
    """Names of the built-in scenes."""
    return tuple(_REGISTRY)


def get(name: str, **overrides) -> Scene:
    """A built-in scene by name, with ``CableSpec`` fields overridden.

    Example::

        scene = mjcable.scenes.get("hang", n_segments=100, damping=1.0)
    """
    if name not in _REGISTRY:
        raise ValueError(f"scene must be one of {names()}, got {name!r}")
    allowed = {f.name for f in dataclasses.fields(CableSpec)}
    unknown = sorted(set(overrides) - allowed)
    if unknown:
        raise ValueError(f"unknown CableSpec field(s) {unknown} for scene {name!r}; allowed: {sorted(allowed)}")
    return _REGISTRY[name](**{**_DEFAULTS, **overrides})


def _cable(points, **fields) -> CableSpec:
    return CableSpec(points, fields.pop("n_segments"), fields.pop("radius"), fields.pop("mass"), **fields)


def _sagging_points(depth: float) -> np.ndarray:
    half = HANG_SPAN / 2
    return np.array([[-half, 0.0, HANG_HEIGHT], [0.0, 0.0, HANG_HEIGHT - depth], [half, 0.0, HANG_HEIGHT]])


def _hang_points(n_segments: int, kind: str) -> np.ndarray:
    """Three control points whose curve resamples to exactly ``HANG_LENGTH`` over ``HANG_SPAN``."""

    def excess(depth):
        chords = spline.resample(spline.CatmullRom(_sagging_points(depth), kind=kind), n_segments)
        return float(np.linalg.norm(chords[1] - chords[0])) * n_segments - HANG_LENGTH

    depth = optimize.brentq(excess, 1e-3, HANG_LENGTH, xtol=1e-14)
    return _sagging_points(depth)


@_register
def _hang(**fields) -> Scene:
    """A 1 m cable pinned at both ends 0.8 m apart at 1 m height: it settles to a catenary."""
    if "points" not in fields:
        fields["points"] = _hang_points(fields["n_segments"], fields.get("kind", "centripetal"))
    cable = _cable(fields.pop("points"), **fields)
    return Scene(cable, pins=(Pin(0), Pin(-1)), name="hang")


@_register
def _table(**fields) -> Scene:
    """A wavy, 1.2 m cable dropped from about 25 cm onto a table (with a floor below)."""
    z = TABLE_TOP + TABLE_DROP
    points = fields.pop("points", [[-0.45, -0.15, z], [-0.15, 0.15, z + 0.05], [0.15, -0.15, z - 0.05],
                                   [0.45, 0.15, z]])
    table = Box(size=(0.6, 0.4, 0.02), pos=(0.0, 0.0, TABLE_TOP - 0.02))
    return Scene(_cable(points, **fields), obstacles=(Floor(), table), name="table")


@_register
def _drape(**fields) -> Scene:
    """A straight 1 m cable falls onto a horizontal peg and drapes over it."""
    points = fields.pop("points", [[-0.5, 0.0, 0.9], [0.5, 0.0, 0.9]])
    peg = Cylinder(radius=0.03, half_length=0.3, pos=(0.05, 0.0, 0.8), euler=(90.0, 0.0, 0.0))
    return Scene(_cable(points, **fields), obstacles=(Floor(), peg), name="drape")


@_register
def _socket(**fields) -> Scene:
    """The plug end sits clamped in a socket in a wall; the other end is held by a gripper."""
    points = fields.pop("points", [[-0.4, 0.0, 0.6], [-0.1, 0.0, 0.45], [0.3, 0.0, 0.6]])
    wall = Box(size=(0.02, 0.2, 0.2), pos=(-0.43, 0.0, 0.6))
    pins = (Pin(0, "socket", clamp=True, release_force=2.0), Pin(-1, "gripper"))
    return Scene(_cable(points, **fields), pins=pins, obstacles=(Floor(), wall), name="socket")
