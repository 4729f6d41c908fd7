"""``composite`` built with the MjSpec API (:func:`mjcable.mjcf.composite.add_cable`) against the XML builder it
replaces, and added into a spec that already holds a user's world.

The reference is the former builder, kept here verbatim: MuJoCo's own ``<composite type="cable">`` parsed from an
XML fragment (``world.new_spec(..., base_xml=...)``; should ``base_xml`` go, parse the fragment with
``mujoco.MjSpec.from_string`` and give it the world the same way), then edited. The new builder must compile to the same model (sizes, names, masses, inertias, armature,
damping, plugin configuration) and simulate the same positions.
"""

import dataclasses

import mujoco
import numpy as np
import pytest

import mjcable
from mjcable import catalog
from mjcable.backends.native import spec_builder
from mjcable.bench import scenarios
from mjcable.mjcf import composite, data, joints, snap, world
from mjcable.scene import CableSpec, Pin, Scene

pytestmark = pytest.mark.composite  # the cable plugin: MuJoCo 3.x only

SCENES = ["hang", "table", "drape", "socket"]
POSITION_TOL = 1e-9  # m: old and new builder after 0.5 s (the same model: only round-off may differ)
MODEL_TOL = 1e-12  # relative: compiled arrays of the two builders
SECONDS = 0.5
GRIPPER_LIFT = 0.05  # m

# -- the former XML-based builder (reference) ------------------------------------------------------------------------

_XML = """<mujoco>
  {extension}
  <worldbody>
    <composite prefix="{prefix}" type="cable" initial="none" vertex="{vertex}">
      {plugin}
      <geom type="capsule" size="{radius!r}" mass="{mass!r}"/>
    </composite>
  </worldbody>
</mujoco>
"""
_PLUGIN_XML = ('<plugin plugin="{name}"><config key="bend" value="{bend!r}"/><config key="twist" value="{twist!r}"/>'
               '<config key="flat" value="true"/></plugin>')


def _old_base_xml(scene):
    cable = scene.cable
    bend, twist = composite.plugin_moduli(scene)
    stiff = bend > 0.0
    return _XML.format(
        extension=f'<extension><plugin plugin="{composite.PLUGIN}"/></extension>' if stiff else "",
        prefix=composite.PREFIX,
        vertex=" ".join(repr(float(x)) for x in cable.particles[joints.tree_order(scene)].ravel()),
        plugin=_PLUGIN_XML.format(name=composite.PLUGIN, bend=bend, twist=twist) if stiff else "",
        radius=cable.radius, mass=cable.mass / cable.n_segments,
    )


def _old_build(scene, *, timestep, self_collision=False):
    body_name, prefix = composite.body_name, composite.PREFIX
    cable = scene.cable
    n = cable.n_segments
    l0 = cable.segment_length
    kind, tree_pin = joints.root_joint(scene)
    order = joints.tree_order(scene)
    p = cable.particles[order]
    spec = world.new_spec(scene, timestep=timestep, base_xml=_old_base_xml(scene))
    spec.option.viscosity = joints.segment_viscosity(scene)
    spec.option.integrator = joints.integrator(scene, timestep)
    spec.option.jacobian = joints.jacobian(scene)
    for exclude in list(spec.excludes):
        spec.delete(exclude)

    joints.add_anchors(spec, scene)
    if tree_pin is not None and scene.pins[tree_pin].kind == "gripper":
        _old_reparent(spec, spec.body(body_name(0, n)), spec.body(world.gripper_body(tree_pin)), p[0])

    geom = world.cable_geom(scene, self_collision=self_collision)
    world.stiffen_obstacle_contacts(spec, scene, timestep)
    options = joints.ball_options(scene, timestep)
    frames = joints.segment_frames(p)
    rel = joints.relative_quats(frames)
    for i in range(n):
        body = spec.body(body_name(i, n))
        body.pos, body.quat = (p[0], frames[0]) if i == 0 else ([l0, 0.0, 0.0], rel[i - 1])
        body.add_site(name=world.particle_site(order[i]))
        for g in body.geoms:
            g.fromto = [0.0, 0.0, 0.0, l0, 0.0, 0.0]
            for key, value in geom.items():
                setattr(g, key, value)
        for j in body.joints:
            if j.type == mujoco.mjtJoint.mjJNT_BALL:
                j.armature, j.damping = options["armature"], options["damping"]
    joints.add_root_joints(spec.body(body_name(0, n)), kind, name=f"{prefix}J_first", options=options)
    spec.body(body_name(n - 1, n)).add_site(name=world.particle_site(order[n]), pos=[l0, 0.0, 0.0])
    for i in range(n - 1):
        spec.add_exclude(bodyname1=body_name(i, n), bodyname2=body_name(i + 1, n))

    joints.add_pin_equalities(spec, scene, timestep=timestep, body_name=lambda i: body_name(i, n), skip=tree_pin)
    return snap.snap_spec(spec)


