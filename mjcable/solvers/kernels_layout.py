"""The particle solvers' data layout, shared by all kernel files: the solver state (:class:`SolverState`, one numba
``structref`` with named fields), its parameter record (:data:`PARAMS`), the codes of orders, bending models,
direct-solve rows, substep phases and run outcomes, and the tolerances that several kernels use.

The state is what ``mjData`` is to MuJoCo: one object handed whole to every driver, holding the chain (positions,
velocities, inverse masses, rest lengths, multipliers), the pins and clamps, the direct order's banded system, the
contacts (buffers grown on demand, with their counts), the contact query's view of the proxy's ``mjData`` and the
user world's host links, plus one parameter record ``par`` (a length-1 numpy structured array: numba reads and
writes its fields by name, Python sees the same memory). Python keeps numpy views of the same arrays
(:func:`mjcable.solvers.state.chain_arrays`), so that reading positions or pin forces costs no compiled call.

Numba freezes module constants and the state's type into the compiled kernels that read them, so this file is a
kernel file for the cache (its name matches ``*kernels*``: a change here recompiles every kernel, see
:mod:`mjcable.solvers._kernel_cache`).
"""

from __future__ import annotations

from collections import namedtuple

import numba
import numpy as np
from numba import types
from numba.experimental import structref

from mjcable.solvers._kernel_cache import jit as _jit

__all__ = ["SolverState", "SolverStateType", "STATE_TYPE", "PARAMS", "CABLE_PARAMS", "FIELDS", "assemble",
           "contact_buffers", "self_contact_buffers", "Shapes"]

ORDER_GAUSS_SEIDEL, ORDER_JACOBI, ORDER_DIRECT = 0, 1, 2
BEND_NONE, BEND_CURVATURE, BEND_DISTANCE = 0, 1, 2
ROW_STRETCH, ROW_CURVATURE, ROW_DISTANCE, ROW_CLAMP, ROW_TRANSVERSE = 0, 1, 2, 3, 4
# How a step's contacts are queried (PARAMS.query): none (no obstacle), by the compiled loop through MuJoCo's C API,
# or by Python through the bindings (the C API's layout check failed): the loop then returns before such a step.
QUERY_NONE, QUERY_COMPILED, QUERY_PYTHON = 0, 1, 2
# What a run of steps stopped on (kernels.run_steps): all steps taken, a divergence check, a step that needs a
# Python query, a socket that let go (until_release), a MuJoCo warning of the user world.
RUN_DONE, RUN_DIVERGED, RUN_QUERY, RUN_RELEASED, RUN_WARNING = 0, 1, 2, 3, 4
# A ring's state (SolverState.ring_mode): the cable slides through it, an end slipped out (it holds nothing), or it
# holds its stop particle at its centre.
RING_SLIDING, RING_LET_GO, RING_STOPPED = 0, 1, 2
# The physics checks of a step (monitor_kernels.step_check): passed, then the breaches that stop a run (non-finite
# state, a particle too far from the origin, a particle's travel too fast, the model's own velocity too fast, a pinned
# particle torn from its pin, a segment stretched beyond the model's limit), then those that warn once (a segment
# stretched beyond what the model promises, the centreline inside an obstacle).
CHECK_OK, CHECK_NON_FINITE, CHECK_DISTANCE, CHECK_SPEED, CHECK_VELOCITY, CHECK_PIN, CHECK_STRAIN = 0, 1, 2, 3, 4, 5, 6
WARN_STRAIN, WARN_DEPTH = 7, 8
# The pieces of a step a Python caller takes one by one (PBD's user constraints: kernels.run_phase).
PHASE_BEGIN, PHASE_ITERATE, PHASE_END, PHASE_HOST_BEFORE, PHASE_HOST_AFTER = 0, 1, 2, 3, 4
# MuJoCo's geom type codes (mujoco.mjtGeom) that the contact kernels measure exactly.
GEOM_PLANE, GEOM_SPHERE, GEOM_CAPSULE, GEOM_ELLIPSOID, GEOM_CYLINDER, GEOM_BOX = 0, 2, 3, 4, 5, 6
# A box's faces (SolverState.con_face): +x, +y, +z, −x, −y, −z in the box's frame (axis = face % 3); FLAT: a contact
# whose point stays over one face of a static box, or on a static plane, while its query is kept: its con_normal and
# con_offset are that face's plane (query_kernels.flatten_contacts); SOLE: a FLAT contact at a particle that has no
# other contact (its friction cone's normal is the face's, SolverState.fric_sole).
BOX_FACE_NONE, BOX_FACE_NEGATIVE, BOX_FACE_FLAT, BOX_FACE_SOLE = -1, 3, -2, -3
#: The obstacle shapes as one argument of the shape kernels (:func:`mjcable.solvers.contact_kernels.shape_distance`):
#: the state's ``shape_type`` (B,), ``shape_size`` (B, 3) m, ``shape_pos`` (B, 3) m, ``shape_rot`` (B, 3, 3).
Shapes = namedtuple("Shapes", ("type", "size", "pos", "rot"))

_TINY_LENGTH = 1e-12  # m: a segment shorter than this has no direction; its projection is skipped
_TINY_SLIP = 1e-15  # m: tangential slip below this needs no friction correction
# the columns of a contact between two cables' row of self_anchor: the anchor's fractions s, t and normal (5), and
# the contact's normal multiplier at the end of the last sweep (cable_contact_kernels._pool_loads)
ANCHOR_COLUMNS = 6
POOL_COLUMN = 5
# m/s: the fastest a static obstacle pushes out a depth that its contact point already had when the substep began (a
# start that cuts into it, or what a sweep after the contacts left): removed in one substep it would leave as a
# velocity of depth / h, 2.4 m/s for 0.3 mm at h = 0.125 ms (contact_kernels.contact_sweep, docs/measurements.md)
DEPENETRATION_SPEED = 0.02
# Impacts (impact_kernels): a contact that presses in a substep and whose point approached its obstacle faster than
# IMPACT_SPEED (m/s) makes the substep an impact, resolved by up to IMPACT_ITERATIONS more iterations of the chain held
# at its lengths, the contacts and friction, until an iteration's contact and friction corrections are at most
# IMPACT_TOLERANCE · h (m/s · s: the velocity they would still leave; docs/measurements.md, 2026-11-27)
IMPACT_SPEED = 0.2
IMPACT_ITERATIONS = 32
IMPACT_TOLERANCE = 1e-4
PAIRS_OFF = -1e10  # m: a pair margin no pair of geoms is closer than (switches the cable's pairs off)

