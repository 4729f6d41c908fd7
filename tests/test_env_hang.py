"""The ``hang`` task (issue 23, item 4): a free gripper picks a cable up from a table by its middle and hangs it on a
hook. dm_env's conformance suite and the random policy run ``hang`` with the other tasks in ``tests/test_envs.py``
(conformance on one model in the quick suite, the others with the slow tests).

Physics checked here: the grip closes only within reach and holds the particle it closed on, which then follows the
gripper and carries the lifted part of the cable; let go over the hook, the cable comes to rest on it, its highest point
on the hook's top (the sum of the radii from the hook's axis), its two halves on either side of the axis, both ends
below the hook and clear of the table; let go away from the hook it falls back onto the table.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from catalog_params import model_params

pytestmark = pytest.mark.envs
try:
    from mjcable import envs
    from mjcable.envs import hang
except ImportError:  # dm_control missing or not running on this MuJoCo: the module collects, its tests are selected out
    envs = hang = None

MIDDLE = 15  # hang.SEGMENTS // 2 (asserted below)
OPEN, CLOSE = -1.0, 1.0
CARRY_HEIGHT = 0.35  # m above the hook's top: the lifted cable's 0.3 m halves pass over the hook
GAIN = 0.2  # of the remaining distance per control step (capped at the action bound): a smooth approach
STILL = 0.05  # m/s: the cable's fastest particle this slow counts as at rest before lowering it onto the hook
REST = STILL  # m/s: at rest on the hook (a cable falling off it would gain g × 20 ms = 0.2 m/s in a control step)
# m: the highest point's distance from the hook's axis against the sum of the radii (measured: 0.5 mm above it for the
# particle solvers, joints and composite, 5 µm for springs, 2.7 mm below for flexrod, whose rod sinks into the hook)
CONTACT_TOLERANCE = 3e-3


def _step(env, target, grip: float, count: int, *, gain: float = 1.0, until_still: bool = False):
    """Up to ``count`` control steps moving the gripper towards ``target`` (a ``gain`` of the rest of the way per
    step, capped at the action bound) with ``grip``; ``until_still``: stop once it is there and the cable at rest
    (its fastest particle slower than STILL). Returns the last TimeStep."""
    physics = env.physics
    bound = env.action_spec().maximum[:3]
    for _ in range(count):
        d = np.clip(gain * (np.asarray(target) - physics.gripper_positions()[0]), -bound, bound)
        time_step = env.step(np.append(d, grip))
        if until_still and np.linalg.norm(d) < 1e-4 and _fastest(physics) < STILL:
            break
    return time_step


def _fastest(physics) -> float:
    return float(np.max(np.linalg.norm(physics.centreline_velocity(), axis=1)))


def test_grip_closes_within_reach_holds_and_lets_go():
    assert hang.SEGMENTS // 2 == MIDDLE
    env = envs.load("hang", "xpbd", random=0)
    spec = env.action_spec()
    assert spec.shape == (4,) and spec.minimum[3] == -1.0 and spec.maximum[3] == 1.0
    np.testing.assert_allclose(spec.maximum[:3], envs.MAX_GRIPPER_SPEED * env.control_timestep())
    env.reset()
    with pytest.raises(ValueError, match=r"action entries must lie in ±\[.*1\.0\] \(entry by entry\).*got \[1\.5\]"):
        env.step([0.0, 0.0, 0.0, 1.5])
    physics = env.physics
    sim = physics.simulator
    assert physics.workspace.tethers(0) == ()  # a free gripper: the box and the obstacles only
    time_step = env.step([0.0, 0.0, 0.0, CLOSE])  # closing 20 cm above the cable grasps nothing
    assert sim.grasped == (None,) and time_step.observation["holding"][0] == 0.0
    middle = physics.centreline()[MIDDLE]
    _step(env, middle + [0.0, 0.0, 0.1], OPEN, 40)
    time_step = _step(env, middle - [0.0, 0.0, 0.1], OPEN, 20)  # the workspace stops it on the cable's centre
    assert physics.gripper_positions()[0][2] == pytest.approx(hang.TABLE_TOP + hang.RADIUS, abs=1e-9)
    assert time_step.reward < 0.01  # lying on the table, far below the hook
    time_step = env.step([0.0, 0.0, 0.0, CLOSE])
    assert sim.grasped == (MIDDLE,) and time_step.observation["holding"][0] == 1.0
    time_step = _step(env, middle + [0.0, 0.0, 0.25], CLOSE, 60)  # up 25 cm at full speed, then held there
    held = physics.centreline()[MIDDLE] - physics.gripper_positions()[0]
    assert np.linalg.norm(held) < 1e-3  # the middle particle follows the gripper
    lifted = time_step.observation["gripper_force"][2] / (hang.MASS * 9.81)
    assert 0.5 < lifted < 1.0  # the lifted part of each half (most of its 0.3 m); the rest lies on the table
    assert time_step.reward <= hang.HELD_SHARE
    time_step = env.step([0.0, 0.0, 0.0, OPEN])  # let go away from the hook: the cable falls back onto the table
    assert sim.grasped == (None,) and not np.any(time_step.observation["gripper_force"])
    for _ in range(40):
        time_step = env.step([0.0, 0.0, 0.0, OPEN])
    assert physics.measures()[3] < hang.TABLE_TOP + 2.0 * hang.RADIUS
    assert time_step.reward < 0.01


@pytest.mark.slow
@pytest.mark.parametrize("model", model_params())
def test_scripted_policy_hangs_the_cable_on_the_hook(model):
    """Grasp the middle particle, lift, carry over the hook, wait for the cable to come to rest, lower it onto the
    hook so that the hook passes between the halves, let go: the success reward, on three episodes."""
    env = envs.load("hang", model, random=0)
    physics = env.physics
    for _ in range(3):  # three episodes: three draws of the cable's place and the hook's
        time_step = env.reset()
        middle = physics.centreline()[MIDDLE]
        _step(env, middle, OPEN, 40)
        env.step([0.0, 0.0, 0.0, CLOSE])
        assert physics.simulator.grasped == (MIDDLE,)
        top = physics.hook_top()
        carry = [top[0], top[1], top[2] + CARRY_HEIGHT]
        _step(env, [middle[0], middle[1], carry[2]], CLOSE, 70, gain=GAIN)
        time_step = _step(env, carry, CLOSE, 300, gain=GAIN, until_still=True)
        assert _fastest(physics) < STILL
        x = physics.centreline()
        assert np.min(x[:, 2]) > top[2]  # held aloft, all of it above the hook
        assert 0.0 < time_step.reward <= hang.HELD_SHARE
        _step(env, top + [0.0, 0.0, hang.RADIUS], CLOSE, 100, gain=GAIN)  # onto the hook's top
        time_step = _step(env, top + [0.0, 0.0, hang.RADIUS], OPEN, 100)  # let go, and wait 2 s
        assert not time_step.last()  # within the task's time limit
        assert physics.simulator.grasped == (None,) and not np.any(physics.simulator.gripper_forces)
        x = physics.centreline()
        assert _fastest(physics) < REST
        hook = physics.hook()
        highest = x[np.argmax(x[:, 2])]
        axis_distance = math.hypot(highest[0] - hook.pos[0], highest[2] - hook.pos[2])
        assert axis_distance == pytest.approx(hook.radius + hang.RADIUS, abs=CONTACT_TOLERANCE)  # resting on it
        assert x[0, 0] < hook.pos[0] < x[-1, 0] or x[-1, 0] < hook.pos[0] < x[0, 0]  # a half on each side
        assert np.all(x[[0, -1], 2] < top[2] - hang.HANG_DROP)
        assert np.min(x[:, 2]) - hang.RADIUS > hang.TABLE_TOP + hang.TABLE_GAP  # clear of the table
        assert time_step.reward == 1.0
