"""Hot loops of the particle solvers: the substep and step drivers and (re-exported) every projection they call.

Every constraint type has one small pure scalar function (differences of positions, inverse masses, rest value,
compliance, λ → Δλ and the correction scale) citing its paper and equation, and one sweep that applies it to
all constraints of that type. One formula serves the three solvers, the XPBD update of Macklin et al. 2016,
Eqs. (17)–(18)::

    Δλ = k · (−C − α̃ λ) / (Σⱼ wⱼ |∇ⱼC|² + α̃),   Δxⱼ = wⱼ ∇ⱼC Δλ,   α̃ = α / h²

with k = 1 for XPBD; α = 0 gives PBD's projection (thesis Eqs. 2.11–2.12; Müller et al. 2007) with its
stiffness k, and Jakobsen's mass-weighted stick (Jakobsen 2001, "Cloth simulation", the ``invmass`` form).
Held particles (pins) have w = 0; the ∇C Δλ they would receive is summed in ``react`` so that the pin force is
known (XPBD's constraint force estimate ∇Cᵀ λ / h², Macklin et al. 2016); sockets decide on its mean over the
step's substeps (the step's impulse / dt, :func:`end_substep`).

Performance notes (measured, numba 0.68, 100 particles): a per-constraint helper that takes arrays ran 3× slower
than the same arithmetic written inline, even with ``inline="always"``, and every call passing the 33-array state
costs microseconds (reference counting per array argument). So the per-constraint functions take and return
scalars only, the hot sweeps and the substep pieces are inlined into the drivers, the rarely used sweeps are called
only when they have work (and a chain with stretch constraints only, Gauss-Seidel order and no obstacles takes
:func:`plain_substep`, the same pieces without the other branches, which cost a third of its time), and the drivers
take the arrays as separate arguments: ``run_substeps_flat`` (one step) and ``run_steps_flat`` (many whole steps
with the Simulator's divergence checks and the contact queries, the grippers following a path if given: one call
per ``step(T)`` or ``step_along(path)``). ``error_model="numpy"``: a division by zero gives inf/NaN (caught as
divergence). Numba
caches per file, but :mod:`mjcable.solvers._kernel_cache` stamps every kernel file's cache with all kernel
files, so the drivers here call projections from sibling files: :mod:`~mjcable.solvers.constraint_kernels`
(sweeps), :mod:`~mjcable.solvers.direct_kernels` (the direct order) and :mod:`~mjcable.solvers.kernels_layout`
(indices, codes, :class:`Chain`, :class:`Contacts`); this module re-exports them.

References:
  [J01] T. Jakobsen, "Advanced Character Physics", GDC 2001 (in ``shared/seeds``).
  [M07] M. Müller, B. Heidelberger, M. Hennix, J. Ratcliff, "Position Based Dynamics", JVCIR 18(2), 2007.
  [M16] M. Macklin, M. Müller, N. Chentanez, "XPBD: Position-Based Simulation of Compliant Constrained
        Dynamics", MIG 2016.
  [M20] M. Müller, M. Macklin, N. Chentanez, S. Jeschke, T.-Y. Kim, "Detailed Rigid Body Simulation with Extended
        Position Based Dynamics", SCA 2020.
  [M14] M. Macklin, M. Müller, N. Chentanez, T.-Y. Kim, "Unified Particle Physics for Real-Time Applications",
        SIGGRAPH 2014 (Jacobi iterations with constraint averaging and over-relaxation ω).
  [D18] C. Deul, T. Kugelstadt, M. Weiler, J. Bender, "Direct Position-Based Solver for Stiff Rods", CGF 2018.
  [T20] the thesis "Physical Experiments in School with Unity: Cable Simulation", Mainz 2020 (``shared/seeds``).
"""

from __future__ import annotations

import math

