"""``joints``: the thesis's stiff model (§2.2.3, §3.3) in reduced coordinates: a kinematic tree of capsules.

Body ``cable{i}`` (``i = 0 .. n-1``) has its frame at particle ``i`` with its local x axis along the segment and
carries a capsule from particle ``i`` to particle ``i+1``; body ``i+1`` hangs from body ``i`` at ``(l₀, 0, 0)`` by a
ball joint. Site ``particle{i}`` sits at body ``i``'s origin, ``particle{n}`` at the end of the last capsule. (This
is the tree order from particle 0; a cable held only at its far end runs the other way, from particle n: see the
pins below.) The segment lengths are part of the kinematics, so the chain is exactly inextensible.

Mapping from the physical cable:

* mass: each of the n segment bodies weighs m/n (a capsule geom of the cable radius; inertia from its shape);
* length: segment l₀ (the equal chord) from body origin to body origin: the rest length n·l₀ holds exactly;
* stretch: E·A (``stretch_stiffness``) is not modelled: the joints keep every segment length exactly;
* bending: ball-joint stiffness k = E·I / l₀ in N·m/rad, the discrete rod energy E·I·θ² / (2 l₀) of a bend by θ
  over one segment. A ball joint's stiffness is isotropic, so it also acts on twist: the chain's torsional
  stiffness is E·I / l₀, not the rod's G·J / l₀ = E·I / ((1 + ν) l₀) (a third stiffer in twist at ν = 0.5).
  E = 0 is a limp chain compiled in its start shape. With E > 0 the chain compiles straight (a ball joint's spring
  reference is qpos0), along the start tangent, and the keyframe ``mjcable.mjcf.world.START_KEY`` poses the start
  shape (each ball quaternion is the minimal rotation between consecutive segment directions, in the parent's
  frame);
* damping rate c (1/s): MuJoCo's medium viscosity (:func:`segment_viscosity`), which drags every segment with
  −c·(m/n)·v at its centre of mass, like the particle models' −c·mᵢ·vᵢ, plus ball-joint damping c·A (A the armature
  below), which drains the armature's kinetic energy at the same rate. Joint damping alone would not do: it acts on
  relative rotations, which a chain's smooth, slow modes hardly have (tried: c·(m/n)·l₀² per ball joint leaves the
  hanging cable swinging for ever). Both vanish at rest, so they never change a static equilibrium;
* integrator: semi-implicit Euler, implicit in joint damping (:func:`integrator`; ``implicitfast`` only where the
  explicit drag would be too strong for Euler). ``implicitfast`` would also differentiate the drag, which triples
  the cost of a step here;
* the whip (numerical regularisation, :func:`ball_options`): a limp inextensible chain's free end speeds up without
  bound as it swings through; joint speeds near 1/h then make MuJoCo's explicit Coriolis terms diverge (at every dt
  tried, down to 0.2 ms). Each ball joint gets the armature ``WHIP_ARMATURE``·(m/n)·l₀², rotor inertia on the
  joint's rotation, and the damping A / (``WHIP_RELAXATION_STEPS``·h), which relaxes a joint's relative spin within
  that many steps. Neither changes statics. The armature adds the fraction α·(k·l₀)⁴ to the kinetic energy of a
  bending wave of wavenumber k (under 1 % for waves longer than 35 segments); the damping is a bending viscosity
  A·l₀ / (20 h) that damps waves shorter than about 10 segments within a few periods and waves of 50 segments or
  more at well under 1/s;
* explicit joint springs: E·I/l₀·(h/``STABLE_OMEGA_H``)² more armature (:func:`joint_armature`). The chain's
  stiffness matrix in joint coordinates is k·I, so its fastest mode has ω² ≤ k / A and ω·h ≤ ``STABLE_OMEGA_H``.
  A free root is three slide joints and a ball joint (:func:`add_root_joints`) so that its rotation carries the
  same armature and damping (a free joint's armature would add massless inertia to its translations);
* contacts: ``world.cable_geom`` on every capsule; neighbouring capsules never collide (parent and child bodies,
  and explicit excludes). The obstacles get a stiff contact time constant of
  ``world.CONTACT_SOLREF_STEPS`` physics steps (:func:`mjcable.mjcf.world.stiffen_obstacle_contacts`): with
  MuJoCo's default 20 ms, the tension of the inextensible chain draping over the ``drape`` peg presses it 3 cm
  into the 3 cm peg and pulls it through;
* cost: a serial chain's joint-space mass matrix is dense, so a step costs O(n³) (reduced coordinates);
  :func:`jacobian` picks the faster constraint Jacobian layout.

The tree is rooted at a pinned end (:func:`root_pin`, :func:`tree_order`): at particle 0, or, when only the far
end (particle n) has a world or gripper pin, at particle n, the chain then running n → 0 (body ``i``'s origin is
particle n − i; the sites keep their particle numbers). A gripper pin at an end is preferred to a world pin, and
the root's pin is part of the tree: a world pin gives the root a ball joint (a clamped world pin none: welded to
the world); a gripper pin makes the root a child of the mocap body ``gripper{k}`` (ball joint, or none when
clamped); no such pin gives a free root. Every other pin holds its particle with a site-to-site connect equality
``pin{k}`` to ``anchor{k}`` (a world site, or a site in the gripper's mocap body). A socket is always such an
equality (it lets go).

Clamps hold the whole frame, the turn about the tangent included: two more connects, a point on the axis one
segment in (``pin{k}_clamp``) and one off the axis (``pin{k}_roll``, ``ROLL_LEVER`` radii out). A stiff cable's
clamp at an end (:func:`frame_clamps`) holds the frame *at its particle*, as the rod's clamped boundary does: a
clamp body ``clamp{k}`` (the clamp's frame: welded to the world or gripper at the tree's root, else held by the
three connects) from which the end segment turns by a ball joint at the particle with the stiffness of half a
segment, E·I / (l₀/2) (:func:`add_first_body`, :func:`add_last_clamp`; the cable plugin measures ``composite``'s
over the half segment between the bodies' origins). The chain then bends and twists over its whole length, as the
rod does: the clamped arc's end torque, the cantilever's deflection and the twisted rod's torque C φ / L converge as
O(1/N²), like ``cosserat``'s, where a rigidly held end segment (a limp cable's clamp, and an interior clamp) bends
and twists over N − 1 joints only (the arc's end torque 1/(N − 1) high and more). The three connects of a clamp
body have MuJoCo's stiffest impedance at rest (``CLAMP_SOLIMP``: 0.9999, falling to 0.99 beyond 1 mm): a soft
equality sags under a steady load by (1 − d) times the load over the constraint's effective mass and its stiffness
1/(2h)², and the fall keeps it soft where a moving gripper's carry violates it by millimetres each step. The sag
grows with the segments (their mass and armature shrink) and with h²: the quarter-circle arc keeps its end force
within 1 % of B / R² at the default 2 ms up to 50 segments, at 1 ms (2 substeps) up to 100 (measurements:
``docs/measurements.md``).

Why the far-end gripper roots the tree: a connect equality at the deepest leaf of a free-rooted 50-segment chain
is what a moving gripper makes diverge (``unplug``: socket at particle 0, gripper at particle n, mjWARN_BADQACC
within 1 s of random 0.5 m/s motion; the ``hang`` cable held by a far-end gripper alone: within 1.3 to 2.7 s).
MuJoCo's equality constraint is a velocity-level servo on the linearised end position: its reference
acceleration −b·J·v − k·r knows neither the mocap anchor's velocity (a mocap body has none; its motion only shows
up as position error r) nor the J̇·v term, the centripetal acceleration of the held end through all n nested
rotations of the whirling chain. Both are left to the two-step Baumgarte spring, so the held end trails by up to
1.5 cm (against 1.7 mm of anchor motion per step) before the blow-up, which starts in the ball joints next to
the constraint (joint speeds 50 → 800 → 10⁵ rad/s within 6 steps). A softer equality (5 steps) only delays
it (2 s); ``implicit``/``implicitfast`` do not help; ten times the whip armature, or relaxing it in 4 steps,
hides it by changing the dynamics. As the tree's root the gripper moves its particle exactly (kinematically, like
the gripper at particle 0, which never diverged), needs no equality, and steps about 2.5 times faster. Grippers
away from the ends (tried at the middle particle) and the second gripper of a cable held at both ends (the chain
closed into a loop, ``reach_sag``) stay connect equalities; random 0.5 m/s motion of those stays stable.

``composite`` builds the same chain with MuJoCo's ``<composite type="cable">`` and shares these helpers.
"""

