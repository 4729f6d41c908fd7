"""Print the benchmark's reference values and the error floor that discretisation alone puts under each scenario.

The floors are what a perfect solver of the discrete (lumped-mass, n-segment) cable would still score against the
continuous reference: no model can beat them at that n_segments.

    python scripts/bench_references.py --n-segments 50
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from mjcable import reference, scenes
from mjcable.bench import scenarios


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-segments", type=int, nargs="+", default=[20, 50, 100])
    args = parser.parse_args()

    print("| scenario | reference | value | n_segments | discretisation floor (same error measure) |")
    print("|---|---|---|---|---|")
    for n in args.n_segments:
        hang = scenes.get("hang", n_segments=n).cable
        start, end = hang.particles[0], hang.particles[-1]
        c = reference.catenary(start, end, hang.length)
        chain = reference.discrete_catenary(start, end, hang.length, n, hang.particle_masses)
        floor = float(np.sqrt(np.mean(reference.distance_to_curve(chain, c) ** 2)))
        print(f"| catenary | sag (m) | {c.sag:.6f} | {n} | RMS distance {floor:.2e} m |")

        scene = scenarios.chain_scene(n)
        omega = reference.chain_frequency(scene.cable.length)
        discrete = reference.discrete_chain_frequencies(scene.cable.particle_masses, scene.cable.length)[0]
        print(f"| chain | ω₁ (rad/s), period (s) | {omega:.6f}, {2 * math.pi / omega:.6f} | {n} | "
              f"relative {abs(discrete / omega - 1):.2e} (lumped masses, rigid links) |")

        cable = scenarios.cantilever_scene(n).cable
        q = cable.linear_density * reference.G
        shape = reference.cantilever(cable.length, q, cable.bending_stiffness)
        beam = reference.beam_tip_deflection(cable.length, q, cable.bending_stiffness)
        print(f"| cantilever | q L³/EI, tip deflection (m), beam theory (m) | {shape.load:.4f}, "
              f"{shape.tip_deflection:.6f}, {beam:.6f} | {n} | – |")
    print()
    print("table: ideal rest = the start shape lowered onto the table top (exact for a uniform fall with sticking "
          "friction); drape: two vertical strands over the peg (exact for a limp cable at rest).")


if __name__ == "__main__":
    main()
