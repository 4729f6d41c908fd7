"""mjcable: cable, rope and wire scenes on MuJoCo, with MuJoCo's native cable models and our own
Jakobsen/PBD/XPBD solvers compared head to head."""

import os

# Offscreen rendering (mjcable.render, dm_control) on EGL unless the user chose otherwise. MuJoCo reads MUJOCO_GL when
# it is first imported, so this must come before anything imports mujoco.
os.environ.setdefault("MUJOCO_GL", "egl")

from mjcable import scenes  # noqa: E402
from mjcable.build import MODELS, NATIVE_MODELS, PARTICLE_MODELS, build
from mjcable.errors import SimulationDivergedError
from mjcable.scene import Box, CableSpec, Capsule, Cylinder, Floor, Pin, Scene, Sphere
from mjcable.simulator import Simulator
from mjcable.spline import CatmullRom, resample

__all__ = [
    "CatmullRom",
    "resample",
    "CableSpec",
    "Pin",
    "Floor",
    "Box",
    "Cylinder",
    "Capsule",
    "Sphere",
    "Scene",
    "scenes",
    "build",
    "Simulator",
    "SimulationDivergedError",
    "MODELS",
    "NATIVE_MODELS",
    "PARTICLE_MODELS",
]

__version__ = "0.1.0"
