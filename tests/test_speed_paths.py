"""The particle solvers' two stepping paths give the same simulation bit for bit: ``Simulator.step(T)`` running its
steps in one compiled loop (:meth:`ParticleBackend.run`, :func:`mjcable.solvers.kernels.run_steps_flat`) and the
per-step Python path it replaces (``ParticleBackend.compiled_steps = False``: one backend ``step`` and one numpy
divergence check per ``dt``). Divergence found inside the loop names the same step, time and reason."""

import inspect

import numpy as np
import pytest

import mjcable
from mjcable import catalog
from mjcable.backends.particle import ParticleBackend
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


def _run(scene, model: str, compiled: bool, monkeypatch) -> tuple:
    """The state after a gripper move (for scenes with a gripper) and ``SECONDS`` of steps in one call, and the
    number of per-step kernel calls and of loop calls it took."""
    monkeypatch.setattr(ParticleBackend, "compiled_steps", compiled)
    per_step = _counting(monkeypatch, "run_substeps_flat")
    loop = _counting(monkeypatch, "run_steps_flat")
    sim = mjcable.Simulator(scene, model)
    for pin in scene.grippers:
        sim.move_gripper(pin, sim.gripper_positions[0] + [0.03, 0.0, 0.02])  # spread over the next step
    sim.step(SECONDS)
    d = sim.mj_data
    state = dict(x=sim.positions, v=sim.velocities, f=sim.pin_forces, torque=sim.pin_torques,
                 sites=d.site_xpos.copy(), geoms=d.geom_xpos.copy(), quat=d.mocap_quat.copy(),
                 time=np.array([d.time, sim.time]), released=np.array(sorted(sim.released)),
                 counts=np.array([sim.diagnostics[k] for k in ("contacts", "self_contacts", "queries")]))
    monkeypatch.undo()
    return state, per_step["n"], loop["n"], sim.steps


@pytest.mark.parametrize("model", PARTICLE)
@pytest.mark.parametrize("scene_name", ["hang", "socket"])
def test_compiled_steps_equal_the_per_step_path_bit_for_bit(scene_name, model, monkeypatch):
    scene = mjcable.scenes.get(scene_name, n_segments=12, damping=1.0)
    fast, fast_per_step, fast_loops, steps = _run(scene, model, True, monkeypatch)
    slow, slow_per_step, slow_loops, slow_steps = _run(scene, model, False, monkeypatch)
    assert steps == slow_steps == 50
    # the two paths really differ: one Python step per dt against the loop
    assert slow_per_step == 50 and slow_loops == 0
    assert fast_per_step == 0 and 1 <= fast_loops <= 50
    if scene_name == "hang":  # nothing to query: the whole call is one loop
        assert fast_loops == 1
    for key in slow:
        np.testing.assert_array_equal(fast[key], slow[key], err_msg=f"{key} differs between the two paths")
    assert np.all(np.isfinite(fast["f"])) and np.abs(fast["f"]).max() > 0.0  # the pins hold the cable


@pytest.mark.parametrize("self_collision", [False, True])
def test_rollout_in_the_loop_records_the_per_step_states(self_collision, monkeypatch):
    """The drape falls freely (in the loop), then lands (queried steps); with self-collision every step is queried."""
    scene = mjcable.scenes.get("drape", n_segments=12)
    rolls = []
    for compiled in (True, False):
        monkeypatch.setattr(ParticleBackend, "compiled_steps", compiled)
        sim = mjcable.Simulator(scene, "xpbd", self_collision=self_collision)
        rolls.append(sim.rollout(0.3, every=7))
        assert sim.diagnostics["queries"] > 0
    for a, b in zip(rolls[0].__dict__.values(), rolls[1].__dict__.values()):
        np.testing.assert_array_equal(a, b)


def _poison_loop_at(step: int, monkeypatch) -> None:
    """Make the compiled loop put a NaN into a free particle before the ``step``-th step (counting from 1) it is
    asked for from now on."""
    real = kernels.run_steps_flat
    n_steps = list(inspect.signature(real.py_func).parameters).index("n_steps")
    taken = {"n": 0}

    def poisoned(*args):
        args = list(args)
        left = step - 1 - taken["n"]
        if left > 0:
            args[n_steps] = min(args[n_steps], left)
        else:
            args[0][4, 2] = np.nan  # args[0]: the positions x
        out = real(*args)
        taken["n"] += out[0]
        return out

    monkeypatch.setattr(kernels, "run_steps_flat", poisoned)


@pytest.mark.parametrize("model", PARTICLE)
def test_nan_in_the_loop_raises_at_its_step(model, monkeypatch):
    sim = mjcable.Simulator(mjcable.scenes.get("hang", n_segments=10), model)
    sim.step(0.01)  # 5 steps
    _poison_loop_at(7, monkeypatch)  # step 12 overall
    with pytest.raises(mjcable.SimulationDivergedError, match=rf"{model}.*step 12 .*t = 0.024.*non-finite") as err:
        sim.step(0.1)
    assert err.value.model == model and err.value.step == 12 and err.value.time == pytest.approx(0.024)
    assert sim.steps == 12 and np.isnan(sim.positions).any()


def test_runaway_in_the_loop_raises_as_the_per_step_path_does(monkeypatch):
    """A gripper yanked 1 m within one step (500 m/s) trips the speed check at that step on both paths, with the
    same message."""
    scene = mjcable.scenes.get("socket", n_segments=12)
    errors = []
    for compiled in (True, False):
        monkeypatch.setattr(ParticleBackend, "compiled_steps", compiled)
        sim = mjcable.Simulator(scene, "xpbd")
        sim.step(0.01)
        sim.move_gripper(1, sim.gripper_positions[0] + [1.0, 0.0, 0.0])
        with pytest.raises(mjcable.SimulationDivergedError, match=r"step 6 .*moved at") as err:
            sim.step(0.02)
        errors.append(str(err.value))
        assert sim.steps == 6
    assert errors[0] == errors[1]
