"""``flexrod``: the cable as a MuJoCo 1D flex, a discrete elastic rod.

The flex is built with the ``MjSpec`` API alone (``MjSpec.add_flex``, no XML fragment, since ``MjSpec.attach``
drops a flex), so :func:`add_cable` can add the cable to any spec, one that already holds a robot included;
:func:`build` is :func:`~mjcable.mjcf.world.new_spec` plus :func:`add_cable`. It makes what
``<flexcomp type="direct" dim="1" dof="full">`` would generate (the compiled models agree to the bit): one body per
vertex, ``cable_{i}``, a world child at the vertex with three unnamed world-aligned slide joints (x, y, z) and the
vertex at the body origin (empty ``vert``: ``flex_centered``), a point mass per particle; the flex ``cable`` lists
them as ``vertbody`` with the edges ``(i, i + 1)`` as ``elem``.

Mapping from the physical cable (MuJoCo 3.17; the numbers below were measured on the compiled model):

* mass: body ``cable_{i}`` weighs ``cable.particle_masses[i]`` (m/n inside, m/2n at the ends), with the inertia of
  a sphere of the cable radius; the site ``particle{i}`` sits at the vertex.
* stretch, inextensible (``stretch_stiffness=None``): the flex edge equality (``<edge equality="true">``, here an
  ``mjEQ_FLEX`` equality added with the API) holds every edge at its rest length, the equal chord. It is a soft
  constraint whose static strain is about ``(1 - d)/d · (2/mᵢ) · T · τ² / l₀`` for edge tension T, impedance d and
  time constant τ; :data:`EDGE_SOLIMP` uses MuJoCo's largest impedance ``mjMAXIMP`` = 0.9999 and
  :data:`EDGE_SOLREF_STEPS` the shortest time constant MuJoCo accepts (2 steps). A 1 m, 100-segment cable hanging
  0.8 m wide then stays below 1e-3 strain at dt = 0.002 s (measured: 6e-4 at most while it swings, 2e-4 at rest).
  The strain grows with n² at a fixed timestep.
* stretch, finite E·A: flex edge springs of stiffness ``E·A / l₀`` (``flex.edgestiffness``, no equality). MuJoCo
  applies them explicitly, so they are used only while they are stable (see the stability rules below); a stiffer
  E·A would blow up, and since its strain is then small anyway the cable falls back to the inextensible equality,
  with a warning.
* bending (young > 0): MuJoCo gives each interior vertex ``i`` of a 1D flex the discrete-elastic-rod energy
  ``U_i = E·I / (l_{i-1} + l_i) · |κb_i|²``, ``κb_i = 2 e_{i-1} × e_i / (|e_{i-1}| |e_i| + e_{i-1}·e_i)`` (so
  ``|κb| = 2 tan(θ/2)`` for the turning angle θ), with ``I = π r⁴ / 4`` from the flex ``radius``; ``poisson`` and
  ``thickness`` play no part (``flex_bending`` holds ``E π r⁴ / (4 (l_{i-1} + l_i))`` per vertex, and the forces
  match ``-∇U`` to round-off). With equal chords l₀ and small θ this is ``E·I θ² / (2 l₀)``, the rod energy
  ``∫ E·I κ²/2 ds`` with κ = θ / l₀, so ``young = cable.young`` and ``radius = cable.radius`` give
  ``E·I = cable.bending_stiffness`` exactly. The rest shape is always straight (the compiler rejects a bent 1D flex
  with young > 0): a stiff cable compiles straight along ``particles[1] - particles[0]`` from particle 0 and the
  keyframe :data:`~mjcable.mjcf.world.START_KEY` poses the start shape (qpos = each vertex's displacement from its
  straight position). A limp cable (young = 0) compiles in its start shape.
* **the stability rules**: MuJoCo integrates 1D flex bending and edge springs explicitly, even with
  ``implicitfast``. Gershgorin's bound on M⁻¹K gives ω²_max ≤ (4 k_s + 16 E·I / l₀³) / mᵢ and semi-implicit Euler
  needs ω h < 2, i.e. ``k_s + 4 E·I / l₀³ < mᵢ / h²`` with mᵢ = m / n and h MuJoCo's timestep (measured: the
  50-segment ``hang`` scene diverges just above E·I = mᵢ l₀³ / (4 h²), at young ≈ 2.4 MPa for dt = 0.002). The edge
  equality is linearised at the start of each step, so a taut cable's geometric stiffness T / l₀ is explicit too:
  its zigzag mode has ω² = 4 T / (mᵢ l₀), stable while ``h < sqrt(mᵢ l₀ / T)``; with T = m g (a cable carrying its
  own weight) that is ``n < sqrt(L / g) / h``, about 160 segments for a 1 m cable at h = 0.002 s (measured on ``hang``,
  whose top tension is 0.6 m g: 160 segments are stable, 200 fold up within 0.1 s). T is the scene's
  :attr:`~mjcable.scene.Scene.max_tension`: the cable's weight in the scene's gravity plus what bodies hang on its
  pins (a 0.5 kg box on a 5 g, 20-segment cable needs h < 1.1 ms: measured, 1 ms holds, 2 ms stretches the cable
  eightfold). :func:`max_timestep` and :func:`stable_substeps` apply both rules; :func:`build` warns
  (:class:`~mjcable.errors.PhysicsWarning`) when the timestep breaks one.
* self-collision: MuJoCo collides every two flex elements that share no vertex, so with a radius beyond half a
  segment, elements i and i + 2 overlap at rest and push each other apart (the ``hang`` cable sags 7 mm lower at
  0.75 l₀); :func:`build` refuses that (``ValueError``) with the largest radius and the most segments that work.
* integrator: the world's (``implicitfast`` in the built-in scenes), except for a stiff cable (young > 0) on a
  MuJoCo that refuses flex bending under ``implicit``/``implicitfast`` (MuJoCo 4): then the spec steps with
  ``Euler``, a user world's included. The trajectories are the same: the only velocity-dependent forces of the
  cable are its slide joints' damping, which both integrate implicitly, and bending is explicit in both (on MuJoCo
  3.17 a stiff cantilever steps bit for bit the same under either).
* damping rate c (1/s): slide-joint damping ``c·mᵢ`` (implicit in ``implicitfast`` and ``Euler``, zero at rest). MuJoCo 3.17
  refuses joint damping on a bare flex vertex body (three slide joints and nothing else), so each vertex body also
  carries a contact-free marker sphere; it changes nothing else (trajectories are identical to the bit).
* contacts: the flex collides as capsules of the cable radius around its edges, with the cable's μ, condim,
  contype and conaffinity from :func:`~mjcable.mjcf.world.cable_geom`; self-collision (``selfcollide``) only when
  asked (MuJoCo never collides elements that share a vertex).
* pins: site-to-site ``connect`` equalities (:func:`~mjcable.mjcf.world.add_connect`) ``pin{k}`` from the pinned
  particle's site to the anchor site ``anchor{k}``; a clamp also pins the neighbour particle to ``anchor{k}_clamp``
  (equality ``pin{k}_clamp``). The anchor is the
  gripper's mocap body (:func:`~mjcable.mjcf.world.add_anchor`) or, for world and socket pins, a world site in a limp
  cable. A stiff cable compiles straight, where fixed anchors would sit far from their particles and yank the cable
  (a fold of the explicit rod then diverges); its world and socket anchors are therefore mocap bodies
  ``anchor{k}_body`` that nothing moves, at the straight particle in the compiled pose and posed by the keyframe at
  the start particle (turned with the clamp direction), so both poses satisfy every pin exactly.
"""

