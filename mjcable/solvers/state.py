"""The particle solvers' state: arrays built once from the scene and a model's rules, packed into one
:class:`~mjcable.solvers.kernels_layout.SolverState` that the numba kernels take whole.

Positions ``x`` and velocities ``v`` are ``(n + 1, 3)`` float64 arrays in metres and m/s; ``w`` holds inverse
masses (1 / lumped mass, 0 for a held particle), so that every correction is mass-weighted (Jakobsen's
``invmass`` form). :func:`chain_arrays` builds the chain's part (every field of
:data:`~mjcable.solvers.kernels_layout.FIELDS`, the contact query's and the user world's as empty placeholders);
the particle backend fills in the query's and the host's parts from the compiled MuJoCo model and
:func:`~mjcable.solvers.kernels_layout.assemble` packs them. Python keeps the arrays (:class:`StateArrays`), which
share their memory with the packed state.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Optional

import numpy as np
from scipy.spatial.transform import Rotation

from mjcable.scene import CableSpec, Scene
from mjcable.solvers import kernels_layout as layout
from mjcable.solvers.settings import ParticleSettings
from mjcable.solvers.topology import topology

__all__ = ["Rules", "StateArrays", "cable_rules", "chain_arrays", "ring_fields", "shared_cable", "single_cable",
           "quat_mul", "material_frames", "start_frames", "darboux", "ORDER_CODES", "BENDING_CODES"]

ORDER_CODES = {"gauss-seidel": layout.ORDER_GAUSS_SEIDEL, "jacobi": layout.ORDER_JACOBI,
               "direct": layout.ORDER_DIRECT}
BENDING_CODES = {"none": layout.BEND_NONE, "curvature": layout.BEND_CURVATURE, "distance": layout.BEND_DISTANCE}
_SELF_CONTACT_CAPACITY = 8  # initial self-contact buffers per segment (the compiled search grows them)
_CONTACT_CAPACITY = 4  # initial obstacle-contact buffers per segment: a cable lying on a face has about one a particle


@dataclasses.dataclass(frozen=True, kw_only=True)
class Rules:
    """What a model makes of one physical cable: the kernels' parameters (of several cables, one :class:`Rules` each,
    :func:`cable_rules`).

    Args:
      verlet_start: start like Verlet, the first substep's prediction x₁ = x₀ + h v₀ + ½ g h² (Taylor; free fall
        exact); else semi-implicit Euler, x₁ = x₀ + h v₀ + g h². The start state is at rest either way (v₀ = 0).
      alpha_stretch, alpha_bend, alpha_clamp: XPBD compliances α (stretch m/N, curvature 1/(N·m³), distance
        bending m/N, clamp 1/(N·m³)); 0 for PBD and Jakobsen.
      k_stretch, k_bend, k_clamp: per-iteration stiffness factors in [0, 1] (1 for XPBD).
      bending: ``"none"``, ``"curvature"`` or ``"distance"``.
      sqrt_approx: Jakobsen's square-root approximation for the stretch constraints.
      direct_bending: with ``order="direct"``, solve bending and clamps in the banded system too (XPBD, whose
        compliances make it well posed); otherwise only the stretch chain, with bending and clamps projected
        sequentially after it (PBD and Jakobsen: hard rows scaled by a stiffness do not form a solvable system).
      geometric_stiffness: with ``order="direct"``, the stretch rows' geometric stiffness λ ∇²C where the tension
        needs it (a KKT solve in positions and multipliers, :mod:`mjcable.solvers.direct_kernels`): for multipliers
        that are forces, k = 1 (XPBD; PBD and Jakobsen at ``stretch_factor`` 1, whose stretch rows are then XPBD's
        at α = 0), and a limp Cosserat rod's stretch rows (:mod:`mjcable.solvers.cosserat_direct_kernels`).
      rod_compliance: a Cosserat rod's six compliances (stretch–shear: shear, shear, stretch in 1/(N·m);
        bend–twist: bend, bend, twist in 1/(N·m³); :mod:`mjcable.solvers.cosserat_kernels`), which gives every
        segment a material frame; ``None``: no frames (the state's frame fields are empty).
      rod_limp: the rod has neither bending nor torsion stiffness: its direct solve leaves out the bend–twist rows
        (:mod:`mjcable.solvers.cosserat_direct_kernels`), as ``xpbd`` leaves out bending at E = 0.
    """

    verlet_start: bool
    alpha_stretch: float
    alpha_bend: float
    alpha_clamp: float
    k_stretch: float
    k_bend: float
    k_clamp: float
    bending: str
    sqrt_approx: bool = False
    direct_bending: bool = False
    geometric_stiffness: bool = False
    rod_compliance: Optional[tuple] = None
    rod_limp: bool = False


def _perpendiculars(axis: np.ndarray) -> np.ndarray:
    """Two unit vectors (2, 3) perpendicular to the unit vector ``axis`` and to each other."""
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    d1 = np.cross(axis, helper)
    d1 /= np.linalg.norm(d1)
    return np.stack([d1, np.cross(axis, d1)])


def _direct_rows(seg_cable: np.ndarray, bending: str, clamp_pq: np.ndarray, transverse: bool = False,
                 bends: Optional[np.ndarray] = None) -> dict:
    """The banded system's rows of the segments of cables (``seg_cable`` (n,) ≥ 0; a gap between two cables has
    none), in order of their first particle, with each row's cable, per-particle row lists and the half-bandwidth;
    bending rows on the cables that ``bends`` (C,) marks (``None``: all); with ``transverse``, each stretch row
    followed by its two transverse rows (the geometric stiffness, :mod:`mjcable.solvers.direct_kernels`). The gaps
    make it one band per cable, solved as one."""
    link = seg_cable >= 0
    n = len(link)
    n_particles = n + 1
    segments = [i for i in range(n) if link[i]]
    triplets = [b for b in range(n - 1) if link[b] and link[b + 1] and (bends is None or bends[seg_cable[b]])]
    rows = []
    for i in segments:
        rows += [(i, layout.ROW_STRETCH, i, (i, i + 1))]
        if transverse:
            rows += [(i, layout.ROW_TRANSVERSE, 2 * i + k, (i, i + 1)) for k in range(2)]
    if bending == "curvature":
        rows += [(b, layout.ROW_CURVATURE, 3 * b + comp, (b, b + 1, b + 2)) for b in triplets for comp in range(3)]
    elif bending == "distance":
        rows += [(b, layout.ROW_DISTANCE, b, (b, b + 2)) for b in triplets]
    for kc, (p, q) in enumerate(clamp_pq):
        rows += [(min(p, q), layout.ROW_CLAMP, 2 * kc + m, (int(p), int(q))) for m in range(2)]
    rows.sort(key=lambda r: r[0])  # stable: keeps the kinds' relative order per particle
    nrow = len(rows)
    row_kind = np.array([r[1] for r in rows], dtype=np.int64)
    row_cable = np.array([max(seg_cable[min(r[3])], 0) for r in rows], dtype=np.int64)  # (its first segment's)
    row_idx = np.array([r[2] for r in rows], dtype=np.int64)
    row_p = np.full((nrow, 3), -1, dtype=np.int64)
    touching = [[] for _ in range(n_particles)]
    for r, (_, _, _, parts) in enumerate(rows):
        for slot, p in enumerate(parts):
            row_p[r, slot] = p
            touching[p].append((r, slot))
    width = max(max(len(t) for t in touching), 1)
    prow = np.full((n_particles, width), -1, dtype=np.int64)
    pslot = np.zeros((n_particles, width), dtype=np.int64)
    bandwidth = 0
    for p, t in enumerate(touching):
        for k, (r, slot) in enumerate(t):
            prow[p, k], pslot[p, k] = r, slot
        if t:
            bandwidth = max(bandwidth, max(r for r, _ in t) - min(r for r, _ in t))
    return dict(row_kind=row_kind, row_idx=row_idx, row_p=row_p, row_cable=row_cable, prow=prow, pslot=pslot,
                band=np.zeros((nrow, bandwidth + 1)), grad=np.zeros((nrow, 3, 3)), rhs=np.zeros(nrow),
                bandwidth=bandwidth)


class StateArrays(dict):
    """The state's arrays by field name (:data:`~mjcable.solvers.kernels_layout.FIELDS`), also as attributes
    (``arrays.x``), and the parameter record's fields as ``arrays.par[0]["h"]``."""

    __getattr__ = dict.__getitem__


