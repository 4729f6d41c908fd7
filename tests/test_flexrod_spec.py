"""``flexrod`` built with the MjSpec API (``add_flex``) instead of a ``<flexcomp>`` XML fragment.

The reference is the former builder, kept here verbatim (it let MuJoCo's ``flexcomp`` generate the vertex bodies,
joints and flex from XML, passed as ``base_xml``): the new builder must compile to the same model and the same
trajectories, and it must add the cable into a spec that already holds a robot, a free body and a keyframe.
"""

import dataclasses
import warnings

import mujoco
import numpy as np
import pytest

import mjcable
from mjcable import catalog
from mjcable.backends.native import spec_builder
from mjcable.bench import scenarios
from mjcable.mjcf import flexrod, snap, world
from mjcable.mjcf.world import START_KEY

MODEL = "flexrod"
REFERENCE = "flexrod_flexcomp"  # the former builder, registered for the duration of a test
SECONDS = 0.5
POSITION_TOL = 1e-9  # m, new vs former builder after SECONDS
WORLD_TOL = 1e-6  # m, the cable inside another spec vs on its own (one constraint solve for both)


# -- the former builder (flexcomp from XML), the reference ---------------------------------------------------------

def _flexcomp_xml(points: np.ndarray) -> str:
    coords = " ".join(f"{x:.17g}" for x in points.ravel())
    elements = " ".join(f"{i} {i + 1}" for i in range(len(points) - 1))
    return (f'<mujoco><worldbody><flexcomp name="{flexrod.FLEX}" type="direct" dim="1" dof="full" point="{coords}" '
            f'element="{elements}"/></worldbody></mujoco>')


def _flexcomp_build(scene, *, timestep, self_collision=False):
    cable = scene.cable
    n = cable.n_particles
    stiff = cable.young > 0.0
    rest = flexrod._straight(scene) if stiff else cable.particles
    spec = world.new_spec(scene, timestep=timestep, base_xml=_flexcomp_xml(rest))

    flex = spec.flex(flexrod.FLEX)
    flex.radius = cable.radius
    flex.young = cable.young
    flex.poisson = 0.0
    geom = world.cable_geom(scene, self_collision=self_collision)
    for attribute in ("friction", "condim", "contype", "conaffinity"):
        setattr(flex, attribute, geom[attribute])
    flexrod._set_material(flex, geom["material"])  # a str on MuJoCo 3.x, a list of names on 4.x
    if stiff and not flexrod._implicit_flex_elasticity():  # MuJoCo 4: no flex bending under implicitfast
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER
    flex.selfcollide = mujoco.mjtFlexSelf.mjFLEXSELF_AUTO if self_collision else mujoco.mjtFlexSelf.mjFLEXSELF_NONE
    if flexrod.uses_edge_springs(scene, timestep):
        flex.edgestiffness = cable.stretch_stiffness / cable.segment_length
    else:
        spec.add_equality(name=flexrod._EDGE_EQUALITY, type=mujoco.mjtEq.mjEQ_FLEX, name1=flexrod.FLEX,
                          solref=[flexrod.EDGE_SOLREF_STEPS * timestep, 1.0], solimp=flexrod.EDGE_SOLIMP)

    masses = cable.particle_masses
    for i in range(n):
        body = spec.body(flexrod.vertex_body(i))
        body.mass = masses[i]
        body.inertia = [flexrod._SPHERE_INERTIA * masses[i] * cable.radius**2] * 3
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[cable.radius, 0, 0], contype=0, conaffinity=0,
                      group=flexrod._MARKER_GROUP, mass=0.0)
        for joint in body.joints:
            joint.damping = [cable.damping * masses[i], 0.0, 0.0]
        body.add_site(name=world.particle_site(i))

    mocap_pose = flexrod._add_pins(spec, scene, timestep, rest, straight=stiff)
    if stiff:
        mocap = [mocap_pose[b.name] for b in spec.bodies if b.mocap]
        extra = dict(mpos=np.ravel([pos for pos, _ in mocap]), mquat=np.ravel([q for _, q in mocap])) if mocap else {}
        spec.add_key(name=START_KEY, qpos=(cable.particles - rest).ravel(), **extra)
    return snap.snap_spec(spec)


