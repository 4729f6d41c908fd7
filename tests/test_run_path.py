"""One run path for every model: ``Simulator.step``, ``step_along`` and ``rollout`` all go through the backend's
``run`` (the particle solvers: one compiled loop, :func:`mjcable.solvers.kernels.run_steps`; the native models: a loop
of ``mj_step``), so that how a duration is split into calls changes nothing, bit for bit, and divergence found inside
the loop names its step, time and reason."""

import numba
import numpy as np
import pytest

import mjcable
from mjcable import catalog
from mjcable.solvers import kernels

PARTICLE = catalog.names("particle")
SECONDS = 0.1  # 50 steps at the default dt: a gripper move, a socket near its release force, contacts


def _counting(monkeypatch, name: str) -> dict:
    """Count the calls of ``kernels.<name>`` (still running the real kernel)."""
    calls = {"n": 0}
    real = getattr(kernels, name)

    def counted(*args):
        calls["n"] += 1
        return real(*args)

    monkeypatch.setattr(kernels, name, counted)
    return calls


def _state(sim) -> dict:
    d = sim.mj_data
    return dict(x=sim.positions, v=sim.velocities, f=sim.pin_forces, torque=sim.pin_torques,
                sites=d.site_xpos.copy(), geoms=d.geom_xpos.copy(), quat=d.mocap_quat.copy(),
                time=np.array([d.time, sim.time]), released=np.array(sorted(sim.released)),
                counts=np.array([sim.diagnostics.get(k, 0) for k in ("contacts", "self_contacts", "queries")]))


def _run(scene, model: str, chunks: int) -> dict:
    """The state after a gripper move (for scenes with a gripper) and ``SECONDS`` of steps in ``chunks`` calls."""
    sim = mjcable.Simulator(scene, model)
    for pin in scene.gripper_pins:
        sim.move_gripper(pin, sim.gripper_positions[0] + [0.03, 0.0, 0.02])  # spread over the next step
    for _ in range(chunks):
        sim.step(SECONDS / chunks)
    assert sim.steps == 50
    return _state(sim)


@pytest.mark.parametrize("model", [*PARTICLE, "springs"])
@pytest.mark.parametrize("scene_name", ["hang", "socket"])
def test_one_call_equals_one_step_per_call_bit_for_bit(scene_name, model, monkeypatch):
    scene = mjcable.scenes.get(scene_name, n_segments=12, damping=1.0)
    loops = _counting(monkeypatch, "run_steps")
    whole = _run(scene, model, 1)
    if model in PARTICLE:
        assert loops["n"] <= 2  # compiled loops (queries inside them), of about 0.1 s of wall time each
    stepped = _run(scene, model, 50)
    for key in stepped:
        np.testing.assert_array_equal(whole[key], stepped[key], err_msg=f"{key} differs between the two splits")
    assert np.all(np.isfinite(whole["f"])) and np.abs(whole["f"]).max() > 0.0  # the pins hold the cable


@pytest.mark.parametrize("self_collision", [False, True])
def test_rollout_records_the_states_of_single_steps(self_collision):
    """The drape falls freely, then lands (queried steps); with self-collision every step is queried."""
    scene = mjcable.scenes.get("drape", n_segments=12)
    rolled = mjcable.Simulator(scene, "xpbd", self_collision=self_collision)
    traj = rolled.rollout(0.3, every=7)
    assert rolled.diagnostics["queries"] > 0
    stepped = mjcable.Simulator(scene, "xpbd", self_collision=self_collision)
    for r, step in enumerate(np.round(traj.times / stepped.dt).astype(int)):
        stepped.step((step - stepped.steps) * stepped.dt)
        assert stepped.steps == step
        np.testing.assert_array_equal(traj.positions[r], stepped.positions)
        np.testing.assert_array_equal(traj.velocities[r], stepped.velocities)


@numba.njit
def _poison(S):
    S.x[4, 2] = np.nan


def _poison_loop_at(step: int, monkeypatch) -> None:
    """Make the compiled loop put a NaN into a free particle before the ``step``-th step (counting from 1) it is
    asked for from now on."""
    real = kernels.run_steps
    taken = {"n": 0}

    def poisoned(S, n_steps, *args):
        left = step - 1 - taken["n"]
        if left > 0:
            n_steps = min(n_steps, left)
        else:
            _poison(S)
        out = real(S, n_steps, *args)
        taken["n"] += out[0]
        return out

    monkeypatch.setattr(kernels, "run_steps", poisoned)


