"""Video rendering: frames show the cable and its motion, MP4s are written atomically and read back with
imageio-ffmpeg, the centreline overlay and the grid layout are where they should be, arguments are validated."""

import dataclasses
import math
import os
import subprocess
import sys

import imageio_ffmpeg
import mujoco
import numpy as np
import pytest

import mjcable
from mjcable import catalog, render
from mjcable.errors import SimulationDivergedError
from mjcable.render import grid, overlays

SMALL = dict(width=96, height=72)


def cable_mask(image: np.ndarray) -> np.ndarray:
    """Pixels of the cable's orange-red (build/world.py's "cable" material): red well above green and blue."""
    rgb = image.astype(np.int32)
    return (rgb[..., 0] > 120) & (rgb[..., 0] - rgb[..., 1] > 60) & (rgb[..., 0] - rgb[..., 2] > 60)


def test_frames_show_the_cable_falling():
    """A straight cable released above a peg falls: with the fixed overview camera its pixels move down the image."""
    seconds, fps = 0.3, 10
    video = render.frames("drape", "springs", seconds=seconds, fps=fps, camera="overview", **SMALL)
    assert video.shape == (round(seconds * fps), SMALL["height"], SMALL["width"], 3)
    assert video.dtype == np.uint8
    for image in video:
        assert image.std() > 10.0  # not blank
        assert cable_mask(image).sum() > 20  # the cable is there
    rows = [np.nonzero(cable_mask(image))[0].mean() for image in video]
    # Free fall of 0.1 m before the peg: the cable's image moves down (rows grow downwards).
    assert rows[-1] > rows[0] + 1.0
    assert np.abs(video[-1].astype(int) - video[0].astype(int)).mean() > 0.5


def test_tracking_camera_frames_the_cable_large():
    image = render.frames("table", "springs", seconds=0.1, fps=10, width=160, height=120)[0]
    cols = np.nonzero(cable_mask(image).any(axis=0))[0]
    rows = np.nonzero(cable_mask(image).any(axis=1))[0]
    assert cols.size and rows.size
    # The cable's extent spans at least half of the frame's width, and it is in the middle of it.
    assert cols.max() - cols.min() > 0.5 * image.shape[1]
    assert abs(0.5 * (cols.max() + cols.min()) - 0.5 * image.shape[1]) < 0.15 * image.shape[1]


def test_render_video_writes_a_readable_mp4_atomically(tmp_path):
    path = tmp_path / "hang.mp4"
    out = render.render_video("hang", "springs", path, seconds=0.2, fps=15, **SMALL)
    assert out == path and path.is_file()
    reader = imageio_ffmpeg.read_frames(str(path), pix_fmt="rgb24")  # an independent reader of the file
    meta = next(reader)
    n = sum(1 for _ in reader)
    reader.close()
    assert meta["codec"] == "h264" and tuple(meta["size"]) == (SMALL["width"], SMALL["height"]) and n == 3
    assert meta["fps"] == pytest.approx(15.0)
    video, fps = render.read_video(path)
    assert fps == pytest.approx(15.0)
    assert video.shape == (3, SMALL["height"], SMALL["width"], 3)
    assert video.std() > 10.0
    assert all(cable_mask(image).sum() > 20 for image in video)  # the cable survives the H.264 round trip
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hang.mp4"]  # no temporary files left


def test_video_io_rejects_bad_arguments(tmp_path):
    frames = [np.zeros((16, 16, 3), np.uint8)]
    with pytest.raises(ValueError, match="fps"):
        render.write_video(tmp_path / "v.mp4", frames, fps=0, shape=(16, 16))
    with pytest.raises(ValueError, match="width"):
        render.write_video(tmp_path / "v.mp4", frames, fps=10, shape=(16, 15))
    with pytest.raises(ValueError, match="shape"):
        render.write_video(tmp_path / "v.mp4", frames, fps=10, shape=16)
    with pytest.raises(ValueError, match="path"):
        render.read_video(tmp_path / "missing.mp4")
    assert list(tmp_path.iterdir()) == []


def test_failed_write_leaves_destination_and_no_temp_files(tmp_path):
    path = tmp_path / "video.mp4"
    path.write_bytes(b"old")

    def broken():
        yield np.zeros((16, 16, 3), np.uint8)
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        render.write_video(path, broken(), fps=10, shape=(16, 16))
    assert path.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["video.mp4"]


