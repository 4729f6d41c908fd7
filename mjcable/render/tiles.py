"""Tiles: one simulation and its offscreen renderer each, stepped and rendered frame by frame together.

Rendering goes through ``mujoco.Renderer`` on EGL (``import mjcable`` sets ``MUJOCO_GL=egl`` when unset, before
MuJoCo is first imported; EGL renders on the CPU where there is no GPU; shadows, reflections and multisampling are
off, as they cost 5-10x on the CPU). The video's frame rate is decoupled from the physics step: each frame advances
every simulation by ``1 / fps`` seconds through :meth:`Simulator.step`, whose own accumulator carries the remainder
below one ``dt`` into the next frame, so frame ``k`` shows the simulation at ``k / fps`` to within one ``dt``.

A tile shows the model's scene, the cable's centreline drawn as capsules of the cable's radius (at least
``min_cable_px`` pixels, so that a thin cable stays visible in small videos), a label and the simulated time. A model
that diverges stops there: its tile freezes, darkens and reads ``"<label>: diverged at t=... s"``, while the other
tiles go on.
"""

from __future__ import annotations

import os
from typing import Callable, Iterator, List, Mapping, Optional, Sequence

import mujoco  # mjcable/__init__.py has set MUJOCO_GL=egl (unless set) before mujoco was first imported
import numpy as np

from mjcable import catalog
from mjcable.errors import SimulationDivergedError
from mjcable.render import camera as cameras
from mjcable.render.options import Options
from mjcable.render.overlays import add_cables, draw_label
from mjcable.scene import Scene
from mjcable.simulator import Simulator

__all__ = ["Tile", "TileStream", "make_tiles", "progress_bar", "Drive", "PROGRESS_MIN_RENDERS"]

Drive = Callable[[Simulator], None]  # what a scene does at run time, called with the Simulator before each frame

PROGRESS_MIN_RENDERS = 150  # tile renders from which a progress bar is shown by default
_DIVERGED_SHADE = 0.45  # brightness factor of a frozen (diverged) tile
_OFFSCREEN_SAMPLES = 0  # no multisampling: 3x faster on CPU (llvmpipe), and the cable is drawn >= min_cable_px wide


class Tile:
    """One simulation and its renderer; freezes at the last good frame when the simulation diverges.

    Args:
      sim: the simulation (its model's offscreen buffer is resized to the tile).
      label: the tile's label.
      opts: the video's options.
      drive: ``drive(sim)``, called before each frame's step: what the scene does at run time (e.g. a winch
        reeling); ``None``: nothing.
    """

    def __init__(self, sim: Simulator, label: str, opts: Options, drive: Optional[Drive] = None):
        self.sim = sim
        self.label = label
        self.opts = opts
        self.drive = drive
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
        self.radius = max(c.radius for c in sim.scene.cables)
        self.has_frames = catalog.get(sim.model).frames

    @property
    def live(self) -> bool:
        """Whether the simulation still runs (has not diverged)."""
        return self.diverged is None

    def advance(self, seconds: float) -> None:
        """Step the simulation by ``seconds``; on divergence, freeze."""
        if not self.live:
            return
        try:
            if self.drive is not None:
                self.drive(self.sim)
            self.sim.step(seconds)
        except SimulationDivergedError as exc:
            self.diverged = exc

    def box(self) -> np.ndarray:
        """``(2, 3)`` min and max corners of the cable (with its radius) in metres."""
        p = self.sim.positions
        return np.stack([p.min(axis=0) - self.radius, p.max(axis=0) + self.radius])

    def render(self, camera, pixel_size: float) -> np.ndarray:
        """The labelled image ``(height, width, 3)`` uint8 seen by ``camera`` (an ``MjvCamera`` or a camera name),
        the cable at least ``min_cable_px`` pixels of ``pixel_size`` metres in radius."""
        if not self.live:
            if self.last is None:  # pragma: no cover - a Simulator never starts diverged
                self.last = np.zeros((self.opts.height, self.opts.width, 3), np.uint8)
            image = (self.last * _DIVERGED_SHADE).astype(np.uint8)
            draw_label(image, f"{self.label}: diverged at t={self.diverged.time:.3f} s", corner="left")
            return image
        r = self.renderer
        # Cameras and lights in world coordinates: derived quantities only, which a backend that poses bodies with
        # mj_kinematics alone (the particle solvers' proxy) leaves at zero: unlit and camera-less frames.
        mujoco.mj_camlight(self.sim.mj_model, self.sim.mj_data)
        r.update_scene(self.sim.mj_data, camera=camera, scene_option=cameras.scene_option())
        r.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0  # CPU rendering: shadows and reflections cost 5-10x
        r.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
        add_cables(r.scene, self.sim.scene, self.sim.positions, self.opts.min_cable_px * pixel_size,
                   frames=self.sim.frames if self.opts.stripe and self.has_frames else None)
        self.last = r.render().copy()
        image = self.last.copy()
        draw_label(image, self.label, corner="left")
        draw_label(image, f"t={self.sim.time:.2f} s", corner="right")
        return image

    def close(self) -> None:
        """Free the renderer's OpenGL context."""
        self.renderer.close()