@pytest.mark.parametrize("model", PARTICLE)
def test_nan_in_the_loop_raises_at_its_step(model, monkeypatch):
    sim = mjcable.Simulator(mjcable.scenes.get("hang", n_segments=10), model)
    sim.step(0.01)  # 5 steps
    _poison_loop_at(7, monkeypatch)  # step 12 overall
    with pytest.raises(mjcable.SimulationDivergedError, match=rf"{model}.*step 12 .*t = 0.024.*non-finite") as err:
        sim.step(0.1)
    assert err.value.model == model and err.value.step == 12 and err.value.time == pytest.approx(0.024)
    assert sim.steps == 12 and np.isnan(sim.positions).any()


@pytest.mark.parametrize("model", ["xpbd", "springs"])
def test_runaway_raises_at_its_step(model):
    """A gripper yanked 1 m within one step (500 m/s) trips the speed check at that step."""
    sim = mjcable.Simulator(mjcable.scenes.get("socket", n_segments=12), model)
    sim.step(0.01)
    sim.move_gripper(1, sim.gripper_positions[0] + [1.0, 0.0, 0.0])
    with pytest.raises(mjcable.SimulationDivergedError, match=r"step 6 .*moved at .* m/s \(limit 200 m/s\)"):
        sim.step(0.02)
    assert sim.steps == 6


# --- Simulator.step_along: a gripper path in one call ---------------------------------------------------------------

_PATH_STEPS = 50


def _pull_path(sim) -> np.ndarray:
    """(50, 1, 3) m: the socket scene's gripper still for 5 steps (rows equal to where it is), then drawn away from
    the socket at 20 m/s², so that the socket lets go part way (after 7 to 24 steps, depending on the model)."""
    scene = sim.scene
    start = sim.gripper_positions[0]
    away = start - scene.cable.particles[scene.pin_particle(0)]
    t = np.maximum(np.arange(1, _PATH_STEPS + 1) - 5, 0) * sim.dt
    return start + (10.0 * t**2)[:, None, None] * (away / np.linalg.norm(away))


def _snapshot(sim) -> dict:
    d = sim.mj_data
    return dict(x=sim.positions, v=sim.velocities, f=sim.pin_forces, grippers=sim.gripper_positions,
                sites=d.site_xpos.copy(), geoms=d.geom_xpos.copy(), mocap=d.mocap_pos.copy(),
                time=np.array([d.time, sim.time, sim.steps]), released=np.array(sorted(sim.released)))


def _assert_same(a: dict, b: dict) -> None:
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=f"{key} differs")


def _reference_path(scene, model: str) -> tuple:
    """The path taken the plain way: per step, move_gripper where the row changes, then step(). Returns the path,
    the snapshot after every step, and the step after which the socket let go."""
    sim = mjcable.Simulator(scene, model)
    path = _pull_path(sim)
    states, released_at = [], None
    for i in range(len(path)):
        if not np.array_equal(path[i, 0], sim.gripper_positions[0]):
            sim.move_gripper(1, path[i, 0])
        sim.step()
        states.append(_snapshot(sim))
        if sim.released and released_at is None:
            released_at = i + 1
    return path, states, released_at


@pytest.mark.parametrize("model", [*PARTICLE, "springs", "flexrod"])
def test_step_along_equals_move_gripper_and_step_bit_for_bit(model, monkeypatch):
    scene = mjcable.scenes.get("socket", n_segments=12)
    path, states, released_at = _reference_path(scene, model)
    assert released_at is not None and 5 < released_at < _PATH_STEPS - 5  # the socket lets go part way

    loop = _counting(monkeypatch, "run_steps")
    whole = mjcable.Simulator(scene, model)
    assert whole.step_along(path) == _PATH_STEPS  # a release does not stop it unless asked
    _assert_same(_snapshot(whole), states[-1])

    watched = mjcable.Simulator(scene, model)
    taken = watched.step_along(path, pins=(1,), until_release=True)
    assert taken == released_at
    _assert_same(_snapshot(watched), states[taken - 1])
    assert watched.step_along(path[taken:], until_release=True) == _PATH_STEPS - taken  # no socket left to let go
    _assert_same(_snapshot(watched), states[-1])
    if model in PARTICLE:  # the paths ran in the loop, not one Python step each
        assert 3 <= loop["n"] <= 6


def test_step_along_takes_no_steps_for_an_empty_path_and_leaves_the_remainder_alone():
    sim = mjcable.Simulator(mjcable.scenes.get("socket", n_segments=12), "xpbd")
    sim.step(0.003)  # one step, 1 ms carried over
    assert sim.step_along(np.zeros((0, 1, 3))) == 0 and sim.steps == 1
    sim.step_along(_pull_path(sim)[:2])
    sim.step(0.001)  # the carried millisecond makes the fourth step
    assert sim.steps == 4


