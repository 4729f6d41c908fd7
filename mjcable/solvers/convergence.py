"""What the particle solvers' constraint iterations leave of a cable's stated stiffness, from the linearised sweeps.

A substep predicts y* = y + h v + h² a (a the acceleration of the loads) and then runs ``iterations`` iterations of
the constraint rows in the solver's order (Gauss-Seidel: one row after another; Jacobi: all rows from the same
positions, each row applying its share ω / count, the smallest of its particles'; direct: all rows of the banded
system at once), the multipliers reset to 0 at the substep's start ([M16] Algorithm 1). Linearised about the
straight rest shape, one coordinate at a time (the rows of a straight chain decouple into the axial and the two
transverse directions), every row is linear in the positions, so the iterations are a linear map P of the predicted
positions: y⁺ = P y*. At a static
equilibrium the substep returns where it started (v = 0):

    y = P (y + h² a)   ⇔   (I − P) y = h² P a

which a converged solve turns into the model's own statics K y = M a, K = Gᵀ α⁻¹ G (rows G, compliances α:
XPBD's Eq. 18 at its fixed point). Unconverged iterations give a larger y: the rod or chain is softer than stated.
:func:`bending_fraction` compares the two on the rod's lowest bending mode (transverse rows: curvature and clamps),
:func:`stretch_strain` gives the static strain of the stretch rows (axial) under the cable's own weight.

The rows and their updates are the kernels' (:mod:`mjcable.solvers.constraint_kernels`,
:mod:`mjcable.solvers.direct_kernels`): a row j with gradient gⱼ, compliance α̃ⱼ = αⱼ / h² and per-iteration factor
kⱼ takes Δλⱼ = kⱼ (−gⱼ·y − α̃ⱼ λⱼ) / (gⱼᵀ W gⱼ + α̃ⱼ) and moves y by W gⱼ Δλⱼ (W the inverse masses, 0 for a held
particle). The maps are dense (the state has n + 1 positions and a multiplier per row), built at O(rows · state)
per sweep and raised to the iteration count by squaring: cheap up to :data:`MAX_SEGMENTS` segments, which is where
the analysis stops (it returns ``None`` beyond).

Contacts, the tension's geometric stiffness, a curved rest shape and the curvature rows' small axial share are
left out: the numbers are what the iterations do to the rod's own stiffness, an estimate of the effect in any scene
(tests/test_prechecks.py measures both against the solvers).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Optional

import numpy as np
from scipy import linalg

from mjcable.scene import Scene
from mjcable.solvers import winches
from mjcable.solvers.settings import MAX_AUTO_ITERATIONS, ParticleSettings
from mjcable.solvers.state import Rules

# an inextensible cable's expected static strain under its loads beyond which a Simulator warns
# (mjcable.prechecks), and which iterations=None keeps it within: a rope dropped onto a peg with one Jakobsen
# substep of 2 ms slid at 0.85 of the capstan law at 0.035 and held at 0.023 (docs/measurements.md, 2026-11-27)
STRAIN_WARNING = 0.025
HANGING_SLOPE = 45.0  # degrees from the horizontal: an unpinned cable most of whose start segments are steeper hangs

__all__ = ["Rows", "sweep_map", "static_response", "bending_fraction", "stretch_strain", "static_strain",
           "hung_masses", "hanging_support", "hangs", "strain_estimate", "strain_within", "resolve_order",
           "resolve_iterations", "MAX_SEGMENTS", "STRAIN_WARNING", "HANGING_SLOPE"]

MAX_SEGMENTS = 400  # the longest chain analysed (a dense map of about 3n × 3n entries, raised by squaring)
_RIGID = 1e-9  # a lowest eigenvalue of K below this fraction of its largest diagonal term is a rigid motion
_BAND = 2  # half-bandwidth of the curvature rows' stiffness (each row spans three neighbours)
_DIRECT_REGULARIZATION = 1e-10  # relative compliance added to the direct rows (direct_kernels' own)


@dataclasses.dataclass(frozen=True)
class Rows:
    """Linear constraint rows of one coordinate, in the order a sweep takes them.

    Attributes:
      grad: ``(m, n + 1)`` each row's gradient gⱼ over the particles.
      alpha: ``(m,)`` compliances α (0: hard).
      k: ``(m,)`` per-iteration factors k ∈ [0, 1].
      direct: ``(m,)`` bool, the rows the direct order solves at once (the others follow in Gauss-Seidel order).
    """

    grad: np.ndarray
    alpha: np.ndarray
    k: np.ndarray
    direct: np.ndarray


def _gauss_seidel(z: np.ndarray, rows: Rows, w: np.ndarray, alpha_t: np.ndarray, select, n_p: int) -> None:
    """One Gauss-Seidel pass over ``rows[select]`` applied to every column of ``z`` ((n + 1 + m) × c: positions,
    then the rows' multipliers) in place."""
    for j in np.flatnonzero(select):
        g = rows.grad[j]
        support = np.flatnonzero(g)
        denom = float(np.sum(w[support] * g[support] ** 2)) + alpha_t[j]
        if denom == 0.0:
            continue
        dlam = rows.k[j] * (-(g[support] @ z[support]) - alpha_t[j] * z[n_p + j]) / denom
        z[support] += (w[support] * g[support])[:, None] * dlam[None, :]
        z[n_p + j] += dlam


def _direct(rows: Rows, w: np.ndarray, alpha_t: np.ndarray, n_p: int) -> np.ndarray:
    """The direct solve of the rows ``rows.direct`` as a matrix on (positions, multipliers): Δλ = K A⁻¹ (−G y − α̃ λ),
    A = G W Gᵀ + α̃ (kernels: the banded system), y += W Gᵀ Δλ, λ += Δλ."""
    m = len(rows.k)
    live = np.sum(rows.grad**2 * w, axis=1) + alpha_t > 0.0  # a row on held particles alone does nothing
    sel = np.flatnonzero(rows.direct & live)
    g = rows.grad[sel]
    a = (g * w) @ g.T + np.diag(alpha_t[sel])
    a += _DIRECT_REGULARIZATION * np.diag(np.diag(a))  # as the kernels: redundant hard rows stay solvable
    rhs = np.zeros((len(sel), n_p + m))  # rhs = −G y − α̃ λ as a matrix on the state
    rhs[:, :n_p] = -g
    rhs[np.arange(len(sel)), n_p + sel] = -alpha_t[sel]
    dlam = rows.k[sel][:, None] * np.linalg.solve(a, rhs)
    step = np.eye(n_p + m)
    step[:n_p] += (w[:, None] * g.T) @ dlam
    step[n_p + sel] += dlam
    return step


def _jacobi(rows: Rows, w: np.ndarray, alpha_t: np.ndarray, omega: float, count: np.ndarray, n_p: int) -> np.ndarray:
    """One Jacobi iteration as a matrix: every row's Δλ from the same state, each row applying (to its particles
    and its multiplier) the share s = min ω / count over its particles (count: the chain constraints on each
    particle; :func:`mjcable.solvers.constraint_kernels.jacobi_relax`)."""
    m = len(rows.k)
    denom = np.sum(rows.grad ** 2 * w, axis=1) + alpha_t
    live = denom > 0.0
    relax = np.where(count > 0.0, omega / np.where(count > 0.0, count, 1.0), 0.0)
    share = np.min(np.where(rows.grad != 0.0, relax, np.inf), axis=1)
    scale = np.where(live, share * rows.k / np.where(live, denom, 1.0), 0.0)
    dlam = np.zeros((m, n_p + m))
    dlam[:, :n_p] = -scale[:, None] * rows.grad
    dlam[np.arange(m), n_p + np.arange(m)] = -scale * alpha_t
    step = np.eye(n_p + m)
    step[:n_p] += (w[:, None] * rows.grad.T) @ dlam
    step[n_p:] += dlam
    return step


def sweep_map(rows: Rows, w: np.ndarray, h: float, *, order: str, iterations: int, omega: float = 1.0,
              count: Optional[np.ndarray] = None) -> np.ndarray:
    """P ``(n + 1, n + 1)``: the positions after one substep's ``iterations`` iterations as a linear function of the
    predicted positions (multipliers starting at 0).

    Args:
      rows: the rows, in sweep order.
      w: ``(n + 1,)`` inverse masses in 1/kg (0: held).
      h: the substep in seconds (α̃ = α / h²).
      order: ``"gauss-seidel"``, ``"jacobi"`` or ``"direct"`` (the rows marked ``direct`` at once, then the others
        in Gauss-Seidel order, as the kernels do for PBD and Jakobsen).
      iterations: iterations per substep (>= 1).
      omega, count: Jacobi's relaxation and ``(n + 1,)`` constraint counts per particle.
    """
    n_p, m = len(w), len(rows.k)
    alpha_t = rows.alpha / (h * h)
    if order == "jacobi":
        step = _jacobi(rows, w, alpha_t, omega, count, n_p)
    else:
        step = _direct(rows, w, alpha_t, n_p) if order == "direct" and rows.direct.any() else np.eye(n_p + m)
        gs = ~rows.direct if order == "direct" else np.ones(m, dtype=bool)
        _gauss_seidel(step, rows, w, alpha_t, gs, n_p)
    total = np.eye(n_p + m)
    power = step
    while iterations:
        if iterations & 1:
            total = power @ total
        iterations >>= 1
        if iterations:
            power = power @ power
    return total[:n_p, :n_p]


def static_response(p: np.ndarray, free: np.ndarray, load: np.ndarray, h: float) -> np.ndarray:
    """y ``(n + 1,)``: the static displacement of the free particles (held ones stay 0) under the acceleration
    ``load`` ``(n + 1,)`` m/s² that a substep map ``p`` (:func:`sweep_map`) holds still: (I − P) y = h² P a over the
    free particles (least squares where rigid motions leave it singular)."""
    pf = p[np.ix_(free, free)]
    y = np.zeros(len(load))
    lhs, rhs = np.eye(len(pf)) - pf, h * h * pf @ load[free]
    try:
        y[free] = np.linalg.solve(lhs, rhs)
    except np.linalg.LinAlgError:
        y[free] = np.linalg.lstsq(lhs, rhs, rcond=None)[0]
    return y


def hung_masses(scene: Scene) -> np.ndarray:
    """``(n + 1,)`` kg: what bodies hang on each particle through its body pins, their
    :attr:`~mjcable.scene.Scene.hanging_weights` over |g|."""
    hung = np.zeros(scene.cable.n_particles)
    g = float(np.linalg.norm(scene.gravity))
    if g > 0.0:
        for k, weight in enumerate(scene.hanging_weights):
            hung[scene.pin_particle(k)] += weight / g
    return hung


def _chain(scene: Scene, hung: np.ndarray, support: Optional[int] = None) -> tuple:
    """``(w (n + 1,), mass (n + 1,), free (n + 1,) bool)``: the cable's inverse masses with its pinned particles held,
    except where a body hangs ``hung`` kg on one (then free, carrying that mass), and particle ``support`` held."""
    mass = np.array(scene.cable.particle_masses, dtype=np.float64) + hung
    free = np.ones(len(mass), dtype=bool)
    for k in range(len(scene.pins)):
        i = scene.pin_particle(k)
        free[i] = hung[i] > 0.0
    if support is not None:
        free[support] = False
    return np.where(free, 1.0 / mass, 0.0), mass, free


def _counts(n: int, bending: str, clamps: list) -> np.ndarray:
    """Chain constraints per particle (Jacobi's averaging): stretch, bending and clamp rows."""
    count = np.zeros(n + 1)
    count[:-1] += 1.0
    count[1:] += 1.0
    if bending == "curvature":
        count[:-2] += 1.0
        count[1:-1] += 1.0
        count[2:] += 1.0
    elif bending == "distance":
        count[:-2] += 1.0
        count[2:] += 1.0
    for p, q in clamps:
        count[p] += 1.0
        count[q] += 1.0
    return count


def _clamps(scene: Scene) -> list:
    return [(scene.pin_particle(k), scene.clamp_neighbour(k)) for k, pin in enumerate(scene.pins) if pin.clamp]


def _bending_rows(scene: Scene, rules: Rules, alpha_b: float, alpha_c: float, k_c: float) -> Rows:
    """The transverse rows: curvature at every interior particle, then the clamps' (one per clamp per direction)."""
    n, l0 = scene.cable.n_segments, scene.cable.segment_length
    clamps = _clamps(scene)
    grad = np.zeros((n - 1 + len(clamps), n + 1))
    for b in range(n - 1):
        grad[b, b:b + 3] = np.array([1.0, -2.0, 1.0]) / l0**2
    for c, (p, q) in enumerate(clamps):
        grad[n - 1 + c, q], grad[n - 1 + c, p] = 2.0 / l0**2, -2.0 / l0**2
    alpha = np.r_[np.full(n - 1, alpha_b), np.full(len(clamps), alpha_c)]
    k = np.r_[np.full(n - 1, rules.k_bend), np.full(len(clamps), k_c)]
    return Rows(grad=grad, alpha=alpha, k=k, direct=np.full(len(k), rules.direct_bending))


def bending_fraction(scene: Scene, rules: Rules, settings: ParticleSettings, h: float, *, alpha_bend: float,
                     hung: Optional[np.ndarray] = None) -> Optional[float]:
    """The fraction of the stated bending stiffness that the solver's iterations reach on the rod's lowest bending
    mode at substep ``h`` seconds: f = (φᵀ M y_stated) / (φᵀ M y) for the load a = φ, φ the lowest mode of
    K φ = ω² M φ (stated compliances: ``alpha_bend`` per curvature row, 2·``alpha_bend`` per clamp row, the model's
    own), y_stated = φ / ω² and y the iterations' static response (:func:`static_response`). 1 for a converged
    solve; 1/f is how much further the rod sags.

    Returns ``None`` where there is nothing to say: no curvature bending, more than :data:`MAX_SEGMENTS` segments,
    or no bending mode the pins hold (fewer than two pins and no clamp: the rod's lowest modes are rigid motions).
    ``hung``: ``(n + 1,)`` kg hung on pinned particles by the bodies they are pinned to (default none)."""
    cable = scene.cable
    n = cable.n_segments
    if rules.bending != "curvature" or n > MAX_SEGMENTS or n < 2 or alpha_bend <= 0.0:
        return None
    hung = np.zeros(n + 1) if hung is None else hung
    w, mass, free = _chain(scene, hung)
    held = int(np.sum(~free))
    if held < 2 and not _clamps(scene):
        return None
    if settings.order == "direct" and rules.direct_bending and rules.k_bend == rules.k_clamp == 1.0:
        return 1.0  # bending solved at once: converged
    stated = _bending_rows(scene, rules, alpha_bend, 2.0 * alpha_bend, 1.0)
    gf = stated.grad[:, free]
    m_half = 1.0 / np.sqrt(mass[free])
    scaled = (gf * m_half).T @ (gf * m_half / stated.alpha[:, None])  # M^-½ K M^-½, pentadiagonal
    band = np.zeros((_BAND + 1, len(scaled)))
    for d in range(_BAND + 1):
        band[_BAND - d, d:] = np.diagonal(scaled, d)
    values, vectors = linalg.eig_banded(band, select="i", select_range=(0, 0))
    omega2 = float(values[0])
    if omega2 <= _RIGID * float(np.max(np.diagonal(scaled))):  # a rigid motion, not a bending mode
        return None
    phi = np.zeros(n + 1)
    phi[free] = m_half * vectors[:, 0]  # M-normalised: φᵀ M φ = 1
    model = _bending_rows(scene, rules, rules.alpha_bend, rules.alpha_clamp, rules.k_clamp)
    p = sweep_map(model, w, h, order=settings.order, iterations=settings.iterations, omega=settings.omega,
                  count=_counts(n, rules.bending, _clamps(scene)))
    y = static_response(p, free, phi, h)
    along = float(phi @ (mass * y))
    if along <= 0.0:  # the iterations do not hold the mode at all
        return 0.0
    return float((1.0 / omega2) / along)


def stretch_strain(scene: Scene, rules: Rules, settings: ParticleSettings, h: float, *,
                   hung: Optional[np.ndarray] = None, support: Optional[int] = None) -> Optional[float]:
    """The largest static strain of the stretch rows under the cable's own weight (and what bodies hang on its pins,
    ``hung`` (n + 1,) kg), acting along the whole straight cable, beyond what the rows' stated compliance gives:
    the stretch that the iterations at substep ``h`` seconds leave unconverged (dimensionless; an upper bound for a
    cable that hangs slack, whose weight pulls only partly along it). ``support``: a particle held besides the pins
    (a cable hanging from an obstacle, a rope over a peg, held where it rests on it).

    Returns ``None`` where there is nothing to say: nothing holds the cable, or more than :data:`MAX_SEGMENTS`
    segments."""
    cable = scene.cable
    n, l0 = cable.n_segments, cable.segment_length
    hung = np.zeros(n + 1) if hung is None else hung
    w, mass, free = _chain(scene, hung, support)
    if n > MAX_SEGMENTS or free.all():
        return None
    if settings.order == "direct" and rules.k_stretch == 1.0:
        return 0.0  # the stretch chain solved at once: converged
    grad = np.zeros((n, n + 1))
    grad[np.arange(n), np.arange(n)], grad[np.arange(n), np.arange(1, n + 1)] = -1.0, 1.0
    rows = Rows(grad=grad, alpha=np.full(n, rules.alpha_stretch), k=np.full(n, rules.k_stretch),
                direct=np.ones(n, dtype=bool))
    load = np.where(free, float(np.linalg.norm(scene.gravity)), 0.0)
    count = _counts(n, rules.bending, _clamps(scene))  # Jacobi averages over every chain row, bending's included
    p = sweep_map(rows, w, h, order=settings.order, iterations=settings.iterations, omega=settings.omega, count=count)
    strain = np.diff(static_response(p, free, load, h)) / l0
    return float(np.max(np.abs(strain - _stated_strains(scene, rules.alpha_stretch, mass, free))))


def _stated_strains(scene: Scene, alpha: float, mass: np.ndarray, free: np.ndarray) -> np.ndarray:
    """``(n,)`` the segments' static strains of a straight chain of stretch compliance ``alpha`` (m/N) under its
    weight along it, held at its held particles: K y = M a, K = Gᵀ G / α."""
    n, l0 = scene.cable.n_segments, scene.cable.segment_length
    if alpha <= 0.0:
        return np.zeros(n)
    diagonal = np.full(n + 1, 2.0 / alpha)
    diagonal[[0, -1]] = 1.0 / alpha
    index = np.flatnonzero(free)
    band = np.zeros((3, len(index)))  # K over the free particles: tridiagonal
    band[1] = diagonal[index]
    band[0, 1:] = band[2, :-1] = np.where(np.diff(index) == 1, -1.0 / alpha, 0.0)
    y = np.zeros(n + 1)
    y[free] = linalg.solve_banded((1, 1), band, mass[free] * float(np.linalg.norm(scene.gravity)))
    return np.diff(y) / l0


def static_strain(scene: Scene, compliance: float, *, hung: Optional[np.ndarray] = None,
                  support: Optional[int] = None) -> Optional[float]:
    """The largest static strain of the cable as a straight chain of stretch springs of ``compliance`` (m/N, 1/k)
    under its weight along it (and ``hung`` (n + 1,) kg on its pins), held by its pins and at particle ``support``
    (:func:`hanging_support`: a rope over a pulley or through a ring, its boxes held still): what a converged model
    with that stretch stiffness gives (m g / 2 at each end of a cable held at both; a hanging catenary carries about
    1.2 times that at its pins; the heavier box's weight and its leg's beside a support). ``None`` where nothing
    holds the cable."""
    hung = np.zeros(scene.cable.n_particles) if hung is None else hung
    _, mass, free = _chain(scene, hung, support)
    if free.all():
        return None
    return float(np.max(np.abs(_stated_strains(scene, compliance, mass, free))))


def hanging_support(scene: Scene) -> Optional[int]:
    """The particle a cable hangs from, where it starts hanging from an obstacle: its highest particle, if no pin
    holds it in place (no pins, or only body pins whose bodies hang on it: boxes at the ends of a rope over a
    pulley), the scene has obstacles or a user world, and it :func:`hangs` (a rope over a peg, a cable draped over
    a bar); else ``None``."""
    weights = scene.hanging_weights if scene.pins else np.zeros(0)
    held = any(not pin.on_body or weight == 0.0 for pin, weight in zip(scene.pins, weights))
    if held or not (scene.obstacles or scene.world is not None) or not hangs(scene):
        return None
    return int(np.argmax(np.asarray(scene.cable.particles, dtype=np.float64) @ -scene.gravity))


def hangs(scene: Scene) -> bool:
    """Whether the cable starts hanging: most of its start segments steeper than :data:`HANGING_SLOPE` (its weight,
    and what hangs on it, pull along it; ``False`` without gravity)."""
    d = np.diff(np.asarray(scene.cable.particles, dtype=np.float64), axis=0)
    up = -np.asarray(scene.gravity, dtype=np.float64)
    norm = float(np.linalg.norm(up))
    if norm == 0.0:
        return False
    rise = np.abs(d @ (up / norm)) / np.maximum(np.linalg.norm(d, axis=1), 1e-300)
    return bool(np.mean(rise > math.sin(math.radians(HANGING_SLOPE))) > 0.5)


def strain_estimate(scene: Scene, entry, dt: float):
    """``strain(settings)``: the static strain that the particle solver ``entry``'s iterations at ``settings`` leave
    an inextensible cable of ``scene`` under its loads (:func:`stretch_strain`; ``None``: none to estimate)."""
    hung = hung_masses(scene)
    support = hanging_support(scene)

    def strain(s):
        h = dt / s.substeps
        return stretch_strain(scene, entry.rules(scene, s, h), s, h, hung=hung, support=support)

    return strain


def strain_within(expected: Optional[float]) -> bool:
    """Whether an estimate of :func:`strain_estimate` is within :data:`STRAIN_WARNING` (``None``: nothing to say)."""
    return expected is None or expected <= STRAIN_WARNING


def resolve_order(scene: Scene, entry, settings, dt: float):
    """``settings`` with ``order=None`` (``pbd``'s and ``jakobsen``'s default) replaced by the order the Simulator
    takes: ``"direct"`` where Gauss-Seidel sweeps can't carry the scene at the model's stated stiffness, else
    ``"gauss-seidel"``. The sweeps can't carry rings (their projection after the chains carries the loads either side
    only over many, irregular iterations), winches (the loaded rope stays long and its load bounces), several cables
    (a cable pinned taut under another sags; no strain estimate is made for them) or, with the automatic iterations
    (``iterations=None``), a cable whose expected static strain under its loads stays beyond :data:`STRAIN_WARNING`
    at :data:`MAX_AUTO_ITERATIONS` iterations: measured in ``docs/measurements.md``. Iterations the user gives keep
    the sweeps there (and :func:`mjcable.prechecks.check` warns, with the direct order among the fixes). Other settings
    are returned as they are."""
    if entry.family != "particle" or settings.order is not None:
        return settings
    direct = dataclasses.replace(settings, order="direct")
    if scene.rings or len(scene.cables) > 1 or winches.winch_pins(scene):
        return direct
    sweeps = dataclasses.replace(settings, order="gauss-seidel")
    if settings.iterations is not None:
        return sweeps
    most = dataclasses.replace(sweeps, iterations=MAX_AUTO_ITERATIONS)
    return sweeps if strain_within(strain_estimate(scene, entry, dt)(most)) else direct


def resolve_iterations(scene: Scene, entry, settings, dt: float):
    """``settings`` with ``iterations=None`` (a particle solver's default) replaced by the number the Simulator
    takes: the fewest, up to :data:`mjcable.solvers.settings.MAX_AUTO_ITERATIONS`, whose expected static strain of
    each cable under its loads (:meth:`~mjcable.scene.Scene.cable_scene`: what junctions add left out) is within
    :data:`STRAIN_WARNING` (where none is, the most;
    :func:`mjcable.prechecks.check` then warns with the fixes); with rings the most (their projection after the
    chains carries the loads on either side through them over the iterations, :mod:`mjcable.solvers.ring_kernels`).
    Other settings are returned as they are."""
    if entry.family != "particle" or settings.iterations is not None:
        return settings
    if scene.rings:
        return dataclasses.replace(settings, iterations=MAX_AUTO_ITERATIONS)
    strains = [strain_estimate(scene.cable_scene(c), entry, dt) for c in range(len(scene.cables))]
    for k in range(1, MAX_AUTO_ITERATIONS + 1):
        trial = dataclasses.replace(settings, iterations=k)
        if all(strain_within(strain(trial)) for strain in strains):
            return trial
    return trial
