import logging
import subprocess
import sys

import mujoco
import numpy as np
import pytest

import mjcable
from mjcable import _mujoco_log


@pytest.fixture(scope="module")
def hang():
    return mjcable.scenes.get("hang", n_segments=20, damping=1.0)


def test_positions_valid_at_start_and_current_after_steps(hang):
    sim = mjcable.Simulator(hang, "springs")
    np.testing.assert_allclose(sim.positions, hang.cable.particles, atol=1e-12)
    sim.step(0.05)
    # current: equal to the particle bodies' positions recomputed from qpos now (not the lagging xpos of mj_step)
    d = mujoco.MjData(sim.mj_model)
    d.qpos[:] = sim.mj_data.qpos
    mujoco.mj_kinematics(sim.mj_model, d)
    ids = [mujoco.mj_name2id(sim.mj_model, mujoco.mjtObj.mjOBJ_SITE, f"particle{i}") for i in range(21)]
    np.testing.assert_array_equal(sim.positions, d.site_xpos[ids])
    assert not np.allclose(sim.positions, hang.cable.particles)


def test_step_accumulates_whole_steps(hang):
    sim = mjcable.Simulator(hang, "springs", dt=0.002)
    sim.step(0.005)  # 2 whole steps, 1 ms carried over
    assert sim.steps == 2 and sim.time == pytest.approx(0.004)
    sim.step(0.001)  # the carried 1 ms + 1 ms make a third step
    assert sim.steps == 3
    sim.step(1 / 30)
    sim.step(1 / 30)
    assert sim.steps == 3 + 33  # 2/30 s = 33.33 steps
    assert sim.mj_data.time == pytest.approx(sim.time)
    with pytest.raises(ValueError, match="seconds"):
        sim.step(-1.0)


def test_free_fall_of_an_unpinned_cable_follows_gravity():
    scene = mjcable.Scene(mjcable.CableSpec([[0, 0, 2], [1, 0, 2]], 10, 0.005, 0.1))
    sim = mjcable.Simulator(scene, "springs", substeps=1)
    sim.step(0.5)
    # MuJoCo's semi-implicit Euler: z(t_k) = z0 − g·h²·k(k+1)/2
    k = sim.mj_data.time / sim.mj_model.opt.timestep
    expected = 2.0 - 9.81 * sim.mj_model.opt.timestep**2 * k * (k + 1) / 2
    np.testing.assert_allclose(sim.positions[:, 2], expected, atol=1e-9)


def test_silent_mujoco_reset_becomes_an_error(hang):
    sim = mjcable.Simulator(hang, "springs")
    sim.mj_data.qpos[0] = np.nan  # MuJoCo would reset the state and carry on, warning only in data.warning
    with pytest.raises(mjcable.SimulationDivergedError, match=r"springs.*step 1 .*mjWARN_BADQ") as err:
        sim.step()
    assert err.value.model == "springs" and err.value.step == 1


def test_unstable_springs_raise_instead_of_running_on(hang):
    sim = mjcable.Simulator(hang, "springs", substeps=1)
    sim.mj_model.tendon_stiffness[:] *= 400.0  # 20x above the explicit stability limit ω h < 2
    with pytest.raises(mjcable.SimulationDivergedError, match="springs") as err:
        sim.step(2.0)
    assert 0.0 < err.value.time < 2.0


@pytest.fixture
def mjcable_warning_handler():
    """mjcable's handler of MuJoCo's warnings, as ``import mjcable`` installs it (dm_control, once imported, puts
    its own in its place; both keep MuJoCo's warnings in Python)."""
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(None)
    _mujoco_log.route_warnings()
    assert mujoco.get_mju_user_warning() is not None
    yield
    mujoco.set_mju_user_warning(previous)


def test_mujocos_warnings_go_to_the_logger_not_to_a_file_in_the_working_folder(hang, tmp_path, monkeypatch, caplog,
                                                                               mjcable_warning_handler):
    monkeypatch.chdir(tmp_path)
    sim = mjcable.Simulator(hang, "springs", substeps=20)
    sim.mj_model.tendon_stiffness[:] *= 1e4  # ω h far beyond the explicit limit 2: MuJoCo's own check trips
    with caplog.at_level(logging.WARNING, logger="mjcable"):
        with pytest.raises(mjcable.SimulationDivergedError, match="mjWARN_BADQACC"):  # its counters still read
            sim.step(0.5)
    assert [r.getMessage() for r in caplog.records if r.name == "mjcable" and "QACC" in r.getMessage()]
    assert list(tmp_path.iterdir()) == []  # no MUJOCO_LOG.TXT
    mine = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(print)
    _mujoco_log.route_warnings()  # a handler of the user's stays
    assert mujoco.get_mju_user_warning() is print
    mujoco.set_mju_user_warning(mine)


def test_import_installs_the_warning_handler():
    code = "import mjcable, mujoco; print(mujoco.get_mju_user_warning() is mjcable._mujoco_log._to_logger)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "True"


def test_move_gripper_validates():
    scene = mjcable.scenes.get("socket", n_segments=10)
    sim = mjcable.Simulator(scene, "springs")
    with pytest.raises(ValueError, match="pin_number"):
        sim.move_gripper(0, [0, 0, 1])  # pin 0 is the socket
    with pytest.raises(ValueError, match="position"):
        sim.move_gripper(1, [0, 0])
    target = scene.cable.particles[-1] + [0.01, 0, 0]
    sim.move_gripper(1, target)
    sim.step(0.01)
    np.testing.assert_allclose(sim.positions[-1], target, atol=1e-9)