from __future__ import annotations

import functools
import math
from typing import Callable, Optional

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from mjcable.mjcf import snap, world
from mjcable.mjcf.world import START_KEY
from mjcable.scene import Scene

__all__ = [
    "build",
    "IGNORES",
    "root_pin",
    "tree_order",
    "root_joint",
    "add_root_joints",
    "joint_stiffness",
    "segment_viscosity",
    "jacobian",
    "integrator",
    "joint_armature",
    "ball_options",
    "segment_frames",
    "relative_quats",
    "add_anchors",
    "add_pin_equalities",
    "body_name",
    "clamp_body_name",
    "frame_clamps",
    "add_clamp_body",
    "add_first_body",
    "add_last_clamp",
    "STABLE_OMEGA_H",
    "WHIP_ARMATURE",
    "WHIP_RELAXATION_STEPS",
]

#: the cable's properties this model does not use (:attr:`mjcable.catalog.ModelEntry.ignores`)
IGNORES = {"stretch_stiffness": "its segments are rigid, so the cable is inextensible"}
ROLL_LEVER = 10.0  # a clamp's roll site sits this many cable radii (at least a segment) off the axis: a stiff turn
CLAMP_MASS = 1e-3  # a clamp body weighs this fraction of a segment (MuJoCo needs a mass on a body that turns)
CLAMP_SOLIMP = (0.9999, 0.99, 0.001, 0.5, 2.0)  # a clamp body's connects' impedance (see add_pin_equalities)
CLAMP_GROUP = 3  # the clamp bodies' geom group (hidden in viewers by default)
STABLE_OMEGA_H = 1.0  # ω·h of the fastest joint-spring mode the armature allows (semi-implicit Euler's limit is 2)
WHIP_ARMATURE = 10.0  # α of the ball-joint armature α·(m/n)·l₀² that tames the free-end whip
WHIP_RELAXATION_STEPS = 20.0  # physics steps in which ball-joint damping relaxes the armature's relative spin
_PARALLEL_EPS = 1e-12  # |sin| below which two directions count as (anti)parallel


