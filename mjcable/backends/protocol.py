"""The one interface every cable model's backend implements, declared as a ``typing.Protocol``.

:class:`mjcable.Simulator` drives a backend and never reaches past this protocol; callers above the Simulator never
see a backend at all. :mod:`mjcable.backends.native` (MuJoCo's own cable models, stepped by ``mj_step``) and
:mod:`mjcable.backends.particle` (the numba particle solvers, colliding through ``mj_collision``) implement it.
"""

from __future__ import annotations

import dataclasses
from typing import Optional, Protocol, runtime_checkable

import mujoco
import numpy as np

from mjcable.monitor import MAX_DISTANCE, MAX_SPEED, Breach

__all__ = ["Backend", "Energy", "RunResult", "MAX_SPEED", "MAX_DISTANCE"]


@dataclasses.dataclass(frozen=True)
class RunResult:
    """What :meth:`Backend.run` did.

    Attributes:
      steps: steps taken (all asked for, unless a failure or a release stopped the run).
      recorded: rows of ``out_x``/``out_v`` written.
      failure: the check the last step failed (:class:`mjcable.monitor.Breach`: a physics check, a MuJoCo warning),
        else ``None``.
      warning: the first warning-level breach of the call (its ``step`` numbered within the call), else ``None``.
    """

    steps: int
    recorded: int
    failure: Optional[Breach] = None
    warning: Optional[Breach] = None


@dataclasses.dataclass(frozen=True, kw_only=True)
class Energy:
    """A cable's energy in joules by kind (:meth:`mjcable.Simulator.energy` with ``parts=True``), each from the
    model's own state and its own potential (README, "Energy").

    Attributes:
      kinetic: ½ Σ mᵢ|vᵢ|² of the particles (particle solvers, ``springs``, ``flexrod``); for the capsule chains
        (``joints``, ``composite``) ½ q̇ᵀ M q̇ over the cable's joints: its bodies' translation and rotation and the
        ball joints' armature.
      gravity: −Σ mᵢ g·xᵢ over the cable's masses (zero at the world origin).
      stretch: elastic energy of the segments' stretch (zero where a model holds them rigid or by a hard constraint).
      bending: elastic energy of bending (clamps included).
      twist: elastic energy of torsion (``joints``, ``composite``; zero where a model has no frames).
      total: the sum of the five.
    """

    kinetic: float
    gravity: float
    stretch: float = 0.0
    bending: float = 0.0
    twist: float = 0.0
    total: float = dataclasses.field(init=False)

    def __post_init__(self):
        for name in ("kinetic", "gravity", "stretch", "bending", "twist"):
            object.__setattr__(self, name, float(getattr(self, name)))
        object.__setattr__(self, "total", self.kinetic + self.gravity + self.stretch + self.bending + self.twist)



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

    def run(self, count: int, *, rows: np.ndarray, out_x: np.ndarray, out_v: np.ndarray,
            path: Optional[tuple] = None, until_release: bool = False) -> RunResult:
        """Take up to ``count`` steps of ``dt``, each checked (:func:`mjcable.solvers.monitor_kernels.step_check`
        against the limits of :func:`mjcable.monitor.limits`, and the model's own divergence signs), stopping after
        the first that fails.

        Args:
          count: steps to take (>= 1).
          rows: ``(R,)`` ascending step numbers (1..count) after which to record the state, into ``out_x`` and
            ``out_v`` ``(R, n_segments + 1, 3)`` (m, m/s).
          path: ``(pins, targets)`` or ``None``: before step ``k`` the gripper of ``scene.pins[pins[g]]`` (``pins``
            (G,) int64) moves to ``targets[k, g]`` (``(count, G, 3)`` m, C-contiguous), as :meth:`move_gripper` (a
            gripper sent where it already is stays where it is, bit for bit).
          until_release: also stop after a step in which a socket let go.
        """

    def reset(self) -> None:
        """Return to the start state bit for bit (added point masses stay)."""

    def positions(self) -> np.ndarray:
        """``(n_segments + 1, 3)`` centreline particles in metres, world frame (a copy)."""

    def velocities(self) -> np.ndarray:
        """``(n_segments + 1, 3)`` particle velocities in m/s from the model's own state (a copy)."""

    def particle_masses(self) -> np.ndarray:
        """``(n_segments + 1,)`` lumped masses in kg, added point masses included."""

    def energy(self) -> Energy:
        """The cable's energy now, by kind, from the model's own state and potential (the cable's alone, not the
        rest of a user world)."""

    def pin_forces(self) -> np.ndarray:
        """``(n_pins, 3)`` force in newtons each pin exerts on the cable; zero rows for released sockets."""

    def pin_torques(self) -> np.ndarray:
        """``(n_pins, 3)`` torque in N·m each pin exerts on the cable about its pinned particle (clamps)."""

    def gripper_positions(self) -> np.ndarray:
        """``(n_grippers, 3)`` commanded gripper positions in metres, in ``scene.gripper_pins`` order."""

    def move_gripper(self, k: int, position: np.ndarray, orientation: Optional[np.ndarray] = None) -> None:
        """Send the gripper of ``scene.pins[k]`` to ``position`` (3,) over the next step, and (a model with frames,
        a clamped gripper) turn it to the unit quaternion ``orientation`` (4,) (w, x, y, z); ``orientation`` given
        to a model that can't honour it raises a ``ValueError``."""

    def reel(self, k: int, speed: float) -> None:
        """Reel winch ``scene.pins[k]`` at ``speed`` m/s (positive pays out) until changed (validated by the
        Simulator; a model without winches refuses the scene at construction)."""

    def free_length(self, k: int) -> float:
        """m: the free cable of winch ``scene.pins[k]``."""

    def grasp(self, g: int, index: int) -> None:
        """Close free gripper ``g`` on particle ``index`` (validated by the Simulator), held where it is."""

    def release(self, g: int) -> None:
        """Open free gripper ``g`` (closed: validated by the Simulator)."""

    def gripper_forces(self) -> np.ndarray:
        """``(n_free_grippers, 3)`` force in newtons each free gripper exerts on its particle (zero while open)."""

    def frames(self) -> np.ndarray:
        """``(n_segments, 4)`` material frames (w, x, y, z) of the segments; a ``ValueError`` for models without."""

    def add_point_mass(self, index: int, mass: float) -> None:
        """Add ``mass`` kg at particle ``index`` (validated by the Simulator)."""

    def diagnostics(self) -> dict:
        """Counters of the last step and cumulative timings (model-specific keys, numbers only)."""

    @property
    def released(self) -> set:
        """Pin numbers of the sockets that have let go."""