from __future__ import annotations

import functools
import math
import warnings

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from mjcable.mjcf import snap, world
from mjcable.mjcf.world import START_KEY
from mjcable.errors import PhysicsWarning
from mjcable.scene import Scene

__all__ = [
    "build",
    "add_cable",
    "vertex_body",
    "stable_substeps",
    "precheck",
    "max_timestep",
    "uses_edge_springs",
    "FLEX",
    "EDGE_SOLREF_STEPS",
    "EDGE_SOLIMP",
    "STRETCH_STABILITY_FRACTION",
]

FLEX = "cable"  # name of the flex; its vertex bodies are cable_{i}
EDGE_SOLREF_STEPS = 2.0  # edge-equality time constant in MuJoCo steps (the shortest MuJoCo accepts)
EDGE_SOLIMP = (mujoco.mjMAXIMP, mujoco.mjMAXIMP, 0.001, 0.5, 2.0)  # MuJoCo's stiffest impedance, 0.9999
STRETCH_STABILITY_FRACTION = 0.5  # of the explicit limit mᵢ/h² that edge springs (plus bending) may use
_EDGE_EQUALITY = f"{FLEX}_edges"
_SUBSTEP_SLACK = 1e-9  # forgives round-off when dt is an exact multiple of the longest stable timestep
_ROUND_OFF = 1e-9  # relative: a radius equal to half a segment up to this is not larger
_MARKER_GROUP = 3  # geom group hidden by default in MuJoCo's viewers
_SPHERE_INERTIA = 0.4  # I = 2/5 m r² of a vertex body (slide joints only: it never rotates)
_IMPLICIT = (mujoco.mjtIntegrator.mjINT_IMPLICIT, mujoco.mjtIntegrator.mjINT_IMPLICITFAST)


