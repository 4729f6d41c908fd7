"""A user world's host substeps in compiled code: :meth:`mjcable.backends.host.Host.substeps` (read its module
docstring for the coupling scheme) with every MuJoCo call made through MuJoCo's C API, ``n`` substeps per call and no
Python between them.

Per substep, as the Python host and in its order (h the substep, P the body pins, p0 / p1 a pin's body point before
and after the host's step, b_free its trial position):

1. pin targets x_to = from + ((k + 1) / n) (to − from) (grippers move linearly);
2. per body pin: ``mj_jac`` at p0, n = (x_q − x_p) / max(|x_q − x_p|, 1e-12) (q the neighbour), jn = nᵀ J,
   ``mj_solveM`` → w_b = jn · M⁻¹ jnᵀ (:func:`pin_axis_jacobian`, :func:`dot`); the trial step ``mj_getState``,
   ``mj_step``, ``mj_kinematics``, read b_free and turn the clamps' body-frame directions (:func:`turn_clamp`),
   ``mj_setState``; the particle predicted at b_free with inverse mass w_b (0 where w_b ≤ ``RIGID``);
3. the solver's substep (:func:`mjcable.solvers.kernels.run_substeps_flat`, one whole substep: called, not inlined,
   so that its compiled code, cached, serves here too; its integer arguments are passed as ``np.int64`` values, not
   literals, which numba would type ``Literal[int]`` and compile the whole driver a second time for, about 40 s);
4. F = (x_p − b_free) / (w_b h h) + m_p g on each moving pin (−pin_force on a rigid one), added with its moment
   (p0 − xipos) × F to ``xfrc_applied``; the contacts' −Σ j / h² on the world's dynamic bodies
   (:func:`mjcable.solvers.contact_kernels.body_wrenches`); ``mj_step``; both taken off ``xfrc_applied`` again;
   ``mj_kinematics``; the moving obstacles' shapes from ``geom_xpos``/``geom_xmat``; x_p = p1, v_p = (p1 − p0) / h;
5. MuJoCo's divergence warnings (``BADQACC``, ``BADQPOS``, ``BADQVEL``: their counts in ``mjData.warning``, read
   through the bindings' numpy view) end the call at that substep, their counts zeroed, as the Python host does.

Every floating-point operation is the Python host's, in its order (no fused multiply-adds: numba emits none without
``fastmath``), and the reductions the two share are these kernels (the Python host calls them too), so that both
paths give the same results bit for bit (``tests/test_host_compiled.py``).

MuJoCo's C functions are called by address (:func:`mjcable.solvers.capi.host_functions`: the ``libmujoco`` the
bindings loaded), one small intrinsic per C signature; addresses are runtime integers, so the compiled code caches.

Caveat: MuJoCo's *warnings* inside these calls are fine (they print through MuJoCo's handler and count in
``mjData.warning``), but a MuJoCo *error* (``mju_error``, e.g. the arena running out of memory) cannot become a Python
exception here: the bindings turn errors into exceptions only around their own calls, so a call by address meets
MuJoCo's default handler, which prints the error and ends the process (measured). The host therefore takes the first step after each reset in Python (an error of the starting
state, such as a model whose arena is too small, is then the bindings' ``mujoco.FatalError``); an error that only
a later state meets is not guarded.
"""

from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from mjcable.solvers import contact_kernels
from mjcable.solvers._kernel_cache import inline as _inline, jit as _jit, nogil as _nogil
from mjcable.solvers.kernels import PHASE_ALL, PS_F, SH_POS, SH_ROT, run_substeps_flat
from mjcable.solvers.query_kernels import _call_model_data

__all__ = ["host_substeps", "pin_axis_jacobian", "dot", "turn_clamp", "RIGID", "HC", "N_HC", "LK", "N_LK"]

RIGID = 1e-12  # 1/kg: a body point lighter to move than this is held fixed (a body welded to the world)
_TINY_AXIS = 1e-12  # m: the pin-to-neighbour distance below which the axis is not normalised further

