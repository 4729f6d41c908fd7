"""Offscreen video of cable simulations: one model, or a labelled side-by-side grid of several models of one scene.

Rendering goes through ``mujoco.Renderer`` on EGL (``import mjcable`` sets ``MUJOCO_GL=egl`` when unset, before
MuJoCo is first imported; EGL renders on the CPU where there is no GPU; shadows, reflections and multisampling are
off, as they cost 5-10x on the CPU). The video's frame rate is decoupled from the physics step: each frame advances
the simulation by ``1 / fps`` seconds through :meth:`Simulator.step`, whose own accumulator carries the remainder
below one ``dt`` into the next frame, so frame ``k`` shows the simulation at ``k / fps`` to within one ``dt``.
Videos are MP4 (H.264) through mediapy with the ffmpeg binary of ``imageio-ffmpeg`` and are written atomically (a
temporary file in the destination folder replaces the destination when complete).

What a frame shows:

* the scene as every model builds it (``build/world.py``: obstacles, lights, the same materials), plus the cable's
  centreline (:attr:`Simulator.positions`) drawn as capsules of the cable's radius, so that every model looks like
  the same cable and like is compared with like (a springs model's beads or a flex's own rendering would otherwise
  differ); a thin cable is drawn at least ``min_cable_px`` pixels in radius so it stays visible in small videos;
* by default a tracking camera (``camera="track"``) that keeps the cable large in frame: it looks along +y from
  ``elevation`` degrees above the horizon, at the centre of the cable's bounding box (the union over all tiles of a
  grid, so tiles stay comparable), from the distance that fits that box into the frame with ``FRAME_MARGIN`` to
  spare; it zooms out at once and follows or zooms in smoothly (time constant ``TRACK_TIME_CONSTANT``). Any camera of
  the model may be named instead, such as ``"overview"``, the fixed camera of ``build/world.py``;
* a label (the model's name) and the simulated time in each tile. A model that diverges stops there: its tile
  freezes, darkens and reads ``"<model>: diverged at t=... s"``, while the other tiles go on.

Example::

    import mjcable
    from mjcable import render

    render.render_video("hang", "springs", "hang.mp4", seconds=3)
    models, problems = render.available_models("table")
    render.render_grid("table", models, "table.mp4", seconds=3)
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
from pathlib import Path
from typing import Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

import mujoco  # mjcable/__init__.py has set MUJOCO_GL=egl (unless set) before mujoco was first imported
import numpy as np

from mjcable import scenes
from mjcable import catalog
from mjcable.errors import SimulationDivergedError
from mjcable.io import atomic_path
from mjcable.scene import Scene
from mjcable.simulator import Simulator

__all__ = [
    "frames",
    "grid_frames",
    "render_video",
    "render_grid",
    "render_env",
    "available_models",
    "write_video",
    "read_video",
    "TRACK",
    "UNAVAILABLE_ERRORS",
]

TRACK = "track"  # the tracking free camera (see the module docstring)
UNAVAILABLE_ERRORS = (NotImplementedError, ImportError)  # a model that is not written yet (ModuleNotFoundError too)

MAX_SECONDS = 3600.0  # s of video
MAX_FPS = 240
MIN_SIZE, MAX_SIZE = 16, 4096  # pixels per side; even, as H.264 with yuv420p needs
FRAME_MARGIN = 1.3  # the tracked box fills 1 / FRAME_MARGIN of the frame
TRACK_TIME_CONSTANT = 0.4  # s: how fast the tracking camera follows and zooms in
MIN_TRACK_HALF_EXTENT = 0.15  # fraction of the cable length: the smallest half-size the camera frames
TRACK_AZIMUTH = 90.0  # degrees: look along +y, as the overview camera does
DEFAULT_ELEVATION = 30.0  # degrees above the horizon
MAX_ELEVATION = 85.0  # degrees: the tracking camera's up direction is undefined looking straight down
PROGRESS_MIN_RENDERS = 150  # tile renders from which a progress bar is shown by default
_CABLE_RGBA = np.array([0.85, 0.25, 0.12, 1.0], dtype=np.float32)  # build/world.py's "cable" material
_CABLE_SPECULAR = 0.3
_DIVERGED_SHADE = 0.45  # brightness factor of a frozen (diverged) tile
_EMPTY_TILE = 40  # grey level of unused grid cells
_LABEL_HEIGHT_FRACTION = 1.0 / 18.0  # label font size as a fraction of the tile height
_MIN_LABEL_PX = 10
_LABEL_BOX_ALPHA = 0.55
_LABEL_PAD_FRACTION = 0.3  # padding around a label, in font sizes
_OFFSCREEN_SAMPLES = 0  # no multisampling: 3x faster on CPU (llvmpipe), and the cable is drawn >= min_cable_px wide
_ENV_RENDER_FLAGS = {"shadow": False, "reflection": False}  # as in _Tile.render
DEFAULT_ENV_CABLE_RADIUS = 0.005  # m, drawn for an environment whose physics has a centreline but no scene
_CAMERA_DISTANCE_RANGE = (1e-3, 1e6)  # m: the tracking camera's distance is clamped to this

SceneLike = Union[Scene, str]


# --------------------------------------------------------------------------------------------------- validation


def _check_number(name: str, value, low: float, high: float, *, low_open: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number in {'(' if low_open else '['}{low:g}, {high:g}], got {value!r}")
    v = float(value)
    if not (math.isfinite(v) and (v > low if low_open else v >= low) and v <= high):
        raise ValueError(f"{name} must be a number in {'(' if low_open else '['}{low:g}, {high:g}], got {value!r}")
    return v


def _check_size(name: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not MIN_SIZE <= value <= MAX_SIZE \
            or value % 2:
        raise ValueError(f"{name} must be an even integer in [{MIN_SIZE}, {MAX_SIZE}] pixels (H.264 needs even "
                         f"sizes), got {value!r}")
    return int(value)


def _check_fps(fps) -> int:
    if isinstance(fps, bool) or not isinstance(fps, (int, np.integer)) or not 1 <= fps <= MAX_FPS:
        raise ValueError(f"fps must be an integer in [1, {MAX_FPS}] frames per second, got {fps!r}")
    return int(fps)


def _check_scene(scene: SceneLike) -> Scene:
    if isinstance(scene, str):
        return scenes.get(scene)  # ValueError for an unknown name
    if not isinstance(scene, Scene):
        raise ValueError(f"scene must be an mjcable.Scene or one of {scenes.names()}, got {type(scene).__name__}")
    return scene


def _check_camera(camera) -> str:
    if not isinstance(camera, str) or not camera:
        raise ValueError(f"camera must be {TRACK!r} or the name of a camera in the model, got {camera!r}")
    return camera


def _check_elevation(elevation) -> float:
    return _check_number("elevation", elevation, 0.0, MAX_ELEVATION)


def _check_progress(progress) -> Optional[bool]:
    if progress is not None and not isinstance(progress, bool):
        raise ValueError(f"progress must be True, False or None (automatic), got {progress!r}")
    return progress


def _check_path(path) -> Path:
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path must be a file path, got {path!r}")
    p = Path(path)
    if p.suffix.lower() != ".mp4":
        raise ValueError(f"path must end in .mp4 (the video is H.264 in MP4), got {str(path)!r}")
    if not p.parent.is_dir():
        raise ValueError(f"path {str(path)!r} is in a folder that does not exist ({str(p.parent)!r}); create it first")
    return p


@dataclasses.dataclass(frozen=True)
class _Options:
    """Validated options shared by every render function."""

    seconds: float
    fps: int
    width: int
    height: int
    camera: str
    elevation: float
    min_cable_px: float
    progress: Optional[bool]

    @property
    def n_frames(self) -> int:
        """Frames at times 0, 1/fps, ...: together they last ``seconds`` (at least one frame)."""
        return max(1, int(round(self.seconds * self.fps)))


def _options(seconds, fps, width, height, camera, elevation, min_cable_px, progress) -> _Options:
    return _Options(
        seconds=_check_number("seconds", seconds, 0.0, MAX_SECONDS, low_open=True),
        fps=_check_fps(fps),
        width=_check_size("width", width),
        height=_check_size("height", height),
        camera=_check_camera(camera),
        elevation=_check_elevation(elevation),
        min_cable_px=_check_number("min_cable_px", min_cable_px, 0.0, 100.0),
        progress=_check_progress(progress),
    )


# ------------------------------------------------------------------------------------------------------ labels


@functools.lru_cache(maxsize=None)
def _font_path() -> str:
    from matplotlib import font_manager

    return font_manager.findfont(font_manager.FontProperties(family="DejaVu Sans Mono"), fallback_to_default=True)


@functools.lru_cache(maxsize=256)
def _text_mask(text: str, size_px: int) -> np.ndarray:
    """Anti-aliased coverage ``(h, w)`` float32 in [0, 1] of ``text`` in DejaVu Sans Mono (matplotlib's bundled
    font, rasterised by its FreeType wrapper), ``size_px`` pixels per em."""
    from matplotlib import ft2font

    font = ft2font.FT2Font(_font_path())
    font.set_size(size_px, 72)  # at 72 dpi one point is one pixel
    font.set_text(text, 0.0)
    font.draw_glyphs_to_bitmap(antialiased=True)
    mask = np.asarray(font.get_image(), dtype=np.float32) / 255.0
    mask.setflags(write=False)
    return mask


def _draw_label(image: np.ndarray, text: str, *, corner: str) -> None:
    """Draw ``text`` in white on a translucent dark box into ``image`` ``(h, w, 3)`` uint8, in place, at the
    ``"left"`` or ``"right"`` top corner, clipped to the image."""
    h, w = image.shape[:2]
    size = max(_MIN_LABEL_PX, int(round(h * _LABEL_HEIGHT_FRACTION)))
    mask = _text_mask(text, size)
    pad = max(2, int(round(size * _LABEL_PAD_FRACTION)))
    box_h = min(mask.shape[0] + 2 * pad, h)
    box_w = min(mask.shape[1] + 2 * pad, w)
    x0 = 0 if corner == "left" else w - box_w
    region = image[:box_h, x0:x0 + box_w].astype(np.float32)
    region *= 1.0 - _LABEL_BOX_ALPHA
    m = mask[: box_h - pad, : box_w - pad][:, :, None]
    sub = region[pad:pad + m.shape[0], pad:pad + m.shape[1]]
    sub[...] = sub * (1.0 - m) + 255.0 * m
    image[:box_h, x0:x0 + box_w] = np.clip(region + 0.5, 0, 255).astype(np.uint8)


# ------------------------------------------------------------------------------------------------------ camera


class _Tracker:
    """The tracking free camera shared by the tiles of one video (see the module docstring)."""

    def __init__(self, *, fps: int, width: int, height: int, fovy_deg: float, elevation_deg: float,
                 min_half_extent: float):
        self.cam = mujoco.MjvCamera()
        self.cam.type = mujoco.mjtCamera.mjCAMERA_FREE
        self.cam.azimuth = TRACK_AZIMUTH
        self.cam.elevation = -elevation_deg
        az, el = math.radians(TRACK_AZIMUTH), math.radians(-elevation_deg)
        forward = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
        right = np.cross(forward, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        self._axes = np.stack([right, up, forward])  # camera frame rows
        self._tan_y = math.tan(math.radians(fovy_deg) / 2)
        self._tan_x = self._tan_y * width / height
        self._min_half = min_half_extent
        self._blend = 1.0 - math.exp(-1.0 / (fps * TRACK_TIME_CONSTANT))
        self._lookat: Optional[np.ndarray] = None
        self._distance = 0.0

    def update(self, boxes: Sequence[np.ndarray]) -> mujoco.MjvCamera:
        """Follow the union of ``boxes`` (each ``(2, 3)``: min and max corners, metres); keep still if none."""
        if boxes:
            lookat, distance = self._target(np.stack([np.min([b[0] for b in boxes], axis=0),
                                                      np.max([b[1] for b in boxes], axis=0)]))
            if self._lookat is None:
                self._lookat, self._distance = lookat, distance
            else:
                self._lookat = self._lookat + self._blend * (lookat - self._lookat)
                smoothed = self._distance + self._blend * (distance - self._distance)
                self._distance = max(distance, smoothed)  # zoom out at once, in smoothly
        if self._lookat is not None:
            self.cam.lookat[:] = self._lookat
            self.cam.distance = self._distance
        return self.cam

    def _target(self, box: np.ndarray) -> Tuple[np.ndarray, float]:
        center = box.mean(axis=0)
        half = np.maximum(0.5 * (box[1] - box[0]), self._min_half)
        corners = center + half * np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        local = (corners - center) @ self._axes.T  # (8, 3): right, up, forward
        # A corner at (r, u, f) relative to the look-at point is in frame when |r| <= tan_x (d + f) / margin.
        need = np.maximum(np.abs(local[:, 0]) * FRAME_MARGIN / self._tan_x,
                          np.abs(local[:, 1]) * FRAME_MARGIN / self._tan_y) - local[:, 2]
        return center, float(np.clip(need.max(), *_CAMERA_DISTANCE_RANGE))


# ------------------------------------------------------------------------------------------------------- tiles


class _Tile:
    """One simulation and its renderer; freezes at the last good frame when the simulation diverges."""

    def __init__(self, sim: Simulator, label: str, opts: _Options):
        self.sim = sim
        self.label = label
        self.opts = opts
        m = sim.mj_model
        # Visual-only settings of the simulator's own model: an offscreen buffer of the video's size.
        m.vis.global_.offwidth = opts.width
        m.vis.global_.offheight = opts.height
        m.vis.quality.offsamples = _OFFSCREEN_SAMPLES
        try:
            self.renderer = mujoco.Renderer(m, opts.height, opts.width)
        except mujoco.FatalError as exc:
            raise RuntimeError(
                f"no offscreen OpenGL context ({exc}). Set MUJOCO_GL=egl (or osmesa) in the environment before "
                f"Python imports mujoco; MUJOCO_GL is now {os.environ.get('MUJOCO_GL')!r}") from exc
        self.diverged: Optional[SimulationDivergedError] = None
        self.last: Optional[np.ndarray] = None
        self.radius = sim.scene.cable.radius

    @property
    def live(self) -> bool:
        return self.diverged is None

    def advance(self, seconds: float) -> None:
        if not self.live:
            return
        try:
            self.sim.step(seconds)
        except SimulationDivergedError as exc:
            self.diverged = exc

    def box(self) -> np.ndarray:
        p = self.sim.positions
        return np.stack([p.min(axis=0) - self.radius, p.max(axis=0) + self.radius])

    def render(self, camera, pixel_size: float) -> np.ndarray:
        if not self.live:
            if self.last is None:  # pragma: no cover - a Simulator never starts diverged
                self.last = np.zeros((self.opts.height, self.opts.width, 3), np.uint8)
            image = (self.last * _DIVERGED_SHADE).astype(np.uint8)
            _draw_label(image, f"{self.label}: diverged at t={self.diverged.time:.3f} s", corner="left")
            return image
        r = self.renderer
        # Cameras and lights in world coordinates: derived quantities only, which a backend that poses bodies with
        # mj_kinematics alone (the particle solvers' proxy) leaves at zero: unlit and camera-less frames.
        mujoco.mj_camlight(self.sim.mj_model, self.sim.mj_data)
        r.update_scene(self.sim.mj_data, camera=camera, scene_option=_scene_option())
        r.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0  # CPU rendering: shadows and reflections cost 5-10x
        r.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
        _add_centreline(r.scene, self.sim.positions, max(self.radius, self.opts.min_cable_px * pixel_size))
        self.last = r.render().copy()
        image = self.last.copy()
        _draw_label(image, self.label, corner="left")
        _draw_label(image, f"t={self.sim.time:.2f} s", corner="right")
        return image

    def close(self) -> None:
        self.renderer.close()


@functools.lru_cache(maxsize=None)
def _scene_option() -> mujoco.MjvOption:
    """What MuJoCo draws besides geoms: no sites or tendons (the springs model's invisible tendons and the particle
    sites are hidden under the drawn centreline anyway, and cost a fifth of the frame)."""
    option = mujoco.MjvOption()
    option.sitegroup[:] = 0
    option.flags[mujoco.mjtVisFlag.mjVIS_TENDON] = 0
    return option


def _add_centreline(scn: mujoco.MjvScene, points: np.ndarray, radius: float) -> None:
    """Append the polyline ``points`` ``(n, 3)`` to ``scn`` as capsules of ``radius`` metres. A loop over segments,
    but per frame, not per physics step: about 5 µs a segment against ~50 ms to render the frame."""
    n_free = scn.maxgeom - scn.ngeom
    count = min(len(points) - 1, n_free)
    eye = np.eye(3).ravel()
    geoms = mujoco.MjvScene.geoms.__get__(scn)  # all maxgeom slots (dm_control's subclass shows the first ngeom)
    for i in range(count):
        g = geoms[scn.ngeom]
        mujoco.mjv_initGeom(g, mujoco.mjtGeom.mjGEOM_CAPSULE, np.zeros(3), np.zeros(3), eye, _CABLE_RGBA)
        mujoco.mjv_connector(g, mujoco.mjtGeom.mjGEOM_CAPSULE, radius, points[i], points[i + 1])
        g.specular = _CABLE_SPECULAR
        scn.ngeom += 1


class _Frames:
    """Steps tiles frame by frame and renders them; use as a context manager (closes the renderers)."""

    def __init__(self, tiles: List[_Tile], opts: _Options):
        self.tiles = tiles
        self.opts = opts
        self.tracker = None
        self.camera = opts.camera
        self._cam_id = -1
        m = tiles[0].sim.mj_model
        self._fovy = float(m.vis.global_.fovy)
        if opts.camera == TRACK:
            length = max(t.sim.scene.cable.length for t in tiles)
            self.tracker = _Tracker(fps=opts.fps, width=opts.width, height=opts.height, fovy_deg=self._fovy,
                                    elevation_deg=opts.elevation, min_half_extent=MIN_TRACK_HALF_EXTENT * length)
            return
        for t in tiles:
            if mujoco.mj_name2id(t.sim.mj_model, mujoco.mjtObj.mjOBJ_CAMERA, opts.camera) < 0:
                self.close()
                raise ValueError(f"camera must be {TRACK!r} or a camera of model {t.sim.model!r}, got "
                                 f"{opts.camera!r}")
        self._cam_id = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, opts.camera)
        self._fovy = float(m.cam_fovy[self._cam_id])

    def __enter__(self) -> "_Frames":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        for t in self.tiles:
            t.close()

    def __iter__(self) -> Iterator[List[np.ndarray]]:
        opts = self.opts
        bar = _progress_bar(opts.n_frames * len(self.tiles), opts.progress, opts.n_frames)
        try:
            for k in range(opts.n_frames):
                if k:
                    for t in self.tiles:
                        t.advance(1.0 / opts.fps)
                camera, pixel = self._camera()
                yield [t.render(camera, pixel) for t in self.tiles]
                bar.update(1)
        finally:
            bar.close()

    def _camera(self):
        if self.tracker is None:  # a fixed camera of the model: size the cable at its distance from the camera
            sim = self.tiles[0].sim
            mujoco.mj_camlight(sim.mj_model, sim.mj_data)
            distance = float(np.linalg.norm(sim.positions.mean(axis=0) - sim.mj_data.cam_xpos[self._cam_id]))
            return self.camera, self._pixel_size(distance)
        cam = self.tracker.update([t.box() for t in self.tiles if t.live])
        return cam, self._pixel_size(cam.distance)

    def _pixel_size(self, distance: float) -> float:
        """Metres per pixel at ``distance`` metres from the camera."""
        return 2.0 * distance * math.tan(math.radians(self._fovy) / 2) / self.opts.height


def _progress_bar(total_renders: int, progress: Optional[bool], n_frames: int):
    from tqdm.auto import tqdm

    if progress is None:
        disable = None if total_renders >= PROGRESS_MIN_RENDERS else True  # None: tqdm hides it off a terminal
    else:
        disable = not progress
    return tqdm(total=n_frames, unit="frame", desc="rendering", disable=disable, leave=False)


def _make_tiles(scene: Scene, models: Sequence[str], opts: _Options, dt: float, settings: Mapping[str, dict],
                labels: Optional[Sequence[str]] = None) -> List[_Tile]:
    tiles: List[_Tile] = []
    labels = list(models) if labels is None else labels
    try:
        for model, label in zip(models, labels):
            sim = Simulator(scene, model, dt=dt, **dict(settings.get(model, {})))
            tiles.append(_Tile(sim, label, opts))
    except BaseException:
        for t in tiles:
            t.close()
        raise
    return tiles


# ---------------------------------------------------------------------------------------------------- public


def available_models(scene: SceneLike, *, models: Optional[Sequence[str]] = None, dt: float = 0.002,
                     settings: Optional[Mapping[str, dict]] = None) -> Tuple[Tuple[str, ...], Dict[str, Exception]]:
    """The models that build and start a simulation of ``scene``.

    A model that is not written yet (``NotImplementedError``, ``ImportError``) is left out quietly; any other
    error is a bug and is returned, so that the caller reports it.

    Args:
      scene: a :class:`~mjcable.scene.Scene` or the name of a built-in scene.
      models: candidates (default: all of :data:`mjcable.MODELS`).
      dt: the simulators' step in seconds.
      settings: per-model settings, ``{model: {setting: value}}``.

    Returns:
      ``(available, problems)``: the models that work, in the order given, and ``{model: exception}`` for those
      that failed with an error other than not being implemented.
    """
    scene = _check_scene(scene)
    models = catalog.names() if models is None else models
    settings = _check_settings(settings, models)
    available, problems = [], {}
    for model in models:
        catalog.check_model(model)
        try:
            Simulator(scene, model, dt=dt, **dict(settings.get(model, {})))
        except UNAVAILABLE_ERRORS:
            continue
        except Exception as exc:  # noqa: BLE001 - reported to the caller
            problems[model] = exc
            continue
        available.append(model)
    return tuple(available), problems


def _check_settings(settings, models) -> Mapping[str, dict]:
    if settings is None:
        return {}
    if not isinstance(settings, Mapping) or not all(isinstance(v, Mapping) for v in settings.values()):
        raise ValueError(f"settings must map model names to dicts of settings, got {settings!r}")
    unknown = sorted(set(settings) - set(models))
    if unknown:
        raise ValueError(f"settings name model(s) {unknown} that are not rendered; rendered: {list(models)}")
    return settings


def frames(scene: SceneLike, model: str, *, seconds: float, fps: int = 30, width: int = 320, height: int = 240,
           dt: float = 0.002, camera: str = TRACK, elevation: float = DEFAULT_ELEVATION, min_cable_px: float = 1.5,
           label: Optional[str] = None, progress: Optional[bool] = False, **settings) -> np.ndarray:
    """Render a simulation of ``scene`` with ``model`` into memory.

    Args:
      scene: a :class:`~mjcable.scene.Scene` or the name of a built-in scene.
      model: one of :data:`mjcable.MODELS`.
      seconds: simulated (and video) duration in seconds, in (0, 3600].
      fps: frames per second, an integer in [1, 240]; frame ``k`` shows simulated time ``k / fps``.
      width, height: frame size in pixels, even, in [16, 4096].
      dt: the simulator's step in seconds.
      camera: ``"track"`` (the tracking camera) or the name of a camera of the model, e.g. ``"overview"``.
      elevation: the tracking camera's angle above the horizon in degrees, in [0, 85].
      min_cable_px: the least radius in pixels the cable is drawn with, in [0, 100].
      label: the tile's label (default: the model's name).
      progress: show a progress bar (``None``: for long renders on a terminal).
      **settings: the model's settings, passed to :class:`~mjcable.Simulator`.

    Returns:
      ``(n_frames, height, width, 3)`` uint8 RGB frames, ``n_frames = max(1, round(seconds * fps))``.

    Example::

        video = render.frames("hang", "springs", seconds=0.5, width=160, height=120)
    """
    scene, opts, label = _check_single(scene, model, seconds, fps, width, height, camera, elevation, min_cable_px,
                                       label, progress)
    out = np.empty((opts.n_frames, opts.height, opts.width, 3), np.uint8)
    with _Frames(_make_tiles(scene, [model], opts, dt, {model: settings}, [label]), opts) as stream:
        for k, (image,) in enumerate(stream):
            out[k] = image
    return out


def _check_single(scene, model, seconds, fps, width, height, camera, elevation, min_cable_px, label, progress):
    scene = _check_scene(scene)
    catalog.check_model(model)
    opts = _options(seconds, fps, width, height, camera, elevation, min_cable_px, progress)
    if label is None:
        label = model
    if not isinstance(label, str):
        raise ValueError(f"label must be a string, got {label!r}")
    return scene, opts, label


def render_video(scene: SceneLike, model: str, path, *, seconds: float = 5.0, fps: int = 30, width: int = 640,
                 height: int = 480, dt: float = 0.002, camera: str = TRACK, elevation: float = DEFAULT_ELEVATION,
                 min_cable_px: float = 1.5, label: Optional[str] = None, progress: Optional[bool] = None,
                 **settings) -> Path:
    """Render a simulation of ``scene`` with ``model`` to an MP4 file, atomically.

    Arguments as in :func:`frames`; ``path`` is the ``.mp4`` file to write (its folder must exist). A model that
    diverges freezes and is labelled ``"diverged at t=..."``; the video still has its full length.

    Returns:
      The path written.

    Example::

        render.render_video("drape", "springs", "drape.mp4", seconds=3, width=480, height=360)
    """
    scene, opts, label = _check_single(scene, model, seconds, fps, width, height, camera, elevation, min_cable_px,
                                       label, progress)
    path = _check_path(path)
    with _Frames(_make_tiles(scene, [model], opts, dt, {model: settings}, [label]), opts) as stream:
        write_video(path, (images[0] for images in stream), fps=opts.fps, shape=(opts.height, opts.width))
    return path


def _grid_options(scene, models, seconds, fps, tile_width, tile_height, columns, camera, elevation, min_cable_px,
                  progress, settings):
    scene = _check_scene(scene)
    if isinstance(models, str) or not isinstance(models, Sequence) or not models:
        raise ValueError(f"models must be a non-empty sequence of names from {catalog.names()}, got {models!r}")
    for model in models:
        catalog.check_model(model)
    if len(set(models)) != len(models):
        raise ValueError(f"models must not repeat a name, got {list(models)}")
    opts = _options(seconds, fps, tile_width, tile_height, camera, elevation, min_cable_px, progress)
    n = len(models)
    if columns is None:
        columns = math.ceil(n / math.ceil(n / 4))  # up to 4 per row, rows filled evenly
    if isinstance(columns, bool) or not isinstance(columns, (int, np.integer)) or not 1 <= columns <= n:
        raise ValueError(f"columns must be an integer in [1, {n}] (the number of models), got {columns!r}")
    return scene, list(models), opts, int(columns), _check_settings(settings, models)


def _grid_stream(scene, models, opts, columns, dt, settings) -> Iterator[np.ndarray]:
    rows = math.ceil(len(models) / columns)
    h, w = opts.height, opts.width
    with _Frames(_make_tiles(scene, models, opts, dt, settings), opts) as stream:
        for images in stream:
            canvas = np.full((rows * h, columns * w, 3), _EMPTY_TILE, np.uint8)
            for i, image in enumerate(images):
                r, c = divmod(i, columns)
                canvas[r * h:(r + 1) * h, c * w:(c + 1) * w] = image
            yield canvas


def grid_frames(scene: SceneLike, models: Sequence[str], *, seconds: float, fps: int = 30, tile_width: int = 320,
                tile_height: int = 240, dt: float = 0.002, columns: Optional[int] = None, camera: str = TRACK,
                elevation: float = DEFAULT_ELEVATION, min_cable_px: float = 1.5,
                settings: Optional[Mapping[str, dict]] = None, progress: Optional[bool] = False) -> np.ndarray:
    """Render several models of one scene side by side into memory.

    Args:
      scene: a :class:`~mjcable.scene.Scene` or the name of a built-in scene.
      models: model names, each once (see :func:`available_models` for "every model that works").
      tile_width, tile_height: one tile's size in pixels, even, in [16, 4096].
      columns: tiles per row (default: up to 4, rows filled evenly); unused cells are dark grey.
      settings: per-model settings, ``{model: {setting: value}}``.
      Other arguments as in :func:`frames`; all tiles share one tracking camera.

    Returns:
      ``(n_frames, rows * tile_height, columns * tile_width, 3)`` uint8 RGB frames.
    """
    scene, models, opts, columns, settings = _grid_options(scene, models, seconds, fps, tile_width, tile_height,
                                                           columns, camera, elevation, min_cable_px, progress,
                                                           settings)
    return np.stack(list(_grid_stream(scene, models, opts, columns, dt, settings)))


def render_grid(scene: SceneLike, models: Sequence[str], path, *, seconds: float = 5.0, fps: int = 30,
                tile_width: int = 320, tile_height: int = 240, dt: float = 0.002, columns: Optional[int] = None,
                camera: str = TRACK, elevation: float = DEFAULT_ELEVATION, min_cable_px: float = 1.5,
                settings: Optional[Mapping[str, dict]] = None, progress: Optional[bool] = None) -> Path:
    """Render several models of one scene side by side, labelled, to an MP4 file, atomically.

    Arguments as in :func:`grid_frames`; ``path`` is the ``.mp4`` file to write (its folder must exist). A model
    that diverges freezes in its tile, labelled ``"diverged at t=..."``, while the others go on.

    Returns:
      The path written.

    Example::

        models, problems = render.available_models("table")
        render.render_grid("table", models, "table.mp4", seconds=3)
    """
    scene, models, opts, columns, settings = _grid_options(scene, models, seconds, fps, tile_width, tile_height,
                                                           columns, camera, elevation, min_cable_px, progress,
                                                           settings)
    path = _check_path(path)
    rows = math.ceil(len(models) / columns)
    write_video(path, _grid_stream(scene, models, opts, columns, dt, settings), fps=opts.fps,
                shape=(rows * opts.height, columns * opts.width))
    return path


def write_video(path, images, *, fps: int, shape: Tuple[int, int]) -> Path:
    """Write ``images`` (an iterable of ``shape + (3,)`` uint8 RGB frames) to ``path`` as H.264 MP4, atomically,
    streaming (frames are not all held in memory).

    Args:
      path: the ``.mp4`` file (its folder must exist).
      images: the frames, each ``(height, width, 3)`` uint8.
      fps: frames per second.
      shape: ``(height, width)`` in pixels, both even.
    """
    import mediapy

    path = _check_path(path)
    fps = _check_fps(fps)
    height, width = shape
    _check_size("height", height)
    _check_size("width", width)
    _use_bundled_ffmpeg()
    with atomic_path(path) as tmp:
        with mediapy.VideoWriter(tmp, (height, width), fps=fps) as writer:
            for image in images:
                writer.add_image(image)
    return path


def read_video(path) -> Tuple[np.ndarray, float]:
    """Read an MP4 written here back into memory.

    Uses imageio-ffmpeg's own reader: ``mediapy.read_video`` passes ffmpeg's ``-vsync`` option, which the ffmpeg 9
    bundled with imageio-ffmpeg 0.8 no longer has.

    Returns:
      ``(frames, fps)``: ``(n, height, width, 3)`` uint8 RGB frames and the frame rate.
    """
    import imageio_ffmpeg

    if not isinstance(path, (str, os.PathLike)) or not Path(path).is_file():
        raise ValueError(f"path must be an existing video file, got {path!r}")
    reader = imageio_ffmpeg.read_frames(str(path), pix_fmt="rgb24")
    try:
        meta = next(reader)
        width, height = meta["size"]
        images = [np.frombuffer(buf, np.uint8).reshape(height, width, 3) for buf in reader]
    finally:
        reader.close()
    return np.stack(images) if images else np.empty((0, height, width, 3), np.uint8), float(meta["fps"])


@functools.lru_cache(maxsize=None)
def _use_bundled_ffmpeg() -> None:
    import imageio_ffmpeg
    import mediapy

    mediapy.set_ffmpeg(imageio_ffmpeg.get_ffmpeg_exe())


def render_env(env, path, *, seconds: float = 5.0, fps: int = 30, width: int = 640, height: int = 480,
               camera: Union[str, int] = "overview", policy: str = "random", seed: Optional[int] = None,
               min_cable_px: float = 1.5) -> Path:
    """Record an episode of a dm_control environment (e.g. from ``mjcable.envs.load``) to an MP4 file.

    Frames are taken by a fixed-step accumulator over the environment's control steps: the episode advances one
    control step at a time and a frame is written whenever the next frame time (``k / fps``) is reached, so the
    video plays in real time whatever the control rate. Recording stops at ``seconds`` or at the episode's end.

    Args:
      env: a ``dm_control.rl.control.Environment`` (``reset``, ``step``, ``action_spec``, ``control_timestep``,
        ``physics.render``).
      path: the ``.mp4`` file to write (its folder must exist).
      seconds: at most this many seconds of episode, in (0, 3600].
      fps: frames per second, an integer in [1, 240].
      width, height: frame size in pixels, even, in [16, 4096].
      camera: camera name or id in the environment's model (``-1``: MuJoCo's free camera).
      policy: ``"random"`` (uniform within the action spec's bounds) or ``"zero"``.
      seed: seed of the random policy.
      min_cable_px: the least radius in pixels the cable is drawn with, in [0, 100], where the physics reads out
        its ``centreline()`` (as ``mjcable.envs`` physics do); otherwise only the model's own geoms show.

    Returns:
      The path written.
    """
    seconds = _check_number("seconds", seconds, 0.0, MAX_SECONDS, low_open=True)
    min_cable_px = _check_number("min_cable_px", min_cable_px, 0.0, 100.0)
    fps = _check_fps(fps)
    width, height = _check_size("width", width), _check_size("height", height)
    if policy not in ("random", "zero"):
        raise ValueError(f"policy must be 'random' or 'zero', got {policy!r}")
    path = _check_path(path)
    rng = np.random.default_rng(seed)
    spec = env.action_spec()
    low = np.broadcast_to(np.asarray(spec.minimum, dtype=np.float64), spec.shape)
    high = np.broadcast_to(np.asarray(spec.maximum, dtype=np.float64), spec.shape)
    if policy == "random" and not (np.all(np.isfinite(low)) and np.all(np.isfinite(high))):
        raise ValueError("policy 'random' needs finite action bounds; the environment's action spec has infinite ones")
    control_dt = float(env.control_timestep())
    n_frames = max(1, int(round(seconds * fps)))
    if isinstance(camera, str):
        names = [env.physics.model.id2name(i, "camera") for i in range(env.physics.model.ncam)]
        camera = camera if camera in names else -1

    from dm_control.mujoco.wrapper import core as dm_core

    option = dm_core.MjvOption()  # dm_control's wrapper of _scene_option()
    option.sitegroup[:] = 0
    option.flags[mujoco.mjtVisFlag.mjVIS_TENDON] = 0

    def stream() -> Iterator[np.ndarray]:
        timestep = env.reset()
        elapsed = 0.0
        for k in range(n_frames):
            while elapsed + 0.5 * control_dt < k / fps:  # catch up to this frame's time, to within half a step
                if timestep.last():
                    return
                action = rng.uniform(low, high) if policy == "random" else np.clip(np.zeros(spec.shape), low, high)
                timestep = env.step(action.astype(spec.dtype))
                elapsed += control_dt
            yield env.physics.render(height=height, width=width, camera_id=camera, scene_option=option,
                                     render_flag_overrides=_ENV_RENDER_FLAGS, scene_callback=draw_cable)

    def draw_cable(physics, scn: mujoco.MjvScene) -> None:
        """Draw the cable's centreline as in :func:`frames`, where the physics reads it out (mjcable.envs)."""
        if not hasattr(physics, "centreline"):
            return
        points = np.asarray(physics.centreline())
        radius = float(physics.scene.cable.radius) if hasattr(physics, "scene") else DEFAULT_ENV_CABLE_RADIUS
        cam = scn.camera[0]
        distance = float(np.linalg.norm(points.mean(axis=0) - np.asarray(cam.pos)))
        pixel = 2.0 * distance * (cam.frustum_top - cam.frustum_bottom) / 2 / cam.frustum_near / height
        _add_centreline(scn, points, max(radius, min_cable_px * pixel))

    return write_video(path, stream(), fps=fps, shape=(height, width))
