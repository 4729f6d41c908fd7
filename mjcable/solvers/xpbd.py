"""``xpbd``: Extended Position Based Dynamics (Macklin, Müller, Chentanez 2016) for the cable.

Semi-implicit Euler prediction from rest, then ``iterations`` constraint iterations per substep with Lagrange
multipliers reset every substep, Δλ = (−C − α̃ λ) / (Σ w |∇C|² + α̃), α̃ = α / h² (Eq. 18). Compliances come
from the physical cable, so the stiffness does not depend on ``dt``, ``substeps`` or ``iterations`` once the
iterations converge (or in one iteration with ``order="direct"``):

* stretch: α = l₀ / E·A per segment constraint (energy ½ (E·A / l₀) C²), or 0 for an inextensible cable
  (``stretch_stiffness=None``); ``stretch_compliance`` overrides it (m/N);
* bending (``"curvature"``, the default when E·I > 0): α = 1 / (E·I·l₀) per interior particle for the discrete
  curvature vector C = (x_{i−1} − 2xᵢ + x_{i+1}) / l₀² (energy ½ E·I κ² l₀); ``bend_compliance`` overrides it;
  ``"distance"`` (the thesis's (i, i+2) stick) has no E·I mapping and needs ``bend_compliance`` (m/N);
* clamp: α = 2 / (E·I·l₀), half a Voronoi cell of the same bending energy (rigid when the cable has no bending);
* pins, contacts and friction are hard (α = 0); a pin's force is λ / h², and a socket lets go above its
  ``release_force``;
* with ``order="direct"``, the stretch rows' geometric stiffness λ ∇²C where the tension's transverse waves cross
  more than a fifth of a segment per substep (:mod:`mjcable.solvers.direct_kernels`): one solve per substep stays
  stable and converged on fine chains (the hang's 1600 segments at the default 4 substeps).
"""

from __future__ import annotations

from mjcable.scene import Scene
from mjcable.solvers.settings import ParticleSettings, bending_kind
from mjcable.solvers.state import Rules, single_cable

__all__ = ["rules"]


def rules(scene: Scene, settings: ParticleSettings, h: float) -> Rules:
    """XPBD's kernel parameters for the cable of the one-cable ``scene`` at substep ``h`` seconds (see the module
    docstring; several cables: :func:`mjcable.solvers.state.cable_rules`)."""
    del h  # XPBD's compliances do not depend on the step: α̃ = α / h² is formed in the kernels
    cable = single_cable(scene)
    l0 = cable.segment_length
    ei = cable.bending_stiffness
    if settings.stretch_compliance is not None:
        alpha_s = float(settings.stretch_compliance)
    else:
        alpha_s = 0.0 if cable.stretch_stiffness is None else l0 / cable.stretch_stiffness
    bending = bending_kind(settings, ei, settings.bend_compliance)
    if bending == "curvature":
        if settings.bend_compliance is not None:
            alpha_b = float(settings.bend_compliance)
        elif ei > 0.0:
            alpha_b = 1.0 / (ei * l0)
        else:
            raise ValueError("bending='curvature' needs a bending stiffness: give the cable young > 0 or set "
                             "bend_compliance (>= 0, 1/(N·m³)) for model 'xpbd'")
        alpha_c = 2.0 * alpha_b
    elif bending == "distance":
        if settings.bend_compliance is None:
            raise ValueError("bending='distance' (the (i, i+2) stick) has no E·I mapping: set bend_compliance "
                             "(>= 0, m/N) for model 'xpbd', or use bending='curvature'")
        alpha_b = float(settings.bend_compliance)
        alpha_c = 0.0
    else:
        alpha_b = 0.0
        alpha_c = 0.0
    return Rules(verlet_start=False, alpha_stretch=alpha_s, alpha_bend=alpha_b, alpha_clamp=alpha_c,
                 k_stretch=1.0, k_bend=1.0, k_clamp=1.0, bending=bending, direct_bending=True,
                 geometric_stiffness=True)