@pytest.fixture
def reference_model():
    """Registers the former builder as model ``REFERENCE`` for one test."""
    catalog.register(dataclasses.replace(catalog.get(MODEL), name=REFERENCE, build=spec_builder(_flexcomp_build)))
    yield REFERENCE
    catalog.unregister(REFERENCE)


# -- scenes --------------------------------------------------------------------------------------------------------

def _scene(name):
    if name == "cantilever":  # young = 1e9: a stiff, clamped rod that compiles straight and poses its START_KEY
        return scenarios.cantilever_scene(20)
    if name == "socket_stiff":  # stiff, with a clamped socket and a gripper: mocap anchors posed by the keyframe
        return mjcable.scenes.get("socket", young=2e5, n_segments=20)
    if name == "springs":  # finite E·A soft enough for flex edge springs instead of the edge equality
        scene = mjcable.scenes.get("hang", stretch_stiffness=20.0, n_segments=20)
        assert flexrod.uses_edge_springs(scene, 0.002)
        return scene
    return mjcable.scenes.get(name)


SCENES = ["hang", "table", "drape", "socket", "cantilever", "socket_stiff", "springs"]


def _both(scene, timestep, self_collision=False):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the stiff scenes warn at a single substep; the models compare all the same
        return (_flexcomp_build(scene, timestep=timestep, self_collision=self_collision).compile(),
                flexrod.build(scene, timestep=timestep, self_collision=self_collision).compile())


_SIZES = ("nbody", "njnt", "nq", "nv", "ngeom", "nsite", "nflex", "nflexvert", "nflexedge", "nflexelem", "neq",
          "nmocap", "nkey", "nu")
_ARRAYS = ("body_parentid", "body_pos", "body_quat", "body_ipos", "body_mass", "body_inertia", "body_mocapid",
           "jnt_type", "jnt_bodyid", "jnt_axis", "jnt_pos", "jnt_qposadr", "dof_damping", "qpos0",
           "geom_bodyid", "geom_type", "geom_size", "geom_contype", "geom_conaffinity", "site_bodyid", "site_pos",
           "eq_type", "eq_obj1id", "eq_obj2id", "eq_objtype", "eq_solref", "eq_solimp", "eq_data",
           "key_qpos", "key_mpos", "key_mquat")


def _flex_arrays(m):
    return sorted(k for k in dir(m) if k.startswith(("flex_", "flexedge_", "flexvert_")) and isinstance(getattr(m, k),
                                                                                                     np.ndarray))


@pytest.mark.parametrize("self_collision", [False, True])
@pytest.mark.parametrize("name", SCENES)
def test_compiles_to_the_flexcomp_model(name, self_collision):
    old, new = _both(_scene(name), 0.002, self_collision)
    for size in _SIZES:
        assert getattr(new, size) == getattr(old, size), size
    flex_arrays = _flex_arrays(old)
    assert {"flex_vertbodyid", "flex_edge", "flex_bending", "flex_radius", "flex_vert", "flex_centered", "flex_rigid",
            "flex_edgeequality", "flex_selfcollide", "flex_contype", "flex_edgestiffness"} <= set(flex_arrays)
    assert _flex_arrays(new) == flex_arrays
    for key in (*flex_arrays, *_ARRAYS):
        a, b = getattr(old, key), getattr(new, key)
        assert a.shape == b.shape, key
        assert np.allclose(a, b, rtol=1e-12, atol=1e-12), key
    for kind, count in ((mujoco.mjtObj.mjOBJ_BODY, old.nbody), (mujoco.mjtObj.mjOBJ_JOINT, old.njnt),
                        (mujoco.mjtObj.mjOBJ_SITE, old.nsite), (mujoco.mjtObj.mjOBJ_EQUALITY, old.neq),
                        (mujoco.mjtObj.mjOBJ_FLEX, old.nflex), (mujoco.mjtObj.mjOBJ_KEY, old.nkey)):
        assert [mujoco.mj_id2name(new, kind, i) for i in range(count)] == \
               [mujoco.mj_id2name(old, kind, i) for i in range(count)], kind
    if name in ("cantilever", "socket_stiff"):
        assert old.flex_bending.size and np.abs(old.flex_bending).max() > 0  # the stiff path was exercised
        assert new.nkey == 1
    if name == "springs":
        assert mujoco.mj_name2id(new, mujoco.mjtObj.mjOBJ_EQUALITY, flexrod._EDGE_EQUALITY) == -1
        assert new.neq == len(_scene(name).pins) and new.flex_edgestiffness[0] > 0  # edge springs, no equality