from mjcable.solvers._kernel_cache import inline as _inline, jit as _jit, nogil as _nogil
# The projections, the direct order and the layout, re-exported: callers keep importing them from here.
from mjcable.solvers.constraint_kernels import (
    _bend_clamp_sweeps, clamp_sweep, curvature_sweep,  # noqa: F401
    stretch_step, stretch_step_rigid, stretch_step_sqrt, stretch_sweep, xpbd_multiplier,  # noqa: F401
)
from mjcable.solvers.contact_kernels import (
    collect_impulses, contact_sweep, friction_sweep, self_contact_sweep, shape_distance,  # noqa: F401
    update_anchors,  # noqa: F401
)
from mjcable.solvers.query_kernels import find_self_contacts, query_obstacles
from mjcable.solvers.direct_kernels import (
    _DIRECT_CONTRACTION, _DIRECT_MAX_SOLVES, _DIRECT_REGULARIZATION, _DIRECT_RESIDUAL_FLOOR,  # noqa: F401
    _direct_apply, _direct_linearise, _direct_relinearise, _direct_within, _distance_rows_within,  # noqa: F401
    banded_ldlt_solve, direct_solve,  # noqa: F401
)
from mjcable.solvers.kernels_layout import (
    _F_ALPHA_B, _F_ALPHA_C, _F_ALPHA_S, _F_DAMP, _F_GX, _F_GY, _F_GZ, _F_H, _F_INV_L0SQ, _F_K_B,  # noqa: F401
    _F_K_C, _F_K_S, _F_OMEGA, _F_RADIUS, _I_BEND, _I_BW, _I_DIRECT_ALL, _I_ITER, _I_ORDER, _I_SQRT,  # noqa: F401
    _I_SUBSTEPS, N_PS, PS_F, PS_N,  # noqa: F401
    _F_MU_SELF, _L_DISTANCE, _L_DT, _L_FALL, _L_MARGIN, _L_RADIUS, _L_SPEED, _TINY_LENGTH, _TINY_SLIP,  # noqa: F401
    BEND_CURVATURE, BEND_DISTANCE, BEND_NONE, FP, IP, LIM, N_FP, N_IP, ORDER_DIRECT,  # noqa: F401
    ORDER_GAUSS_SEIDEL, ORDER_JACOBI, PHASE_ALL, PHASE_BEGIN, PHASE_END, PHASE_ITERATE, ROW_CLAMP,  # noqa: F401
    ROW_CURVATURE, ROW_DISTANCE, ROW_STRETCH, Chain, Contacts, IM_F, IM_M, N_FR, N_SH,  # noqa: F401
    SH_POS, SH_ROT, SH_SIZE, SH_TYPE, CAPI, CAPI_ENABLED, COUNT_CONTACTS, COUNT_QUERIES, COUNT_SELF, N_CAPI,  # noqa: F401
)

__all__ = ["Chain", "Contacts", "run_substeps", "run_substeps_flat", "run_steps_flat", "step_margin", "begin_substep",
           "iterate", "end_substep", "xpbd_multiplier", "stretch_step", "stretch_step_sqrt", "stretch_sweep",
           "curvature_sweep", "clamp_sweep", "contact_sweep", "friction_sweep", "self_contact_sweep", "direct_solve",
           "banded_ldlt_solve", "FP", "IP", "LIM", "is_plain", "plain_substep"]


# ---------------------------------------------------------------------------------------------------------------
# The substep: predict, iterate, update velocities.


@_inline
def _predict(x, v, x0, w, react, fp):
    """Predict: x₀ ← x, and for every free particle (w > 0) v ← e^{−c h} v + h g, x ← x + h v (semi-implicit
    Euler in velocity form; Verlet is the same recurrence with v read as (x − x_prev)/h, [T20] Eq. 2.7 with
    Jakobsen's damping); a held particle's (w = 0) reaction ``react`` ← 0. ``x``, ``v``, ``x0``, ``react`` (N, 3)
    m, m/s, kg·m; ``w`` (N,) 1/kg.

    Only held particles collect reactions (every sweep adds to ``react`` where w = 0, moves ``x`` elsewhere) and
    only pinned particles are ever held, so a free particle's row stays 0 without being zeroed every substep
    (:func:`_move_pins` zeroes the pins' rows, so a pin whose particle turned free keeps none either)."""
    h, damp = fp[_F_H], fp[_F_DAMP]
    gx, gy, gz = fp[_F_GX], fp[_F_GY], fp[_F_GZ]
    for p in range(x.shape[0]):
        x0[p, 0] = x[p, 0]
        x0[p, 1] = x[p, 1]
        x0[p, 2] = x[p, 2]
        if w[p] > 0.0:
            # damping multiplies the velocity before gravity is added: it never changes a static equilibrium
            v[p, 0] = damp * v[p, 0] + h * gx
            v[p, 1] = damp * v[p, 1] + h * gy
            v[p, 2] = damp * v[p, 2] + h * gz
            x[p, 0] += h * v[p, 0]
            x[p, 1] += h * v[p, 1]
            x[p, 2] += h * v[p, 2]
        else:
            react[p, 0] = 0.0
            react[p, 1] = 0.0
            react[p, 2] = 0.0