def body_name(i: int) -> str:
    """Name of segment body ``i``."""
    return f"cable{i}"


def clamp_body_name(k: int) -> str:
    """Name of the clamp body of pin ``k`` (:func:`frame_clamps`)."""
    return f"clamp{k}"


def root_pin(scene: Scene) -> Optional[int]:
    """Index into ``scene.pins`` of the pin that the kinematic tree realises at its root, or ``None``.

    A world or gripper pin at either end of the cable (a socket is releasable, and a body pin must leave the user's
    kinematic tree and joint order alone, so neither is ever a root): grippers before world pins, particle 0 before
    particle n. Holding a moving gripper at the tree's root, rather than with a
    connect equality at a leaf, is what keeps the chain stable under a moving gripper (see the module docstring).
    """
    n = scene.cable.n_segments
    ends = [k for k, pin in enumerate(scene.pins)
            if pin.kind in ("world", "gripper") and scene.pin_particle(k) in (0, n)]
    if not ends:
        return None
    return min(ends, key=lambda k: (scene.pins[k].kind != "gripper", scene.pin_particle(k) != 0))


def tree_order(scene: Scene) -> np.ndarray:
    """``(n + 1,)`` particle indices in tree order: body ``j``'s origin is particle ``tree_order(scene)[j]``;
    ``0 .. n``, or ``n .. 0`` when :func:`root_pin` holds particle n."""
    n = scene.cable.n_segments
    k = root_pin(scene)
    order = np.arange(n + 1)
    return order[::-1].copy() if k is not None and scene.pin_particle(k) == n else order