@pytest.mark.parametrize("name", SCENES)
def test_trajectories_match_the_flexcomp_model(name, reference_model):
    scene = _scene(name)
    substeps = flexrod.stable_substeps(scene, 0.002)
    sims = [mjcable.Simulator(scene, model, substeps=substeps) for model in (reference_model, MODEL)]
    for sim in sims:
        sim.step(SECONDS)
    old, new = (sim.positions for sim in sims)
    assert np.all(np.isfinite(new))
    assert np.abs(old - scene.cable.particles).max() > 1e-3  # the cable moved
    assert np.abs(new - old).max() < POSITION_TOL


# -- the cable inside a spec that already holds a robot ------------------------------------------------------------

USER_QPOS = [0.4, 0.0, 1.0, 0.2, 1.0, 0.0, 0.0, 0.0]  # shoulder angle, then the free box: position, quaternion
ARM_Y = 1.0  # m: the arm and the box stand well clear of the cables of the built-in scenes


def _add_user_things(spec: mujoco.MjSpec) -> mujoco.MjSpec:
    """A user's robot and props added to ``spec``: a hinged arm with a position actuator, a free box, a mocap target
    and a keyframe."""
    spec.worldbody.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[3, 3, 0.1], pos=[0, ARM_Y, 0])
    arm = spec.worldbody.add_body(name="arm", pos=[0.0, ARM_Y, 0.5])
    arm.add_joint(name="shoulder", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0], damping=1.0)
    arm.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, size=[0.03, 0, 0], fromto=[0, 0, 0, 0.3, 0, 0])
    spec.add_actuator(name="shoulder", target="shoulder", trntype=mujoco.mjtTrn.mjTRN_JOINT).set_to_position(kp=20.0)
    box = spec.worldbody.add_body(name="box", pos=[0.0, ARM_Y + 0.3, 0.2])
    box.add_freejoint(name="box")
    box.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.05, 0.05, 0.05])
    spec.worldbody.add_body(name="target", pos=[0.3, ARM_Y, 0.8], mocap=True)
    spec.add_key(name="home", qpos=USER_QPOS, ctrl=[0.4], mpos=[0.2, ARM_Y, 0.9])
    return spec


_NEW_SPEC = world.new_spec  # before any monkeypatching


def _user_spec(scene, timestep: float) -> mujoco.MjSpec:
    """What ``new_spec`` will return for a user's world: the scene's world additions plus the user's things."""
    return _add_user_things(_NEW_SPEC(scene, timestep=timestep))


def _particles(m, d, n):
    sites = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, world.particle_site(i)) for i in range(n)]
    return d.site_xpos[sites].copy()


def _run(m, key: str | None, seconds: float):
    d = mujoco.MjData(m)
    k = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, key) if key else -1
    if k >= 0:
        mujoco.mj_resetDataKeyframe(m, d, k)
    mujoco.mj_forward(m, d)
    start = d.qpos.copy()
    mujoco.mj_step(m, d, nstep=round(seconds / m.opt.timestep))
    mujoco.mj_kinematics(m, d)
    return d, start


