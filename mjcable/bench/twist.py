"""The twist family's scenes, gripper paths and errors (issue 21): rods with material frames against rod theory.

A straight rod (L = 1 m, r = 5 mm, E = 1e8 Pa, G = E / 3 unless the cable says otherwise, 0.05 kg, damping 30/s) in
a zero-gravity user world (``<option gravity="0 0 0"/>``), both ends clamped, the far end held by a gripper:

* ``torsion``: the gripper turned by φ = π about the rod's axis over :data:`TORSION_RAMP` s, then left to settle;
  error = |end torque / (G·J φ / L) − 1| (rod theory: a uniform twist, torque C φ / L).
* ``arc``: the gripper carried along a quarter circle (R = 2L/π) with the arc's tangent over :data:`ARC_SWEEP` s
  (longer than the rod's lowest period, so that it arrives near rest), then left to settle; error = the largest
  distance in metres of the centreline from the arc at the particles' arc lengths.
* ``greenhill``: the rod with a 1 mm bow to buckle from, clamped at particle n to a carriage
  (:data:`CARRIAGE`, a body of the user world on a frictionless slide along the axis: the end free to slide, the
  axial force zero by construction) whose hinge about the axis a position actuator turns at a constant rate, so that
  the rod's torque C φ / L grows to :data:`GREENHILL_END` M_c over :data:`GREENHILL_RAMP` s, M_c = 2.86 π B / L
  (Greenhill; Timoshenko & Gere); error = |M / M_c − 1| for the end torque M (at the world clamp) at which the rod's
  middle first leaves :data:`BUCKLED` of the axis (a rod that never does: the ramp's largest torque, a lower bound).
* ``curved_rest``: a quarter circle (R = 2L/π) with ``rest_shape="start"``, clamped at particle 0 by a gripper and
  held at its free end by a socket (:data:`SOCKET_FORCE`); the gripper pulls aside 1 mm a step until the socket lets
  the free end go (at most :data:`PULL_TIME` s), goes back, and the rod settles for the scenario's duration; error =
  the largest distance in metres from the start shape. A model without curved rest shapes is ``rejected`` with its
  ``ValueError``.

Only models with material frames can turn a gripper: :func:`require_frames` (the scenarios' setup) rejects the
others with their own ``ValueError`` (the runner records ``rejected``). ``scripts/bench_twist.py`` prints the arc's
end torque and force and the costs too.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from mjcable.scene import CableSpec, Pin, Scene

__all__ = ["TwistScene", "twist_scene", "greenhill_scene", "greenhill_setup", "greenhill_drive", "greenhill_error",
           "greenhill_critical", "greenhill_turn", "curved_scene", "curved_drive", "curved_error", "GREENHILL_RAMP",
           "GREENHILL_END", "CARRIAGE", "BUCKLED", "PULL_TIME", "SOCKET_FORCE", "torsion_path",
           "torsion_turns", "arc_path", "arc_turns", "torsion_error", "arc_error", "arc_point", "turn",
           "require_frames", "LENGTH", "RADIUS", "YOUNG", "START", "TORSION_ANGLE", "TORSION_RAMP", "ARC_SWEEP",
           "ARC_ANGLE"]

LENGTH, RADIUS, YOUNG, MASS, DAMPING = 1.0, 0.005, 1e8, 0.05, 30.0
START = np.array([0.0, 0.0, 0.5])
ZERO_G = '<mujoco><option gravity="0 0 0"/><worldbody/></mujoco>'
TORSION_ANGLE = math.pi  # rad, the gripper's turn
TORSION_RAMP = 0.08  # s over which the gripper turns
ARC_SWEEP = 1.0  # s over which the gripper travels the quarter circle
ARC_ANGLE = 0.5 * math.pi  # the arc's total turn: R = L / ARC_ANGLE
BOW = 1e-3  # m: the greenhill rod's start bow (a half sine), the imperfection it buckles from
GREENHILL_RAMP = 10.0  # s over which the twist grows to GREENHILL_END · M_c
GREENHILL_END = 1.2  # the ramp's end torque in units of M_c
CARRIAGE = "carriage"  # the greenhill rod's sliding end: its body, slide joint "slide", hinge "turn", actuator "twist"
CARRIAGE_WORLD = f"""<mujoco><option gravity="0 0 0"/><worldbody>
  <body name="{CARRIAGE}" pos="{START[0] + LENGTH} {START[1]} {START[2]}">
    <joint name="slide" type="slide" axis="1 0 0" damping="1"/>
    <joint name="turn" type="hinge" axis="1 0 0"/>
    <inertial pos="0 0 0" mass="0.05" diaginertia="1e-3 1e-3 1e-3"/>
  </body></worldbody>
  <actuator><position name="twist" joint="turn" kp="10" kv="0.04"/></actuator></mujoco>"""
BUCKLED = 5e-3  # m off the axis at the rod's middle: buckled (5 bows)
PULL_TIME = 0.2  # s: the curved rod's pull, 1 mm a step, stops at the latest here
SOCKET_FORCE = 0.05  # N: the curved rod's free end lets go above this pin force


@dataclasses.dataclass(frozen=True)
class TwistScene(Scene):
    """A twist-family scene with ``runs``: scratch of one benchmark run (its drive's record), not part of the
    scene."""

    runs: dict = dataclasses.field(default_factory=dict, kw_only=True, compare=False, repr=False)


def turn(axis, angle) -> np.ndarray:
    """The unit quaternion (w, x, y, z) of a turn by ``angle`` rad about ``axis``."""
    axis = np.asarray(axis, dtype=float)
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * axis / np.linalg.norm(axis)])


def arc_point(theta: float, s) -> np.ndarray:
    """The point(s) at arc length ``s`` (m, scalar or ``(k,)``) of the rod bent into a circular arc of total turn
    ``theta`` in the x-z plane, starting at :data:`START` along +x; ``(3,)`` or ``(k, 3)`` metres."""
    s = np.asarray(s, dtype=float)
    if theta == 0.0:
        offset = np.stack([s, np.zeros_like(s), np.zeros_like(s)], axis=-1)
    else:
        radius = LENGTH / theta
        offset = radius * np.stack([np.sin(s / radius), np.zeros_like(s), 1.0 - np.cos(s / radius)], axis=-1)
    return START + offset


def twist_scene(n_segments: int = 50, **fields) -> Scene:
    """The straight rod, clamped at particle 0 in the world and at particle n by a gripper, in zero gravity."""
    fields = {"young": YOUNG, "damping": DAMPING, **fields}
    cable = CableSpec([START, START + [LENGTH, 0.0, 0.0]], n_segments, RADIUS, MASS, **fields)
    return Scene(cable, pins=(Pin(0, clamp=True), Pin(-1, "gripper", clamp=True)),
                 world=mujoco.MjSpec.from_string(ZERO_G), name="twist")


def greenhill_scene(n_segments: int = 50) -> TwistScene:
    """The rod of :func:`twist_scene` with a :data:`BOW` half-sine bow in y, clamped at
    particle 0 in the world and at particle n to the sliding, turning :data:`CARRIAGE`."""
    s = np.linspace(0.0, LENGTH, 21)
    bow = START + np.stack([s, BOW * np.sin(math.pi * s / LENGTH), np.zeros_like(s)], axis=1)
    cable = CableSpec(bow, n_segments, RADIUS, MASS, young=YOUNG, damping=DAMPING)
    return TwistScene(cable, pins=(Pin(0, clamp=True), Pin(-1, "body", body=CARRIAGE, clamp=True)),
                      world=mujoco.MjSpec.from_string(CARRIAGE_WORLD), name="greenhill")


def greenhill_critical(cable: CableSpec) -> float:
    """M_c = 2.86 π B / L in N·m (Greenhill; Timoshenko & Gere, *Theory of Elastic Stability*, §2.19)."""
    return 2.86 * math.pi * cable.bending_stiffness / LENGTH


def greenhill_turn(sim, t: float) -> float:
    """The carriage's hinge angle in rad at ``t`` (s): the twist whose torque C φ / L, with the rod's own twist
    stiffness C (G·J, or ``joints``' stated E·I), grows to :data:`GREENHILL_END` M_c over :data:`GREENHILL_RAMP`."""
    cable = sim.scene.cable
    stiffness = cable.bending_stiffness if sim.model == "joints" else cable.torsion_stiffness
    return GREENHILL_END * greenhill_critical(cable) * LENGTH / stiffness * min(t / GREENHILL_RAMP, 1.0)


def greenhill_setup(sim, params: dict) -> None:
    """:func:`require_frames`, then start the drive's record in ``sim.scene.runs``."""
    require_frames(sim, params)
    sim.scene.runs.update(torque=[], offset=[])


def greenhill_drive(sim, t: float, params: dict) -> None:
    """Before the step at ``t`` (s): record the end torque at the world clamp and the middle's distance from the
    axis, and set the carriage's hinge to :func:`greenhill_turn` at ``t + dt``."""
    run = sim.scene.runs
    run["torque"].append(-float(sim.pin_torques[0, 0]))
    run["offset"].append(float(np.linalg.norm(sim.positions[sim.scene.cable.n_segments // 2, 1:] - START[1:])))
    sim.mj_data.ctrl[sim.mj_model.actuator("twist").id] = greenhill_turn(sim, t + sim.dt)


def greenhill_error(scene: TwistScene, x: np.ndarray, history: dict) -> float:
    """|M / M_c − 1| for the end torque M at which the middle first leaves :data:`BUCKLED` of the axis (never: the
    largest torque of the ramp, a lower bound of the error)."""
    torque, offset = np.array(scene.runs["torque"]), np.array(scene.runs["offset"])
    out = np.flatnonzero(offset > BUCKLED)
    measured = torque[out[0]] if len(out) else torque.max()
    return abs(measured / greenhill_critical(scene.cable) - 1.0)


def curved_scene(n_segments: int = 50) -> TwistScene:
    """The quarter circle (R = 2L/π, in the x-z plane from :data:`START` along +x) with ``rest_shape="start"``,
    clamped at particle 0 by a gripper, its free end held by a socket."""
    radius = LENGTH / ARC_ANGLE
    a = np.linspace(0.0, ARC_ANGLE, 60)
    points = START + radius * np.stack([np.sin(a), np.zeros_like(a), 1.0 - np.cos(a)], axis=1)
    cable = CableSpec(points, n_segments, RADIUS, MASS, young=YOUNG, damping=6.0, rest_shape="start")
    return TwistScene(cable, pins=(Pin(0, "gripper", clamp=True), Pin(-1, "socket", release_force=SOCKET_FORCE)),
                      world=mujoco.MjSpec.from_string(ZERO_G), name="curved_rest")


def curved_drive(sim, t: float, params: dict) -> None:
    """Before the step at ``t`` (s): the gripper 1 mm a step further aside (+y) until the socket has let go or
    :data:`PULL_TIME` has passed, then back at its start."""
    start = np.asarray(sim.scene.cable.particles[0])
    pulling = not sim.released and t < PULL_TIME
    sim.move_gripper(0, start + [0.0, 1e-3 * (round(t / sim.dt) + 1) if pulling else 0.0, 0.0])


def curved_error(scene: TwistScene, x: np.ndarray, history: dict) -> float:
    """The largest distance in metres of the particles from their start (rest) positions."""
    return float(np.linalg.norm(x - np.asarray(scene.cable.particles), axis=1).max())


def require_frames(sim, params: dict) -> None:
    """The scenarios' setup: a model without material frames raises its ``ValueError`` (it cannot turn a gripper)."""
    sim.frames


def _done(times: np.ndarray, duration: float) -> np.ndarray:
    """``(steps,)`` fraction in [0, 1] of a drive over ``duration`` s done at ``times`` (s)."""
    return np.clip(np.asarray(times, dtype=float) / duration, 0.0, 1.0)


def torsion_path(scene: Scene, times: np.ndarray, params: dict) -> np.ndarray:
    """``(steps, 1, 3)``: the gripper stays at the rod's end."""
    end = scene.cable.particles[-1]
    return np.tile(end, (len(times), 1, 1))


def torsion_turns(scene: Scene, times: np.ndarray, params: dict) -> np.ndarray:
    """``(steps, 1, 4)``: the gripper's turn about the rod's axis at ``times`` (s), growing to
    :data:`TORSION_ANGLE` over :data:`TORSION_RAMP` s."""
    done = _done(times, TORSION_RAMP)
    return np.array([turn([1.0, 0.0, 0.0], TORSION_ANGLE * f) for f in done])[:, None, :]


def arc_path(scene: Scene, times: np.ndarray, params: dict) -> np.ndarray:
    """``(steps, 1, 3)``: the gripper at ``times`` (s) on the end of arcs of growing turn, a quarter circle after
    :data:`ARC_SWEEP` s."""
    done = _done(times, ARC_SWEEP)
    return np.array([arc_point(ARC_ANGLE * f, LENGTH) for f in done])[:, None, :]


def arc_turns(scene: Scene, times: np.ndarray, params: dict) -> np.ndarray:
    """``(steps, 1, 4)``: the gripper at ``times`` (s) turned with the arc's end tangent (about −y)."""
    done = _done(times, ARC_SWEEP)
    return np.array([turn([0.0, -1.0, 0.0], ARC_ANGLE * f) for f in done])[:, None, :]


def torsion_error(scene: Scene, x: np.ndarray, history: dict) -> float:
    """|axial end torque at the gripper / (G·J φ / L) − 1| (``history["pin_torques"]``, N·m)."""
    cable = scene.cable
    return abs(float(history["pin_torques"][1, 0]) / (cable.torsion_stiffness * TORSION_ANGLE / LENGTH) - 1.0)


def arc_error(scene: Scene, x: np.ndarray, history: dict) -> float:
    """The largest distance in metres of the particles from the quarter circle at their arc lengths."""
    s = np.arange(scene.cable.n_particles) * scene.cable.segment_length
    return float(np.linalg.norm(x - arc_point(ARC_ANGLE, s), axis=1).max())