@_inline
def _move_pins(x, react, pin_p, pin_from, pin_to, pin_active, pin_sum, substeps, sub, n_sub):
    """Held particles to their pin targets, interpolated linearly across the step (substep ``sub`` of ``n_sub``
    reaches ``(sub + 1) / n_sub`` of the way from ``pin_from`` to ``pin_to`` (P, 3) m), every pinned particle's
    reaction ``react`` (N, 3) zeroed, and a pin's force sums (``pin_sum`` (P, N_PS)) zeroed when they hold a whole
    step's ``substeps`` (:func:`_pin_forces`)."""
    frac = (sub + 1.0) / n_sub
    for k in range(pin_p.shape[0]):
        q = pin_p[k]
        react[q, 0] = 0.0
        react[q, 1] = 0.0
        react[q, 2] = 0.0
        if pin_sum[k, PS_N] >= substeps:  # the last step's sums are complete: this substep starts a new step
            for col in range(N_PS):
                pin_sum[k, col] = 0.0
        if pin_active[k]:
            p = pin_p[k]
            for comp in range(3):
                x[p, comp] = pin_from[k, comp] + frac * (pin_to[k, comp] - pin_from[k, comp])


@_inline
def begin_substep(S, C, sub, n_sub):
    """Predict (:func:`_predict`), move held particles to their pin targets (interpolated linearly across the
    step) and, at a step's first substep, zero the pins' force sums (``pin_sum``, :func:`_move_pins`), and reset the
    multipliers (every substep, [M16] Algorithm 1)."""
    x = S.x
    _predict(x, S.v, S.x0, S.w, S.react, S.fp)
    _move_pins(x, S.react, S.pin_p, S.pin_from, S.pin_to, S.pin_active, S.pin_sum, S.ip[_I_SUBSTEPS], sub, n_sub)
    S.lam_s[:] = 0.0
    S.lam_d[:] = 0.0
    S.lam_b[:] = 0.0
    S.lam_c[:] = 0.0
    C.lam[:] = 0.0
    C.slam[:] = 0.0


@_jit
def _jacobi_counts(S):
    """Number of active chain constraints on each particle (Jacobi constraint averaging, [M14])."""
    cnt = S.count
    cnt[:] = 0.0
    n = S.rest.shape[0]
    for i in range(n):
        cnt[i] += 1.0
        cnt[i + 1] += 1.0
    bending = S.ip[_I_BEND]
    if bending == BEND_CURVATURE:
        for b in range(n - 1):
            cnt[b] += 1.0
            cnt[b + 1] += 1.0
            cnt[b + 2] += 1.0
    elif bending == BEND_DISTANCE:
        for b in range(n - 1):
            cnt[b] += 1.0
            cnt[b + 2] += 1.0
    for kc in range(S.clamp_pq.shape[0]):
        if S.pin_active[S.clamp_pin[kc]]:
            cnt[S.clamp_pq[kc, 0]] += 1.0
            cnt[S.clamp_pq[kc, 1]] += 1.0


@_inline
def iterate(S, C):
    """One constraint iteration in the configured order; contacts are projected sequentially last, so that they
    hold exactly when the iteration ends."""
    fp = S.fp
    h2 = fp[_F_H] * fp[_F_H]
    at_s, at_b, at_c = fp[_F_ALPHA_S] / h2, fp[_F_ALPHA_B] / h2, fp[_F_ALPHA_C] / h2
    k_s, k_b, k_c = fp[_F_K_S], fp[_F_K_B], fp[_F_K_C]
    order = S.ip[_I_ORDER]
    x, w = S.x, S.w
    bend_or_clamp = S.ip[_I_BEND] != BEND_NONE or S.clamp_pq.shape[0] > 0
    if order == ORDER_DIRECT:
        direct_solve(S, at_s, at_b, at_c, k_s, k_b, k_c)
        if not S.ip[_I_DIRECT_ALL] and bend_or_clamp:  # PBD/Jakobsen: only the stretch chain is solved directly
            _bend_clamp_sweeps(S, x, at_b, at_c, k_b, k_c)
    elif order == ORDER_JACOBI:
        dx = S.dx
        dx[:] = 0.0
        stretch_sweep(x, dx, w, S.react, S.rest, 1, at_s, S.lam_s, k_s, S.ip[_I_SQRT] != 0)
        if bend_or_clamp:
            _bend_clamp_sweeps(S, dx, at_b, at_c, k_b, k_c)
        _jacobi_counts(S)
        omega = fp[_F_OMEGA]
        cnt = S.count
        for p in range(x.shape[0]):
            if cnt[p] > 0.0 and w[p] > 0.0:
                f = omega / cnt[p]
                x[p, 0] += f * dx[p, 0]
                x[p, 1] += f * dx[p, 1]
                x[p, 2] += f * dx[p, 2]
    else:
        stretch_sweep(x, x, w, S.react, S.rest, 1, at_s, S.lam_s, k_s, S.ip[_I_SQRT] != 0)
        if bend_or_clamp:  # a call passing S costs microseconds: skip it when there is nothing to do
            _bend_clamp_sweeps(S, x, at_b, at_c, k_b, k_c)
    if C.seg.shape[0]:
        contact_sweep(x, w, S.react, S.fric, S.anchor_ob, C.seg, C.geo, C.lam, C.shapes, fp[_F_RADIUS])
        friction_sweep(x, S.x0, w, S.fric, S.anchor, S.anchor_ob, C.shapes)
    if C.pair.shape[0]:
        self_contact_sweep(x, S.x0, w, S.react, C.pair, C.sgeo, 2.0 * fp[_F_RADIUS], fp[_F_MU_SELF], C.slam)


