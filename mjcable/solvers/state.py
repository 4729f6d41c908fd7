"""The particle solvers' state: arrays built once from the scene and a model's rules.

Positions ``x`` and velocities ``v`` are ``(n + 1, 3)`` float64 arrays in metres and m/s; ``w`` holds inverse
masses (1 / lumped mass, 0 for a held particle), so that every correction is mass-weighted (Jakobsen's
``invmass`` form). The arrays live in a :class:`~mjcable.solvers.kernels.Chain` named tuple that the numba kernels
take whole.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Optional

import numpy as np

from mjcable.scene import Scene
from mjcable.solvers import kernels
from mjcable.solvers.kernels import FP, IP
from mjcable.solvers.settings import ParticleSettings

__all__ = ["Rules", "new_chain", "empty_contacts", "ORDER_CODES", "BENDING_CODES"]

ORDER_CODES = {"gauss-seidel": kernels.ORDER_GAUSS_SEIDEL, "jacobi": kernels.ORDER_JACOBI,
               "direct": kernels.ORDER_DIRECT}
BENDING_CODES = {"none": kernels.BEND_NONE, "curvature": kernels.BEND_CURVATURE, "distance": kernels.BEND_DISTANCE}


@dataclasses.dataclass(frozen=True, kw_only=True)
class Rules:
    """What a model makes of the physical cable: the kernels' parameters.

    Args:
      verlet_start: start like Verlet from the exact previous position x₋₁ = x₀ + ½ g h² (v₀ = −½ g h); else
        semi-implicit Euler from rest (v₀ = 0).
      alpha_stretch, alpha_bend, alpha_clamp: XPBD compliances α (stretch m/N, curvature 1/(N·m³), distance
        bending m/N, clamp 1/(N·m³)); 0 for PBD and Jakobsen.
      k_stretch, k_bend, k_clamp: per-iteration stiffness factors in [0, 1] (1 for XPBD).
      bending: ``"none"``, ``"curvature"`` or ``"distance"``.
      sqrt_approx: Jakobsen's square-root approximation for the stretch constraints.
      direct_bending: with ``order="direct"``, solve bending and clamps in the banded system too (XPBD, whose
        compliances make it well posed); otherwise only the stretch chain, with bending and clamps projected
        sequentially after it (PBD and Jakobsen: hard rows scaled by a stiffness do not form a solvable system).
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


def _perpendiculars(axis: np.ndarray) -> np.ndarray:
    """Two unit vectors (2, 3) perpendicular to the unit vector ``axis`` and to each other."""
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    d1 = np.cross(axis, helper)
    d1 /= np.linalg.norm(d1)
    return np.stack([d1, np.cross(axis, d1)])


def _direct_rows(n_particles: int, bending: str, clamp_pq: np.ndarray) -> dict:
    """The banded system's rows, ordered by their first particle, with per-particle row lists and the
    half-bandwidth."""
    n = n_particles - 1
    rows = [(i, kernels.ROW_STRETCH, i, (i, i + 1)) for i in range(n)]
    if bending == "curvature":
        rows += [(b, kernels.ROW_CURVATURE, 3 * b + comp, (b, b + 1, b + 2)) for b in range(n - 1) for comp in range(3)]
    elif bending == "distance":
        rows += [(b, kernels.ROW_DISTANCE, b, (b, b + 2)) for b in range(n - 1)]
    for kc, (p, q) in enumerate(clamp_pq):
        rows += [(min(p, q), kernels.ROW_CLAMP, 2 * kc + m, (int(p), int(q))) for m in range(2)]
    rows.sort(key=lambda r: r[0])  # stable: keeps the kinds' relative order per particle
    nrow = len(rows)
    row_kind = np.array([r[1] for r in rows], dtype=np.int64)
    row_idx = np.array([r[2] for r in rows], dtype=np.int64)
    row_p = np.full((nrow, 3), -1, dtype=np.int64)
    touching = [[] for _ in range(n_particles)]
    for r, (_, _, _, parts) in enumerate(rows):
        for slot, p in enumerate(parts):
            row_p[r, slot] = p
            touching[p].append((r, slot))
    width = max(len(t) for t in touching)
    prow = np.full((n_particles, width), -1, dtype=np.int64)
    pslot = np.zeros((n_particles, width), dtype=np.int64)
    bandwidth = 0
    for p, t in enumerate(touching):
        for k, (r, slot) in enumerate(t):
            prow[p, k], pslot[p, k] = r, slot
        if t:
            bandwidth = max(bandwidth, max(r for r, _ in t) - min(r for r, _ in t))
    return dict(row_kind=row_kind, row_idx=row_idx, row_p=row_p, prow=prow, pslot=pslot,
                band=np.zeros((nrow, bandwidth + 1)), grad=np.zeros((nrow, 3, 3)), rhs=np.zeros(nrow),
                bandwidth=bandwidth)


