"""Settings of the particle solvers: one frozen, keyword-only dataclass per model, validated on construction.

Each model's class holds exactly the settings it takes (``dataclasses.asdict(sim.settings)`` rebuilds the same
simulator), and its defaults are the ones the README's "Which model?" recommends: 4 substeps × 1 iteration
(*Small Steps*: substeps beat iterations), and for ``xpbd`` the direct order, which gives XPBD its stated stiffness
in one iteration. Values outside their range raise ``ValueError`` naming parameter, value and allowed range.

A dimensionless PBD/Jakobsen factor k ∈ [0, 1] is called ``*_factor``, never ``*stiffness``: the cable's
``stretch_stiffness`` (E·A, N) and ``bending_stiffness`` (E·I, N·m²) are physical quantities.
"""

from __future__ import annotations

import dataclasses
from typing import Optional

from mjcable import _validate
from mjcable.solvers.user_constraints import UserConstraint

__all__ = [
    "ParticleSettings",
    "JakobsenSettings",
    "PBDSettings",
    "XPBDSettings",
    "CosseratSettings",
    "ORDERS",
    "COSSERAT_ORDERS",
    "BENDING_KINDS",
    "INTEGRATORS",
    "DEFAULT_CONTACT_MARGIN",
    "DEFAULT_QUERY_SLACK",
    "DEFAULT_SUBSTEPS",
    "MAX_AUTO_ITERATIONS",
    "bending_kind",
]

ORDERS = ("gauss-seidel", "jacobi", "direct")
COSSERAT_ORDERS = ("direct", "gauss-seidel")
BENDING_KINDS = ("auto", "none", "curvature", "distance")
INTEGRATORS = ("euler", "verlet")
DEFAULT_CONTACT_MARGIN = 0.005  # m, added to the distance the cable can travel in one step (see contacts.py)
# m, added to a contact query's margin so that the next steps may keep its contacts: a cable at rest (moving
# microns) stops querying, a moving one queries as before. Kept contacts go stale by up to this much (their point on
# the segment and normal): 0.2 mm already made the capstan's rope creep at 0.85 of its slip load (pbd, 3.5 mm/s),
# 1-2.5 mm made it slide at 0.6 (tests/test_particle_contacts.py).
DEFAULT_QUERY_SLACK = 1e-5
# the most constraint iterations per substep that iterations=None takes (beyond them, substeps or the direct order
# are the cheaper fix, and the Simulator warns with them: mjcable.prechecks)
MAX_AUTO_ITERATIONS = 8
DEFAULT_SUBSTEPS = 4  # substeps per dt of every particle solver (Small Steps: substeps beat iterations)
_MAX_OMEGA = 2.0  # Jacobi over-relaxation must stay below 2 to converge


@dataclasses.dataclass(frozen=True, kw_only=True)
class ParticleSettings:
    """Settings shared by the ``jakobsen``, ``pbd`` and ``xpbd`` solvers.

    Args:
      substeps: substeps per ``dt`` (>= 1, default 4); the substep is ``h = dt / substeps``.
      iterations: constraint iterations per substep (>= 1), or ``None`` (default): the Simulator takes the fewest,
        up to :data:`MAX_AUTO_ITERATIONS`, at which the cable's expected static strain under the scene's loads stays
        within what the model promises (:func:`mjcable.solvers.convergence.resolve_iterations`); 1 at the default substeps of
        every built-in scene. The Simulator's ``settings`` hold the number it took.
      order: ``None`` (default): ``"gauss-seidel"``, or ``"direct"`` where the sweeps can't carry the scene (rings,
        winches, several cables, or with ``iterations=None`` a static strain under the scene's loads that
        :data:`MAX_AUTO_ITERATIONS` sweeps leave beyond what the model promises:
        :func:`mjcable.solvers.convergence.resolve_order`; the
        Simulator's ``settings`` hold the order it took); ``"gauss-seidel"`` (sequential projections), ``"jacobi"``
        (all corrections from the same positions,
        each constraint applying the share ``omega`` / count, count the most constraints on one of its particles,
        so that its pushes stay equal and opposite and the pins' reactions are the pushes applied) or
        ``"direct"`` (a banded solve of all chain constraints per iteration: tridiagonal, i.e. the Thomas
        algorithm, for the stretch chain alone; contacts stay sequential).
      omega: Jacobi relaxation ω in (0, 2] (ignored by the other orders).
      bending: ``"auto"`` (``"curvature"`` if the cable has E·I > 0 or a bending override is given, else
        ``"none"``), ``"none"``, ``"curvature"`` (the discrete curvature vector at every interior particle) or
        ``"distance"`` (the thesis's next-neighbour (i, i+2) stick of rest length 2 l₀).
      contact_margin: metres (>= 0) added to the distance the cable may travel in one ``dt`` when contacts are
        queried from MuJoCo.
      query_slack: metres (>= 0) added to a contact query's margin, so that the steps after it keep its contacts
        instead of querying again while every particle stays within ``query_slack`` (less the growth of the step's
        own margin) of where it was at the query (static obstacles only;
        :mod:`mjcable.solvers.query_kernels`, "Reusing a query"). Kept contacts keep their point on the segment
        and normal: the slack bounds how stale they get.
      self_collision: collide non-adjacent segments with each other (Coulomb friction with the cable's own μ).
    """

    substeps: int = DEFAULT_SUBSTEPS
    iterations: Optional[int] = None
    order: Optional[str] = None
    omega: float = 1.0
    bending: str = "auto"
    contact_margin: float = DEFAULT_CONTACT_MARGIN
    query_slack: float = DEFAULT_QUERY_SLACK
    self_collision: bool = False

    def __post_init__(self):
        _validate.integer("substeps", self.substeps, low=1, high=_validate.MAX_SUBSTEPS)
        if self.iterations is not None:
            _validate.integer("iterations", self.iterations, low=1, high=_validate.MAX_SUBSTEPS)
        if self.order is not None:
            _validate.choice("order", self.order, ORDERS)
        _validate.number("omega", self.omega, low=0.0, high=_MAX_OMEGA, low_open=True)
        _validate.choice("bending", self.bending, BENDING_KINDS)
        _validate.number("contact_margin", self.contact_margin, low=0.0, unit="m")
        _validate.number("query_slack", self.query_slack, low=0.0, unit="m")
        _validate.boolean("self_collision", self.self_collision)