@functools.cache
def _implicit_flex_elasticity() -> bool:
    """Whether the installed MuJoCo compiles a flex with bending (young > 0) under ``implicitfast`` (MuJoCo 3.x does;
    MuJoCo 4 refuses: "flex elasticity is no longer integrated implicitly"). Found by compiling a two-edge flex."""
    spec = mujoco.MjSpec()
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    for i in range(3):
        body = spec.worldbody.add_body(name=f"v{i}", pos=[0.1 * i, 0.0, 0.0], mass=1.0, ipos=[0.0, 0.0, 0.0],
                                       inertia=[1e-3] * 3, explicitinertial=True)
        for axis in np.eye(3):
            body.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis)
    spec.add_flex(name="probe", dim=1, vertbody=["v0", "v1", "v2"], elem=[0, 1, 1, 2], radius=0.01, young=1e3,
                  poisson=0.0)
    try:
        spec.compile()
    except ValueError:
        return False
    return True


def vertex_body(i: int) -> str:
    """Name of the body of flex vertex ``i``."""
    return f"{FLEX}_{i}"


def _explicit_limit(scene: Scene, timestep: float) -> float:
    """``mᵢ / h²`` in N/m: explicit forces are stable while ``k_s + 4 E·I / l₀³`` stays below it."""
    cable = scene.cable
    return cable.mass / cable.n_segments / timestep**2


def _bending_load(scene: Scene) -> float:
    """``4 E·I / l₀³`` in N/m: the bending term of the stability rule."""
    return 4.0 * scene.cable.bending_stiffness / scene.cable.segment_length**3


def _tension_timestep(scene: Scene) -> float:
    """The longest stable timestep (s) of a cable taut under the scene's load: ``sqrt(mᵢ l₀ / T)``, T the scene's
    :attr:`~mjcable.scene.Scene.max_tension`."""
    cable = scene.cable
    tension = scene.max_tension
    if tension <= 0.0:
        return math.inf
    return math.sqrt(cable.mass / cable.n_segments * cable.segment_length / tension)


def uses_edge_springs(scene: Scene, timestep: float) -> bool:
    """Whether the cable's finite E·A is modelled by edge springs at MuJoCo ``timestep`` (s); otherwise (and for
    ``stretch_stiffness=None``) by the inextensible edge equality."""
    cable = scene.cable
    if cable.stretch_stiffness is None:
        return False
    k_stretch = cable.stretch_stiffness / cable.segment_length
    return k_stretch + _bending_load(scene) <= STRETCH_STABILITY_FRACTION * _explicit_limit(scene, timestep)


def max_timestep(scene: Scene) -> float:
    """The longest MuJoCo timestep in seconds at which the stability rules (module docstring) hold: bending (and, for
    a finite E·A, the edge springs) and the tension of a cable taut under its weight and the bodies hung on its
    pins."""
    cable = scene.cable
    mass = cable.mass / cable.n_segments
    load, fraction = _bending_load(scene), 1.0
    if cable.stretch_stiffness is not None:
        load, fraction = load + cable.stretch_stiffness / cable.segment_length, STRETCH_STABILITY_FRACTION
    explicit = math.sqrt(fraction * mass / load) if load > 0 else math.inf
    return min(explicit, _tension_timestep(scene))


def stable_substeps(scene: Scene, dt: float) -> int:
    """The fewest MuJoCo substeps per ``dt`` (seconds) with a timestep within :func:`max_timestep`.

    Example::

        scene = mjcable.scenes.get("hang", young=1e8)
        sim = mjcable.Simulator(scene, "flexrod", substeps=flexrod.stable_substeps(scene, 0.002))
    """
    return max(1, math.ceil(dt / max_timestep(scene) - _SUBSTEP_SLACK))


