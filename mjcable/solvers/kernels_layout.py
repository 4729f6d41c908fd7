"""The particle solvers' data layout, shared by all kernel files: indices into the parameter arrays, the codes of
orders, bending models, direct-solve rows and substep phases, the solver state (:class:`Chain`) and the contacts
(:class:`Contacts`) named tuples, and the tolerances that several kernels use.

Numba freezes these module constants into the compiled kernels that read them, so this file is a kernel file for the
cache (its name matches ``*kernels*``: a change here recompiles every kernel, see
:mod:`mjcable.solvers._kernel_cache`). Re-exported by :mod:`mjcable.solvers.kernels`.
"""

from __future__ import annotations

from collections import namedtuple

# Indices into Chain.fp (floats) and Chain.ip (integers): named, so that driver and kernels agree.
FP = dict(h=0, damp=1, gx=2, gy=3, gz=4, alpha_s=5, alpha_b=6, alpha_c=7, k_s=8, k_b=9, k_c=10, inv_l0sq=11,
          omega=12, radius=13, mu_self=14)
IP = dict(iterations=0, order=1, bending=2, sqrt=3, bandwidth=4, direct_all=5, substeps=6)
# Indices into run_steps_flat's ``lim`` (floats): step (s), divergence limits (m, m/s), the contact query's terms.
LIM = dict(dt=0, max_distance=1, max_speed=2, contact_margin=3, fall=4, radius=5)
N_FP = len(FP)
N_IP = len(IP)
_F_H, _F_DAMP, _F_GX, _F_GY, _F_GZ = 0, 1, 2, 3, 4
_F_ALPHA_S, _F_ALPHA_B, _F_ALPHA_C, _F_K_S, _F_K_B, _F_K_C = 5, 6, 7, 8, 9, 10
_F_INV_L0SQ, _F_OMEGA, _F_RADIUS, _F_MU_SELF = 11, 12, 13, 14
_I_ITER, _I_ORDER, _I_BEND, _I_SQRT, _I_BW, _I_DIRECT_ALL, _I_SUBSTEPS = 0, 1, 2, 3, 4, 5, 6
_L_DT, _L_DISTANCE, _L_SPEED, _L_MARGIN, _L_FALL, _L_RADIUS = 0, 1, 2, 3, 4, 5

ORDER_GAUSS_SEIDEL, ORDER_JACOBI, ORDER_DIRECT = 0, 1, 2
BEND_NONE, BEND_CURVATURE, BEND_DISTANCE = 0, 1, 2
ROW_STRETCH, ROW_CURVATURE, ROW_DISTANCE, ROW_CLAMP = 0, 1, 2, 3
# MuJoCo's geom type codes (mujoco.mjtGeom) that the contact kernels measure exactly.
GEOM_PLANE, GEOM_SPHERE, GEOM_CAPSULE, GEOM_ELLIPSOID, GEOM_CYLINDER, GEOM_BOX = 0, 2, 3, 4, 5, 6
# Columns of Contacts.shapes (B, 16), one row per obstacle geom: type, size (3), pos (3), row-major rotation (9).
SH_TYPE, SH_SIZE, SH_POS, SH_ROT, N_SH = 0, 1, 4, 7, 16
# Columns of Chain.fric (N, 13), per particle and substep: its share of the contacts' Σ Δλₙ, their largest μ,
# slid (0/1), Σ Δλₙ n (3), its friction impulse (3), Σ share · n over its pressing contacts (3), the obstacle
# row of its last contact (kept across substeps).
FR_FN, FR_MU, FR_SLID, FR_NX, FR_FT, FR_GN, FR_OB, N_FR = 0, 1, 2, 3, 6, 9, 12, 13
PHASE_ALL, PHASE_BEGIN, PHASE_ITERATE, PHASE_END = 0, 1, 2, 3
# Entries of run_steps_flat's ``capi`` (int64): whether the loop queries contacts itself (0: it returns to Python
# for every query), the addresses of mj_kinematics, mj_collision, the proxy's mjModel and mjData, the index of
# mjData.ncon in its int32 words and of mjData.contact in its int64 words, the arena's address, sizeof(mjContact) and
# the byte offsets of its dist, pos, frame and geom (mjcable.solvers.capi.Layout), the cable's pairs' first and
# past-the-last rows of pair_margin.
CAPI = dict(enabled=0, kinematics=1, collision=2, model=3, data=4, ncon=5, contact=6, arena=7, stride=8, dist=9, pos=10,
            frame=11, geom=12, pair_start=13, pair_stop=14)