# Entries of host_substeps' ``capi`` (int64): the addresses of mj_step, mj_kinematics, mj_getState, mj_setState,
# mj_jac, mj_solveM (mjcable.solvers.capi.HostFunctions), of the world's mjModel and mjData, the state signature
# (mjSTATE_INTEGRATION), nv and the state's size (mj_stateSize).
HC = dict(step=0, kinematics=1, get_state=2, set_state=3, jac=4, solve_m=5, model=6, data=7, sig=8, nv=9, nstate=10)
(_HC_STEP, _HC_KINEMATICS, _HC_GET_STATE, _HC_SET_STATE, _HC_JAC, _HC_SOLVE_M, _HC_MODEL, _HC_DATA, _HC_SIG, _HC_NV,
 _HC_NSTATE) = range(11)
N_HC = len(HC)
# Columns of host_substeps' ``links`` (P, 5) int64, per body pin: the pin's index, its particle, the particle's
# neighbour along the cable, the body and the anchor site.
LK = dict(pin=0, particle=1, neighbour=2, body=3, site=4)
_LK_PIN, _LK_PARTICLE, _LK_NEIGHBOUR, _LK_BODY, _LK_SITE = range(5)
N_LK = len(LK)


# -- MuJoCo's C functions by address, one intrinsic per signature --------------------------------------------------


def _is_f64_c(t) -> bool:
    return isinstance(t, types.Array) and t.dtype == types.float64 and t.layout == "C"


def _data_pointer(context, builder, array_type, value):
    """The ``i8*`` to an array argument's first element."""
    data = context.make_array(array_type)(context, builder, value=value).data
    return builder.bitcast(data, ir.IntType(8).as_pointer())


@intrinsic
def _call_state(typingctx, fn, model, data, state, sig):
    """``void fn(const mjModel* model, [const] mjData* data, mjtNum* state, int sig)`` at address ``fn``
    (``mj_getState``, ``mj_setState``): ``state`` a C-contiguous float64 array of ``mj_stateSize(sig)``."""
    if not (all(isinstance(a, types.Integer) for a in (fn, model, data, sig)) and _is_f64_c(state)):
        return None

    def codegen(context, builder, signature, args):
        i8p, i32 = ir.IntType(8).as_pointer(), ir.IntType(32)
        address, m, d = (context.cast(builder, a, t, types.intp) for a, t in zip(args[:3], signature.args[:3]))
        s = context.cast(builder, args[4], signature.args[4], types.int32)
        function = ir.FunctionType(ir.VoidType(), [i8p, i8p, i8p, i32])
        builder.call(builder.inttoptr(address, function.as_pointer()),
                     [builder.inttoptr(m, i8p), builder.inttoptr(d, i8p),
                      _data_pointer(context, builder, signature.args[3], args[3]), s])
        return context.get_dummy_value()

    return types.void(fn, model, data, state, sig), codegen


@intrinsic
def _call_jac(typingctx, fn, model, data, jacp, point, body):
    """``void fn(const mjModel*, const mjData*, mjtNum* jacp, mjtNum* jacr, const mjtNum point[3], int body)`` at
    address ``fn`` (``mj_jac``) with ``jacr`` NULL: ``jacp`` (3, nv) and ``point`` (3,) C-contiguous float64."""
    if not (all(isinstance(a, types.Integer) for a in (fn, model, data, body)) and _is_f64_c(jacp)
            and _is_f64_c(point)):
        return None

    def codegen(context, builder, signature, args):
        i8p, i32 = ir.IntType(8).as_pointer(), ir.IntType(32)
        address, m, d = (context.cast(builder, a, t, types.intp) for a, t in zip(args[:3], signature.args[:3]))
        b = context.cast(builder, args[5], signature.args[5], types.int32)
        function = ir.FunctionType(ir.VoidType(), [i8p, i8p, i8p, i8p, i8p, i32])
        builder.call(builder.inttoptr(address, function.as_pointer()),
                     [builder.inttoptr(m, i8p), builder.inttoptr(d, i8p),
                      _data_pointer(context, builder, signature.args[3], args[3]), ir.Constant(i8p, None),
                      _data_pointer(context, builder, signature.args[4], args[4]), b])
        return context.get_dummy_value()

    return types.void(fn, model, data, jacp, point, body), codegen