def _straight(scene: Scene) -> np.ndarray:
    """``(n + 1, 3)`` the straight rest shape: equal chords from particle 0 along its start tangent, metres."""
    p = scene.cable.particles
    tangent = (p[1] - p[0]) / np.linalg.norm(p[1] - p[0])
    return p[0] + np.arange(scene.cable.n_particles)[:, None] * scene.cable.segment_length * tangent


def build(scene: Scene, *, timestep: float, self_collision: bool = False) -> mujoco.MjSpec:
    """The ``flexrod`` model of ``scene``: :func:`~mjcable.mjcf.world.new_spec`'s world plus :func:`add_cable`,
    MuJoCo stepping at ``timestep`` seconds."""
    spec = world.new_spec(scene, timestep=timestep)
    _add_cable(spec, scene, timestep, self_collision, stacklevel=5)  # warnings point at the catalogue's caller
    return snap.snap_spec(spec)


def add_cable(spec: mujoco.MjSpec, scene: Scene, *, timestep: float, self_collision: bool = False) -> mujoco.MjSpec:
    """Add the scene's cable (the flex, its vertex bodies, edge equality, pins and, for a stiff cable, the
    :data:`~mjcable.mjcf.world.START_KEY` keyframe) to ``spec`` after whatever it already holds, and return it.

    ``spec`` may hold other bodies, joints, actuators and keyframes: their ids do not change (the vertex bodies are
    the last children of the world body). MuJoCo pads the existing keyframes with the cable's compiled pose; a stiff
    cable's START_KEY starts with the spec's own ``qpos0`` and mocap poses (read from a compiled copy). The
    flex is made with ``MjSpec.add_flex``, as ``<flexcomp type="direct" dim="1" dof="full">`` would make it: one
    body ``cable_{i}`` per vertex at the vertex, three unnamed world-aligned slide joints, the vertex at the body
    origin (an empty ``vert``: a centred flex).

    Args:
      spec: the spec to add to (edited in place). It must hold :func:`~mjcable.mjcf.world.new_spec`'s materials
        (``cable``, and ``gripper`` for gripper pins) and none of the cable's names.
      scene: the scene.
      timestep: MuJoCo's physics step in seconds (edge-equality and pin time constants, stability rules).
      self_collision: whether the flex collides with itself.
    """
    return _add_cable(spec, scene, timestep, self_collision, stacklevel=4)


def _add_cable(spec: mujoco.MjSpec, scene: Scene, timestep: float, self_collision: bool, *,
               stacklevel: int) -> mujoco.MjSpec:
    cable = scene.cable
    n = cable.n_particles
    stiff = cable.young > 0.0
    rest = _straight(scene) if stiff else cable.particles
    _check_self_collision(scene, self_collision)
    _check_stability(scene, timestep, stacklevel)
    if stiff and spec.option.integrator in _IMPLICIT and not _implicit_flex_elasticity():
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER
    base_qpos, base_mocap = _base_pose(spec) if stiff else (np.zeros(0), [])

    masses = cable.particle_masses
    for i in range(n):
        body = spec.worldbody.add_body(name=vertex_body(i), pos=rest[i], mass=masses[i], ipos=[0.0, 0.0, 0.0],
                                       inertia=[_SPHERE_INERTIA * masses[i] * cable.radius**2] * 3,
                                       explicitinertial=True)
        for axis in np.eye(3):
            body.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis,
                           damping=[cable.damping * masses[i], 0.0, 0.0])  # MuJoCo 3.17: [linear, polynomial]
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[cable.radius, 0, 0], contype=0, conaffinity=0,
                      group=_MARKER_GROUP, mass=0.0)
        body.add_site(name=world.particle_site(i))

    geom = world.cable_geom(scene, self_collision=self_collision)
    springs = uses_edge_springs(scene, timestep)
    flex = spec.add_flex(
        name=FLEX, dim=1, vertbody=[vertex_body(i) for i in range(n)],
        elem=np.column_stack([np.arange(n - 1), np.arange(1, n)]).ravel().tolist(),
        radius=cable.radius, young=cable.young,
        poisson=0.0,  # unused by a 1D flex; 0 keeps it in MuJoCo's valid range [0, 0.5)
        selfcollide=(mujoco.mjtFlexSelf.mjFLEXSELF_AUTO if self_collision else mujoco.mjtFlexSelf.mjFLEXSELF_NONE),
        edgestiffness=cable.stretch_stiffness / cable.segment_length if springs else 0.0,
        **{attribute: geom[attribute] for attribute in ("friction", "condim", "contype", "conaffinity")})
    _set_material(flex, geom["material"])
    if not springs:
        spec.add_equality(name=_EDGE_EQUALITY, type=mujoco.mjtEq.mjEQ_FLEX, name1=FLEX,
                          solref=[EDGE_SOLREF_STEPS * timestep, 1.0], solimp=EDGE_SOLIMP)

    mocap_pose = _add_pins(spec, scene, timestep, rest, straight=stiff)
    if stiff:
        # the keyframe covers the whole model: what the spec held before keeps its compiled pose (base_*), the
        # cable's joints (the last qpos) take the start shape, its mocap anchors (the last mocap bodies) their poses
        mocap = base_mocap + [mocap_pose[b.name] for b in spec.bodies if b.mocap and b.name in mocap_pose]
        extra = dict(mpos=np.ravel([pos for pos, _ in mocap]), mquat=np.ravel([q for _, q in mocap])) if mocap else {}
        spec.add_key(name=START_KEY, qpos=np.concatenate([base_qpos, (cable.particles - rest).ravel()]), **extra)
    return spec


