"""``pbd``: Position Based Dynamics (Müller et al. 2007) for the cable, with user constraints.

Prediction by semi-implicit Euler (default) or Verlet (``integrator``). With velocities updated from positions,
v = (x − x_prev)/h, the two are one recurrence (x′ = x + e^{−c h}(x − x_prev) + g h²); they differ in how they
start: Verlet from the exact previous position x₋₁ = x₀ + ½ g h² (free fall exact), Euler from rest (free fall
off by −½ g t h). Then ``iterations`` sequential projections Δxⱼ = −k′ s wⱼ ∇ⱼC, s = C / Σ wⱼ |∇ⱼC|² (thesis
Eqs. 2.11–2.12). The stiffness k ∈ [0, 1] is applied per iteration as k′ = 1 − (1 − k)^(1/iterations) (Müller et
al. 2007), so that a lone constraint loses the fraction k of its violation per substep whatever the iteration
count; with many constraints fighting the result still depends on iterations and on dt: the thesis's accuracy-
and timescale-stiffness effects. PBD has no compliance: the cable's E·A is not used (stretch is hard, softened
only by k and by unconverged iterations).

Bending: ``"curvature"`` (default when E·I > 0) with ``bend_stiffness`` derived from E·I as the fraction XPBD's
first iteration would remove, k = W / (W + α̃), α̃ = 1 / (E·I·l₀·h²), W = 6 w / l₀⁴ for an interior particle;
or ``"distance"``, the thesis's (i, i+2) stick (``bend_stiffness`` default 1). Clamps hold the tangent rigidly.

User constraints (:class:`UserConstraint`) take any C(x) over a few particles, with an analytic gradient or the
thesis's central difference (Eq. 3.1) with a configurable step; they run in Python after the built-in constraints
in every iteration (convenient, not fast: a Python call per constraint per iteration).

Example::

    floor = UserConstraint(particles=(10,), function=lambda p: p[0, 2] - 0.5, inequality=True)
    sim = mjcable.Simulator(scene, "pbd", iterations=4, constraints=[floor])
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable, Optional

import numpy as np

from mjcable.scene import Scene
from mjcable.solvers.settings import SolverSettings, bending_kind
from mjcable.solvers.state import Rules

__all__ = ["rules", "UserConstraint", "iteration_stiffness", "derived_bend_stiffness", "DEFAULT_GRADIENT_STEP"]

DEFAULT_GRADIENT_STEP = 1e-6  # m, central-difference step of numerical gradients
_INTERIOR_BEND_WEIGHT = 6.0  # Σ (1, −2, 1)² of the curvature constraint's gradient, times w / l₀⁴


def iteration_stiffness(k: float, iterations: int) -> float:
    """PBD's per-iteration stiffness 1 − (1 − k)^(1/iterations) (Müller et al. 2007)."""
    return 1.0 - (1.0 - k) ** (1.0 / iterations)


def derived_bend_stiffness(scene: Scene, h: float) -> float:
    """The fraction of a curvature violation XPBD's first iteration removes at substep ``h``: W / (W + α̃)."""
    cable = scene.cable
    l0 = cable.segment_length
    w = cable.n_segments / cable.mass  # interior inverse mass
    weight = _INTERIOR_BEND_WEIGHT * w / l0**4
    alpha_tilde = 1.0 / (cable.bending_stiffness * l0 * h * h)
    return weight / (weight + alpha_tilde)


def bending_rules(model: str, scene: Scene, settings: SolverSettings, h: float) -> tuple:
    """(bending kind, per-substep bend stiffness) for the stiffness-based solvers ``jakobsen`` and ``pbd``."""
    ei = scene.cable.bending_stiffness
    bending = bending_kind(settings, ei, settings.bend_stiffness)
    if bending == "curvature":
        if settings.bend_stiffness is not None:
            k = float(settings.bend_stiffness)
        elif ei > 0.0:
            k = derived_bend_stiffness(scene, h)
        else:
            raise ValueError(f"bending='curvature' needs a bending stiffness: give the cable young > 0 or set "
                             f"bend_stiffness (in [0, 1]) for model {model!r}")
    elif bending == "distance":
        k = 1.0 if settings.bend_stiffness is None else float(settings.bend_stiffness)
    else:
        k = 0.0
    return bending, k


def rules(scene: Scene, settings: SolverSettings, h: float) -> Rules:
    """PBD's kernel parameters for ``scene`` at substep ``h`` seconds (see the module docstring)."""
    n = settings.iterations
    bending, k_bend = bending_rules("pbd", scene, settings, h)
    return Rules(verlet_start=settings.integrator == "verlet", alpha_stretch=0.0, alpha_bend=0.0, alpha_clamp=0.0,
                 k_stretch=iteration_stiffness(settings.stiffness, n), k_bend=iteration_stiffness(k_bend, n),
                 k_clamp=1.0, bending=bending)


