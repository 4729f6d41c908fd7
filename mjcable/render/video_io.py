"""MP4 files: writing frames as H.264 (mediapy, streaming, atomically) and reading them back (imageio-ffmpeg).

Both use the ffmpeg binary bundled with ``imageio-ffmpeg``, so no system ffmpeg is needed: mediapy is pointed at it
before it first writes. Reading goes through imageio-ffmpeg's own reader because ``mediapy.read_video`` passes
ffmpeg's ``-vsync`` option, which the ffmpeg bundled with imageio-ffmpeg 0.8 no longer has.

Example::

    write_video("out.mp4", (np.zeros((48, 64, 3), np.uint8) for _ in range(10)), fps=10, shape=(48, 64))
    frames, fps = read_video("out.mp4")   # (10, 48, 64, 3) uint8, 10.0
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Iterable, Tuple

import numpy as np

from mjcable import _validate
from mjcable.io import atomic_path
from mjcable.render.options import check_fps, check_path, check_size

__all__ = ["write_video", "read_video"]


@functools.lru_cache(maxsize=None)
def _use_bundled_ffmpeg() -> None:
    """Point mediapy at imageio-ffmpeg's ffmpeg binary (once)."""
    import imageio_ffmpeg
    import mediapy

    mediapy.set_ffmpeg(imageio_ffmpeg.get_ffmpeg_exe())


def write_video(path, images: Iterable[np.ndarray], *, fps: int, shape: Tuple[int, int]) -> Path:
    """Write ``images`` to ``path`` as H.264 MP4, atomically, streaming (frames are not all held in memory).

    A temporary file in the destination folder replaces ``path`` once every frame is written
    (:func:`mjcable.io.atomic_path`); if ``images`` raises or the process is killed, ``path`` is left as it was and
    no temporary file remains.

    Args:
      path: the ``.mp4`` file (its folder must exist).
      images: the frames, each ``(height, width, 3)`` uint8 RGB.
      fps: frames per second, an integer in [1, 240].
      shape: ``(height, width)`` in pixels, both even, in [16, 4096].

    Returns:
      The path written.
    """
    import mediapy

    path = check_path(path)
    fps = check_fps(fps)
    if not isinstance(shape, (tuple, list)) or len(shape) != 2:
        raise ValueError(f"shape must be (height, width) in pixels, got {shape!r}")
    height, width = check_size("height", shape[0]), check_size("width", shape[1])
    _use_bundled_ffmpeg()
    with atomic_path(path) as tmp:  # tmp may have no suffix (mjcable.io): the format is named
        with mediapy.VideoWriter(tmp, (height, width), fps=fps, ffmpeg_args=["-f", "mp4"]) as writer:
            for image in images:
                writer.add_image(image)
    return path


def read_video(path) -> Tuple[np.ndarray, float]:
    """Read an MP4 (as written by :func:`write_video`) back into memory.

    Args:
      path: an existing video file.

    Returns:
      ``(frames, fps)``: ``(n, height, width, 3)`` uint8 RGB frames and the frame rate in frames per second.
    """
    import imageio_ffmpeg

    path = Path(_validate.path_like("path", path))
    if not path.is_file():
        raise ValueError(f"path must be an existing video file, got {str(path)!r}")
    reader = imageio_ffmpeg.read_frames(str(path), pix_fmt="rgb24")
    try:
        meta = next(reader)
        width, height = meta["size"]
        images = [np.frombuffer(buf, np.uint8).reshape(height, width, 3) for buf in reader]
    finally:
        reader.close()
    return np.stack(images) if images else np.empty((0, height, width, 3), np.uint8), float(meta["fps"])
