"""How a run ends: the outcome classification of the sweep.

Every run ends in exactly one ``outcome`` (:data:`OUTCOMES`):

* ``stable``: ran its whole duration with no sign of divergence or tunnelling;
* ``diverged``: NaN or runaway state (a particle faster than :data:`RUNAWAY_SPEED` m/s plus the driven speed, a
  segment stretched beyond :data:`STRAIN_LIMIT`), energy growth (passive scenes: kinetic + potential energy above
  its start value by more than :data:`ENERGY_GROWTH` m g L), a MuJoCo warning or silent reset
  (:class:`~mjcable.errors.SimulationDivergedError`), any other exception while building or stepping, or over its
  time cap;
* ``tunneled``: a particle ended up inside or beyond an obstacle (:func:`mjcable.metrics.tunneled`);
* ``rejected``: mjcable's own validation refused the settings or scene up front with a ``ValueError`` (not a
  failure; a ``ValueError`` from MuJoCo while building counts as ``diverged``).

A defect of the code rather than of the numerics (:data:`DEFECTS`: a failed import, a missing attribute, a wrong
call) is no outcome: the run raises it, so that a broken model fails loudly.
"""

from __future__ import annotations

import dataclasses
import math
import os
import traceback
from typing import Optional

from mjcable.errors import SimulationDivergedError
from mjcable.monitor import STRAIN_FAIL

__all__ = [
    "OUTCOMES",
    "ENERGY_GROWTH",
    "STRAIN_LIMIT",
    "RUNAWAY_SPEED",
    "RESET_TOLERANCE",
    "DEFECTS",
    "Limits",
    "judge",
    "classify_exception",
]

OUTCOMES = ("stable", "diverged", "tunneled", "rejected")
ENERGY_GROWTH = 0.5  # of m g L: a passive cable whose kinetic + potential energy grows by more has diverged
STRAIN_LIMIT = STRAIN_FAIL  # the physics monitor's: a segment stretched to twice its rest length is no cable
RUNAWAY_SPEED = 50.0  # m/s on top of the driven speed: a particle faster than this has run away
RESET_TOLERANCE = 0.5  # in steps: MuJoCo's clock may lag the simulator's by this much before we call it a reset
DEFECTS = (ImportError, NotImplementedError, AttributeError, NameError, TypeError)
_PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # .../mjcable


@dataclasses.dataclass(frozen=True)
class Limits:
    """What a sample of the state may show before the run counts as diverged.

    Attributes:
      strain: largest segment strain (dimensionless).
      speed: largest particle speed in m/s.
      energy: largest growth in joules of kinetic + potential energy over its start value (``inf``: not checked,
        e.g. while a gripper drives the cable).
      clock: largest lag in seconds of MuJoCo's clock behind the simulator's (``inf``: not checked; particle
        solvers advance ``mj_data.time`` themselves).
    """

    strain: float = STRAIN_LIMIT
    speed: float = RUNAWAY_SPEED
    energy: float = math.inf
    clock: float = math.inf


def judge(limits: Limits, *, time: float, strain: float, speed: float, energy_growth: float, mj_time: float,
          crossed: int) -> Optional[tuple]:
    """The verdict on one sample: ``(outcome, reason)`` when it ends the run, ``None`` while it may go on.

    Args:
      limits: the run's limits.
      time: the simulator's time in s.
      strain: the largest segment strain (NaN counts as beyond any limit).
      speed: the largest particle speed in m/s.
      energy_growth: kinetic + potential energy minus its start value, J.
      mj_time: MuJoCo's clock (``mj_data.time``) in s.
      crossed: how many particles lie inside or beyond an obstacle they started outside of.
    """
    if not strain <= limits.strain:  # also NaN
        return "diverged", f"runaway strain {strain:.3g} (limit {limits.strain:g})"
    if speed > limits.speed:
        return "diverged", f"runaway speed {speed:.3g} m/s (limit {limits.speed:g} m/s)"
    if energy_growth > limits.energy:
        return "diverged", (f"energy grew by {energy_growth:.3g} J (limit {ENERGY_GROWTH:g} m g L"
                            f" = {limits.energy:.3g} J)")
    if abs(mj_time - time) > limits.clock:
        return "diverged", f"MuJoCo's clock reads {mj_time:.6g} s at simulated {time:.6g} s: a silent reset"
    if crossed:
        return "tunneled", f"{crossed} particle(s) inside or beyond an obstacle at t = {time:.4g} s"
    return None


def classify_exception(exc: BaseException, *, building: bool) -> tuple:
    """``(outcome, reason)`` of an exception raised while building (``building``) or stepping a case.

    Raises:
      Exception: ``exc`` itself when it is one of :data:`DEFECTS` (a broken model is not an outcome).
    """
    if isinstance(exc, DEFECTS):
        raise exc
    if isinstance(exc, SimulationDivergedError):
        return "diverged", f"{exc.check}: {exc.reason}"
    if isinstance(exc, ValueError) and building and _raised_by_mjcable(exc):
        return "rejected", f"ValueError: {exc}"
    tail = traceback.format_exception_only(type(exc), exc)[-1].strip()
    return "diverged", f"exception while {'building' if building else 'stepping'}: {tail}"


def _raised_by_mjcable(exc: BaseException) -> bool:
    """Whether the innermost frame of ``exc`` lies in the mjcable package (its own input validation), rather than
    in MuJoCo or another library (a crash while building, which counts as a failure)."""
    tb = exc.__traceback__
    if tb is None:
        return False
    while tb.tb_next is not None:
        tb = tb.tb_next
    return os.path.abspath(tb.tb_frame.f_code.co_filename).startswith(_PACKAGE_DIR)