def test_grid_tiles_and_labels():
    models = ["springs", "flexrod"]
    video = render.grid_frames("table", models, seconds=0.1, fps=10, tile_width=96, tile_height=72)
    assert video.shape == (1, 72, 2 * 96, 3)
    for c in range(2):
        tile = video[0, :, c * 96:(c + 1) * 96]
        assert cable_mask(tile).sum() > 20
        label = tile[:12, :40]  # white label text on a dark box, top left
        assert (label.min(axis=-1) > 200).sum() > 5 and (label.max(axis=-1) < 120).sum() > 20


class _DivergingSimulator(mjcable.Simulator):
    """A Simulator whose springs model 'diverges' after 0.1 s (to test the grid, not the physics)."""

    def step(self, seconds=None):
        super().step(seconds)
        if self.model == "springs" and self.time > 0.1:
            raise SimulationDivergedError(self.model, self.steps, self.time, "test divergence")


def test_diverged_tile_freezes_while_others_go_on(monkeypatch):
    monkeypatch.setattr(render.tiles, "Simulator", _DivergingSimulator)
    w, h = 96, 72
    video = render.grid_frames("drape", ["springs", "flexrod"], seconds=0.5, fps=10, tile_width=w, tile_height=h,
                               camera="overview")
    diverged, live = video[:, :, :w], video[:, :, w:]
    # After divergence (frame 2, t = 0.2 s) the springs tile is frozen and darkened; the flexrod tile still moves.
    assert np.array_equal(diverged[2], diverged[-1])
    assert diverged[2].mean() < 0.7 * diverged[1].mean()
    assert not np.array_equal(live[2], live[-1])


class _RecordingSimulator(mjcable.Simulator):
    calls = []

    def step(self, seconds=None):
        type(self).calls.append(seconds)
        super().step(seconds)


def test_frames_step_the_simulation_by_one_frame_period(monkeypatch):
    monkeypatch.setattr(render.tiles, "Simulator", _RecordingSimulator)
    _RecordingSimulator.calls = []
    render.frames("hang", "springs", seconds=0.2, fps=25, dt=0.003, drive=lambda sim: _RecordingSimulator.calls.append(
        ("drive", sim.time)), **SMALL)
    steps = [c for c in _RecordingSimulator.calls if not isinstance(c, tuple)]
    assert steps == [pytest.approx(1 / 25)] * 4  # 5 frames: the first shows t = 0
    # the drive runs before each frame's step, at the time that frame shows (to within one dt)
    assert _RecordingSimulator.calls[::2] == [("drive", pytest.approx(k / 25, abs=0.003)) for k in range(4)]
    with pytest.raises(ValueError, match=r"drive must be None or a callable drive\(simulator\), got 3"):
        render.frames("hang", "springs", seconds=0.2, drive=3, **SMALL)


def _broken_backend(*args, **kwargs):
    raise NotImplementedError("a model that cannot build")


def test_available_models_asks_the_catalogue_and_reports_failures():
    """A model registered at run time is a candidate; one that fails to build is reported, not hidden."""
    catalog.register(dataclasses.replace(catalog.get("springs"), name="broken", backend=_broken_backend))
    try:
        models, problems = render.available_models("hang")
        assert "broken" not in models and set(models) == set(catalog.names()) - {"broken"}
        assert list(problems) == ["broken"] and isinstance(problems["broken"], NotImplementedError)
        models, problems = render.available_models("hang", models=("broken", "springs"))
        assert models == ("springs",) and list(problems) == ["broken"]
    finally:
        catalog.unregister("broken")


def test_every_model_is_available_on_the_demo_scene():
    models, problems = render.available_models("table")
    assert problems == {}
    assert models == catalog.names()


def _capsule_scene(maxgeom=100):
    spec = mujoco.MjSpec()
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1, 1, 0.1])
    mj_model = spec.compile()
    mj_data = mujoco.MjData(mj_model)
    mujoco.mj_forward(mj_model, mj_data)
    scn = mujoco.MjvScene(mj_model, maxgeom=maxgeom)
    cam = mujoco.MjvCamera()
    mujoco.mjv_updateScene(mj_model, mj_data, mujoco.MjvOption(), None, cam, mujoco.mjtCatBit.mjCAT_ALL, scn)
    return scn


