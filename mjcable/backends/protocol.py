"""The one interface every cable model's backend implements, declared as a ``typing.Protocol``.

:class:`mjcable.Simulator` drives a backend and never reaches past this protocol; callers above the Simulator never
see a backend at all. :mod:`mjcable.backends.native` (MuJoCo's own cable models, stepped by ``mj_step``) and
:mod:`mjcable.backends.particle` (the numba particle solvers, colliding through ``mj_collision``) implement it.
"""

from __future__ import annotations

from typing import Optional, Protocol, runtime_checkable

import mujoco
import numpy as np

__all__ = ["Backend"]


@runtime_checkable
class Backend(Protocol):
    """What :class:`mjcable.Simulator` asks of a cable model.

    Attributes:
      mj_model, mj_data: the compiled MuJoCo model of the scene with the cable (native models) or its proxy
        (particle solvers), current after every :meth:`step`.
      released: pin numbers (indices into ``scene.pins``) of the sockets that have let go.
    """

    mj_model: mujoco.MjModel
    mj_data: mujoco.MjData

    def step(self) -> Optional[str]:
        """Advance exactly one ``dt``. Returns why the state diverged (a MuJoCo warning, NaNs), else ``None``."""

    def reset(self) -> None:
        """Return to the start state bit for bit (added point masses stay)."""

    def positions(self) -> np.ndarray:
        """``(n_segments + 1, 3)`` centreline particles in metres, world frame (a copy)."""

    def velocities(self) -> np.ndarray:
        """``(n_segments + 1, 3)`` particle velocities in m/s from the model's own state (a copy)."""

    def particle_masses(self) -> np.ndarray:
        """``(n_segments + 1,)`` lumped masses in kg, added point masses included."""

    def pin_forces(self) -> np.ndarray:
        """``(n_pins, 3)`` force in newtons each pin exerts on the cable; zero rows for released sockets."""

    def pin_torques(self) -> np.ndarray:
        """``(n_pins, 3)`` torque in N·m each pin exerts on the cable about its pinned particle (clamps)."""

    def gripper_positions(self) -> np.ndarray:
        """``(n_grippers, 3)`` commanded gripper positions in metres, in ``scene.grippers`` order."""

    def move_gripper(self, k: int, position: np.ndarray) -> None:
        """Send the gripper of ``scene.pins[k]`` to ``position`` (3,) over the next step."""

    def add_point_mass(self, index: int, mass: float) -> None:
        """Add ``mass`` kg at particle ``index`` (validated by the Simulator)."""

    def diagnostics(self) -> dict:
        """Counters of the last step and cumulative timings (model-specific keys, numbers only)."""

    @property
    def released(self) -> set:
        """Pin numbers of the sockets that have let go."""