@pytest.mark.parametrize("name", ["hang", "socket_stiff"])
def test_add_cable_goes_in_after_what_the_spec_holds(name):
    scene = _scene(name)
    timestep = 0.002 / flexrod.stable_substeps(scene, 0.002)
    alone = flexrod.build(scene, timestep=timestep).compile()
    user = _user_spec(scene, timestep).compile()
    spec = _user_spec(scene, timestep)
    assert flexrod.add_cable(spec, scene, timestep=timestep) is spec  # edited in place
    m = spec.compile()

    # what the user had keeps its ids and data; the cable comes after it
    assert mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, 0) == "shoulder"
    assert mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, 0) == "shoulder"
    assert mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_KEY, 0) == "home"
    assert (m.nflex, m.nu) == (1, 1)
    assert (m.nbody, m.nq, m.nv, m.nmocap) == (user.nbody + alone.nbody - 1, user.nq + alone.nq,
                                               user.nv + alone.nv, user.nmocap + alone.nmocap)
    np.testing.assert_array_equal(m.flex_vertbodyid, alone.flex_vertbodyid + user.nbody - 1)
    np.testing.assert_array_equal(m.key_qpos[0, :user.nq], USER_QPOS)
    np.testing.assert_array_equal(m.key_qpos[0, user.nq:], alone.qpos0)  # padded with the cable's compiled pose
    for key in ("flex_edge", "flex_bending", "flex_radius", "flex_edgeequality", "flex_contype"):
        assert np.allclose(getattr(m, key), getattr(alone, key)), key

    # the cable's start: for a stiff cable, START_KEY holds the user's qpos0 and mocap poses, then the cable's
    key = START_KEY if alone.nkey else None
    if key:
        k = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, START_KEY)
        np.testing.assert_allclose(m.key_qpos[k, :user.nq], user.qpos0)
        np.testing.assert_allclose(m.key_mpos[k, :3 * user.nmocap], user.body_pos[user.body_mocapid >= 0].ravel())
        np.testing.assert_allclose(m.key_qpos[k, user.nq:], alone.key_qpos[0])
        np.testing.assert_allclose(m.key_mpos[k, 3 * user.nmocap:], alone.key_mpos[0])
    d, start = _run(m, key, 0.0)
    np.testing.assert_allclose(_particles(m, d, scene.cable.n_particles), scene.cable.particles, atol=1e-12)
    if key:
        np.testing.assert_allclose(start[:user.nq], user.qpos0)

    d, _ = _run(m, key, SECONDS)
    d_alone, _ = _run(alone, key, SECONDS)
    assert np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))
    moved = _particles(alone, d_alone, scene.cable.n_particles)
    assert np.abs(moved - scene.cable.particles).max() > 1e-3
    assert np.abs(_particles(m, d, scene.cable.n_particles) - moved).max() < WORLD_TOL


def test_build_adds_the_cable_to_the_spec_new_spec_returns(monkeypatch):
    """``build`` is ``new_spec`` (no XML base) plus ``add_cable``: whatever ``new_spec`` returns gets the cable."""
    scene = mjcable.scenes.get("hang")
    calls = []

    def user_world(scene_, *, timestep, **kwargs):
        calls.append(kwargs)
        return _user_spec(scene_, timestep)

    monkeypatch.setattr(world, "new_spec", user_world)
    sim = mjcable.Simulator(scene, MODEL)
    assert calls == [{}]  # no base_xml
    m = sim.mj_model
    assert mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, 0) == "shoulder"
    assert mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, 0) == "shoulder"
    assert m.nflex == 1
    sim.step(SECONDS)
    assert np.all(np.isfinite(sim.positions)) and np.all(np.isfinite(sim.mj_data.qpos))
    assert np.abs(sim.positions - scene.cable.particles).max() > 1e-3