@intrinsic
def _call_solve(typingctx, fn, model, data, x, y, n):
    """``void fn(const mjModel*, mjData*, mjtNum* x, const mjtNum* y, int n)`` at address ``fn`` (``mj_solveM``):
    ``x``, ``y`` (n, nv) C-contiguous float64."""
    if not (all(isinstance(a, types.Integer) for a in (fn, model, data, n)) and _is_f64_c(x) and _is_f64_c(y)):
        return None

    def codegen(context, builder, signature, args):
        i8p, i32 = ir.IntType(8).as_pointer(), ir.IntType(32)
        address, m, d = (context.cast(builder, a, t, types.intp) for a, t in zip(args[:3], signature.args[:3]))
        rows = context.cast(builder, args[5], signature.args[5], types.int32)
        function = ir.FunctionType(ir.VoidType(), [i8p, i8p, i8p, i8p, i32])
        builder.call(builder.inttoptr(address, function.as_pointer()),
                     [builder.inttoptr(m, i8p), builder.inttoptr(d, i8p),
                      _data_pointer(context, builder, signature.args[3], args[3]),
                      _data_pointer(context, builder, signature.args[4], args[4]), rows])
        return context.get_dummy_value()

    return types.void(fn, model, data, x, y, n), codegen


# -- the arithmetic both host paths share ----------------------------------------------------------------------------


@_jit
def pin_axis_jacobian(x, p, q, jacp, jn):
    """jn (nv,) = nᵀ J: the body point's translational Jacobian ``jacp`` (3, nv) along the unit vector n from
    particle ``p`` to particle ``q`` of ``x`` (N, 3) (x_q − x_p divided by max(|x_q − x_p|, 1e-12) m)."""
    a0, a1, a2 = x[q, 0] - x[p, 0], x[q, 1] - x[p, 1], x[q, 2] - x[p, 2]
    scale = max(math.sqrt(a0 * a0 + a1 * a1 + a2 * a2), _TINY_AXIS)
    a0, a1, a2 = a0 / scale, a1 / scale, a2 / scale
    for k in range(jn.shape[0]):
        jn[k] = a0 * jacp[0, k] + a1 * jacp[1, k] + a2 * jacp[2, k]


@_jit
def dot(a, b):
    """Σ a_k b_k of two (n,) arrays, summed in order (1/kg for w_b = jn · M⁻¹ jnᵀ)."""
    total = 0.0
    for k in range(a.shape[0]):
        total += a[k] * b[k]
    return total


@_jit
def turn_clamp(xmat, body, local, clamp_dir, row):
    """A clamp's two directions from ``body``'s frame into the world: ``clamp_dir[row]`` (2, 3) = (R ``local``)ᵀ,
    R the body's rotation (row-major ``xmat[body]`` (9,)), ``local`` (3, 2)."""
    for k in range(2):
        for i in range(3):
            clamp_dir[row, k, i] = (xmat[body, 3 * i] * local[0, k] + xmat[body, 3 * i + 1] * local[1, k]
                                    + xmat[body, 3 * i + 2] * local[2, k])


# -- the driver ------------------------------------------------------------------------------------------------------


@_inline
def _mj_step(capi):
    _call_model_data(capi[_HC_STEP], capi[_HC_MODEL], capi[_HC_DATA])


@_inline
def _mj_kinematics(capi):
    _call_model_data(capi[_HC_KINEMATICS], capi[_HC_MODEL], capi[_HC_DATA])


