"""``springs``: the thesis's elastic spring model (§2.2.3, §3.3) on MuJoCo.

One body per particle with three slide joints (a point mass: a free joint's rotations would let a sphere roll
without friction), joined by spatial-tendon springs between neighbours (stretch) and next neighbours (bending).

Mapping from the physical cable:

* mass: lumped particle masses (m/n inside, m/2n at the ends), as sphere geoms of the cable radius;
* stretch: tendon stiffness k₁ = E·A / l₀, rest length l₀ (the equal chord);
* bending: next-neighbour springs (rest length 2 l₀) are quartic in the bending angle θ, so they cannot match
  E·I exactly; their stiffness k₂ = 16 E·I / (l₀³ θ_ref²) equates the spring energy with the rod's E·I θ²/(2 l₀)
  at θ_ref = 1 rad. A qualitative bending model: use ``joints``, ``composite`` or ``flexrod`` for beams;
* damping rate c (1/s): slide-joint damping c·mᵢ (implicit in MuJoCo's ``implicitfast``, and zero at rest);
* **the stability rule**: MuJoCo integrates spring forces explicitly. Gershgorin's bound on M⁻¹K gives
  ω²_max ≤ 4 (k₁ + k₂) n / m for lumped masses, and semi-implicit Euler needs ω_max·h < 2, i.e.
  k₁ + k₂ < m / (n h²) with h MuJoCo's timestep. We use ``k₁ + k₂ = STABILITY_FRACTION · m / (n h²)``: an
  inextensible cable (``stretch_stiffness=None``) gets the largest k₁ the rule allows; a stiffer E·A (or E·I) is
  capped there with a :class:`~mjcable.errors.PhysicsWarning`. The static strain under tension T is then
  T / (k₁ l₀) ∝ h², which is why the model defaults to 10 MuJoCo steps per ``dt``; a Simulator warns when that
  strain under the cable's weight and what bodies hang on its pins would exceed :data:`STRAIN_WARNING` for a
  nominally inextensible cable, and refuses a scene whose loads, let go at rest, would stretch it beyond the
  physics monitor's failing strain (:func:`precheck`: boxes of 2 and 1 kg on a light rope through a ring at the
  default substeps);
* contacts: sphere geoms of the cable radius; the obstacles get a stiff contact time constant
  (:func:`mjcable.mjcf.world.stiffen_obstacle_contacts`), without which the spheres sink through a thin plate and
  chatter as they slide.
"""

from __future__ import annotations

import math
import warnings
from typing import Optional

import mujoco
import numpy as np

from mjcable import monitor
from mjcable._validate import MAX_SUBSTEPS
from mjcable.errors import PhysicsWarning
from mjcable.mjcf import snap, world
from mjcable.scene import Scene
from mjcable.solvers import convergence
from mjcable.worlds import pulley

__all__ = ["build", "spring_stiffness", "static_strain", "precheck", "STABILITY_FRACTION", "BEND_REFERENCE_ANGLE",
           "STRAIN_WARNING", "START_OVERSHOOT"]

STABILITY_FRACTION = 0.25  # of the semi-implicit Euler limit k < m / (n h²); a chain just above it jitters
BEND_REFERENCE_ANGLE = 1.0  # rad, where next-neighbour spring energy equals E·I θ² / (2 l₀)
STRAIN_WARNING = 0.05  # static strain of a nominally inextensible cable beyond which a Simulator warns
# the peak strain over the static one where the loads start from rest on unstretched springs (an undamped spring
# under a step load; measured 1.4-1.6 on the Atwood machine through a ring, docs/measurements.md, 2026-11-27)
START_OVERSHOOT = 2.0
#: what :func:`precheck` refuses a ring with rim friction with (docs/measurements.md, 2026-11-27)
RING_CREEP = ("measured: boxes of 2 and 1 kg through a ring with μ = 0.3 at 0.85 of the capstan law creep at 12-22 "
              "mm/s over 0.3-1 s at 80 to 640 substeps, 2.6 cm in all, where the other models hold within 2 mm/s")
