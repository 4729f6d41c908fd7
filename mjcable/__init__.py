"""mjcable: cable, rope and wire scenes on MuJoCo, with MuJoCo's native cable models and our own
Jakobsen/PBD/XPBD solvers compared head to head."""

import importlib
import os

# Offscreen rendering (mjcable.render, dm_control) on EGL unless the user chose otherwise. MuJoCo reads MUJOCO_GL when
# it is first imported, so this must come before anything imports mujoco.
os.environ.setdefault("MUJOCO_GL", "egl")

from mjcable import _mujoco_log, catalog, mjcf, scenes, solvers  # noqa: E402
from mjcable.backends.protocol import Energy  # noqa: E402
from mjcable.batch import Batch, BatchTrajectory  # noqa: E402
from mjcable.catalog import build  # noqa: E402
from mjcable.errors import PhysicsWarning, SimulationDivergedError  # noqa: E402
from mjcable.scene import Box, CableSpec, Capsule, Cylinder, Floor, Gripper, Junction, Pin, Ring, Scene, Sphere  # noqa: E402
from mjcable.simulator import Simulator, Trajectory  # noqa: E402
from mjcable.spline import CatmullRom, resample  # noqa: E402

__all__ = [
    "CatmullRom",
    "resample",
    "CableSpec",
    "Pin",
    "Junction",
    "Gripper",
    "Floor",
    "Box",
    "Cylinder",
    "Capsule",
    "Sphere",
    "Scene",
    "scenes",
    "catalog",
    "mjcf",
    "solvers",
    "build",
    "Simulator",
    "Trajectory",
    "Energy",
    "Batch",
    "BatchTrajectory",
    "SimulationDivergedError",
    "PhysicsWarning",
    "MODELS",
    "NATIVE_MODELS",
    "PARTICLE_MODELS",
]

__version__ = "0.1.0"

_mujoco_log.route_warnings()  # MuJoCo's warnings to the logger "mjcable", not to ./MUJOCO_LOG.TXT


_FAMILY_VIEWS = {"MODELS": None, "NATIVE_MODELS": "native", "PARTICLE_MODELS": "particle"}
# Subpackages imported on first attribute access (they pull in dm_control, matplotlib or ffmpeg): after
# ``import mjcable``, ``mjcable.envs.load`` resolves like any other name.
_LAZY_SUBMODULES = ("backends", "bench", "cli", "envs", "export", "geometry", "io", "knots", "metrics", "reference",
                    "reference_harness", "render", "user_world", "worlds")


def __getattr__(name: str):
    """``MODELS``, ``NATIVE_MODELS`` and ``PARTICLE_MODELS``: live views of :mod:`mjcable.catalog` (a model
    registered later shows up in them); the heavier subpackages, imported on first access."""
    if name in _FAMILY_VIEWS:
        return catalog.names(_FAMILY_VIEWS[name])
    if name in _LAZY_SUBMODULES:
        return importlib.import_module(f"mjcable.{name}")
    raise AttributeError(f"module 'mjcable' has no attribute {name!r}")