def _contact_buffers(capacity: int, self_capacity: int) -> dict:
    """Empty obstacle- and self-contact buffers (the state's ``con_*`` and ``self_*``) for ``capacity`` and
    ``self_capacity`` contacts (the compiled query grows them)."""
    c, s = capacity, self_capacity
    return dict(con_seg=np.zeros(c, dtype=np.int64), con_s=np.zeros(c), con_normal=np.zeros((c, 3)),
                con_offset=np.zeros(c), con_mu=np.zeros(c), con_shape=np.zeros(c, dtype=np.int64),
                con_face=np.zeros(c, dtype=np.int64), con_lam=np.zeros(c), self_pair=np.zeros((s, 2), dtype=np.int64),
                self_st=np.zeros((s, 2)),
                self_normal=np.zeros((s, 3)), self_lam_n=np.zeros(s), self_lam_t=np.zeros(s),
                self_anchor=np.zeros((s, layout.ANCHOR_COLUMNS)))


#: how a cable's property that the parameter record holds once for all cables is read (:func:`shared_cable`)
_SHARED = {"radius": lambda c: c.radius, "segment_length": lambda c: c.segment_length,
           "stretch_stiffness": lambda c: c.stretch_stiffness, "friction": lambda c: c.friction,
           # a rod with frames (cosserat): its rows' compliances and its frames' inertia
           "shear stiffness G·A": lambda c: c.shear * c.area, "torsion_stiffness": lambda c: c.torsion_stiffness,
           "bending stiffness E·I₁": lambda c: c.bending_stiffnesses[0],
           "bending stiffness E·I₂": lambda c: c.bending_stiffnesses[1]}
