"""Errors and warnings raised by mjcable."""

from typing import Optional

__all__ = ["SimulationDivergedError", "PhysicsWarning"]


class PhysicsWarning(UserWarning):
    """A result the model can only partly vouch for: the fix is in the message."""


class SimulationDivergedError(RuntimeError):
    """A simulation left the physically meaningful regime.

    Raised for NaN/inf states, runaway positions or speeds, a cable torn from its pin or stretched to more than twice
    its length (:mod:`mjcable.monitor`), and MuJoCo warnings such as ``mjWARN_BADQACC`` (after which MuJoCo silently
    resets the state).

    Attributes:
      model: name of the cable model (``"springs"``, ``"xpbd"``, ...).
      step: number of the step of size ``dt`` (counting from 1) during which the divergence was detected.
      time: simulated time in seconds at detection.
      reason: short description of what was detected.
      check: the check that failed (:class:`mjcable.monitor.Breach`'s names, e.g. ``"strain"``, ``"torn pin"``,
        ``"MuJoCo warning"``; ``"divergence"`` where none is named).
      value: what the check measured (NaN where it measured no number).
      fix: what to try instead.
    """

    def __init__(self, model: str, step: int, time: float, reason: str, *, check: str = "divergence",
                 value: float = float("nan"), fix: Optional[str] = None):
        self.model = model
        self.step = int(step)
        self.time = float(time)
        self.reason = reason
        self.check = check
        self.value = float(value)
        self.fix = fix or "try a smaller dt, more substeps, or a softer cable"
        super().__init__(f"model {model!r} diverged at step {self.step} (t = {self.time:.6g} s), check {check!r}: "
                         f"{reason}. Fix: {self.fix}.")
