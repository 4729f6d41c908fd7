"""Errors and warnings raised by mjcable."""

__all__ = ["SimulationDivergedError", "PhysicsWarning"]


class PhysicsWarning(UserWarning):
    """A result the model can only partly vouch for: the fix is in the message."""


class SimulationDivergedError(RuntimeError):
    """A simulation left the physically meaningful regime.

    Raised for NaN/inf states, runaway positions or speeds, and MuJoCo warnings such as
    ``mjWARN_BADQACC`` (after which MuJoCo silently resets the state).

    Attributes:
      model: name of the cable model (``"springs"``, ``"xpbd"``, ...).
      step: number of the step of size ``dt`` (counting from 1) during which the divergence was detected.
      time: simulated time in seconds at detection.
      reason: short description of what was detected.
    """

    def __init__(self, model: str, step: int, time: float, reason: str):
        self.model = model
        self.step = int(step)
        self.time = float(time)
        self.reason = reason
        super().__init__(
            f"model {model!r} diverged at step {self.step} (t = {self.time:.6g} s): {reason}. "
            "Try a smaller dt, more substeps, or a softer cable."
        )