#: The solver's scalars, one record (``SolverState.par``, a length-1 array of this dtype).
PARAMS = np.dtype([
    # the substep: h (s), gravity (m/s²) (each cable's damping, compliances and factors: CABLE_PARAMS)
    ("h", "f8"), ("gx", "f8"), ("gy", "f8"), ("gz", "f8"),
    ("omega", "f8"),  # Jacobi relaxation
    ("max_radius", "f8"),  # m, the largest of the cables' radii (the contact queries' reach)
    ("iterations", "i8"), ("substeps", "i8"), ("order", "i8"), ("bending", "i8"),  # ORDER_*, BEND_*
    ("sqrt_approx", "?"), ("direct_all", "?"), ("bandwidth", "i8"),  # the direct order's system
    # the step: dt (s), divergence limits (m from the origin, m/s), the contact query's margin (m) and what gravity
    # adds to one step's travel, ½ g dt² (m)
    ("dt", "f8"), ("max_distance", "f8"), ("max_speed", "f8"), ("contact_margin", "f8"), ("fall", "f8"),
    # the physics monitor's limits (mjcable.monitor.Limits): a segment's strain that stops a run and the one that
    # warns, the distance (m) at which a pinned particle counts as torn from its pin, and whether to look for the
    # centreline inside an obstacle
    ("strain_fail", "f8"), ("strain_warn", "f8"), ("tear", "f8"), ("depth_check", "?"),
    ("self_collision", "?"), ("query", "i8"),  # QUERY_*
    # the last obstacle query's margin (m; −inf: none to keep), kept by the steps whose pairs it still holds
    # (query_kernels.query_holds), whether queries may be kept (static obstacles, no user world), and the slack (m)
    # added to a query's margin so that they can be
    ("query_margin", "f8"), ("keep_queries", "?"), ("query_slack", "f8"),
    # MuJoCo's C API (mjcable.solvers.capi): entry points, the proxy's (or user world's) mjModel and mjData, the word
    # indices of mjData.ncon (int32) and mjData.contact (int64), the arena's address, sizeof(mjContact) and the
    # byte offsets of its dist, pos, frame and geom, the cable's pairs' rows of pair_margin
    ("fn_kinematics", "i8"), ("fn_collision", "i8"), ("model", "i8"), ("data", "i8"), ("ncon_word", "i8"),
    ("contact_word", "i8"), ("arena", "i8"), ("contact_size", "i8"), ("off_dist", "i8"), ("off_pos", "i8"),
    ("off_frame", "i8"), ("off_geom", "i8"), ("pair_start", "i8"), ("pair_stop", "i8"),
    # the user world's host (mjcable.backends.host): whether there is one, mj_step, mj_getState, mj_setState, mj_jac,
    # mj_solveM, the state signature (mjSTATE_INTEGRATION), nv and the state's size
    ("host", "?"), ("fn_step", "i8"), ("fn_get_state", "i8"), ("fn_set_state", "i8"), ("fn_jac", "i8"),
    ("fn_solve_m", "i8"), ("state_sig", "i8"), ("nv", "i8"), ("nstate", "i8"),
    # read-outs: the last step's obstacle and self contacts, queries run, the query margin a step asked Python for (m),
    # the MuJoCo warning that stopped a step (−1: none), the check that stopped one (CHECK_*) and what it measured,
    # simulated time (s)
    ("n_con", "i8"), ("n_self", "i8"), ("queries", "i8"), ("margin", "f8"), ("warning", "i8"), ("check", "i8"),
    ("check_value", "f8"), ("time", "f8"),
    # where the check that stopped a step found it (segment, pin or particle; −1: nowhere in particular), and the first
    # warning-level check of a run call (WARN_*; CHECK_OK: none yet), what it measured, where, and the step of the call
    # (1-based) it came in; Python reads and clears them after each call
    ("check_where", "i8"), ("warn_check", "i8"), ("warn_value", "f8"), ("warn_where", "i8"), ("warn_step", "i8"),
    # the direct order's geometric stiffness (direct_kernels: the stretch rows' transverse rows): whether the model's
    # multipliers carry it (XPBD), the half-bandwidth of the rows with it, whether the last solve found the tension
    # stiff (its multipliers then in lam_gs; False from the start and after a reset), whether its rows are the stretch
    # chain's only (then solved block by block in gs_blocks, not over the gs_ rows), and a read-out: the direct
    # solves taken since the start
    ("geometric", "?"), ("gs_bandwidth", "i8"), ("gs_stiff", "?"), ("gs_chain", "?"), ("direct_solves", "i8"),
    # Verlet's start (Jakobsen, PBD's Verlet): the next substep is the first from the start state (at rest, v = 0),
    # whose prediction is Taylor's x₁ = x₀ + h v₀ + ½ g h² (half of gravity's velocity h g); False after it
    ("verlet_start", "?"),
    # the cosserat rod's compliances (cosserat_kernels): stretch–shear rows (shear, shear, stretch; 1/(N·m)) and
    # bend–twist rows (bend about d₁, bend about d₂, twist; 1/(N·m³))
    ("ss_alpha1", "f8"), ("ss_alpha2", "f8"), ("ss_alpha3", "f8"),
    ("bt_alpha1", "f8"), ("bt_alpha2", "f8"), ("bt_alpha3", "f8"),
    # whether the rod is limp (E·I = G·J = 0): its direct solve is over the stretch–shear rows alone
    # (cosserat_direct_kernels)
    ("rod_limp", "?"),
    # impacts (impact_kernels): the approach speed (m/s) from which a pressing contact counts as struck, the most
    # iterations of a struck substep, the contact and friction correction (m) that ends them, and a read-out: the
    # substeps resolved as impacts since the start; the most depth (m) one contact projection removed in the
    # substep's iterations so far (the impact test's gate: a struck contact is that deep after the prediction)
    ("impact_speed", "f8"), ("impact_iterations", "i8"), ("impact_tol", "f8"), ("impacts", "i8"),
    ("substep_depth", "f8"),
    # several cables (the topology fields): whether segments of different cables touch (cable contacts, always on
    # with several cables), and the substeps summed in junction_sum (a step's count: par.substeps)
    ("cable_contact", "?"), ("junction_count", "i8"),
])