def _old_reparent(spec, root, parent, origin):
    spec.copy_during_attach = True
    parent.add_frame(pos=-np.asarray(origin)).attach_body(root, "", "")
    spec.copy_during_attach = False
    spec.delete(root)


# -- equivalence ---------------------------------------------------------------------------------------------------

def _scenes():
    cases = [(name, mjcable.scenes.get(name)) for name in SCENES]
    # (a stiff cable's clamp is a clamp body turning over half a segment, which MuJoCo's composite has no counterpart
    # of: test_capsule_chains holds the clamped cantilever against beam theory instead)
    cases.append(("cantilever_limp", scenarios.cantilever_scene(20, young=0.0)))  # a clamped root
    cases.append(("hang_stiff", mjcable.scenes.get("hang", young=3e6, n_segments=20)))
    cases.append(("yank_stiff", scenarios.yank_scene(12, young=1e6)))  # a gripper at particle 0 roots the tree
    cases.append(("free_2", Scene(CableSpec([[0.0, 0.0, 1.0], [0.2, 0.05, 1.1]], 2, 0.004, 0.01, young=2e5))))
    cases.append(("free_1", Scene(CableSpec([[0.0, 0.0, 1.0], [0.2, 0.05, 1.1]], 1, 0.004, 0.01, young=2e5))))
    return cases


CASES = _scenes()
IDS = [name for name, _ in CASES]


def _names(model, kind, count):
    return [mujoco.mj_id2name(model, kind, i) for i in range(count)]


@pytest.fixture(scope="module")
def old_model_name():
    """The reference builder as a catalogue model, so that ``Simulator`` steps both the same way."""
    name = "composite_xml_reference"
    catalog.register(dataclasses.replace(catalog.get("composite"), name=name, build=spec_builder(_old_build)))
    yield name
    catalog.unregister(name)


@pytest.mark.parametrize("name, scene", CASES, ids=IDS)
@pytest.mark.parametrize("self_collision", [False, True])
def test_composite_spec_compiles_to_the_xml_builders_model(name, scene, self_collision):
    dt = 0.002
    old = _old_build(scene, timestep=dt, self_collision=self_collision).compile()
    new = composite.build(scene, timestep=dt, self_collision=self_collision).compile()
    for size in ("nbody", "njnt", "nq", "nv", "neq", "ngeom", "nsite", "nexclude", "nplugin", "npluginattr",
                 "nmocap", "ntext", "nkey", "nu"):
        assert getattr(new, size) == getattr(old, size), size
    assert new.nplugin == (1 if scene.cable.young > 0.0 else 0)
    for kind, count in ((mujoco.mjtObj.mjOBJ_BODY, old.nbody), (mujoco.mjtObj.mjOBJ_JOINT, old.njnt),
                        (mujoco.mjtObj.mjOBJ_GEOM, old.ngeom), (mujoco.mjtObj.mjOBJ_SITE, old.nsite),
                        (mujoco.mjtObj.mjOBJ_EQUALITY, old.neq), (mujoco.mjtObj.mjOBJ_PLUGIN, old.nplugin),
                        (mujoco.mjtObj.mjOBJ_TEXT, old.ntext)):
        assert _names(new, kind, count) == _names(old, kind, count), kind
    for array in ("body_parentid", "body_mocapid", "body_plugin", "jnt_type", "jnt_bodyid", "jnt_group",
                  "geom_bodyid", "geom_type", "geom_contype", "geom_conaffinity", "geom_condim", "site_bodyid",
                  "site_group", "exclude_signature", "plugin", "plugin_attr", "plugin_attradr", "plugin_stateadr",
                  "plugin_statenum", "text_data", "eq_type", "eq_obj1id", "eq_obj2id"):
        np.testing.assert_array_equal(getattr(new, array), getattr(old, array), err_msg=array)
    for array in ("body_mass", "body_inertia", "body_pos", "body_quat", "body_ipos", "body_iquat", "dof_armature",
                  "dof_damping", "jnt_stiffness", "jnt_axis", "qpos0", "geom_size", "geom_pos", "geom_quat",
                  "geom_friction", "geom_solref", "geom_solimp", "site_pos", "eq_data", "eq_solref", "opt.viscosity",
                  "opt.timestep"):
        a, b = new, old
        for attr in array.split("."):
            a, b = getattr(a, attr), getattr(b, attr)
        # The composite's own end sites sit at its single-precision segment length; the new ones at the exact l0.
        atol = 1e-7 if array == "site_pos" else 1e-15
        np.testing.assert_allclose(a, b, rtol=MODEL_TOL, atol=atol, err_msg=array)
    assert (new.opt.integrator, new.opt.jacobian) == (old.opt.integrator, old.opt.jacobian)
    assert new.body_mass.sum() == pytest.approx(old.body_mass.sum())
    np.testing.assert_allclose(new.body_mass[new.body_plugin >= 0], scene.cable.mass / scene.cable.n_segments)


