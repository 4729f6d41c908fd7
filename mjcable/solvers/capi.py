"""MuJoCo's C API for the particle solvers' compiled step loop: ``mj_kinematics`` and ``mj_collision`` called from numba.

The step driver (:func:`mjcable.solvers.kernels.run_steps`) queries contacts between steps without returning to
Python: it poses the proxy capsules, calls ``mj_kinematics`` and ``mj_collision`` on the proxy's ``mjModel`` and
``mjData`` through their C entry points, and reads ``ncon`` and the contact array out of ``mjData``'s memory. This
module finds what that needs, once per process:

* the entry points: the ``libmujoco`` shared library the ``mujoco`` wheel ships, opened with ``RTLD_NOLOAD`` (the very
  copy the Python bindings loaded, so that MuJoCo's global callbacks and warning handlers are the bindings'); the
  addresses of its functions; ``MjModel._address`` and ``MjData._address`` give the struct pointers;
* the struct layout (:class:`Layout`): the byte offsets of ``mjData.ncon``, ``mjData.arena`` and ``mjData.contact``
  and of ``mjContact``'s fields, from the C declarations the wheel ships (``mujoco.introspect``, generated from the
  headers) laid out by ``ctypes`` with the C rules, then checked against the bindings' own views of a small model's
  contacts (their addresses, ``ncon``, the contact stride); any difference, or anything missing, and the layout is
  ``None`` with the reason (:func:`unavailable`);
* per ``MjData`` (:class:`DataViews`): numpy views of its struct (``ncon``, the ``contact`` pointer) and of its arena
  (where ``mj_collision`` writes the contacts), valid while the ``MjData`` lives (MuJoCo never moves them).

A MuJoCo *error* (``mju_error``) inside a call made by address ends the process: MuJoCo's default handler runs, not
the bindings' (which turn errors into ``mujoco.FatalError`` around their own calls only). The callers keep a first
call through the bindings after each start or reset (:func:`mjcable.solvers.query_kernels.query_obstacles`,
:mod:`mjcable.solvers.host_kernels`). Where the layout is unavailable, the particle backend queries in Python
(``mujoco.mj_collision`` and the bindings' contact views), with identical results (``tests/test_capi.py``); a user
world's host has no such fallback (:class:`mjcable.backends.host.Host` says why it can't run). The numba side, the calls and the reads, is
:func:`mjcable.solvers.query_kernels.query_obstacles`.
"""

from __future__ import annotations

import ctypes
import dataclasses
import functools
import glob
import os
import sys
from typing import Optional

import mujoco
import numpy as np

__all__ = ["Layout", "DataViews", "layout", "unavailable", "function_addresses", "model_address", "data_views",
           "HostFunctions", "host_functions", "host_unavailable"]

#: the user-world host's entry points (:class:`HostFunctions`) and the arguments the host kernels pass them, as the C
#: ABI sees them ("p": a pointer; MuJoCo 3.17's mujoco.h: mj_getState/mj_setState take ``int sig``), checked against
#: the shipped declarations (:func:`_check_host_signatures`)
_HOST_FUNCTIONS = {
    "mj_step": ("p", "p"),  # (const mjModel* m, mjData* d)
    "mj_kinematics": ("p", "p"),  # (const mjModel* m, mjData* d)
    "mj_getState": ("p", "p", "p", "int"),  # (const mjModel* m, const mjData* d, mjtNum* state, int sig)
    "mj_setState": ("p", "p", "p", "int"),  # (const mjModel* m, mjData* d, const mjtNum* state, int sig)
    "mj_jac": ("p", "p", "p", "p", "p", "int"),  # (m, d, mjtNum* jacp, mjtNum* jacr, const mjtNum point[3], int body)
    "mj_solveM": ("p", "p", "p", "p", "int"),  # (const mjModel* m, mjData* d, mjtNum* x, const mjtNum* y, int n)
}
_FUNCTIONS = ("mj_kinematics", "mj_collision", *(f for f in _HOST_FUNCTIONS if f != "mj_kinematics"))
_SCALARS = {"mjtNum": ctypes.c_double, "int": ctypes.c_int, "mjtSize": ctypes.c_int64, "size_t": ctypes.c_size_t,
            "uintptr_t": ctypes.c_size_t, "mjtBool": ctypes.c_bool, "mjtByte": ctypes.c_ubyte,
            "float": ctypes.c_float}