@dataclasses.dataclass(frozen=True, kw_only=True)
class UserConstraint:
    """A user constraint C(p) = 0 (or C(p) >= 0) over a few particles, projected by PBD.

    Args:
      particles: indices of the particles C depends on (negative values count from the end).
      function: ``C(p) -> float`` with ``p`` the ``(k, 3)`` positions of ``particles`` in metres.
      gradient: ``∇C(p) -> (k, 3)`` array; ``None`` uses the central difference of thesis Eq. 3.1.
      step: central-difference step in metres (> 0).
      stiffness: k in [0, 1], applied per iteration as 1 − (1 − k)^(1/iterations).
      inequality: project only while C < 0 (a unilateral constraint C >= 0).
    """

    particles: tuple
    function: Callable
    gradient: Optional[Callable] = None
    step: float = DEFAULT_GRADIENT_STEP
    stiffness: float = 1.0
    inequality: bool = False

    def __post_init__(self):
        try:
            parts = tuple(int(p) for p in self.particles)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"particles must be a sequence of particle indices, got {self.particles!r}") from exc
        if not parts or any(isinstance(p, bool) for p in self.particles):
            raise ValueError(f"particles must be a non-empty sequence of particle indices, got {self.particles!r}")
        object.__setattr__(self, "particles", parts)
        if not callable(self.function):
            raise ValueError(f"function must be callable C(p) -> float, got {self.function!r}")
        if self.gradient is not None and not callable(self.gradient):
            raise ValueError(f"gradient must be None or callable ∇C(p) -> (k, 3), got {self.gradient!r}")
        if isinstance(self.step, bool) or not isinstance(self.step, (int, float)) or not 0 < self.step < math.inf:
            raise ValueError(f"step must be a finite number > 0 (metres), got {self.step!r}")
        ok = not isinstance(self.stiffness, bool) and isinstance(self.stiffness, (int, float))
        if not ok or not 0.0 <= self.stiffness <= 1.0:
            raise ValueError(f"stiffness must be a number in [0, 1], got {self.stiffness!r}")
        if not isinstance(self.inequality, bool):
            raise ValueError(f"inequality must be a bool, got {self.inequality!r}")

    def resolved(self, n_particles: int) -> np.ndarray:
        """The particle indices as non-negative integers, checked against a cable of ``n_particles``."""
        idx = np.array(self.particles, dtype=np.int64)
        if np.any(idx < -n_particles) or np.any(idx >= n_particles):
            raise ValueError(f"particles must lie in [{-n_particles}, {n_particles - 1}] for a cable of "
                             f"{n_particles} particles, got {self.particles!r}")
        idx = idx % n_particles
        if len(set(idx.tolist())) != len(idx):
            raise ValueError(f"particles must be distinct, got {self.particles!r}")
        return idx

    def numerical_gradient(self, p: np.ndarray) -> np.ndarray:
        """Central difference (f(x + h) − f(x − h)) / 2h per coordinate (thesis Eq. 3.1); ``p`` (k, 3)."""
        grad = np.empty_like(p)
        q = p.copy()
        for j in range(p.shape[0]):
            for comp in range(3):
                q[j, comp] = p[j, comp] + self.step
                up = float(self.function(q))
                q[j, comp] = p[j, comp] - self.step
                down = float(self.function(q))
                q[j, comp] = p[j, comp]
                grad[j, comp] = (up - down) / (2.0 * self.step)
        return grad

    def project(self, x: np.ndarray, w: np.ndarray, idx: np.ndarray, k: float) -> None:
        """One PBD projection in place: Δxⱼ = −k s wⱼ ∇ⱼC, s = C / Σ wⱼ |∇ⱼC|² (thesis Eqs. 2.11–2.12)."""
        p = x[idx]
        c = float(self.function(p))
        if self.inequality and c >= 0.0:
            return
        grad = np.asarray(self.numerical_gradient(p) if self.gradient is None else self.gradient(p),
                          dtype=np.float64)
        if grad.shape != p.shape:
            raise ValueError(f"gradient must return shape {p.shape}, got {grad.shape}")
        wj = w[idx]
        denom = float(np.sum(wj * np.sum(grad * grad, axis=1)))
        if denom == 0.0:
            return
        x[idx] -= (k * c / denom) * wj[:, None] * grad
