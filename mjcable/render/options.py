"""Argument checks and the validated options shared by every render function.

Generic checks go through :mod:`mjcable._validate`; the render-specific ones live here: frame sizes must be even
(H.264 with yuv420p needs them), videos are ``.mp4`` files in an existing folder, a scene is a
:class:`~mjcable.scene.Scene` or a built-in scene's name.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, Mapping, Optional, Sequence, Union

from mjcable import _validate, scenes
from mjcable.render.camera import check_camera, check_elevation
from mjcable.scene import Scene

__all__ = ["Options", "options", "check_seconds", "check_fps", "check_size", "check_min_cable_px", "check_progress",
           "check_path", "check_scene", "check_settings", "SceneLike", "MAX_SECONDS", "MAX_FPS", "MIN_SIZE",
           "MAX_SIZE", "MAX_CABLE_PX"]

MAX_SECONDS = 3600.0  # s of video
MAX_FPS = 240  # frames per second
MIN_SIZE, MAX_SIZE = 16, 4096  # pixels per side; even, as H.264 with yuv420p needs
MAX_CABLE_PX = 100.0  # pixels: the largest least drawn cable radius

SceneLike = Union[Scene, str]


def check_seconds(seconds: Any) -> float:
    """Video duration in seconds, in (0, :data:`MAX_SECONDS`]."""
    return _validate.number("seconds", seconds, low=0.0, high=MAX_SECONDS, low_open=True, unit="s")


def check_fps(fps: Any) -> int:
    """Frames per second, an integer in [1, :data:`MAX_FPS`]."""
    return _validate.integer("fps", fps, low=1, high=MAX_FPS)


def check_size(name: str, value: Any) -> int:
    """A frame side ``name`` in pixels: an even integer in [:data:`MIN_SIZE`, :data:`MAX_SIZE`]."""
    value = _validate.integer(name, value, low=MIN_SIZE, high=MAX_SIZE)
    if value % 2:
        raise ValueError(f"{name} must be an even number of pixels (H.264 with yuv420p needs even sizes), "
                         f"got {value!r}")
    return value


def check_min_cable_px(min_cable_px: Any) -> float:
    """The least radius in pixels the cable is drawn with, in [0, :data:`MAX_CABLE_PX`]."""
    return _validate.number("min_cable_px", min_cable_px, low=0.0, high=MAX_CABLE_PX, unit="pixels")


def check_progress(progress: Any) -> Optional[bool]:
    """``None`` (automatic) or a bool."""
    return None if progress is None else _validate.boolean("progress", progress)


def check_path(path: Any) -> Path:
    """``path`` as a :class:`~pathlib.Path`, checked to name an ``.mp4`` file in an existing folder."""
    p = Path(_validate.path_like("path", path))
    if p.suffix.lower() != ".mp4":
        raise ValueError(f"path must end in .mp4 (the video is H.264 in MP4), got {str(path)!r}")
    if not p.parent.is_dir():
        raise ValueError(f"path {str(path)!r} is in a folder that does not exist ({str(p.parent)!r}); create it first")
    return p


def check_scene(scene: Any) -> Scene:
    """A :class:`~mjcable.scene.Scene`, or the built-in scene of that name."""
    if isinstance(scene, str):
        return scenes.get(scene)  # ValueError naming the scene for an unknown name
    if not isinstance(scene, Scene):
        raise ValueError(f"scene must be an mjcable.Scene or one of {scenes.names()}, got {type(scene).__name__}")
    return scene


def check_settings(settings: Any, models: Sequence[str]) -> Mapping[str, Mapping]:
    """Per-model settings ``{model: {setting: value}}`` naming only models in ``models`` (``None``: none)."""
    if settings is None:
        return {}
    if not isinstance(settings, Mapping) or not all(isinstance(v, Mapping) for v in settings.values()):
        raise ValueError(f"settings must map model names to dicts of settings, got {settings!r}")
    unknown = sorted(set(settings) - set(models))
    if unknown:
        raise ValueError(f"settings name model(s) {unknown} that are not rendered; rendered: {list(models)}")
    return settings


@dataclasses.dataclass(frozen=True, kw_only=True)
class Options:
    """Validated options shared by the simulation renderers (build with :func:`options`).

    Attributes:
      seconds: video duration in seconds.
      fps: frames per second.
      width, height: one tile's size in pixels.
      camera: ``"track"`` or the name of a camera of the model (checked against the models by the camera module).
      elevation: the tracking camera's angle above the horizon in degrees.
      min_cable_px: the least radius in pixels the cable is drawn with.
      progress: show a progress bar (``None``: automatic).
      stripe: draw a stripe along each segment's material d₁ (models with frames: twist shows as a turning
        stripe; the others are drawn without).
    """

    seconds: float
    fps: int
    width: int
    height: int
    camera: str
    elevation: float
    min_cable_px: float
    progress: Optional[bool]
    stripe: bool = False

    @property
    def n_frames(self) -> int:
        """Frames at times 0, 1/fps, ...: together they last ``seconds`` (at least one frame)."""
        return max(1, int(round(self.seconds * self.fps)))


def options(*, seconds, fps, width, height, camera, elevation, min_cable_px, progress, stripe=False,
            width_name: str = "width", height_name: str = "height") -> Options:
    """Check every option and return them as :class:`Options` (``ValueError`` naming the first bad one)."""
    return Options(
        seconds=check_seconds(seconds),
        fps=check_fps(fps),
        width=check_size(width_name, width),
        height=check_size(height_name, height),
        camera=check_camera(camera),
        elevation=check_elevation(elevation),
        min_cable_px=check_min_cable_px(min_cable_px),
        progress=check_progress(progress),
        stripe=_validate.boolean("stripe", stripe),
    )