@_inline
def end_substep(S, C):
    """Contact anchors (:func:`update_anchors`); v = (x − x₀)/h; the pins' forces; sockets let go. Returns the number
    released.

    A held particle's force, the force that holds it ([M16]'s force estimate ∇Cᵀλ / h²), in substep s:
    F_s = −Σ ∇C λ / h² − m g, from its reactions ``react`` (stretch, bending, clamp and contact shares); it goes
    to ``pin_force`` (the host's body pins couple through it every substep) and is added to ``pin_sum``. At the
    step's last substep (``pin_sum`` holds ``ip[substeps]`` of them) a socket lets go, with its clamp, if the
    step's mean force |F̄| = |Σ_s F_s| / n exceeds its release force. F̄ = J / dt, J = Σ_s F_s h the impulse the
    pin gave its particle over the step: the force that would give the same momentum held for the whole step, the
    quantity MuJoCo's constraint force of one step is (native sockets decide on it per step). A single substep's
    F_s is not: a positional solver settles a violation in one substep, so a contact that pushes a segment out of
    a moving body (the Jaco hand's finger tip, measured: 8.7 N at a cable segment 3 segments from the grip) leaves
    the chain over-long and the next substep's stretch solve pulls all of it, up to the socket 22 segments away,
    with 18 N for that 0.2 ms substep (3.6 mN·s, at 0.85 N before), a socket of 5 N let go at that spike at
    t = 0.67 s; the step's mean is 2.4 N, and the socket lets go at 0.76 s at 4.6 N, as the native models."""
    fp = S.fp
    x = S.x
    if C.shapes.shape[0]:
        if C.impulse.shape[0]:  # two-way contacts (a user world's bodies): before update_anchors zeroes the sums
            collect_impulses(x, S.w, S.fric, C.seg, C.geo, C.lam, C.shapes, fp[_F_RADIUS], C.impulse)
        update_anchors(x, S.fric, S.anchor, S.anchor_ob, C.shapes)
    _velocities(x, S.v, S.x0, 1.0 / fp[_F_H])
    return _pin_forces(S.w, S.mass, S.react, fp, S.pin_p, S.pin_active, S.pin_release, S.pin_force, S.pin_sum,
                       S.ip[_I_SUBSTEPS])


@_inline
def _velocities(x, v, x0, inv_h):
    """v = (x − x₀) / h for every particle (``x``, ``v``, ``x0`` (N, 3) m, m/s; ``inv_h`` 1/s)."""
    for p in range(x.shape[0]):
        v[p, 0] = (x[p, 0] - x0[p, 0]) * inv_h
        v[p, 1] = (x[p, 1] - x0[p, 1]) * inv_h
        v[p, 2] = (x[p, 2] - x0[p, 2]) * inv_h


