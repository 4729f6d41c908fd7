"""Tests of the ``jaco_unplug`` environment (mjcable.envs.jaco_unplug): dm_env conformance on every model, 1000
random control steps on every model (finite, no divergence), a segmentation frame of the overview camera with the arm
and the cable, the scripted retreat of the arm pulling the plug out of the socket on every model (the task is
solvable), ``mjcable render --env jaco_unplug`` and ``scripts/jaco_compare.py``."""

from __future__ import annotations

import csv
import importlib.util
import math
import unittest
from pathlib import Path

import numpy as np
import pytest

import mjcable
import mjcable.cli
import mjcable.io
from mjcable.worlds import jaco

pytestmark = pytest.mark.envs  # dm_control: the MuJoCo-4 CI job selects every test here out (-m "not envs")
try:
    from dm_env import test_utils

    from mjcable import envs
    from mjcable.envs import jaco_unplug as ju
except ImportError:  # dm_control missing or not running on this MuJoCo: the module collects, its tests are selected out
    test_utils = envs = ju = None

TASK = "jaco_unplug"
MODELS = tuple(mjcable.catalog.names())
QUICK = ("joints", "xpbd")  # one native, one particle model: the quick run's
SHORT_LIMIT = 0.2  # s: conformance episodes of 10 control steps, so the 25 actions cross episode ends
RANDOM_STEPS = 1000  # control steps (20 s: two 10 s episodes)
RANDOM_HOLD = 10  # control steps each random action is held, so the arm really moves between the bounds
RANDOM_SEED = 11
# Action seeds on which the undamped cable diverged (see the module docstring of mjcable.envs.jaco_unplug): joints
# and composite on 6, 10, 11, 17, 29, springs on 6, 10, 11
EXTRA_SEEDS = {"joints": (6, 10, 17, 29), "springs": (6,), "composite": (6,), "flexrod": (6,)}  # the cheap models


def _random_actions(spec, count: int, seed: int):
    rng = np.random.default_rng(seed)
    return [rng.uniform(spec.minimum, spec.maximum, spec.shape) for _ in range(count)]


# --- dm_env's own conformance suite, for every model ----------------------------------------------------------------


class _Conformance(test_utils.EnvironmentTestMixin if test_utils else object):
    model = None

    def make_object_under_test(self):
        return envs.load(TASK, self.model, random=0, time_limit=SHORT_LIMIT)

    def make_action_sequence(self):
        yield from _random_actions(self.environment.action_spec(), 25, seed=1)


_QUICK = ("xpbd", "joints", "composite", "flexrod", "springs")  # pbd and jakobsen (~5 s each) run with the slow ones
for _model in MODELS:
    _name = f"TestConformance_{_model}"
    _marks = {} if _model in _QUICK else {"pytestmark": [pytest.mark.slow]}
    globals()[_name] = type(_name, (_Conformance, unittest.TestCase), {"model": _model, **_marks})  # ~25 s for all
del _model, _name, _marks


# --- registry, specs, reward ----------------------------------------------------------------------------------------


def test_registered_with_its_own_step_and_specs():
    assert TASK in envs.names() and TASK in envs.names("arm") and TASK not in envs.names("benchmarking")
    env = envs.load(TASK, "joints", random=0)
    assert env.physics.timestep() == ju.DT and env.control_timestep() == pytest.approx(0.02)
    spec = env.action_spec()
    assert spec.shape == (6,) and np.all(spec.minimum == -ju.ACTION_RANGE) and np.all(spec.maximum == ju.ACTION_RANGE)
    obs = env.reset().observation
    assert list(obs) == ["centreline", "centreline_velocity", "arm_qpos", "arm_qvel", "grip", "plug", "socket",
                         "released", "target"]
    n = ju.SEGMENTS + 1
    assert obs["centreline"].shape == (n, 3) and obs["arm_qpos"].shape == (6,) and obs["released"].shape == (1,)
    np.testing.assert_allclose(obs["arm_qpos"], jaco.home_qpos(), atol=1e-9)
    np.testing.assert_allclose(obs["grip"], obs["centreline"][0], atol=1e-6)
    np.testing.assert_array_equal(obs["plug"], obs["centreline"][-1])
    assert np.all(obs["target"] >= ju.TARGET_BOX[0]) and np.all(obs["target"] <= ju.TARGET_BOX[1])
    np.testing.assert_array_equal(env.physics.named.model.site_pos[jaco.TARGET_SITE], obs["target"])
    # the plug starts a cable radius plus the standoff out of the faceplate, along the socket site's z axis
    site = env.physics.named.data
    out = site.site_xmat[jaco.SOCKET_SITE].reshape(3, 3)[:, 2]
    np.testing.assert_allclose(obs["plug"], site.site_xpos[jaco.SOCKET_SITE]
                               + (ju.CABLE_RADIUS + ju.PLUG_STANDOFF) * out, atol=1e-9)
    assert out[0] == pytest.approx(-1.0)  # out of the wall (the wall faces -x)


