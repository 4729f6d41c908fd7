"""The user world's host substeps in one compiled call through MuJoCo's C API
(:func:`mjcable.solvers.host_kernels.host_substeps`) against the Python loop of :meth:`mjcable.backends.host.Host
.substeps` (``Host.compiled = False``): the same simulation bit for bit (the cable's positions, velocities and pin
forces, the world's ``qpos``, ``qvel`` and body poses) for a clamped body pin on a free box, a cable lying on a box
that feels its contacts (two-way), and the ``jaco_unplug`` environment; and a divergence of the world (MuJoCo's
``BADQVEL`` warning) still ends the step with :class:`mjcable.SimulationDivergedError` naming the warning.

Each comparison also counts the compiled calls, so that it cannot pass by running the Python loop twice.
"""

import math
import warnings

import mujoco
import numpy as np
import pytest

import mjcable
from mjcable import CableSpec, Pin, Scene, Simulator
from mjcable.backends.host import Host
from mjcable.solvers import capi, host_kernels

pytestmark = pytest.mark.skipif(capi.host_functions() is None, reason=f"no C API: {capi.host_unavailable()}")


@pytest.fixture
def compiled_calls(monkeypatch):
    """Counts :func:`host_kernels.host_substeps` calls; returns the dict holding the count."""
    calls = {"n": 0}
    real = host_kernels.host_substeps

    def counted(*args):
        calls["n"] += 1
        return real(*args)

    monkeypatch.setattr(host_kernels, "host_substeps", counted)
    return calls


def _state(sim: Simulator) -> dict:
    d = sim.mj_data
    return dict(x=sim.positions, v=sim.velocities, f=sim.pin_forces, qpos=d.qpos.copy(), qvel=d.qvel.copy(),
                xpos=d.xpos.copy(), xquat=d.xquat.copy(), time=np.array([d.time, sim.time]))


def _both(make, run, monkeypatch, calls) -> tuple:
    """The states after ``run(sim)`` on ``make()`` with the Python loop and with the compiled substeps."""
    out = []
    for compiled in (False, True):
        monkeypatch.setattr(Host, "compiled", compiled)
        calls["n"] = 0
        sim = make()
        run(sim)
        out.append((_state(sim), calls["n"]))
    (python, n_python), (compiled, n_compiled) = out
    assert n_python == 0
    assert n_compiled > 0
    return python, compiled


def _assert_same(python: dict, compiled: dict) -> None:
    for key in python:
        np.testing.assert_array_equal(compiled[key], python[key], err_msg=key)


def _sim(scene: Scene, **kw) -> Simulator:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # stability warnings of capped stiffness
        return Simulator(scene, "xpbd", dt=0.002, **kw)


# --- a clamped body pin on a free box swinging on the cable ---------------------------------------------------------

PIVOT, LENGTH, SWING = np.array([0.0, 0.0, 1.0]), 0.4, math.radians(25.0)


def _pendulum() -> Simulator:
    end = PIVOT + LENGTH * np.array([math.sin(SWING), 0.0, -math.cos(SWING)])
    box = end - [0.01, 0.0, 0.0]  # the pin's point off the box's centre, so that the cable also turns it
    xml = f"""<mujoco><worldbody><body name="box" pos="{box[0]} {box[1]} {box[2]}"><freejoint/>
      <geom name="box" type="box" size="0.02 0.03 0.04" mass="0.1"/></body></worldbody></mujoco>"""
    cable = CableSpec([PIVOT, end], 16, 0.003, 0.02)
    scene = Scene(cable, (Pin(0), Pin(-1, "body", body="box", offset=(0.01, 0.0, 0.0), clamp=True)),
                  world=mujoco.MjSpec.from_string(xml))
    return _sim(scene)


def test_a_clamped_body_pin_on_a_free_box_is_the_same_compiled(monkeypatch, compiled_calls):
    python, compiled = _both(_pendulum, lambda sim: sim.step(0.3), monkeypatch, compiled_calls)
    _assert_same(python, compiled)
    # it did swing, and the box pulled the cable: a comparison of a state at rest would prove little
    assert np.linalg.norm(python["qvel"][:3]) > 0.1
    assert np.linalg.norm(python["f"][1]) > 0.5


# --- a cable lying on a box on a table: the box feels its contacts ---------------------------------------------------

HALF, RADIUS = 0.1, 0.005
TABLE_XML = f"""<mujoco><worldbody>
  <geom name="table" type="box" size="0.5 0.5 0.05" pos="0 0 -0.05"/>
  <body name="box" pos="0 0 {HALF}"><freejoint/>
    <geom name="box" type="box" size="{HALF} {HALF} {HALF}" mass="0.05"/></body>
  </worldbody></mujoco>"""