@dataclasses.dataclass(frozen=True, kw_only=True)
class _FactorSettings(ParticleSettings):
    """The dimensionless factors of Jakobsen and PBD.

    Args:
      stretch_factor: stretch k in [0, 1] (PBD applies 1 − (1 − k)^(1/iterations); Jakobsen applies k as is).
      bend_factor: bending k in [0, 1]; ``None`` derives it from E·I for curvature bending (the fraction XPBD's
        first iteration would remove, k = W / (W + α̃)) and uses 1 for distance bending.
    """

    stretch_factor: float = 1.0
    bend_factor: Optional[float] = None

    def __post_init__(self):
        super().__post_init__()
        _validate.number("stretch_factor", self.stretch_factor, low=0.0, high=1.0)
        _validate.optional_number("bend_factor", self.bend_factor, low=0.0, high=1.0)


@dataclasses.dataclass(frozen=True, kw_only=True)
class JakobsenSettings(_FactorSettings):
    """``jakobsen``: :class:`ParticleSettings`, the factors, and

    Args:
      sqrt_approx: Jakobsen's square-root approximation (first-order Taylor at the rest length).
    """

    sqrt_approx: bool = False

    def __post_init__(self):
        super().__post_init__()
        _validate.boolean("sqrt_approx", self.sqrt_approx)


@dataclasses.dataclass(frozen=True, kw_only=True)
class PBDSettings(_FactorSettings):
    """``pbd``: :class:`ParticleSettings`, the factors, and

    Args:
      integrator: PBD prediction, ``"euler"`` (semi-implicit) or ``"verlet"``.
      constraints: user constraints (:class:`~mjcable.solvers.user_constraints.UserConstraint`, or mappings of
        their fields, as ``dataclasses.asdict`` writes them), projected after the built-in ones in every iteration.
    """

    integrator: str = "euler"
    constraints: tuple = ()

    def __post_init__(self):
        super().__post_init__()
        _validate.choice("integrator", self.integrator, INTEGRATORS)
        try:
            items = tuple(self.constraints)
        except TypeError as exc:
            raise ValueError(f"constraints must be a sequence of UserConstraint, got {self.constraints!r}") from exc
        constraints = []
        for c in items:
            if isinstance(c, dict):
                c = UserConstraint(**c)
            if not isinstance(c, UserConstraint):
                raise ValueError(f"constraints must hold mjcable.solvers.UserConstraint objects, got {c!r}")
            constraints.append(c)
        object.__setattr__(self, "constraints", tuple(constraints))


@dataclasses.dataclass(frozen=True, kw_only=True)
class XPBDSettings(ParticleSettings):
    """``xpbd``: :class:`ParticleSettings` (order ``"direct"`` by default) and

    Args:
      stretch_compliance: α of every stretch constraint in m/N (>= 0); default l₀ / E·A (0: inextensible).
      bend_compliance: α of every bending constraint (>= 0), in 1/(N·m³) for curvature bending
        (default 1 / (E·I·l₀)) and m/N for distance bending (required there).
    """

    order: str = "direct"
    stretch_compliance: Optional[float] = None
    bend_compliance: Optional[float] = None

    def __post_init__(self):
        super().__post_init__()
        _validate.optional_number("stretch_compliance", self.stretch_compliance, low=0.0, unit="m/N")
        _validate.optional_number("bend_compliance", self.bend_compliance, low=0.0)


@dataclasses.dataclass(frozen=True, kw_only=True)
class CosseratSettings(ParticleSettings):
    """``cosserat``: :class:`ParticleSettings` with ``order`` ``"direct"`` (default: one banded solve over the rod
    per iteration, [D18]) or ``"gauss-seidel"`` (constraint by constraint; stiff rods need many iterations), and
    ``bending`` ``"auto"`` (the rod's bend–twist constraints; the other kinds belong to the point chains)."""

    order: str = "direct"

    def __post_init__(self):
        super().__post_init__()
        _validate.choice("order", self.order, COSSERAT_ORDERS)
        _validate.choice("bending", self.bending, ("auto",))


def bending_kind(settings: ParticleSettings, bending_stiffness: float, override) -> str:
    """The bending constraint in use: ``settings.bending``, where ``"auto"`` means ``"curvature"`` if the cable has
    E·I > 0 (``bending_stiffness``, N·m²) or the model's bending override (``bend_factor`` or ``bend_compliance``)
    is given, else ``"none"``."""
    if settings.bending != "auto":
        return settings.bending
    return "curvature" if (bending_stiffness > 0.0 or override is not None) else "none"