def frame_clamps(scene: Scene) -> tuple:
    """``(first, last)``: the index into ``scene.pins`` of the clamp at the tree's first particle and at its last
    (:func:`tree_order`) that holds its frame in a clamp body, each ``None`` where there is none.

    Only a stiff cable (E > 0) has them: its clamp holds the frame at its particle, and the end segment turns from it
    through a ball joint over half a segment (stiffness E·I / (l₀/2), see the module docstring). A limp cable's clamp,
    and a clamp at an interior particle, holds the segment beside it instead (the connects of
    :func:`add_pin_equalities`).
    """
    if scene.cable.young <= 0.0:
        return None, None
    order = tree_order(scene)
    clamps = {scene.pin_particle(k): k for k in reversed(range(len(scene.pins))) if scene.pins[k].clamp}
    return clamps.get(int(order[0])), clamps.get(int(order[-1]))


def add_clamp_body(parent, scene: Scene, k: int, *, pos, quat):
    """Add pin ``k``'s clamp body to ``parent`` at ``pos`` (m) and ``quat`` (w, x, y, z) in it, and return it.

    The body's frame is its end segment's at the start (x along the chain in tree order); its origin sits half a
    segment before the particle the clamp holds, which is at (l₀/2, 0, 0) in it: the cable plugin measures a joint's
    length between body origins, so the clamp's joint gets E·I / (l₀/2) there as in ``joints``. It carries a hidden
    capsule of the cable's radius that never collides (the plugin reads the section from a body's first geom) and
    weighs ``CLAMP_MASS`` of a segment (a body that turns needs a mass in MuJoCo).
    """
    cable = scene.cable
    body = parent.add_body(name=clamp_body_name(k), pos=pos, quat=quat)
    body.add_geom(name=f"{clamp_body_name(k)}_capsule", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                  fromto=[0.0, 0.0, 0.0, 0.5 * cable.segment_length, 0.0, 0.0], size=[cable.radius, 0.0, 0.0],
                  mass=CLAMP_MASS * cable.mass / cable.n_segments, contype=0, conaffinity=0, group=CLAMP_GROUP,
                  rgba=[0.0, 0.0, 0.0, 0.0])
    return body


def joint_stiffness(scene: Scene) -> float:
    """Ball-joint bending stiffness E·I / l₀ in N·m/rad (0 for a limp cable)."""
    return scene.cable.bending_stiffness / scene.cable.segment_length


def joint_armature(scene: Scene, timestep: float, *, half: bool = False) -> float:
    """Ball-joint armature in kg·m²: ``WHIP_ARMATURE``·(m/n)·l₀² + k·(h / ``STABLE_OMEGA_H``)², k the joint's
    stiffness: E·I/l₀, or a clamp's half-segment joint's (``half``) 2·E·I/l₀."""
    cable = scene.cable
    whip = WHIP_ARMATURE * cable.mass / cable.n_segments * cable.segment_length**2
    return whip + (2.0 if half else 1.0) * joint_stiffness(scene) * (timestep / STABLE_OMEGA_H) ** 2


def ball_options(scene: Scene, timestep: float, *, half: bool = False) -> dict:
    """Armature and damping of a ball joint (``half``: a clamp's half-segment joint): :func:`joint_armature` A, and
    the damping A·(c + 1 / (``WHIP_RELAXATION_STEPS``·h)) in N·m·s/rad: the first part drains the armature's kinetic
    energy at the cable's damping rate c (the medium drag only reaches the bodies), the second relaxes a joint's
    relative spin within ``WHIP_RELAXATION_STEPS`` steps (see the module docstring)."""
    armature = joint_armature(scene, timestep, half=half)
    rate = scene.cable.damping + 1.0 / (WHIP_RELAXATION_STEPS * timestep)
    return dict(armature=armature, damping=[rate * armature, 0.0, 0.0])


@functools.lru_cache(maxsize=64)
def _capsule_box(radius: float, length: float, mass: float) -> tuple:
    """``(inertia (3,), box (3,))``: MuJoCo's principal inertia in kg·m² of a capsule geom (compiled, so it matches
    MuJoCo exactly) and the full sides in metres of its equivalent inertia box (MuJoCo's fluid model)."""
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body()
    body.add_freejoint()
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0.0, 0.0, 0.0, length, 0.0, 0.0],
                  size=[radius, 0.0, 0.0], mass=mass)
    inertia = spec.compile().body_inertia[1].copy()
    box = np.sqrt(6.0 * (inertia.sum() - 2.0 * inertia) / mass)
    return inertia, box


