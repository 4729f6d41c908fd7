"""``pbd``: Position Based Dynamics (Müller et al. 2007) for the cable, with user constraints.

Prediction by semi-implicit Euler (default) or Verlet (``integrator``). With velocities updated from positions,
v = (x − x_prev)/h, the two are one recurrence (x′ = x + e^{−c h}(x − x_prev) + g h²); they differ in how they
start, both from rest (v₀ = 0): Verlet by Taylor's first step x₁ = x₀ + ½ g h² (free fall exact), Euler by
x₁ = x₀ + g h² (free fall off by −½ g t h). Then ``iterations`` sequential projections Δxⱼ = −k′ s wⱼ ∇ⱼC, s = C / Σ wⱼ |∇ⱼC|² (thesis
Eqs. 2.11–2.12). The factor k ∈ [0, 1] (``stretch_factor``) is applied per iteration as k′ = 1 − (1 − k)^(1/iterations) (Müller et
al. 2007), so that a lone constraint loses the fraction k of its violation per substep whatever the iteration
count; with many constraints fighting the result still depends on iterations and on dt: the thesis's accuracy-
and timescale-stiffness effects. PBD has no compliance: the cable's E·A is not used (stretch is hard, softened
only by k and by unconverged iterations).

With ``order="direct"`` the stretch chain is solved at once, and at ``stretch_factor`` 1 (its rows are then
XPBD's at α = 0, its multipliers forces) with the tension's geometric stiffness where the tension is stiff, as
``xpbd``'s (:mod:`mjcable.solvers.direct_kernels`): a cable pinned taut between two points stays straight.

Bending: ``"curvature"`` (default when E·I > 0) with ``bend_factor`` derived from E·I as the fraction XPBD's
first iteration would remove, k = W / (W + α̃), α̃ = 1 / (E·I·l₀·h²), W = 6 w / l₀⁴ for an interior particle;
or ``"distance"``, the thesis's (i, i+2) stick (``bend_factor`` default 1). Clamps hold the tangent rigidly.

User constraints (:class:`~mjcable.solvers.user_constraints.UserConstraint`) take any C(x) over a few particles and
run in Python after the built-in constraints in every iteration.

Example::

    floor = UserConstraint(particles=(10,), function=lambda p: p[0, 2] - 0.5, inequality=True)
    sim = mjcable.Simulator(scene, "pbd", iterations=4, constraints=[floor])
"""

from __future__ import annotations

from mjcable.scene import Scene
from mjcable.solvers.settings import ParticleSettings, bending_kind
from mjcable.solvers.state import Rules, single_cable
from mjcable.solvers.user_constraints import UserConstraint, iteration_factor

__all__ = ["rules", "UserConstraint", "iteration_factor", "derived_bend_factor", "IGNORES", "FACTOR_STRETCH"]

#: what the stiffness-based solvers (``pbd``, ``jakobsen``) make of the stretch instead of the cable's E·A
FACTOR_STRETCH = ("its stretch is the dimensionless factor stretch_factor k in [0, 1] (hard at k = 1, softened by k "
                  "and by unconverged iterations), not E·A")
#: the cable's properties this model does not use (:attr:`mjcable.catalog.ModelEntry.ignores`)
IGNORES = {"stretch_stiffness": FACTOR_STRETCH}

_INTERIOR_BEND_WEIGHT = 6.0  # Σ (1, −2, 1)² of the curvature constraint's gradient, times w / l₀⁴


def derived_bend_factor(scene: Scene, h: float) -> float:
    """The fraction of a curvature violation XPBD's first iteration removes at substep ``h``: W / (W + α̃)."""
    cable = single_cable(scene)
    l0 = cable.segment_length
    w = cable.n_segments / cable.mass  # interior inverse mass
    weight = _INTERIOR_BEND_WEIGHT * w / l0**4
    alpha_tilde = 1.0 / (cable.bending_stiffness * l0 * h * h)
    return weight / (weight + alpha_tilde)


def bending_rules(model: str, scene: Scene, settings: ParticleSettings, h: float) -> tuple:
    """(bending kind, per-substep bend factor k) for the stiffness-based solvers ``jakobsen`` and ``pbd``."""
    ei = single_cable(scene).bending_stiffness
    bending = bending_kind(settings, ei, settings.bend_factor)
    if bending == "curvature":
        if settings.bend_factor is not None:
            k = float(settings.bend_factor)
        elif ei > 0.0:
            k = derived_bend_factor(scene, h)
        else:
            raise ValueError(f"bending='curvature' needs a bending stiffness: give the cable young > 0 or set "
                             f"bend_factor (in [0, 1]) for model {model!r}")
    elif bending == "distance":
        k = 1.0 if settings.bend_factor is None else float(settings.bend_factor)
    else:
        k = 0.0
    return bending, k


def rules(scene: Scene, settings: ParticleSettings, h: float) -> Rules:
    """PBD's kernel parameters for the cable of the one-cable ``scene`` at substep ``h`` seconds (see the module
    docstring; several cables: :func:`mjcable.solvers.state.cable_rules`)."""
    n = settings.iterations
    bending, k_bend = bending_rules("pbd", scene, settings, h)
    k_stretch = iteration_factor(settings.stretch_factor, n)
    return Rules(verlet_start=settings.integrator == "verlet", alpha_stretch=0.0, alpha_bend=0.0, alpha_clamp=0.0,
                 k_stretch=k_stretch, k_bend=iteration_factor(k_bend, n), k_clamp=1.0, bending=bending,
                 geometric_stiffness=k_stretch == 1.0)
