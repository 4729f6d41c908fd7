"""The Jaco lab world (mjcable.worlds.jaco): names, actuators, the home pose, its hold under gravity, the camera."""

import mujoco
import numpy as np
import pytest

from mjcable.worlds import jaco

pytestmark = pytest.mark.envs  # the arm and hand are dm_control's Kinova models


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return jaco.jaco_lab_spec().compile()


def _home(model: mujoco.MjModel) -> mujoco.MjData:
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key(jaco.HOME_KEY).id)
    mujoco.mj_forward(model, data)
    return data


def _qadr(model, names):
    return np.array([model.joint(n).qposadr[0] for n in names])


def test_compiles_with_documented_names_and_options(model):
    assert model.njnt == model.nq == model.nv == len(jaco.ARM_JOINTS) + len(jaco.FINGER_JOINTS) == 9
    assert [model.joint(i).name for i in range(model.njnt)] == list(jaco.ARM_JOINTS + jaco.FINGER_JOINTS)
    assert [model.actuator(i).name for i in range(model.nu)] == list(jaco.ARM_ACTUATORS + jaco.FINGER_ACTUATORS)
    for k, name in enumerate(jaco.ARM_ACTUATORS):  # each actuator drives the joint of its name
        assert model.actuator_trnid[model.actuator(name).id, 0] == model.joint(jaco.ARM_JOINTS[k]).id
    for body in (jaco.GRIP_BODY, jaco.SOCKET_BODY):
        model.body(body)
    for site in (jaco.GRIP_SITE, jaco.SOCKET_SITE, jaco.TARGET_SITE):
        model.site(site)
    model.camera(jaco.CAMERA)
    assert model.site_bodyid[model.site(jaco.GRIP_SITE).id] == model.body(jaco.GRIP_BODY).id
    assert model.site_bodyid[model.site(jaco.SOCKET_SITE).id] == model.body(jaco.SOCKET_BODY).id
    assert model.body_weldid[model.body(jaco.SOCKET_BODY).id] == 0  # fixed to the world (the wall)
    assert model.opt.timestep == jaco.TIMESTEP == 0.002
    np.testing.assert_array_equal(model.opt.gravity, [0.0, 0.0, -9.81])
    assert model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_NATIVECCD  # the arm's own option survives
    target = model.site(jaco.TARGET_SITE).id
    assert model.site_group[target] in (0, 1, 2) and 0 < model.site_rgba[target, 3] < 1  # renders, translucent


def test_position_servos_replace_dm_control_velocity_servos(model):
    for k, name in enumerate(jaco.ARM_ACTUATORS):
        i = model.actuator(name).id
        kp = jaco.KP_LARGE if k < 3 else jaco.KP_SMALL
        assert model.actuator_gaintype[i] == mujoco.mjtGain.mjGAIN_FIXED
        assert model.actuator_biastype[i] == mujoco.mjtBias.mjBIAS_AFFINE
        assert model.actuator_gainprm[i, 0] == kp and model.actuator_biasprm[i, 1] == -kp
        assert model.actuator_biasprm[i, 2] < 0  # damped
        torque = 30.5 if k < 3 else 6.8  # dm_control's peak torques, kept
        np.testing.assert_array_equal(model.actuator_forcerange[i], [-torque, torque])
        joint = model.joint(jaco.ARM_JOINTS[k]).id
        assert model.actuator_ctrllimited[i] == model.jnt_limited[joint]
        if model.jnt_limited[joint]:
            np.testing.assert_array_equal(model.actuator_ctrlrange[i], model.jnt_range[joint])


def test_velocity_mode_keeps_dm_control_servos():
    model = jaco.jaco_lab_spec("velocity").compile()
    assert [model.actuator(i).name for i in range(model.nu)] == list(jaco.ARM_ACTUATORS + jaco.FINGER_ACTUATORS)
    for name in jaco.ARM_ACTUATORS + jaco.FINGER_ACTUATORS:  # force = kv (ctrl − qvel)
        i = model.actuator(name).id
        kv = model.actuator_gainprm[i, 0]
        assert kv > 0 and model.actuator_biasprm[i, 1] == 0 and model.actuator_biasprm[i, 2] == -kv
    np.testing.assert_array_equal(_home(model).ctrl, 0.0)
    with pytest.raises(ValueError):
        jaco.jaco_lab_spec("torque")