def test_actions_are_offsets_from_home_and_checked():
    env = envs.load(TASK, "joints", random=0)
    env.reset()
    action = np.linspace(-0.3, 0.3, 6)
    env.step(action)
    np.testing.assert_allclose(env.physics.arm_targets(), jaco.home_qpos() + action)
    for bad in (np.zeros(5), np.full(6, np.nan), np.full(6, ju.ACTION_RANGE + 0.1)):
        with pytest.raises(ValueError):
            env.step(bad)


def test_resting_cable_does_not_release_and_reward_is_small():
    env = envs.load(TASK, "joints", random=0, time_limit=2.0)
    ts = env.reset()
    while not ts.last():
        ts = env.step(np.zeros(6))
        assert 0.0 <= ts.reward < 0.5 and ts.observation["released"][0] == 0.0
    # the arm holds home within a few mrad under the cable's pull
    np.testing.assert_allclose(ts.observation["arm_qpos"], jaco.home_qpos(), atol=5e-3)
    assert np.linalg.norm(env.physics.simulator.pin_forces[1]) < 0.5 * ju.RELEASE_FORCE


# --- a random policy, 1000 control steps ----------------------------------------------------------------------------


_RANDOM_CASES = [(model, RANDOM_SEED) for model in MODELS] + [(m, seed) for m in EXTRA_SEEDS for seed in EXTRA_SEEDS[m]]


@pytest.mark.slow
@pytest.mark.parametrize("model, seed", _RANDOM_CASES)
def test_random_policy_stays_finite(model, seed):
    """1000 control steps (two episodes) of uniform random arm targets, each held 0.2 s, on every model: every
    observation finite and of its spec, the cable's positions finite, no divergence, no MuJoCo warning."""
    env = envs.load(TASK, model, random=7)
    obs_spec = env.observation_spec()
    time_step = env.reset()
    actions = _random_actions(env.action_spec(), RANDOM_STEPS // RANDOM_HOLD, seed=seed)
    episodes = 1
    for action in (a for a in actions for _ in range(RANDOM_HOLD)):
        for name, value in time_step.observation.items():
            assert value.dtype == np.float64 and value.shape == obs_spec[name].shape, name
            assert np.all(np.isfinite(value)), (name, value)
        assert np.all(np.isfinite(env.physics.simulator.positions)) and np.all(np.isfinite(env.physics.data.qpos))
        if time_step.last():
            assert not np.any(env.physics.data.warning.number), env.physics.data.warning.number
            time_step = env.reset()
            episodes += 1
            continue
        time_step = env.step(action)  # raises SimulationDivergedError on divergence
        assert math.isfinite(time_step.reward) and 0.0 <= time_step.reward <= 1.0, time_step.reward
    assert episodes == 2 and not np.any(env.physics.data.warning.number)


# --- the task is solvable: retreating from the wall pulls the plug out ----------------------------------------------


# the quick run retreats with the native models; xpbd's release in this task is quick in test_socket_release.py
_RETREAT_QUICK = ("joints", "composite", "flexrod", "springs")


@pytest.mark.parametrize("model", [m if m in _RETREAT_QUICK else pytest.param(m, marks=pytest.mark.slow)
                                   for m in MODELS])
def test_retreating_arm_releases_the_plug(model):
    env = envs.load(TASK, model, random=0, time_limit=3.0)
    ts = env.reset()
    start = ts.observation["grip"]
    released_at = None
    while not ts.last():
        ts = env.step(ju.retreat_action(env.physics.time() + env.control_timestep()))
        if released_at is None and ts.observation["released"][0] == 1.0:
            released_at = env.physics.time()
            assert ts.reward >= 0.5
    assert released_at is not None, f"{model}: the plug stayed in; pin force {env.physics.simulator.pin_forces[1]}"
    assert ts.observation["grip"][0] < start[0] - 0.15  # the hand did retreat along -x
    assert np.linalg.norm(ts.observation["plug"] - ts.observation["socket"]) > 0.05  # and the plug came away


# --- rendering ------------------------------------------------------------------------------------------------------


def _segmentation(env, height=240, width=320):
    try:
        return env.physics.render(height, width, camera_id=jaco.CAMERA, segmentation=True)
    except Exception as exc:  # no usable OpenGL backend here
        if any(word in f"{type(exc).__name__} {exc}".lower() for word in ("gl", "egl", "display", "render")):
            pytest.skip(f"no offscreen OpenGL: {exc}")
        raise


@pytest.mark.parametrize("model", QUICK)
def test_overview_frame_shows_arm_and_cable(model):
    env = envs.load(TASK, model, random=0)
    env.reset()
    for _ in range(5):
        env.step(np.zeros(6))
    seg = _segmentation(env)
    m = env.physics.model
    geom = seg[..., 1] == int(__import__("mujoco").mjtObj.mjOBJ_GEOM)
    ids = np.unique(seg[..., 0][geom])
    world_geoms = jaco.jaco_lab_spec().compile().ngeom  # the cable's geoms come after the world's
    arm = [i for i in ids if i < world_geoms and m.id2name(m.geom_bodyid[i], "body").startswith(jaco.ARM_PREFIX)]
    cable = [i for i in ids if i >= world_geoms]
    assert len(arm) >= 3, f"{model}: arm geoms seen {arm}"
    assert len(cable) >= 5, f"{model}: cable geoms seen {[m.id2name(i, 'geom') for i in cable]}"
    if model in mjcable.catalog.names("particle"):
        assert all(m.id2name(i, "geom").startswith("segment") for i in cable)
    pixels = np.count_nonzero(np.isin(seg[..., 0], cable) & geom)
    assert pixels >= 50, f"{model}: only {pixels} cable pixels"


@pytest.mark.slow
def test_render_env_writes_an_episode(tmp_path):
    env = envs.load(TASK, "joints", random=0, time_limit=0.2)
    _segmentation(env, 32, 32)  # skips without GL
    path = mjcable.render.render_env(env, tmp_path / "jaco.mp4", seconds=0.2, fps=10, width=160, height=120)
    assert path.stat().st_size > 0


# --- the scripts and the command line -------------------------------------------------------------------------------


def _skip_without_gl(exc: Exception) -> None:
    """Skip when ``exc`` says there is no offscreen OpenGL context (any other error fails the test)."""
    if any(word in f"{type(exc).__name__} {exc}".lower() for word in ("egl", "opengl", "osmesa", "gl context",
                                                                       "display", "mujoco_gl")):
        pytest.skip(f"no offscreen OpenGL: {exc}")


def _red_pixels(video: np.ndarray) -> np.ndarray:
    """Pixels per frame in the drawn cable's red (mjcable.render.overlays.CABLE_RGBA) and nothing else's."""
    return ((video[..., 0].astype(int) - video[..., 1] > 60) & (video[..., 0] > 120)).sum(axis=(1, 2))


def test_render_command_records_a_jaco_episode(tmp_path, capsys):
    """``mjcable render --env jaco_unplug``: an MP4 of the overview camera with the cable drawn in every frame."""
    path = tmp_path / "jaco.mp4"
    try:
        status = mjcable.cli.main(["render", "--env", TASK, "--model", "joints", "--seed", "0", "-o", str(path),
                                   "--seconds", "0.2", "--fps", "10", "--width", "160", "--height", "120"])
    except Exception as exc:
        _skip_without_gl(exc)
        raise
    assert status == 0, capsys.readouterr().err
    video, fps = mjcable.render.read_video(path)
    assert video.shape == (2, 120, 160, 3) and fps == pytest.approx(10)
    assert _red_pixels(video).min() > 20  # the cable, drawn at >= 1.5 px radius, in every frame
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(mjcable.io.TEMP_PREFIX)]