#: Each cable's parameters (``SolverState.cable_par``, one record per cable, a row of ``chain_seg``): what the model
#: makes of its material (:class:`mjcable.solvers.state.Rules`), read once per chain by the sweeps and per row by the
#: direct solve, so that cables of different radius, segment length, damping, E·A and E·I share one state.
CABLE_PARAMS = np.dtype([
    ("radius", "f8"), ("l0", "f8"), ("inv_l0sq", "f8"),  # m, m, 1/m²: radius, rest segment length, 1 / l₀²
    # XPBD compliances α (stretch m/N, curvature 1/(N·m³) or distance m/N, clamp 1/(N·m³)), the same per substep
    # α̃ = α / h², and the per-iteration factors k in [0, 1]
    ("alpha_s", "f8"), ("alpha_b", "f8"), ("alpha_c", "f8"), ("at_s", "f8"), ("at_b", "f8"), ("at_c", "f8"),
    ("k_s", "f8"), ("k_b", "f8"), ("k_c", "f8"),
    # segments apart (j − i) from which two of the cable's own segments may touch: their capsules don't overlap at
    # rest, (j − i − 1) l₀ ≥ 2 r (cable_contact_kernels.self_contacts)
    ("near", "i8"),
    # whether the state's bending rows (par.bending) act on the cable: not on a limp one (E·I = 0) beside others
    ("bends", "?"),
])


def _a(dtype, ndim):
    return types.Array(dtype, ndim, "C")


_F1, _F2, _F3, _I1, _I2, _B1 = (_a(types.float64, 1), _a(types.float64, 2), _a(types.float64, 3),
                                _a(types.int64, 1), _a(types.int64, 2), _a(types.boolean, 1))