# the peak strain (START_OVERSHOOT times the static one) beyond which a rope carrying loads over a pulley or through a
# ring is refused: the loads bounce on the capped springs and the Atwood machine's acceleration is off (measured,
# docs/measurements.md, 2026-11-27: over a pulley at R = 0.8 m 37, 8.5 and 2.1 % off at peaks 0.083, 0.049 and 0.021
# (10, 13, 20 substeps), 0.2 % at 0.005 (40); through a ring 5.5 % at 0.039 (80), 0.47 % at 0.0098 (160))
ROUTED_STRAIN = 0.01
#: what :func:`precheck` refuses a rope over a pulley or through a ring with
ROUTED_MEASURED = ("measured on the Atwood machines: over a pulley 37 %, 8.5 % and 2.1 % off at peak strains 0.083, "
                   "0.049 and 0.021, 0.2 % at 0.005; through a ring 5.5 % at 0.039, 0.47 % at 0.0098")
_AXES = np.eye(3)


def _stiffness(scene: Scene, timestep: float) -> tuple:
    """``(k_stretch, k_bend, wanted_stretch, wanted_bend)`` in N/m: the springs at MuJoCo timestep ``timestep``
    (s) and what E·A and E·I asked for (``wanted_stretch`` None for an inextensible cable)."""
    cable = scene.cable
    l0 = cable.segment_length
    limit = STABILITY_FRACTION * cable.mass / (cable.n_segments * timestep**2)
    wanted_bend = 16.0 * cable.bending_stiffness / (l0**3 * BEND_REFERENCE_ANGLE**2)
    k_bend = min(wanted_bend, 0.5 * limit)
    wanted_stretch = None if cable.stretch_stiffness is None else cable.stretch_stiffness / l0
    k_stretch = limit - k_bend if wanted_stretch is None else min(wanted_stretch, limit - k_bend)
    return k_stretch, k_bend, wanted_stretch, wanted_bend


def _substeps_for(timestep: float, ratio: float) -> str:
    """The fix: a timestep ``ratio`` times shorter, in substeps per ``dt``."""
    return (f"use at least {math.ceil(ratio)} times the substeps (a MuJoCo timestep of at most "
            f"{timestep / ratio:.3g} s)")


def spring_stiffness(scene: Scene, timestep: float) -> tuple:
    """``(k_stretch, k_bend)`` in N/m for the cable at MuJoCo timestep ``timestep`` (see the module docstring);
    a spring capped at the stable limit warns (:class:`~mjcable.errors.PhysicsWarning`)."""
    k_stretch, k_bend, wanted_stretch, wanted_bend = _stiffness(scene, timestep)
    if wanted_bend > k_bend:
        warnings.warn(f"springs: bending stiffness capped from {wanted_bend:.4g} to {k_bend:.4g} N/m, the stable "
                      f"limit at timestep {timestep:g} s; {_substeps_for(timestep, math.sqrt(wanted_bend / k_bend))}",
                      PhysicsWarning, stacklevel=3)
    if wanted_stretch is not None and wanted_stretch > k_stretch:
        limit = STABILITY_FRACTION * scene.cable.mass / (scene.cable.n_segments * timestep**2)
        ratio = math.sqrt((wanted_stretch + min(wanted_bend, 0.5 * limit)) / limit)
        warnings.warn(f"springs: stretch stiffness capped from {wanted_stretch:.4g} to {k_stretch:.4g} N/m, the stable "
                      f"limit at timestep {timestep:g} s; {_substeps_for(timestep, ratio)}", PhysicsWarning,
                      stacklevel=3)
    return k_stretch, k_bend