@_inline
def _pin_forces(w, mass, react, fp, pin_p, pin_active, pin_release, pin_force, pin_sum, substeps):
    """The active pins' substep forces F_s = −``react`` / h² − m g (N) into ``pin_force`` (P, 3) and ``pin_sum``
    (P, N_PS); at the step's last substep (``pin_sum`` holds ``substeps`` of them) a socket whose mean force exceeds
    ``pin_release`` (P,) N lets go (its particle gets w = 1/m, ``pin_active`` False). Returns the number released
    (:func:`end_substep`)."""
    inv_h = 1.0 / fp[_F_H]
    inv_h2 = inv_h * inv_h
    released = 0
    for k in range(pin_p.shape[0]):
        if not pin_active[k]:
            continue
        p = pin_p[k]
        m = mass[p]
        fx = -react[p, 0] * inv_h2 - m * fp[_F_GX]
        fy = -react[p, 1] * inv_h2 - m * fp[_F_GY]
        fz = -react[p, 2] * inv_h2 - m * fp[_F_GZ]
        pin_force[k, 0], pin_force[k, 1], pin_force[k, 2] = fx, fy, fz
        pin_sum[k, PS_F] += fx
        pin_sum[k, PS_F + 1] += fy
        pin_sum[k, PS_F + 2] += fz
        pin_sum[k, PS_N] += 1.0
        if pin_sum[k, PS_N] >= substeps:
            n = pin_sum[k, PS_N]
            mx, my, mz = pin_sum[k, PS_F] / n, pin_sum[k, PS_F + 1] / n, pin_sum[k, PS_F + 2] / n
            if math.sqrt(mx * mx + my * my + mz * mz) > pin_release[k]:
                pin_active[k] = False
                w[p] = 1.0 / m
                released += 1
    return released


@_inline
def is_plain(S, C):
    """Whether a substep is :func:`plain_substep`'s: Gauss-Seidel order, no bending, no clamps, no obstacle shapes
    and no contacts."""
    ip = S.ip
    return (ip[_I_ORDER] == ORDER_GAUSS_SEIDEL and ip[_I_BEND] == BEND_NONE and S.clamp_pq.shape[0] == 0
            and C.shapes.shape[0] == 0 and C.seg.shape[0] == 0 and C.pair.shape[0] == 0)


@_inline
def plain_substep(x, v, x0, w, mass, react, rest, lam_s, pin_p, pin_from, pin_to, pin_active, pin_release,
                  pin_force, pin_sum, fp, ip, sub, n_sub):
    """Substep ``sub`` of ``n_sub`` of a chain that :func:`is_plain` (stretch constraints only, Gauss-Seidel, no
    contacts): :func:`begin_substep`, ``iterations`` × :func:`iterate` and :func:`end_substep` for that case, the
    same arithmetic in the same order (bit for bit), on the chain's arrays passed one by one. Returns the number of
    sockets released.

    Why a separate path: the general pieces, inlined into one substep loop with the code of every order and of the
    contacts, ran hang's substep (51 particles) 0.4 µs slower than this loop of the same operations, though that
    code never ran (numba 0.68, measured; see ``scripts/bench_speed.py``)."""
    _predict(x, v, x0, w, react, fp)
    _move_pins(x, react, pin_p, pin_from, pin_to, pin_active, pin_sum, ip[_I_SUBSTEPS], sub, n_sub)
    lam_s[:] = 0.0
    h2 = fp[_F_H] * fp[_F_H]
    at_s, k_s, sqrt_approx = fp[_F_ALPHA_S] / h2, fp[_F_K_S], ip[_I_SQRT] != 0
    for _ in range(ip[_I_ITER]):
        stretch_sweep(x, x, w, react, rest, 1, at_s, lam_s, k_s, sqrt_approx)
    _velocities(x, v, x0, 1.0 / fp[_F_H])
    return _pin_forces(w, mass, react, fp, pin_p, pin_active, pin_release, pin_force, pin_sum, ip[_I_SUBSTEPS])


@_inline
def run_substeps(S, C, n_sub, phase, sub):
    """Substeps of ``iterations`` iterations each. Returns (all positions and velocities finite, number of sockets
    released).

    ``phase`` ``PHASE_ALL`` runs ``n_sub`` whole substeps (``sub`` ignored); the other phases run one piece of
    substep ``sub`` of ``n_sub``, so that a Python caller (PBD's user constraints) can act between iterations
    without a second compiled entry point: ``PHASE_BEGIN`` (predict), ``PHASE_ITERATE`` (one iteration),
    ``PHASE_END`` (velocities and pins). Whole substeps of a chain that :func:`is_plain` run
    :func:`plain_substep`."""
    released = 0
    if phase == PHASE_ALL and is_plain(S, C):
        for k in range(n_sub):
            released += plain_substep(S.x, S.v, S.x0, S.w, S.mass, S.react, S.rest, S.lam_s, S.pin_p, S.pin_from,
                                      S.pin_to, S.pin_active, S.pin_release, S.pin_force, S.pin_sum, S.fp, S.ip, k,
                                      n_sub)
    elif phase == PHASE_ALL:
        for k in range(n_sub):
            begin_substep(S, C, k, n_sub)
            for _ in range(S.ip[_I_ITER]):
                iterate(S, C)
            released += end_substep(S, C)
    elif phase == PHASE_BEGIN:
        begin_substep(S, C, sub, n_sub)
    elif phase == PHASE_ITERATE:
        iterate(S, C)
    else:
        released = end_substep(S, C)
    finite = True
    x, v = S.x, S.v
    for p in range(x.shape[0]):
        for comp in range(3):
            if not (math.isfinite(x[p, comp]) and math.isfinite(v[p, comp])):
                finite = False
    return finite, released