_SAME = 1e-12  # relative: two cables' properties this close count as one
_ROUND_OFF = 1e-9  # relative: a radius equal to half a segment up to this does not overlap its neighbours


def single_cable(scene: Scene) -> CableSpec:
    """The cable of a one-cable ``scene``, whose rules a model derives (:func:`cable_rules` gives each cable of a
    scene its own).

    Raises:
      ValueError: ``scene`` holds several cables."""
    if len(scene.cables) != 1:
        raise ValueError(f"a point chain's rules are those of one cable, got a scene of {len(scene.cables)} cables; "
                         f"take each cable's with mjcable.solvers.state.cable_rules")
    return scene.cables[0]


def shared_cable(scene: Scene, properties: tuple, holder: str = "the particle solvers") -> CableSpec:
    """``scene``'s first cable, standing for all of them where ``holder`` (named in the message) keeps each of
    ``properties`` (names of :data:`_SHARED`) once for all cables: a rod with frames (``cosserat``), or the
    friction a user world's geoms take.

    Raises:
      ValueError: two cables differ in one of ``properties`` (named, with both values)."""
    cables = scene.cables
    first = cables[0]
    for name in properties:
        get = _SHARED[name]
        value = get(first)
        for k, cable in enumerate(cables[1:], start=1):
            other = get(cable)
            if (value is None) != (other is None) or (value is not None and not math.isclose(
                    value, other, rel_tol=_SAME, abs_tol=0.0)):
                raise ValueError(f"cables[{k}]: {holder} hold{'' if holder.endswith('s') else 's'} one {name} for "
                                 f"all cables, got {other!r} against cables[0]'s {value!r}; give every cable the "
                                 f"same {name}")
    return first


#: the fields of :class:`Rules` that one state holds once for all of its cables (:func:`cable_rules`)
_ONE_FOR_ALL = ("verlet_start", "sqrt_approx", "direct_bending", "geometric_stiffness", "rod_limp")


def cable_rules(rules, scene: Scene, settings: ParticleSettings, h: float) -> tuple:
    """One :class:`Rules` per cable of ``scene``: ``rules(scene, settings, h)`` (a model's rules) of each cable alone
    (:meth:`~mjcable.scene.Scene.cable_scene`), so that cables of different radius, segment length, damping, E·A
    and E·I each get their own compliances and factors; a limp cable (bending ``"none"``) beside bending ones has
    none of their bending rows. A rod with frames (``rod_compliance``) holds one set for all cables: its rules of
    the whole scene, once per cable.

    Raises:
      ValueError: two cables whose rules differ in what the state holds once (:data:`_ONE_FOR_ALL`, or two bending
        kinds other than ``"none"``), naming both; or the model's own (a rod's cables that differ)."""
    one = tuple(rules(scene.cable_scene(c), settings, h) for c in range(len(scene.cables)))
    if one[0].rod_compliance is not None:
        return (rules(scene, settings, h),) * len(one)
    for k, r in enumerate(one[1:], start=1):
        for name in _ONE_FOR_ALL:
            mine, first = getattr(r, name), getattr(one[0], name)
            if mine != first:
                raise ValueError(f"cables[{k}]: the particle solvers hold one {name} for all cables, got {mine!r} "
                                 f"against cables[0]'s {first!r}; give the cables the same settings")
    kinds = sorted({r.bending for r in one} - {"none"})
    if len(kinds) > 1:
        raise ValueError(f"the particle solvers bend every cable of a state one way, got bending {kinds}; set the "
                         f"solver's bending for all")
    return one


def _bending(rules: tuple) -> str:
    """The state's bending kind of cables with ``rules``: theirs, ``"none"`` where none bends."""
    return next((r.bending for r in rules if r.bending != "none"), "none")


