"""Cameras of the videos: the tracking free camera, checks of camera names, and the size of a pixel in metres.

The tracking camera (``camera="track"``) keeps the cable large in frame: it looks along +y from ``elevation``
degrees above the horizon, at the centre of the cable's bounding box (the union over all tiles of a grid, so tiles
stay comparable), from the distance that fits that box into the frame with :data:`FRAME_MARGIN` to spare; it zooms
out at once and follows or zooms in smoothly (time constant :data:`TRACK_TIME_CONSTANT`). Any camera of the model
may be named instead, such as ``"overview"``, the fixed camera of ``mjcable/mjcf/world.py``.
"""

from __future__ import annotations

import functools
import math
from typing import Optional, Sequence, Tuple

import mujoco
import numpy as np

from mjcable import _validate

__all__ = ["TRACK", "Tracker", "check_camera", "check_elevation", "check_model_cameras", "pixel_size",
           "scene_pixel_size", "scene_option", "DEFAULT_ELEVATION", "MAX_ELEVATION", "FRAME_MARGIN",
           "TRACK_TIME_CONSTANT", "MIN_TRACK_HALF_EXTENT"]

TRACK = "track"  # the tracking free camera
FRAME_MARGIN = 1.3  # the tracked box fills 1 / FRAME_MARGIN of the frame
TRACK_TIME_CONSTANT = 0.4  # s: how fast the tracking camera follows and zooms in
MIN_TRACK_HALF_EXTENT = 0.15  # fraction of the cable length: the smallest half-size the camera frames
TRACK_AZIMUTH = 90.0  # degrees: look along +y, as the overview camera does
DEFAULT_ELEVATION = 30.0  # degrees above the horizon
MAX_ELEVATION = 85.0  # degrees: the tracking camera's up direction is undefined looking straight down
_CAMERA_DISTANCE_RANGE = (1e-3, 1e6)  # m: the tracking camera's distance is clamped to this


def check_camera(camera) -> str:
    """``"track"`` or a non-empty camera name (whether the models have it: :func:`check_model_cameras`)."""
    if not isinstance(camera, str) or not camera:
        raise ValueError(f"camera must be {TRACK!r} or the name of a camera in the model, got {camera!r}")
    return camera


def check_elevation(elevation) -> float:
    """The tracking camera's elevation in degrees, in [0, :data:`MAX_ELEVATION`]."""
    return _validate.number("elevation", elevation, low=0.0, high=MAX_ELEVATION, unit="degrees")


def check_model_cameras(camera: str, mj_models: Sequence[mujoco.MjModel], labels: Sequence[str]) -> int:
    """The id of the fixed camera ``camera``, checked to exist in every model (labelled ``labels`` in messages);
    ``-1`` for :data:`TRACK`."""
    if camera == TRACK:
        return -1
    ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, camera) for m in mj_models]
    for cam_id, label in zip(ids, labels):
        if cam_id < 0:
            raise ValueError(f"camera must be {TRACK!r} or a camera of model {label!r}, got {camera!r}")
    return ids[0]


def pixel_size(distance: float, fovy_deg: float, height: int) -> float:
    """Metres per pixel at ``distance`` metres from a camera of vertical field of view ``fovy_deg`` degrees whose
    image is ``height`` pixels tall."""
    return 2.0 * distance * math.tan(math.radians(fovy_deg) / 2) / height


def scene_pixel_size(scn: mujoco.MjvScene, point: np.ndarray, height: int) -> float:
    """Metres per pixel at ``point`` ``(3,)`` (metres) seen by the first camera of an updated ``scn`` whose image is
    ``height`` pixels tall."""
    cam = scn.camera[0]
    distance = float(np.linalg.norm(np.asarray(point) - np.asarray(cam.pos)))
    return distance * (cam.frustum_top - cam.frustum_bottom) / cam.frustum_near / height


@functools.lru_cache(maxsize=None)
def scene_option() -> mujoco.MjvOption:
    """What MuJoCo draws besides geoms: no sites or tendons (the springs model's invisible tendons and the particle
    sites are hidden under the drawn centreline anyway, and cost a fifth of the frame)."""
    option = mujoco.MjvOption()
    option.sitegroup[:] = 0
    option.flags[mujoco.mjtVisFlag.mjVIS_TENDON] = 0
    return option


class Tracker:
    """The tracking free camera shared by the tiles of one video.

    Args:
      fps: frames per second of the video (sets how far the camera moves per frame).
      width, height: image size in pixels.
      fovy_deg: vertical field of view in degrees.
      elevation_deg: angle above the horizon in degrees.
      min_half_extent: the smallest half-size of the framed box in metres.
    """

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
