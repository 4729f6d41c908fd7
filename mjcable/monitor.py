"""The physics monitor: what each model promises about its cable, and what a breach of it means.

Every step of every model passes the compiled checks of :mod:`mjcable.solvers.monitor_kernels` (inside the particle
solvers' step loop, after each ``dt`` of ``mj_step`` for MuJoCo's models). This module sets their limits from the
scene and the model (:func:`limits`), names what a check found (:class:`Breach`) and the fix (:func:`fix`).

The checks, and what a breach does:

========== ============================================================================ =========================
check      measured                                                                     breach
========== ============================================================================ =========================
non-finite a NaN or inf in a particle's position or velocity                            SimulationDivergedError
run-off    a particle's distance from the origin beyond :data:`MAX_DISTANCE` m           SimulationDivergedError
speed      a particle's travel over one step faster than :data:`MAX_SPEED` m/s          SimulationDivergedError
velocity   the model's own velocity of a particle faster than :data:`MAX_SPEED` m/s     SimulationDivergedError
torn pin   a pinned particle farther from its pin than :attr:`Limits.tear`              SimulationDivergedError
strain     a segment stretched beyond :attr:`Limits.strain_fail`                        SimulationDivergedError
strain     a segment stretched beyond :attr:`Limits.strain_warn` (what the model        PhysicsWarning, once
           promises: :data:`STRAIN_TOLERANCE` for an inextensible cable, else
           :data:`ELASTIC_MARGIN` times the static stretch under the scene's weight)
depth      the cable's centreline inside an obstacle (its surface deeper than its       PhysicsWarning, once
           radius)
========== ============================================================================ =========================
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Optional

import numpy as np

from mjcable.errors import PhysicsWarning
from mjcable.scene import Scene
from mjcable.solvers.kernels_layout import (CHECK_DISTANCE, CHECK_NON_FINITE, CHECK_OK, CHECK_PIN, CHECK_SPEED,
                                            CHECK_STRAIN, CHECK_VELOCITY, WARN_DEPTH, WARN_STRAIN)

__all__ = ["Limits", "Breach", "limits", "strain_limits", "limits_record", "breach", "fix", "warn", "LIMITS",
           "MAX_SPEED", "MAX_DISTANCE", "STRAIN_TOLERANCE", "STRAIN_FAIL", "ELASTIC_MARGIN", "TEAR_FRACTION"]

MAX_SPEED = 200.0  # m/s: a cable particle faster than this has diverged
MAX_DISTANCE = 1e3  # m from the origin: a particle further away has run off
STRAIN_TOLERANCE = 0.1  # an inextensible cable's segment stretched by more has broken its model's promise
STRAIN_FAIL = 1.0  # a segment stretched to more than twice its rest length is no longer a cable
ELASTIC_MARGIN = 10.0  # an elastic cable may stretch this many times its static stretch under the scene's weight
TEAR_FRACTION = 0.01  # of the cable's length (at least a segment): a pinned particle this far off is torn away

#: The limits of :func:`mjcable.solvers.monitor_kernels.step_check` as a record (the particle state's ``par`` has the
#: same fields among its own).
LIMITS = np.dtype([("dt", "f8"), ("max_distance", "f8"), ("max_speed", "f8"), ("strain_fail", "f8"),
                   ("strain_warn", "f8"), ("tear", "f8")])

_CHECK_NAMES = {CHECK_NON_FINITE: "non-finite", CHECK_DISTANCE: "run-off", CHECK_SPEED: "speed",
                CHECK_VELOCITY: "velocity", CHECK_PIN: "torn pin", CHECK_STRAIN: "strain", WARN_STRAIN: "strain",
                WARN_DEPTH: "depth"}


@dataclasses.dataclass(frozen=True)
class Limits:
    """What a model promises about a scene's cable.

    Attributes:
      strain_warn: a segment's strain (dimensionless) beyond which the model breaks its promise (a warning).
      strain_fail: a segment's strain beyond which the result is no cable (an error).
      tear: m, how far a pinned particle may stray from its pin.
      static_strain: the static stretch under the scene's weight, F / (E·A) (0 for an inextensible cable).
    """

    strain_warn: float
    strain_fail: float
    tear: float
    static_strain: float


@dataclasses.dataclass(frozen=True)
class Breach:
    """What a check found.

    Attributes:
      check: its name (``"non-finite"``, ``"run-off"``, ``"speed"``, ``"velocity"``, ``"torn pin"``, ``"strain"``,
        ``"depth"``, or ``"MuJoCo warning"``).
      value: what it measured (strain, m/s, m; NaN for a non-finite state or a MuJoCo warning).
      reason: the finding in words.
      step: the step of the run call it came in (1-based; 0: not known).
      warning: whether the result may still serve (a :class:`~mjcable.errors.PhysicsWarning`, once), rather than
        an error.
    """

    check: str
    value: float
    reason: str
    step: int = 0
    warning: bool = False


def limits(scene: Scene, entry) -> Limits:
    """The limits of the model of catalogue entry ``entry`` (:class:`mjcable.catalog.ModelEntry`: whether it uses
    ``stretch_stiffness``, from its ``ignores``) on ``scene``'s cable (see the module docstring)."""
    eas = [None if "stretch_stiffness" in dict(entry.ignores) else c.stretch_stiffness for c in scene.cables]
    ea = None if None in eas else min(eas)  # (several cables: the softest's)
    warn_at, fail_at, static = strain_limits(scene, ea)
    tear = max(max(c.segment_length, TEAR_FRACTION * c.segment_length * c.n_segments) for c in scene.cables)
    return Limits(strain_warn=warn_at, strain_fail=fail_at, tear=tear, static_strain=static)


