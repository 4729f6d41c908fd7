"""The public render functions: one model or a labelled grid of several models of one scene, into memory or to an
MP4 file; an episode of a dm_control environment to MP4; and which models can render a scene.

Example::

    from mjcable import render

    render.render_video("hang", "springs", "hang.mp4", seconds=3)
    models, problems = render.available_models("table")
    render.render_grid("table", models, "table.mp4", seconds=3)
"""

from __future__ import annotations

from pathlib import Path
from typing import Dict, Iterator, Mapping, Optional, Sequence, Tuple, Union

import mujoco
import numpy as np

from mjcable import _validate, catalog
from mjcable.render import camera as cameras
from mjcable.render.grid import Layout, compose, grid_layout
from mjcable.render.options import (Options, SceneLike, check_fps, check_min_cable_px, check_path, check_scene,
                                    check_seconds, check_settings, check_size, options)
from mjcable.render.overlays import add_cables, add_centreline
from mjcable.render.tiles import Drive, TileStream, make_tiles
from mjcable.render.video_io import write_video
from mjcable.simulator import Simulator

__all__ = ["frames", "render_video", "grid_frames", "render_grid", "render_parts", "render_env", "available_models", "POLICIES",
           "DEFAULT_ENV_CABLE_RADIUS"]

POLICIES = ("random", "zero")  # render_env's policies
DEFAULT_ENV_CABLE_RADIUS = 0.005  # m, drawn for an environment whose physics has a centreline but no scene
_ENV_RENDER_FLAGS = {"shadow": False, "reflection": False}  # as in tiles.Tile.render


def available_models(scene: SceneLike, *, models: Optional[Sequence[str]] = None, dt: float = 0.002,
                     settings: Optional[Mapping[str, dict]] = None) -> Tuple[Tuple[str, ...], Dict[str, Exception]]:
    """The models that build and start a simulation of ``scene``.

    Every candidate is built once; a model that fails (with any ``Exception``) is left out and its error returned,
    so that the caller reports it.

    Args:
      scene: a :class:`~mjcable.scene.Scene` or the name of a built-in scene.
      models: candidates (default: every model of the catalogue, :func:`mjcable.catalog.names`, at call time).
      dt: the simulators' step in seconds.
      settings: per-model settings, ``{model: {setting: value}}``.

    Returns:
      ``(available, problems)``: the models that work, in the order given, and ``{model: exception}`` for those
      that failed.
    """
    scene = check_scene(scene)
    models = catalog.names() if models is None else _check_models(models)
    catalog.check_dt(dt)
    settings = check_settings(settings, models)
    available, problems = [], {}
    for model in models:
        try:
            Simulator(scene, model, dt=dt, **dict(settings.get(model, {})))
        except Exception as exc:  # noqa: BLE001 - reported to the caller
            problems[model] = exc
            continue
        available.append(model)
    return tuple(available), problems


def _check_models(models) -> Tuple[str, ...]:
    if isinstance(models, str) or not isinstance(models, Sequence) or not models:
        raise ValueError(f"models must be a non-empty sequence of names from {catalog.names()}, got {models!r}")
    for model in models:
        catalog.check_model(model)
    if len(set(models)) != len(models):
        raise ValueError(f"models must not repeat a name, got {list(models)}")
    return tuple(models)


def _single(scene, model, label, **opts) -> Tuple:
    scene = check_scene(scene)
    catalog.check_model(model)
    opts = options(**opts)
    label = model if label is None else label
    if not isinstance(label, str):
        raise ValueError(f"label must be a string, got {label!r}")
    return scene, opts, label


def frames(scene: SceneLike, model: str, *, seconds: float, fps: int = 30, width: int = 320, height: int = 240,
           dt: float = 0.002, camera: str = cameras.TRACK, elevation: float = cameras.DEFAULT_ELEVATION,
           min_cable_px: float = 1.5, stripe: bool = False, label: Optional[str] = None,
           progress: Optional[bool] = False, drive: Optional[Drive] = None, **settings) -> np.ndarray:
    """Render a simulation of ``scene`` with ``model`` into memory.

    Args:
      scene: a :class:`~mjcable.scene.Scene` or the name of a built-in scene.
      model: one of :func:`mjcable.catalog.names`.
      seconds: simulated (and video) duration in seconds, in (0, 3600].
      fps: frames per second, an integer in [1, 240]; frame ``k`` shows simulated time ``k / fps``.
      width, height: frame size in pixels, even, in [16, 4096].
      dt: the simulator's step in seconds.
      camera: ``"track"`` (the tracking camera, see :mod:`mjcable.render.camera`) or the name of a camera of the
        model, e.g. ``"overview"``.
      elevation: the tracking camera's angle above the horizon in degrees, in [0, 85].
      min_cable_px: the least radius in pixels the cable is drawn with, in [0, 100].
      label: the tile's label (default: the model's name).
      progress: show a progress bar (``None``: for long renders on a terminal).
      stripe: draw a stripe along the cable's material frame (d₁) so that twist shows, for models with frames
        (``cosserat``, ``joints``, ``composite``; the others are drawn without).
      drive: ``drive(simulator)``, called before each frame's step (every ``1 / fps`` s): what the scene does at
        run time, such as reeling a winch; ``None``: nothing.
      **settings: the model's settings, passed to :class:`~mjcable.Simulator`.

    Returns:
      ``(n_frames, height, width, 3)`` uint8 RGB frames, ``n_frames = max(1, round(seconds * fps))``.

    Example::

        video = render.frames("hang", "springs", seconds=0.5, width=160, height=120)
    """
    scene, opts, label = _single(scene, model, label, seconds=seconds, fps=fps, width=width, height=height,
                                 camera=camera, elevation=elevation, min_cable_px=min_cable_px, progress=progress,
        stripe=stripe)
    drive = _check_drive(drive)
    out = np.empty((opts.n_frames, opts.height, opts.width, 3), np.uint8)
    with TileStream(make_tiles(scene, [model], opts, dt, {model: settings}, [label], drive), opts) as stream:
        for k, (image,) in enumerate(stream):
            out[k] = image
    return out