def _cable_params(scene: Scene, rules: tuple, h: float) -> np.ndarray:
    """``(C,)`` :data:`~mjcable.solvers.kernels_layout.CABLE_PARAMS` of ``scene``'s cables from their ``rules``
    (one :class:`Rules` each) at substep ``h`` seconds."""
    out = np.zeros(len(scene.cables), dtype=layout.CABLE_PARAMS)
    h2 = h * h
    for c, (cable, r) in enumerate(zip(scene.cables, rules)):
        l0 = cable.segment_length
        near = int(math.ceil(2.0 * cable.radius / l0 * (1.0 - _ROUND_OFF))) + 1
        out[c] = (cable.radius, l0, 1.0 / l0**2, r.alpha_stretch, r.alpha_bend, r.alpha_clamp,
                  r.alpha_stretch / h2, r.alpha_bend / h2, r.alpha_clamp / h2, r.k_stretch, r.k_bend, r.k_clamp,
                  max(near, 2), r.bending != "none")
    return out


def ring_fields(scene: Scene) -> dict:
    """The state's ring fields of ``scene``'s rings (:data:`~mjcable.solvers.kernels_layout.FIELDS`,
    :mod:`mjcable.solvers.ring_kernels`), as they start: each ring on the segment of its cable that crosses its plane
    nearest its centre, the anchor where the segment passes it, its hub the particle ``scene.n_particles + k``, its
    pin row after the scene's pins and free grippers'. Also ``centres`` (R, 3) m, the hubs' start positions, and
    ``sign`` (n + R,): −1 at the segments the rings hold (their rest lengths negated), else 1."""
    count = len(scene.rings)
    n_segments = scene.n_particles - 1 + count
    seg, t, stop = np.zeros(count, dtype=np.int64), np.zeros(count), np.full(count, -1, dtype=np.int64)
    centres, pulls = np.zeros((count, 3)), np.zeros((count, 3))
    for k, ring in enumerate(scene.rings):
        centre, axis = scene.ring_frame(k)
        part = scene.cable_slices[ring.cable]
        p = np.asarray(scene.particles)[part]
        along = (p - centre) @ axis
        cross = np.flatnonzero((along[:-1] >= 0.0) != (along[1:] >= 0.0))
        a, b = along[cross], along[cross + 1]
        frac = np.where(a == b, 0.5, a / np.where(a == b, 1.0, a - b))[:, None]
        best = int(cross[np.argmin(np.linalg.norm(p[cross] + frac * (p[cross + 1] - p[cross]) - centre, axis=1))])
        la, lb = np.linalg.norm(p[best] - centre), np.linalg.norm(p[best + 1] - centre)
        seg[k], t[k] = part.start + best, la / (la + lb)
        pull = (p[best] - centre) / max(la, 1e-12) + (p[best + 1] - centre) / max(lb, 1e-12)
        pulls[k] = pull / max(np.linalg.norm(pull), 1e-12) if np.linalg.norm(pull) > 1e-9 else axis
        if ring.stop is not None:
            stop[k] = part.start + ring.stop % len(p)
        centres[k] = centre
    sign = np.ones(n_segments)
    sign[seg] = -1.0
    first_row = len(scene.pins) + len(scene.grippers)
    return dict(centres=centres, sign=sign, ring_p=np.arange(count, dtype=np.int64) + scene.n_particles,
                ring_pin=np.arange(count, dtype=np.int64) + first_row, ring_seg=seg, ring_t=t,
                ring_mode=np.full(count, layout.RING_SLIDING, dtype=np.int64),
                ring_mu=np.array([ring.friction for ring in scene.rings], dtype=np.float64), ring_stop=stop,
                ring_cable=np.array([ring.cable for ring in scene.rings], dtype=np.int64), ring_lam=np.zeros(count),
                ring_dir=pulls, ring_tension=np.zeros(count))


