"""The user world's host in the particle solvers' compiled step loop (:mod:`mjcable.solvers.host_kernels`, MuJoCo
called through its C API): a clamped body pin on a free box swings and pulls, with the same results however its
steps are split into calls; a divergence of the world (MuJoCo's ``BADQVEL`` warning) ends the step with
:class:`mjcable.SimulationDivergedError` naming the warning; the arithmetic the host kernels share is numpy's to
rounding."""

import math
import warnings

import mujoco
import numpy as np
import pytest

import mjcable
from mjcable import CableSpec, Pin, Scene, Simulator
from mjcable.solvers import capi, host_kernels

pytestmark = pytest.mark.skipif(capi.host_functions() is None, reason=f"no C API: {capi.host_unavailable()}")


def _state(sim: Simulator) -> dict:
    d = sim.mj_data
    return dict(x=sim.positions, v=sim.velocities, f=sim.pin_forces, qpos=d.qpos.copy(), qvel=d.qvel.copy(),
                xpos=d.xpos.copy(), xquat=d.xquat.copy(), time=np.array([d.time, sim.time]))


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


def test_a_clamped_body_pin_on_a_free_box_swings_the_same_in_any_split():
    whole = _pendulum()
    whole.step(0.3)
    stepped = _pendulum()
    for _ in range(150):
        stepped.step()
    a, b = _state(whole), _state(stepped)
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    # it did swing, and the box pulled the cable: a comparison of a state at rest would prove little
    assert np.linalg.norm(a["qvel"][:3]) > 0.1
    assert np.linalg.norm(a["f"][1]) > 0.5


# --- divergence -----------------------------------------------------------------------------------------------------


def test_a_diverging_world_raises_naming_mujocos_warning():
    sim = _pendulum()
    sim.step()
    sim.mj_data.qvel[0] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(mjcable.SimulationDivergedError, match="mjWARN_BADQVEL"):
            sim.step()
    assert sim.steps == 2
    assert sim.mj_data.warning.number[mujoco.mjtWarning.mjWARN_BADQVEL] == 0  # counted once, then cleared


# --- the arithmetic both paths share, against numpy -----------------------------------------------------------------


def test_the_shared_arithmetic_is_numpys_to_rounding():
    """The pin axis's Jacobian row nᵀ J, the dot product and the clamp's turn (the host kernels' own reductions)
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
