"""``jakobsen``: Jakobsen's Verlet relaxation ("Advanced Character Physics", 2001), as in the thesis §3.4.1.

Verlet integration x′ = x + e^{−c h}(x − x*) + g h² (thesis Eq. 2.7 with Jakobsen's damping, as a rate c in 1/s
that multiplies the velocity only, never gravity), started at rest by Taylor's first step x₁ = x₀ + ½ g h² so that
free fall is exact (the start state's velocity is a true 0, not a fictitious previous position's). Then
``iterations`` relaxation sweeps over the sticks with mass-weighted corrections (Jakobsen's ``invmass`` form),
each scaled by ``stretch_factor`` k ∈ [0, 1] as is (no iteration correction: stiffness grows with iterations and
with smaller steps, the thesis's accuracy- and timescale-stiffness effects).
``sqrt_approx`` replaces the square root by its first-order Taylor expansion at the rest length.

The direct order as for ``pbd`` (at ``stretch_factor`` 1 with the tension's geometric stiffness). Bending as for
``pbd`` (curvature with a stiffness derived from E·I, or the (i, i+2) support stick); clamps hold
the tangent rigidly; contacts move the segment's two particles with Jakobsen's weights (1 − s, s); the cable's
E·A is not used.
"""

from __future__ import annotations

from mjcable.scene import Scene
from mjcable.solvers.pbd import FACTOR_STRETCH, bending_rules
from mjcable.solvers.settings import ParticleSettings
from mjcable.solvers.state import Rules

__all__ = ["rules", "IGNORES"]

#: the cable's properties this model does not use (:attr:`mjcable.catalog.ModelEntry.ignores`)
IGNORES = {"stretch_stiffness": FACTOR_STRETCH}


def rules(scene: Scene, settings: ParticleSettings, h: float) -> Rules:
    """Jakobsen's kernel parameters for ``scene`` at substep ``h`` seconds (see the module docstring)."""
    bending, k_bend = bending_rules("jakobsen", scene, settings, h)
    k_stretch = float(settings.stretch_factor)
    return Rules(verlet_start=True, alpha_stretch=0.0, alpha_bend=0.0, alpha_clamp=0.0,
                 k_stretch=k_stretch, k_bend=k_bend, k_clamp=1.0, bending=bending,
                 sqrt_approx=settings.sqrt_approx, geometric_stiffness=k_stretch == 1.0)
