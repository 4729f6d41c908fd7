"""Checks before the first step: what a model would get wrong about a scene without a word, said when the Simulator
is made.

:class:`mjcable.Simulator` calls :func:`check` once, after validating its arguments and before building the model.
Each check warns with a :class:`~mjcable.errors.PhysicsWarning` that names the model, the quantity, its limit and the
fix (a ``ValueError`` where no result could be right):

* **ignored properties**: a ``CableSpec`` property that the model does not use (its catalogue entry's ``ignores``:
  ``stretch_stiffness`` on ``joints`` and ``composite``, whose segments are rigid, and on ``pbd`` and ``jakobsen``,
  whose stretch is the factor k), and ``young`` on a Jakobsen/PBD distance bend (a stick of factor 1, not E·I).
  Explicit overrides (``bend_factor``, ``bend_compliance``, ``stretch_compliance``, ``bending="none"``) are the
  user's choice and pass;
* **the fall rule**, every model: gravity moves a free particle |g| h² in one substep (h = dt / substeps, MuJoCo's
  timestep for the native models). Beyond a segment l₀, one substep's constraints and contacts no longer follow the
  cable: measured on ``hang`` and ``table`` (dt 0.05 to 1 s), ``xpbd`` comes back 1 % long at |g| h² = 1.2 l₀ and
  52 % at 7.6 l₀, ``joints`` and ``composite`` diverge or end up below the floor;
* **the model's own rule** (its entry's ``check``): ``springs``' static stretch under the capped springs
  (:func:`mjcable.mjcf.springs.precheck`: a ``ValueError`` where the cable would tear, as a rope under the 2 kg box
  of an Atwood machine through a ring at the default substeps); ``flexrod``'s explicit bending and tension rules
  are checked by its builder (:mod:`mjcable.mjcf.flexrod`), with the weight of bodies hung on its pins, and its
  ``precheck`` refuses self-collision it cannot do (below); ``joints`` and
  ``composite`` need none (their armature keeps the explicit joint springs stable by construction);
* **the particle solvers' iterations** (:mod:`mjcable.solvers.convergence`): unconverged Gauss-Seidel or Jacobi
  sweeps leave a rod a fraction f of its stated bending stiffness on its lowest mode (warned where its sag 1/f is off
  by more than :data:`STIFFNESS_TOLERANCE`) and stretch an inextensible chain under its weight (warned beyond
  :data:`STRAIN_WARNING`); the warning gives the substeps or iterations that bring it within, or the direct order.
  The iterations' default, ``None``, takes the fewest (up to
  :data:`~mjcable.solvers.settings.MAX_AUTO_ITERATIONS`) that keep the strain within (:func:`resolve_iterations`,
  which the Simulator calls before :func:`check`), so that only iterations the user chose warn. A cable that
  no pin holds but that starts hanging from an obstacle (most of its segments steeper than :data:`HANGING_SLOPE`,
  and obstacles or a user world to hang from) is estimated held at its highest particle: a rope over a peg that one
  Gauss-Seidel sweep per 2 ms leaves 2–4 % long stretches and swings on the peg, and its friction there holds it
  only well below Coulomb's threshold (it slid off at 0.85 of the capstan law, ``docs/measurements.md``). With
  several cables the estimate is not made (each cable's alone would leave out what the cables hang on each other):
  the sweeping orders warn, and the direct order holds every chain at its stated stiffness;
* **pulleys on a native model without spin** (``springs``' point masses and ``flexrod``'s flex vertices: no frames;
  a pulley of :func:`mjcable.worlds.pulley.add_pulley` in the world): no-slip friction holds the rope's surface at
  the rim, R, to the rim's speed, so its centreline runs at ω R instead of ω (R + r) and the pulley turns faster
  than the rope runs, by about r / R (measured: the rim ahead of the boxes by 0.85–0.97 r / R on an elliptic cone;
  the acceleration stays right).
  Beyond :data:`PULLEY_SLIP_TOLERANCE` (the rim's speed equal to the rope's within 1 %) a ``ValueError`` names the
  pulley radius that holds it; within it, a warning;
* **rings on a particle solver's sweeps**: the rings' projection after the chains' Gauss-Seidel or Jacobi sweeps
  carries heavy loads through a ring only over many iterations, irregularly (:func:`_rings`); the direct order
  converges them (the Atwood machine through a ring within 0.12 % on all three solvers, ``docs/measurements.md``).

Self-collision with a radius beyond half a segment works where it can (geoms that overlap at rest never collide:
:meth:`mjcable.scene.CableSpec.overlapping_neighbours`) and is refused by ``flexrod``, whose flex cannot skip them.
A cable starting inside an obstacle or a geom of the user's world is refused by :class:`~mjcable.scene.Scene`.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Optional

import mujoco
import numpy as np

from mjcable import _validate, catalog
from mjcable.errors import PhysicsWarning
from mjcable.scene import CableSpec, Scene
from mjcable.solvers import convergence
from mjcable.solvers.convergence import HANGING_SLOPE, STRAIN_WARNING, resolve_iterations, resolve_order
from mjcable.solvers.settings import MAX_AUTO_ITERATIONS
from mjcable.worlds import pulley

__all__ = ["check", "resolve_order", "resolve_iterations", "STRAIN_WARNING", "STIFFNESS_TOLERANCE",
           "MAX_SUBSTEP_FACTOR", "HANGING_SLOPE", "PULLEY_SLIP_TOLERANCE"]

STIFFNESS_TOLERANCE = 0.1  # a rod whose expected sag is off by more than this fraction warns
#: the rim's speed over the rope's, less 1, beyond which a pulley on a model without spin is refused (the issue's bar)
PULLEY_SLIP_TOLERANCE = 0.01
#: what :func:`_spinless_pulleys` refuses with (docs/measurements.md, 2026-11-27: the Atwood machine over a pulley)
PULLEY_MEASURED = ("measured on the Atwood machine over a pulley: the rim ahead of the boxes by 0.85-0.97 r / R on an "
                   "elliptic friction cone, 0.5-0.8 r / R on the pyramidal one")
MAX_SUBSTEP_FACTOR = 256  # the most substeps (times the given ones) a fix suggests; beyond, only another order
#: what :func:`_rings` warns with (docs/measurements.md, 2026-11-27: the Atwood machine through a ring)
RING_MEASURED = ("the Atwood machine through a ring (2 and 1 kg boxes on a 21 g rope, dt = 2 ms) was 49 % off at 8 "
                 "iterations × 4 substeps (Gauss-Seidel) and 0.4–5 % at 16–60 iterations × 4–8 substeps, not "
                 "steadily better with more")
_UNITS = {"stretch_stiffness": "N", "young": "Pa", "damping": "1/s", "radius": "m", "mass": "kg"}
_STACK = 4  # warnings point at the Simulator's caller: warn ← a check ← check ← Simulator.__init__ ← caller


def check(scene: Scene, entry: catalog.ModelEntry, settings, dt: float) -> None:
    """Every check of the module docstring for ``scene`` simulated by the catalogue's ``entry`` with its validated
    ``settings`` at step ``dt`` seconds.

    Warns:
      PhysicsWarning: a property the model ignores, a substep beyond the fall rule or the model's own rule, a rod or
        chain the solver's iterations leave softer (or stiffer) than stated.

    Raises:
      ValueError: where the model's own rule says no result can be right.
    """
    if entry.family == "native" and not entry.frames and scene.world is not None:
        _spinless_pulleys(scene, entry)  # first: a refusal that no substeps mend
    several = len(scene.cables) > 1
    for c in range(len(scene.cables)):  # several cables: each one's rules (the junctions' loads left out)
        one = scene.cable_scene(c) if several else scene
        _ignored(one, entry, settings)
        _fall(one, entry, settings, dt)
        if entry.check is not None:
            entry.check(one, settings, dt)
        if entry.family == "particle" and not several:  # (the solvers' iterations over several chains: below)
            _iterations(one, entry, settings, dt)
        elif entry.family == "particle" and entry.frames and c == 0:  # a rod's order, once (one stiffness for all)
            _rod_iterations(one, entry, settings, dt)
    if entry.family == "particle" and several:
        _several_sweeps(scene, entry, settings)
    if entry.family == "particle":
        _rings(scene, entry, settings, dt)
    elif scene.rings and scene.world is not None:
        _pyramidal_rings(scene, entry)


def _warn(message: str) -> None:
    warnings.warn(message, PhysicsWarning, stacklevel=_STACK + 1)


def _ignored(scene: Scene, entry: catalog.ModelEntry, settings) -> None:
    """A set ``CableSpec`` property the model does not use."""
    cable = scene.cable
    defaults = {f.name: f.default for f in dataclasses.fields(CableSpec)}
    for field, instead in entry.ignores:
        value = getattr(cable, field)
        if value == defaults[field]:
            continue
        users = ", ".join(catalog.honouring(field)) or "none"
        _warn(f"{entry.name}: CableSpec.{field} = {value:g} {_UNITS.get(field, '')} is ignored: {instead}; the models "
              f"that use it: {users}")
    if cable.young > 0.0 and getattr(settings, "bending", None) == "distance" and (
            hasattr(settings, "bend_factor") and settings.bend_factor is None):
        _warn(f"{entry.name}: CableSpec.young = {cable.young:g} Pa is ignored: bending='distance' is the (i, i+2) "
              f"stick with bend_factor 1 (rigid), not E·I; use bending='curvature' (its stiffness from E·I) or set "
              f"bend_factor")


def _fall(scene: Scene, entry: catalog.ModelEntry, settings, dt: float) -> None:
    """Gravity moving a free particle more than a segment in one substep."""
    substeps = getattr(settings, "substeps", 1)
    h = dt / substeps
    g = float(np.linalg.norm(scene.gravity))
    l0 = scene.cable.segment_length
    if g * h * h > l0:
        longest = math.sqrt(l0 / g)
        need = math.ceil(dt / longest)
        fix = "a smaller dt" if need > _validate.MAX_SUBSTEPS else f"substeps >= {need} at dt={dt:g} s, or a smaller dt"
        _warn(f"{entry.name}: gravity moves a free particle |g| h² = {g * h * h:.3g} m in one substep (h = dt / "
              f"substeps = {h:.3g} s), more than a segment ({l0:.3g} m): one substep's constraints and contacts no "
              f"longer follow the cable, which stretches, passes through obstacles or diverges; the substep must be at "
              f"most sqrt(l₀ / |g|) = {longest:.3g} s: use {fix}")


def _rings(scene: Scene, entry: catalog.ModelEntry, settings, dt: float) -> None:
    """Rings on a particle solver's Gauss-Seidel or Jacobi order: the rings' projection after the chains' sweeps
    carries the loads either side through a ring only over many, irregularly converging iterations
    (:data:`RING_MEASURED`); the direct order solves each side's chain at once."""
    if not scene.rings or settings.order == "direct":
        return
    how = f"order={settings.order!r}, {settings.iterations} iteration(s) × {settings.substeps} substeps at dt={dt:g} s"
    _warn(f"{entry.name}: with {how}, the rings' projection after the chain's sweeps carries the loads either side "
          f"of a ring through it only over many iterations: {RING_MEASURED}; use order='direct' (the chain solved at "
          f"once: 0.12 %)")