def segment_viscosity(scene: Scene) -> float:
    """MuJoCo's medium ``viscosity`` μ in Pa·s whose drag on every segment body is c·(m/n)·v.

    MuJoCo's inertia-box fluid model applies the force −3π·μ·d·v at a body's centre of mass and the torque
    −π·μ·d³·ω, d the mean side of the box with the body's mass and inertia. Every segment is the same capsule, so
    μ = c·(m/n) / (3π·d) gives each the translational damping c·(m/n) (and the rotational damping c·(m/n)·d²/3).
    """
    cable = scene.cable
    m_seg = cable.mass / cable.n_segments
    _, box = _capsule_box(cable.radius, cable.segment_length, m_seg)
    return cable.damping * m_seg / (3.0 * math.pi * float(box.mean()))


def integrator(scene: Scene, timestep: float) -> int:
    """MuJoCo's semi-implicit Euler where the explicit medium drag is stable, else ``implicitfast``.

    Euler integrates joint damping implicitly but the drag explicitly: the drag's largest rate (c, or
    c·d²/3 per unit mass over the capsule's smallest moment of inertia per unit mass for rotations) times the
    timestep must stay below ``STABLE_OMEGA_H``. ``implicitfast`` also differentiates the drag, at about three times
    the cost of a step, so it is used only beyond that (very heavy damping).
    """
    cable = scene.cable
    m_seg = cable.mass / cable.n_segments
    inertia, box = _capsule_box(cable.radius, cable.segment_length, m_seg)
    rate = cable.damping * max(1.0, m_seg * float(box.mean()) ** 2 / 3.0 / float(inertia.min()))
    if rate * timestep <= STABLE_OMEGA_H:
        return mujoco.mjtIntegrator.mjINT_EULER
    return mujoco.mjtIntegrator.mjINT_IMPLICITFAST


def jacobian(scene: Scene) -> int:
    """MuJoCo's constraint Jacobian layout: dense for a scene without obstacles (a serial chain's mass matrix is
    dense, and its pin equalities reach every dof: about twice as fast), MuJoCo's automatic choice (sparse for long
    chains) with contacts, where the Newton solver refactors per iteration (about twice as fast at 100 segments)."""
    return mujoco.mjtJacobian.mjJAC_AUTO if scene.obstacles else mujoco.mjtJacobian.mjJAC_DENSE


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(m, 4)`` unit quaternions (w, x, y, z) of the minimal rotations taking unit vectors ``a`` to ``b`` (m, 3)."""
    a = np.atleast_2d(a)
    b = np.atleast_2d(b)
    cross = np.cross(a, b)
    dot = np.sum(a * b, axis=1)
    q = np.concatenate([(1.0 + dot)[:, None], cross], axis=1)
    opposite = np.linalg.norm(cross, axis=1) < _PARALLEL_EPS
    opposite &= dot < 0.0
    if np.any(opposite):  # half turn about any axis normal to a
        helper = np.where(np.abs(a[opposite, 0:1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        axis = np.cross(a[opposite], helper)
        q[opposite] = np.concatenate([np.zeros((axis.shape[0], 1)), axis], axis=1)
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def _quat_mul(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Hamilton products of ``(m, 4)`` quaternion arrays (w, x, y, z)."""
    w1, x1, y1, z1 = np.moveaxis(np.atleast_2d(q1), -1, 0)
    w2, x2, y2, z2 = np.moveaxis(np.atleast_2d(q2), -1, 0)
    return np.stack([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ], axis=-1)


def _conj(q: np.ndarray) -> np.ndarray:
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def segment_frames(particles: np.ndarray, root_quat: Optional[np.ndarray] = None) -> np.ndarray:
    """World orientations of the segment bodies along a polyline, without twist.

    Args:
      particles: ``(n + 1, 3)`` particle positions in metres.
      root_quat: ``(4,)`` orientation (w, x, y, z) of segment 0, whose x axis must point along the first segment;
        default: the minimal rotation taking the world x axis there.

    Returns:
      ``(n, 4)`` unit quaternions: segment ``i``'s local x axis points from particle ``i`` to ``i + 1``; each frame
      is its predecessor turned by the minimal rotation between the two segment directions (parallel transport).
    """
    d = np.diff(np.asarray(particles, dtype=np.float64), axis=0)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    turns = _rotation_between(d[:-1], d[1:])
    frames = np.empty((d.shape[0], 4))
    frames[0] = _rotation_between(np.array([1.0, 0.0, 0.0]), d[0])[0] if root_quat is None else root_quat
    for i in range(1, d.shape[0]):  # build time only: a short sequential product
        frames[i] = _quat_mul(turns[i - 1], frames[i - 1])[0]
        frames[i] /= np.linalg.norm(frames[i])
    return frames


