"""What is drawn over MuJoCo's own picture: the cable's centreline as capsules in an ``MjvScene``, and text labels
on finished images.

:func:`add_centreline` is shared by the renderer and the environments (``mjcable.envs``), so that every model looks
like the same continuous cable (a springs model's beads, a flex's own rendering or the particle solvers' proxy
capsules would otherwise differ) wherever it is drawn.

Example::

    renderer.update_scene(mj_data)
    overlays.add_centreline(renderer.scene, sim.positions, radius=sim.scene.cable.radius)
    image = renderer.render()
    overlays.draw_label(image, "springs", corner="left")
"""

from __future__ import annotations

import functools

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from mjcable import _validate
from mjcable.mjcf.world import CABLE_COLOURS

__all__ = ["add_centreline", "add_cables", "add_stripe", "draw_label", "CABLE_RGBA", "CABLE_COLOURS", "STRIPE_RGBA",
           "CABLE_SPECULAR", "CORNERS"]

CABLE_RGBA = CABLE_COLOURS[0]  # mjcable/mjcf/world.py's "cable" material
CABLE_SPECULAR = 0.3
STRIPE_RGBA = (0.95, 0.9, 0.2, 1.0)  # the twist stripe (add_stripe): yellow on the red-brown cable
STRIPE_WIDTH = 0.35  # the stripe's radius as a fraction of the cable's drawn radius
CORNERS = ("left", "right")  # where draw_label puts a label: the top left or top right corner
_LABEL_HEIGHT_FRACTION = 1.0 / 18.0  # label font size as a fraction of the image height
_MIN_LABEL_PX = 10
_LABEL_BOX_ALPHA = 0.55
_LABEL_PAD_FRACTION = 0.3  # padding around a label, in font sizes
_EYE = np.eye(3).ravel()
_ZERO3 = np.zeros(3)


def add_centreline(scn: mujoco.MjvScene, points, radius: float, rgba=CABLE_RGBA, *,
                   specular: float = CABLE_SPECULAR) -> int:
    """Append the polyline ``points`` to ``scn`` as capsules, one per segment, as far as ``scn`` has free geoms.

    Works on a ``mujoco.MjvScene`` and on dm_control's subclass of it (as a ``scene_callback`` of
    ``Physics.render``). A loop over segments, but per frame, not per physics step: about 5 µs a segment against
    ~50 ms to render the frame.

    Args:
      scn: the scene, after ``mjv_updateScene`` (``Renderer.update_scene``).
      points: ``(n, 3)`` centreline points in metres (``Simulator.positions``), ``n >= 1``.
      radius: capsule radius in metres, > 0.
      rgba: colour, 4 values in [0, 1] (default: the cable material's).
      specular: specular reflectance in [0, 1].

    Returns:
      The number of capsules added (``n - 1``, fewer when ``scn.maxgeom`` is reached).

    Example::

        def scene_callback(physics, scn):
            overlays.add_centreline(scn, physics.centreline(), physics.scene.cable.radius)
    """
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < 1 or not np.all(np.isfinite(points)):
        raise ValueError(f"points must be an (n, 3) array of finite positions in metres, got shape {points.shape}")
    radius = _validate.number("radius", radius, low=0.0, low_open=True, unit="m")
    colour = _colour(rgba)
    specular = _validate.number("specular", specular, low=0.0, high=1.0)
    return _add_capsules(scn, points[:-1], points[1:], radius, colour, specular)


def add_cables(scn: mujoco.MjvScene, scene, positions, radius: float, *, frames=None) -> None:
    """Append every cable of ``scene`` to ``scn``: :func:`add_centreline` of its slice of ``positions``
    (``(scene.n_particles, 3)`` m, ``Simulator.positions``) in its colour (:data:`CABLE_COLOURS`), at least
    ``radius`` m thick (its own radius where that is larger), and with ``frames`` (``(Σ nᵢ, 4)``,
    ``Simulator.frames``) its twist stripe (:func:`add_stripe`)."""
    for c, (cable, s) in enumerate(zip(scene.cables, scene.cable_slices)):
        drawn = max(cable.radius, radius)
        add_centreline(scn, positions[s], drawn, CABLE_COLOURS[c % len(CABLE_COLOURS)])
        if frames is not None:  # cable c's segments: its particles' slice less one per cable before it
            add_stripe(scn, positions[s], frames[s.start - c:s.stop - 1 - c], drawn)