(CAPI_ENABLED, CAPI_KINEMATICS, CAPI_COLLISION, CAPI_MODEL, CAPI_DATA, CAPI_NCON, CAPI_CONTACT, CAPI_ARENA,
 CAPI_STRIDE, CAPI_DIST, CAPI_POS, CAPI_FRAME, CAPI_GEOM, CAPI_PAIR_START, CAPI_PAIR_STOP) = range(15)
N_CAPI = len(CAPI)
# Entries of run_steps_flat's ``counts`` (int64): the last step's obstacle and self contacts, contact queries run.
COUNT_CONTACTS, COUNT_SELF, COUNT_QUERIES = 0, 1, 2
# Columns of Chain.pin_sum (P, 4): the sum of a pin's substep forces over the current step (N) and how many substeps
# it holds; the step's mean force is their ratio (kernels.end_substep).
PS_F, PS_N, N_PS = 0, 3, 4

_TINY_LENGTH = 1e-12  # m: a segment shorter than this has no direction; its projection is skipped
_TINY_SLIP = 1e-15  # m: tangential slip below this needs no friction correction

# The solver state, owned by the driver (mjcable.solvers.state) and passed whole to the driver kernels.
Chain = namedtuple("Chain", [
    "x", "v", "x0", "w", "mass", "react", "dx", "count",  # particles (N, 3) / (N,)
    "rest", "lam_s",  # stretch constraint i joins particles i, i+1: rest length (n,), multiplier (n,)
    "rest_d", "lam_d",  # distance bending b joins b, b+2: rest 2 l₀ (n-1,), multiplier (n-1,)
    "lam_b",  # curvature bending at particle b+1: multipliers (n-1, 3)
    "clamp_pq", "clamp_pin", "clamp_dir", "lam_c",  # clamps (K, 2) [pin particle, neighbour], (K,), (K, 2, 3), (K, 2)
    "pin_p", "pin_from", "pin_to", "pin_active", "pin_release", "pin_force",  # pins (P,), (P, 3), ..., (P, 3)
    "pin_sum",  # (P, 4): per pin, Σ of the step's substep forces so far (N, columns PS_F..+2), their count (PS_N)
    "row_kind", "row_idx", "row_p", "prow", "pslot", "band", "grad", "rhs",  # direct order: the banded system
    "fric", "anchor", "anchor_ob",  # friction: per-particle sums (N, N_FR), anchors (N, 3) in obstacle anchor_ob (N,)
    "fp", "ip",  # parameters (N_FP,), (N_IP,)
])
# Contacts found once per step: obstacle contacts and self contacts, re-projected in every substep and iteration.
Contacts = namedtuple("Contacts", [
    "seg", "geo", "lam",  # obstacle contacts: segment (C,), [s, n₀ (3), offset, μ, shape row] (C, 7), λₙ (C,)
    "pair", "sgeo", "slam",  # self contacts: segments (S, 2), [s, t, nx, ny, nz] (S, 5), [λₙ, λ_t] (S, 2)
    "shapes",  # the obstacles' shapes (B, N_SH)
    "impulse",  # per obstacle row, the substep's contact impulse on the cable (B, 6) or (0, 6) to skip it: IM_*
])
# Columns of Contacts.impulse (B, 6), summed over a substep by contact_kernels.collect_impulses: Σ Δλ ∇C (kg·m;
# ÷ h is the momentum the contacts gave the cable, ÷ h² the force), and its moment Σ point × impulse about the origin.
IM_F, IM_M = 0, 3
