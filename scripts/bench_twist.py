"""The twist family: every model with material frames against rod theory, and what it costs (issue 21).

A straight rod (L = 1 m, r = 5 mm, E = 1e8 Pa, G = E / 3, 0.05 kg, damping 30/s) in a zero-gravity user world, both
ends clamped, the far end held by a gripper:

* torsion: the gripper turned by φ = π about the rod's axis over 0.08 s, then 1.5 s to settle; error = |end torque /
  (G·J φ / L) − 1| (rod theory: a uniform twist, torque C φ / L);
* arc: the gripper carried along a quarter circle (R = 2L/π) with the arc's tangent over 1 s, then 1 s; errors =
  the largest distance of the centreline from the arc (m), |end torque / (E·I / R) − 1| and the end force over
  E·I / R² (rod theory: none);

(A curved rest shape only ``cosserat`` takes: ``tests/test_cosserat.py`` holds it to 0.1 mm.)

Cost: wall seconds per simulated second of the torsion run (after a first step that compiles). Models without frames
(``springs``, ``flexrod``, ``jakobsen``, ``pbd``, ``xpbd``) have no twist; they are listed as such. Every model runs
at its default settings (``--native-substeps`` for the native ones' substeps).

    python scripts/bench_twist.py
    python scripts/bench_twist.py --segments 50 100 --models cosserat joints
"""

from __future__ import annotations

import argparse
import math
import os
import time
import warnings

import mujoco
import numpy as np

import mjcable
from mjcable import CableSpec, Pin, Scene, catalog

ZERO_G = '<mujoco><option gravity="0 0 0"/><worldbody/></mujoco>'
START = np.array([0.0, 0.0, 0.5])
L, RADIUS, YOUNG, MASS, DAMPING = 1.0, 0.005, 1e8, 0.05, 30.0
PHI = math.pi


def _turn(axis, angle) -> np.ndarray:
    axis = np.asarray(axis, dtype=float)
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * axis / np.linalg.norm(axis)])


def _arc_point(theta: float, s: float) -> np.ndarray:
    if theta == 0.0:
        return START + [s, 0.0, 0.0]
    radius = L / theta
    return START + radius * np.array([math.sin(s / radius), 0.0, 1.0 - math.cos(s / radius)])


def _simulator(model: str, n: int, settings: dict, **fields) -> mjcable.Simulator:
    cable = CableSpec([START, START + [L, 0, 0]], n, RADIUS, MASS, young=YOUNG, damping=DAMPING, **fields)
    scene = Scene(cable, pins=(Pin(0, clamp=True), Pin(-1, "gripper", clamp=True)),
                  world=mujoco.MjSpec.from_string(ZERO_G))
    return mjcable.Simulator(scene, model, **settings)


def torsion(model: str, n: int, settings: dict) -> dict:
    sim = _simulator(model, n, settings)
    end = sim.gripper_positions[0]
    t0 = time.perf_counter()
    for j in range(1, 41):
        sim.move_gripper(1, end, _turn([1, 0, 0], PHI * j / 40))
        sim.step()
    sim.step(1.5)
    wall = (time.perf_counter() - t0) / sim.time
    cable = sim.scene.cable
    return {"error": abs(sim.pin_torques[1, 0] / (cable.torsion_stiffness * PHI / L) - 1.0), "cost": wall}


def arc(model: str, n: int, settings: dict) -> dict:
    sim = _simulator(model, n, settings)
    steps = round(1.0 / sim.dt)
    for j in range(1, steps + 1):
        theta = 0.5 * math.pi * j / steps
        sim.move_gripper(1, _arc_point(theta, L), _turn([0, -1, 0], theta))
        sim.step()
    sim.step(1.0)
    cable = sim.scene.cable
    radius = 2 * L / math.pi
    s = np.arange(n + 1) * cable.segment_length
    shape = np.array([_arc_point(0.5 * math.pi, si) for si in s])
    b = cable.bending_stiffness
    return {"distance": float(np.linalg.norm(sim.positions - shape, axis=1).max()),
            "torque": float(np.abs(np.linalg.norm(sim.pin_torques, axis=1) / (b / radius) - 1.0).max()),
            "force": float(np.linalg.norm(sim.pin_forces, axis=1).max() / (b / radius**2))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--segments", type=int, nargs="+", default=[50, 100])
    parser.add_argument("--models", nargs="+", default=list(catalog.names()))
    parser.add_argument("--native-substeps", type=int, default=None)
    args = parser.parse_args()
    print(f"twist family, zero gravity, L = {L} m, r = {RADIUS} m, E = {YOUNG:g} Pa, G = E/3; load "
          f"{os.getloadavg()[0]:.1f}\n")
    print("| model | N | torsion: torque error | arc: distance (m) | arc: torque error | arc: force / (B/R²) | "
          "cost (wall s / s) |")
    print("|---|---|---|---|---|---|---|")
    for model in args.models:
        entry = catalog.get(model)
        if not entry.frames:
            print(f"| {model} | – | no twist (no material frames) | | | | |")
            continue
        native = entry.family == "native" and args.native_substeps is not None
        settings = {"substeps": args.native_substeps} if native else {}
        for n in args.segments:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                t, a = torsion(model, n, settings), arc(model, n, settings)
            print(f"| {model} | {n} | {t['error']:.2%} | {a['distance']:.2g} | {a['torque']:.2%} | "
                  f"{a['force']:.2%} | {t['cost']:.3g} |", flush=True)


if __name__ == "__main__":
    main()