_CHECK_XML = """<mujoco><worldbody><geom type="plane" size="1 1 0.1"/>
  <body pos="0 0 0.05"><freejoint/><geom type="box" size="0.1 0.1 0.1"/></body>
  <body pos="0.5 0 0.05"><freejoint/><geom type="capsule" fromto="0 0 0 0.1 0.05 0" size="0.06"/></body>
</worldbody></mujoco>"""  # a box and a capsule sunk into a plane: 4 + 2 contacts to check the layout against


@dataclasses.dataclass(frozen=True)
class Layout:
    """Byte offsets into MuJoCo 3.17's structs, and its C entry points.

    Attributes:
      ncon, arena, contact: offsets of ``mjData.ncon`` (int), ``mjData.arena`` and ``mjData.contact`` (pointers).
      struct_size: bytes of ``mjData`` up to and including ``contact`` (what :class:`DataViews` maps).
      contact_size: ``sizeof(mjContact)`` (bytes, a multiple of 8).
      dist, pos, frame, geom: offsets of ``mjContact.dist`` (double), ``.pos`` (double[3]), ``.frame`` (double[9])
        and ``.geom`` (int[2]).
      kinematics, collision: addresses of ``mj_kinematics`` and ``mj_collision`` (``void f(const mjModel*,
        mjData*)``).
    """

    ncon: int
    arena: int
    contact: int
    struct_size: int
    contact_size: int
    dist: int
    pos: int
    frame: int
    geom: int
    kinematics: int
    collision: int


@dataclasses.dataclass(frozen=True)
class DataViews:
    """An ``MjData``'s memory as the compiled query reads it (keep it with its ``MjData``: the views borrow its memory).

    Attributes:
      data: the ``MjData`` (kept alive by this object).
      address: its ``mjData*``.
      struct_i32, struct_i64: the struct up to ``contact``, as int32 and int64 words (``ncon`` at
        ``Layout.ncon // 4``, the ``contact`` pointer at ``Layout.contact // 8``).
      arena_address: the arena's address (``mjData.arena``; ``contact`` points into it).
      arena_f64, arena_i32: the arena as float64 and int32 words.
    """

    data: mujoco.MjData
    address: int
    struct_i32: np.ndarray
    struct_i64: np.ndarray
    arena_address: int
    arena_f64: np.ndarray
    arena_i32: np.ndarray


def _library() -> ctypes.CDLL:
    """The ``libmujoco`` the bindings loaded (``RTLD_NOLOAD``: never a second copy). Raises ``OSError`` if none."""
    folder = os.path.dirname(mujoco.__file__)
    pattern = {"darwin": "libmujoco*.dylib", "win32": "mujoco*.dll"}.get(sys.platform, "libmujoco.so*")
    paths = sorted(glob.glob(os.path.join(folder, pattern)))
    if not paths:
        raise OSError(f"no {pattern} in {folder}")
    mode = getattr(os, "RTLD_NOLOAD", 0) | getattr(os, "RTLD_NOW", 0)
    return ctypes.CDLL(paths[0], mode=mode)


def _ctype(decl_type):
    from mujoco.introspect import ast_nodes

    if isinstance(decl_type, ast_nodes.PointerType):
        return ctypes.c_void_p
    if isinstance(decl_type, ast_nodes.ArrayType):
        out = _ctype(decl_type.inner_type)
        for extent in reversed(decl_type.extents):
            out = out * extent
        return out
    if decl_type.name in _SCALARS:
        return _SCALARS[decl_type.name]
    return _struct(decl_type.name)


