"""A user world's host in compiled code: the coupling of :mod:`mjcable.backends.host` (read its module docstring for
the scheme) with every MuJoCo call made through MuJoCo's C API, in pieces that the step loop
(:func:`mjcable.solvers.kernels.run_steps`) calls around each solver substep: :func:`host_begin_step`,
:func:`host_before`, the solver's substep, :func:`host_after`, ..., :func:`host_end_step`.

Per substep (h the substep, P the body pins, p0 / p1 a pin's body point before and after the host's step, b_free
its trial position):

1. pin targets x_to = from + ((k + 1) / n) (to − from) (grippers move linearly);
2. per body pin: ``mj_jac`` at p0, n = (x_q − x_p) / max(|x_q − x_p|, 1e-12) (q the neighbour; a body ring's hub:
   n its pull, ``ring_dir``), jn = nᵀ J,
   ``mj_solveM`` → w_b = jn · M⁻¹ jnᵀ (:func:`pin_axis_jacobian`, :func:`dot`), per body clamp its body's
   W = J_r M⁻¹ J_rᵀ (:func:`_clamp_inertias`: the clamp turns with it in the solve); the trial step ``mj_getState``,
   ``mj_step``, ``mj_kinematics``, read b_free and turn the clamps' body-frame directions (:func:`turn_clamp`),
   ``mj_setState``; the particle predicted at b_free with inverse mass w_b (0 where w_b ≤ ``RIGID``);
3. the solver's substep (one whole substep, the pins at this substep's targets);
4. F = (x_p − b_free) / (w_b h h) + m_p g on each moving pin (−pin_force on a rigid one), added with its moment
   (p0 − xipos) × F (and a body clamp's torque, ``clamp_react`` / h²) to ``xfrc_applied``; the contacts' −Σ j / h²
   on the world's dynamic bodies (:func:`mjcable.solvers.impulse_kernels.body_wrenches`); ``mj_step``; both taken
   off ``xfrc_applied`` again;
   ``mj_kinematics``; the moving obstacles' shapes from ``geom_xpos``/``geom_xmat``; x_p = p1, v_p = (p1 − p0) / h;
5. MuJoCo's divergence warnings (``BADQACC``, ``BADQPOS``, ``BADQVEL``: their counts in ``mjData.warning``, read
   through the bindings' numpy view) stop the step at that substep, their counts zeroed.

MuJoCo's C functions are called by address (:func:`mjcable.solvers.capi.host_functions`: the ``libmujoco`` the
bindings loaded), one small intrinsic per C signature; addresses are runtime integers, so the compiled code caches.
MuJoCo's *warnings* inside these calls are fine (they print through MuJoCo's handler and count in
``mjData.warning``), but a MuJoCo *error* (``mju_error``, e.g. the arena running out of memory) ends the process: the
bindings turn errors into exceptions only around their own calls. The backend therefore steps the world once through
the bindings at construction and reset (state restored after), so that an error of the starting state is the
bindings' ``mujoco.FatalError``; an error that only a later state meets is not guarded.
"""

from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from mjcable.solvers import impulse_kernels
from mjcable.solvers._kernel_cache import inline as _inline, jit as _jit
from mjcable.solvers.cosserat_kernels import _qmul, _rotation
from mjcable.solvers.cosserat_step_kernels import clamp_frames
from mjcable.solvers.query_kernels import _call_model_data, refresh_moving

__all__ = ["host_begin_step", "host_before", "host_after", "host_end_step", "pin_axis_jacobian", "dot", "turn_clamp",
           "RIGID"]