@_nogil
def run_substeps_flat(x, v, x0, w, mass, react, dx, count, rest, lam_s, rest_d, lam_d, lam_b, clamp_pq, clamp_pin,
                      clamp_dir, lam_c, pin_p, pin_from, pin_to, pin_active, pin_release, pin_force, pin_sum,
                      row_kind, row_idx, row_p, prow, pslot, band, grad, rhs, fric, anchor, anchor_ob, fp, ip, seg, geo,
                      lam, pair, sgeo, slam, shapes, impulse, n_sub, phase, sub):
    """:func:`run_substeps` with the state's arrays as separate arguments (``*chain, *contacts, n_sub, phase,
    sub``): numba types plain array arguments in C but a named tuple of 40 arrays in Python (about 25 µs a call)."""
    S = Chain(x, v, x0, w, mass, react, dx, count, rest, lam_s, rest_d, lam_d, lam_b, clamp_pq, clamp_pin,
              clamp_dir, lam_c, pin_p, pin_from, pin_to, pin_active, pin_release, pin_force, pin_sum, row_kind,
              row_idx, row_p, prow, pslot, band, grad, rhs, fric, anchor, anchor_ob, fp, ip)
    C = Contacts(seg, geo, lam, pair, sgeo, slam, shapes, impulse)
    return run_substeps(S, C, n_sub, phase, sub)


# ---------------------------------------------------------------------------------------------------------------
# Whole steps: the Simulator's steps without returning to Python while nothing needs it.


@_inline
def step_margin(v, contact_margin, dt, fall):
    """The contact query's margin (m) for the next step: ``contact_margin`` plus the fastest particle's travel in
    one step, speed · dt + ``fall`` (½ g dt²), from ``v`` (N, 3); ``contact_margin`` alone for a non-finite state."""
    top = 0.0
    for p in range(v.shape[0]):
        s2 = v[p, 0] * v[p, 0] + v[p, 1] * v[p, 1] + v[p, 2] * v[p, 2]
        if s2 > top or s2 != s2:
            top = s2
    margin = contact_margin + math.sqrt(top) * dt + fall
    return margin if math.isfinite(margin) else contact_margin


@_inline
def touches_obstacles(x, reach, box_lo, box_hi, plane_n, plane_p):
    """Whether the bounding box of particles ``x`` (N, 3), grown by ``reach`` metres, touches an obstacle: a world
    bounding box (``box_lo``, ``box_hi`` (B, 3)) or the solid side of a plane (unit normal ``plane_n``, point
    ``plane_p`` (F, 3)). The step driver and :meth:`mjcable.solvers.contacts.ObstacleContacts.touching` share it."""
    lo0 = lo1 = lo2 = math.inf
    hi0 = hi1 = hi2 = -math.inf
    for p in range(x.shape[0]):
        lo0, lo1, lo2 = min(lo0, x[p, 0]), min(lo1, x[p, 1]), min(lo2, x[p, 2])
        hi0, hi1, hi2 = max(hi0, x[p, 0]), max(hi1, x[p, 1]), max(hi2, x[p, 2])
    lo, hi = (lo0 - reach, lo1 - reach, lo2 - reach), (hi0 + reach, hi1 + reach, hi2 + reach)
    for k in range(box_lo.shape[0]):
        if (lo[0] <= box_hi[k, 0] and hi[0] >= box_lo[k, 0] and lo[1] <= box_hi[k, 1] and hi[1] >= box_lo[k, 1]
                and lo[2] <= box_hi[k, 2] and hi[2] >= box_lo[k, 2]):
            return True
    for k in range(plane_n.shape[0]):
        depth = 0.0
        for comp in range(3):
            depth += plane_n[k, comp] * (0.5 * (lo[comp] + hi[comp]) - plane_p[k, comp])
            depth -= abs(plane_n[k, comp]) * 0.5 * (hi[comp] - lo[comp])
        if depth <= 0.0:
            return True
    return False