def static_strain(scene: Scene, timestep: float) -> Optional[float]:
    """The largest static strain of the stretch springs at MuJoCo ``timestep`` (s) under the cable's weight along it
    and the bodies hung on its pins, held by its pins or, where bodies alone hang on it, at its highest particle
    (:func:`mjcable.solvers.convergence.static_strain` and :func:`~mjcable.solvers.convergence.hanging_support`: a
    rope over a pulley or through a ring carries the heavier box's weight beside it; a hanging catenary carries
    about 1.2 times the estimate at its pins); ``None`` where nothing holds the cable. The bending springs carry
    their share of a straight cable's tension: a cut crosses one stretch spring and two bending springs, each
    stretched over twice the length, so the cable's axial stiffness per segment is k₁ + 4 k₂."""
    k_stretch, k_bend = _stiffness(scene, timestep)[:2]
    return convergence.static_strain(scene, 1.0 / (k_stretch + 4.0 * k_bend), hung=convergence.hung_masses(scene),
                                     support=convergence.hanging_support(scene))


def precheck(scene: Scene, settings, dt: float) -> None:
    """The model's rule at construction (the catalogue's ``check``): the static strain of the springs, capped by the
    stability rule at MuJoCo's timestep ``dt / substeps``, under the scene's loads (:func:`static_strain`). Beyond
    the physics monitor's failing strain (:func:`mjcable.monitor.strain_limits`: twice the rest length for an
    inextensible cable) at :data:`START_OVERSHOOT` times it, a cable that starts hanging
    (:func:`mjcable.solvers.convergence.hangs`: its loads pull along it) would tear: a ``ValueError`` with the
    substeps that hold it (elsewhere the estimate is an upper bound, and warns). A nominally
    inextensible cable (``stretch_stiffness=None``) stretched by more than :data:`STRAIN_WARNING` (a hanging one's
    :data:`START_OVERSHOOT` times its static strain: its loads bounce it on the soft springs) warns with them (the
    strain falls with the timestep squared). A hanging rope over a pulley or through a ring is refused beyond a peak
    strain of :data:`ROUTED_STRAIN` (its loads bounce on the springs), and a ring with rim friction always
    (:data:`RING_CREEP`)."""
    if any(ring.friction > 0.0 for ring in scene.rings):
        raise ValueError(f"springs: a ring's rim friction does not hold its rope, which creeps through it while it "
                         f"settles on the rim at any substeps ({RING_CREEP}); use joints, composite, flexrod or a "
                         f"particle solver for a ring with friction")
    timestep = dt / settings.substeps
    strain = static_strain(scene, timestep)
    if strain is None:
        return
    inextensible = scene.cable.stretch_stiffness is None
    promise, fail, _ = monitor.strain_limits(scene, scene.cable.stretch_stiffness)
    hanging = convergence.hangs(scene)  # (else the loads pull only partly along it)
    peak = START_OVERSHOOT * strain if hanging else strain
    routed = hanging and bool(scene.rings or (scene.world is not None and pulley.pulleys(scene.world.model)))
    target = ROUTED_STRAIN if routed else STRAIN_WARNING if inextensible else promise
    need = math.ceil(settings.substeps * math.sqrt(peak / target))
    fix = (f"substeps >= {need} at dt={dt:g} s" if need <= MAX_SUBSTEPS else
           f"a smaller dt (a MuJoCo timestep of at most {dt / need:.3g} s)")
    if peak > fail and hanging:
        raise ValueError(
            f"springs: the cable's springs, capped at the stable limit for MuJoCo's timestep {timestep:g} s (stretch "
            f"{_stiffness(scene, timestep)[0]:.4g} N/m), would stretch to a static strain of about {strain:.3g} under "
            f"{_loads(scene)}, and to about {peak:.3g} as the loads start from rest, beyond {fail:g} (the physics "
            f"monitor's failing strain: the cable tears); use {fix} (a strain within {target:g}), or a model with "
            f"inextensible segments")
    if routed and peak > ROUTED_STRAIN:
        raise ValueError(
            f"springs: the rope carries its loads over a pulley or through a ring on springs capped at the stable limit "
            f"for MuJoCo's timestep {timestep:g} s: a static strain of about {strain:.3g} under {_loads(scene)}, about "
            f"{peak:.3g} as the loads start from rest, and they bounce on it beyond {ROUTED_STRAIN:g} "
            f"({ROUTED_MEASURED}); use {fix}, or joints, composite or a particle solver")
    if inextensible and peak > STRAIN_WARNING:
        start = f", and to about {peak:.3g} as the loads start from rest" if peak > strain else ""
        warnings.warn(f"springs: the inextensible cable's springs, capped at the stable stiffness for timestep "
                      f"{timestep:g} s, stretch to a static strain of about {strain:.3g} under {_loads(scene)}{start} "
                      f"(beyond {STRAIN_WARNING:g}); use {fix}, or a model with inextensible segments", PhysicsWarning,
                      stacklevel=4)


