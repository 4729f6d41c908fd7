"""PBD user constraints: any C(p) = 0 or C(p) >= 0 over a few particles, projected in Python.

User constraints take any C(x) over a few particles, with an analytic gradient or the thesis's central difference
(Eq. 3.1) with a configurable step; :mod:`mjcable.backends.particle` projects them after the built-in constraints
in every iteration (convenient, not fast: a Python call per constraint per iteration).

Example::

    floor = UserConstraint(particles=(10,), function=lambda p: p[0, 2] - 0.5, inequality=True)
    sim = mjcable.Simulator(scene, "pbd", iterations=4, constraints=[floor])
"""

from __future__ import annotations

import dataclasses
from typing import Callable, Optional

import numpy as np

from mjcable import _validate

__all__ = ["UserConstraint", "DEFAULT_GRADIENT_STEP", "iteration_factor"]

DEFAULT_GRADIENT_STEP = 1e-6  # m, central-difference step of numerical gradients


def iteration_factor(k: float, iterations: int) -> float:
    """PBD's per-iteration factor 1 − (1 − k)^(1/iterations) (Müller et al. 2007) for a factor k in [0, 1]."""
    return 1.0 - (1.0 - k) ** (1.0 / iterations)


@dataclasses.dataclass(frozen=True, kw_only=True)
class UserConstraint:
    """A user constraint C(p) = 0 (or C(p) >= 0) over a few particles, projected by PBD.

    Args:
      particles: indices of the particles C depends on (negative values count from the end).
      function: ``C(p) -> float`` with ``p`` the ``(k, 3)`` positions of ``particles`` in metres.
      gradient: ``∇C(p) -> (k, 3)`` array; ``None`` uses the central difference of thesis Eq. 3.1.
      step: central-difference step in metres (> 0).
      factor: PBD's dimensionless k in [0, 1], applied per iteration as 1 − (1 − k)^(1/iterations).
      inequality: project only while C < 0 (a unilateral constraint C >= 0).
    """

    particles: tuple
    function: Callable
    gradient: Optional[Callable] = None
    step: float = DEFAULT_GRADIENT_STEP
    factor: float = 1.0
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
        _validate.number("step", self.step, low=0.0, low_open=True, unit="m")
        _validate.number("factor", self.factor, low=0.0, high=1.0)
        _validate.boolean("inequality", self.inequality)

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