class TileStream:
    """Steps tiles frame by frame and renders them, all seen by one camera; use as a context manager (closes the
    renderers, also when the camera is not in every model).

    Iterating yields, for each of ``opts.n_frames`` frames, the list of the tiles' images.
    """

    def __init__(self, tiles: List[Tile], opts: Options):
        self.tiles = tiles
        self.opts = opts
        self.tracker: Optional[cameras.Tracker] = None
        m = tiles[0].sim.mj_model
        try:
            self._cam_id = cameras.check_model_cameras(opts.camera, [t.sim.mj_model for t in tiles],
                                                       [t.sim.model for t in tiles])
        except ValueError:
            self.close()
            raise
        if self._cam_id < 0:
            self._fovy = float(m.vis.global_.fovy)
            length = max(c.length for t in tiles for c in t.sim.scene.cables)
            self.tracker = cameras.Tracker(fps=opts.fps, width=opts.width, height=opts.height, fovy_deg=self._fovy,
                                           elevation_deg=opts.elevation,
                                           min_half_extent=cameras.MIN_TRACK_HALF_EXTENT * length)
        else:
            self._fovy = float(m.cam_fovy[self._cam_id])

    def __enter__(self) -> "TileStream":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Close every tile's renderer."""
        for t in self.tiles:
            t.close()

    def __iter__(self) -> Iterator[List[np.ndarray]]:
        opts = self.opts
        bar = progress_bar(opts.n_frames, len(self.tiles), opts.progress)
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
        """The camera of this frame and the size of a pixel at the cable, in metres."""
        if self.tracker is None:  # a fixed camera of the model: size the cable at its distance from the camera
            sim = self.tiles[0].sim
            mujoco.mj_camlight(sim.mj_model, sim.mj_data)
            distance = float(np.linalg.norm(sim.positions.mean(axis=0) - sim.mj_data.cam_xpos[self._cam_id]))
            return self.opts.camera, cameras.pixel_size(distance, self._fovy, self.opts.height)
        cam = self.tracker.update([t.box() for t in self.tiles if t.live])
        return cam, cameras.pixel_size(cam.distance, self._fovy, self.opts.height)


def progress_bar(n_frames: int, n_tiles: int, progress: Optional[bool]):
    """A tqdm bar over ``n_frames`` frames; ``progress=None`` shows it from :data:`PROGRESS_MIN_RENDERS` tile
    renders on, on a terminal only."""
    from tqdm.auto import tqdm

    if progress is None:
        disable = None if n_frames * n_tiles >= PROGRESS_MIN_RENDERS else True  # None: tqdm hides it off a terminal
    else:
        disable = not progress
    return tqdm(total=n_frames, unit="frame", desc="rendering", disable=disable, leave=False)


def make_tiles(scene: Scene, models: Sequence[str], opts: Options, dt: float, settings: Mapping[str, Mapping],
               labels: Optional[Sequence[str]] = None, drive: Optional[Drive] = None) -> List[Tile]:
    """One :class:`Tile` per model (``settings[model]`` passed to its Simulator), labelled ``labels`` (default: the
    model names), each driven by ``drive`` (:class:`Tile`); on failure the tiles already made are closed."""
    tiles: List[Tile] = []
    labels = list(models) if labels is None else labels
    try:
        for model, label in zip(models, labels):
            sim = Simulator(scene, model, dt=dt, **dict(settings.get(model, {})))
            tiles.append(Tile(sim, label, opts, drive))
    except BaseException:
        for t in tiles:
            t.close()
        raise
    return tiles
