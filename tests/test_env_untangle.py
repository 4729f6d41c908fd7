"""The environments over several cables: the ``untangle`` task's physics on every model that simulates several cables
(catalogue capability ``several_cables``; the others are refused up front), observations of every cable, the
workspace's tethers along the cables and through junctions, and videos that show each cable in its colour. dm_env's
conformance suite and the random policy run ``untangle`` with the other tasks in ``tests/test_envs.py``."""

from __future__ import annotations

import math

import imageio_ffmpeg
import numpy as np
import pytest

import mjcable
from catalog_params import marked
from mjcable import catalog, geometry
from mjcable.bench.harness import y_harness_scene
from mjcable.mjcf.world import CABLE_COLOURS
from mjcable.scene import CableSpec, Junction, Pin, Scene

pytestmark = pytest.mark.envs
try:
    from mjcable import envs
    from mjcable.envs import untangle
    from mjcable.envs.workspace import STRETCH_MARGIN, Workspace
except ImportError:  # dm_control missing or not running on this MuJoCo: the module collects, its tests are selected out
    envs = untangle = Workspace = STRETCH_MARGIN = None

SEVERAL = [m for m in catalog.names() if catalog.get(m).several_cables]  # asked of the catalogue, never listed
ONE_CABLE = [m for m in catalog.names() if not catalog.get(m).several_cables]
# One model's geometry cannot hold one cable on another at the sum of their radii: named as a documented limitation
# (README "Several cables"), not as a model list; a model added to the catalogue is tested like every other.
_REST_LIMITATION = {"springs": "springs' cables are spheres at the particles: A's spheres settle into the gaps between "
                               "B's (tests/test_native_cables.py, docs/measurements.md)"}
_DRAG_LIMITATION = {"springs": "springs' cables are spheres at the particles: A's spheres sit in the gaps between "
                               "B's, so lifting or carrying A drags B along (13.9 mm on the straight lift, "
                               "docs/measurements.md)"}
SETTLE_STEPS = 50  # control steps (1 s) holding still: A settles onto B and the table
REST_TOLERANCE = 1e-3  # m: A's centreline rests this close to the sum of the radii from B's
STILL = 0.01  # m: B stays put within this when A is lifted off it
LIFT = 0.45  # m: a lift that takes all of A (0.4 m) off the table
MIN_CHROMA = 60  # a cable's pixel: its largest and smallest channels at least this far apart (of 255)
COLOUR_COSINE = 0.95  # a cable's pixel: its deviation from grey this close in direction to its colour's
MIN_CABLE_PIXELS = 30  # of a cable drawn at least 1.5 pixels in radius in a tile of 96 x 64 or more


def _params(models, reasons=None) -> list:
    """``models`` as test parameters (:func:`catalog_params.marked`), those named in ``reasons`` a strict xfail; all
    but the first of each family run with the slow tests."""
    reasons = reasons or {}
    params = []
    firsts = {next(m for m in models if catalog.get(m).family == f) for f in {catalog.get(m).family for m in models}}
    for m in models:
        marks = getattr(marked(m), "marks", ())
        if m not in firsts:
            marks = (*marks, pytest.mark.slow)
        if m in reasons:
            marks = (*marks, pytest.mark.xfail(reason=reasons[m], strict=True))
        params.append(pytest.param(m, marks=marks))
    return params


def _step_towards(env, target, count: int):
    """``count`` control steps moving the gripper towards ``target`` at the action bound; the last TimeStep."""
    bound = float(np.max(env.action_spec().maximum))
    for _ in range(count):
        time_step = env.step(np.clip(np.asarray(target) - env.physics.gripper_positions()[0], -bound, bound))
    return time_step


def _hold(env, count: int):
    for _ in range(count):
        time_step = env.step(np.zeros(3))
    return time_step


def test_the_task_runs_on_the_models_with_several_cables():
    assert envs.models("untangle") == tuple(SEVERAL)
    assert envs.models("drape") == catalog.names()


@pytest.mark.parametrize("model", ONE_CABLE)
def test_models_without_several_cables_are_refused_up_front(model):
    with pytest.raises(ValueError, match=rf"model must simulate several_cables .* task 'untangle', got '{model}'; "
                                         r"use one of \("):
        envs.load("untangle", model, random=0)


@pytest.mark.parametrize("model", _params(SEVERAL[:1]))
def test_observations_hold_every_cable_in_cable_order(model):
    env = envs.load("untangle", model, random=1)
    observation = _hold(env, 5).observation
    physics = env.physics
    scene = physics.scene
    a, b = scene.cables
    assert observation["centreline"].shape == (a.n_particles + b.n_particles, 3)
    assert observation["centreline_velocity"].shape == observation["centreline"].shape
    np.testing.assert_array_equal(observation["centreline"], physics.simulator.positions)
    np.testing.assert_array_equal(observation["centreline"][:a.n_particles], physics.cable_a())
    np.testing.assert_array_equal(observation["centreline"][a.n_particles:], physics.cable_b())
    assert physics.cable_a().shape == (untangle.SEGMENTS_A + 1, 3)  # A is cable 0, B cable 1
    start = scene.particles[a.n_particles:]
    moved = max(math.dist(p, q) for p, q in zip(observation["centreline"][a.n_particles:], start))
    assert observation["b_displacement"][0] == pytest.approx(moved, abs=1e-15)
    zone = observation["zone"]
    assert zone[1, 2] - zone[0, 2] == pytest.approx(untangle.ZONE_HEIGHT)
    assert zone[0, 2] == untangle.TABLE_TOP
    with pytest.raises(ValueError, match=r"c must be a cable index in \[0, 1\], got 2"):
        physics.cable_centreline(2)