@_inline
def _step_checks(x, v, prev, lim):
    """(x, v finite; runaway: |coordinate| > lim[max_distance] or |x − prev| / dt > lim[max_speed]), as Simulator."""
    far, top, bad = 0.0, 0.0, 0.0  # bad: NaN once any x or v is non-finite (z − z), without a branch
    for p in range(x.shape[0]):
        d2 = 0.0
        for comp in range(3):
            bad += (x[p, comp] - x[p, comp]) + (v[p, comp] - v[p, comp])
            far = max(far, abs(x[p, comp]))
            d = x[p, comp] - prev[p, comp]
            d2 += d * d
        top = max(top, d2)
    return bad == 0.0, far > lim[_L_DISTANCE] or math.sqrt(top) / lim[_L_DT] > lim[_L_SPEED]


@_nogil
def run_steps_flat(x, v, x0, w, mass, react, dx, count, rest, lam_s, rest_d, lam_d, lam_b, clamp_pq, clamp_pin,
                   clamp_dir, lam_c, pin_p, pin_from, pin_to, pin_active, pin_release, pin_force, pin_sum, row_kind,
                   row_idx, row_p, prow, pslot, band, grad, rhs, fric, anchor, anchor_ob, fp, ip, seg, geo, lam, pair,
                   sgeo, slam, shapes, impulse, n_sub, n_steps, solo, lim, box_lo, box_hi, plane_n, plane_p, prev,
                   rows, out_x, out_v, clock, path, path_pins, until_release, capi, struct_i32, struct_i64, arena_f64,
                   arena_i32, pose_pos, pose_quat, pair_margin, segment_of_geom, shape_of_geom, geom_friction, seg_buf,
                   geo_buf, lam_buf, pair_buf, sgeo_buf, slam_buf, counts):
    """Up to ``n_steps`` whole steps of ``n_sub`` substeps (:func:`run_substeps`) in one call (``*chain,
    *contacts, n_sub, n_steps, ...``); the first step uses the given contacts, the later ones query their own
    (below) or have none. After each step, as the Python step: the pins' start moves to their target (a gripper
    move spreads over one step), ``clock[0] += lim[dt]`` (``mj_data.time``), x and v go to ``out_x[r]``,
    ``out_v[r]`` (R, N, 3) when the step's number in this call is ``rows[r]`` (ascending). Grippers follow ``path``
    (P, G, 3) m: before step ``k`` (``k < P``) the target of pin ``path_pins[g]`` (G,) becomes ``path[k, g]``, as
    ``Simulator.move_gripper`` before a Python step (P = 0: no path). Returns (steps taken, finite, sockets
    released, stopped by a check, rows stored), early:

    * after a step whose state is non-finite or runs away (:func:`_step_checks`; ``prev`` (N, 3) holds the
      positions before it), so that the caller raises naming that step;
    * before a step that needs a contact query, if ``capi[CAPI_ENABLED]`` is 0 or the query overflows its buffers:
      the caller queries that step's contacts in Python (and grows the buffers);
    * after a step in which a socket let go, if ``until_release``.

    A step after the first needs a query when its reach (:func:`step_margin` + ``lim[radius]``) touches an obstacle
    (``box_lo``, ``box_hi``, ``plane_n``, ``plane_p``: empty for none), and every step does if ``solo``
    (self-collision). With ``capi[CAPI_ENABLED]`` the loop queries itself, as the Python step: the obstacles through
    MuJoCo's C API (:func:`~mjcable.solvers.query_kernels.query_obstacles`: ``capi``, the ``mjData`` views
    ``struct_i32``, ``struct_i64``, ``arena_f64``, ``arena_i32``, the proxy's ``mocap_pos``/``mocap_quat`` views
    ``pose_pos``, ``pose_quat`` and ``pair_margin``, the maps ``segment_of_geom``, ``shape_of_geom`` and
    ``geom_friction``) into ``seg_buf``, ``geo_buf``, ``lam_buf`` (capacity), and self contacts
    (:func:`~mjcable.solvers.query_kernels.find_self_contacts`) into ``pair_buf``, ``sgeo_buf``, ``slam_buf``.
    ``counts`` gets the last step's obstacle and self contact numbers (``COUNT_CONTACTS``, ``COUNT_SELF``, when the
    loop queried them) and the number of obstacle queries it ran (``COUNT_QUERIES``, added)."""
    S = Chain(x, v, x0, w, mass, react, dx, count, rest, lam_s, rest_d, lam_d, lam_b, clamp_pq, clamp_pin,
              clamp_dir, lam_c, pin_p, pin_from, pin_to, pin_active, pin_release, pin_force, pin_sum, row_kind,
              row_idx, row_p, prow, pslot, band, grad, rhs, fric, anchor, anchor_ob, fp, ip)
    given = Contacts(seg, geo, lam, pair, sgeo, slam, shapes, impulse)
    none = Contacts(seg[:0], geo[:0], lam[:0], pair[:0], sgeo[:0], slam[:0], shapes, impulse)
    obstacles = box_lo.shape[0] + plane_n.shape[0] > 0
    released, stored = 0, 0
    C = given
    for k in range(n_steps):
        if k > 0:
            margin, near = 0.0, False
            if obstacles or solo:  # (nothing to measure on a free cable: hang's steps skip it)
                margin = step_margin(v, lim[_L_MARGIN], lim[_L_DT], lim[_L_FALL])
                near = obstacles and touches_obstacles(x, margin + lim[_L_RADIUS], box_lo, box_hi, plane_n, plane_p)
            if not (near or solo):
                C = none
                counts[COUNT_CONTACTS], counts[COUNT_SELF] = 0, 0
            elif capi[CAPI_ENABLED] == 0:
                return k, True, released, False, stored
            else:  # the query of ParticleBackend._find_contacts, in the loop
                n_con = n_self = 0
                if solo:
                    n_self = find_self_contacts(x, 2.0 * lim[_L_RADIUS] + margin, pair_buf, sgeo_buf)
                    if n_self < 0:
                        return k, True, released, False, stored
                if near:  # last: a query handed back to Python is counted there, once
                    n_con = query_obstacles(x, margin, capi, struct_i32, struct_i64, arena_f64, arena_i32, pose_pos,
                                            pose_quat, pair_margin, segment_of_geom, shape_of_geom, geom_friction,
                                            lim[_L_RADIUS], seg_buf, geo_buf)
                    if n_con < 0:
                        return k, True, released, False, stored
                    counts[COUNT_QUERIES] += 1
                C = Contacts(seg_buf[:n_con], geo_buf[:n_con], lam_buf[:n_con], pair_buf[:n_self], sgeo_buf[:n_self],
                             slam_buf[:n_self], shapes, impulse)
                counts[COUNT_CONTACTS], counts[COUNT_SELF] = n_con, n_self
        if k < path.shape[0]:
            for g in range(path_pins.shape[0]):
                q = path_pins[g]
                pin_to[q, 0], pin_to[q, 1], pin_to[q, 2] = path[k, g, 0], path[k, g, 1], path[k, g, 2]
        for p in range(x.shape[0]):  # (explicit copies: faster than slice assignments here)
            prev[p, 0], prev[p, 1], prev[p, 2] = x[p, 0], x[p, 1], x[p, 2]
        # run_substeps(S, C, n_sub, PHASE_ALL, 0), its finite check below: written out with the flat arrays, which
        # ran hang's plain substeps 5-15 % faster than the same code through S's fields (measured, numba 0.68)
        let_go = 0
        if is_plain(S, C):
            for sub in range(n_sub):
                let_go += plain_substep(x, v, x0, w, mass, react, rest, lam_s, pin_p, pin_from, pin_to, pin_active,
                                        pin_release, pin_force, pin_sum, fp, ip, sub, n_sub)
        else:
            for sub in range(n_sub):
                begin_substep(S, C, sub, n_sub)
                for _ in range(ip[_I_ITER]):
                    iterate(S, C)
                let_go += end_substep(S, C)
        released += let_go
        for q in range(pin_to.shape[0]):
            pin_from[q, 0], pin_from[q, 1], pin_from[q, 2] = pin_to[q, 0], pin_to[q, 1], pin_to[q, 2]
        clock[0] += lim[_L_DT]
        if stored < rows.shape[0] and rows[stored] == k + 1:
            out_x[stored, :, :] = x
            out_v[stored, :, :] = v
            stored += 1
        finite, runaway = _step_checks(x, v, prev, lim)
        if not finite or runaway:
            return k + 1, finite, released, True, stored
        if until_release and let_go > 0:
            return k + 1, True, released, False, stored
    return n_steps, True, released, False, stored
