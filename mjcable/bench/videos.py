"""A video of each bench family whose scene shows a feature at work: a rope turning a pulley, ...

Each entry of :data:`VIDEOS` names a family, builds its scene, says how long its video runs and, for a scene that
does something at run time (a winch reeling), what to do before each frame (``drive``, called with the
Simulator). :func:`render` renders it with one model to an MP4, or with several side by side; ``mjcable render
--family pulley --model xpbd -o pulley.mp4`` and ``scripts/render_all.py`` call it. A new family's video is one
more entry.

* ``pulley``: the Atwood machine of :mod:`mjcable.bench.pulley` with boxes of :data:`PULLEY_MASSES` (the heavy box
  drops 0.55 m in the video's :data:`PULLEY_SECONDS`; the must-show's 2 : 1 takes 0.6 s) and a two-coloured spoke
  across the pulley (visual only), so that the rope is seen turning it.
* ``ring``: the Atwood machine through a frictionless ring of :mod:`mjcable.bench.ring` (2 and 1 kg boxes), seen
  from the side by a fixed camera (:data:`RING_CAMERA`), with the ring drawn (:func:`ring_scene`; particle solvers:
  the native models' rim for this rope would be thicker than its start allows).
* ``winch``: the lift of :mod:`mjcable.bench.winch`, seen from the side by a fixed camera (:data:`WINCH_CAMERA`): the
  winch reels the box up at 0.1 m/s for 3 s, then lowers it again (particle solvers; the others refuse a winch).

Example::

    from mjcable.bench import videos
    videos.render("pulley", "xpbd", "pulley.mp4")
    videos.render("pulley", ("xpbd", "joints"), "pulley_grid.mp4", seconds=1.0)
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Callable, Dict, Optional, Sequence, Union

import mujoco
import numpy as np

from mjcable import render as render_
from mjcable.bench import pulley, ring, winch
from mjcable.render.camera import DEFAULT_ELEVATION
from mjcable.render.tiles import Drive
from mjcable.scene import Scene

__all__ = ["FamilyVideo", "VIDEOS", "names", "get", "render", "pulley_scene", "PULLEY_MASSES", "PULLEY_SECONDS",
           "SPOKE_COLOURS", "ring_scene", "RING_CAMERA", "RING_CAMERA_DISTANCE", "winch_scene", "winch_drive", "WINCH_CAMERA", "WINCH_CAMERA_DISTANCE"]

PULLEY_MASSES = (1.1, 1.0)  # kg: a ≈ g (m₁ − m₂) / (m₁ + m₂ + I / R_c²) = 0.38 m/s²
PULLEY_SECONDS = 1.7  # s: the heavy box drops 0.55 m of its 0.6 m leg difference
PULLEY_ELEVATION = 10.0  # degrees: nearly level, looking along the pulley's axis at its face
SPOKE_COLOURS = {"blue": (0.1, 0.3, 0.9, 1.0), "green": (0.1, 0.8, 0.2, 1.0)}  # no other geom or cable is either
_SPOKE_LENGTH = 0.9  # of the pulley's radius, each half
_SPOKE_HALF_WIDTH = 0.015  # m
_SPOKE_PROUD = 0.002  # m the spoke stands out of the pulley's faces, so that it shows on them
RING_CAMERA = "ring_side"  # the ring video's camera: on −y, level with the middle of the boxes' travel, looking along +y
RING_CAMERA_DISTANCE = 1.5  # m from the plane of the rope
_RING_SIDES = 16  # the drawn ring's capsules
WINCH_CAMERA = "winch_side"  # the winch video's camera: on +x, level with the box's middle height, looking along −x
WINCH_CAMERA_DISTANCE = 1.5  # m from the rope's line


@dataclasses.dataclass(frozen=True)
class FamilyVideo:
    """How to film one bench family.

    Attributes:
      name: the family's name (the key of :data:`VIDEOS`).
      description: one line for listings.
      make_scene: ``() → Scene``, the scene filmed.
      seconds: the video's default length, simulated seconds.
      elevation: the tracking camera's angle above the horizon, degrees.
      drive: ``drive(simulator)`` before each frame's step, for a scene that does something at run time; ``None``:
        nothing.
      camera: a camera of the scene's world that films it; ``None``: the tracking camera.
    """

    name: str
    description: str
    make_scene: Callable[[], Scene]
    seconds: float
    elevation: float = DEFAULT_ELEVATION
    drive: Optional[Drive] = None
    camera: Optional[str] = None


def pulley_scene() -> pulley.AtwoodScene:
    """:func:`mjcable.bench.pulley.atwood_scene` with boxes of :data:`PULLEY_MASSES` and a spoke across the pulley,
    blue from its axis towards the rim on one side and green on the other (:data:`SPOKE_COLOURS`), touching nothing
    and adding no mass (the pulley's inertial is explicit): the line from the green half to the blue one shows the
    pulley's turn (its body's x axis)."""
    scene = pulley.atwood_scene(masses=PULLEY_MASSES)
    spec = scene.world.spec()
    body = next(b for b in spec.bodies if b.name == scene.pulley)
    half = 0.5 * _SPOKE_LENGTH * pulley.PULLEY_RADIUS
    for side, (colour, rgba) in zip((1.0, -1.0), SPOKE_COLOURS.items()):
        body.add_geom(name=f"{scene.pulley}_spoke_{colour}", type=mujoco.mjtGeom.mjGEOM_BOX,
                      pos=[side * half, 0.0, 0.0], size=[half, _SPOKE_HALF_WIDTH, 0.5 * pulley.PULLEY_WIDTH +
                                                         _SPOKE_PROUD],
                      contype=0, conaffinity=0, rgba=list(rgba))
    return dataclasses.replace(scene, world=spec)


def ring_scene() -> ring.RingAtwoodScene:
    """:func:`mjcable.bench.ring.atwood_scene` with its ring drawn (a polygon of thin capsules around the hole, visual
    only: they touch nothing) and a fixed camera :data:`RING_CAMERA` at :data:`RING_CAMERA_DISTANCE` m on −y, level
    with the middle of the boxes' travel, looking along +y (image right is +x, image up is +z; a 45° field of
    view)."""
    scene = ring.atwood_scene()
    spec = scene.world.spec()
    centre, axis = scene.ring_frame(0)
    u = np.cross(axis, (0.0, 1.0, 0.0) if abs(axis[1]) < 0.9 else (1.0, 0.0, 0.0))
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    rim = scene.cable.radius
    around = centre + (scene.rings[0].hole(scene.cable.radius) + rim) * np.array(
        [math.cos(a) * u + math.sin(a) * v for a in np.linspace(0.0, 2.0 * math.pi, _RING_SIDES + 1)])
    for j in range(_RING_SIDES):
        spec.worldbody.add_geom(name=f"ring_drawn_{j}", type=mujoco.mjtGeom.mjGEOM_CAPSULE, size=[rim, 0.0, 0.0],
                                fromto=np.concatenate([around[j], around[j + 1]]), contype=0, conaffinity=0,
                                rgba=[0.55, 0.55, 0.6, 1.0])
    z = ring.RING_HEIGHT - 0.45
    spec.worldbody.add_camera(name=RING_CAMERA, pos=[0.0, -RING_CAMERA_DISTANCE, z],
                              xyaxes=[1.0, 0.0, 0.0, 0.0, 0.0, 1.0])
    return dataclasses.replace(scene, world=spec)


def winch_scene() -> winch.LiftScene:
    """:func:`mjcable.bench.winch.lift_scene` with a fixed camera :data:`WINCH_CAMERA` at
    :data:`WINCH_CAMERA_DISTANCE` m on +x, level with the middle of the box's travel, looking along −x (image right is
    +y, image up is +z; MuJoCo's default 45° field of view)."""
    scene = winch.lift_scene()
    spec = scene.world.spec()
    z = winch.WINCH_HEIGHT - scene.free_length - winch.BOX_HALF + 0.5 * winch.SPEED * winch.DURATION
    spec.worldbody.add_camera(name=WINCH_CAMERA, pos=[WINCH_CAMERA_DISTANCE, 0.0, z],
                              xyaxes=[0.0, 1.0, 0.0, 0.0, 0.0, 1.0])
    return dataclasses.replace(scene, world=spec)