RIGID = 1e-12  # 1/kg: a body point lighter to move than this is held fixed (a body welded to the world)
_TINY_AXIS = 1e-12  # m: the pin-to-neighbour distance below which the axis is not normalised further

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
def _call_jac(typingctx, fn, model, data, jacp, jacr, point, body):
    """``void fn(const mjModel*, const mjData*, mjtNum* jacp, mjtNum* jacr, const mjtNum point[3], int body)`` at
    address ``fn`` (``mj_jac``): ``jacp``, ``jacr`` (3, nv) and ``point`` (3,) C-contiguous float64."""
    if not (all(isinstance(a, types.Integer) for a in (fn, model, data, body)) and _is_f64_c(jacp)
            and _is_f64_c(jacr) and _is_f64_c(point)):
        return None

    def codegen(context, builder, signature, args):
        i8p, i32 = ir.IntType(8).as_pointer(), ir.IntType(32)
        address, m, d = (context.cast(builder, a, t, types.intp) for a, t in zip(args[:3], signature.args[:3]))
        b = context.cast(builder, args[6], signature.args[6], types.int32)
        function = ir.FunctionType(ir.VoidType(), [i8p, i8p, i8p, i8p, i8p, i32])
        builder.call(builder.inttoptr(address, function.as_pointer()),
                     [builder.inttoptr(m, i8p), builder.inttoptr(d, i8p)]
                     + [_data_pointer(context, builder, signature.args[k], args[k]) for k in (3, 4, 5)] + [b])
        return context.get_dummy_value()

    return types.void(fn, model, data, jacp, jacr, point, body), codegen


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
def axis_jacobian(n, jacp, jn):
    """jn (nv,) = nᵀ J along the unit vector ``n`` (3,) (a body ring's pull, ``ring_dir``)."""
    for k in range(jn.shape[0]):
        jn[k] = n[0] * jacp[0, k] + n[1] * jacp[1, k] + n[2] * jacp[2, k]


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


@_jit
def _clamp_inertias(S, P):
    """Per body clamp k, its body's inverse rotational inertia in the world, W = J_r M⁻¹ J_rᵀ (``mj_jac``'s
    rotational Jacobian, ``mj_solveM``; 0 where its trace is at most ``RIGID``), into ``clamp_wq[row]`` (a rod's:
    :func:`_clamp_free_frames` turns it into the clamp's frame), and the torque it collects, ``clamp_react[row]``,
    zeroed."""
    jacr, solved = S.jacr, S.solved_r
    for k in range(S.link_clamp.shape[0]):
        row, b = S.link_clamp[k, 0], S.link_clamp[k, 1]
        _call_jac(P.fn_jac, P.model, P.data, S.jacp, jacr, S.xipos[b], b)
        _call_solve(P.fn_solve_m, P.model, P.data, solved, jacr, 3)
        W = S.clamp_wq[row]
        for a in range(3):
            for c in range(3):
                W[a, c] = dot(jacr[a], solved[c])
        if W[0, 0] + W[1, 1] + W[2, 2] <= RIGID:  # a body that does not turn
            W[:, :] = 0.0
        S.clamp_react[row, 0] = S.clamp_react[row, 1] = S.clamp_react[row, 2] = 0.0


@_jit
def _clamp_free_frames(S):
    """After the trial step: each rod body clamp's frame where its body went, q_c = q_body ⊗ ``clamp_qlocal``, and its
    inverse inertia turned into that frame, D_c = R_cᵀ W R_c (0 where W's trace is at most ``RIGID``: a body that
    does not turn)."""
    xquat, cq = S.xquat, S.clamp_q
    R = np.empty((3, 3))
    T = np.empty((3, 3))
    for k in range(S.clamp_qlocal.shape[0]):
        row, b = S.link_clamp[k, 0], S.link_clamp[k, 1]
        a, l = xquat[b], S.clamp_qlocal[k]
        cq[row, 0], cq[row, 1], cq[row, 2], cq[row, 3] = _qmul(a[0], a[1], a[2], a[3], l[0], l[1], l[2], l[3])
        W = S.clamp_wq[row]
        if W[0, 0] + W[1, 1] + W[2, 2] <= RIGID:
            W[:, :] = 0.0
            continue
        _rotation(cq, row, R)
        for i in range(3):  # T = W R
            for c in range(3):
                T[i, c] = W[i, 0] * R[0, c] + W[i, 1] * R[1, c] + W[i, 2] * R[2, c]
        for i in range(3):  # D = Rᵀ T
            for c in range(3):
                W[i, c] = R[0, i] * T[0, c] + R[1, i] * T[1, c] + R[2, i] * T[2, c]


