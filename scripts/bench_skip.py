"""Measure what skipping unneeded work saves.

* Obstacles never touched: the hang scene without obstacles, with an unused floor (never touched, so contact
  detection runs for nothing) and, for MuJoCo's native models, with the collision pipeline disabled.
* A cable at rest (issue 18, item 6): ``table`` with the cable lying still on the table against the same cable
  hanging free (``hang``), ``step(1.0)`` each, measured side by side (:func:`measure`): the particle solvers repeat
  a contact query only when a particle has moved enough to change it (``ParticleSettings.query_slack``).

Runs in this process, variants interleaved, and keeps the fastest of ``--repeats`` timings of each (the one least
disturbed by other processes). Prints Markdown tables of wall time per simulated second.

    python scripts/bench_skip.py --repeats 5 --seconds 2
    python scripts/bench_skip.py --only rest --rest-segments 200
"""

from __future__ import annotations

import argparse
import dataclasses
import os
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


def _settled(scene_name: str, model: str, n_segments: int, settle: float, settings: dict) -> mjcable.Simulator:
    """A simulator of ``scene_name`` stepped ``settle`` seconds (the table's cable has fallen and come to rest)."""
    overrides = {"damping": scenarios.DAMPING_CATENARY} if scene_name == "hang" else {}
    scene = mjcable.scenes.get(scene_name, n_segments=n_segments, **overrides)
    sim = mjcable.Simulator(scene, model, **settings)
    sim.step(settle)
    return sim


def measure(*, model: str = "xpbd", n_segments: int = 200, seconds: float = 1.0, settle: float = 3.0,
            repeats: int = 3, **settings) -> dict:
    """``step(seconds)`` of a cable at rest on the table against the same cable hanging free, side by side.

    Both simulators first take ``settle`` simulated seconds (untimed: the table's cable falls onto the table and
    comes to rest; numba compiles), then ``step(seconds)`` alternates between them ``repeats`` times; each keeps its
    fastest timing (the least disturbed by other processes).

    Args:
      model: a particle model (``jakobsen``, ``pbd``, ``xpbd``); ``settings`` its settings (defaults otherwise).
      n_segments: segments of both cables.
      seconds, settle: simulated seconds timed per repeat and stepped before timing.
      repeats: timings of each scene.

    Returns:
      ``table_s``, ``hang_s``: wall seconds of one ``step(seconds)``; ``ratio``: ``table_s / hang_s`` (issue 18's
      bar is 1.5); ``queries_per_step``: MuJoCo collision queries per step of the table's timed steps;
      ``contacts``: the table's contacts after them; ``load``: the 1-minute load average when done.
    """
    sims = {name: _settled(name, model, n_segments, settle, settings) for name in ("table", "hang")}
    best = {name: float("inf") for name in sims}
    table = sims["table"]
    queries0, steps0 = table.diagnostics["queries"], table.steps
    for _ in range(repeats):
        for name, sim in sims.items():
            t0 = time.perf_counter()
            sim.step(seconds)
            best[name] = min(best[name], time.perf_counter() - t0)
    diag = table.diagnostics
    return {"model": model, "n_segments": n_segments, "table_s": best["table"], "hang_s": best["hang"],
            "ratio": best["table"] / best["hang"], "queries_per_step": (diag["queries"] - queries0) /
            max(table.steps - steps0, 1), "contacts": diag["contacts"], "load": os.getloadavg()[0]}


def _print_rest(args) -> None:
    print(f"\ncable at rest: table vs hang, n_segments={args.rest_segments}, step({args.rest_seconds}), settled "
          f"{args.settle} s, fastest of {args.repeats}; wall s\n")
    print("| model | table (at rest) | hang | table / hang | queries per step | contacts | load |")
    print("|---|---|---|---|---|---|---|")
    for label in args.rest_models:
        model, settings = case.resolve(label)
        r = measure(model=model, n_segments=args.rest_segments, seconds=args.rest_seconds, settle=args.settle,
                    repeats=args.repeats, **settings)
        print(f"| {label} | {r['table_s']:.4g} | {r['hang_s']:.4g} | {r['ratio']:.2f} | {r['queries_per_step']:.3g} "
              f"| {r['contacts']} | {r['load']:.2f} |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seconds", type=float, default=2.0, help="simulated seconds per timing")
    parser.add_argument("--n-segments", type=int, default=50)
    parser.add_argument("--dt", type=float, default=0.002)
    parser.add_argument("--models", nargs="+", default=list(case.MODEL_LABELS), choices=list(case.MODEL_LABELS))
    parser.add_argument("--only", choices=("unused", "rest"), help="run one of the two measurements")
    parser.add_argument("--rest-segments", type=int, default=200, help="segments of the cable at rest")
    parser.add_argument("--rest-seconds", type=float, default=1.0, help="simulated seconds per rest timing")
    parser.add_argument("--settle", type=float, default=3.0, help="simulated seconds before the rest timings")
    parser.add_argument("--rest-models", nargs="+", default=["xpbd"],
                        choices=[m for m in case.MODEL_LABELS if case.family(m) == "particle"])
    args = parser.parse_args()
    if args.only != "unused":
        _print_rest(args)
    if args.only == "rest":
        return
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
