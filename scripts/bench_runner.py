"""The bench runs what users run: ``mjcable bench``'s wall time against a plain ``Simulator.step(T)``.

:func:`measure_bench_vs_step` times one bench case (:func:`mjcable.bench.runner.run_case`: its stepping wall time
per simulated second, the CSV's ``wall_per_sim_s``) and, side by side in the same process, ``Simulator.step(T)`` on
the same scene, model, dt and duration, each the best of ``repeats`` interleaved runs (numba compile time excluded:
the runner warms up untimed, and so does this script). Default case: ``xpbd`` on the catenary, 50 segments,
dt = 0.002 s, 3 simulated seconds (the full sweep's duration). The ratio is the bench's time over the plain step's.

Usage::

    python scripts/bench_runner.py [--repeats 5] [--model xpbd]
"""

from __future__ import annotations

import argparse
import os
import time

import mjcable
from mjcable.bench import case as case_mod
from mjcable.bench import scenarios
from mjcable.bench.case import Case
from mjcable.bench.runner import run_case

__all__ = ["measure_bench_vs_step"]


def _plain_step(case: Case, seconds: float) -> float:
    """Wall seconds of one ``Simulator.step(seconds)`` on ``case``'s scene, model and settings (build not timed)."""
    model, fixed = case_mod.resolve(case.model)
    scene = scenarios.get(case.scenario).make_scene(case.n_segments, dict(case.params))
    sim = mjcable.Simulator(scene, model, dt=case.dt, **{**fixed, **dict(case.settings)})
    t0 = time.perf_counter()
    sim.step(seconds)
    return time.perf_counter() - t0


def measure_bench_vs_step(*, model: str = "xpbd", scenario: str = "catenary", n_segments: int = 50,
                          dt: float = 0.002, repeats: int = 5) -> dict:
    """Time the bench's run of one case against ``Simulator.step(T)`` of the same case, best of ``repeats``.

    Args:
      model: a bench model label (:data:`mjcable.bench.case.MODEL_LABELS`), at its defaults.
      scenario: an accuracy scenario without a drive (its full duration ``T`` is stepped).
      n_segments: cable segments.
      dt: step in seconds.
      repeats: interleaved runs of each; the best (least disturbed) counts.

    Returns:
      ``{"case", "sim_seconds", "bench_wall_per_sim_s", "step_wall_per_sim_s", "ratio", "bench_runs",
      "step_runs", "load"}``: wall seconds per simulated second of each (best), their ratio (bench / step), every
      run's wall time per simulated second, and the 1-minute load average before and after.
    """
    case = Case(scenario, model, dt, n_segments=n_segments)
    seconds = float(scenarios.get(scenario).duration)
    load_before = os.getloadavg()[0]
    _plain_step(case, dt)  # compile or load numba's cache
    bench, step = [], []
    for _ in range(repeats):
        row = run_case(case)
        if row["outcome"] != "stable":
            raise RuntimeError(f"the bench case {case} did not run stably: {row['outcome']}: {row['reason']}")
        bench.append(float(row["wall_per_sim_s"]))
        step.append(_plain_step(case, seconds) / seconds)
    return {
        "case": f"{scenario}, {model}, {n_segments} segments, dt = {dt:g} s, {seconds:g} s simulated",
        "sim_seconds": seconds,
        "bench_wall_per_sim_s": min(bench),
        "step_wall_per_sim_s": min(step),
        "ratio": min(bench) / min(step),
        "bench_runs": bench,
        "step_runs": step,
        "load": (load_before, os.getloadavg()[0]),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--model", default="xpbd")
    args = parser.parse_args()
    r = measure_bench_vs_step(model=args.model, repeats=args.repeats)
    print(f"{r['case']}, best of {args.repeats}, load average {r['load'][0]:.2f} → {r['load'][1]:.2f}:")
    print(f"  mjcable bench (run_case): {r['bench_wall_per_sim_s']:.4g} s/s  "
          f"(runs: {', '.join(f'{v:.4g}' for v in r['bench_runs'])})")
    print(f"  Simulator.step(T):        {r['step_wall_per_sim_s']:.4g} s/s  "
          f"(runs: {', '.join(f'{v:.4g}' for v in r['step_runs'])})")
    print(f"  ratio bench / step:       {r['ratio']:.2f}x")


if __name__ == "__main__":
    main()
