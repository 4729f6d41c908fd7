"""``mjcable stress``: where each model breaks. Sweeps axial stiffness (to 1e9 N), dt (to 50 ms), n_segments (to
500), a gripper's speed (to 20 m/s), a heavy end load on a light cable, a cable falling onto a 4 mm plate at up
to 10 m/s (dt to 10 ms) and a knot pulled taut at up to 2 m/s per gripper (dt to 10 ms; ``tunneled``: a segment
through another or the knot undone); every run gets an ``outcome`` (``stable``, ``diverged``, ``tunneled``; see
:mod:`mjcable.bench.outcome`).

Outputs in ``--out`` (default ``stress_out``): ``stress.csv`` (one row per run, resumable),
``stability_<model>.png`` (per model: each family's parameter against dt, coloured by outcome) and ``stress.md``
(outcome counts and every failure's reason).
"""

from __future__ import annotations

import os
import platform
import time
from typing import List, Optional, Sequence

from mjcable.bench import case as case_mod
from mjcable.bench import plots, results, sweep
from mjcable.bench.case import Case
from mjcable.bench.outcome import OUTCOMES
from mjcable.io import atomic_write

__all__ = ["FAMILIES", "QUICK_FAMILIES", "FAMILY_DTS", "stress_cases", "run_stress", "cli_stress"]

# family → (parameter, full values); n_segments is the "segments" family's parameter. Quick values below.
FAMILIES = {
    "stiffness": ("stiffness", (1e2, 1e4, 1e6, 1e9)),
    "bending": ("young", (1e5, 1e7, 1e9, 1e11)),
    "segments": ("n_segments", (20, 100, 500)),
    "speed": ("speed", (1.0, 5.0, 20.0)),
    "load": ("load", (1.0, 10.0, 100.0, 1000.0)),
    "plate": ("speed", (2.0, 5.0, 10.0)),
    "knot": ("speed", (0.1, 0.5, 2.0)),
}
QUICK_FAMILIES = {
    "stiffness": (1e4, 1e9),
    "bending": (1e6, 1e10),
    "segments": (50, 500),
    "speed": (2.0, 20.0),
    "load": (1.0, 1000.0),
    "plate": (5.0, 10.0),
    "knot": (0.1, 2.0),
}
FULL_DTS = (0.001, 0.005, 0.02, 0.05)
QUICK_DTS = (0.002, 0.05)
# family → (full dts, quick dts) where a family has its own: the thin plate up to the 10 ms of issue 9
FAMILY_DTS = {
    "plate": ((0.001, 0.002, 0.005, 0.01), (0.002, 0.01)),
    "knot": ((0.001, 0.002, 0.005, 0.01), (0.002, 0.01)),
}
TIME_CAP_FULL = 120.0  # s wall time per run
TIME_CAP_QUICK = 25.0


def stress_cases(*, quick: bool, models: Optional[Sequence[str]] = None) -> List[Case]:
    """Every model label (default all) × family value × dt (:data:`FAMILY_DTS` where a family has its own), at
    the label's default settings."""
    cap = TIME_CAP_QUICK if quick else TIME_CAP_FULL
    out = []
    for model in case_mod.model_labels(models):
        for family, (param, full) in FAMILIES.items():
            values = QUICK_FAMILIES[family] if quick else full
            dts = FAMILY_DTS.get(family, (FULL_DTS, QUICK_DTS))[1 if quick else 0]
            for value in values:
                for dt in dts:
                    n = int(value) if param == "n_segments" else 50
                    params = () if param == "n_segments" else ((param, float(value)),)
                    out.append(Case(family, model, dt, n_segments=n, params=params, quick=quick, time_cap=cap))
    return out


def run_stress(out: str, *, quick: bool = False, jobs: int = 1, scheduler=None,
               models: Optional[Sequence[str]] = None, progress: bool = True) -> List[dict]:
    """Run (or resume) the stress sweep into ``out``; write the stability maps and ``stress.md``.

    ``jobs`` (local Dask worker processes; 1: in this process) and ``scheduler`` (an existing Dask cluster) are
    those of :func:`mjcable.bench.sweep.run_sweep`; this process writes every output.

    Returns:
      The latest row per run of ``stress.csv``.
    """
    models = case_mod.model_labels(models)
    os.makedirs(out, exist_ok=True)
    csv_path = os.path.join(out, "stress.csv")
    start = time.perf_counter()
    cases = stress_cases(quick=quick, models=models)
    sweep.run_sweep(cases, csv_path, jobs=jobs, scheduler=scheduler, desc="stress", progress=progress)
    wall = time.perf_counter() - start
    keys = {c.key for c in cases}  # the folder may hold other sweeps: report this one
    rows = [r for r in results.latest_rows(results.read_rows(csv_path)) if r["key"] in keys]
    for model in models:
        plots.stability_map(rows, model, os.path.join(out, f"stability_{model}.png"))

    md = [f"# mjcable stress{' --quick' if quick else ''}\n",
          f"Machine: {platform.machine()}, {os.cpu_count()} CPU(s); ran on "
          f"{sweep.describe_workers(jobs=jobs, scheduler=scheduler)}; this call took "
          f"{wall:.0f} s wall time. Families: stiffness (E·A in N, drape), segments (n_segments, table drop), "
          "speed (gripper yank in m/s), load (end mass / cable mass, hanging cable), plate (drop speed in m/s), knot "
          "(pull speed in m/s).\n",
          plots.outcome_markdown(rows)]
    with atomic_write(os.path.join(out, "stress.md")) as f:
        f.write("\n".join(md))
    return rows


def cli_stress(args) -> int:
    """Entry point of ``mjcable stress``: ``args`` has ``quick``, ``out`` and ``jobs`` (optional ``scheduler`` and
    ``models``)."""
    out = getattr(args, "out", None) or "stress_out"
    jobs, scheduler = sweep.workers_of(args)
    rows = run_stress(out, quick=bool(getattr(args, "quick", False)), jobs=jobs, scheduler=scheduler,
                      models=getattr(args, "models", None))
    counts = {o: sum(r["outcome"] == o for r in rows) for o in OUTCOMES}
    print(f"wrote {os.path.join(out, 'stress.csv')} ({len(rows)} runs: "
          + ", ".join(f"{v} {k}" for k, v in counts.items() if v) + "), stability maps and stress.md")
    return 0
