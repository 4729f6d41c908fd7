"""Tests of mjcable.envs: dm_env conformance, random-policy robustness, seeding, errors, the Physics over one
Simulator, workspace and task physics. Every task and model comes from the registries (``envs.names()``,
``mjcable.catalog``)."""

from __future__ import annotations

import dataclasses
import math
import unittest

import numpy as np
import pytest
from dm_env import test_utils
from scipy import optimize

import mjcable
from mjcable import catalog, envs

from mjcable.envs import workspace as ws
from mjcable.scene import Box, Capsule, Cylinder, Floor, Sphere

MODELS = mjcable.MODELS

TASKS = envs.names()
MAX_GRIPPER_SPEED = envs.MAX_GRIPPER_SPEED
SHORT_LIMIT = 0.2  # s: conformance episodes of 10 control steps, so the action sequence crosses an episode's end
RANDOM_STEPS = 400  # control steps of the random policy: two 4 s episodes
RANDOM_HOLD = 10  # control steps each random action is held: a persistent random walk reaches the workspace's walls
RANDOM_LIMIT = 4.0  # s, the random policy's episodes
CABLE_MIN_REDNESS = 60  # red minus green and red minus blue of a cable pixel (material (0.85, 0.25, 0.12), shaded)
CABLE_MIN_PIXELS = 150  # a 1 m cable about 1/3 of a 320-pixel-wide frame across, 2 or more pixels thick


def _random_actions(spec, count: int, seed: int):
    rng = np.random.default_rng(seed)
    return [rng.uniform(spec.minimum, spec.maximum, spec.shape) for _ in range(count)]


# --- dm_env's own conformance suite, for every task x model ---------------------------------------------------------


class _Conformance(test_utils.EnvironmentTestMixin):
    task = model = None

    def make_object_under_test(self):
        return envs.load(self.task, self.model, random=0, time_limit=SHORT_LIMIT)

    def make_action_sequence(self):
        yield from _random_actions(self.environment.action_spec(), 25, seed=1)


for _task in TASKS:
    for _model in MODELS:
        _name = f"TestConformance_{_task}_{_model}"
        globals()[_name] = type(_name, (_Conformance, unittest.TestCase), {"task": _task, "model": _model})
del _task, _model, _name