def strain_limits(scene: Scene, stretch_stiffness: Optional[float]) -> tuple:
    """``(strain_warn, strain_fail, static_strain)`` of :class:`Limits` for ``scene``'s cable of E·A
    ``stretch_stiffness`` N (``None``: inextensible); a model's precheck compares its own estimate with them."""
    # the weight it may carry: its own and its bodies'
    static = 0.0 if stretch_stiffness is None else scene.max_tension / stretch_stiffness
    return max(STRAIN_TOLERANCE, ELASTIC_MARGIN * static), max(STRAIN_FAIL, 2.0 * ELASTIC_MARGIN * static), static


def limits_record(lim: Limits, dt: float) -> np.ndarray:
    """``lim`` and the step ``dt`` (s) as a length-1 :data:`LIMITS` record for the compiled checks."""
    out = np.zeros(1, dtype=LIMITS)
    out[0] = (dt, MAX_DISTANCE, MAX_SPEED, lim.strain_fail, lim.strain_warn, lim.tear)
    return out


def breach(check: int, value: float, where: int, scene: Scene, lim: Limits, *, step: int = 0) -> Optional[Breach]:
    """The :class:`Breach` of a compiled check's ``(check, value, where)``, or ``None`` for ``CHECK_OK``."""
    if check == CHECK_OK:
        return None
    name = _CHECK_NAMES[check]
    if check == CHECK_NON_FINITE:
        text = "non-finite particle state (NaN or inf)"
    elif check == CHECK_DISTANCE:
        text = f"a particle ran off {value:.4g} m from the origin (limit {MAX_DISTANCE:g} m)"
    elif check == CHECK_SPEED:
        text = f"a particle moved at {value:.3g} m/s (limit {MAX_SPEED:g} m/s) over one step"
    elif check == CHECK_VELOCITY:
        text = f"the model's velocity of a particle is {value:.3g} m/s (limit {MAX_SPEED:g} m/s)"
    elif check == CHECK_PIN and where >= len(scene.pins):  # a particle solver's row of a free gripper
        text = (f"the particle free gripper {where - len(scene.pins)} holds is {value:.4g} m from it (torn beyond "
                f"{lim.tear:.4g} m)")
    elif check == CHECK_PIN:
        pin = scene.pins[where]
        text = (f"pinned particle {scene.pin_particle(where)} is {value:.4g} m from its {pin.kind} pin (pins[{where}]; "
                f"torn beyond {lim.tear:.4g} m){_pin_load(scene, where)}")
    elif check == WARN_DEPTH:
        text = (f"{'the cable' if where < 0 else f'segment {where}'}'s centreline is inside an obstacle: the "
                f"cable's surface {value:.4g} m deep, beyond its radius {max(c.radius for c in scene.cables):g} m")
    else:
        promise = (f"an inextensible cable's tolerance {STRAIN_TOLERANCE:g}" if lim.static_strain == 0.0 else
                   f"{ELASTIC_MARGIN:g} × the static stretch {lim.static_strain:.3g} under the scene's weight")
        limit = lim.strain_fail if check == CHECK_STRAIN else lim.strain_warn
        text = (f"strain {value:.3g} of segment {where} (limit {limit:.3g}: "
                f"{'twice the rest length' if check == CHECK_STRAIN else promise}){_pin_load(scene, None)}")
    return Breach(check=name, value=float(value), reason=text, step=step, warning=check >= WARN_STRAIN)


