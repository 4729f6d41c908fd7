"""Energy drift of every model on the bench's ``energy`` scenario (an undamped chain swinging from a 20 cm mode-1
displacement, :mod:`mjcable.bench.scenarios`), at several substep counts: how much of the swing's energy
:meth:`mjcable.Simulator.energy` (kinetic + gravity + the model's own elastic energy) gains or loses.

Prints a Markdown table: the largest change over the run and the change at its end, both relative to the swing's
energy (:func:`mjcable.bench.scenarios.swing_energy`), sampled every ``--sample`` seconds, and the wall time.

    python scripts/bench_energy.py
    python scripts/bench_energy.py --models xpbd pbd --substeps 1 4 16 64 --seconds 10
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import mjcable
from mjcable.bench import case, scenarios

NATIVE_SUBSTEP_FACTORS = (1, 4)  # native models: their default substeps and 4 times as many
PARTICLE_SUBSTEPS = (1, 4, 16)


def drift(label: str, substeps: int, *, seconds: float, sample: float, dt: float = 0.002,
          n_segments: int = 50) -> dict:
    """``max`` and ``final`` change of the total energy relative to the swing energy, and ``wall`` seconds, of
    model ``label`` at ``substeps`` on the energy scenario."""
    model, settings = case.resolve(label)
    scenario = scenarios.get("energy")
    scene = scenario.make_scene(n_segments, {})
    swing = scenarios.swing_energy(scene)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = mjcable.Simulator(scene, model, dt=dt, **{**settings, "substeps": substeps})
    sim.step()  # compile (particle solvers) outside the timing
    sim.reset()
    energies = [sim.energy()]
    t0 = time.perf_counter()
    for _ in range(int(round(seconds / sample))):
        sim.step(sample)
        energies.append(sim.energy())
    wall = time.perf_counter() - t0
    change = (np.array(energies) - energies[0]) / swing
    return {"max": float(np.max(np.abs(change))), "final": float(change[-1]), "wall": wall}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=list(case.MODEL_LABELS), choices=list(case.MODEL_LABELS))
    parser.add_argument("--substeps", nargs="+", type=int, default=None,
                        help="particle models' substeps (default 1 4 16; native models: their default and 4x)")
    parser.add_argument("--seconds", type=float, default=scenarios.ENERGY_DURATION)
    parser.add_argument("--sample", type=float, default=0.02, help="seconds between energy samples")
    args = parser.parse_args()
    print(f"| model | substeps | largest change (of the swing energy) | change after {args.seconds:g} s | wall s |")
    print("|---|---|---|---|---|")
    for label in args.models:
        if case.family(label) == "native":
            default = int(case.settings_of(label).substeps)
            counts = [default * f for f in NATIVE_SUBSTEP_FACTORS]
        else:
            counts = args.substeps or list(PARTICLE_SUBSTEPS)
        for substeps in counts:
            r = drift(label, substeps, seconds=args.seconds, sample=args.sample)
            print(f"| {label} | {substeps} | {r['max']:.2g} | {r['final']:+.2g} | {r['wall']:.2f} |", flush=True)


if __name__ == "__main__":
    main()