def relative_quats(frames: np.ndarray) -> np.ndarray:
    """``(n - 1, 4)`` orientation of each segment frame ``i + 1`` in frame ``i`` (ball-joint quaternions)."""
    q = _quat_mul(_conj(frames[:-1]), frames[1:])
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def add_anchors(spec: mujoco.MjSpec, scene: Scene) -> None:
    """``world.add_anchor`` for every pin, in pin order (so mocap ids follow ``scene.gripper_pins``)."""
    for k in range(len(scene.pins)):
        world.add_anchor(spec, scene, k)


def add_pin_equalities(spec: mujoco.MjSpec, scene: Scene, *, timestep: float, body_name: Callable[[int], str],
                       skip: Optional[int] = None) -> None:
    """Hold every pin but ``skip`` with site-to-site connect equalities (independent of qpos0).

    Pin ``k`` connects ``particle{i}`` to ``anchor{k}`` (from :func:`add_anchors`: a world site, or a site in the
    gripper's mocap body); a clamp also connects a point on the cable's axis one segment in (``anchor{k}_clamp``, at
    the neighbouring particle's start position, in the same body) and a point off the axis beside the particle (along
    the segment's y axis, ``anchor{k}_roll``): three points hold the whole frame, the turn about the tangent
    included. The points are sites of the clamp body (:func:`frame_clamps`: ``particle{i}_clamp`` and
    ``particle{i}_roll``, the frame at the particle, the end segment turning from it), or else of the segment body
    ``body_name(b)`` (tree index b) beside the particle (``particle{j}``, the neighbour itself, and
    ``particle{i}_roll``: that segment held rigidly). Equalities are named ``pin{k}``, ``pin{k}_clamp`` and
    ``pin{k}_roll``.
    """
    cable = scene.cable
    n, l0 = cable.n_segments, cable.segment_length
    order = tree_order(scene)
    frames = segment_frames(cable.particles[order])  # the bodies' start orientations, in tree order
    framed = frame_clamps(scene)
    for k, pin in enumerate(scene.pins):
        if k == skip:
            continue
        i = scene.pin_particle(k)
        solimp = CLAMP_SOLIMP if k in framed else world.PIN_SOLIMP
        world.add_connect(spec, world.pin_equality(k), world.particle_site(i), world.anchor_site(k),
                          timestep=timestep, solimp=solimp)
        if not pin.clamp:
            continue
        j = scene.clamp_neighbour(k)
        b = int(np.flatnonzero(order == i)[0])
        along = 0.0 if b < n else l0  # the last particle sits at the end of the last body
        b = min(b, n - 1)
        frame = Rotation.from_quat(frames[b], scalar_first=True)
        lever = max(l0, ROLL_LEVER * cable.radius)
        roll_point = cable.particles[i] + lever * frame.apply([0.0, 1.0, 0.0])
        if k in framed:  # the clamp body's frame: its sites at the neighbour's and the roll point's start positions
            holder = spec.body(clamp_body_name(k))
            origin = cable.particles[i] - 0.5 * l0 * frame.apply([1.0, 0.0, 0.0])
            tangent = world.clamp_site(i)
            holder.add_site(name=tangent, pos=frame.inv().apply(cable.particles[j] - origin))
            holder.add_site(name=world.roll_site(i), pos=frame.inv().apply(roll_point - origin))
        else:  # the segment beside the particle, held rigidly: its neighbour particle and a roll site on it
            holder, tangent = spec.body(body_name(b)), world.particle_site(j)
            holder.add_site(name=world.roll_site(i), pos=[along, lever, 0.0])
        world.add_connect(spec, world.pin_equality(k, clamp=True), tangent, world.add_clamp_anchor(spec, scene, k),
                          timestep=timestep, solimp=solimp)
        roll = world.add_roll_anchor(spec, scene, k, roll_point)
        world.add_connect(spec, world.pin_equality(k, roll=True), world.roll_site(i), roll, timestep=timestep,
                          solimp=solimp)