def _pin_load(scene: Scene, k: Optional[int]) -> str:
    """`` under the 0.5 kg body on pin 1`` where the cable holds bodies of the user's world (pin ``k`` or any)."""
    if scene.world is None:
        return ""
    for j, pin in enumerate(scene.pins):
        if pin.on_body and k in (None, j):
            mass = float(scene.world.model.body_subtreemass[scene.world.body_id(pin.body)])
            return f" under the {mass:.3g} kg body {pin.body!r} on pin {j}"
    return ""


def fix(scene: Scene, model: str, settings, dt: float, check: str) -> str:
    """The fix to try after a breach of ``check`` by ``model`` with ``settings`` at step ``dt`` (s)."""
    substeps = getattr(settings, "substeps", 1)
    h = dt / substeps
    if check == "MuJoCo warning" or check in ("non-finite", "run-off", "speed", "velocity"):
        generic = f"use a smaller dt or more substeps (now dt = {dt:g} s, substeps = {substeps})"
    else:
        generic = f"use more substeps or a smaller dt (the substep is now {h:.3g} s)"
    if model == "flexrod":
        from mjcable.mjcf import flexrod  # the generators are imported by the catalogue; here only when needed

        need = max(flexrod.stable_substeps(scene.cable_scene(c), dt) for c in range(len(scene.cables)))
        if need > substeps:
            return f"use substeps >= {need} (mjcable.mjcf.flexrod.stable_substeps)"
        return f"{generic}; flexrod's edges are explicit springs, so a heavy load on a light cable needs more"
    order = getattr(settings, "order", None)
    if check == "strain" and order in ("gauss-seidel", "jacobi"):
        iterations = getattr(settings, "iterations", 1)
        direct = "; xpbd's order='direct' reaches the stated stiffness in one iteration" if model == "xpbd" else ""
        return f"use more substeps or iterations (now {substeps} × {iterations}){direct}"
    if check == "strain" and model == "springs":
        return f"{generic}: springs caps its stretch stiffness at the stable limit of the substep"
    if check == "depth":
        return f"{generic}, or a thicker obstacle"
    return generic


def warn(found: Breach, model: str, step: int, time: float, advice: str) -> None:
    """Warn once with a :class:`~mjcable.errors.PhysicsWarning` about ``found`` at ``step``, simulated ``time``."""
    warnings.warn(PhysicsWarning(f"{model}: {found.check} at step {step} (t = {time:.6g} s): {found.reason}; "
                                 f"{advice}"), stacklevel=4)