@functools.lru_cache(maxsize=None)
def _struct(name: str, last: Optional[str] = None) -> type:
    """``ctypes.Structure`` of MuJoCo struct ``name`` from its shipped declaration, up to field ``last`` (all)."""
    from mujoco.introspect import structs

    fields = []
    for field in structs.STRUCTS[name].fields:
        fields.append((field.name, _ctype(field.type)))
        if field.name == last:
            break
    else:
        if last is not None:
            raise KeyError(f"{name} has no field {last!r}")
    return type(name, (ctypes.Structure,), {"_fields_": fields})


def _read_layout() -> Layout:
    """The layout from the declarations, checked against the bindings' views; raises ``RuntimeError`` on a mismatch."""
    lib = _library()
    address = {name: ctypes.cast(getattr(lib, name), ctypes.c_void_p).value for name in _FUNCTIONS}
    data_t, contact_t = _struct("mjData", "contact"), _struct("mjContact")
    out = Layout(ncon=data_t.ncon.offset, arena=data_t.arena.offset, contact=data_t.contact.offset,
                 struct_size=ctypes.sizeof(data_t), contact_size=ctypes.sizeof(contact_t), dist=contact_t.dist.offset,
                 pos=contact_t.pos.offset, frame=contact_t.frame.offset, geom=contact_t.geom.offset,
                 kinematics=address["mj_kinematics"], collision=address["mj_collision"])
    # the check: a model with contacts, stepped by the bindings, read through the layout
    m = mujoco.MjModel.from_xml_string(_CHECK_XML)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    con = d.contact
    views = data_views(d, out)
    contact_ptr = int(views.struct_i64[out.contact // 8])
    expected = {
        "ncon": (int(views.struct_i32[out.ncon // 4]), d.ncon),
        "energy": (data_t.energy.offset, d.energy.ctypes.data - d._address),
        "narena": (views.arena_f64.nbytes, d.narena),
        "contact": (contact_ptr, con.dist.ctypes.data),
        "sizeof(mjContact)": (out.contact_size, con.dist.strides[0]),
        **{f"mjContact.{f}": (getattr(out, f), getattr(con, f).ctypes.data - contact_ptr)
           for f in ("dist", "pos", "frame", "geom")},
    }
    if d.ncon < 2:  # pragma: no cover - the check model always has contacts
        raise RuntimeError(f"the layout check model has {d.ncon} contacts")
    wrong = {k: v for k, v in expected.items() if v[0] != v[1]}
    if wrong:
        raise RuntimeError("MuJoCo's struct layout differs from its declarations: "
                           + ", ".join(f"{k} {a} != {b}" for k, (a, b) in wrong.items()))
    base = (contact_ptr - views.arena_address) // 8
    stride = out.contact_size // 8
    read = views.arena_f64[base + np.arange(d.ncon) * stride + out.dist // 8]
    if not np.array_equal(read, con.dist):
        raise RuntimeError("the contact distances read through the layout differ from the bindings'")
    return out


@functools.lru_cache(maxsize=None)
def _cached() -> tuple:
    try:
        return _read_layout(), None
    except Exception as exc:  # anything: the compiled query is an optimisation, Python's query stays
        return None, f"{type(exc).__name__}: {exc}"


def layout() -> Optional[Layout]:
    """The checked :class:`Layout` of the loaded MuJoCo, or ``None`` where the compiled query cannot be used."""
    return _cached()[0]


def unavailable() -> Optional[str]:
    """Why :func:`layout` is ``None`` (``None`` when it is available)."""
    return _cached()[1]


def function_addresses() -> tuple:
    """(``mj_kinematics``, ``mj_collision``) addresses; raises ``RuntimeError`` where unavailable."""
    lay = layout()
    if lay is None:
        raise RuntimeError(f"MuJoCo's C API is unavailable: {unavailable()}")
    return lay.kinematics, lay.collision


def model_address(m: mujoco.MjModel) -> int:
    """The ``mjModel*`` of ``m``."""
    return int(m._address)


def _words(address: int, nbytes: int, ctype) -> np.ndarray:
    size = ctypes.sizeof(ctype)
    return np.ctypeslib.as_array(ctypes.cast(address, ctypes.POINTER(ctype)), shape=(nbytes // size,))


def data_views(d: mujoco.MjData, lay: Optional[Layout] = None) -> DataViews:
    """Views of ``d``'s struct and arena for :func:`mjcable.solvers.query_kernels.query_obstacles`."""
    lay = lay or layout()
    if lay is None:
        raise RuntimeError(f"MuJoCo's C API is unavailable: {unavailable()}")
    address = int(d._address)
    arena_address = ctypes.c_void_p.from_address(address + lay.arena).value
    narena = ctypes.c_int64.from_address(address + _struct("mjData", "contact").narena.offset).value
    return DataViews(data=d, address=address, struct_i32=_words(address, lay.struct_size, ctypes.c_int32),
                     struct_i64=_words(address, lay.struct_size, ctypes.c_int64), arena_address=arena_address,
                     arena_f64=_words(arena_address, narena, ctypes.c_double),
                     arena_i32=_words(arena_address, narena, ctypes.c_int32))


@dataclasses.dataclass(frozen=True)
class HostFunctions:
    """The entry points a user world's host calls from compiled code (:mod:`mjcable.solvers.host_kernels`), as
    addresses; their C signatures (MuJoCo 3.17's ``mujoco.h``) are those of ``_HOST_FUNCTIONS``.

    Attributes:
      step, kinematics: ``mj_step``, ``mj_kinematics`` (``void f(const mjModel*, mjData*)``).
      get_state, set_state: ``mj_getState``, ``mj_setState`` (``void f(const mjModel*, [const] mjData*, mjtNum*
        state, int sig)``).
      jac: ``mj_jac`` (``void f(const mjModel*, const mjData*, mjtNum* jacp, mjtNum* jacr, const mjtNum point[3],
        int body)``).
      solve_m: ``mj_solveM`` (``void f(const mjModel*, mjData*, mjtNum* x, const mjtNum* y, int n)``).
    """

    step: int
    kinematics: int
    get_state: int
    set_state: int
    jac: int
    solve_m: int


def _check_host_signatures() -> None:
    """The shipped declarations (``mujoco.introspect``, from the headers) return void and take the arguments in
    ``_HOST_FUNCTIONS``; raises ``RuntimeError`` otherwise."""
    from mujoco.introspect import ast_nodes, functions

    def kind(t) -> str:
        return "p" if isinstance(t, (ast_nodes.PointerType, ast_nodes.ArrayType)) else getattr(t, "name", repr(t))

    for name, expected in _HOST_FUNCTIONS.items():
        decl = functions.FUNCTIONS[name]
        got = tuple(kind(p.type) for p in decl.parameters)
        if kind(decl.return_type) != "void" or got != expected:
            raise RuntimeError(f"{name} is declared {kind(decl.return_type)} {name}{got}, the host kernels call "
                               f"void {name}{expected}")


@functools.lru_cache(maxsize=None)
def _cached_host() -> tuple:
    if layout() is None:
        return None, unavailable()
    try:
        _check_host_signatures()
        lib = _library()
        a = {name: ctypes.cast(getattr(lib, name), ctypes.c_void_p).value for name in _HOST_FUNCTIONS}
    except Exception as exc:  # anything: the compiled host is an optimisation, the Python host stays
        return None, f"{type(exc).__name__}: {exc}"
    return HostFunctions(step=a["mj_step"], kinematics=a["mj_kinematics"], get_state=a["mj_getState"],
                         set_state=a["mj_setState"], jac=a["mj_jac"], solve_m=a["mj_solveM"]), None


def host_functions() -> Optional[HostFunctions]:
    """The user-world host's entry points, or ``None`` where the C API is unavailable (:func:`layout` is ``None``,
    or a declaration differs from the signature the host kernels call: :func:`host_unavailable` says which)."""
    return _cached_host()[0]


def host_unavailable() -> Optional[str]:
    """Why :func:`host_functions` is ``None`` (``None`` when it is available)."""
    return _cached_host()[1]