def render_video(scene: SceneLike, model: str, path, *, seconds: float = 5.0, fps: int = 30, width: int = 640,
                 height: int = 480, dt: float = 0.002, camera: str = cameras.TRACK,
                 elevation: float = cameras.DEFAULT_ELEVATION, min_cable_px: float = 1.5, stripe: bool = False,
                 label: Optional[str] = None, progress: Optional[bool] = None, drive: Optional[Drive] = None,
                 **settings) -> Path:
    """Render a simulation of ``scene`` with ``model`` to an MP4 file, atomically.

    Arguments as in :func:`frames`; ``path`` is the ``.mp4`` file to write (its folder must exist). A model that
    diverges freezes and is labelled ``"diverged at t=..."``; the video still has its full length.

    Returns:
      The path written.

    Example::

        render.render_video("drape", "springs", "drape.mp4", seconds=3, width=480, height=360)
    """
    scene, opts, label = _single(scene, model, label, seconds=seconds, fps=fps, width=width, height=height,
                                 camera=camera, elevation=elevation, min_cable_px=min_cable_px, progress=progress,
        stripe=stripe)
    drive = _check_drive(drive)
    path = check_path(path)
    with TileStream(make_tiles(scene, [model], opts, dt, {model: settings}, [label], drive), opts) as stream:
        write_video(path, (images[0] for images in stream), fps=opts.fps, shape=(opts.height, opts.width))
    return path


def _grid(scene, models, columns, settings, **opts) -> Tuple:
    scene = check_scene(scene)
    models = _check_models(models)
    opts = options(width_name="tile_width", height_name="tile_height", **opts)
    return scene, models, opts, grid_layout(len(models), columns), check_settings(settings, models)


def _check_drive(drive) -> Optional[Drive]:
    if drive is not None and not callable(drive):
        raise ValueError(f"drive must be None or a callable drive(simulator), got {drive!r}")
    return drive


def _grid_stream(scene, models, opts: Options, layout: Layout, dt, settings,
                 drive: Optional[Drive] = None) -> Iterator[np.ndarray]:
    with TileStream(make_tiles(scene, models, opts, dt, settings, drive=drive), opts) as stream:
        for images in stream:
            yield compose(images, layout)


def grid_frames(scene: SceneLike, models: Sequence[str], *, seconds: float, fps: int = 30, tile_width: int = 320,
                tile_height: int = 240, dt: float = 0.002, columns: Optional[int] = None,
                camera: str = cameras.TRACK, elevation: float = cameras.DEFAULT_ELEVATION,
                min_cable_px: float = 1.5, stripe: bool = False, settings: Optional[Mapping[str, dict]] = None,
                progress: Optional[bool] = False, drive: Optional[Drive] = None) -> np.ndarray:
    """Render several models of one scene side by side into memory.

    Args:
      scene: a :class:`~mjcable.scene.Scene` or the name of a built-in scene.
      models: model names, each once (see :func:`available_models` for "every model that works").
      tile_width, tile_height: one tile's size in pixels, even, in [16, 4096].
      columns: tiles per row (default: up to 4, rows filled evenly); unused cells are dark grey.
      settings: per-model settings, ``{model: {setting: value}}``.
      drive: called with each tile's Simulator before each frame's step (as in :func:`frames`).
      Other arguments as in :func:`frames`; all tiles share one tracking camera.

    Returns:
      ``(n_frames, rows * tile_height, columns * tile_width, 3)`` uint8 RGB frames.
    """
    scene, models, opts, layout, settings = _grid(
        scene, models, columns, settings, seconds=seconds, fps=fps, width=tile_width, height=tile_height,
        camera=camera, elevation=elevation, min_cable_px=min_cable_px, progress=progress,
        stripe=stripe)
    return np.stack(list(_grid_stream(scene, models, opts, layout, dt, settings, _check_drive(drive))))