def winch_drive(sim) -> None:
    """The winch video's reel (:data:`Drive`): in at :data:`mjcable.bench.winch.SPEED` for
    :data:`mjcable.bench.winch.DURATION`, then out as fast."""
    sim.reel(0, -winch.SPEED if sim.time < winch.DURATION - 1e-9 else winch.SPEED)


VIDEOS: Dict[str, FamilyVideo] = {
    v.name: v
    for v in (
        FamilyVideo("pulley", "the Atwood machine over a pulley on a frictionless hinge: the rope turns the pulley",
                    pulley_scene, seconds=PULLEY_SECONDS, elevation=PULLEY_ELEVATION),
        FamilyVideo("ring", "the Atwood machine through a frictionless ring: the rope slides through it", ring_scene,
                    seconds=ring.DURATION, camera=RING_CAMERA),
        FamilyVideo("winch", "a winch reels a box up 0.3 m and lowers it again", winch_scene,
                    seconds=2.0 * winch.DURATION, drive=winch_drive, camera=WINCH_CAMERA),
    )
}


def names() -> tuple:
    """The families with a video."""
    return tuple(VIDEOS)


def get(name: str) -> FamilyVideo:
    """The video entry of family ``name``.

    Raises:
      ValueError: no family of that name has a video.
    """
    if not isinstance(name, str) or name not in VIDEOS:
        raise ValueError(f"name must be one of the families with a video {names()}, got {name!r}")
    return VIDEOS[name]