def test_each_episode_draws_its_start_and_zone():
    env = envs.load("untangle", SEVERAL[0], random=0)
    starts = set()
    for _ in range(3):
        observation = env.reset().observation
        starts.add((float(observation["centreline"][-1, 0]), float(observation["zone"][0, 1])))
        x_b = env.physics.cable_b()[:, 0]
        assert untangle.B_X[0] <= x_b.mean() <= untangle.B_X[1]
    assert len(starts) == 3


@pytest.mark.parametrize("model", _params(SEVERAL, _REST_LIMITATION))
def test_a_rests_on_b_at_the_start(model):
    """A starts straight on B's top; settled, it drapes over B: their centrelines the sum of the radii apart at the
    crossing, A's ends down on the table."""
    env = envs.load("untangle", model, random=0)
    _hold(env, SETTLE_STEPS)
    physics = env.physics
    radii = sum(c.radius for c in physics.scene.cables)
    gap = float(np.min(geometry.segment_distances(physics.cable_a(), physics.cable_b())))
    assert abs(gap - radii) < REST_TOLERANCE, f"{model}: A rests {gap * 1e3:.3f} mm from B (radii {radii * 1e3} mm)"
    a = physics.cable_a()
    assert a[-1, 2] < untangle.TABLE_TOP + 2 * untangle.RADIUS  # the free end is down on the table


