"""The twist family's scenes, gripper paths and errors (issue 21): rods with material frames against rod theory.

A straight rod (L = 1 m, r = 5 mm, E = 1e8 Pa, G = E / 3 unless the cable says otherwise, 0.05 kg, damping 30/s) in
a zero-gravity user world (``<option gravity="0 0 0"/>``), both ends clamped, the far end held by a gripper:

* ``torsion``: the gripper turned by φ = π about the rod's axis over :data:`TORSION_RAMP` s, then left to settle;
  error = |end torque / (G·J φ / L) − 1| (rod theory: a uniform twist, torque C φ / L).
* ``arc``: the gripper carried along a quarter circle (R = 2L/π) with the arc's tangent over :data:`ARC_SWEEP` s
  (longer than the rod's lowest period, so that it arrives near rest), then left to settle; error = the largest
  distance in metres of the centreline from the arc at the particles' arc lengths.

Only models with material frames can turn a gripper: :func:`require_frames` (the scenarios' setup) rejects the
others with their own ``ValueError`` (the runner records ``rejected``). ``scripts/bench_twist.py`` prints the arc's
end torque and force and the costs too.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from mjcable.scene import CableSpec, Pin, Scene

__all__ = ["twist_scene", "torsion_path", "torsion_turns", "arc_path", "arc_turns", "torsion_error", "arc_error",
           "arc_point", "turn", "require_frames", "LENGTH", "RADIUS", "YOUNG", "START", "TORSION_ANGLE", "TORSION_RAMP",
           "ARC_SWEEP", "ARC_ANGLE"]

LENGTH, RADIUS, YOUNG, MASS, DAMPING = 1.0, 0.005, 1e8, 0.05, 30.0
START = np.array([0.0, 0.0, 0.5])
ZERO_G = '<mujoco><option gravity="0 0 0"/><worldbody/></mujoco>'
TORSION_ANGLE = math.pi  # rad, the gripper's turn
TORSION_RAMP = 0.08  # s over which the gripper turns
ARC_SWEEP = 1.0  # s over which the gripper travels the quarter circle
ARC_ANGLE = 0.5 * math.pi  # the arc's total turn: R = L / ARC_ANGLE


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