def _loads(scene: Scene) -> str:
    """The loads of :func:`static_strain` in words."""
    hung = float(np.sum(convergence.hung_masses(scene)))
    support = convergence.hanging_support(scene)
    bodies = f" and {hung:.3g} kg of bodies on its pins" if hung > 0.0 else ""
    held = "" if support is None else f", held where it hangs (particle {support}, its highest)"
    return f"its weight{bodies}{held}"


def build(scene: Scene, *, timestep: float, self_collision: bool = False) -> mujoco.MjSpec:
    spec = world.new_spec(scene, timestep=timestep)
    cable = scene.cable
    n = cable.n_particles
    p = cable.particles
    masses = cable.particle_masses
    geom = world.cable_geom(scene, self_collision=self_collision)

    # Where each particle hangs: the world (fixed), a gripper (welded to its mocap body), or free (slide joints).
    parent = {}
    for k, pin in enumerate(scene.pins):
        held = [scene.pin_particle(k)] + ([scene.clamp_neighbour(k)] if pin.clamp else [])
        if pin.kind == "gripper":
            world.add_anchor(spec, scene, k)
            body = spec.body(world.gripper_body(k))
            for i in held:
                parent[i] = body
        elif pin.kind == "world":
            for i in held:
                parent[i] = spec.worldbody
        else:  # socket or body: free particles held by (releasable) equalities
            world.add_anchor(spec, scene, k)
    for i in range(n):
        host = parent.get(i, spec.worldbody)
        origin = np.zeros(3) if host is spec.worldbody else p[scene.pin_particle(_pin_of(scene, i))]
        body = host.add_body(name=f"cable{i}", pos=p[i] - origin)
        if i not in parent:
            for axis in _AXES:
                body.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis, damping=cable.damping * masses[i])
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[cable.radius, 0, 0], mass=masses[i], **geom)
        body.add_site(name=world.particle_site(i))
    for k, pin in enumerate(scene.pins):
        if pin.kind not in ("socket", "body"):
            continue
        world.add_connect(spec, world.pin_equality(k), world.particle_site(scene.pin_particle(k)),
                          world.anchor_site(k), timestep=timestep)
        if pin.clamp:
            j = scene.clamp_neighbour(k)
            world.add_connect(spec, world.pin_equality(k, clamp=True), world.particle_site(j),
                              world.add_clamp_anchor(spec, scene, k), timestep=timestep)

    k_stretch, k_bend = spring_stiffness(scene, timestep)
    l0 = cable.segment_length
    for gap, k in ((1, k_stretch), (2, k_bend)):
        if k <= 0.0:
            continue
        for i in range(n - gap):
            tendon = spec.add_tendon(name=f"spring{gap}_{i}", stiffness=k, springlength=[gap * l0, gap * l0],
                                     width=0.25 * cable.radius, rgba=[0.3, 0.3, 0.3, 0.0])
            tendon.wrap_site(world.particle_site(i))
            tendon.wrap_site(world.particle_site(i + gap))
    if self_collision:
        world.exclude_overlapping(spec, scene, [f"cable{i}" for i in range(n)], spheres=True)
    world.stiffen_obstacle_contacts(spec, scene, timestep)
    return snap.snap_spec(spec)


def _pin_of(scene: Scene, i: int) -> int:
    """Index into scene.pins of the gripper pin holding particle ``i`` (directly or as its clamp neighbour)."""
    for k, pin in enumerate(scene.pins):
        if pin.kind == "gripper" and (scene.pin_particle(k) == i or (pin.clamp and scene.clamp_neighbour(k) == i)):
            return k
    raise KeyError(i)  # pragma: no cover