def _set_material(flex: mujoco.MjsFlex, material: str) -> None:
    """Give ``flex`` the material named ``material`` in whichever form the installed MuJoCo has: one name (a ``str``,
    MuJoCo 3.x) or a list of names (MuJoCo 4, where ``MjSpec.add_flex(material=...)`` takes ``list[str]``); the form
    is read off the flex itself, not off a version number."""
    flex.material = material if isinstance(flex.material, str) else [material]


def _base_pose(spec: mujoco.MjSpec) -> tuple:
    """What ``spec`` holds before the cable goes in: its ``qpos0`` and its mocap bodies' ``[(pos, quat)]`` in mocap
    id order (compiled from a copy; nothing to compile for a spec without joints or mocap bodies)."""
    if not spec.joints and not any(b.mocap for b in spec.bodies):
        return np.zeros(0), []
    model = spec.copy().compile()
    bodies = np.flatnonzero(model.body_mocapid >= 0)
    bodies = bodies[np.argsort(model.body_mocapid[bodies])]
    return model.qpos0.copy(), [(model.body_pos[b].copy(), model.body_quat[b].copy()) for b in bodies]


def _add_pins(spec: mujoco.MjSpec, scene: Scene, timestep: float, rest: np.ndarray, *, straight: bool) -> dict:
    """Anchors and connect equalities of every pin (see the module docstring).

    Args:
      rest: ``(n + 1, 3)`` particle positions in the compiled pose, metres.
      straight: whether that pose is the straight one (else it is the start shape).

    Returns:
      ``{mocap body name: (position (3,), quaternion (4,))}``, the start pose of every mocap anchor.
    """
    p = scene.cable.particles
    pose = {}
    for k, pin in enumerate(scene.pins):
        i = scene.pin_particle(k)
        anchor = world.anchor_site(k)
        if pin.on_body:  # a site in the user's body; the start keyframe poses the cable there
            world.add_anchor(spec, scene, k)
            world.add_connect(spec, world.pin_equality(k), world.particle_site(i), anchor, timestep=timestep)
            if pin.clamp:
                world.add_connect(spec, world.pin_equality(k, clamp=True), world.particle_site(scene.clamp_neighbour(k)),
                                  world.add_clamp_anchor(spec, scene, k), timestep=timestep)
            continue
        if pin.kind == "gripper":
            world.add_anchor(spec, scene, k, position=rest[i])
            host = spec.body(world.gripper_body(k))
        elif straight:
            host = spec.worldbody.add_body(name=_fixed_anchor_body(k), pos=rest[i], mocap=True)
            host.add_site(name=anchor)
        else:
            world.add_anchor(spec, scene, k)
            host = spec.worldbody
        world.add_connect(spec, world.pin_equality(k), world.particle_site(i), anchor, timestep=timestep)
        quat = np.array([1.0, 0.0, 0.0, 0.0])
        if pin.clamp:
            j = scene.clamp_neighbour(k)
            clamp_anchor = f"{anchor}_clamp"
            host.add_site(name=clamp_anchor, pos=p[j] if host is spec.worldbody else rest[j] - rest[i])
            world.add_connect(spec, world.pin_equality(k, clamp=True), world.particle_site(j), clamp_anchor,
                              timestep=timestep)
            quat = _turn(rest[j] - rest[i], p[j] - p[i])
        if host is not spec.worldbody:
            pose[host.name] = (p[i], quat)
    return pose