# -- the host's pieces of a step (kernels.run_steps calls them around each solver substep) ----------------------


@_inline
def _mj_step(P):
    _call_model_data(P.fn_step, P.model, P.data)


@_inline
def _mj_kinematics(P):
    _call_model_data(P.fn_kinematics, P.model, P.data)


@_jit
def host_begin_step(S):
    """A step's start: the pins' targets at the step's start and end (``start_from``, ``start_to``), from which
    every substep's are interpolated."""
    S.start_from[:, :] = S.pin_from
    S.start_to[:, :] = S.pin_to


@_jit
def host_before(S, sub, n):
    """Before the solver's substep ``sub`` of ``n`` (steps 1–2 of the module docstring): the pins' targets for the
    substep, and per body pin its inverse mass along the cable w_b, the trial step's free path b_free (the particle's
    target, its inverse mass w_b; 0 where w_b ≤ ``RIGID``) and the clamps turned with their bodies; the contacts'
    impulse sums zeroed."""
    P = S.par[0]
    x, w = S.x, S.w
    start_from, start_to, target = S.start_from, S.start_to, S.target
    link_pin, link_particle, link_neighbour, link_body, link_site = (S.link_pin, S.link_particle, S.link_neighbour,
                                                                     S.link_body, S.link_site)
    site_xpos, xipos, p0, arm, free, free_w = S.site_xpos, S.xipos, S.p0, S.arm, S.free, S.free_w
    npin = link_pin.shape[0]
    frac = (sub + 1.0) / n
    for i in range(target.shape[0]):
        for c in range(3):
            target[i, c] = start_from[i, c] + frac * (start_to[i, c] - start_from[i, c])
    if npin:
        for j in range(npin):
            b, s = link_body[j], link_site[j]
            for c in range(3):
                p0[j, c] = site_xpos[s, c]
                arm[j, c] = p0[j, c] - xipos[b, c]
        for j in range(npin):  # the body's inverse mass at its point along the cable
            _call_jac(P.fn_jac, P.model, P.data, S.jacp, S.jacr, p0[j], link_body[j])
            if link_neighbour[j] >= 0:
                pin_axis_jacobian(x, link_particle[j], link_neighbour[j], S.jacp, S.jn[0])
            else:  # a body ring's hub: along the cable's pull on the ring (ring_kernels)
                axis_jacobian(S.ring_dir[-1 - link_neighbour[j]], S.jacp, S.jn[0])
            _call_solve(P.fn_solve_m, P.model, P.data, S.solved, S.jn, 1)
            w_b = dot(S.jn[0], S.solved[0])
            free_w[j] = w_b if w_b > RIGID else 0.0
        if S.link_clamp.shape[0]:  # body clamps: the bodies' inverse rotational inertias, the torques zeroed
            _clamp_inertias(S, P)
        _call_state(P.fn_get_state, P.model, P.data, S.saved, P.state_sig)
        _mj_step(P)
        _mj_kinematics(P)
        for j in range(npin):
            s = link_site[j]
            for c in range(3):
                free[j, c] = site_xpos[s, c]
        for k in range(S.link_clamp.shape[0]):
            turn_clamp(S.xmat, S.link_clamp[k, 1], S.clamp_local[k], S.clamp_dir, S.link_clamp[k, 0])
        if S.q.shape[0]:  # a rod's clamped frames: slerped (grippers, the world's), then the body clamps' free frames
            clamp_frames(S, frac)
            if S.clamp_qlocal.shape[0]:
                _clamp_free_frames(S)
        _call_state(P.fn_set_state, P.model, P.data, S.saved, P.state_sig)
        for j in range(npin):
            for c in range(3):
                target[link_pin[j], c] = free[j, c]
            w[link_particle[j]] = free_w[j]
    elif S.q.shape[0]:
        clamp_frames(S, frac)
    pin_to = S.pin_to
    for i in range(target.shape[0]):
        for c in range(3):
            pin_to[i, c] = target[i, c]
    if S.impulse_force.shape[0]:
        S.impulse_force[:] = 0.0
        S.impulse_moment[:] = 0.0