#: The state's fields: name, numba type, and what it holds (N particles of all cables, n = N − 1 segments (gaps
#: between cables included), P pins, K clamps, R direct rows, B obstacles, C/S obstacle/self contact capacity (in
#: the topology fields C: cables), L body pins, G moving geoms, J junctions, W winches; in the ring fields R: rings).
FIELDS = (
    # the chain
    ("x", _F2, "(N, 3) m positions"), ("v", _F2, "(N, 3) m/s velocities"), ("x0", _F2, "(N, 3) m substep start"),
    ("w", _F1, "(N,) 1/kg inverse masses (0: held)"), ("mass", _F1, "(N,) kg lumped masses"),
    ("react", _F2, "(N, 3) kg·m Σ ∇C Δλ a held particle collects"), ("dx", _F2, "(N, 3) m Jacobi corrections"),
    ("relax", _F1, "(N,) Jacobi relaxation ω / count"), ("prev", _F2, "(N, 3) m positions before the step"),
    ("query_x", _F2, "(N, 3) m positions at the last obstacle query"),
    ("rest", _F1, "(n,) m stretch rest lengths"), ("lam_s", _F1, "(n,) stretch multipliers"),
    ("rest_d", _F1, "(n-1,) m distance-bending rest lengths"), ("lam_d", _F1, "(n-1,) their multipliers"),
    ("lam_b", _F2, "(n-1, 3) curvature multipliers"),
    # clamps and pins
    ("clamp_pq", _I2, "(K, 2) [pinned particle, neighbour]"), ("clamp_pin", _I1, "(K,) the clamp's pin"),
    ("clamp_dir", _F3, "(K, 2, 3) the two clamped directions"), ("lam_c", _F2, "(K, 2) clamp multipliers"),
    ("pin_p", _I1, "(P,) pinned particles"), ("pin_from", _F2, "(P, 3) m target at the step's start"),
    ("pin_to", _F2, "(P, 3) m target at its end"), ("pin_active", _B1, "(P,) holds (sockets let go)"),
    ("pin_release", _F1, "(P,) N release force (inf: never)"), ("pin_force", _F2, "(P, 3) N last substep's force"),
    ("pin_sum", _F2, "(P, 3) N Σ of the step's substep forces"), ("pin_count", _F1, "(P,) substeps in pin_sum"),
    # the direct order's banded system
    ("row_kind", _I1, "(R,) ROW_*"), ("row_idx", _I1, "(R,) constraint index"), ("row_p", _I2, "(R, 3) particles"),
    ("prow", _I2, "(N, W) rows touching a particle"), ("pslot", _I2, "(N, W) the particle's slot in them"),
    ("band", _F2, "(R, bw + 1) lower band"), ("grad", _F3, "(R, 3, 3) row gradients"), ("rhs", _F1, "(R,)"),
    ("row_cable", _I1, "(R,) the row's cable (its compliance, factor and l₀: a row of cable_par)"),
    # friction, per particle and substep (sums over its contacts and the substep's iterations; Δλ in kg·m)
    ("fric_n", _F1, "(N,) kg·m the particle's share of its contacts' Σ Δλₙ"),
    ("fric_mu", _F1, "(N,) the largest μ of its contacts"), ("fric_slid", _B1, "(N,) it slid (reached the cone's rim)"),
    ("fric_nsum", _F2, "(N, 3) kg·m Σ share · Δλₙ n over its contacts"),
    ("fric_impulse", _F2, "(N, 3) kg·m its friction impulse"),
    ("fric_normal", _F2, "(N, 3) Σ share · n over its pressing contacts (its normal, unnormalised)"),
    ("fric_ob", _I1, "(N,) obstacle row of its friction contact (kept across substeps)"),
    # the particle's friction cone, from the sums (contact_kernels.friction_sweep's first pass)
    ("fric_unit", _F2, "(N, 3) its unit normal n̂"), ("fric_push", _F2, "(N, 3) kg·m the sums' tangential part"),
    ("fric_cone", _F1, "(N,) kg·m the cone's radius μ λₙ (−1: no friction this substep)"),
    ("fric_sole", _B1, "(N,) its one contact is a flat one at it, its normal in fric_unit (query_kernels)"),
    ("anchor", _F2, "(N, 3) m friction anchors in their obstacle's frame (the world's for a static one)"),
    ("anchor_ob", _I1, "(N,) the anchors' obstacle rows (−1: none)"),
    # obstacle contacts (C: the buffers' capacity, par.n_con in use; grown together by query_kernels.reserve_contacts)
    ("con_seg", _I1, "(C,) the contact's segment"), ("con_s", _F1, "(C,) fraction s of its axis point on the segment"),
    ("con_normal", _F2, "(C, 3) the detection's unit normal n₀, from the obstacle to the cable"),
    ("con_offset", _F1, "(C,) m half-space offset: n₀·p ≥ offset (n₀·q + radius, q on the obstacle)"),
    ("con_mu", _F1, "(C,) Coulomb μ"), ("con_shape", _I1, "(C,) the obstacle's shape row (−1: half-space only)"),
    ("con_face", _I1, "(C,) the face n₀ picks on a static box (BOX_FACE_*; −1: none, or found in every sweep)"),
    ("con_lam", _F1, "(C,) kg·m normal multipliers"),
    # self contacts (S: capacity, par.n_self in use; grown together by cable_contact_kernels.self_contacts)
    ("self_pair", _I2, "(S, 2) segments i, j"), ("self_st", _F2, "(S, 2) fractions s, t of the closest points"),
    ("self_normal", _F2, "(S, 3) unit normal from segment j to segment i"),
    ("self_lam_n", _F1, "(S,) kg·m normal multipliers"), ("self_lam_t", _F1, "(S,) kg·m friction multipliers"),
    ("self_anchor", _F2, "(S, 6) a contact between two cables' friction anchor, kept across steps: the fractions s, "
     "t of the points that touched and the normal then, and its λₙ at the end of the last sweep "
     "(cable_contact_kernels)"),
    # obstacle shapes (B rows; contacts and anchors name their row)
    ("shape_type", _I1, "(B,) MuJoCo geom type (mjtGeom)"), ("shape_size", _F2, "(B, 3) m geom size"),
    ("shape_pos", _F2, "(B, 3) m world position"), ("shape_rot", _F3, "(B, 3, 3) world rotation (geom to world)"),
    ("shape_moves", _B1, "(B,) on a moving body (its pose is refreshed)"),
    # two-way contacts: per obstacle row, Σ Δλ ∇C over a substep (collect_impulses; ÷ h the momentum the contacts
    # gave the cable, ÷ h² the force) and its moment about the world origin; (0, 3) where no body takes them
    ("impulse_force", _F2, "(B, 3) or (0, 3) kg·m"), ("impulse_moment", _F2, "(B, 3) or (0, 3) kg·m²"),
    # the contact query: static obstacles' bounds, mjData views (struct and arena), the proxy's poses and margins,
    # geom maps, moving geoms and their poses
    ("box_lo", _F2, "(B', 3) m"), ("box_hi", _F2, "(B', 3) m"), ("plane_n", _F2, "(F, 3)"), ("plane_p", _F2, "(F, 3) m"),
    ("struct_i32", _a(types.int32, 1), "mjData as int32 words"), ("struct_i64", _I1, "mjData as int64 words"),
    ("arena_f64", _F1, "mjData's arena as float64"), ("arena_i32", _a(types.int32, 1), "mjData's arena as int32"),
    ("pose_pos", _F2, "(n, 3) proxy mocap_pos"), ("pose_quat", _F2, "(n, 4) proxy mocap_quat"),
    ("pair_margin", _F1, "(npair,) mjModel.pair_margin"), ("segment_of_geom", _I1, "(ngeom,) −1: none"),
    ("shape_of_geom", _I1, "(ngeom,) −1: none"), ("geom_friction", _F2, "(ngeom, 3)"),
    ("moving", _I2, "(G, 2) [geom, shape row] of moving obstacles"), ("geom_xpos", _F2, "mjData.geom_xpos"),
    ("geom_xmat", _F2, "mjData.geom_xmat"),
    # the user world's host: body pins (L), their clamps, mjData views, the warnings that stop a step, two-way rows
    ("link_pin", _I1, "(L,) pin"), ("link_particle", _I1, "(L,)"), ("link_neighbour", _I1, "(L,)"),
    ("link_body", _I1, "(L,)"), ("link_site", _I1, "(L,)"), ("link_clamp", _I2, "(K', 2) [clamp row, body]"),
    ("clamp_local", _F3, "(K', 3, 2) clamp directions in the body"),
    ("clamp_qlocal", _F2, "(K', 4) or (0, 4) a rod's clamped frames in their bodies (w, x, y, z)"),
    ("site_xpos", _F2, "mjData.site_xpos"), ("xipos", _F2, "mjData.xipos"), ("xmat", _F2, "mjData.xmat"),
    ("xquat", _F2, "mjData.xquat"), ("xfrc_applied", _F2, "mjData.xfrc_applied"),
    ("warning_number", types.Array(types.int32, 1, "A"), "mjData.warning.number (strided)"),
    ("bad", _I1, "(W,) warnings that stop"),
    ("wrench_rows", _I1, "(R',) obstacle rows on dynamic bodies"), ("wrench_bodies", _I1, "(R',) their bodies"),
    ("contact_wrench", _F2, "(nbody, 6) N, N·m"),
    # the host's scratch (sized at construction)
    ("saved", _F1, "(nstate,)"), ("jacp", _F2, "(3, nv)"), ("jn", _F2, "(1, nv)"), ("solved", _F2, "(1, nv)"),
    ("start_from", _F2, "(P, 3)"), ("start_to", _F2, "(P, 3)"), ("target", _F2, "(P, 3)"), ("p0", _F2, "(L, 3)"),
    ("arm", _F2, "(L, 3)"), ("free", _F2, "(L, 3)"), ("free_w", _F1, "(L,)"), ("force", _F2, "(L, 3)"),
    ("applied", _F2, "(L, 6)"), ("jacr", _F2, "(3, nv)"), ("solved_r", _F2, "(3, nv)"),
    ("par", _a(numba.from_dtype(PARAMS), 1), "(1,) PARAMS"),
    # the direct order's rows with the geometric stiffness: the rows above and two transverse rows per stretch row
    # (R' rows, ROW_TRANSVERSE), and the stretch multipliers it is taken from
    ("gs_row_kind", _I1, "(R',) ROW_*"), ("gs_row_idx", _I1, "(R',) constraint index"),
    ("gs_row_p", _I2, "(R', 3) particles"), ("gs_prow", _I2, "(N, W') rows touching a particle"),
    ("gs_pslot", _I2, "(N, W') the particle's slot in them"), ("gs_band", _F2, "(R', bw' + 1) lower band"),
    ("gs_grad", _F3, "(R', 3, 3) row gradients"), ("gs_rhs", _F1, "(R',)"), ("gs_row_cable", _I1, "(R',)"),
    ("lam_gs", _F1, "(n,) stretch multipliers of the last direct solve"),
    ("gs_blocks", _F2, "(n, 12) or (0, 12) per segment of a stretch chain (par.gs_chain): its direction n (3), the "
     "block solve's E = Π D⁻¹ Π (6: xx, yy, zz, xy, xz, yz) and forward-substituted y (3)"),
    # the cosserat rod's material frames (cosserat_kernels; every array (0, ...) for the other models)
    ("q", _F2, "(n, 4) segment frames, unit quaternions (w, x, y, z), body to world"),
    ("q0", _F2, "(n, 4) frames at the substep's start"), ("omega", _F2, "(n, 3) rad/s angular velocities (body)"),
    ("inertia", _F2, "(n, 3) kg·m² principal rotational inertias (body)"),
    ("wq", _F2, "(n, 3) 1/(kg·m²) inverse inertias (0: a held frame)"),
    ("darboux0", _F2, "(n-1, 3) 1/m rest Darboux vectors"), ("lam_ss", _F2, "(n, 3) stretch–shear multipliers"),
    ("lam_bt", _F2, "(n-1, 3) bend–twist multipliers"),
    ("lam_end", _F2, "(2, 3) multipliers of the clamps' constraints at the rod's start and end"),
    ("clamp_seg", _I1, "(K,) the segment next to a clamp"), ("clamp_q", _F2, "(K, 4) the frame a clamp holds"),
    ("clamp_qfrom", _F2, "(K, 4) its target at the step's start"), ("clamp_qto", _F2, "(K, 4) at its end"),
    ("clamp_react", _F2, "(K, 3) Σ R ∇_c Cᵀ Δλ the clamp's frame collects (world; a chain's body clamp: "
     "Σ ∇_θ C Δλ)"),
    ("clamp_wq", _F3, "(K, 3, 3) 1/(kg·m²) a clamp frame's inverse inertia in that frame (0: held; a body clamp's "
     "body; a chain's body clamp: its body's, in the world)"),
    ("end_clamp", _I1, "(2,) the clamp row at the rod's start and end (−1: none)"),
    ("weld_seg", _I2, "(W, 2) the segments [a, b] whose frames a clamped junction welds (cosserat_weld_kernels)"),
    ("weld_r0", _F2, "(W, 4) the weld's rest turn q̄_a ⊗ q_b of the start frames"),
    ("lam_weld", _F2, "(W, 3) the welds' multipliers"),
    ("cs_jac", _F3, "(4n + 4, 3, 3) Jacobian blocks"), ("cs_band", _F2, "(6n + 3, 9) the direct solve's band"),
    ("cs_rhs", _F1, "(6n + 3,) its right-hand side, then Δλ"), ("cs_db", _F2, "(n, 3) rad body rotations of a solve"),
    # the topology of several cables (one chain per cable, concatenated in cable order; the segment from a cable's
    # last particle to the next cable's first is a gap: no constraint, contact or check acts on it)
    ("seg_cable", _I1, "(n,) the cable of each segment (−1: a gap)"),
    ("chain_seg", _I2, "(C, 2) each cable's segments [first, stop)"), ("cable_mu", _F1, "(C,) each cable's Coulomb μ"),
    ("cable_par", _a(numba.from_dtype(CABLE_PARAMS), 1), "(C,) each cable's parameters (CABLE_PARAMS)"),
    ("seg_radius", _F1, "(n,) m the radius of each segment's cable (0: a gap)"),
    ("damp", _F1, "(N,) each particle's cable's damping factor e^{−c h} (1 at a ring's hub)"),
    ("junction_p", _I2, "(J, 2) the particles [a, b] a junction makes one point"),
    ("lam_j", _F2, "(J, 3) kg·m junction multipliers of the substep (the impulse on b · h)"),
    ("junction_sum", _F2, "(J, 3) N Σ of the step's substep forces on b"),
    ("joined_p", _I2, "(M, 2) every pair of particles the junctions make one point (through others too): the "
     "segment pairs near them never touch"),
    ("brace_p", _I2, "(Q, 2) a clamped junction's braces: a neighbour of each joined particle (junction_kernels)"),
    ("brace_d", _F1, "(Q,) m the braces' lengths: their particles' start distance"),
    # winches (winch_kernels; every array (0, ...) without one): the pin row, the cable, which way its free part runs
    # (+1: to higher indices), the spool's last particle, the free end, the host link of a body winch (−1: a world
    # winch), a world winch's point, the cable's direction leaving the winch, the free part r of the first segment,
    # the reel speed, the cable's mass per metre and segment length
    ("winch_pin", _I1, "(W,) pin row"), ("winch_cable", _I1, "(W,) cable"), ("winch_dir", _I1, "(W,) +1 or −1"),
    ("winch_end", _I1, "(W,) the spool's last particle"), ("winch_far", _I1, "(W,) the cable's free end"),
    ("winch_link", _I1, "(W,) link row (−1: world)"), ("winch_at", _F2, "(W, 3) m"), ("winch_u", _F2, "(W, 3) unit"),
    ("winch_len", _F1, "(W,) m r in [0, l0]"), ("winch_speed", _F1, "(W,) m/s (positive pays out)"),
    ("winch_rho", _F1, "(W,) kg/m"), ("winch_l0", _F1, "(W,) m"),
    ("cable_load", _F2, "(N, 2) kg·m, 1: a particle's Σ share · λₙ and Σ share over its pressing contacts with other "
     "cables, the pooled friction cones' sums (cable_contact_kernels)"),
    # rings (ring_kernels; R rings, every array (0, ...) without): each ring's centre is a hub particle after the
    # cables' (held by a pin row: a world pin, or a body pin's coupling), and the cable slides through it
    ("ring_p", _I1, "(R,) the ring's hub particle"), ("ring_pin", _I1, "(R,) the hub's pin row"),
    ("ring_seg", _I1, "(R,) the segment the ring holds (its rest length negated while it does)"),
    ("ring_t", _F1, "(R,) the held material point's fraction along ring_seg (the friction anchor)"),
    ("ring_mode", _I1, "(R,) RING_SLIDING, RING_LET_GO or RING_STOPPED"),
    ("ring_mu", _F1, "(R,) the rim's Coulomb μ"), ("ring_stop", _I1, "(R,) the stop particle (−1: none)"),
    ("ring_cable", _I1, "(R,) the cable (a row of chain_seg) through it"),
    ("ring_lam", _F1, "(R,) kg·m the material point's multiplier of the substep (the length's: lam_s)"),
    ("ring_dir", _F2, "(R, 3) unit direction of the cable's pull on the ring (a body ring's inverse mass)"),
    ("ring_tension", _F1, "(R,) kg·m the length's multiplier at the last substep's end (the direct solve's "
     "geometric stiffness of the arms in the next substep's first solve)"),
)