def test_home_pose_places_grip_25_to_40_cm_from_the_socket(model):
    data = _home(model)
    np.testing.assert_array_equal(data.qpos[_qadr(model, jaco.ARM_JOINTS)], jaco.home_qpos())
    np.testing.assert_array_equal(data.qpos[_qadr(model, jaco.FINGER_JOINTS)], jaco.home_finger_qpos())
    np.testing.assert_array_equal(data.ctrl[: len(jaco.ARM_JOINTS)], jaco.home_qpos())
    for j in range(model.njnt):
        if model.jnt_limited[j]:
            assert model.jnt_range[j, 0] <= data.qpos[model.jnt_qposadr[j]] <= model.jnt_range[j, 1]
    assert data.ncon == 0  # touching nothing, itself included
    grip, socket = jaco.grip_and_socket(model)
    np.testing.assert_array_equal(grip, data.site(jaco.GRIP_SITE).xpos)
    np.testing.assert_array_equal(socket, data.site(jaco.SOCKET_SITE).xpos)
    assert 0.25 <= np.linalg.norm(grip - socket) <= 0.40
    assert grip[2] > jaco.TABLE_TOP_Z + 0.25  # room below for a hanging cable
    # The grip is in front of the wall, and the socket site's z axis points out of the wall, towards the arm.
    assert grip[0] < socket[0]
    out = data.site(jaco.SOCKET_SITE).xmat.reshape(3, 3)[:, 2]
    np.testing.assert_allclose(out, [-1.0, 0.0, 0.0], atol=1e-12)


def test_socket_plug_is_on_the_faceplate_and_the_faceplate_on_the_wall(model):
    data = _home(model)
    plate, wall = model.geom("socket_plate").id, model.geom("wall").id
    front = data.geom_xpos[plate, 0] - model.geom_size[plate, 0]
    back = data.geom_xpos[plate, 0] + model.geom_size[plate, 0]
    assert data.site(jaco.SOCKET_SITE).xpos[0] == pytest.approx(front, abs=1e-12)
    assert back == pytest.approx(data.geom_xpos[wall, 0] - model.geom_size[wall, 0], abs=1e-12)
    assert back == pytest.approx(jaco.WALL_X, abs=1e-12)


def test_grip_site_lies_between_the_closed_fingers(model):
    data = mujoco.MjData(model)
    fingers = _qadr(model, jaco.FINGER_JOINTS)
    data.qpos[fingers] = model.jnt_range[[model.joint(n).id for n in jaco.FINGER_JOINTS], 1]  # fully closed
    mujoco.mj_kinematics(model, data)
    grip = data.site(jaco.GRIP_SITE).xpos
    tips = np.array([data.geom(f"{jaco.HAND_PREFIX}finger_tip_{k}").xpos for k in (1, 2, 3)])
    assert np.all(np.linalg.norm(tips - grip, axis=1) < 0.03)  # within 3 cm of each distal phalanx
    # Inside the triangle of the three phalanges: positive barycentric weights, within 5 mm of its plane.
    weights = np.linalg.lstsq(np.vstack([tips.T, np.ones(3)]), np.append(grip, 1.0), rcond=None)[0]
    assert np.all(weights > 0)
    assert np.linalg.norm(weights @ tips - grip) < 0.005


def test_target_and_socket_within_reach(model):
    """Both lie closer to the shoulder (joint 2) than the summed link offsets from there to the grip site."""
    data = _home(model)
    chain = [f"{jaco.ARM_PREFIX}b_{k}" for k in (3, 4, 5, 6)]
    reach = sum(np.linalg.norm(model.body(b).pos) for b in chain) + np.linalg.norm(jaco.GRIP_OFFSET)
    shoulder = data.xpos[model.body(f"{jaco.ARM_PREFIX}b_2").id]
    for site in (jaco.TARGET_SITE, jaco.SOCKET_SITE):
        assert np.linalg.norm(data.site(site).xpos - shoulder) < reach
    assert data.site(jaco.TARGET_SITE).xpos[2] > jaco.TABLE_TOP_Z + jaco.TARGET_RADIUS  # above the bench