@_jit
def host_after(S):
    """After the solver's substep (steps 4–5 of the module docstring): the cable's pull on each body pin's body and
    the contacts' reactions on the dynamic bodies through ``xfrc_applied``, the world's ``mj_step``, the moving
    obstacles' shapes, the pinned particles where their body points went. Returns whether one of MuJoCo's
    divergence warnings (``S.bad``) stopped the step: the first goes to ``par.warning``, their counts zeroed."""
    P = S.par[0]
    h = P.h
    x, v, mass, pin_force, pin_sum = S.x, S.v, S.mass, S.pin_force, S.pin_sum
    link_pin, link_particle, link_body, link_site = S.link_pin, S.link_particle, S.link_body, S.link_site
    site_xpos, xfrc_applied, p0, arm, free, free_w, f, applied = (S.site_xpos, S.xfrc_applied, S.p0, S.arm, S.free,
                                                                  S.free_w, S.force, S.applied)
    npin = link_pin.shape[0]
    two_way = S.impulse_force.shape[0] > 0
    gravity = (P.gx, P.gy, P.gz)
    if npin:
        for j in range(npin):
            k, p = link_pin[j], link_particle[j]
            if free_w[j] > 0.0:  # the cable's pull on the body, F + m_p g; the pin holds the particle with −F
                denom = free_w[j] * h * h
                for c in range(3):
                    f[j, c] = (x[p, c] - free[j, c]) / denom
                for c in range(3):
                    f[j, c] += mass[p] * gravity[c]
                for c in range(3):  # the kernel counted −m g for the pin (its particle was free): −F instead
                    pin_sum[k, c] += -f[j, c] - pin_force[k, c]
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
        for k in range(S.link_clamp.shape[0]):  # a body clamp: the torque the clamp gave its body, +clamp_react / h²
            row = S.link_clamp[k, 0]
            for j in range(npin):
                if link_pin[j] == S.clamp_pin[row]:
                    for c in range(3):
                        applied[j, 3 + c] += S.clamp_react[row, c] / (h * h)
        for j in range(npin):
            b = link_body[j]
            for c in range(6):
                xfrc_applied[b, c] += applied[j, c]
    if two_way:
        impulse_kernels.body_wrenches(S, -1.0 / (h * h))
    _mj_step(P)
    if npin:
        for j in range(npin):
            b = link_body[j]
            for c in range(6):
                xfrc_applied[b, c] -= applied[j, c]
    if two_way:
        for b in range(xfrc_applied.shape[0]):
            for c in range(6):
                xfrc_applied[b, c] -= S.contact_wrench[b, c]
    _mj_kinematics(P)
    refresh_moving(S)
    for j in range(npin):
        p, s = link_particle[j], link_site[j]
        for c in range(3):
            x[p, c] = site_xpos[s, c]
            v[p, c] = (site_xpos[s, c] - p0[j, c]) / h
    first = -1
    bad, warning_number = S.bad, S.warning_number
    for k in range(bad.shape[0]):
        if warning_number[bad[k]] > 0:
            if first < 0:
                first = bad[k]
            warning_number[bad[k]] = 0
    P.warning = first
    return first >= 0


@_jit
def host_end_step(S):
    """A step's end: the pins' targets back to the step's end target, a body pin's at its body point now."""
    pin_to = S.pin_to
    pin_to[:, :] = S.start_to
    for j in range(S.link_pin.shape[0]):
        k, s = S.link_pin[j], S.link_site[j]
        for c in range(3):
            pin_to[k, c] = S.site_xpos[s, c]