@pytest.mark.slow  # (keeps the quick suite of a cold clone under 5 minutes)
@pytest.mark.parametrize("name, scene", CASES, ids=IDS)
def test_composite_spec_moves_like_the_xml_builder(name, scene, old_model_name):
    old = mjcable.Simulator(scene, old_model_name)
    new = mjcable.Simulator(scene, "composite")
    for sim in (old, new):
        for step in range(round(SECONDS / sim.dt)):  # grippers rise 5 cm in 0.1 s (the yank cable lies at rest)
            for k in scene.gripper_pins:
                lift = GRIPPER_LIFT * min(step * sim.dt / 0.1, 1.0)
                sim.move_gripper(k, scene.cable.particles[scene.pin_particle(k)] + [0.0, 0.0, lift])
            sim.step(sim.dt)
    moved = np.linalg.norm(new.positions - scene.cable.particles, axis=1).max()
    assert np.all(np.isfinite(new.positions))
    assert moved > 1e-4, f"{name}: nothing moved ({moved:.2e} m)"
    error = np.linalg.norm(new.positions - old.positions, axis=1).max()
    assert error < POSITION_TOL, f"{name}: {error:.3e} m"


def test_composite_plugin_config_is_the_composites():
    """The plugin instance carries the composite's configuration: bend = E, twist = G, flat (its XML form)."""
    scene = mjcable.scenes.get("hang", young=3e6)
    old = _old_build(scene, timestep=0.002)
    new = composite.build(scene, timestep=0.002)
    (p_old,), (p_new,) = old.plugins, new.plugins
    assert (p_new.name, p_new.plugin_name) == (p_old.name, p_old.plugin_name) == ("compositecable", composite.PLUGIN)
    assert p_new.config == p_old.config
    assert {float(p_new.config["bend"]), float(p_new.config["twist"])} == {3e6, 3e6 / 3.0}
    xml = new.to_xml()
    reloaded = mujoco.MjModel.from_xml_string(xml)
    assert reloaded.nplugin == 1 and bytes(reloaded.plugin_attr) == bytes(old.compile().plugin_attr)


# -- into a user's world ---------------------------------------------------------------------------------------------

def _user_spec(scene) -> mujoco.MjSpec:
    """A small world of a user's in the scene's world (``world.new_spec``: options, assets, obstacles): a hinged arm
    with a position actuator, a free box, a ground plane and a keyframe."""
    spec = world.new_spec(scene, timestep=0.002)
    arm = spec.worldbody.add_body(name="arm", pos=[0.0, 0.6, 0.8])
    arm.add_joint(name="shoulder", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0.0, 1.0, 0.0])
    arm.add_geom(name="arm", type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0.0, 0.0, 0.0, 0.3, 0.0, 0.0],
                 size=[0.02, 0.0, 0.0])
    spec.add_actuator(name="shoulder", target="shoulder", trntype=mujoco.mjtTrn.mjTRN_JOINT).set_to_position(kp=20.0)
    box = spec.worldbody.add_body(name="box", pos=[0.5, 0.6, 0.05])
    box.add_freejoint(name="box")
    box.add_geom(name="box", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.05, 0.05, 0.05])
    spec.worldbody.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2.0, 2.0, 0.1])
    spec.add_key(name="home", qpos=[0.3, 0.5, 0.6, 0.05, 1.0, 0.0, 0.0, 0.0], ctrl=[0.3])
    return spec


USER_NQ = 8  # the hinge and the box's free joint


