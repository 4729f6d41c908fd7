"""MuJoCo's C API from the compiled step loop (:mod:`mjcable.solvers.capi`): the struct layout read from the shipped
declarations agrees with the Python bindings' own views, and the loop that queries contacts itself gives the same
simulation bit for bit as the fallback that returns to Python for every ``mujoco.mj_collision`` (where the layout
does not check out)."""

import dataclasses

import mujoco
import numpy as np
import pytest

import mjcable
from mjcable.solvers import capi, state
from mjcable.solvers.contacts import ObstacleContacts

_PILE = """<mujoco><worldbody><geom type="plane" size="2 2 0.1"/>
  <body pos="0 0 0.09"><freejoint/><geom type="box" size="0.1 0.1 0.1"/></body>
  <body pos="0.5 0 0.05"><freejoint/><geom type="capsule" fromto="0 0 0 0.1 0.05 0" size="0.06"/></body>
  <body pos="-0.5 0 0.04"><freejoint/><geom type="sphere" size="0.05"/></body>
</worldbody></mujoco>"""


def test_the_layout_reads_what_the_bindings_read():
    """Every field the loop reads, for every contact of a pile of bodies sunk into a floor, through the layout and
    the raw views, equals the bindings' ``MjData.contact`` and ``ncon``."""
    lay = capi.layout()
    assert lay is not None, capi.unavailable()
    assert capi.unavailable() is None
    m = mujoco.MjModel.from_xml_string(_PILE)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    views = capi.data_views(d)
    ncon = int(views.struct_i32[lay.ncon // 4])
    assert ncon == d.ncon >= 6
    base = int(views.struct_i64[lay.contact // 8]) - views.arena_address
    rows = base + lay.contact_size * np.arange(ncon)
    f64 = views.arena_f64
    np.testing.assert_array_equal(f64[(rows + lay.dist) // 8], d.contact.dist)
    for k in range(3):
        np.testing.assert_array_equal(f64[(rows + lay.pos) // 8 + k], d.contact.pos[:, k])
    for k in range(9):
        np.testing.assert_array_equal(f64[(rows + lay.frame) // 8 + k], d.contact.frame[:, k])
    for k in range(2):
        np.testing.assert_array_equal(views.arena_i32[(rows + lay.geom) // 4 + k], d.contact.geom[:, k])


def _state(sim) -> dict:
    d = sim.mj_data
    return dict(x=sim.positions, v=sim.velocities, f=sim.pin_forces, geoms=d.geom_xpos.copy(),
                time=np.array([d.time, sim.time]),
                counts=np.array([sim.diagnostics[k] for k in ("contacts", "self_contacts", "queries")]))


def _run(scene, model, monkeypatch, seconds=0.4, c_api=True, **settings) -> tuple:
    """The state after ``seconds`` of steps in one call, and how many contact queries Python ran for it (through
    the bindings; the first, at construction, is the backend's check of the starting state)."""
    if not c_api:
        monkeypatch.setattr(capi, "_cached", lambda: (None, "RuntimeError: test"))
        assert capi.layout() is None and capi.unavailable() == "RuntimeError: test"
    calls = {"n": 0}
    real = ObstacleContacts.query

    def counted(self, *args):
        calls["n"] += 1
        return real(self, *args)

    monkeypatch.setattr(ObstacleContacts, "query", counted)
    sim = mjcable.Simulator(scene, model, **settings)
    sim.step(seconds)
    out = _state(sim)
    monkeypatch.undo()
    return out, calls["n"] - 1


@pytest.mark.parametrize("scene_name,model,settings", [
    ("table", "xpbd", {}),  # falls for 0.2 s, lands: about 100 queried steps
    ("drape", "pbd", {}),  # over a cylinder
    ("socket", "jakobsen", {}),  # a gripper, a socket, wall and floor
    ("drape", "xpbd", {"self_collision": True}),  # every step queries its self contacts too
])
def test_the_loop_queries_contacts_itself_bit_for_bit(scene_name, model, settings, monkeypatch):
    scene = mjcable.scenes.get(scene_name, n_segments=16)
    fast, python_queries_fast = _run(scene, model, monkeypatch, **settings)
    slow, python_queries_slow = _run(scene, model, monkeypatch, c_api=False, **settings)
    assert fast["counts"][2] > 20  # the cable met the obstacles for many steps
    assert python_queries_slow == slow["counts"][2]  # every query went through Python ...
    assert python_queries_fast == 0  # ... or through the C API in the loop
    for key in slow:
        np.testing.assert_array_equal(fast[key], slow[key], err_msg=f"{key} differs between the two queries")


@pytest.mark.parametrize("c_api", [True, False])
def test_contact_buffers_grow_in_the_loop(c_api, monkeypatch):
    """With no room for contacts at first (obstacle and self contacts), the loop grows its buffers as the queries
    need; the simulation is the same as with ample buffers."""
    table = mjcable.scenes.get("table")
    loop = [(-0.2, 0, 0.78), (0.1, 0, 0.78), (0.15, 0.08, 0.79), (0.05, 0.12, 0.80), (0.0, 0.0, 0.81), (0.0, -0.1, 0.81)]
    scene = dataclasses.replace(table, cable=dataclasses.replace(table.cable, points=tuple(loop), n_segments=30))
    ample, _ = _run(scene, "xpbd", monkeypatch, seconds=0.3, c_api=c_api, self_collision=True)
    monkeypatch.setattr(state, "_CONTACT_CAPACITY", 0)
    monkeypatch.setattr(state, "_SELF_CONTACT_CAPACITY", 0)
    tight, _ = _run(scene, "xpbd", monkeypatch, seconds=0.3, c_api=c_api, self_collision=True)
    assert tight["counts"][0] > 0 and tight["counts"][1] > 0  # obstacle and self contacts
    for key in ample:
        np.testing.assert_array_equal(tight[key], ample[key], err_msg=key)


def test_the_installed_mujoco_passes_the_layout_and_host_signature_checks():
    """On every MuJoCo mjcable supports (3.17 and 4.x), the layout check and the host functions' declarations pass."""
    assert capi.unavailable() is None, capi.unavailable()
    assert capi.host_unavailable() is None, capi.host_unavailable()


@pytest.mark.parametrize("name, position, new_type", [("mj_getState", 3, "unsigned int"),
                                                       ("mj_setState", 3, "mjtState"),
                                                       ("mj_jac", 5, "mjtNum")])
def test_a_changed_host_signature_falls_back_with_its_reason(monkeypatch, name, position, new_type):
    """A MuJoCo whose mj_getState/mj_setState (or any host function) took other arguments than the host kernels pass
    leaves the compiled host off, and says which declaration differs."""
    from mujoco.introspect import ast_nodes, functions

    decl = functions.FUNCTIONS[name]
    parameters = list(decl.parameters)
    parameters[position] = dataclasses.replace(parameters[position], type=ast_nodes.ValueType(name=new_type))
    monkeypatch.setitem(functions.FUNCTIONS, name, dataclasses.replace(decl, parameters=tuple(parameters)))
    capi._cached_host.cache_clear()
    try:
        assert capi.host_functions() is None
        assert name in capi.host_unavailable() and new_type in capi.host_unavailable()
    finally:
        monkeypatch.undo()
        capi._cached_host.cache_clear()
    assert capi.host_functions() is not None
