"""MJCF generators: one module per cable model, all from the same :class:`~mjcable.scene.Scene`.

``mjcable.build(scene, model, *, dt=0.002, **settings)`` returns a ``mujoco.MjSpec``. Native models
(``springs``, ``joints``, ``composite``, ``flexrod``) are complete MuJoCo models; the particle solvers
(``jakobsen``, ``pbd``, ``xpbd``) get the proxy spec (the scene plus one capsule per segment) used for contacts and
rendering.
"""

from __future__ import annotations

import dataclasses
import importlib
from typing import Optional

import mujoco

from mjcable.scene import Scene

__all__ = ["build", "MODELS", "NATIVE_MODELS", "PARTICLE_MODELS", "NativeSettings", "native_settings", "START_KEY", "check_model", "check_dt"]

NATIVE_MODELS = ("springs", "joints", "composite", "flexrod")
PARTICLE_MODELS = ("jakobsen", "pbd", "xpbd")
MODELS = NATIVE_MODELS + PARTICLE_MODELS
START_KEY = "start"  # keyframe holding the scene's start pose where a model compiles in another (straight) pose

# MuJoCo physics steps per Simulator step: spring forces are explicit in MuJoCo's integrators, so a stiff
# (near-inextensible) spring chain needs small steps; the other native models are stable at dt.
_DEFAULT_SUBSTEPS = {"springs": 10, "joints": 1, "composite": 1, "flexrod": 1}


@dataclasses.dataclass(frozen=True)
class NativeSettings:
    """Settings of MuJoCo's native cable models.

    Args:
      substeps: MuJoCo steps per ``dt`` (>= 1); MuJoCo's timestep is ``dt / substeps``. Default per model.
      self_collision: let non-adjacent cable segments collide.
    """

    substeps: Optional[int] = None
    self_collision: bool = False

    def __post_init__(self):
        s = self.substeps
        if s is not None and (isinstance(s, bool) or not isinstance(s, int) or s < 1):
            raise ValueError(f"substeps must be an integer >= 1, got {s!r}")
        if not isinstance(self.self_collision, bool):
            raise ValueError(f"self_collision must be a bool, got {self.self_collision!r}")


def native_settings(model: str, **settings) -> NativeSettings:
    """Validated native settings with the model's default substeps filled in."""
    allowed = {f.name for f in dataclasses.fields(NativeSettings)}
    unknown = sorted(set(settings) - allowed)
    if unknown:
        raise ValueError(f"unknown setting(s) {unknown} for model {model!r}; allowed: {sorted(allowed)}")
    s = NativeSettings(**settings)
    if s.substeps is None:
        s = dataclasses.replace(s, substeps=_DEFAULT_SUBSTEPS[model])
    return s


def check_model(model: str) -> None:
    if model not in MODELS:
        raise ValueError(f"model must be one of {MODELS}, got {model!r}")


def check_dt(dt) -> float:
    if isinstance(dt, bool) or not isinstance(dt, (int, float)) or not 0.0 < float(dt) < float("inf"):
        raise ValueError(f"dt must be a finite number > 0 (seconds), got {dt!r}")
    return float(dt)


def build(scene: Scene, model: str, *, dt: float = 0.002, **settings) -> mujoco.MjSpec:
    """The MuJoCo spec of ``scene`` for ``model``.

    Args:
      scene: the scene.
      model: one of :data:`MODELS`.
      dt: the simulator's step in seconds (> 0); native models step MuJoCo at ``dt / substeps``.
      **settings: model settings (see :class:`NativeSettings` and the solvers' settings).

    Returns:
      An uncompiled ``mujoco.MjSpec``; ``spec.compile()`` gives the ``MjModel``.

    Example::

        spec = mjcable.build(mjcable.scenes.get("hang"), "flexrod")
        model = spec.compile()
    """
    if not isinstance(scene, Scene):
        raise ValueError(f"scene must be an mjcable.Scene, got {type(scene).__name__}")
    check_model(model)
    dt = check_dt(dt)
    if model in NATIVE_MODELS:
        s = native_settings(model, **settings)
        module = importlib.import_module(f"mjcable.build.{model}")
        spec = module.build(scene, timestep=dt / s.substeps, self_collision=s.self_collision)
        if not scene.obstacles and not s.self_collision:
            # nothing can touch: skip MuJoCo's collision pipeline altogether
            spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
        return spec
    from mjcable.build import proxy

    return proxy.build(scene, dt=dt, **settings)