@pytest.mark.parametrize("pins, message", [
    ((0,), r"pins must be distinct gripper pins, from \(1,\), got \(0,\)"),
    ((1, 1), r"pins must be distinct gripper pins, from \(1,\), got \(1, 1\)"),
    ((True,), r"pins must be distinct gripper pins, from \(1,\), got \(True,\)"),
    (7, r"pins must be distinct gripper pins, from \(1,\), got 7"),
])
def test_step_along_rejects_pins_that_are_not_distinct_grippers(pins, message):
    sim = mjcable.Simulator(mjcable.scenes.get("socket", n_segments=12), "xpbd")
    with pytest.raises(ValueError, match=message):
        sim.step_along(np.zeros((2, 1, 3)), pins=pins)
    assert sim.steps == 0


@pytest.mark.parametrize("path, message", [
    (np.zeros((2, 3)), r"path must be an array of shape \(steps, 1, 3\) in metres"),
    (np.zeros((2, 2, 3)), r"path must be an array of shape \(steps, 1, 3\)"),
    ("far", r"path must be an array of shape \(steps, 1, 3\).*got 'far'"),
    (np.full((2, 1, 3), np.nan), r"path must be finite, got array\(\[\[\[nan"),
])
def test_step_along_rejects_a_path_of_the_wrong_shape_or_not_finite(path, message):
    sim = mjcable.Simulator(mjcable.scenes.get("socket", n_segments=12), "xpbd")
    with pytest.raises(ValueError, match=message):
        sim.step_along(path)
    assert sim.steps == 0


@pytest.mark.envs
def test_an_environment_control_step_runs_in_the_compiled_loop(monkeypatch):
    """unplug on xpbd: a moving control step is one call of the compiled loop (contact queries inside it), and one
    more after a socket lets go (the environment recomputes the rest of the path without its tether)."""
    from mjcable import envs

    env = envs.load("unplug", "xpbd", random=0)
    env.reset()
    nstep = round(env.control_timestep() / env.physics.timestep())
    action = np.full(env.action_spec().shape, 0.5 * env.action_spec().maximum)
    loop = _counting(monkeypatch, "run_steps")
    before = env.physics.gripper_positions()
    env.step(action)
    assert not np.array_equal(env.physics.gripper_positions(), before)  # the gripper moved
    assert env.physics.simulator.steps == nstep
    assert loop["n"] == 1 + len(env.physics.simulator.released)


# --- Ctrl-C ----------------------------------------------------------------------------------------------------------

INTERRUPT_AFTER = 0.3  # s of wall time into a long step(T)
STOP_WITHIN = 0.5  # s: how soon after Ctrl-C the run must stop


@pytest.mark.parametrize("model", [pytest.param(m, marks=() if m in ("xpbd", "flexrod") else pytest.mark.slow)
                                   for m in catalog.names()])  # the others with the slow tests
def test_ctrl_c_stops_a_long_run_soon_at_a_whole_step(model):
    """``step(1e6)`` (half a billion steps) interrupted by Ctrl-C (SIGINT, as ``_thread.interrupt_main`` sends it)
    raises KeyboardInterrupt within half a second, and the state is that of the whole steps taken: a second
    Simulator stepped as many steps has the same positions, bit for bit."""
    import _thread
    import signal
    import threading
    import time

    scene = mjcable.scenes.get("socket", n_segments=12)
    sim = mjcable.Simulator(scene, model)
    sim.step(0.01)  # compiled and warm
    sent = {}

    def interrupt():
        sent["t"] = time.perf_counter()
        _thread.interrupt_main(signal.SIGINT)

    # (a process started in the background by a shell without job control ignores SIGINT, and then
    # interrupt_main does nothing: Python's own handler for the test's length)
    handler = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(INTERRUPT_AFTER, interrupt)
    try:
        timer.start()
        with pytest.raises(KeyboardInterrupt):
            sim.step(1e6)
        stopped = time.perf_counter()
        timer.join()
    finally:
        signal.signal(signal.SIGINT, handler)
    assert stopped - sent["t"] < STOP_WITHIN
    assert 5 < sim.steps < 1e8
    again = mjcable.Simulator(scene, model)
    again.step(sim.steps * sim.dt)
    assert again.steps == sim.steps
    np.testing.assert_array_equal(again.positions, sim.positions)
    sim.step(0.01)  # and it goes on
    assert np.all(np.isfinite(sim.positions))