def root_joint(scene: Scene) -> tuple:
    """``(kind, k)``: how body 0 attaches (``"free"``, ``"ball"`` or ``None``: welded to its parent) and the index
    of the pin that the tree itself realises (``None`` when equalities hold every pin)."""
    k = root_pin(scene)
    if k is None or scene.pins[k].kind == "socket":
        return "free", None
    return (None if scene.pins[k].clamp else "ball"), k


def add_root_joints(body, kind: Optional[str], *, name: str, options: dict) -> None:
    """Joints of the root segment ``body`` (a child of the world or of a mocap gripper).

    ``"free"`` is three slide joints along the world axes followed by a ball joint: unlike a free joint (whose
    armature would also act as massless inertia on translations), the root's rotation then carries the same
    armature and damping (``options``, from :func:`ball_options`) as every other ball joint; its qpos is laid out
    like a free joint's: displacement from the body position (3), then the ball quaternion relative to the body
    frame (4). ``"ball"`` is a ball joint without stiffness (a pin free to rotate); ``None`` adds nothing.
    """
    if kind == "free":
        world_axes = Rotation.from_quat(np.asarray(body.quat), scalar_first=True).inv().apply(np.eye(3))
        for axis, label in zip(world_axes, "xyz"):
            body.add_joint(name=f"{name}_{label}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis)
    if kind in ("free", "ball"):
        body.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_BALL, **options)


def add_first_body(parent, scene: Scene, kind: Optional[str], *, pos, quat, timestep: float, name: str,
                   root_name: str, stiffness: float = 0.0):
    """Add segment body 0 (``name``) to ``parent`` at ``pos`` and ``quat`` (its start frame in ``parent``) with the
    root's joints ``kind`` (:func:`add_root_joints`, named ``root_name``), and return it. With a clamp body at
    the tree's first particle (:func:`frame_clamps`) the clamp body takes that place and the root's joints, and
    segment 0 hangs from it by the clamp's half-segment ball joint (``stiffness`` in N·m/rad: 2·E·I/l₀ for
    ``joints``, 0 where the cable plugin bends it)."""
    first, _ = frame_clamps(scene)
    root_options = ball_options(scene, timestep)
    if first is None:
        segment = parent.add_body(name=name, pos=pos, quat=quat)
        add_root_joints(segment, kind, name=root_name, options=root_options)
        return segment
    along = Rotation.from_quat(quat, scalar_first=True).apply([0.5 * scene.cable.segment_length, 0.0, 0.0])
    holder = add_clamp_body(parent, scene, first, pos=np.asarray(pos) - along, quat=quat)
    add_root_joints(holder, kind, name=root_name, options=root_options)
    segment = holder.add_body(name=name, pos=[0.5 * scene.cable.segment_length, 0.0, 0.0])
    segment.add_joint(name=f"{clamp_body_name(first)}_ball", type=mujoco.mjtJoint.mjJNT_BALL,
                      stiffness=[stiffness, 0.0, 0.0], **ball_options(scene, timestep, half=True))
    return segment


def add_last_clamp(last, scene: Scene, *, timestep: float, stiffness: float = 0.0):
    """The clamp body at the tree's last particle (:func:`frame_clamps`), a child of the last segment body
    ``last``, turning from it by a half-segment ball joint at the particle (``stiffness`` as in
    :func:`add_first_body`); returns it, or ``None`` where there is none."""
    _, k = frame_clamps(scene)
    if k is None:
        return None
    half = 0.5 * scene.cable.segment_length
    holder = add_clamp_body(last, scene, k, pos=[half, 0.0, 0.0], quat=[1.0, 0.0, 0.0, 0.0])
    holder.add_joint(name=f"{clamp_body_name(k)}_ball", type=mujoco.mjtJoint.mjJNT_BALL, pos=[half, 0.0, 0.0],
                     stiffness=[stiffness, 0.0, 0.0], **ball_options(scene, timestep, half=True))
    return holder