def render(name: str, models: Union[str, Sequence[str]], path, *, seconds: Optional[float] = None, fps: int = 30,
           width: Optional[int] = None, height: Optional[int] = None, dt: float = 0.002,
           camera: Optional[str] = None, stripe: bool = False, progress: Optional[bool] = None,
           **settings) -> Path:
    """Render family ``name``'s video to an MP4 file, atomically: one model (:func:`mjcable.render.render_video`),
    or several side by side (:func:`mjcable.render.render_grid`).

    Args:
      name: one of :func:`names`.
      models: a model name, or a sequence of them (each once).
      path: the ``.mp4`` file to write (its folder must exist).
      seconds: simulated (and video) seconds; default the family's.
      fps: frames per second.
      width, height: frame size in pixels, per tile side by side (even); default 640 × 480 for one model, 320 × 240
        per tile.
      dt: the simulators' step in seconds.
      camera: ``"track"`` or a camera of the models; ``None``: the family's (:attr:`FamilyVideo.camera`, else the
        tracking camera).
      stripe: draw a stripe along the cable's material frame (models with frames), so that twist shows.
      progress: show a progress bar (``None``: for long renders on a terminal).
      **settings: the models' settings (every model gets the same).

    Returns:
      The path written.

    Raises:
      ValueError: an unknown family or model, or a bad render argument (named by the render function).
    """
    video = get(name)
    seconds = video.seconds if seconds is None else seconds
    camera = (video.camera or render_.TRACK) if camera is None else camera
    options = dict(seconds=seconds, fps=fps, dt=dt, camera=camera, elevation=video.elevation, stripe=stripe,
                   progress=progress, drive=video.drive)
    if isinstance(models, str):
        size = dict(width=640 if width is None else width, height=480 if height is None else height)
        return render_.render_video(video.make_scene(), models, path, **size, **options, **settings)
    size = dict(tile_width=320 if width is None else width, tile_height=240 if height is None else height)
    return render_.render_grid(video.make_scene(), list(models), path, **size, **options,
                               settings={m: settings for m in models} if settings else None)