def chain_arrays(scene: Scene, rules: tuple, settings: ParticleSettings, dt: float) -> StateArrays:
    """The solver state of ``scene`` at rest in its start shape: every field, those of the contact query and of a
    user world's host empty (the backend fills them in).

    Args:
      scene: the scene.
      rules: the model's parameters, one :class:`Rules` per cable (:func:`cable_rules`).
      settings: validated solver settings.
      dt: the simulator's step in seconds; the substep is ``h = dt / settings.substeps``.
    """
    cables = scene.cables
    first = rules[0]  # what the state holds once for all cables (cable_rules checked that they agree)
    topo = topology(scene, frames=first.rod_compliance is not None)
    rings = ring_fields(scene)
    hubs = rings.pop("centres")
    topo["seg_cable"] = np.concatenate([topo["seg_cable"], np.full(len(hubs), -1, dtype=np.int64)])
    link = topo["seg_cable"] >= 0
    n_particles = scene.n_particles + len(hubs)  # the cables' particles, then the rings' hubs (held)
    h = dt / settings.substeps
    x = np.concatenate([np.array(scene.particles, dtype=np.float64), hubs])
    mass = np.concatenate([c.particle_masses for c in scene.cables] + [np.zeros(len(hubs))]).astype(np.float64)
    w = np.divide(1.0, mass, out=np.zeros_like(mass), where=mass > 0.0)
    pins = scene.pins
    pin_p = np.array([scene.pin_particle(k) for k in range(len(pins))], dtype=np.int64)
    w[pin_p] = 0.0
    pin_from = x[pin_p].copy()
    release = np.array([p.release_force if p.kind == "socket" else math.inf for p in pins], dtype=np.float64)
    clamps = [k for k, p in enumerate(pins) if p.clamp]
    clamp_pq = np.array([[scene.pin_particle(k), scene.clamp_neighbour(k)] for k in clamps],
                        dtype=np.int64).reshape(-1, 2)
    clamp_dir = np.zeros((len(clamps), 2, 3))
    for kc, (p, q) in enumerate(clamp_pq):
        axis = x[q] - x[p]
        clamp_dir[kc] = _perpendiculars(axis / np.linalg.norm(axis))
    v = np.zeros_like(x)  # at rest: Verlet's start is the first substep's prediction (par.verlet_start)
    n = n_particles - 1
    cable_par = _cable_params(scene, rules, h)
    l0 = np.where(link, cable_par["l0"][np.maximum(topo["seg_cable"], 0)], math.inf)  # (n,) m, inf in the gaps
    damp = np.ones(n_particles)  # (a ring's hub is held: its damping is never used)
    for cable, part in zip(cables, scene.cable_slices):
        damp[part] = math.exp(-cable.damping * h)
    no_clamps = np.zeros((0, 2), dtype=np.int64)
    seg_cable = topo["seg_cable"]
    placeholder = np.zeros(1, dtype=np.int64)  # one segment: the unused rows' placeholder of the right types
    bending, bends = _bending(rules), cable_par["bends"]
    if settings.order == "direct" and first.direct_bending:
        rows = _direct_rows(seg_cable, bending, clamp_pq, bends=bends)
    elif settings.order == "direct":
        rows = _direct_rows(seg_cable, "none", no_clamps)
    else:
        rows = _direct_rows(placeholder, "none", no_clamps)
    geometric = settings.order == "direct" and first.geometric_stiffness
    # a chain of stretch rows only solves its geometric stiffness block by block (direct_kernels), in gs_blocks
    gs_chain = (geometric and bool(np.all(rows["row_kind"] == layout.ROW_STRETCH)) and not scene.rings
                and first.rod_compliance is None)  # (a rod condenses its own: cosserat_direct_kernels)
    if geometric and not gs_chain:  # the same rows with the stretch rows' transverse rows
        gs = _direct_rows(seg_cable, bending if first.direct_bending else "none",
                          clamp_pq if first.direct_bending else no_clamps, transverse=True, bends=bends)
    else:
        gs = _direct_rows(placeholder, "none", no_clamps)
    rows.update({f"gs_{name}": value for name, value in gs.items()})
    rows["gs_blocks"] = np.zeros((n if gs_chain else 0, 12))
    par = np.zeros(1, dtype=layout.PARAMS)
    P = par[0]
    gravity = np.asarray(scene.gravity, dtype=np.float64)
    for name, value in dict(
            h=h, gx=gravity[0], gy=gravity[1], gz=gravity[2], omega=settings.omega,
            max_radius=max(cable.radius for cable in cables),
            cable_contact=len(scene.cables) > 1, junction_count=0, iterations=settings.iterations,
            substeps=settings.substeps,
            order=ORDER_CODES[settings.order], bending=BENDING_CODES[bending], sqrt_approx=first.sqrt_approx,
            direct_all=first.direct_bending, bandwidth=rows.pop("bandwidth"), dt=dt, geometric=geometric,
            gs_bandwidth=rows.pop("gs_bandwidth"), gs_stiff=False, gs_chain=gs_chain, direct_solves=0,
            max_distance=math.inf, max_speed=math.inf, strain_fail=math.inf, strain_warn=math.inf, tear=math.inf,
            check_where=-1, warn_where=-1, warn_step=-1, contact_margin=settings.contact_margin,
            fall=0.5 * float(np.linalg.norm(gravity)) * dt**2, self_collision=bool(settings.self_collision),
            query=layout.QUERY_NONE, query_margin=-math.inf, query_slack=settings.query_slack, warning=-1,
            verlet_start=first.verlet_start,
            impact_speed=layout.IMPACT_SPEED, impact_iterations=layout.IMPACT_ITERATIONS,
            impact_tol=layout.IMPACT_TOLERANCE * h).items():
        P[name] = value
    n_pins = len(pins)
    a = StateArrays(
        x=x, v=v, x0=x.copy(), w=w, mass=mass, react=np.zeros_like(x), dx=np.zeros_like(x),
        relax=np.zeros(n_particles), prev=x.copy(), query_x=x.copy(),
        rest=l0 * rings.pop("sign"), lam_s=np.zeros(n), lam_gs=np.zeros(n),
        rest_d=np.where(link[:-1] & link[1:], 2.0 * l0[:-1], math.inf), lam_d=np.zeros(max(n - 1, 0)),
        cable_par=cable_par, seg_radius=np.where(link, cable_par["radius"][np.maximum(topo["seg_cable"], 0)], 0.0),
        damp=damp,
        lam_b=np.zeros((max(n - 1, 0), 3)),
        clamp_pq=clamp_pq, clamp_pin=np.array(clamps, dtype=np.int64), clamp_dir=clamp_dir,
        lam_c=np.zeros((len(clamps), 2)), clamp_react=np.zeros((len(clamps), 3)),
        clamp_wq=np.zeros((len(clamps), 3, 3)),
        pin_p=pin_p, pin_from=pin_from, pin_to=pin_from.copy(), pin_active=np.ones(n_pins, dtype=np.bool_),
        pin_release=release, pin_force=np.zeros((n_pins, 3)), pin_sum=np.zeros((n_pins, 3)),
        pin_count=np.zeros(n_pins),
        fric_n=np.zeros(n_particles), fric_mu=np.zeros(n_particles), fric_slid=np.zeros(n_particles, dtype=np.bool_),
        fric_nsum=np.zeros((n_particles, 3)), fric_impulse=np.zeros((n_particles, 3)),
        fric_normal=np.zeros((n_particles, 3)), fric_ob=np.zeros(n_particles, dtype=np.int64),
        fric_unit=np.zeros((n_particles, 3)), fric_push=np.zeros((n_particles, 3)), fric_cone=np.zeros(n_particles),
        fric_sole=np.zeros(n_particles, dtype=bool),
        anchor=np.zeros((n_particles, 3)), anchor_ob=np.full(n_particles, -1, dtype=np.int64),
        par=par, **rows, **topo, **rings, **_contact_buffers(_CONTACT_CAPACITY * n, _SELF_CONTACT_CAPACITY * n))
    for name, typ, _ in layout.FIELDS:  # the query's and the host's fields: empty until the backend fills them
        if name not in a:
            a[name] = np.zeros((0,) * typ.ndim, dtype=np.dtype(str(typ.dtype)))
    a["start_from"], a["start_to"], a["target"] = (np.zeros((n_pins, 3)) for _ in range(3))
    if first.rod_compliance is not None:
        a.update(_rod_arrays(scene, clamps, welds=settings.order == "direct" and not first.rod_limp))
        for name, value in zip(("ss_alpha1", "ss_alpha2", "ss_alpha3", "bt_alpha1", "bt_alpha2", "bt_alpha3"),
                               first.rod_compliance):
            P[name] = value
        P["rod_limp"] = first.rod_limp
    return a