def _fixed_anchor_body(k: int) -> str:
    return f"{world.anchor_site(k)}_body"


def _turn(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The quaternion (w, x, y, z) of the smallest rotation taking direction ``a`` to direction ``b``."""
    rotation, _ = Rotation.align_vectors(b[None], a[None])
    return rotation.as_quat(scalar_first=True)


def precheck(scene: Scene, settings, dt: float) -> None:
    """The catalogue's ``check``, before the model is built: self-collision that the flex cannot do
    (``ValueError``). The stability rules warn when the model is built (:func:`build`)."""
    del dt
    _check_self_collision(scene, settings.self_collision)


def _check_self_collision(scene: Scene, self_collision: bool) -> None:
    """Refuse self-collision where flex elements i and i + 2 overlap at rest (radius beyond half a segment)."""
    cable = scene.cable
    if not self_collision or cable.radius <= 0.5 * cable.segment_length * (1.0 + _ROUND_OFF):
        return
    raise ValueError(
        f"self_collision=True needs a radius of at most half a segment for flexrod, got radius={cable.radius:g} m "
        f"with segments of {cable.segment_length:.4g} m: MuJoCo collides every two flex elements that share no "
        f"vertex, so elements i and i + 2 would overlap at rest and push each other apart, stretching the cable; "
        f"use a radius <= {0.5 * cable.segment_length:.4g} m for {cable.n_segments} segments, at most "
        f"{max(int(cable.length / (2.0 * cable.radius) * (1.0 + _ROUND_OFF)), 1)} segments for this radius, or "
        f"self_collision=False")


def _fix(scene: Scene, timestep: float) -> str:
    """The fix of a timestep beyond :func:`max_timestep`."""
    longest = max_timestep(scene)
    return (f"use {math.ceil(timestep / longest - _SUBSTEP_SLACK)} times the substeps, for a MuJoCo timestep of at "
            f"most {longest:.3g} s (flexrod.stable_substeps(scene, dt))")


def _check_stability(scene: Scene, timestep: float, stacklevel: int) -> None:
    cable = scene.cable
    if cable.stretch_stiffness is not None and not uses_edge_springs(scene, timestep):
        limit = STRETCH_STABILITY_FRACTION * _explicit_limit(scene, timestep)
        warnings.warn(f"flexrod: edge springs of E·A / l₀ = {cable.stretch_stiffness / cable.segment_length:.4g} N/m "
                      f"are unstable at timestep {timestep:g} s (limit {limit:.4g} N/m including bending); the "
                      f"cable is modelled as inextensible instead (CableSpec.stretch_stiffness="
                      f"{cable.stretch_stiffness:g} N is not used); for the elastic cable, {_fix(scene, timestep)}",
                      PhysicsWarning, stacklevel=stacklevel)
    if _bending_load(scene) > _explicit_limit(scene, timestep):
        warnings.warn(f"flexrod: bending stiffness E·I = {cable.bending_stiffness:.4g} N·m² is unstable at timestep "
                      f"{timestep:g} s (MuJoCo integrates flex bending explicitly; stable below "
                      f"{_explicit_limit(scene, timestep) * cable.segment_length**3 / 4:.4g} N·m²); "
                      f"{_fix(scene, timestep)}", PhysicsWarning, stacklevel=stacklevel)
    if timestep > _tension_timestep(scene):
        warnings.warn(f"flexrod: {cable.n_segments} segments are too fine for timestep {timestep:g} s once the cable "
                      f"is taut under its load of {scene.max_tension:.4g} N (its weight and the bodies hung on its "
                      f"pins; stable below {_tension_timestep(scene):.3g} s); {_fix(scene, timestep)}", PhysicsWarning,
                      stacklevel=stacklevel)