def _read_png(path) -> np.ndarray:
    from matplotlib import image

    return image.imread(path)


def _compare_script():
    path = Path(__file__).resolve().parents[1] / "scripts" / "jaco_compare.py"
    spec = importlib.util.spec_from_file_location("jaco_compare", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow  # (keeps the quick suite of a cold clone under 5 minutes)
def test_compare_script_writes_video_plot_and_pin_forces(tmp_path, capsys):
    """scripts/jaco_compare.py on two models, tiny: a grid video with both cables, a PNG plot, and pin forces at every
    step that carry the cable's weight while it hangs between the hand and the socket."""
    compare = _compare_script()
    out = tmp_path / "out"
    seconds, fps = 0.3, 10
    try:
        status = compare.main(["--out", str(out), "--models", "joints", "springs", "--seconds", str(seconds),
                               "--fps", str(fps), "--width", "96", "--height", "72"])
    except Exception as exc:
        _skip_without_gl(exc)
        raise
    assert status == 0, capsys.readouterr().err
    video, _ = mjcable.render.read_video(out / compare.VIDEO)
    assert video.shape == (round(seconds * fps), 72, 2 * 96, 3)  # one row of two tiles
    assert _red_pixels(video[:, :, :96]).min() > 5 and _red_pixels(video[:, :, 96:]).min() > 5  # both cables
    image = _read_png(out / compare.PLOT)
    assert image.shape[0] >= 300 and image.shape[1] >= 400 and np.ptp(image[..., :3]) > 0.5
    with open(out / compare.TABLE, newline="") as f:
        rows = list(csv.DictReader(f))
    steps = round(seconds / ju.DT) + 1  # the start and every Simulator step
    weight = ju.CABLE_MASS * 9.81
    for model in ("joints", "springs"):
        mine = [r for r in rows if r["model"] == model]
        assert len(mine) == steps
        times = np.array([float(r["time_s"]) for r in mine])
        np.testing.assert_allclose(times, ju.DT * np.arange(steps), atol=1e-9)
        total = np.array([float(r["hand_N"]) + float(r["socket_N"]) for r in mine])
        assert np.all(np.isfinite(total))
        # |F_hand| + |F_socket| >= |F_hand + F_socket|, whose mean over the window is the cable's weight plus its
        # momentum change over the window (a few hundredths of a newton-second while it settles and hangs)
        assert np.mean(total[1:]) > 0.8 * weight, (model, total)
    assert not [p for p in out.iterdir() if p.name.startswith(mjcable.io.TEMP_PREFIX)]
