"""Several cables' cost (issue 22): four cables of 50 segments dropped side by side onto the ``table`` against one.

The ``table`` scene's wavy cable, its waves narrowed to a quarter across the table (y) so that four copies fit side by
side :data:`SPACING` apart, dropped onto the table; ``step(1.0)`` from the start on ``xpbd`` (defaults) for the four
together and for the first alone, alternated run by run, the best of ``--repeats`` each. The issue's bar is 4.5×.

    python scripts/bench_cables.py --repeats 5
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time
import warnings

import numpy as np

import mjcable

__all__ = ["scene", "measure", "SPACING", "NARROW"]

SPACING = 0.16  # m between the cables' middles across the table
NARROW = 0.25  # the table cable's waves across the table, scaled


def scene(n_cables: int, *, n_segments: int = 50) -> mjcable.Scene:
    """``n_cables`` copies of the ``table`` scene's cable (``n_segments`` each), their waves narrowed by
    :data:`NARROW` and set :data:`SPACING` apart across the table, centred, over its table and floor."""
    table = mjcable.scenes.get("table", n_segments=n_segments)
    points = np.asarray(table.cable.points, dtype=np.float64) * [1.0, NARROW, 1.0]
    offsets = (np.arange(n_cables) - 0.5 * (n_cables - 1)) * SPACING
    cables = [dataclasses.replace(table.cable, points=tuple(map(tuple, points + [0.0, dy, 0.0]))) for dy in offsets]
    return mjcable.Scene(cables if n_cables > 1 else cables[0], obstacles=table.obstacles, name=f"table_x{n_cables}")


def _step_time(sim_scene: mjcable.Scene, model: str) -> float:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = mjcable.Simulator(sim_scene, model)
    t0 = time.perf_counter()
    sim.step(1.0)
    return time.perf_counter() - t0


def measure(model: str = "xpbd", *, n_cables: int = 4, repeats: int = 3) -> dict:
    """``{"one": s, "several": s, "ratio": several / one}``: the best ``step(1.0)`` wall time of one cable and of
    ``n_cables``, alternated run by run after a warm-up of each (numba's compile left out)."""
    one, several = scene(1), scene(n_cables)
    for s in (one, several):
        _step_time(s, model)  # warm-up
    best = {"one": np.inf, "several": np.inf}
    for _ in range(repeats):
        best["one"] = min(best["one"], _step_time(one, model))
        best["several"] = min(best["several"], _step_time(several, model))
    return {**best, "ratio": best["several"] / best["one"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--model", default="xpbd")
    args = parser.parse_args()
    r = measure(args.model, repeats=args.repeats)
    print(f"| four `table` cables of 50 segments vs one, {args.model} (defaults): `step(1.0)` | "
          f"{r['several'] * 1e3:.2f} ms | {r['one'] * 1e3:.2f} ms | {r['ratio']:.2f}× | (load {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