def new_chain(scene: Scene, rules: Rules, settings: ParticleSettings, dt: float) -> kernels.Chain:
    """The solver state of ``scene`` at rest in its start shape.

    Args:
      scene: the scene.
      rules: the model's parameters (see :class:`Rules`).
      settings: validated solver settings.
      dt: the simulator's step in seconds; the substep is ``h = dt / settings.substeps``.
    """
    cable = scene.cable
    n_particles = cable.n_particles
    h = dt / settings.substeps
    x = np.array(cable.particles, dtype=np.float64)
    mass = np.array(cable.particle_masses, dtype=np.float64)
    w = 1.0 / mass
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
    v = np.zeros_like(x)
    if rules.verlet_start:
        v[w > 0] = -0.5 * scene.gravity * h
    n = cable.n_segments
    l0 = cable.segment_length
    if settings.order == "direct" and rules.direct_bending:
        rows = _direct_rows(n_particles, rules.bending, clamp_pq)
    elif settings.order == "direct":
        rows = _direct_rows(n_particles, "none", np.zeros((0, 2), dtype=np.int64))
    else:
        rows = _direct_rows(2, "none", np.zeros((0, 2), dtype=np.int64))  # unused placeholder of the right types
    fp = np.zeros(kernels.N_FP)
    fp[FP["h"]] = h
    fp[FP["damp"]] = math.exp(-cable.damping * h)
    fp[[FP["gx"], FP["gy"], FP["gz"]]] = scene.gravity
    fp[FP["alpha_s"]], fp[FP["alpha_b"]], fp[FP["alpha_c"]] = rules.alpha_stretch, rules.alpha_bend, rules.alpha_clamp
    fp[FP["k_s"]], fp[FP["k_b"]], fp[FP["k_c"]] = rules.k_stretch, rules.k_bend, rules.k_clamp
    fp[FP["inv_l0sq"]] = 1.0 / l0**2
    fp[FP["omega"]] = settings.omega
    fp[FP["radius"]] = cable.radius
    fp[FP["mu_self"]] = cable.friction
    ip = np.zeros(kernels.N_IP, dtype=np.int64)
    ip[IP["iterations"]] = settings.iterations
    ip[IP["order"]] = ORDER_CODES[settings.order]
    ip[IP["bending"]] = BENDING_CODES[rules.bending]
    ip[IP["sqrt"]] = int(rules.sqrt_approx)
    ip[IP["bandwidth"]] = rows.pop("bandwidth")
    ip[IP["direct_all"]] = int(rules.direct_bending)
    ip[IP["substeps"]] = settings.substeps
    return kernels.Chain(
        x=x, v=v, x0=x.copy(), w=w, mass=mass, react=np.zeros_like(x), dx=np.zeros_like(x),
        count=np.zeros(n_particles),
        rest=np.full(n, l0), lam_s=np.zeros(n),
        rest_d=np.full(max(n - 1, 0), 2.0 * l0), lam_d=np.zeros(max(n - 1, 0)), lam_b=np.zeros((max(n - 1, 0), 3)),
        clamp_pq=clamp_pq, clamp_pin=np.array(clamps, dtype=np.int64), clamp_dir=clamp_dir,
        lam_c=np.zeros((len(clamps), 2)),
        pin_p=pin_p, pin_from=pin_from, pin_to=pin_from.copy(), pin_active=np.ones(len(pins), dtype=np.bool_),
        pin_release=release, pin_force=np.zeros((len(pins), 3)), pin_sum=np.zeros((len(pins), kernels.N_PS)),
        fric=np.zeros((n_particles, kernels.N_FR)), anchor=np.zeros((n_particles, 3)),
        anchor_ob=np.full(n_particles, -1, dtype=np.int64),
        fp=fp, ip=ip, **rows,
    )


def empty_contacts(capacity: int = 0, shapes: Optional[np.ndarray] = None) -> kernels.Contacts:
    """Contact arrays holding no contacts, with the obstacles' ``shapes`` (B, ``kernels.N_SH``; default none)."""
    return kernels.Contacts(seg=np.zeros(capacity, dtype=np.int64), geo=np.zeros((capacity, 7)),
                            lam=np.zeros(capacity), pair=np.zeros((0, 2), dtype=np.int64),
                            sgeo=np.zeros((0, 5)), slam=np.zeros((0, 2)),
                            shapes=np.zeros((0, kernels.N_SH)) if shapes is None else shapes,
                            impulse=np.zeros((0, 6)))
