"""Settings of the particle solvers, validated once at the boundary.

Every setting is keyword-only; :func:`solver_settings` rejects names that do not apply to the model, and
:class:`SolverSettings` rejects values outside their range, naming parameter, value and allowed range.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Optional

__all__ = [
    "SolverSettings",
    "solver_settings",
    "ORDERS",
    "BENDING_KINDS",
    "INTEGRATORS",
    "COMMON_SETTINGS",
    "MODEL_SETTINGS",
    "DEFAULT_CONTACT_MARGIN",
    "bending_kind",
]

ORDERS = ("gauss-seidel", "jacobi", "direct")
BENDING_KINDS = ("auto", "none", "curvature", "distance")
INTEGRATORS = ("euler", "verlet")
DEFAULT_CONTACT_MARGIN = 0.005  # m, added to the distance the cable can travel in one step (see contacts.py)
_MAX_OMEGA = 2.0  # Jacobi over-relaxation must stay below 2 to converge

COMMON_SETTINGS = ("substeps", "iterations", "order", "omega", "bending", "contact_margin", "self_collision")
MODEL_SETTINGS = {
    "jakobsen": COMMON_SETTINGS + ("stiffness", "bend_stiffness", "sqrt_approx"),
    "pbd": COMMON_SETTINGS + ("stiffness", "bend_stiffness", "integrator", "constraints"),
    "xpbd": COMMON_SETTINGS + ("stretch_compliance", "bend_compliance"),
}


def _int_at_least(name: str, value, low: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")


def _number_in(name: str, value, low: float, high: float, *, low_open: bool = False) -> None:
    ok = not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)
    ok = ok and (value > low if low_open else value >= low) and value <= high
    if not ok:
        lo = "(" if low_open else "["
        raise ValueError(f"{name} must be a number in {lo}{low:g}, {high:g}], got {value!r}")


def _optional_nonnegative(name: str, value) -> None:
    if value is None:
        return
    ok = not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value) and value >= 0
    if not ok:
        raise ValueError(f"{name} must be None or a finite number >= 0, got {value!r}")


def _choice(name: str, value, allowed: tuple) -> None:
    if value not in allowed:
        raise ValueError(f"{name} must be one of {allowed}, got {value!r}")


@dataclasses.dataclass(frozen=True, kw_only=True)
class SolverSettings:
    """Settings shared by the ``jakobsen``, ``pbd`` and ``xpbd`` solvers (each model accepts a subset, see
    :data:`MODEL_SETTINGS`).

    Args:
      substeps: substeps per ``dt`` (>= 1); the substep is ``h = dt / substeps``.
      iterations: constraint iterations per substep (>= 1).
      order: ``"gauss-seidel"`` (sequential projections), ``"jacobi"`` (all corrections from the same positions,
        averaged per particle and scaled by ``omega``) or ``"direct"`` (a banded solve of all chain constraints per
        iteration: tridiagonal, i.e. the Thomas algorithm, for the stretch chain alone; contacts stay sequential).
      omega: Jacobi relaxation ω in (0, 2] (ignored by the other orders).
      bending: ``"auto"`` (``"curvature"`` if the cable has E·I > 0 or a bend compliance is given, else
        ``"none"``), ``"none"``, ``"curvature"`` (the discrete curvature vector at every interior particle,
        compliance from E·I) or ``"distance"`` (the thesis's next-neighbour (i, i+2) stick of rest length 2 l₀).
      contact_margin: metres (>= 0) added to the distance the cable may travel in one ``dt`` when contacts are
        queried from MuJoCo once per step.
      self_collision: collide non-adjacent segments with each other (no friction).
      stiffness: Jakobsen/PBD stretch stiffness k in [0, 1] (PBD applies 1 − (1 − k)^(1/iterations)).
      bend_stiffness: Jakobsen/PBD bending stiffness in [0, 1]; ``None`` derives it from E·I for curvature bending
        (the stiffness XPBD's first iteration would apply, k = W / (W + α̃)) and uses 1 for distance bending.
      sqrt_approx: Jakobsen's square-root approximation (first-order Taylor at the rest length).
      integrator: PBD prediction, ``"euler"`` (semi-implicit) or ``"verlet"``.
      constraints: PBD user constraints (:class:`mjcable.solvers.pbd.UserConstraint`), projected after the
        built-in ones in every iteration.
      stretch_compliance: XPBD α of every stretch constraint in m/N (>= 0); default l₀ / E·A (0: inextensible).
      bend_compliance: XPBD α of every bending constraint (>= 0), in 1/(N·m³) for curvature bending
        (default 1 / (E·I·l₀)) and m/N for distance bending (required there).
    """

    substeps: int = 1
    iterations: int = 1
    order: str = "gauss-seidel"
    omega: float = 1.0
    bending: str = "auto"
    contact_margin: float = DEFAULT_CONTACT_MARGIN
    self_collision: bool = False
    stiffness: float = 1.0
    bend_stiffness: Optional[float] = None
    sqrt_approx: bool = False
    integrator: str = "euler"
    constraints: tuple = ()
    stretch_compliance: Optional[float] = None
    bend_compliance: Optional[float] = None

    def __post_init__(self):
        _int_at_least("substeps", self.substeps, 1)
        _int_at_least("iterations", self.iterations, 1)
        _choice("order", self.order, ORDERS)
        _number_in("omega", self.omega, 0.0, _MAX_OMEGA, low_open=True)
        _choice("bending", self.bending, BENDING_KINDS)
        _number_in("contact_margin", self.contact_margin, 0.0, math.inf)
        if not isinstance(self.self_collision, bool):
            raise ValueError(f"self_collision must be a bool, got {self.self_collision!r}")
        _number_in("stiffness", self.stiffness, 0.0, 1.0)
        if self.bend_stiffness is not None:
            _number_in("bend_stiffness", self.bend_stiffness, 0.0, 1.0)
        if not isinstance(self.sqrt_approx, bool):
            raise ValueError(f"sqrt_approx must be a bool, got {self.sqrt_approx!r}")
        _choice("integrator", self.integrator, INTEGRATORS)
        try:
            constraints = tuple(self.constraints)
        except TypeError as exc:
            raise ValueError(f"constraints must be a sequence of UserConstraint, got {self.constraints!r}") from exc
        from mjcable.solvers.pbd import UserConstraint  # late: pbd imports this module

        for c in constraints:
            if not isinstance(c, UserConstraint):
                raise ValueError(f"constraints must hold mjcable.solvers.pbd.UserConstraint objects, got {c!r}")
        object.__setattr__(self, "constraints", constraints)
        _optional_nonnegative("stretch_compliance", self.stretch_compliance)
        _optional_nonnegative("bend_compliance", self.bend_compliance)


def bending_kind(settings: SolverSettings, bending_stiffness: float, override) -> str:
    """The bending constraint in use: ``settings.bending``, where ``"auto"`` means ``"curvature"`` if the cable has
    E·I > 0 (``bending_stiffness``, N·m²) or the model's bending override (``bend_stiffness`` or ``bend_compliance``)
    is given, else ``"none"``."""
    if settings.bending != "auto":
        return settings.bending
    return "curvature" if (bending_stiffness > 0.0 or override is not None) else "none"


def solver_settings(model: str, **settings) -> SolverSettings:
    """Validated settings for particle model ``model`` (``"jakobsen"``, ``"pbd"`` or ``"xpbd"``).

    Raises:
      ValueError: an unknown model, a setting the model does not take, or a value outside its range.

    Example::

        s = solver_settings("xpbd", substeps=10, order="direct")
    """
    if model not in MODEL_SETTINGS:
        raise ValueError(f"model must be one of {tuple(MODEL_SETTINGS)}, got {model!r}")
    allowed = MODEL_SETTINGS[model]
    unknown = sorted(set(settings) - set(allowed))
    if unknown:
        raise ValueError(f"unknown setting(s) {unknown} for model {model!r}; allowed: {sorted(allowed)}")
    return SolverSettings(**settings)