def test_add_centreline_draws_one_capsule_per_segment():
    scn = _capsule_scene()
    before = scn.ngeom
    points = np.array([[0.0, 0.0, 0.5], [0.3, 0.0, 0.5], [0.3, 0.4, 0.5]])
    assert render.add_centreline(scn, points, 0.01, (0.0, 0.0, 1.0, 1.0)) == 2
    assert scn.ngeom == before + 2
    for i, g in enumerate(scn.geoms[before:before + 2]):
        a, b = points[i], points[i + 1]
        assert g.type == mujoco.mjtGeom.mjGEOM_CAPSULE
        np.testing.assert_allclose(g.pos, (a + b) / 2, atol=1e-6)  # centred on the segment
        np.testing.assert_allclose(g.size[:2], [0.01, 0.01], rtol=1e-6)
        assert g.size[2] == pytest.approx(np.linalg.norm(b - a) / 2, rel=1e-6)  # half-length
        axis = np.asarray(g.mat).reshape(3, 3)[:, 2]  # the capsule's axis is its frame's z
        assert abs(axis @ (b - a)) == pytest.approx(np.linalg.norm(b - a), rel=1e-6)
        np.testing.assert_allclose(g.rgba, [0, 0, 1, 1])


def test_add_centreline_stops_at_the_scene_capacity_and_checks_its_input():
    scn = _capsule_scene(maxgeom=5)
    free = scn.maxgeom - scn.ngeom
    assert render.add_centreline(scn, np.zeros((20, 3)) + np.arange(20)[:, None], 0.01) == free
    assert scn.ngeom == scn.maxgeom
    scn = _capsule_scene()
    for kwargs, name in [(dict(points=np.zeros((4, 2))), "points"), (dict(points=[[0, 0, math.nan]] * 2), "points"),
                         (dict(radius=0.0), "radius"), (dict(rgba=(1, 0, 0)), "rgba"),
                         (dict(specular=2.0), "specular")]:
        args = dict(points=np.zeros((3, 3)), radius=0.01)
        args.update(kwargs)
        with pytest.raises(ValueError, match=name):
            render.add_centreline(scn, **args)


def test_grid_layout_and_compose():
    assert [(grid.grid_layout(n).rows, grid.grid_layout(n).columns) for n in (1, 4, 5, 7, 8, 9)] == \
        [(1, 1), (1, 4), (2, 3), (2, 4), (2, 4), (3, 3)]
    layout = grid.grid_layout(3, columns=2)
    tiles = [np.full((4, 6, 3), 50 * (i + 1), np.uint8) for i in range(3)]
    canvas = grid.compose(tiles, layout)
    assert canvas.shape == (8, 12, 3)
    assert (canvas[:4, :6] == 50).all() and (canvas[:4, 6:] == 100).all() and (canvas[4:, :6] == 150).all()
    assert (canvas[4:, 6:] == grid.EMPTY_TILE).all()  # the unused cell
    with pytest.raises(ValueError, match="columns"):
        grid.grid_layout(3, columns=4)
    with pytest.raises(ValueError, match="images"):
        grid.compose(tiles[:2], layout)


def test_labels_are_drawn_in_their_corner():
    image = np.full((72, 96, 3), 128, np.uint8)
    overlays.draw_label(image, "abc", corner="right")
    assert (image[:, :40] == 128).all()  # the left part is untouched
    corner = image[:12, -30:]
    assert (corner.min(axis=-1) > 200).sum() > 5 and (corner.max(axis=-1) < 120).sum() > 20
    with pytest.raises(ValueError, match="corner"):
        overlays.draw_label(image, "abc", corner="middle")


@pytest.mark.parametrize("kwargs, name", [
    (dict(seconds=0), "seconds"),
    (dict(seconds=-1.0), "seconds"),
    (dict(seconds=math.nan), "seconds"),
    (dict(seconds=1e9), "seconds"),
    (dict(fps=0), "fps"),
    (dict(fps=2.5), "fps"),
    (dict(fps=1000), "fps"),
    (dict(width=97), "width"),
    (dict(width=8), "width"),
    (dict(height=10000), "height"),
    (dict(camera=""), "camera"),
    (dict(camera="nope"), "camera"),
    (dict(elevation=120.0), "elevation"),
    (dict(min_cable_px=-1.0), "min_cable_px"),
    (dict(progress="yes"), "progress"),
    (dict(label=3), "label"),
])
def test_frames_rejects_bad_arguments(kwargs, name):
    args = dict(seconds=0.1, **SMALL)
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        render.frames("hang", "springs", **args)