def _stated_bending(scene: Scene, rules, settings) -> Optional[float]:
    """The curvature compliance the user states (1/(N·m³)): the model's own (XPBD), else 1 / (E·I·l₀) where the
    bending factor derives from E·I (PBD, Jakobsen without ``bend_factor``); ``None``: nothing stated."""
    if rules.alpha_bend > 0.0:
        return rules.alpha_bend
    ei = scene.cable.bending_stiffness
    if ei > 0.0 and getattr(settings, "bend_factor", None) is None:
        return 1.0 / (ei * scene.cable.segment_length)
    return None


def _direct_bending_models(scene: Scene, h: float) -> list:
    """The particle models whose ``order="direct"`` solves bending at once (their stated stiffness in one
    iteration)."""
    found = []
    for name in catalog.names("particle"):
        try:
            settings = catalog.make_settings(name, order="direct", iterations=1)
            if catalog.get(name).rules(scene, settings, h).direct_bending:
                found.append(name)
        except ValueError:
            continue
    return found


def _more_substeps(settings, measure, good) -> Optional[int]:
    """The fewest substeps, doubling from ``settings.substeps`` up to :data:`MAX_SUBSTEP_FACTOR` times them, whose
    ``measure(settings)`` is ``good``; ``None`` if none is."""
    factor = 2
    while factor <= MAX_SUBSTEP_FACTOR and settings.substeps * factor <= _validate.MAX_SUBSTEPS:
        trial = dataclasses.replace(settings, substeps=settings.substeps * factor)
        if good(measure(trial)):
            return trial.substeps
        factor *= 2
    return None