def build(scene: Scene, *, timestep: float, self_collision: bool = False) -> mujoco.MjSpec:
    """The ``joints`` spec of ``scene`` (see the module docstring); MuJoCo steps at ``timestep`` seconds."""
    spec = world.new_spec(scene, timestep=timestep)
    cable = scene.cable
    n = cable.n_segments
    l0 = cable.segment_length
    order = tree_order(scene)
    p = cable.particles[order]  # tree order: body i's origin is p[i], particle order[i]
    frames = segment_frames(p)
    rel = relative_quats(frames)
    straight = cable.young > 0.0
    geom = world.cable_geom(scene, self_collision=self_collision)
    options = ball_options(scene, timestep)
    spec.option.viscosity = segment_viscosity(scene)
    spec.option.integrator = integrator(scene, timestep)
    spec.option.jacobian = jacobian(scene)
    world.stiffen_obstacle_contacts(spec, scene, timestep)

    add_anchors(spec, scene)
    kind, tree_pin = root_joint(scene)
    if tree_pin is not None and scene.pins[tree_pin].kind == "gripper":
        parent, origin = spec.body(world.gripper_body(tree_pin)), np.zeros(3)
    else:
        parent, origin = spec.worldbody, p[0]
    half = 2.0 * joint_stiffness(scene)  # a clamp's half-segment joint
    body = add_first_body(parent, scene, kind, pos=origin, quat=frames[0], timestep=timestep, name=body_name(0),
                          root_name=f"{body_name(0)}_root", stiffness=half)
    for i in range(n):
        if i > 0:
            quat = [1.0, 0.0, 0.0, 0.0] if straight else rel[i - 1]
            body = body.add_body(name=body_name(i), pos=[l0, 0.0, 0.0], quat=quat)
            body.add_joint(name=f"{body_name(i)}_ball", type=mujoco.mjtJoint.mjJNT_BALL,
                           stiffness=[joint_stiffness(scene), 0.0, 0.0], **options)
        body.add_geom(name=f"{body_name(i)}_capsule", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                      fromto=[0.0, 0.0, 0.0, l0, 0.0, 0.0], size=[cable.radius, 0.0, 0.0], mass=cable.mass / n,
                      **geom)
        body.add_site(name=world.particle_site(order[i]))
    body.add_site(name=world.particle_site(order[n]), pos=[l0, 0.0, 0.0])
    add_last_clamp(body, scene, timestep=timestep, stiffness=half)

    add_pin_equalities(spec, scene, timestep=timestep, body_name=body_name, skip=tree_pin)
    if self_collision:
        world.exclude_overlapping(spec, scene, [body_name(i) for i in range(n)])
    if straight:  # the root is compiled in its start pose: identity root qpos, then the start shape's ball quats
        root = {"free": [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0], "ball": [1.0, 0.0, 0.0, 0.0], None: []}[kind]
        first, last = frame_clamps(scene)  # the clamps' half-segment joints start unbent
        identity = [1.0, 0.0, 0.0, 0.0]
        _add_start_key(spec, scene, np.concatenate([root, identity if first is not None else [], rel.ravel(),
                                                    identity if last is not None else []]))
    return snap.snap_spec(spec)


def _add_start_key(spec: mujoco.MjSpec, scene: Scene, qpos: np.ndarray) -> None:
    """Keyframe ``START_KEY`` with the cable's ``qpos`` and the grippers at their start positions, after a user
    world's own joints and mocap bodies (which come first in the model: their places here are filled with the
    world's start by :func:`mjcable.mjcf.world.finish`)."""
    start = scene.world.start_state() if scene.world is not None else None
    n_qpos, n_mocap = (len(start["qpos"]), len(start["mpos"])) if start is not None else (0, 0)
    mocap = [np.zeros(3)] * n_mocap + [scene.cable.particles[scene.pin_particle(k)] for k in scene.gripper_pins]
    key = spec.add_key(name=START_KEY, qpos=np.concatenate([np.zeros(n_qpos), qpos]))
    if mocap:
        key.mpos = np.concatenate(mocap)
        key.mquat = np.tile([1.0, 0.0, 0.0, 0.0], len(mocap))
