"""The bench families' videos (:mod:`mjcable.bench.videos`; issue 23, item 5): the pulley's video, rendered through
``mjcable render --family``, read back with imageio-ffmpeg's own reader, shows the pulley turning as the rope's
Atwood machine turns it (the heavy-rope reference, :func:`mjcable.bench.pulley.heavy_rope_drop`, over R_c)."""

from __future__ import annotations

import math

import imageio_ffmpeg
import numpy as np
import pytest

from mjcable import cli
from mjcable.bench import pulley, videos, winch

SECONDS, FPS, WIDTH, HEIGHT = 1.0, 10, 320, 240
ANGLE_TOLERANCE = 6.0  # degrees: the spoke's halves are ~15 pixels long at this size (H.264 blurs their edges)


def _colour_mask(image: np.ndarray, colour: str) -> np.ndarray:
    """Pixels of one half of the spoke: its channel well above the other two (nothing else in the scene is blue or
    green; the cable is red, the boxes orange, the pulley grey)."""
    rgb = image.astype(np.int32)
    main = {"blue": 2, "green": 1}[colour]
    others = [c for c in range(3) if c != main]
    return (rgb[..., main] - rgb[..., others[0]] > 60) & (rgb[..., main] - rgb[..., others[1]] > 40)


def _spoke_angle(image: np.ndarray) -> float:
    """Degrees, counter-clockwise in the image from its +x (rightwards): the direction from the green half's centroid
    to the blue half's, the pulley body's x axis seen along the axis."""
    (by, bx), (gy, gx) = (np.nonzero(_colour_mask(image, c)) for c in ("blue", "green"))
    assert by.size > 10 and gy.size > 10  # both halves are in view
    return math.degrees(math.atan2(-(by.mean() - gy.mean()), bx.mean() - gx.mean()))  # image rows grow downwards


@pytest.mark.slow
def test_the_pulley_video_shows_the_rope_turning_the_pulley(tmp_path):
    path = tmp_path / "pulley.mp4"
    assert cli.main(["render", "--family", "pulley", "--model", "xpbd", "-o", str(path), "--seconds", str(SECONDS),
                     "--fps", str(FPS), "--width", str(WIDTH), "--height", str(HEIGHT)]) == cli.EXIT_OK
    reader = imageio_ffmpeg.read_frames(str(path), pix_fmt="rgb24")  # an independent reader of the file
    meta = next(reader)
    images = [np.frombuffer(frame, np.uint8).reshape(HEIGHT, WIDTH, 3) for frame in reader]
    reader.close()
    assert meta["codec"] == "h264" and tuple(meta["size"]) == (WIDTH, HEIGHT)
    assert meta["fps"] == pytest.approx(FPS) and len(images) == round(SECONDS * FPS)
    scene = videos.pulley_scene()
    times = np.arange(len(images)) / FPS  # frame k shows the simulation at k / fps
    # the heavy box on the left falls: seen along +y the pulley turns counter-clockwise, by the rope's run over R_c
    expected = np.degrees(pulley.heavy_rope_drop(times, scene) / scene.contact_radius)
    assert expected[-1] > 60.0  # a turn that the spoke's pixels resolve many times over
    turned = np.unwrap(np.radians([_spoke_angle(image) for image in images]))
    np.testing.assert_allclose(np.degrees(turned), expected, rtol=0.0, atol=ANGLE_TOLERANCE)


def _orange_rows(image: np.ndarray) -> np.ndarray:
    """The image rows that hold a box's orange pixels (red well above blue, green lit; the ropes are dark red, the
    background black, the labels white)."""
    rgb = image.astype(np.int32)
    rows, _ = np.nonzero((rgb[..., 0] - rgb[..., 2] > 30) & (rgb[..., 1] > 70) & (rgb[..., 2] < 200))
    assert rows.size > 50  # the boxes are in view
    return rows


def _family_frames(tmp_path, family: str, seconds: float, fps: int) -> list:
    """Family ``family``'s video on xpbd through ``mjcable render``, read back: its frames, (HEIGHT, WIDTH, 3)."""
    path = tmp_path / f"{family}.mp4"
    assert cli.main(["render", "--family", family, "--model", "xpbd", "-o", str(path), "--seconds", str(seconds),
                     "--fps", str(fps), "--width", str(WIDTH), "--height", str(HEIGHT)]) == cli.EXIT_OK
    reader = imageio_ffmpeg.read_frames(str(path), pix_fmt="rgb24")
    next(reader)
    frames = [np.frombuffer(frame, np.uint8).reshape(HEIGHT, WIDTH, 3) for frame in reader]
    reader.close()
    assert len(frames) == round(seconds * fps)
    return frames


@pytest.mark.slow
def test_the_winch_video_shows_the_box_rising_as_fast_as_the_winch_reels(tmp_path):
    """The fixed side camera at distance d with a 45° field of view: the box rises 0.1 m/s × t, which is
    H · 0.1 t / (2 d tan 22.5°) pixels (a pinhole camera, the box in the plane through the rope)."""
    fps = 5
    rows = np.array([_orange_rows(frame).mean() for frame in _family_frames(tmp_path, "winch", 2.0, fps)])
    times = np.arange(len(rows)) / fps
    scale = HEIGHT / (2.0 * videos.WINCH_CAMERA_DISTANCE * math.tan(math.radians(22.5)))  # pixels per metre
    risen = rows[0] - rows  # image rows grow downwards
    np.testing.assert_allclose(risen, scale * winch.SPEED * times, rtol=0.0, atol=2.0)  # 2 px: about 1 cm


@pytest.mark.slow
def test_the_ring_video_shows_the_boxes_moving_as_the_atwood_machine_through_the_ring_does(tmp_path):
    """The fixed side camera: the heavy box's bottom (the lowest orange row) falls and the light box's top (the
    highest) rises by the heavy-rope Atwood machine's drop (:func:`mjcable.bench.pulley.heavy_rope_drop`, no
    pulley), H · x / (2 d tan 22.5°) pixels."""
    fps = 10
    rows = [_orange_rows(frame) for frame in _family_frames(tmp_path, "ring", 0.5, fps)]
    scale = HEIGHT / (2.0 * videos.RING_CAMERA_DISTANCE * math.tan(math.radians(22.5)))  # pixels per metre
    expected = scale * pulley.heavy_rope_drop(np.arange(len(rows)) / fps, videos.ring_scene())
    assert expected[-1] > 30.0
    fell = np.array([r.max() for r in rows], dtype=float) - rows[0].max()
    rose = rows[0].min() - np.array([r.min() for r in rows], dtype=float)
    np.testing.assert_allclose(fell, expected, rtol=0.0, atol=3.0)  # 3 px: about 1.5 cm
    np.testing.assert_allclose(rose, expected, rtol=0.0, atol=3.0)


def test_unknown_family_is_named():
    with pytest.raises(ValueError, match=r"name must be one of the families with a video \('pulley'"):
        videos.get("winch_that_is_not")