#: (w, x, y, z) of the turn taking a body's z axis to its x axis (+90° about y): a frame from
#: :func:`mjcable.mjcf.joints.segment_frames` (x along the segment) times it has d₃ along the segment
_Z_TO_X = np.array([math.sqrt(0.5), 0.0, math.sqrt(0.5), 0.0])


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products of quaternions (..., 4) (w, x, y, z)."""
    aw, av, bw, bv = a[..., :1], a[..., 1:], b[..., :1], b[..., 1:]
    return np.concatenate([aw * bw - np.sum(av * bv, axis=-1, keepdims=True),
                           aw * bv + bw * av + np.cross(av, bv)], axis=-1)


def material_frames(body_quats: np.ndarray) -> np.ndarray:
    """``(n, 4)`` material frames (w, x, y, z; d₃ along the segment) of segment bodies whose x axis runs along their
    segment, from the bodies' orientations ``(n, 4)`` (w, x, y, z): the frames of ``joints``' and ``composite``'s
    capsule bodies, and of :func:`start_frames`."""
    return quat_mul(body_quats, _Z_TO_X)


def start_frames(particles: np.ndarray) -> np.ndarray:
    """``(n, 4)`` material frames (w, x, y, z) of a polyline's segments: d₃ along each segment, transported along the
    curve without twist (:func:`mjcable.mjcf.joints.segment_frames`)."""
    from mjcable.mjcf.joints import segment_frames  # (the MjSpec side; imported here only)

    return material_frames(segment_frames(particles))


def _about_d3(frame: np.ndarray, axis: np.ndarray, tangent: np.ndarray) -> np.ndarray:
    """``(4,)`` the turn about d₃ (body z) that takes ``frame``'s d₁ onto ``axis`` projected perpendicular to
    ``tangent`` (d₃).

    Raises:
      ValueError: ``axis`` along the tangent (no direction across the segment)."""
    t = tangent / np.linalg.norm(tangent)
    across = axis - np.dot(axis, t) * t
    if np.linalg.norm(across) < 1e-9 * np.linalg.norm(axis):
        raise ValueError(f"section_axis must point across the cable's first segment (direction {t.round(6).tolist()}),"
                         f" got {axis.tolist()}, which runs along it")
    d1, d2 = Rotation.from_quat(frame, scalar_first=True).apply(np.eye(3)[:2])
    angle = math.atan2(np.dot(across, d2), np.dot(across, d1))
    return np.array([math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)])


def darboux(frames: np.ndarray, segment_length: float) -> np.ndarray:
    """``(n − 1, 3)`` 1/m discrete Darboux vectors (2 / l₀) Im(q̄ᵢ ⊗ q_{i+1}) of frames ``(n, 4)``, each relative
    rotation taken with w ≥ 0 ([KS16] Eq. 32, :mod:`mjcable.solvers.cosserat_kernels`)."""
    conj = frames[:-1] * np.array([1.0, -1.0, -1.0, -1.0])
    r = quat_mul(conj, frames[1:])
    r *= np.where(r[:, :1] < 0.0, -1.0, 1.0)
    return 2.0 / segment_length * r[:, 1:]


def _cable_frames(cable) -> tuple:
    """One cable's start frames ``(n, 4)`` (its section axis and start twist in them) and its rest Darboux vectors
    ``(n − 1, 3)`` (:func:`_rod_arrays`)."""
    n = cable.n_segments
    q = start_frames(cable.particles)
    if cable.section_axis is not None:  # the section's d₁ turned about d₃ onto the given axis, the same turn for all
        q = quat_mul(q, _about_d3(q[0], np.asarray(cable.section_axis), cable.particles[1] - cable.particles[0]))
    untwisted = q
    if cable.start_twist != 0.0:  # segment i turned about d₃ by Φ (i + ½) / n: a uniform elastic twist
        half = 0.5 * cable.start_twist * (np.arange(n) + 0.5) / n
        q = quat_mul(q, np.stack([np.cos(half), 0.0 * half, 0.0 * half, np.sin(half)], axis=1))
    rest = darboux(untwisted, cable.segment_length) if cable.rest_shape == "start" else np.zeros((max(n - 1, 0), 3))
    return q, rest


def _rod_arrays(scene: Scene, clamps: list, *, welds: bool) -> dict:
    """The frame fields of a Cosserat rod (:data:`~mjcable.solvers.kernels_layout.FIELDS`, "material frames") for
    ``scene``'s start curve: frames without twist, at rest; the rest Darboux vectors zero (``rest_shape="straight"``)
    or the start curve's (``"start"``); each segment's rotational inertia that of its slice of the rod, ρ l₀ (I, I, J)
    = m (r²/4, r²/4, r²/2); a clamp's frame starts as its segment's. Several cables lie one after the other, as the
    chains do (:func:`~mjcable.solvers.topology.topology`): the gap segment between two cables has the identity frame, which no constraint
    turns, and the bend–twist rows beside it rest at zero (they are not solved).

    Raises:
      ValueError: a clamp at an interior particle (a clamped frame is a constraint at the rod's start or end: the
        first cable's first particle or the last cable's last), or a clamped junction without ``welds``
        (:func:`_welds`)."""
    cables = scene.cables
    n = scene.n_particles - 1
    frames, rests, inertias = [], [], []
    for c, cable in enumerate(cables):
        q_c, rest_c = _cable_frames(cable)
        m = cable.mass / cable.n_segments
        i1, i2 = cable.second_moments
        one = [m * i1 / cable.area, m * i2 / cable.area, m * (i1 + i2) / cable.area]
        frames.append(q_c)
        rests.append(rest_c)
        inertias.append(np.tile(one, (cable.n_segments, 1)))
        if c < len(cables) - 1:  # the gap to the next cable: the identity frame, and the two rows beside it
            frames.append(np.array([[1.0, 0.0, 0.0, 0.0]]))
            rests.append(np.zeros((2, 3)))
            inertias.append(np.array([one]))  # (unused: no row turns a gap's frame)
    q = np.concatenate(frames)
    omega0 = np.concatenate(rests).reshape(max(n - 1, 0), 3)
    inertia = np.concatenate(inertias)
    ends = np.full(2, -1, dtype=np.int64)
    for row, k in enumerate(clamps):
        p = scene.pin_particle(k)
        if p not in (0, n):
            where = ("" if len(cables) == 1 else
                     "; of several cables, only the first cable's first particle or the last cable's last")
            raise ValueError(f"pins[{k}]: model 'cosserat' clamps the rod's first or last particle (0 or {n}{where}),"
                             f" got a clamp at particle {p}; drop clamp=True or move the pin to an end")
        if ends[0 if p == 0 else 1] < 0:
            ends[0 if p == 0 else 1] = row
    seg = np.array([min(scene.pin_particle(k), n - 1) for k in clamps], dtype=np.int64)
    # a clamp holds its segment's frame, turned back to its particle's share of the start twist (0 at the start,
    # Φ at the end: the twist then starts uniform, half a segment from the clamp too)
    turn = np.array([(-0.25 if scene.pin_particle(k) == 0 else 0.25)
                     * cables[scene.pin_cable(k)].start_twist / cables[scene.pin_cable(k)].n_segments
                     for k in clamps])
    held = quat_mul(q[seg], np.stack([np.cos(turn), 0.0 * turn, 0.0 * turn, np.sin(turn)], axis=1).reshape(-1, 4))
    rows = 6 * n + 3
    return dict(q=q, q0=q.copy(), omega=np.zeros((n, 3)), inertia=inertia, wq=1.0 / inertia, darboux0=omega0,
                lam_ss=np.zeros((n, 3)), lam_bt=np.zeros((max(n - 1, 0), 3)), lam_end=np.zeros((2, 3)),
                clamp_seg=seg, clamp_q=held, clamp_qfrom=held.copy(), clamp_qto=held.copy(),
                clamp_react=np.zeros((len(clamps), 3)), clamp_wq=np.zeros((len(clamps), 3, 3)), end_clamp=ends,
                cs_jac=np.zeros((4 * n + 4, 3, 3)),
                cs_band=np.zeros((rows, 9)), cs_rhs=np.zeros(rows), cs_db=np.zeros((n, 3)), **_welds(scene, q, welds))


def _welds(scene: Scene, q: np.ndarray, able: bool) -> dict:
    """The weld fields of ``scene``'s clamped junctions for start frames ``q`` (n, 4): each welds the frames of the
    segments at its two particles, which must be cable ends (a loop: the cable's last segment and its first), at
    their start turn r₀ = q̄_a ⊗ q_b (:mod:`mjcable.solvers.cosserat_weld_kernels`, in the direct solve: ``able``).

    Raises:
      ValueError: a clamped junction where the rod can't weld (not ``able``: the Gauss-Seidel order, or a limp rod),
        at an interior particle, or at the two ends of a one-segment cable."""
    n = len(q)
    welds = []
    for j, junction in enumerate(scene.junctions):
        if not junction.clamp:
            continue
        if len(scene.cables) > 1:
            raise ValueError(f"junctions[{j}]: model 'cosserat' welds a clamped junction's frames in a scene of one "
                             f"cable only (a loop of its ends), got clamp=True in a scene of {len(scene.cables)} "
                             f"cables; use clamp=False (a ball joint)")
        if not able:
            raise ValueError(f"junctions[{j}]: model 'cosserat' welds a clamped junction's frames in its direct solve "
                             f"only (order='direct', a cable with young > 0), got order='gauss-seidel' or a limp "
                             f"cable; use order='direct' and young > 0, or clamp=False")
        ends = scene.junction_particles(j)
        segs = [min(p, n - 1) for p in ends]
        if not all(p in (0, n) for p in ends) or segs[0] == segs[1]:
            raise ValueError(f"junctions[{j}]: model 'cosserat' clamps a junction of cable ends (particles 0 and {n}"
                             f", of distinct segments), got particles {ends}; drop clamp=True or join the ends")
        welds.append(segs)
    seg = np.array(welds, dtype=np.int64).reshape(-1, 2)
    r0 = quat_mul(q[seg[:, 0]] * np.array([1.0, -1.0, -1.0, -1.0]), q[seg[:, 1]])
    return dict(weld_seg=seg, weld_r0=r0.reshape(-1, 4), lam_weld=np.zeros((len(seg), 3)))
