"""Cost against chain length: wall seconds per simulated second of ``hang`` on ``xpbd`` (its defaults: the direct
order, 4 substeps of 1 iteration, dt = 2 ms) for several segment counts.

The direct order solves the whole chain as one banded system, O(n) per solve; with its safeguard accepting one
solve per substep the cost is linear in n, so the 1600/400 ratio should be near 4.

Every time is the best of ``repeats`` runs of ``Simulator.step(seconds)`` on a fresh simulator after a warm-up step
(numba compile time excluded; kernels cached on disk). The machine may be shared: the table states the load.

Usage::

    python scripts/bench_length.py [--repeats 3] [--ns 50 400 800 1600] [--model cosserat]

From another script in this folder::

    import bench_length
    times = bench_length.measure(ns=(50, 400), repeats=3)  # {50: s/s, 400: s/s}
"""

from __future__ import annotations

import argparse
import math
import os
import time
import warnings

import mjcable

MODEL = "xpbd"
SCENE = "hang"
WARM_UP = 0.02  # s simulated before timing: compiles or loads the kernels and leaves the start transient
SECONDS = 0.5  # s simulated per timed run (250 steps at the default dt)


def _seconds_per_second(n: int, seconds: float, settings: dict, model: str = MODEL) -> float:
    with warnings.catch_warnings():  # fine chains warn that the default radius exceeds a segment: no contacts here
        warnings.simplefilter("ignore", UserWarning)
        scene = mjcable.scenes.get(SCENE, n_segments=n)
    sim = mjcable.Simulator(scene, model, **settings)
    sim.step(WARM_UP)
    start = time.perf_counter()
    sim.step(seconds)
    return (time.perf_counter() - start) / seconds


def measure(ns=(50, 400, 800, 1600), repeats: int = 3, *, seconds: float = SECONDS, model: str = MODEL,
            **settings) -> dict:
    """Wall seconds per simulated second of ``hang`` with ``n`` segments on ``model`` (default ``xpbd``; its
    defaults), best of ``repeats``.

    Args:
        ns: segment counts.
        repeats: timed runs per count (each on a fresh simulator); the best is kept.
        seconds: simulated seconds per timed run.
        model: the particle model (a catalogue name).
        **settings: :class:`mjcable.Simulator` settings replacing the model's defaults (e.g. ``substeps=16``).

    Returns:
        ``{n: wall seconds per simulated second}`` in the order of ``ns``.
    """
    ns = tuple(int(n) for n in ns)
    if not ns or min(ns) < 1:
        raise ValueError(f"ns must be positive segment counts, got {ns}")
    if repeats < 1:
        raise ValueError(f"repeats must be at least 1, got {repeats}")
    return {n: min(_seconds_per_second(n, seconds, settings, model) for _ in range(repeats)) for n in ns}


def table(times: dict) -> str:
    """A markdown table of :func:`measure`'s result, with each count's exponent against the previous one and the
    1600/400 ratio (when both were measured)."""
    lines = ["| segments | wall s / simulated s | exponent vs previous |", "|---:|---:|---:|"]
    previous = None
    for n, t in times.items():
        exponent = "" if previous is None else f"{math.log(t / previous[1]) / math.log(n / previous[0]):.2f}"
        lines.append(f"| {n} | {t:.4f} | {exponent} |")
        previous = (n, t)
    if 400 in times and 1600 in times:
        lines.append(f"\n1600/400 ratio: {times[1600] / times[400]:.2f} (linear: 4)")
    lines.append(f"\nload average: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--ns", type=int, nargs="+", default=[50, 400, 800, 1600])
    parser.add_argument("--substeps", type=int, default=None, help="replace the model's default substeps")
    parser.add_argument("--model", default=MODEL, help=f"the particle model (default {MODEL})")
    args = parser.parse_args()
    settings = {} if args.substeps is None else {"substeps": args.substeps}
    print(table(measure(args.ns, args.repeats, model=args.model, **settings)))


if __name__ == "__main__":
    main()