@pytest.mark.parametrize("integrator", ["euler", "implicitfast"])
def test_home_holds_under_gravity(integrator):
    """With ctrl at the home targets the grip moves < 1 cm in 2 s; with actuation off the arm sags by more."""
    spec = jaco.jaco_lab_spec()
    spec.option.integrator = {"euler": mujoco.mjtIntegrator.mjINT_EULER,
                              "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST}[integrator]
    model = spec.compile()
    moved = {}
    for actuated in (True, False):
        model.opt.disableflags = 0 if actuated else mujoco.mjtDisableBit.mjDSBL_ACTUATION
        model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_NATIVECCD
        data = _home(model)
        start = data.site(jaco.GRIP_SITE).xpos.copy()
        steps = round(2.0 / model.opt.timestep)
        path = np.empty((steps, 3))
        for k in range(steps):
            mujoco.mj_step(model, data)
            path[k] = data.site(jaco.GRIP_SITE).xpos
        assert np.all(np.isfinite(path))
        moved[actuated] = np.linalg.norm(path - start, axis=1).max()
    assert moved[True] < 0.01
    assert moved[False] > 0.01  # the servos, not joint friction, hold the arm


def test_specs_are_fresh_and_independent():
    first = jaco.jaco_lab_spec()
    reference = jaco.jaco_lab_spec().compile()
    first.option.gravity = [0.0, 0.0, 0.0]
    first.delete(first.body(jaco.SOCKET_BODY))
    first.worldbody.add_body(name="extra").add_geom(size=[0.01, 0, 0])
    first.assets.clear()
    second = jaco.jaco_lab_spec().compile()
    assert second.nbody == reference.nbody and second.ngeom == reference.ngeom and second.nmesh == reference.nmesh
    np.testing.assert_array_equal(second.opt.gravity, [0.0, 0.0, -9.81])
    second.body(jaco.SOCKET_BODY)
    with pytest.raises(KeyError):
        second.body("extra")


def test_home_key_survives_bodies_added_after_the_arm():
    """A cable builder appends joints: MuJoCo pads the home keyframe with their qpos0, the arm's pose is kept."""
    spec = jaco.jaco_lab_spec()
    grip, socket = jaco.grip_and_socket(spec)
    cable = spec.worldbody.add_body(name="cable_0", pos=list((grip + socket) / 2))
    cable.add_freejoint()
    cable.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, size=[0.005, 0.02, 0])
    model = spec.compile()
    data = _home(model)
    np.testing.assert_array_equal(data.qpos[_qadr(model, jaco.ARM_JOINTS)], jaco.home_qpos())
    np.testing.assert_allclose(data.qpos[-7:-4], (grip + socket) / 2)
    np.testing.assert_allclose(jaco.grip_and_socket(model)[0], grip)


def _renderer(model, height, width):
    try:
        return mujoco.Renderer(model, height, width)
    except Exception as exc:  # no EGL/OSMesa/GLFW context on this machine
        pytest.skip(f"no OpenGL context for offscreen rendering: {type(exc).__name__}: {exc}")


def test_overview_camera_sees_arm_and_socket(model):
    data = _home(model)
    with _renderer(model, 240, 320) as renderer:
        renderer.enable_segmentation_rendering()
        renderer.update_scene(data, camera=jaco.CAMERA)
        seg = renderer.render()
    assert seg.shape == (240, 320, 2)
    geoms = seg[..., 0][seg[..., 1] == mujoco.mjtObj.mjOBJ_GEOM]
    seen = {model.body(model.geom_bodyid[g]).name for g in np.unique(geoms)}
    assert jaco.SOCKET_BODY in seen
    assert jaco.GRIP_BODY in seen
    assert {f"{jaco.ARM_PREFIX}b_{k}" for k in range(1, 7)} & seen  # links of the arm
    sites = seg[..., 0][seg[..., 1] == mujoco.mjtObj.mjOBJ_SITE]
    assert model.site(jaco.TARGET_SITE).id in sites