@pytest.mark.parametrize("model", _params(SEVERAL, _DRAG_LIMITATION))
def test_b_stays_put_when_a_is_lifted_straight_up(model):
    env = envs.load("untangle", model, random=0)
    _hold(env, SETTLE_STEPS // 2)
    physics = env.physics
    before = physics.cable_b().copy()
    above = physics.gripper_positions()[0] + [0.0, 0.0, LIFT]
    _step_towards(env, above, round(LIFT / float(np.max(env.action_spec().maximum))) + 5)  # at full speed
    _hold(env, SETTLE_STEPS // 2)
    assert np.min(physics.cable_a()[:, 2]) > untangle.TABLE_TOP + 0.03  # all of A hangs off the table and B
    moved = np.max(np.linalg.norm(physics.cable_b() - before, axis=1))
    assert moved < STILL, f"{model}: B moved {moved * 1e3:.2f} mm"
    assert physics.b_displacement() < STILL


@pytest.mark.parametrize("model", _params(SEVERAL, _DRAG_LIMITATION))
def test_a_scripted_carry_into_the_zone_earns_the_reward(model):
    """Lift A off B, carry it over the zone and lay it down along the zone while moving away from B."""
    env = envs.load("untangle", model, random=0, time_limit=20.0)
    time_step = _hold(env, SETTLE_STEPS // 2)
    assert time_step.reward < 0.1  # A lies across B, mostly outside the zone
    zone = env.task.zone
    y, top = 0.5 * (zone[0, 1] + zone[1, 1]), untangle.TABLE_TOP
    near, far = zone[1, 0] - 0.04, zone[0, 0] + 0.02  # the zone's ends along x, B's side first
    start = env.physics.gripper_positions()[0]
    _step_towards(env, (start[0], start[1], top + LIFT), 60)
    _step_towards(env, (near, y, top + LIFT), 50)
    for s in np.linspace(0.0, 1.0, 61)[1:]:  # down to the table while moving to the far end: A is laid along x
        _step_towards(env, (near + (far - near) * s, y, top + LIFT + (0.015 - LIFT) * s), 1)
    time_step = _hold(env, SETTLE_STEPS)
    assert env.task.zone_distance(env.physics) < 0.03
    assert env.physics.b_displacement() < STILL
    assert time_step.reward > 0.9


def test_reward_terms_follow_their_definitions():
    env = envs.load("untangle", SEVERAL[0], random=0)
    _hold(env, 5)
    task, physics = env.task, env.physics
    a = physics.cable_a()
    task._zone = np.array([a.min(axis=0), a.max(axis=0)])  # a zone around A where it lies: full reward
    assert task.zone_distance(physics) == 0.0
    assert physics.b_displacement() < untangle.STILL_TOLERANCE and task.get_reward(physics) == 1.0  # B still too
    task._zone = np.array([a.min(axis=0) + [0, 0, 1.0], a.max(axis=0) + [0, 0, 1.0]])  # 1 m above A
    assert task.zone_distance(physics) == pytest.approx(1.0 - (a[:, 2] - a[:, 2].min()).mean(), abs=1e-12)
    assert task.get_reward(physics) < 1e-6


# --- the workspace's tethers over several cables ----------------------------------------------------------------------


def test_tethers_run_through_junctions_and_round_a_loop():
    harness = y_harness_scene(10)
    scene = Scene(harness.cables, (Pin(0, "gripper"), Pin(0, cable=1), Pin(5, cable=2)),
                  junctions=harness.junctions)
    workspace = Workspace(scene, (-2, -2, -2), (2, 2, 2), clearance=0.01)
    legs = [c.length for c in scene.cables]
    keep = 1.0 - STRETCH_MARGIN
    assert workspace.tether(0, 1) == pytest.approx(keep * (legs[0] + legs[1]), rel=1e-12)  # pin to junction to pin
    assert workspace.tether(0, 2) == pytest.approx(keep * (legs[0] + legs[2] / 2), rel=1e-12)
    side_by_side = [CableSpec([[0.0, y, 1.0], [0.5, y, 1.0]], 10, 0.004, 0.05) for y in (0.0, 0.3)]
    apart = Scene(side_by_side, (Pin(0, "gripper"), Pin(0, cable=1)))  # no junction: nothing ties them
    assert Workspace(apart, (-2, -2, -2), (2, 2, 2), clearance=0.01).tether(0, 1) == math.inf
    circle = [[0.2 * math.cos(t), 0.2 * math.sin(t), 1.0] for t in np.linspace(0.0, 2 * math.pi, 9)]
    ring = CableSpec(circle, 24, 0.004, 0.05)
    loop = Scene(ring, (Pin(21, "gripper"), Pin(3)), junctions=(Junction((0, 0), (0, -1)),))
    workspace = Workspace(loop, (-2, -2, -2), (2, 2, 2), clearance=0.01)
    assert workspace.tether(0, 1) == pytest.approx(keep * 6 * ring.segment_length, rel=1e-12)  # 21-24=0-3, not 18
    one = Scene(ring, (Pin(21, "gripper"), Pin(3)))  # the same cable, not closed: along it
    assert Workspace(one, (-2, -2, -2), (2, 2, 2), clearance=0.01).tether(0, 1) == pytest.approx(
        keep * 18 * ring.segment_length, rel=1e-12)


# --- pictures: each cable in its colour ------------------------------------------------------------------------------


def _colour_pixels(image: np.ndarray, c: int) -> int:
    """How many pixels of ``image`` (h, w, 3) show cable ``c``'s colour, whatever the shading: strongly coloured
    (channels at least MIN_CHROMA apart) with the colour's hue (their deviation from grey within COLOUR_COSINE of the
    colour's in direction). The sky, floor, table and labels are greys or a pale brown."""
    ref = 255.0 * np.asarray(CABLE_COLOURS[c][:3])
    ref -= ref.mean()
    pixels = image.reshape(-1, 3).astype(float)
    chroma = pixels - pixels.mean(axis=1, keepdims=True)
    cosine = chroma @ ref / (np.linalg.norm(chroma, axis=1) * np.linalg.norm(ref) + 1e-9)
    return int(np.sum((np.ptp(pixels, axis=1) > MIN_CHROMA) & (cosine > COLOUR_COSINE)))


@pytest.mark.parametrize("model", _params(SEVERAL[:1]))
def test_the_environment_draws_each_cable_in_its_colour(model):
    env = envs.load("untangle", model, random=0)
    env.reset()
    image = env.physics.render(240, 320, camera_id="overview")
    assert _colour_pixels(image, 0) > MIN_CABLE_PIXELS and _colour_pixels(image, 1) > MIN_CABLE_PIXELS


def test_a_video_of_several_scenes_shows_each_cable_in_its_colour(tmp_path):
    from mjcable import render

    models = tuple(m for m in catalog.names() if catalog.get(m).several_cables and catalog.get(m).junctions)[:2]
    path = render.render_parts([("hang", models[:1]), (y_harness_scene(8), models)], tmp_path / "parts.mp4",
                               seconds=0.2, fps=10, tile_width=96, tile_height=64)
    reader = imageio_ffmpeg.read_frames(str(path), pix_fmt="rgb24")
    meta = next(reader)
    width, height = meta["size"]
    frames = [np.frombuffer(buf, np.uint8).reshape(height, width, 3) for buf in reader]
    reader.close()
    assert (width, height) == (96 * len(models), 64) and len(frames) == 4  # 2 frames per part, in one grid
    first, last = frames[0], frames[-1]
    counts = [[_colour_pixels(frame, c) for c in range(3)] for frame in (first, last)]
    assert counts[0][0] > MIN_CABLE_PIXELS and max(counts[0][1:]) < counts[0][0] / 10, counts  # the hang: red
    assert min(counts[1]) > MIN_CABLE_PIXELS, counts  # the harness: three legs in three colours