def _iterations(scene: Scene, entry: catalog.ModelEntry, settings, dt: float) -> None:
    """The stiffness a particle solver's iterations leave the cable (:mod:`mjcable.solvers.convergence`)."""
    hung = convergence.hung_masses(scene)
    support = convergence.hanging_support(scene)

    def rules(s):
        return entry.rules(scene, s, dt / s.substeps)

    strain = convergence.strain_estimate(scene, entry, dt)
    how = f"order={settings.order!r}, {settings.iterations} iteration(s) × {settings.substeps} substeps at dt={dt:g} s"
    expected = strain(settings)
    if not convergence.strain_within(expected):
        need = _more_substeps(settings, strain, convergence.strain_within)
        fixes = [] if settings.order == "direct" else ["order='direct' (the stretch chain solved at once)"]
        if need is not None:
            fixes.append(f"substeps >= {need}")
        more = next((k for k in range(settings.iterations + 1, MAX_AUTO_ITERATIONS + 1)
                     if convergence.strain_within(strain(dataclasses.replace(settings, iterations=k)))), None)
        if more is not None:
            fixes.append(f"iterations >= {more} (iterations=None takes it)")
        where = "" if support is None else (
            f"; it hangs from an obstacle (estimated held at particle {support}, its highest), so it stretches and "
            f"swings on its support, and friction there holds it only well below Coulomb's threshold")
        _warn(f"{entry.name}: with {how}, the constraint iterations leave the cable a static strain of about "
              f"{expected:.3g} under its weight beyond what its stated stretch gives (none for an inextensible cable; "
              f"warned beyond {STRAIN_WARNING:g}){where}; use "
              f"{' or '.join(fixes) or 'a smaller dt'}")

    if entry.frames:  # a rod with frames (cosserat): its stretch rows sweep as the chain's, its bending does not
        _rod_iterations(scene, entry, settings, dt)
        return

    def fraction(s):
        r = rules(s)
        alpha = _stated_bending(scene, r, s)
        return None if alpha is None else convergence.bending_fraction(scene, r, s, dt / s.substeps,
                                                                        alpha_bend=alpha, hung=hung)

    def within(f):
        return f is not None and f > 0.0 and abs(1.0 / f - 1.0) <= STIFFNESS_TOLERANCE

    f = fraction(settings)
    if f is None or within(f):
        return
    stated = 1.0 / (_stated_bending(scene, rules(settings), settings) * scene.cable.segment_length)
    direct = _direct_bending_models(scene, dt / settings.substeps)
    fixes = []
    if entry.name in direct and settings.order != "direct":
        fixes.append("order='direct' (bending solved at once: the stated stiffness in one iteration)")
    elif entry.name not in direct and direct:
        fixes.append(f"the direct order of {' or '.join(direct)} (order='direct': the stated stiffness in one "
                     f"iteration)")
    need = _more_substeps(settings, fraction, within)
    if need is not None:
        fixes.append(f"substeps >= {need}")
    sag = f"sags {1.0 / f:.3g} times as far as stated" if f > 0.0 else "does not hold its shape"
    _warn(f"{entry.name}: with {how}, the rod reaches about {f:.3g} of its stated bending stiffness (E·I = "
          f"{stated:.4g} N·m²) on its lowest bending mode: it {sag}; use "
          f"{' or '.join(fixes) or 'more iterations'}")