def render_grid(scene: SceneLike, models: Sequence[str], path, *, seconds: float = 5.0, fps: int = 30,
                tile_width: int = 320, tile_height: int = 240, dt: float = 0.002, columns: Optional[int] = None,
                camera: str = cameras.TRACK, elevation: float = cameras.DEFAULT_ELEVATION,
                min_cable_px: float = 1.5, stripe: bool = False, settings: Optional[Mapping[str, dict]] = None,
                progress: Optional[bool] = None, drive: Optional[Drive] = None) -> Path:
    """Render several models of one scene side by side, labelled, to an MP4 file, atomically.

    Arguments as in :func:`grid_frames`; ``path`` is the ``.mp4`` file to write (its folder must exist). A model
    that diverges freezes in its tile, labelled ``"diverged at t=..."``, while the others go on.

    Returns:
      The path written.

    Example::

        models, problems = render.available_models("table")
        render.render_grid("table", models, "table.mp4", seconds=3)
    """
    scene, models, opts, layout, settings = _grid(
        scene, models, columns, settings, seconds=seconds, fps=fps, width=tile_width, height=tile_height,
        camera=camera, elevation=elevation, min_cable_px=min_cable_px, progress=progress,
        stripe=stripe)
    drive = _check_drive(drive)
    path = check_path(path)
    write_video(path, _grid_stream(scene, models, opts, layout, dt, settings, drive), fps=opts.fps,
                shape=layout.shape(opts.height, opts.width))
    return path


def render_parts(parts: Sequence[Tuple[SceneLike, Sequence[str]]], path, *, seconds: float = 5.0, fps: int = 30,
                 tile_width: int = 320, tile_height: int = 240, dt: float = 0.002, columns: Optional[int] = None,
                 camera: str = cameras.TRACK, elevation: float = cameras.DEFAULT_ELEVATION,
                 min_cable_px: float = 1.5, progress: Optional[bool] = None) -> Path:
    """Render grids of several scenes one after another into one MP4 file, atomically: each part ``(scene,
    models)`` as :func:`render_grid` renders it, for ``seconds`` each, all in the grid of the largest part (a part of
    fewer models leaves its last cells dark grey).

    Args:
      parts: a non-empty sequence of ``(scene, models)``: a :class:`~mjcable.scene.Scene` or the name of a built-in
        scene, and the models to show it with side by side (each once).
      columns: tiles per row (default: up to 4, rows filled evenly, for the largest part).
      Other arguments as in :func:`render_grid`.

    Returns:
      The path written.

    Example::

        render.render_parts([("table", ("xpbd", "joints")), (harness, ("joints",))], "demo.mp4", seconds=3)
    """
    if isinstance(parts, (str, bytes)) or not isinstance(parts, Sequence) or not parts or not all(
            isinstance(part, (tuple, list)) and len(part) == 2 for part in parts):
        raise ValueError(f"parts must be a non-empty sequence of (scene, models) pairs, got {parts!r}")
    checked = [_grid(scene, models, None, None, seconds=seconds, fps=fps, width=tile_width, height=tile_height,
                     camera=camera, elevation=elevation, min_cable_px=min_cable_px, progress=progress, stripe=False)
               for scene, models in parts]
    grid = grid_layout(max(len(models) for _, models, *_ in checked), columns)
    opts = checked[0][2]

    def stream() -> Iterator[np.ndarray]:
        for scene, models, part_opts, _, _ in checked:
            layout = Layout(n=len(models), rows=grid.rows, columns=grid.columns)
            yield from _grid_stream(scene, models, part_opts, layout, dt, {})

    path = check_path(path)
    write_video(path, stream(), fps=opts.fps, shape=grid.shape(opts.height, opts.width))
    return path


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
      camera: camera name or id in the environment's model (``-1`` or an unknown name: MuJoCo's free camera).
      policy: ``"random"`` (uniform within the action spec's bounds) or ``"zero"``.
      seed: seed of the random policy.
      min_cable_px: the least radius in pixels the cable is drawn with, in [0, 100], where the physics reads out
        its ``centreline()`` (as ``mjcable.envs`` physics do); otherwise only the model's own geoms show.

    Returns:
      The path written.
    """
    seconds = check_seconds(seconds)
    min_cable_px = check_min_cable_px(min_cable_px)
    fps = check_fps(fps)
    width, height = check_size("width", width), check_size("height", height)
    _validate.choice("policy", policy, POLICIES)
    path = check_path(path)
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

    option = dm_core.MjvOption()  # dm_control's wrapper of camera.scene_option()
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
        """Draw the cables' centrelines as in :func:`frames` (each cable in its colour), where the physics reads
        them out (mjcable.envs)."""
        if not hasattr(physics, "centreline"):
            return
        points = np.asarray(physics.centreline())
        pixel = cameras.scene_pixel_size(scn, points.mean(axis=0), height)
        if hasattr(physics, "scene"):
            add_cables(scn, physics.scene, points, min_cable_px * pixel)
        else:
            add_centreline(scn, points, max(DEFAULT_ENV_CABLE_RADIUS, min_cable_px * pixel))

    return write_video(path, stream(), fps=fps, shape=(height, width))
