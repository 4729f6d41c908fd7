"""Measure the stability limit of the particle solvers' two-way contacts in a user world (mjcable.backends.host):
a cable (0.1 kg) lying on a box that a vertical spring (k = 200 N/m, damping 5 N·s/m) holds up, for box masses M
from 5 times the cable's down to a tenth of it. The contact is explicit in the box (immovable within a substep,
the reaction applied afterwards), so the relative normal velocity is multiplied by about −m / M every substep: the
pair settles for m / M < 1 and chatters beyond.

Prints a Markdown table: m / M, the box's sag against Hooke's (M + m) g / k, its standard deviation over the last
0.2 s and the largest gap between cable and box top in that window (a cable hopping on a light box).

    python scripts/bench_two_way_limit.py --model xpbd --substeps 4
"""

from __future__ import annotations

import argparse
import warnings

import mujoco
import numpy as np

from mjcable import CableSpec, Scene, Simulator

HALF, RADIUS, CABLE_MASS, K, G = 0.1, 0.005, 0.1, 200.0, 9.81


def measure(model: str, box_mass: float, substeps: int, seconds: float = 2.0) -> tuple:
    """(sag / Hooke's, std of sag (m), largest cable-box gap (m)) after ``seconds`` of settling."""
    xml = f"""<mujoco><worldbody>
      <body name="box" pos="0 0 {HALF}"><joint name="lift" type="slide" axis="0 0 1" stiffness="{K}" damping="5"/>
        <geom name="box" type="box" size="{HALF} {HALF} {HALF}" mass="{box_mass}"/></body></worldbody></mujoco>"""
    z = 2 * HALF + RADIUS
    cable = CableSpec([[-0.06, 0, z], [0.06, 0, z]], 12, RADIUS, CABLE_MASS)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulator(Scene(cable, (), world=mujoco.MjSpec.from_string(xml)), model, dt=0.002, substeps=substeps)
    sim.step(seconds)
    sag, gap = [], []
    for _ in range(100):
        sim.step()
        q = sim.mj_data.joint("lift").qpos[0]
        sag.append(-q)
        gap.append(float(sim.positions[:, 2].min()) - (2 * HALF + q + RADIUS))
    hooke = (box_mass + CABLE_MASS) * G / K
    return float(np.mean(sag)) / hooke, float(np.std(sag)), float(np.max(np.abs(gap)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="xpbd", choices=("xpbd", "pbd", "jakobsen"))
    parser.add_argument("--substeps", type=int, default=4)
    args = parser.parse_args()
    print(f"{args.model}, {args.substeps} substeps, cable {CABLE_MASS} kg\n")
    print("| m / M | sag / Hooke | sag std (m) | max gap (m) |\n|---|---|---|---|")
    for ratio in (0.2, 0.5, 0.8, 1.0, 1.25, 2.0, 5.0, 10.0):
        rel, std, gap = measure(args.model, CABLE_MASS / ratio, args.substeps)
        print(f"| {ratio:g} | {rel:.4f} | {std:.1e} | {gap:.1e} |")


if __name__ == "__main__":
    main()