@_nogil
def host_substeps(x, v, x0, w, mass, react, dx, count, rest, lam_s, rest_d, lam_d, lam_b, clamp_pq, clamp_pin,
                  clamp_dir, lam_c, pin_p, pin_from, pin_to, pin_active, pin_release, pin_force, pin_sum,
                  row_kind, row_idx, row_p, prow, pslot, band, grad, rhs, fric, anchor, anchor_ob, fp, ip, seg, geo,
                  lam, pair, sgeo, slam, shapes, impulse, n, h, capi, links, clamps, clamp_local, gravity,
                  site_xpos, xipos, xmat, xfrc_applied, geom_xpos, geom_xmat, warning_number, bad, moving,
                  obstacle_shapes, host_impulse, wrench_obstacles, wrench_bodies, contact_wrench):
    """``n`` host substeps of ``h`` seconds (see the module docstring) on the solver state and contacts
    (``*chain, *contacts`` as :func:`mjcable.solvers.kernels.run_substeps_flat`) and the user world.

    Args:
      n, h: substeps and the substep (s).
      capi: (N_HC,) int64, the C entry points, model and data (``HC``).
      links: (P, N_LK) int64, the body pins (``LK``).
      clamps, clamp_local: (K, 2) int64 [row of ``clamp_dir``, body] and (K, 3, 2) the clamps' directions in their
        bodies' frames.
      gravity: (3,) m/s².
      site_xpos, xipos, xmat, xfrc_applied, geom_xpos, geom_xmat, warning_number: the world's ``mjData`` views
        (``warning_number`` is ``mjData.warning.number``).
      bad: (W,) int64, the warnings that end the call (``mjtWarning`` codes, first reported first).
      moving: (G, 2) int64 [geom, row of ``obstacle_shapes``] of the obstacles on moving bodies.
      obstacle_shapes: (B, N_SH) the obstacles' shapes to refresh (the contacts' ``shapes``).
      host_impulse: (B, 6) or (0, 6) the contacts' impulses summed per substep (``impulse``; empty: no two-way
        contacts).
      wrench_obstacles, wrench_bodies, contact_wrench: (R,) int64 the obstacle rows on dynamic bodies and their
        bodies, and (nbody, 6) the last substep's contact wrench per body (N, N·m).

    Returns:
      (all positions and velocities finite, sockets released, the first ``bad`` warning that MuJoCo counted, or −1).
    """
    npin = links.shape[0]
    nv = capi[_HC_NV]
    start_from, start_to = pin_from.copy(), pin_to.copy()
    target = np.empty_like(start_from)
    p0 = np.empty((npin, 3))
    arm = np.empty((npin, 3))
    free = np.empty((npin, 3))
    free_w = np.empty(npin)
    f = np.empty((npin, 3))
    applied = np.empty((npin, 6))
    saved = np.empty(capi[_HC_NSTATE])
    jacp = np.empty((3, nv))
    jn = np.empty((1, nv))
    solved = np.empty((1, nv))
    coupled = npin > 0
    two_way = host_impulse.shape[0] > 0
    scale = -1.0 / (h * h)
    finite, released = True, 0
    for sub in range(n):
        frac = (sub + 1.0) / n
        for i in range(target.shape[0]):
            for c in range(3):
                target[i, c] = start_from[i, c] + frac * (start_to[i, c] - start_from[i, c])
        if coupled:
            for j in range(npin):
                b, s = links[j, _LK_BODY], links[j, _LK_SITE]
                for c in range(3):
                    p0[j, c] = site_xpos[s, c]
                    arm[j, c] = p0[j, c] - xipos[b, c]
            for j in range(npin):  # the body's inverse mass at its point along the cable
                _call_jac(capi[_HC_JAC], capi[_HC_MODEL], capi[_HC_DATA], jacp, p0[j], links[j, _LK_BODY])
                pin_axis_jacobian(x, links[j, _LK_PARTICLE], links[j, _LK_NEIGHBOUR], jacp, jn[0])
                _call_solve(capi[_HC_SOLVE_M], capi[_HC_MODEL], capi[_HC_DATA], solved, jn, 1)
                w_b = dot(jn[0], solved[0])
                free_w[j] = w_b if w_b > RIGID else 0.0
            _call_state(capi[_HC_GET_STATE], capi[_HC_MODEL], capi[_HC_DATA], saved, capi[_HC_SIG])
            _mj_step(capi)
            _mj_kinematics(capi)
            for j in range(npin):
                s = links[j, _LK_SITE]
                for c in range(3):
                    free[j, c] = site_xpos[s, c]
            for k in range(clamps.shape[0]):
                turn_clamp(xmat, clamps[k, 1], clamp_local[k], clamp_dir, clamps[k, 0])
            _call_state(capi[_HC_SET_STATE], capi[_HC_MODEL], capi[_HC_DATA], saved, capi[_HC_SIG])
            for j in range(npin):
                for c in range(3):
                    target[links[j, _LK_PIN], c] = free[j, c]
                w[links[j, _LK_PARTICLE]] = free_w[j]
        for i in range(target.shape[0]):
            for c in range(3):
                pin_to[i, c] = target[i, c]
        if two_way:
            host_impulse[:] = 0.0
        ok, got = run_substeps_flat(x, v, x0, w, mass, react, dx, count, rest, lam_s, rest_d, lam_d, lam_b, clamp_pq,
                                    clamp_pin, clamp_dir, lam_c, pin_p, pin_from, pin_to, pin_active, pin_release,
                                    pin_force, pin_sum, row_kind, row_idx, row_p, prow, pslot, band, grad, rhs, fric,
                                    anchor, anchor_ob, fp, ip, seg, geo, lam, pair, sgeo, slam, shapes, impulse,
                                    np.int64(1), np.int64(PHASE_ALL), np.int64(0))
        finite = finite and ok
        released += got
        if coupled:
            for j in range(npin):
                k, p = links[j, _LK_PIN], links[j, _LK_PARTICLE]
                if free_w[j] > 0.0:  # the cable's pull on the body, F + m_p g; the pin holds the particle with −F
                    denom = free_w[j] * h * h
                    for c in range(3):
                        f[j, c] = (x[p, c] - free[j, c]) / denom
                    for c in range(3):
                        f[j, c] += mass[p] * gravity[c]
                    for c in range(3):
                        pin_sum[k, PS_F + c] += -f[j, c] - pin_force[k, c]
                        pin_force[k, c] = -f[j, c]
                else:
                    for c in range(3):
                        f[j, c] = -pin_force[k, c]
            for j in range(npin):
                for c in range(3):
                    applied[j, c] = f[j, c]
                applied[j, 3] = arm[j, 1] * f[j, 2] - arm[j, 2] * f[j, 1]
                applied[j, 4] = arm[j, 2] * f[j, 0] - arm[j, 0] * f[j, 2]
                applied[j, 5] = arm[j, 0] * f[j, 1] - arm[j, 1] * f[j, 0]
            for j in range(npin):
                b = links[j, _LK_BODY]
                for c in range(6):
                    xfrc_applied[b, c] += applied[j, c]
        if two_way:
            contact_kernels.body_wrenches(host_impulse, wrench_obstacles, wrench_bodies, xipos, scale,
                                          contact_wrench, xfrc_applied)
        _mj_step(capi)
        if coupled:
            for j in range(npin):
                b = links[j, _LK_BODY]
                for c in range(6):
                    xfrc_applied[b, c] -= applied[j, c]
        if two_way:
            for b in range(xfrc_applied.shape[0]):
                for c in range(6):
                    xfrc_applied[b, c] -= contact_wrench[b, c]
        _mj_kinematics(capi)
        for r in range(moving.shape[0]):
            g, row = moving[r, 0], moving[r, 1]
            for c in range(3):
                obstacle_shapes[row, SH_POS + c] = geom_xpos[g, c]
            for c in range(9):
                obstacle_shapes[row, SH_ROT + c] = geom_xmat[g, c]
        if coupled:
            for j in range(npin):
                p, s = links[j, _LK_PARTICLE], links[j, _LK_SITE]
                for c in range(3):
                    x[p, c] = site_xpos[s, c]
                    v[p, c] = (site_xpos[s, c] - p0[j, c]) / h
        first = -1
        for k in range(bad.shape[0]):
            if warning_number[bad[k]] > 0:
                if first < 0:
                    first = bad[k]
                warning_number[bad[k]] = 0
        if first >= 0:
            return finite, released, first
    for i in range(pin_to.shape[0]):
        for c in range(3):
            pin_to[i, c] = start_to[i, c]
    if coupled:
        for j in range(npin):
            k, s = links[j, _LK_PIN], links[j, _LK_SITE]
            for c in range(3):
                pin_to[k, c] = site_xpos[s, c]
    return finite, released, -1