# --- a random policy over two episodes per task x model -------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("task", TASKS)
def test_random_policy(task, model):
    env = envs.load(task, model, random=7, time_limit=RANDOM_LIMIT)
    spec = env.action_spec()
    obs_spec = env.observation_spec()
    time_step = env.reset()
    actions = _random_actions(spec, RANDOM_STEPS // RANDOM_HOLD, seed=11)
    for action in (a for a in actions for _ in range(RANDOM_HOLD)):
        for name, value in time_step.observation.items():
            assert value.dtype == np.float64 and value.shape == obs_spec[name].shape, name
            assert np.all(np.isfinite(value)), (name, value)
        if time_step.last():  # the next reset clears MuJoCo's warnings: check this episode's now
            assert not np.any(env.physics.data.warning.number), env.physics.data.warning.number
        time_step = env.step(action)
        if not time_step.first():
            assert 0.0 <= time_step.reward <= 1.0, time_step.reward
        workspace = env.physics.workspace
        for k in env.physics.scene.grippers:
            excess = workspace.violation(k, env.physics.pin_positions()[k], env.physics.pin_positions(),
                                         env.physics.pins_engaged())
            assert excess <= 1e-9, (k, excess)
    assert not np.any(env.physics.data.warning.number), env.physics.data.warning.number


# --- seeding --------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("task", TASKS)
def test_same_seed_same_episode(task):
    runs = []
    for _ in range(2):
        env = envs.load(task, "springs", random=3, time_limit=0.4)
        steps = [env.reset()]
        steps += [env.step(a) for a in _random_actions(env.action_spec(), 20, seed=5)]  # crosses into episode 2
        runs.append(steps)
    for a, b in zip(*runs):
        assert a.step_type == b.step_type and a.reward == b.reward
        for name in a.observation:
            np.testing.assert_array_equal(a.observation[name], b.observation[name], err_msg=name)


def test_seed_draws_target():
    targets = set()
    for seed in range(4):
        env = envs.load("reach_sag", "springs", random=seed)
        targets.add(float(env.reset().observation["target_sag"][0]))
    assert len(targets) == 4
    env = envs.load("reach_sag", "springs", random=np.random.RandomState(0))
    assert env.reset().observation["target_sag"][0] == envs.load("reach_sag", "springs", random=0).reset(
    ).observation["target_sag"][0]


# --- settings: the catalogue's families, not model names -----------------------------------------------------------


def test_family_defaults_reach_every_model_of_the_family_and_yield_to_the_caller():
    particle = catalog.get(catalog.names("particle")[0])
    entry = dataclasses.replace(particle, name="test_env_particle", summary="a particle model registered by a test")
    catalog.register(entry)
    try:
        env = envs.load("reach_sag", entry.name, random=0)  # registered at run time: no other edit needed
        assert env.physics.simulator.settings.substeps == envs.FAMILY_DEFAULTS["particle"]["substeps"]
        assert envs.load("reach_sag", entry.name, random=0, substeps=3).physics.simulator.settings.substeps == 3
    finally:
        catalog.unregister(entry.name)
    for model in MODELS:
        family = envs.FAMILY_DEFAULTS.get(catalog.get(model).family, {})
        assert envs.env_defaults(model) == family, model


# --- errors ---------------------------------------------------------------------------------------------------------


def test_unknown_names():
    with pytest.raises(ValueError, match=r"task must be one of .*'tie_knot'"):
        envs.load("tie_knot", "springs")
    with pytest.raises(ValueError, match=r"model must be one of .*'rubber'"):
        envs.load("reach_sag", "rubber")
    with pytest.raises(ValueError, match=r"unknown setting.*'wobble'"):
        envs.load("reach_sag", "springs", wobble=3)


@pytest.mark.parametrize("kwargs, match", [
    (dict(time_limit=-1.0), r"time_limit must be .* got -1.0"),
    (dict(time_limit=math.inf), r"time_limit must be .* got inf"),
    (dict(control_timestep=0.003), r"control_timestep must be a whole number .* got 0.003"),
    (dict(control_timestep=0.0), r"control_timestep must be .* got 0.0"),
])
def test_bad_options(kwargs, match):
    with pytest.raises(ValueError, match=match):
        envs.load("reach_sag", "springs", **kwargs)


def test_actions_outside_the_spec():
    env = envs.load("reach_sag", "springs", random=0)
    env.reset()
    bound = env.action_spec().maximum.max()
    with pytest.raises(ValueError, match=r"action entries must lie in .*0\.5"):
        env.step(np.array([0.0, 0.5, 0.0]))
    with pytest.raises(ValueError, match=r"action must have shape \(3,\).*shape \(2,\)"):
        env.step(np.zeros(2))
    with pytest.raises(ValueError, match=r"action must be finite.*nan"):
        env.step(np.array([np.nan, 0.0, 0.0]))
    with pytest.raises(ValueError, match=r"action must be an array"):
        env.step("up")
    env.step(np.full(3, bound, dtype=np.float32))  # exactly at the bound, even rounded to float32: accepted


def test_record_episode_errors(tmp_path):
    with pytest.raises(ValueError, match=r"policy must be one of .*'greedy'"):
        envs.record_episode("drape", "springs", tmp_path / "x.mp4", policy="greedy", seconds=0.04)
    with pytest.raises(ValueError, match=r"width must be .* got 0"):
        envs.record_episode("drape", "springs", tmp_path / "x.mp4", width=0)


# --- the Physics wraps one Simulator and mirrors none of its state --------------------------------------------------


def test_physics_shares_the_simulators_data():
    env = envs.load("unplug", "springs", random=0)
    env.reset()
    physics = env.physics
    assert physics.data.ptr is physics.simulator.mj_data
    assert physics.model.ptr is physics.simulator.mj_model
    assert physics.timestep() == physics.simulator.dt
    env.step(np.zeros(3))
    assert physics.time() == pytest.approx(env.control_timestep())
    step = float(np.max(env.action_spec().maximum))
    observation = env.step(np.array([step, 0.0, step])).observation
    np.testing.assert_array_equal(observation["centreline"], physics.simulator.positions)
    np.testing.assert_array_equal(observation["grippers"], physics.simulator.gripper_positions)
    start = physics.scene.cable.particles[physics.scene.pin_particle(1)]
    np.testing.assert_allclose(observation["grippers"][0], start + [step, 0.0, step], atol=1e-12)  # as commanded
    np.testing.assert_array_equal(physics.pin_positions()[0], physics.scene.cable.particles[0])  # the socket stays


def _start_state(env) -> dict:
    """Everything an episode starts from: the Simulator's read-outs and the MuJoCo state under them."""
    sim = env.physics.simulator
    d = sim.mj_data
    return {"positions": sim.positions, "velocities": sim.velocities, "grippers": sim.gripper_positions,
            "time": np.array([sim.time, sim.steps]), "released": np.array(sorted(sim.released)),
            "qpos": d.qpos.copy(), "qvel": d.qvel.copy(), "act": d.act.copy(), "mocap_pos": d.mocap_pos.copy(),
            "mocap_quat": d.mocap_quat.copy(), "eq_active": d.eq_active.copy(),
            "qacc_warmstart": d.qacc_warmstart.copy()}


@pytest.mark.parametrize("model", MODELS)
def test_one_simulator_across_episodes_restarts_exactly(model):
    env = envs.load("unplug", model, random=0)
    env.reset()
    sim = env.physics.simulator
    step = float(np.max(env.action_spec().maximum))
    for _ in range(100):  # yank the gripper away from the socket at full speed until the plug comes out
        away = env.physics.gripper_positions()[0] - env.physics.socket()
        if env.step(step * away / np.max(np.abs(away))).observation["released"][0]:
            break
    assert sim.released and sim.steps > 0  # the episode changed the state, the grippers and the socket
    again = env.reset()
    assert env.physics.simulator is sim  # the same scene: the same Simulator, reset
    fresh = envs.load("unplug", model, random=0)
    first = fresh.reset()
    expected = _start_state(fresh)
    for name, value in _start_state(env).items():  # restarting is exact: equal to a fresh start, bit for bit
        np.testing.assert_array_equal(value, expected[name], err_msg=name)
    actions = _random_actions(env.action_spec(), 5, seed=2)
    for a, b in zip([again] + [env.step(x) for x in actions], [first] + [fresh.step(x) for x in actions]):
        for name in a.observation:
            if name != "target":  # the task's random target is the next draw of the same stream, not the first
                np.testing.assert_array_equal(a.observation[name], b.observation[name], err_msg=name)


def test_a_new_simulator_only_for_a_new_start_shape():
    model = catalog.names("particle")[0]
    env = envs.load("drape", model, random=0, dt=0.004, iterations=2)
    env.reset()
    sim = env.physics.simulator
    env.step(np.zeros(3))
    env.reset()  # drape draws a new start side and distance from the peg: a new scene, so a new Simulator
    new = env.physics.simulator
    assert new is not sim and new.scene != sim.scene
    assert (new.model, new.dt, new.settings) == (sim.model, 0.004, sim.settings)  # the same model and settings
    assert new.settings.iterations == 2 and new.steps == 0
    assert env.physics.data.ptr is new.mj_data and env.physics.model.ptr is new.mj_model
    env.step(np.zeros(3))
    env.task.make_scene = lambda: new.scene  # the next start shape is the same: the Simulator is reused
    env.reset()
    assert env.physics.simulator is new and new.steps == 0


@pytest.mark.parametrize("model", MODELS)
def test_velocity_observation_is_the_models_own(model):
    env = envs.load("reach_sag", model, random=0)
    observation = env.reset().observation
    np.testing.assert_array_equal(observation["centreline_velocity"], env.physics.simulator.velocities)
    # the cable starts at rest (a Verlet model's implied velocity, half a substep back, is below one dt of gravity)
    assert np.max(np.abs(observation["centreline_velocity"])) <= 9.81 * env.physics.timestep()
    step = float(np.max(env.action_spec().maximum))
    before = observation["centreline"]
    for _ in range(3):
        observation = env.step(np.array([0.0, 0.0, step])).observation  # lift the right-hand end at full speed
        velocity = observation["centreline_velocity"]
        np.testing.assert_array_equal(velocity, env.physics.simulator.velocities)
    mean = (observation["centreline"] - before) / (3 * env.control_timestep())  # what differencing would report
    assert np.max(np.abs(velocity)) > 0.1 * MAX_GRIPPER_SPEED  # the lifted end drags the cable along
    assert not np.allclose(velocity, mean)


# --- workspace: independent distances and the clamp ---------------------------------------------------------------


@pytest.mark.parametrize("obstacle, point, distance, normal", [
    (Floor(pos=(0, 0, 0.5)), (1.0, 2.0, 0.7), 0.2, (0, 0, 1)),
    (Floor(euler=(0, 90, 0)), (0.3, 0.0, 5.0), 0.3, (1, 0, 0)),  # +90° about y turns the normal z into +x
    (Sphere(radius=0.1, pos=(1, 0, 0)), (1.0, 0.0, 0.3), 0.2, (0, 0, 1)),
    (Box(size=(0.1, 0.2, 0.3)), (0.4, 0.0, 0.0), 0.3, (1, 0, 0)),
    (Box(size=(0.1, 0.2, 0.3)), (0.4, 0.6, 0.0), 0.5, (0.6, 0.8, 0)),  # corner region: 3-4-5 triangle
    (Box(size=(0.1, 0.2, 0.3)), (0.05, 0.0, 0.0), -0.05, (1, 0, 0)),
    (Box(size=(0.1, 0.2, 0.3), euler=(0, 0, 90)), (0.4, 0.0, 0.0), 0.2, (1, 0, 0)),  # y half-extent now along x
    (Cylinder(radius=0.1, half_length=0.5), (0.0, 0.4, 0.2), 0.3, (0, 1, 0)),
    (Cylinder(radius=0.1, half_length=0.5), (0.0, 0.0, 0.9), 0.4, (0, 0, 1)),
    (Cylinder(radius=0.1, half_length=0.5), (0.4, 0.0, 0.9), 0.5, (0.6, 0, 0.8)),  # beyond the rim
    (Cylinder(radius=0.03, half_length=0.3, pos=(0.05, 0, 0.8), euler=(90, 0, 0)), (0.05, 0.1, 0.9), 0.07, (0, 0, 1)),
    (Capsule(radius=0.1, half_length=0.5), (0.0, 0.0, 0.9), 0.3, (0, 0, 1)),
    (Capsule(radius=0.1, half_length=0.5), (0.05, 0.0, 0.0), -0.05, (1, 0, 0)),
])
def test_signed_distance(obstacle, point, distance, normal):
    d, n = ws.signed_distance(obstacle, point)
    assert d == pytest.approx(distance, abs=1e-12)
    np.testing.assert_allclose(n, normal, atol=1e-12)


def test_clamp_keeps_grippers_out_of_the_peg_and_within_reach():
    # drape: drive the gripper straight down onto the peg for 3 s at full speed
    env = envs.load("drape", "springs", random=0)
    env.reset()
    physics = env.physics
    peg_top = physics.peg_top()
    step = float(np.max(env.action_spec().maximum))
    for _ in range(60):  # first over the peg, above the hanging cable
        g = physics.gripper_positions()[0]
        env.step(np.clip(np.array([peg_top[0], 0.0, 1.45]) - g, -step, step))
    for _ in range(150):
        env.step(np.array([0.0, 0.0, -step]))
    g = physics.gripper_positions()[0]
    assert g[0] == pytest.approx(peg_top[0], abs=1e-6)
    assert g[2] == pytest.approx(peg_top[2] + physics.workspace.clearance, abs=1e-6)  # resting on the clearance

    # reach_sag: pull the right gripper away from the left one for 4 s at full speed
    env = envs.load("reach_sag", "springs", random=0)
    env.reset()
    for _ in range(200):
        env.step(np.array([step, 0.0, 0.0]))
    physics = env.physics
    cable = physics.scene.cable
    span = float(np.linalg.norm(np.diff(physics.gripper_positions(), axis=0)))
    assert span == pytest.approx((1.0 - envs.STRETCH_MARGIN) * cable.length, rel=1e-9)
    arc = float(np.sum(np.linalg.norm(np.diff(physics.centreline(), axis=0), axis=1)))
    assert arc < 1.02 * cable.length  # nearly straight, stretched at most by its own elasticity (springs: ~1 %)


# --- task physics, on every model -----------------------------------------------------------------------------------


@pytest.mark.parametrize("model", MODELS)
def test_unplug_pull_releases_and_rest_does_not(model):
    env = envs.load("unplug", model, random=0)
    time_step = env.reset()
    for _ in range(100):  # 2 s at rest: the swinging cable pulls less than the release force
        time_step = env.step(np.zeros(3))
    assert time_step.observation["released"][0] == 0.0
    physics = env.physics
    step = float(np.max(env.action_spec().maximum))
    for _ in range(150):  # pull straight away from the socket at full speed: the plug comes out
        away = physics.gripper_positions()[0] - physics.socket()
        time_step = env.step(step * away / np.max(np.abs(away)))
        if time_step.observation["released"][0]:
            break
    assert time_step.observation["released"][0] == 1.0
    assert time_step.reward >= 0.5


@pytest.mark.parametrize("model", MODELS)
def test_reach_sag_settles_to_the_catenary_and_rewards_its_target(model):
    env = envs.load("reach_sag", model, random=0)
    env.reset()
    sags = []
    for _ in range(250):  # 5 s holding still: the sag swings about the catenary's
        time_step = env.step(np.zeros(3))
        sags.append(time_step.observation["sag"][0])
    x = time_step.observation["centreline"]
    n = len(x) - 1
    sag = 0.5 * (x[0, 2] + x[-1, 2]) - 0.5 * (x[n // 2, 2] + x[(n + 1) // 2, 2])
    assert sags[-1] == pytest.approx(sag)
    assert np.mean(sags[100:]) == pytest.approx(_catenary_sag(length=1.0, span=0.8), abs=0.01)  # mean of the last 3 s
    task = env.task
    task._target = sag  # the target where the cable is: full reward
    assert task.get_reward(env.physics) == 1.0
    task._target = sag + 0.3
    assert 0.0 <= task.get_reward(env.physics) < 0.1


# One model's own physics cannot hold the draped cable: named here as a documented limitation, not a model list (a
# model added to the catalogue is tested like every other).
_DRAPE_KNOWN_LIMITATION = {"springs": "the springs bead chain slides off the peg once the gripper stops"}
DRAPE_SETTLE_STEPS = 150  # 3 s holding still: the lightly damped capsule chains' free leg stops swinging across the axis


@pytest.mark.slow
@pytest.mark.parametrize("model", [
    pytest.param(m, marks=pytest.mark.xfail(reason=_DRAPE_KNOWN_LIMITATION[m], strict=True))
    if m in _DRAPE_KNOWN_LIMITATION else m
    for m in MODELS
])
def test_drape_scripted_solution(model):
    env = envs.load("drape", model, random=0, time_limit=20.0)
    env.reset()
    physics = env.physics
    top = physics.peg_top()
    start = physics.gripper_positions()[0]
    assert env.task.get_reward(physics) < 0.1  # hanging beside the peg
    far = top[0] - 0.25 * np.sign(start[0] - top[0])  # 0.25 m beyond the peg's axis
    step = float(np.max(env.action_spec().maximum))
    for target, count in (((far, 0.0, start[2]), 60), ((far, 0.0, 0.5), 350)):  # over the peg, then down beyond it
        for _ in range(count):
            time_step = env.step(np.clip(np.array(target) - physics.gripper_positions()[0], -step, step))
    for _ in range(DRAPE_SETTLE_STEPS):
        time_step = env.step(np.zeros(3))
    legs = physics.leg_positions()
    assert min(legs) < top[0] < max(legs)
    assert physics.rest_gap() < 0.02
    assert time_step.reward > 0.95


@pytest.mark.parametrize("model", MODELS)
def test_render_shows_the_cable(model):
    env = envs.load("reach_sag", model, random=0)
    env.reset()
    image = env.physics.render(240, 320, camera_id="overview").astype(int)
    assert image.shape == (240, 320, 3)
    red = (image[..., 0] - image[..., 2] > CABLE_MIN_REDNESS) & (image[..., 0] - image[..., 1] > CABLE_MIN_REDNESS)
    assert red.sum() > CABLE_MIN_PIXELS, red.sum()  # the sky, floor and grippers are grey or blue: only cable is red


def _catenary_sag(*, length: float, span: float) -> float:
    """Sag of a uniform chain of ``length`` hung between two points ``span`` apart at equal height:
    ``length = 2 a sinh(span / 2a)``, sag ``a (cosh(span / 2a) - 1)``."""
    a = optimize.brentq(lambda a: 2.0 * a * math.sinh(span / (2.0 * a)) - length, 0.05, 100.0)
    return a * (math.cosh(span / (2.0 * a)) - 1.0)


def test_record_episode(tmp_path):
    from mjcable import render

    path = envs.record_episode("unplug", "springs", tmp_path / "unplug.mp4", seconds=0.2, width=96, height=64,
                               fps=25, seed=0)
    video, fps = render.read_video(path)
    assert fps == pytest.approx(25.0)
    assert video.shape == (5, 64, 96, 3)  # 0.2 s at 25 frames per second