def _rod_iterations(scene: Scene, entry: catalog.ModelEntry, settings, dt: float) -> None:
    """A Cosserat rod's Gauss-Seidel order: its stiffness is stated only when converged. Each frame's rotational
    inertia (its slice ρ l₀ I of the rod) is tiny against the bend–twist rows, so the sweeps move the frames little
    per iteration (at 50 segments, 20 iterations left a torsion 7 times too soft, docs/measurements.md); the direct
    order reaches the stated stiffness in one iteration."""
    if settings.order == "direct" or scene.cable.young <= 0.0:
        return
    how = f"order={settings.order!r}, {settings.iterations} iteration(s) × {settings.substeps} substeps at dt={dt:g} s"
    _warn(f"{entry.name}: with {how}, the rod's bending and twist reach their stated stiffness (E·I = "
          f"{scene.cable.bending_stiffness:.4g} N·m², G·J = {scene.cable.torsion_stiffness:.4g} N·m²) only once the "
          "Gauss-Seidel sweeps converge, which its frames' small rotational inertia makes slow: it may sag and twist "
          "several times as far as stated; use order='direct' (the stated stiffness in one iteration)")


def _several_sweeps(scene: Scene, entry: catalog.ModelEntry, settings) -> None:
    """Several cables on a particle solver's Gauss-Seidel or Jacobi order: no strain estimate (module docstring)."""
    if settings.order == "direct":
        return
    _warn(f"{entry.name}: with order={settings.order!r} and {len(scene.cables)} cables, no estimate of the iterations' "
          f"static strain is made (one cable's alone would leave out what the cables hang on each other through their "
          f"contacts and junctions): a cable pinned taut under another sags and swings (measured: a rope over a "
          f"taut cable at 0.85 of the capstan law creeps at 4 mm/s with pbd and jakobsen at their defaults, where it "
          f"holds with the direct order); use order='direct'")