def test_bad_scene_model_and_path(tmp_path):
    with pytest.raises(ValueError, match="scene"):
        render.frames("nowhere", "springs", seconds=0.1)
    with pytest.raises(ValueError, match="model"):
        render.frames("hang", "verlet", seconds=0.1)
    with pytest.raises(ValueError, match="mp4"):
        render.render_video("hang", "springs", tmp_path / "x.avi", seconds=0.1)
    with pytest.raises(ValueError, match="folder"):
        render.render_video("hang", "springs", tmp_path / "missing" / "x.mp4", seconds=0.1)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("kwargs, name", [
    (dict(models=[]), "models"),
    (dict(models="springs"), "models"),
    (dict(models=["springs", "springs"]), "models"),
    (dict(models=["springs", "verlet"]), "model"),
    (dict(columns=0), "columns"),
    (dict(columns=3), "columns"),
    (dict(settings={"joints": {}}), "settings"),
    (dict(tile_width=33), "tile_width"),
    (dict(tile_height=8), "tile_height"),
])
def test_grid_rejects_bad_arguments(kwargs, name):
    args = dict(models=["springs", "flexrod"], seconds=0.1, tile_width=32, tile_height=32)
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        render.grid_frames("hang", **args)


def test_import_sets_egl_when_unset():
    env = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}
    code = "import os, mjcable; print(os.environ['MUJOCO_GL'])"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "egl"


def test_add_stripe_winds_round_a_twisted_cable():
    """A straight cable twisted by φ = π/2 over its 4 segments (frames turned by φ (i + ½) / 4 about the axis): the
    stripe's capsules lie at the drawn radius from the centreline, thinner than the cable, and their angle round the
    axis advances by φ / 4 per segment."""
    scn = _capsule_scene()
    before = scn.ngeom
    points = np.array([[0.25 * i, 0.0, 0.5] for i in range(5)])
    to_x = np.array([math.sqrt(0.5), 0.0, math.sqrt(0.5), 0.0])  # d₃ (body z) along world x
    angles = (np.arange(4) + 0.5) * (math.pi / 2) / 4
    frames = np.array([[to_x[0] * math.cos(a / 2) - to_x[3] * math.sin(a / 2), to_x[1] * math.cos(a / 2)
                        + to_x[2] * math.sin(a / 2), to_x[2] * math.cos(a / 2) - to_x[1] * math.sin(a / 2),
                        to_x[3] * math.cos(a / 2) + to_x[0] * math.sin(a / 2)] for a in angles])  # to_x ⊗ (turn about z)
    assert render.add_stripe(scn, points, frames, 0.02) == 4
    centres = np.array([g.pos for g in scn.geoms[before:before + 4]])
    across = centres[:, 1:] - points[0, 1:]  # off the axis (the cable runs along x)
    np.testing.assert_allclose(np.linalg.norm(across, axis=1), 0.02, rtol=1e-5)
    turn = np.diff(np.unwrap(np.arctan2(across[:, 1], across[:, 0])))
    np.testing.assert_allclose(np.abs(turn), math.pi / 8, rtol=1e-5)
    assert all(g.size[0] < 0.02 for g in scn.geoms[before:before + 4])
    with pytest.raises(ValueError, match="frames must be"):
        render.add_stripe(scn, points, frames[:3], 0.02)


def test_frames_draw_the_stripe_for_models_with_frames():
    """``stripe=True`` puts the stripe's colour into a cosserat video and leaves an xpbd one without it."""
    yellow = np.array(overlays.STRIPE_RGBA[:3]) * 255
    for model, has in (("cosserat", True), ("xpbd", False)):
        video = render.frames("hang", model, seconds=0.1, fps=10, stripe=True, min_cable_px=4, **SMALL)
        near = np.abs(video[-1].astype(float) - yellow).max(axis=-1) < 60
        assert near.any() == has, model