@structref.register
class SolverStateType(types.StructRef):
    """numba's type of :class:`SolverState`."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


class SolverState(structref.StructRefProxy):
    """The particle solver's state (see the module docstring); built by :func:`mjcable.solvers.kernels_layout.assemble`,
    read from Python through the numpy views it returns beside it."""


structref.define_boxing(SolverStateType, SolverState)
STATE_TYPE = SolverStateType([(name, typ) for name, typ, _ in FIELDS])




# -- assembly: the state's parts, each set by one function (numba sets a structref's fields by name only) -----------


@_jit
def _chain(S, x, v, x0, w, mass, react, dx, relax, prev, query_x, par):
    S.x, S.v, S.x0, S.w, S.mass, S.react, S.dx, S.relax = x, v, x0, w, mass, react, dx, relax
    S.prev, S.query_x, S.par = prev, query_x, par


@_jit
def _constraints(S, rest, lam_s, rest_d, lam_d, lam_b, clamp_pq, clamp_pin, clamp_dir, lam_c):
    S.rest, S.lam_s, S.rest_d, S.lam_d, S.lam_b = rest, lam_s, rest_d, lam_d, lam_b
    S.clamp_pq, S.clamp_pin, S.clamp_dir, S.lam_c = clamp_pq, clamp_pin, clamp_dir, lam_c


@_jit
def _pins(S, pin_p, pin_from, pin_to, pin_active, pin_release, pin_force, pin_sum, pin_count):
    S.pin_p, S.pin_from, S.pin_to, S.pin_active = pin_p, pin_from, pin_to, pin_active
    S.pin_release, S.pin_force, S.pin_sum, S.pin_count = pin_release, pin_force, pin_sum, pin_count


@_jit
def _direct(S, row_kind, row_idx, row_p, prow, pslot, band, grad, rhs, row_cable):
    S.row_kind, S.row_idx, S.row_p, S.prow, S.pslot, S.band, S.grad, S.rhs = (row_kind, row_idx, row_p, prow, pslot,
                                                                             band, grad, rhs)
    S.row_cable = row_cable


@_jit
def _friction(S, fric_n, fric_mu, fric_slid, fric_nsum, fric_impulse, fric_normal, fric_ob):
    S.fric_n, S.fric_mu, S.fric_slid, S.fric_nsum = fric_n, fric_mu, fric_slid, fric_nsum
    S.fric_impulse, S.fric_normal, S.fric_ob = fric_impulse, fric_normal, fric_ob


@_jit
def _anchors(S, fric_unit, fric_push, fric_cone, fric_sole, anchor, anchor_ob):
    S.fric_unit, S.fric_push, S.fric_cone, S.fric_sole = fric_unit, fric_push, fric_cone, fric_sole
    S.anchor, S.anchor_ob = anchor, anchor_ob


@_jit
def _obstacle_contacts(S, con_seg, con_s, con_normal, con_offset, con_mu, con_shape, con_face, con_lam):
    S.con_seg, S.con_s, S.con_normal, S.con_offset, S.con_mu = con_seg, con_s, con_normal, con_offset, con_mu
    S.con_shape, S.con_face, S.con_lam = con_shape, con_face, con_lam


@_jit
def _self_contacts(S, self_pair, self_st, self_normal, self_lam_n, self_lam_t, self_anchor):
    S.self_pair, S.self_st, S.self_normal, S.self_lam_n, S.self_lam_t = (self_pair, self_st, self_normal, self_lam_n,
                                                                         self_lam_t)
    S.self_anchor = self_anchor


@_jit
def _shapes(S, shape_type, shape_size, shape_pos, shape_rot, shape_moves, impulse_force, impulse_moment):
    S.shape_type, S.shape_size, S.shape_pos, S.shape_rot = shape_type, shape_size, shape_pos, shape_rot
    S.shape_moves = shape_moves
    S.impulse_force, S.impulse_moment = impulse_force, impulse_moment


@_jit
def _query(S, box_lo, box_hi, plane_n, plane_p, struct_i32, struct_i64, arena_f64, arena_i32, pose_pos, pose_quat):
    S.box_lo, S.box_hi, S.plane_n, S.plane_p = box_lo, box_hi, plane_n, plane_p
    S.struct_i32, S.struct_i64, S.arena_f64, S.arena_i32, S.pose_pos, S.pose_quat = (struct_i32, struct_i64, arena_f64,
                                                                                   arena_i32, pose_pos, pose_quat)


@_jit
def _geoms(S, pair_margin, segment_of_geom, shape_of_geom, geom_friction, moving, geom_xpos, geom_xmat):
    S.pair_margin, S.segment_of_geom, S.shape_of_geom, S.geom_friction = (pair_margin, segment_of_geom, shape_of_geom,
                                                                          geom_friction)
    S.moving, S.geom_xpos, S.geom_xmat = moving, geom_xpos, geom_xmat


@_jit
def _links(S, link_pin, link_particle, link_neighbour, link_body, link_site, link_clamp, clamp_local, clamp_qlocal):
    S.link_pin, S.link_particle, S.link_neighbour, S.link_body, S.link_site = (link_pin, link_particle, link_neighbour,
                                                                               link_body, link_site)
    S.link_clamp, S.clamp_local, S.clamp_qlocal = link_clamp, clamp_local, clamp_qlocal


@_jit
def _world(S, site_xpos, xipos, xmat, xquat, xfrc_applied, warning_number, bad, wrench_rows, wrench_bodies,
           contact_wrench):
    S.site_xpos, S.xipos, S.xmat, S.xquat, S.xfrc_applied, S.warning_number, S.bad = (
        site_xpos, xipos, xmat, xquat, xfrc_applied, warning_number, bad)
    S.wrench_rows, S.wrench_bodies, S.contact_wrench = wrench_rows, wrench_bodies, contact_wrench


@_jit
def _scratch(S, saved, jacp, jn, solved, start_from, start_to, target, p0, arm, free, free_w):
    S.saved, S.jacp, S.jn, S.solved, S.start_from, S.start_to, S.target = (saved, jacp, jn, solved, start_from,
                                                                           start_to, target)
    S.p0, S.arm, S.free, S.free_w = p0, arm, free, free_w


@_jit
def _scratch_forces(S, force, applied, jacr, solved_r):
    S.force, S.applied, S.jacr, S.solved_r = force, applied, jacr, solved_r


@_jit
def _geometric(S, gs_row_kind, gs_row_idx, gs_row_p, gs_prow, gs_pslot, gs_band, gs_grad, gs_rhs, gs_row_cable, lam_gs,
               gs_blocks):
    S.gs_row_kind, S.gs_row_idx, S.gs_row_p, S.gs_prow, S.gs_pslot = gs_row_kind, gs_row_idx, gs_row_p, gs_prow, gs_pslot
    S.gs_band, S.gs_grad, S.gs_rhs, S.gs_row_cable = gs_band, gs_grad, gs_rhs, gs_row_cable
    S.lam_gs, S.gs_blocks = lam_gs, gs_blocks


@_jit
def _frames(S, q, q0, omega, inertia, wq, darboux0, lam_ss, lam_bt, lam_end):
    S.q, S.q0, S.omega, S.inertia, S.wq, S.darboux0 = q, q0, omega, inertia, wq, darboux0
    S.lam_ss, S.lam_bt, S.lam_end = lam_ss, lam_bt, lam_end


@_jit
def _frame_scratch(S, clamp_seg, clamp_q, clamp_qfrom, clamp_qto, clamp_react, clamp_wq, end_clamp, cs_jac,
                   cs_band, cs_rhs, cs_db):
    S.clamp_seg, S.clamp_q, S.clamp_qfrom, S.clamp_qto = clamp_seg, clamp_q, clamp_qfrom, clamp_qto
    S.clamp_react, S.clamp_wq, S.end_clamp = clamp_react, clamp_wq, end_clamp
    S.cs_jac, S.cs_band, S.cs_rhs, S.cs_db = cs_jac, cs_band, cs_rhs, cs_db


@_jit
def _welds(S, weld_seg, weld_r0, lam_weld):
    S.weld_seg, S.weld_r0, S.lam_weld = weld_seg, weld_r0, lam_weld


@_jit
def _topology(S, seg_cable, chain_seg, cable_mu, junction_p, lam_j, junction_sum, joined_p, cable_load, brace_p,
              brace_d):
    S.seg_cable, S.chain_seg, S.cable_mu = seg_cable, chain_seg, cable_mu
    S.junction_p, S.lam_j, S.junction_sum, S.joined_p = junction_p, lam_j, junction_sum, joined_p
    S.cable_load, S.brace_p, S.brace_d = cable_load, brace_p, brace_d


@_jit
def _cables(S, cable_par, seg_radius, damp):
    S.cable_par, S.seg_radius, S.damp = cable_par, seg_radius, damp


@_jit
def _winch_topology(S, winch_pin, winch_cable, winch_dir, winch_end, winch_far, winch_link):
    S.winch_pin, S.winch_cable, S.winch_dir = winch_pin, winch_cable, winch_dir
    S.winch_end, S.winch_far, S.winch_link = winch_end, winch_far, winch_link


@_jit
def _winch_motion(S, winch_at, winch_u, winch_len, winch_speed, winch_rho, winch_l0):
    S.winch_at, S.winch_u, S.winch_len, S.winch_speed, S.winch_rho, S.winch_l0 = (winch_at, winch_u, winch_len,
                                                                                 winch_speed, winch_rho, winch_l0)


@_jit
def _rings(S, ring_p, ring_pin, ring_seg, ring_t, ring_mode, ring_mu, ring_stop, ring_cable):
    S.ring_p, S.ring_pin, S.ring_seg, S.ring_t, S.ring_mode = ring_p, ring_pin, ring_seg, ring_t, ring_mode
    S.ring_mu, S.ring_stop, S.ring_cable = ring_mu, ring_stop, ring_cable


@_jit
def _ring_multipliers(S, ring_lam, ring_dir, ring_tension):
    S.ring_lam, S.ring_dir, S.ring_tension = ring_lam, ring_dir, ring_tension


@_jit
def _new():
    return structref.new(STATE_TYPE)


#: the parts in the order :func:`assemble` sets them, each with its setter: every field of FIELDS once
_PARTS = (
    (_chain, ("x", "v", "x0", "w", "mass", "react", "dx", "relax", "prev", "query_x", "par")),
    (_constraints, ("rest", "lam_s", "rest_d", "lam_d", "lam_b", "clamp_pq", "clamp_pin", "clamp_dir", "lam_c")),
    (_pins, ("pin_p", "pin_from", "pin_to", "pin_active", "pin_release", "pin_force", "pin_sum", "pin_count")),
    (_direct, ("row_kind", "row_idx", "row_p", "prow", "pslot", "band", "grad", "rhs", "row_cable")),
    (_friction, ("fric_n", "fric_mu", "fric_slid", "fric_nsum", "fric_impulse", "fric_normal", "fric_ob")),
    (_anchors, ("fric_unit", "fric_push", "fric_cone", "fric_sole", "anchor", "anchor_ob")),
    (_obstacle_contacts, ("con_seg", "con_s", "con_normal", "con_offset", "con_mu", "con_shape", "con_face",
                          "con_lam")),
    (_self_contacts, ("self_pair", "self_st", "self_normal", "self_lam_n", "self_lam_t", "self_anchor")),
    (_shapes, ("shape_type", "shape_size", "shape_pos", "shape_rot", "shape_moves", "impulse_force",
               "impulse_moment")),
    (_query, ("box_lo", "box_hi", "plane_n", "plane_p", "struct_i32", "struct_i64", "arena_f64", "arena_i32",
              "pose_pos", "pose_quat")),
    (_geoms, ("pair_margin", "segment_of_geom", "shape_of_geom", "geom_friction", "moving", "geom_xpos",
              "geom_xmat")),
    (_links, ("link_pin", "link_particle", "link_neighbour", "link_body", "link_site", "link_clamp", "clamp_local",
               "clamp_qlocal")),
    (_world, ("site_xpos", "xipos", "xmat", "xquat", "xfrc_applied", "warning_number", "bad", "wrench_rows",
              "wrench_bodies", "contact_wrench")),
    (_scratch, ("saved", "jacp", "jn", "solved", "start_from", "start_to", "target", "p0", "arm", "free", "free_w")),
    (_scratch_forces, ("force", "applied", "jacr", "solved_r")),
    (_geometric, ("gs_row_kind", "gs_row_idx", "gs_row_p", "gs_prow", "gs_pslot", "gs_band", "gs_grad", "gs_rhs",
                  "gs_row_cable", "lam_gs", "gs_blocks")),
    (_frames, ("q", "q0", "omega", "inertia", "wq", "darboux0", "lam_ss", "lam_bt", "lam_end")),
    (_frame_scratch, ("clamp_seg", "clamp_q", "clamp_qfrom", "clamp_qto", "clamp_react", "clamp_wq", "end_clamp",
                      "cs_jac", "cs_band", "cs_rhs", "cs_db")),
    (_welds, ("weld_seg", "weld_r0", "lam_weld")),
    (_topology, ("seg_cable", "chain_seg", "cable_mu", "junction_p", "lam_j", "junction_sum", "joined_p",
                 "cable_load", "brace_p", "brace_d")),
    (_cables, ("cable_par", "seg_radius", "damp")),
    (_winch_topology, ("winch_pin", "winch_cable", "winch_dir", "winch_end", "winch_far", "winch_link")),
    (_winch_motion, ("winch_at", "winch_u", "winch_len", "winch_speed", "winch_rho", "winch_l0")),
    (_rings, ("ring_p", "ring_pin", "ring_seg", "ring_t", "ring_mode", "ring_mu", "ring_stop", "ring_cable")),
    (_ring_multipliers, ("ring_lam", "ring_dir", "ring_tension")),
)
assert sorted(n for _, names in _PARTS for n in names) == sorted(n for n, _, _ in FIELDS)


def assemble(arrays: dict) -> SolverState:
    """A :class:`SolverState` holding ``arrays`` (field name → C-contiguous numpy array of the field's type, one for
    every field of :data:`FIELDS`); the state and the arrays share their memory."""
    S = _new()
    for setter, names in _PARTS:
        setter(S, *(arrays[n] for n in names))
    return S


@_jit
def contact_buffers(S):
    """The obstacle-contact buffers (``con_seg``, ``con_s``, ``con_normal``, ``con_offset``, ``con_mu``,
    ``con_shape``, ``con_face``, ``con_lam``): the compiled query replaces them when they must grow, so Python asks
    for them rather than keeping its own."""
    return S.con_seg, S.con_s, S.con_normal, S.con_offset, S.con_mu, S.con_shape, S.con_face, S.con_lam


@_jit
def self_contact_buffers(S):
    """The segment-contact buffers (``self_pair``, ``self_st``, ``self_normal``, ``self_lam_n``, ``self_lam_t``,
    ``self_anchor``), as :func:`contact_buffers`."""
    return S.self_pair, S.self_st, S.self_normal, S.self_lam_n, S.self_lam_t, S.self_anchor