def _pyramidal_rings(scene: Scene, entry: catalog.ModelEntry) -> None:
    """A native model's rings with rim friction in a user world on MuJoCo's pyramidal friction cone."""
    if scene.world.model.opt.cone != mujoco.mjtCone.mjCONE_PYRAMIDAL or not any(r.friction for r in scene.rings):
        return
    _warn(f"{entry.name}: the world's friction cone is pyramidal, on which a ring's rim friction creeps (measured: "
          f"boxes held at 0.85 of the capstan law through a ring with μ = 0.3 move at 0.11-0.18 m/s); set the world's "
          f"<option cone=\"elliptic\" impratio=\"10\"/> (spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC)")


def _spinless_pulleys(scene: Scene, entry: catalog.ModelEntry) -> None:
    """A native model whose particles carry no spin (no frames: ``springs``' point masses, ``flexrod``'s flex
    vertices) with pulleys of :func:`mjcable.worlds.pulley.add_pulley` in the world (module docstring): the rim
    runs ahead of the rope by about r / R, refused beyond :data:`PULLEY_SLIP_TOLERANCE`."""
    radius = max(c.radius for c in scene.cables)
    for body, rim in pulley.pulleys(scene.world.model).items():
        ratio = radius / rim
        why = (f"its particles carry no spin, so the rim's friction holds the rope's surface (at the rim, R = {rim:g} "
               f"m) rather than its centreline (at R + r, r = {radius:g} m) and pulley {body!r} turns faster than the "
               f"rope runs, by about r / R = {ratio:.2g}")
        if ratio > PULLEY_SLIP_TOLERANCE:
            raise ValueError(
                f"{entry.name}: {why}, beyond {PULLEY_SLIP_TOLERANCE:g} ({PULLEY_MEASURED}); use a pulley of radius "
                f"at least r / {PULLEY_SLIP_TOLERANCE:g} = {radius / PULLEY_SLIP_TOLERANCE:.3g} m, or a model whose "
                f"segments turn with the rim (joints, composite) or a particle solver")
        _warn(f"{entry.name}: {why} (within {PULLEY_SLIP_TOLERANCE:g}); the boxes' acceleration is not affected. "
              f"For the pulley's exact speed use joints, composite or a particle solver")
