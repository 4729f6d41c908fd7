"""``cosserat``: a Cosserat rod in XPBD, particles and one material frame (a unit quaternion) per segment.

Stretch–shear and bend–twist constraints of Kugelstadt & Schömer 2016 ("Position and Orientation Based Cosserat
Rods", SCA 2016) with XPBD compliances (Macklin et al. 2016) from the physical cable, solved all at once per iteration
as one banded system over the rod (``order="direct"``, Deul et al. 2018, "Direct Position-Based Solver for Stiff
Rods") or constraint by constraint (``order="gauss-seidel"``); the equations, with their sources, are in
:mod:`mjcable.solvers.cosserat_kernels`. With l₀ the rest segment length:

* stretch–shear of each segment: α = (1/(G·A l₀), 1/(G·A l₀), 1/(E·A l₀)), the stretch row 0 for an inextensible
  cable (``stretch_stiffness=None``), the shear rows 0 for a cable without G (E = 0: its frames follow the tangent,
  or the segment could grow across its frame's axis);
* bend–twist between neighbouring segments: α = (1/(E·I₁ l₀), 1/(E·I₂ l₀), 1/(G·J l₀)) (I₁ = I₂ = I for a round
  cable; a flat one's ``CableSpec.section`` gives I₁ about d₁ and I₂ about d₂); a rod without bending
  stiffness (E = 0) has none of these rows' stiffness (α = ∞ is taken as a free joint: the rows are left at a
  compliance of 1/(ε l₀) with ε = ``_LIMP`` N·m²); where the torsion stiffness G·J is none too (a rope), the
  direct solve leaves those rows out (:mod:`mjcable.solvers.cosserat_direct_kernels`, as ``xpbd`` leaves out
  bending at E = 0), and with them a clamp's frame, which then holds its particle only;
* G is the cable's ``shear_modulus``, or E / (2 (1 + ν)), ν = 0.5; A = π r², I = π r⁴ / 4, J = π r⁴ / 2
  (an elliptic section's, :class:`mjcable.CableSpec`);
* the rest Darboux vectors are zero (``rest_shape="straight"``) or the start curve's (``"start"``);
* a clamp holds its particle and the frame of the segment beside it (the whole frame: tangent and the turn about it);
  a body clamp holds the frame at its start orientation in the body, and the body feels the rod's torque, axial
  twist included (two-way, implicit in the body's rotational inertia: :mod:`mjcable.solvers.cosserat_kernels`);
  a gripper's frame turns with :meth:`mjcable.Simulator.move_gripper`'s ``orientation``; a clamp's torque
  (:attr:`mjcable.Simulator.pin_torques`) is the torque its frame receives, −Σ R ∇_b Cᵀ λ / h², axial torque
  included;
* the start frames carry ``CableSpec.start_twist`` (segment i turned about d₃ by Φ (i + ½) / n) while the rest
  Darboux vectors stay untwisted: Φ is elastic twist (a clamp's frame starts at its particle's share, 0 or Φ);
* a junction makes two particles one point as in ``xpbd``; a clamped one, of two cable ends (a loop: the cable's own),
  also welds the frames of the segments at it at their start turn (hard), so that a closed ring keeps the twist its
  start frames carry. The welds and junctions are solved with the rod's band through its Schur complement (a loop's
  closing rows are not banded), so a rod welds in the direct order and with E > 0 only (the Gauss-Seidel order and
  a limp rod refuse a clamped junction; :mod:`mjcable.solvers.cosserat_weld_kernels`);
* pins, contacts and friction act on the particles as in ``xpbd``;
* several cables lie one after the other in one rod state as ``xpbd``'s chains do: the gap segment between two
  cables carries no rows (its frame, the identity, is turned by nothing), so that the band falls apart into one block
  per cable, joined only by the junctions' rows; contacts between cables as in ``xpbd``. The cables share the rod's
  compliances and segment (:data:`ROD_SHARED`); a clamp holds the first cable's start or the last one's end only, and
  a clamped junction welds a loop of a one-cable scene only (a ``ValueError`` otherwise).
"""

from __future__ import annotations

from mjcable.scene import Scene
from mjcable.solvers.settings import ParticleSettings
from mjcable.solvers.state import Rules, shared_cable

__all__ = ["rules", "compliances", "ROD_SHARED"]

_LIMP = 1e-12  # N·m²: the bending and twist stiffness standing in for none (E = 0): a free joint in practice


#: the cable properties the rod's parameters hold once for all of a scene's cables (:func:`shared_cable`)
ROD_SHARED = ("radius", "segment_length", "stretch_stiffness", "shear stiffness G·A", "bending stiffness E·I₁",
              "bending stiffness E·I₂", "torsion_stiffness")


def compliances(scene: Scene) -> tuple:
    """The six compliances of ``scene``'s cable (of several: their one set, :data:`ROD_SHARED`): stretch–shear
    (shear, shear, stretch) in 1/(N·m) and bend–twist (bend, bend, twist) in 1/(N·m³) (see the module docstring).

    Raises:
      ValueError: several cables that differ in one of :data:`ROD_SHARED` (named, with both values)."""
    cable = shared_cable(scene, ROD_SHARED, "model 'cosserat'")
    l0 = cable.segment_length
    ga = cable.shear * cable.area
    shear = 1.0 / (ga * l0) if ga > 0.0 else 0.0  # a rope without E: frames held to the tangent (Kirchhoff)
    stretch = 0.0 if cable.stretch_stiffness is None else 1.0 / (cable.stretch_stiffness * l0)
    bend1, bend2 = (1.0 / (max(ei, _LIMP) * l0) for ei in cable.bending_stiffnesses)
    twist = 1.0 / (max(cable.torsion_stiffness, _LIMP) * l0)
    return (shear, shear, stretch, bend1, bend2, twist)


def rules(scene: Scene, settings: ParticleSettings, h: float) -> Rules:
    """The kernels' parameters of ``cosserat`` for ``scene`` (see the module docstring)."""
    del settings, h  # XPBD's compliances do not depend on the step: α̃ = α / h² is formed in the kernels
    limp = max(*scene.cables[0].bending_stiffnesses, scene.cables[0].torsion_stiffness) <= _LIMP
    # a limp rod's geometric stiffness (cosserat_direct_kernels) with several cables only: it holds a cable pinned
    # taut under a rope lying on it (without it the rope slid off at 0.85 of the capstan law), one cable's scenes run
    # as before without it, and it doubles a solve's cost wherever the tension is stiff (a 1600-segment hang: 0.39
    # against 0.17 s per simulated s; docs/measurements.md, 2026-11-27)
    return Rules(verlet_start=False, alpha_stretch=0.0, alpha_bend=0.0, alpha_clamp=0.0, k_stretch=1.0, k_bend=1.0,
                 k_clamp=1.0, bending="none", rod_compliance=compliances(scene), rod_limp=limp,
                 geometric_stiffness=limp and len(scene.cables) > 1)
