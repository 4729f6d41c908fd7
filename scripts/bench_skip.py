"""Measure what skipping unneeded work saves: the hang scene without obstacles, with an unused floor (never touched,
so contact detection runs for nothing) and, for MuJoCo's native models, with the collision pipeline disabled.

Runs in this process, variants interleaved, and keeps the fastest of ``--repeats`` timings of each (the one least
disturbed by other processes). Prints a Markdown table of wall time per simulated second.

    python scripts/bench_skip.py --repeats 5 --seconds 2
"""

from __future__ import annotations

import argparse
import dataclasses
import time
import warnings

import mujoco
import numpy as np

import mjcable
from mjcable.bench import case, scenarios

VARIANTS = ("none", "unused_floor", "contact_off")


def _simulator(label: str, variant: str, n_segments: int, dt: float):
    model, settings = case.resolve(label)  # the label's fixed settings, the model's defaults otherwise
    scene = mjcable.scenes.get("hang", n_segments=n_segments, damping=scenarios.DAMPING_CATENARY)
    if variant == "unused_floor":
        scene = dataclasses.replace(scene, obstacles=(mjcable.Floor(pos=(0.0, 0.0, scenarios.UNUSED_FLOOR_HEIGHT)),))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = mjcable.Simulator(scene, model, dt=dt, **settings)
    if variant == "contact_off":
        sim.mj_model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    return sim


def _time(label: str, variant: str, n_segments: int, dt: float, seconds: float) -> float:
    sim = _simulator(label, variant, n_segments, dt)
    sim.step()  # compile / load caches outside the timing
    t0 = time.perf_counter()
    sim.step(seconds)
    return (time.perf_counter() - t0) / seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seconds", type=float, default=2.0, help="simulated seconds per timing")
    parser.add_argument("--n-segments", type=int, default=50)
    parser.add_argument("--dt", type=float, default=0.002)
    parser.add_argument("--models", nargs="+", default=list(case.MODEL_LABELS), choices=list(case.MODEL_LABELS))
    args = parser.parse_args()
    print(f"hang, n_segments={args.n_segments}, dt={args.dt}, {args.seconds} s simulated, fastest of "
          f"{args.repeats}; wall s per simulated s\n")
    print("| model | no obstacles | unused floor | collision off | no obstacles vs unused floor |")
    print("|---|---|---|---|---|")
    for label in args.models:
        variants = VARIANTS if case.family(label) == "native" else VARIANTS[:2]
        best = {v: np.inf for v in variants}
        for _ in range(args.repeats):
            for v in variants:
                best[v] = min(best[v], _time(label, v, args.n_segments, args.dt, args.seconds))
        off = f"{best['contact_off']:.4g}" if "contact_off" in best else "–"
        saving = 1.0 - best["none"] / best["unused_floor"]
        print(f"| {label} | {best['none']:.4g} | {best['unused_floor']:.4g} | {off} | {saving:+.0%} |", flush=True)


if __name__ == "__main__":
    main()
