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

The drivers take the packed solver state :class:`~mjcable.solvers.kernels_layout.SolverState` (``S``) and a handful
of arguments: :func:`run_steps` (whole steps: contacts, substeps, a user world's host, divergence checks; one call per
``Simulator.step(T)``, ``step_along`` or ``rollout``) and :func:`run_phase` (one piece of a step, for PBD's Python
user constraints). The per-constraint functions take and return scalars, the hot sweeps and the substep's pieces are
inlined, and the rarely used sweeps are called only when they have work (``docs/measurements.md`` says why).
``error_model="numpy"``: a division by zero gives inf/NaN (caught as divergence). Numba caches per file, but
:mod:`mjcable.solvers._kernel_cache` stamps every kernel file's cache with all kernel files, so the drivers here call
projections from sibling files: :mod:`~mjcable.solvers.constraint_kernels` (sweeps),
:mod:`~mjcable.solvers.contact_kernels` (contacts and friction), :mod:`~mjcable.solvers.direct_kernels` (the direct
order), :mod:`~mjcable.solvers.query_kernels` (contact queries), :mod:`~mjcable.solvers.host_kernels` (a user
world's host), :mod:`~mjcable.solvers.monitor_kernels` (the divergence checks) and
:mod:`~mjcable.solvers.kernels_layout` (the state, codes); this module re-exports the projections.

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
from mjcable.solvers.constraint_kernels import (
    _bend_clamp_sweeps, clamp_sweep, curvature_sweep, jacobi_relax,  # noqa: F401
    stretch_step, stretch_step_rigid, stretch_step_sqrt, stretch_sweep, xpbd_multiplier,  # noqa: F401
)
from mjcable.solvers.cable_contact_kernels import self_contact_sweep, self_contacts
from mjcable.solvers.contact_kernels import contact_sweep, friction_sweep, shape_distance, update_anchors  # noqa: F401
from mjcable.solvers.cosserat_step_kernels import frames_begin, frames_end, rod_iterate
from mjcable.solvers.direct_kernels import banded_ldlt_solve, direct_solve  # noqa: F401
from mjcable.solvers.impact_kernels import resolve_impact, struck
from mjcable.solvers.impulse_kernels import collect_impulses
from mjcable.solvers.junction_kernels import junction_begin, junction_forces, junction_sweep
from mjcable.solvers.winch_kernels import winch_advance
from mjcable.solvers.ring_kernels import ring_begin, ring_end, ring_sweep
from mjcable.solvers.ring_direct_kernels import ring_predicted
from mjcable.solvers.host_kernels import host_after, host_before, host_begin_step, host_end_step
from mjcable.solvers.kernels_layout import (
    BEND_NONE, ORDER_DIRECT, ORDER_GAUSS_SEIDEL, ORDER_JACOBI, PAIRS_OFF,
    PHASE_BEGIN, PHASE_END, PHASE_HOST_AFTER, PHASE_HOST_BEFORE, PHASE_ITERATE, QUERY_COMPILED, QUERY_PYTHON,
    RUN_DIVERGED, RUN_DONE, RUN_QUERY, RUN_RELEASED, RUN_WARNING, CHECK_OK, WARN_STRAIN, SolverState,  # noqa: F401
)
from mjcable.solvers.monitor_kernels import contact_depth, step_check
from mjcable.solvers.query_kernels import (flatten_contacts, query_holds, query_obstacles, step_margin,  # noqa: F401
                                           touches_obstacles)

__all__ = ["SolverState", "run_steps", "run_phase", "substep", "begin_substep", "iterate", "end_substep",
           "is_plain", "plain_substep", "step_margin", "touches_obstacles", "xpbd_multiplier", "stretch_step",
           "stretch_step_sqrt", "stretch_sweep", "curvature_sweep", "clamp_sweep", "contact_sweep", "friction_sweep",
           "self_contact_sweep", "direct_solve", "banded_ldlt_solve", "STEP_BEGIN", "STEP_END"]

# run_phase's step-level phases (beside the substep phases PHASE_* of kernels_layout)
STEP_BEGIN, STEP_END = 10, 11


# ---------------------------------------------------------------------------------------------------------------
# The substep: predict, iterate, update velocities.


@_inline
def _predict(x, v, x0, w, react, h, damp, gx, gy, gz):
    """Predict: x₀ ← x, and for every free particle (w > 0) v ← e^{−c h} v + h g, x ← x + h v (semi-implicit
    Euler in velocity form; Verlet is the same recurrence with v read as (x − x_prev)/h, [T20] Eq. 2.7 with
    Jakobsen's damping); a held particle's (w = 0) reaction ``react`` ← 0. ``x``, ``v``, ``x0``, ``react`` (N, 3)
    m, m/s, kg·m; ``w`` (N,) 1/kg; ``damp`` (N,) each particle's e^{−c h} (its cable's c); ``h`` s; g m/s².

    Only held particles collect reactions (every sweep adds to ``react`` where w = 0, moves ``x`` elsewhere) and
    only pinned particles are ever held, so a free particle's row stays 0 without being zeroed every substep
    (:func:`_move_pins` zeroes the pins' rows, so a pin whose particle turned free keeps none either)."""
    for p in range(x.shape[0]):
        x0[p, 0] = x[p, 0]
        x0[p, 1] = x[p, 1]
        x0[p, 2] = x[p, 2]
        if w[p] > 0.0:
            # damping multiplies the velocity before gravity is added: it never changes a static equilibrium
            e = damp[p]
            v[p, 0] = e * v[p, 0] + h * gx
            v[p, 1] = e * v[p, 1] + h * gy
            v[p, 2] = e * v[p, 2] + h * gz
            x[p, 0] += h * v[p, 0]
            x[p, 1] += h * v[p, 1]
            x[p, 2] += h * v[p, 2]
        else:
            react[p, 0] = 0.0
            react[p, 1] = 0.0
            react[p, 2] = 0.0


@_inline
def _gravity_kick(P):
    """The fraction of gravity's velocity h g this substep's prediction adds: ½ for Verlet's first substep from the
    start state (``par.verlet_start``, cleared here), so that x₁ = x₀ + h v₀ + ½ g h² (Taylor; free fall exact,
    and the start state's velocity a true 0), else 1. Verlet afterwards reads its velocity from the previous
    position, v = (x − x_prev) / h."""
    if P.verlet_start:
        P.verlet_start = False
        return 0.5
    return 1.0


@_inline
def _move_pins(S, sub, n_sub):
    """Held particles to their pin targets, interpolated linearly across the step (substep ``sub`` of ``n_sub``
    reaches ``(sub + 1) / n_sub`` of the way from ``pin_from`` to ``pin_to``), every pinned particle's reaction
    zeroed, and a pin's force sums (``pin_sum``, ``pin_count``) zeroed when they hold a whole step's substeps
    (:func:`_pin_forces`)."""
    x, react, pin_p, pin_from, pin_to, pin_active = S.x, S.react, S.pin_p, S.pin_from, S.pin_to, S.pin_active
    pin_sum, pin_count = S.pin_sum, S.pin_count
    substeps = S.par[0].substeps
    frac = (sub + 1.0) / n_sub
    for k in range(pin_p.shape[0]):
        q = pin_p[k]
        react[q, 0] = 0.0
        react[q, 1] = 0.0
        react[q, 2] = 0.0
        if pin_count[k] >= substeps:  # the last step's sums are complete: this substep starts a new step
            pin_sum[k, 0] = pin_sum[k, 1] = pin_sum[k, 2] = 0.0
            pin_count[k] = 0.0
        if pin_active[k]:
            for comp in range(3):
                x[q, comp] = pin_from[k, comp] + frac * (pin_to[k, comp] - pin_from[k, comp])


@_inline
def begin_substep(S, sub, n_sub):
    """Predict (:func:`_predict`), move held particles to their pin targets (:func:`_move_pins`) and reset the
    multipliers (every substep, [M16] Algorithm 1); in the direct order a particle that the prediction carried
    through a ring passes (:func:`~mjcable.solvers.ring_direct_kernels.ring_predicted`)."""
    P = S.par[0]
    kick = _gravity_kick(P)
    _predict(S.x, S.v, S.x0, S.w, S.react, P.h, S.damp, kick * P.gx, kick * P.gy, kick * P.gz)
    _move_pins(S, sub, n_sub)
    if S.q.shape[0]:  # a Cosserat rod's frames (cosserat_kernels)
        frames_begin(S, sub, n_sub)
    S.lam_s[:] = 0.0
    S.lam_d[:] = 0.0
    S.lam_b[:] = 0.0
    S.lam_c[:] = 0.0
    S.con_lam[:P.n_con] = 0.0
    P.substep_depth = 0.0
    S.self_lam_n[:P.n_self] = 0.0
    S.self_lam_t[:P.n_self] = 0.0
    if S.junction_p.shape[0]:
        junction_begin(S)
    if S.ring_p.shape[0]:
        ring_begin(S)
        if P.order == ORDER_DIRECT:
            ring_predicted(S)


@_inline
def iterate(S, last):
    """One constraint iteration in the configured order; contacts are projected sequentially last, so that they
    hold exactly when the iteration ends. ``last``: the substep's last iteration: a struck contact then gets the
    impact's iterations (:func:`_struck`, after this iteration's friction), and otherwise the friction sweep also
    ends the particles' substep (:func:`~mjcable.solvers.contact_kernels.update_anchors`) unless two-way contacts
    read the sums after it. Junctions follow the chains (:mod:`~mjcable.solvers.junction_kernels`). Returns whether it
    did."""
    P = S.par[0]
    order = P.order
    cables = S.cable_par
    x, w = S.x, S.w
    bend_or_clamp = P.bending != BEND_NONE or S.clamp_pq.shape[0] > 0
    if S.q.shape[0]:  # a Cosserat rod: its stretch–shear and bend–twist constraints replace the chain's
        rod_iterate(S)
    elif order == ORDER_DIRECT:
        direct_solve(S)
        if not P.direct_all and bend_or_clamp:  # PBD/Jakobsen: only the stretch chain is solved directly
            _bend_clamp_sweeps(S, x, False)
    elif order == ORDER_JACOBI:  # every constraint's share of its correction into dx, then all at once
        dx = S.dx
        dx[:] = 0.0
        jacobi_relax(S)
        stretch_sweep(x, dx, w, S.react, S.rest, 1, cables, S.lam_s, P.sqrt_approx, S.relax, S.chain_seg)
        if bend_or_clamp:
            _bend_clamp_sweeps(S, dx, True)
        for p in range(x.shape[0]):
            if w[p] > 0.0:
                x[p, 0] += dx[p, 0]
                x[p, 1] += dx[p, 1]
                x[p, 2] += dx[p, 2]
    else:
        stretch_sweep(x, x, w, S.react, S.rest, 1, cables, S.lam_s, P.sqrt_approx, S.relax[:0], S.chain_seg)
        if bend_or_clamp:  # a call passing S: skipped when there is nothing to do
            _bend_clamp_sweeps(S, x, False)
    if S.junction_p.shape[0]:  # the junctions after the chains (junction_kernels)
        junction_sweep(S)
    if S.ring_p.shape[0]:  # the rings after them (ring_kernels)
        ring_sweep(S)
    n_con, n_self = P.n_con, P.n_self
    impact = finished = False
    if n_con:
        deepest = contact_sweep(S)
        if deepest > P.substep_depth:
            P.substep_depth = deepest
        impact = last and _struck(S, P.substep_depth)
        finished = last and not impact and S.impulse_force.shape[0] == 0
        friction_sweep(S, finished)
    if n_self:
        self_contact_sweep(S)
    if impact:
        resolve_impact(S)
    return finished


@_inline
def end_substep(S, finished):
    """Contact anchors (:func:`update_anchors`, unless the last iteration's friction sweep ``finished`` them; before
    them, with two-way contacts, the contacts' impulses per obstacle:
    :func:`~mjcable.solvers.impulse_kernels.collect_impulses`); v = (x − x₀)/h; the pins' forces and sockets that let go
    (:func:`_pin_forces`). Returns the number released."""
    P = S.par[0]
    x = S.x
    if S.shape_type.shape[0] and not finished:
        if S.impulse_force.shape[0]:  # two-way contacts (a user world's bodies): before update_anchors zeroes the sums
            collect_impulses(S)
        update_anchors(S)
    _velocities(x, S.v, S.x0, 1.0 / P.h)
    if S.q.shape[0]:
        frames_end(S)
    if S.junction_p.shape[0]:
        junction_forces(S)
    if S.ring_p.shape[0]:
        ring_end(S)
    return _pin_forces(S)


@_inline
def _velocities(x, v, x0, inv_h):
    """v = (x − x₀) / h for every particle (``x``, ``v``, ``x0`` (N, 3) m, m/s; ``inv_h`` 1/s)."""
    for p in range(x.shape[0]):
        v[p, 0] = (x[p, 0] - x0[p, 0]) * inv_h
        v[p, 1] = (x[p, 1] - x0[p, 1]) * inv_h
        v[p, 2] = (x[p, 2] - x0[p, 2]) * inv_h


@_inline
def _pin_forces(S):
    """The active pins' substep forces F_s = −∇Cᵀλ / h² − m g ([M16]'s force estimate, from the held particle's
    reactions ``react``) into ``pin_force`` and added to ``pin_sum`` / ``pin_count``; at the step's last substep
    (``pin_count`` = substeps) a socket whose mean force F̄ = |Σ_s F_s| / n exceeds ``pin_release`` lets go (its
    particle gets w = 1/m, ``pin_active`` False). F̄ = J / dt, J the impulse the pin gave its particle over the step:
    the quantity MuJoCo's constraint force of one step is (native sockets decide on it per step). A single
    substep's force is not a measure of the pull: a positional solver settles a violation within one substep, as a
    force spike of that substep. Returns the number released."""
    P = S.par[0]
    w, mass, react = S.w, S.mass, S.react
    pin_p, pin_active, pin_force, pin_sum, pin_count = S.pin_p, S.pin_active, S.pin_force, S.pin_sum, S.pin_count
    substeps = P.substeps
    inv_h = 1.0 / P.h
    inv_h2 = inv_h * inv_h
    gx, gy, gz = P.gx, P.gy, P.gz
    released = 0
    for k in range(pin_p.shape[0]):
        if not pin_active[k]:
            continue
        p = pin_p[k]
        m = mass[p]
        fx = -react[p, 0] * inv_h2 - m * gx
        fy = -react[p, 1] * inv_h2 - m * gy
        fz = -react[p, 2] * inv_h2 - m * gz
        pin_force[k, 0], pin_force[k, 1], pin_force[k, 2] = fx, fy, fz
        pin_sum[k, 0] += fx
        pin_sum[k, 1] += fy
        pin_sum[k, 2] += fz
        pin_count[k] += 1.0
        if pin_count[k] >= substeps:
            n = pin_count[k]
            mx, my, mz = pin_sum[k, 0] / n, pin_sum[k, 1] / n, pin_sum[k, 2] / n
            if math.sqrt(mx * mx + my * my + mz * mz) > S.pin_release[k]:
                pin_active[k] = False
                w[p] = 1.0 / m
                released += 1
    return released


@_inline
def is_plain(S):
    """Whether a substep is :func:`plain_substep`'s: Gauss-Seidel order, no bending, no clamps, no obstacle shapes,
    no contacts, no frames, no junctions and no rings."""
    P = S.par[0]
    return (P.order == ORDER_GAUSS_SEIDEL and P.bending == BEND_NONE and S.clamp_pq.shape[0] == 0
            and S.shape_type.shape[0] == 0 and P.n_con == 0 and P.n_self == 0 and S.q.shape[0] == 0
            and S.junction_p.shape[0] == 0 and S.ring_p.shape[0] == 0)


@_inline
def plain_substep(S, sub, n_sub):
    """Substep ``sub`` of ``n_sub`` of a chain that :func:`is_plain` (stretch constraints only, Gauss-Seidel, no
    contacts): :func:`begin_substep`, ``iterations`` stretch sweeps and :func:`end_substep` for that case, from the
    same pieces, without the branches of the other orders and of the contacts (a hanging chain's substep pays for
    nothing it doesn't do; ``docs/measurements.md``). Returns the number of sockets released."""
    P = S.par[0]
    x, w, react, lam_s = S.x, S.w, S.react, S.lam_s
    h = P.h
    kick = _gravity_kick(P)
    _predict(x, S.v, S.x0, w, react, h, S.damp, kick * P.gx, kick * P.gy, kick * P.gz)
    _move_pins(S, sub, n_sub)
    lam_s[:] = 0.0
    cables, sqrt_approx = S.cable_par, P.sqrt_approx
    rest, chains = S.rest, S.chain_seg
    for _ in range(P.iterations):
        stretch_sweep(x, x, w, react, rest, 1, cables, lam_s, sqrt_approx, S.relax[:0], chains)
    _velocities(x, S.v, S.x0, 1.0 / h)
    return _pin_forces(S)


@_jit
def substep(S, sub, n_sub):
    """Substep ``sub`` of ``n_sub`` (the pins' targets interpolated across them): :func:`plain_substep` where it
    applies, else :func:`begin_substep`, ``iterations`` × :func:`iterate`, :func:`end_substep`. Returns the number of
    sockets released. Compiled once and called (not inlined) by the step loop, with or without a host world: one
    call per substep costs nanoseconds, one copy of the substep's code less compile time. Winches reel first
    (:func:`~mjcable.solvers.winch_kernels.winch_advance`)."""
    if S.winch_pin.shape[0]:
        winch_advance(S)
    if is_plain(S):
        return plain_substep(S, sub, n_sub)
    begin_substep(S, sub, n_sub)
    n_it = S.par[0].iterations
    finished = False
    for it in range(n_it):
        finished = iterate(S, it == n_it - 1)
    return end_substep(S, finished)


@_inline
def _struck(S, deepest):
    """Whether a substep's contacts of a point chain were struck (:func:`~mjcable.solvers.impact_kernels.struck`),
    so that it is resolved as an impact (:func:`~mjcable.solvers.impact_kernels.resolve_impact`). A struck contact's
    approach alone puts it at least ``impact_speed`` · h deep after the prediction, so a substep whose contact sweeps
    removed less (``deepest``, m: ``par.substep_depth``, the most over the substep's iterations; a cable at rest,
    g h²) is not tested. (The substep's first sweep removes the approach: with several iterations, the last sweep's
    depth alone missed every impact.)"""
    P = S.par[0]
    return (P.n_con > 0 and P.impact_iterations > 0 and deepest >= P.impact_speed * P.h and S.q.shape[0] == 0
            and struck(S))


@_inline
def _substeps(S):
    """One step's ``substeps`` substeps; in a user world each with the host's coupling and ``mj_step``
    (:mod:`mjcable.solvers.host_kernels`; a MuJoCo warning that stops the step goes to ``par.warning``). Returns the
    number of sockets released."""
    P = S.par[0]
    n = P.substeps
    released = 0
    if P.host:
        host_begin_step(S)
        for sub in range(n):
            host_before(S, sub, n)
            # the host set the pins' targets for this substep: its last of n reaches them, as the only one of 1
            released += substep(S, n - 1, n)  # (variables: one compiled substep serves both paths)
            if host_after(S):
                return released
        host_end_step(S)
    else:
        for sub in range(n):
            released += substep(S, sub, n)
    return released


# ---------------------------------------------------------------------------------------------------------------
# Whole steps: contacts, substeps, checks.


@_inline
def _step_contacts(S, given):
    """The contacts of the next step into the state (``par.n_con``, ``par.n_self``): none while the cable's reach
    (:func:`~mjcable.solvers.query_kernels.step_margin` + radius) touches no obstacle's bounds; the last query's while
    they still hold every pair the step needs (static obstacles: :func:`~mjcable.solvers.query_kernels.query_holds`);
    else MuJoCo's query (:func:`~mjcable.solvers.query_kernels.query_obstacles`, its margin widened by
    ``par.query_slack`` so that later steps may keep it); and the segment pairs: the self contacts with
    ``par.self_collision``, those between cables with ``par.cable_contact``. ``given``: the obstacle contacts are
    already there (Python queried them at ``par.margin``). Returns False, with the margin in ``par.margin``, when
    Python must query this step's obstacle contacts through the bindings (``QUERY_PYTHON``)."""
    P = S.par[0]
    x = S.x
    obstacles = S.box_lo.shape[0] + S.plane_n.shape[0] > 0
    n_con = n_self = 0
    segments = P.self_collision or P.cable_contact  # segment pairs to find (self_contacts)
    if obstacles or segments:  # (nothing to measure on a free cable)
        margin = step_margin(S.v, P.contact_margin, P.dt, P.fall)
        if obstacles and not given and P.keep_queries and query_holds(x, margin, S.query_x, P.query_margin):
            n_con = P.n_con  # the last query's contacts, still in the buffers (they hold every pair the step needs)
        elif obstacles and touches_obstacles(x, margin + P.max_radius, S.box_lo, S.box_hi, S.plane_n, S.plane_p):
            if given:  # Python queried them at par.margin
                n_con = P.n_con
                wide = P.margin
            else:
                wide = margin + P.query_slack if P.keep_queries else margin
                n_con = query_obstacles(S, wide) if P.query == QUERY_COMPILED else -1
                if n_con < 0:  # the C API's query is unavailable (or its contact array misplaced): Python's
                    P.query = QUERY_PYTHON
                    P.margin = wide
                    return False
                P.queries += 1
            flatten_contacts(S, n_con, 2.0 * wide)  # contacts that stay over a flat face while the query is kept
            if P.keep_queries:  # a new query: where it was taken, and its margin
                S.query_x[:, :] = x
                P.query_margin = wide
        else:
            P.query_margin = -math.inf  # (its contacts are dropped: the next step that needs them queries)
        if P.host:  # a user world's mj_step must not see the proxy's pairs
            for p in range(P.pair_start, P.pair_stop):
                S.pair_margin[p] = PAIRS_OFF
        if segments:
            n_self = self_contacts(S, 2.0 * P.max_radius + margin)
    P.n_con, P.n_self = n_con, n_self
    return True


@_inline
def _end_step(S):
    """After a step's substeps: the pins' start moves to their target (a gripper move spreads over one step), the
    clock advances (a user world's ``mj_step`` keeps its own), and the divergence checks
    (:func:`~mjcable.solvers.monitor_kernels.step_check` and :func:`~mjcable.solvers.monitor_kernels.contact_depth`
    into ``par.check``, ``par.check_value``, ``par.check_where``; the first warning-level check into ``par.warn_*``,
    its ``warn_step`` 0 for the caller to number). Returns whether the step passed the checks that stop a run."""
    P = S.par[0]
    pin_from, pin_to = S.pin_from, S.pin_to
    for q in range(pin_to.shape[0]):
        pin_from[q, 0], pin_from[q, 1], pin_from[q, 2] = pin_to[q, 0], pin_to[q, 1], pin_to[q, 2]
    qfrom, qto = S.clamp_qfrom, S.clamp_qto  # (a Cosserat rod's clamped frames, like the pins)
    for q in range(qto.shape[0]):  # (explicit copies: a slice assignment costs more than a short loop)
        for comp in range(4):
            qfrom[q, comp] = qto[q, comp]
    if not P.host:
        P.time += P.dt
    check, value, where = step_check(S.x, S.v, S.prev, S.rest, S.pin_p, S.pin_to, S.pin_active, S.par)
    if check == CHECK_OK and P.depth_check and P.n_con > 0:
        check, value, where = contact_depth(S)
    if check >= WARN_STRAIN:  # a warning: the first of the call is kept for Python, the run goes on
        if P.warn_check == CHECK_OK:
            P.warn_check, P.warn_value, P.warn_where, P.warn_step = check, value, where, 0
        check = CHECK_OK
    P.check, P.check_value, P.check_where = check, value, where
    return check == CHECK_OK


@_inline
def _keep_prev(S):
    x, prev = S.x, S.prev
    for p in range(x.shape[0]):  # (explicit copies: faster than slice assignments here)
        prev[p, 0], prev[p, 1], prev[p, 2] = x[p, 0], x[p, 1], x[p, 2]


@_nogil
def run_steps(S, n_steps, given, rows, out_x, out_v, path, path_pins, until_release):
    """Up to ``n_steps`` whole steps of the solver state ``S`` (a :class:`SolverState`) in one call: each step
    finds its contacts, takes ``par.substeps`` substeps (in a user world each with the host's ``mj_step``) and passes
    the divergence checks.

    Args:
      S: the state.
      n_steps: steps to take.
      given: the first step's obstacle contacts are in the state already (Python queried them, see ``RUN_QUERY``).
      rows, out_x, out_v: ``(R,)`` ascending step numbers of this call (1..n_steps) after which x and v go to
        ``out_x[r]``, ``out_v[r]`` ``(R, N, 3)`` (m, m/s).
      path, path_pins: gripper targets ``(steps, G, 3)`` m and the pins ``(G,)`` they move: before step ``k``
        (``k < steps``) the target of pin ``path_pins[g]`` becomes ``path[k, g]`` (steps = 0: no path).
      until_release: stop after a step in which a socket let go.

    Returns:
      (steps taken, outcome ``RUN_*``, sockets released, rows stored). Early outcomes: ``RUN_DIVERGED`` after a
      step that failed a check (``par.check``), ``RUN_WARNING`` after a step that made the user world's MuJoCo warn
      (``par.warning``), ``RUN_QUERY`` before a step whose contacts Python must query, ``RUN_RELEASED``.
    """
    P = S.par[0]
    pin_to = S.pin_to
    released, stored = 0, 0
    for k in range(n_steps):
        if not _step_contacts(S, given and k == 0):
            return k, RUN_QUERY, released, stored
        if k < path.shape[0]:
            for g in range(path_pins.shape[0]):
                q = path_pins[g]
                pin_to[q, 0], pin_to[q, 1], pin_to[q, 2] = path[k, g, 0], path[k, g, 1], path[k, g, 2]
        _keep_prev(S)
        let_go = _substeps(S)
        released += let_go
        passed = _end_step(S)
        if P.warn_step == 0:
            P.warn_step = k + 1
        if stored < rows.shape[0] and rows[stored] == k + 1:
            out_x[stored, :, :] = S.x[:out_x.shape[1]]  # (the cables' particles: rings' hubs follow them)
            out_v[stored, :, :] = S.v[:out_v.shape[1]]
            stored += 1
        if P.warning >= 0:
            return k + 1, RUN_WARNING, released, stored
        if not passed:
            return k + 1, RUN_DIVERGED, released, stored
        if until_release and let_go > 0:
            return k + 1, RUN_RELEASED, released, stored
    return n_steps, RUN_DONE, released, stored


@_jit
def run_phase(S, phase, sub, n_sub):
    """One piece of a step, for a Python caller that acts between iterations (PBD's user constraints), the pieces
    :func:`run_steps` takes: ``STEP_BEGIN`` (the step's contacts, :func:`_step_contacts`, ``sub`` ≠ 0 if Python
    queried them; returns 0 if Python must query them first), ``PHASE_HOST_BEFORE``/``PHASE_HOST_AFTER`` (a user
    world's coupling around substep ``sub`` of ``n_sub``; after: returns 1 if a MuJoCo warning stopped the step),
    ``PHASE_BEGIN``, ``PHASE_ITERATE``, ``PHASE_END`` (the substep's pieces; end: returns the sockets released) and
    ``STEP_END`` (:func:`_end_step`; returns 1 if the step passed the checks)."""
    if phase == STEP_BEGIN:
        ok = _step_contacts(S, sub != 0)
        if ok:
            _keep_prev(S)
        return 1 if ok else 0
    if phase == PHASE_HOST_BEFORE:
        if sub == 0:
            host_begin_step(S)
        host_before(S, sub, n_sub)
        return 0
    if phase == PHASE_HOST_AFTER:
        stopped = host_after(S)
        if not stopped and sub == n_sub - 1:
            host_end_step(S)
        return 1 if stopped else 0
    if phase == PHASE_BEGIN:
        if S.winch_pin.shape[0]:
            winch_advance(S)
        begin_substep(S, sub, n_sub)
        return 0
    if phase == PHASE_ITERATE:
        iterate(S, False)
        return 0
    if phase == PHASE_END:
        if _struck(S, S.par[0].substep_depth):
            resolve_impact(S)
        return end_substep(S, False)
    return 1 if _end_step(S) else 0