def _cable_on_box() -> Simulator:
    z = 2 * HALF + RADIUS + 0.01  # dropped from 1 cm onto a box lighter than itself
    cable = CableSpec([[-0.06, 0, z], [0.06, 0, z]], 12, RADIUS, 0.1, friction=0.3)
    return _sim(Scene(cable, (), world=mujoco.MjSpec.from_string(TABLE_XML)))


def test_two_way_contacts_are_the_same_compiled(monkeypatch, compiled_calls):
    pushed = []
    real = Host.substeps

    def substeps(host, *args, **kwargs):  # records the contact force each step put on the world's bodies
        assert host.impulse.shape[0] > 0  # the box is a dynamic obstacle: two-way contacts
        out = real(host, *args, **kwargs)
        pushed.append(float(np.abs(host.contact_wrench).max()))
        return out

    monkeypatch.setattr(Host, "substeps", substeps)

    def run(sim):
        for _ in range(150):
            sim.step()

    python, compiled = _both(_cable_on_box, run, monkeypatch, compiled_calls)
    _assert_same(python, compiled)
    # the cable landed on the box, which felt it
    assert max(pushed) > 0.1
    assert np.all(python["x"][:, 2] < 2 * HALF + RADIUS + 0.005)


# --- the jaco_unplug environment ------------------------------------------------------------------------------------


@pytest.mark.envs
def test_the_jaco_unplug_environment_is_the_same_compiled(monkeypatch, compiled_calls):
    from mjcable import envs  # dm_control

    action = None

    def make():
        env = envs.load("jaco_unplug", "xpbd", random=0)
        env.reset()
        return env

    out = []
    for compiled in (False, True):
        monkeypatch.setattr(Host, "compiled", compiled)
        compiled_calls["n"] = 0
        env = make()
        spec = env.action_spec()
        if action is None:  # a fixed action halfway between the middle and the top of every bound
            action = np.broadcast_to(0.5 * (spec.minimum + spec.maximum) + 0.25 * (spec.maximum - spec.minimum),
                                     spec.shape).copy()
        for _ in range(10):
            env.step(action)
        sim = env.physics.simulator
        out.append((_state(sim), compiled_calls["n"]))
    (python, n_python), (compiled, n_compiled) = out
    assert n_python == 0 and n_compiled > 0
    _assert_same(python, compiled)
    assert np.linalg.norm(python["qvel"]) > 1e-3  # the arm moved


# --- divergence -----------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("compiled", [False, True])
def test_a_diverging_world_raises_naming_mujocos_warning(monkeypatch, compiled_calls, compiled):
    monkeypatch.setattr(Host, "compiled", compiled)
    sim = _pendulum()
    sim.step()  # the first step after the reset is the Python loop's; the next one is compiled where it can be
    compiled_calls["n"] = 0
    sim.mj_data.qvel[0] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(mjcable.SimulationDivergedError, match="mjWARN_BADQVEL"):
            sim.step()
    assert compiled_calls["n"] == int(compiled)
    assert sim.mj_data.warning.number[mujoco.mjtWarning.mjWARN_BADQVEL] == 0  # counted once, then cleared


# --- the arithmetic both paths share, against numpy -----------------------------------------------------------------


def test_the_shared_arithmetic_is_numpys_to_rounding():
    """The pin axis's Jacobian row nᵀ J, the dot product and the clamp's turn (the kernels both host paths call)
    against numpy's norm, matmul and dot."""
    rng = np.random.default_rng(3)
    x = rng.normal(size=(5, 3))
    jacp = rng.normal(size=(3, 7))
    jn = np.zeros(7)
    host_kernels.pin_axis_jacobian(x, 1, 3, jacp, jn)
    axis = (x[3] - x[1]) / np.linalg.norm(x[3] - x[1])
    np.testing.assert_allclose(jn, axis @ jacp, rtol=1e-14, atol=1e-15)
    same = np.zeros(7)
    host_kernels.pin_axis_jacobian(np.zeros((2, 3)), 0, 1, jacp, same)  # coincident particles: no axis, no NaN
    np.testing.assert_array_equal(same, 0.0)
    a, b = rng.normal(size=40), rng.normal(size=40)
    assert host_kernels.dot(a, b) == pytest.approx(float(a @ b), rel=1e-13, abs=1e-14)
    quat = rng.normal(size=4)
    quat /= np.linalg.norm(quat)
    xmat = np.zeros((2, 9))
    mujoco.mju_quat2Mat(xmat[1], quat)
    local = rng.normal(size=(3, 2))
    clamp_dir = np.zeros((3, 2, 3))
    host_kernels.turn_clamp(xmat, 1, local, clamp_dir, 2)
    np.testing.assert_allclose(clamp_dir[2], (xmat[1].reshape(3, 3) @ local).T, rtol=1e-14, atol=1e-15)
    np.testing.assert_array_equal(clamp_dir[:2], 0.0)