@pytest.mark.parametrize("scene", [
    mjcable.scenes.get("hang", young=1e6, n_segments=20),  # world pins: a ball root and a connect equality
    Scene(CableSpec([[0.0, 0.0, 1.0], [0.4, 0.0, 1.0]], 15, 0.005, 0.02, young=2e5, damping=1.0),
          pins=(Pin(0, "gripper"),)),  # a gripper roots the chain: a mocap body the user's keyframe lacks
    Scene(CableSpec([[0.0, 0.0, 1.0], [0.4, 0.0, 1.2]], 10, 0.005, 0.02)),  # limp, free: no plugin
], ids=["hang", "gripper", "free_limp"])
def test_add_cable_into_a_user_spec(scene):
    user = _user_spec(scene)
    user.activate_plugin(composite.PLUGIN)  # a user's world that declares the plugin already
    ref = _user_spec(scene).compile()
    composite.add_cable(user, scene, timestep=0.002)
    assert len(user.keys[0].qpos) == USER_NQ
    m = snap.snap_spec(user).compile()
    assert len(user.keys[0].qpos) == m.nq  # compiling writes the padded keyframe back into the spec

    assert mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, 0) == "shoulder"
    assert mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, 0) == "shoulder"
    assert m.nu == 1 and m.actuator_trnid[0, 0] == 0
    np.testing.assert_array_equal(m.qpos0[:USER_NQ], ref.qpos0)
    np.testing.assert_array_equal(m.body_mass[:ref.nbody], ref.body_mass)
    assert m.nplugin == (1 if scene.cable.young > 0.0 else 0)
    if m.nplugin:
        assert mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_PLUGIN, 0) == composite.INSTANCE
        assert np.count_nonzero(m.body_plugin == 0) == scene.cable.n_segments
    cable_nq = m.nq - USER_NQ
    assert cable_nq > 0

    # MuJoCo 3.17 pads the user's keyframe (written for 8 qpos, no mocap) with qpos0 and the mocap start poses.
    assert m.nkey == 1 and m.key_qpos.shape == (1, m.nq)
    np.testing.assert_array_equal(m.key_qpos[0, :USER_NQ], ref.key_qpos[0])
    np.testing.assert_array_equal(m.key_qpos[0, USER_NQ:], m.qpos0[USER_NQ:])
    np.testing.assert_array_equal(m.key_ctrl[0], ref.key_ctrl[0])
    grippers = [k for k, pin in enumerate(scene.pins) if pin.kind == "gripper"]
    assert m.nmocap == len(grippers)
    for k in grippers:
        mocap = m.body_mocapid[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, world.gripper_body(k))]
        np.testing.assert_array_equal(m.key_mpos[0, 3 * mocap:3 * mocap + 3],
                                      scene.cable.particles[scene.pin_particle(k)])

    # The key puts the cable at its start: the particle sites where the scene starts them.
    d = data.new_data(m)  # (MuJoCo's own MjData may hand the cable plugin a NaN: mjcable.mjcf.data)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    mujoco.mj_forward(m, d)
    sites = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, world.particle_site(i))
             for i in range(scene.cable.n_particles)]
    np.testing.assert_allclose(d.site_xpos[sites], scene.cable.particles, atol=1e-12)
    assert d.qpos[0] == 0.3

    # The user's arm follows its actuator while the cable moves; nothing blows up.
    d.ctrl[0] = 0.3
    for _ in range(round(SECONDS / m.opt.timestep)):
        mujoco.mj_step(m, d)
    assert np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))
    assert abs(d.qpos[0] - 0.3) < 0.05
    assert np.linalg.norm(d.site_xpos[sites] - scene.cable.particles, axis=1).max() > 1e-3  # the cable moved

    # The saved XML reloads into the same model.
    reloaded = mujoco.MjModel.from_xml_string(user.to_xml())
    for size in ("nbody", "njnt", "nq", "nu", "nplugin", "nkey", "neq", "nmocap"):
        assert getattr(reloaded, size) == getattr(m, size), size
    np.testing.assert_allclose(reloaded.key_qpos, m.key_qpos, atol=1e-6)


def test_add_cable_into_a_user_spec_with_a_cable_plugin_instance():
    """A world with its own instance of the cable plugin keeps it; the cable's is a second one."""
    scene = mjcable.scenes.get("hang", young=1e6, n_segments=10)
    user = _user_spec(scene)
    user.activate_plugin(composite.PLUGIN)
    theirs = user.add_plugin(name="theirs", plugin_name=composite.PLUGIN, active=True)
    theirs.config = {"bend": "1e5", "twist": "1e5", "vmax": "0"}
    composite.add_cable(user, scene, timestep=0.002)
    m = snap.snap_spec(user).compile()
    assert m.nplugin == 2
    assert _names(m, mujoco.mjtObj.mjOBJ_PLUGIN, 2) == ["theirs", composite.INSTANCE]
    assert np.count_nonzero(m.body_plugin == 1) == scene.cable.n_segments


def test_new_data_hands_the_cable_plugin_zeroed_memory_whatever_the_heap_held():
    """MuJoCo's cable plugin measures the chain's segments inside mj_makeData, from mocap positions MuJoCo has not
    yet initialised: after NaN-filled arrays were freed, half of plain MjData's elastic forces were NaN."""
    m = mjcable.build(scenarios.yank_scene(12, young=1e6), "composite").compile()  # a gripper roots the chain
    reference = data.new_data(m)
    mujoco.mj_forward(m, reference)
    assert np.all(np.isfinite(reference.qfrc_passive))
    for _ in range(10):
        garbage = [np.full(size // 8, np.nan) for size in (200_000, 100_000, 50_000, 20_000, 8_000, 4_000)]
        del garbage  # freed memory full of NaNs, which the next allocation may reuse
        d = data.new_data(m)
        mujoco.mj_forward(m, d)
        np.testing.assert_array_equal(d.qfrc_passive, reference.qfrc_passive)
