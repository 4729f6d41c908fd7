"""The twist family: every model with material frames against rod theory, and what it costs (issue 21).

A straight rod (L = 1 m, r = 5 mm, E = 1e8 Pa, G = E / 3, 0.05 kg, damping 30/s) in a zero-gravity user world, both
ends clamped, the far end held by a gripper:

* torsion: the gripper turned by φ = π about the rod's axis over 0.08 s, then 1.5 s to settle; error = |end torque /
  (G·J φ / L) − 1| (rod theory: a uniform twist, torque C φ / L);
* arc: the gripper carried along a quarter circle (R = 2L/π) with the arc's tangent over 1 s, then 1 s; errors =
  the largest distance of the centreline from the arc (m), |end torque / (E·I / R) − 1| and the end force over
  E·I / R² (rod theory: none);

The scene and paths are :mod:`mjcable.bench.twist`'s, whose ``torsion`` and ``arc`` scenarios run in ``mjcable bench``
(one error each). (A curved rest shape only ``cosserat`` takes: ``tests/test_cosserat.py`` holds it to 0.1 mm.)

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

import numpy as np

import mjcable
from mjcable import catalog
from mjcable.bench.twist import ARC_ANGLE, LENGTH as L, RADIUS, YOUNG, arc_point, turn, twist_scene

PHI = math.pi


def _simulator(model: str, n: int, settings: dict) -> mjcable.Simulator:
    return mjcable.Simulator(twist_scene(n), model, **settings)


def torsion(model: str, n: int, settings: dict) -> dict:
    sim = _simulator(model, n, settings)
    end = sim.gripper_positions[0]
    t0 = time.perf_counter()
    for j in range(1, 41):
        sim.move_gripper(1, end, turn([1, 0, 0], PHI * j / 40))
        sim.step()
    sim.step(1.5)
    wall = (time.perf_counter() - t0) / sim.time
    cable = sim.scene.cable
    return {"error": abs(sim.pin_torques[1, 0] / (cable.torsion_stiffness * PHI / L) - 1.0), "cost": wall}


def arc(model: str, n: int, settings: dict) -> dict:
    sim = _simulator(model, n, settings)
    steps = round(1.0 / sim.dt)
    for j in range(1, steps + 1):
        theta = ARC_ANGLE * j / steps
        sim.move_gripper(1, arc_point(theta, L), turn([0, -1, 0], theta))
        sim.step()
    sim.step(1.0)
    cable = sim.scene.cable
    radius = L / ARC_ANGLE
    shape = arc_point(ARC_ANGLE, np.arange(n + 1) * cable.segment_length)
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