def _colour(rgba) -> np.ndarray:
    """``rgba`` as 4 float32 values in [0, 1].

    Raises:
      ValueError: not 4 numbers in [0, 1]."""
    colour = np.asarray(rgba, dtype=np.float32)
    if colour.shape != (4,) or not np.all((colour >= 0) & (colour <= 1)):
        raise ValueError(f"rgba must be 4 numbers in [0, 1], got {rgba!r}")
    return colour


def _add_capsules(scn: mujoco.MjvScene, starts: np.ndarray, ends: np.ndarray, radius: float, colour: np.ndarray,
                  specular: float) -> int:
    """Capsules from ``starts[i]`` to ``ends[i]`` (k, 3) into ``scn`` as far as it has free geoms; returns how many."""
    count = max(0, min(len(starts), scn.maxgeom - scn.ngeom))
    geoms = mujoco.MjvScene.geoms.__get__(scn)  # all maxgeom slots (dm_control's subclass shows the first ngeom)
    for i in range(count):
        g = geoms[scn.ngeom]
        mujoco.mjv_initGeom(g, mujoco.mjtGeom.mjGEOM_CAPSULE, _ZERO3, _ZERO3, _EYE, colour)
        mujoco.mjv_connector(g, mujoco.mjtGeom.mjGEOM_CAPSULE, radius, starts[i], ends[i])
        g.specular = specular
        scn.ngeom += 1
    return count


def add_stripe(scn: mujoco.MjvScene, points, frames, radius: float, rgba=STRIPE_RGBA) -> int:
    """Append a stripe along the cable's surface on the side of each segment's material d₁ to ``scn``: per segment
    a thin capsule from pᵢ + r d₁ to pᵢ₊₁ + r d₁, so that the cable's twist shows as a stripe that winds round it.

    Args:
      scn: the scene, after :func:`add_centreline` (the stripe lies on that surface).
      points: ``(n + 1, 3)`` centreline points in metres.
      frames: ``(n, 4)`` the segments' material frames, unit quaternions (w, x, y, z)
        (:attr:`mjcable.Simulator.frames`).
      radius: the drawn cable's radius in metres, > 0.
      rgba: colour, 4 values in [0, 1].

    Returns:
      The number of capsules added (``n``, fewer when ``scn.maxgeom`` is reached).
    """
    points = np.asarray(points, dtype=np.float64)
    q = np.asarray(frames, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or q.shape != (len(points) - 1, 4):
        raise ValueError(f"frames must be (n, 4) quaternions for the n segments of points (n + 1, 3), got shapes "
                         f"{q.shape} and {points.shape}")
    radius = _validate.number("radius", radius, low=0.0, low_open=True, unit="m")
    colour = _colour(rgba)
    side = radius * Rotation.from_quat(q, scalar_first=True).apply([1.0, 0.0, 0.0])  # r d₁ of each segment
    return _add_capsules(scn, points[:-1] + side, points[1:] + side, STRIPE_WIDTH * radius, colour, CABLE_SPECULAR)


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


def draw_label(image: np.ndarray, text: str, *, corner: str) -> None:
    """Draw ``text`` in white on a translucent dark box into ``image``, in place, clipped to the image.

    Args:
      image: ``(h, w, 3)`` uint8 RGB.
      text: one line of text; its size follows the image height.
      corner: ``"left"`` or ``"right"``: the top corner to draw in.
    """
    _validate.choice("corner", corner, CORNERS)
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
