"""``mjcable bench``: every model on every accuracy scenario, the stiffness-effect grid, the skip rows and the
convergence of the contact scenes' references; CSV, work-precision PNGs and Markdown.

Outputs in ``--out`` (default ``bench_out``):

* ``bench.csv``: one row per run (columns :data:`mjcable.bench.results.COLUMNS`), appended as runs finish; a
  re-run resumes by skipping the runs already there;
* ``work_precision_<scenario>.png``: error against wall time per simulated second, one line per model (the
  catenary's includes the equal-error grid, :func:`cost_cases`: n_segments, dt and substeps);
* ``pareto.md``: each model's Pareto front per scenario, the cost at equal error (each model's cheapest catenary
  run within :data:`COST_TARGET`), the stiffness-effect table, the skip rows, the convergence table and every
  failed run's reason;
* ``stiffness_grid.png``: the thesis's stiffness-effect grid (iterations {1, 12, 25} × dt {0.02, 0.002, 0.0002})
  for every particle model's label: the cable's shape at t = 0.25 s.
"""

from __future__ import annotations

import itertools
import json
import math
import os
import platform
import time
from typing import List, Optional, Sequence

import numpy as np

from mjcable import reference
from mjcable.bench import case as case_mod
from mjcable.bench import plots, results, scenarios, sweep
from mjcable.bench.case import Case
from mjcable.bench.outcome import OUTCOMES
from mjcable.io import atomic_write

__all__ = [
    "STIFFNESS_ITERATIONS",
    "STIFFNESS_DTS",
    "accuracy_cases",
    "stiffness_cases",
    "skip_cases",
    "convergence_cases",
    "cost_cases",
    "COST_TARGET",
    "run_bench",
    "write_reports",
    "cli_bench",
]

QUICK_SCENARIOS = ("catenary", "chain", "table")
STIFFNESS_ITERATIONS = (1, 12, 25)
STIFFNESS_DTS = (0.02, 0.002, 0.0002)
FULL_DTS_NATIVE = (0.01, 0.005, 0.002, 0.001, 0.0005)
FULL_DTS_PARTICLE = (0.01, 0.005, 0.002, 0.001)
QUICK_DTS = (0.005, 0.002)
NATIVE_SUBSTEP_FACTOR = 4  # native models: substeps 1, the default d and 4 d
NATIVE_MIN_STEP = 5e-4  # s: finest MuJoCo step swept at one default substep (d substeps: NATIVE_MIN_STEP / d)
PARTICLE_SETTINGS = ((1, 1), (1, 4), (1, 16), (4, 1), (4, 4), (16, 1))  # (substeps, iterations)
DIRECT_SETTINGS = ((1, 1), (4, 1), (16, 1))  # the direct order converges the stretch chain in one iteration
SEGMENT_COUNTS = (20, 100)  # besides the default 50, at dt = 0.002 with the default settings
CONVERGENCE_SCENARIOS = ("table", "drape")
SET_ERROR_SCENARIOS = ("drape",)  # errors measured to a curve, not particle by particle
CONVERGENCE_DT = 0.001  # the finest dt of the convergence check; its half is run too
TIME_CAP_BENCH = 600.0  # s of wall time per run (joints and composite cost ~1 ms per MuJoCo step)
TIME_CAP_QUICK = 40.0
_AT_REFERENCE = 1e-9  # m: errors this small are round-off, not a convergence question
COST_SCENARIO = "catenary"  # the equal-error table's scene
COST_TARGET = 1e-4  # m RMS: the error every model is asked to reach at its lowest cost
COST_SEGMENTS = (25, 50, 100, 200)
COST_DTS = (0.005, 0.002, 0.001)
COST_PARTICLE_SUBSTEPS = (1, 4, 16)  # one iteration each: substeps, not iterations (*Small Steps*)
TIME_CAP_COST = 30.0  # s of wall time: a run over it costs > 15 s/s (2 s simulated), never the cheapest here


def _particle(iterations: int, substeps: int) -> tuple:
    return (("iterations", iterations), ("substeps", substeps))


def _direct(label: str) -> bool:
    """Whether ``label`` runs the direct order (which converges the stretch chain in one iteration)."""
    return getattr(case_mod.settings_of(label), "order", None) == "direct"


def _settings_grid(label: str, quick: bool) -> List[tuple]:
    """The ``(dt, settings)`` points of one label's sweep: ``--quick``, its defaults at :data:`QUICK_DTS`; else,
    native models substeps 1, d and 4 d (d: the default; MuJoCo's step no finer than :data:`NATIVE_MIN_STEP` / d),
    particle models the (substeps, iterations) grid (:data:`DIRECT_SETTINGS` for the direct order)."""
    if quick:
        return [(dt, ()) for dt in QUICK_DTS]
    if case_mod.family(label) == "native":
        default = int(getattr(case_mod.settings_of(label), "substeps", 1))
        finest = NATIVE_MIN_STEP / default * (1 - 1e-9)
        substeps = sorted({1, default, NATIVE_SUBSTEP_FACTOR * default})
        return [(dt, (("substeps", s),)) for dt in FULL_DTS_NATIVE for s in substeps if s == 1 or dt / s >= finest]
    grid = DIRECT_SETTINGS if _direct(label) else PARTICLE_SETTINGS
    return [(dt, _particle(i, s)) for dt in FULL_DTS_PARTICLE for s, i in grid]


def accuracy_cases(*, quick: bool, models: Optional[Sequence[str]] = None,
                   scenario_names: Optional[Sequence[str]] = None) -> List[Case]:
    """The accuracy sweep: each scenario × model label (default all) × (dt, settings), plus n_segments ∈
    :data:`SEGMENT_COUNTS` at dt = 0.002 with the defaults (full sweep). ``--quick``: two dts per label at its
    defaults on ``catenary``, ``chain`` and ``table`` and one run on the other scenarios that run in quick sweeps
    (:attr:`~mjcable.bench.scenarios.Scenario.in_quick`, with their ``quick_params`` and ``quick_time_cap``: one
    capstan μ, fewer bisection steps)."""
    models = case_mod.model_labels(models)
    cap = TIME_CAP_QUICK if quick else TIME_CAP_BENCH
    names = scenario_names or tuple(n for n, s in scenarios.SCENARIOS.items() if s.in_quick or not quick)
    cases = []
    for name in names:
        scenario = scenarios.get(name)
        params = scenario.quick_params if quick else ()
        cap_of = (scenario.quick_time_cap or cap) if quick else cap
        for model in models:
            grid = _settings_grid(model, quick)
            if quick and name not in QUICK_SCENARIOS:
                grid = grid[-1:]
            for dt, settings in grid:
                cases.append(Case(name, model, dt, settings=settings, params=params, quick=quick, time_cap=cap_of))
            if not quick:
                for n in SEGMENT_COUNTS:
                    cases.append(Case(name, model, 0.002, n_segments=n, time_cap=cap))
    return cases


def stiffness_cases(*, models: Optional[Sequence[str]] = None) -> List[Case]:
    """The thesis's stiffness-effect grid (§3.4.3) of the particle models among ``models`` (default all labels):
    iterations × dt, one substep, the shape at t = 0.25 s."""
    return [Case("swing", m, dt, settings=_particle(it, 1), params=(("save_positions", 1),), time_cap=TIME_CAP_BENCH)
            for m in case_mod.model_labels(models) if case_mod.family(m) == "particle"
            for dt in STIFFNESS_DTS for it in STIFFNESS_ITERATIONS]


def skip_cases(*, models: Optional[Sequence[str]] = None, repeats: int = 1) -> List[Case]:
    """Hang without obstacles, with an unused floor, and (native models) with MuJoCo's collision disabled."""
    out = []
    for model in case_mod.model_labels(models):
        variants = ["none", "unused_floor"] + (["contact_off"] if case_mod.family(model) == "native" else [])
        for variant, rep in itertools.product(variants, range(repeats)):
            out.append(Case("skip", model, 0.002, params=(("repeat", rep), ("variant", variant)),
                            time_cap=TIME_CAP_BENCH))
    return out


def convergence_cases(*, models: Optional[Sequence[str]] = None, quick: bool = False) -> List[Case]:
    """Each label's finest setting on the contact scenes at dt and dt / 2, keeping final positions: native models
    at their defaults (joints and composite cost ~1 ms per MuJoCo step), particle models 4 substeps × 4 iterations
    (× 1 in the direct order)."""
    out = []
    for model, name in itertools.product(case_mod.model_labels(models), CONVERGENCE_SCENARIOS):
        settings = () if case_mod.family(model) == "native" else _particle(1 if _direct(model) else 4, 4)
        for dt in (CONVERGENCE_DT, CONVERGENCE_DT / 2):
            out.append(Case(name, model, dt, settings=settings, params=(("save_positions", 1),), quick=quick,
                            time_cap=TIME_CAP_BENCH))
    return out


def cost_cases(*, models: Optional[Sequence[str]] = None) -> List[Case]:
    """The equal-error grid on :data:`COST_SCENARIO` (``--quick`` duration, 2 s simulated): n_segments ∈
    :data:`COST_SEGMENTS` × dt ∈ :data:`COST_DTS` × substeps (particle models :data:`COST_PARTICLE_SUBSTEPS` at one
    iteration; native models 1, the default d and 4 d, as in the full sweep), each run capped at
    :data:`TIME_CAP_COST` s. The table (:func:`mjcable.bench.plots.cheapest_markdown`) takes each model's cheapest
    stable run within :data:`COST_TARGET`."""
    out = []
    for model in case_mod.model_labels(models):
        if case_mod.family(model) == "native":
            default = int(getattr(case_mod.settings_of(model), "substeps", 1))
            settings = [(("substeps", s),) for s in sorted({1, default, NATIVE_SUBSTEP_FACTOR * default})]
        else:
            settings = [_particle(1, s) for s in COST_PARTICLE_SUBSTEPS]
        for n, dt, st in itertools.product(COST_SEGMENTS, COST_DTS, settings):
            out.append(Case(COST_SCENARIO, model, dt, n_segments=n, settings=st, quick=True, time_cap=TIME_CAP_COST))
    return out


def _convergence_markdown(rows: Sequence[dict], csv_path: str) -> str:
    lines = ["| scenario | model | settings | error at dt (m) | error at dt/2 (m) | RMS change dt → dt/2 (m) | "
             "converged (change < error) |", "|---|---|---|---|---|---|---|"]
    by_key = {r["key"]: r for r in rows}
    known = [m for m in sorted({r["model"] for r in rows}, key=case_mod.rank) if m in case_mod.MODEL_LABELS]
    for c in convergence_cases(models=known):
        if c.dt != CONVERGENCE_DT:
            continue
        fine = Case(c.scenario, c.model, c.dt / 2, settings=c.settings, params=c.params, quick=c.quick)
        a, b = by_key.get(c.key), by_key.get(fine.key)
        if a is None or b is None:
            continue
        if a["outcome"] != "stable" or b["outcome"] != "stable":
            lines.append(f"| {c.scenario} | {c.model} | {dict(c.settings)} | {a['outcome']} | {b['outcome']} | | |")
            continue
        pa, pb = results.positions_path(csv_path, a["key"]), results.positions_path(csv_path, b["key"])
        if not (os.path.exists(pa) and os.path.exists(pb)):
            continue
        xa, xb = np.load(pa), np.load(pb)
        if c.scenario in SET_ERROR_SCENARIOS:  # error ignores slip along the rest set: so does the change
            change = float(np.sqrt(np.mean(reference.distance_to_curve(xb, xa) ** 2)))
        else:
            change = float(np.sqrt(np.mean(np.sum((xa - xb) ** 2, axis=1))))
        if max(a["error"], b["error"]) < _AT_REFERENCE:
            ok = "at the reference (both errors below 1 nm)"
        else:
            ok = "yes" if change < min(a["error"], b["error"]) else "no"
        lines.append(f"| {c.scenario} | {c.model} | {dict(c.settings)} | {a['error']:.3g} | {b['error']:.3g} | "
                     f"{change:.3g} | {ok} |")
    return "\n".join(lines) + "\n"


def _skip_markdown(rows: Sequence[dict]) -> str:
    lines = ["| model | no obstacles (s/s) | unused floor (s/s) | collision off (s/s) | saving of no obstacles vs "
             "unused floor |", "|---|---|---|---|---|"]
    for model in sorted({r["model"] for r in rows}, key=case_mod.rank):
        cost = {}
        for variant in ("none", "unused_floor", "contact_off"):
            values = [r["wall_per_sim_s"] for r in rows if r["model"] == model and r["outcome"] == "stable"
                      and json.loads(r["params"]).get("variant") == variant]
            cost[variant] = float(np.min(values)) if values else math.nan  # the least disturbed repeat
        saving = 1.0 - cost["none"] / cost["unused_floor"] if cost["unused_floor"] > 0 else math.nan
        cells = ["–" if math.isnan(v) else f"{v:.3g}" for v in cost.values()]
        lines.append(f"| {model} | " + " | ".join(cells) + f" | {'–' if math.isnan(saving) else f'{saving:.0%}'} |")
    return "\n".join(lines) + "\n"


def run_bench(out: str, *, quick: bool = False, jobs: int = 1, scheduler=None,
              models: Optional[Sequence[str]] = None, scenario_names: Optional[Sequence[str]] = None,
              progress: bool = True, extras: bool = True) -> List[dict]:
    """Run (or resume) the benchmark into ``out`` and write its plots and tables.

    Args:
      out: output folder (created).
      quick: the reduced sweep.
      jobs: worker processes of the local Dask cluster (1: none, the runs go one after the other in this process);
        see :func:`mjcable.bench.sweep.run_sweep`.
      scheduler: an existing Dask cluster to run on instead (its scheduler's address, or a
        :class:`distributed.Client`); this process still writes every output.
      models: model labels (default all of :data:`mjcable.bench.case.MODEL_LABELS`).
      scenario_names: accuracy scenarios (default all; ``--quick``: all, with one run on the two not in
        :data:`QUICK_SCENARIOS`).
      progress: tqdm progress bars.
      extras: also run the stiffness-effect grid, the skip rows, the equal-error grid (:func:`cost_cases`) and
        (full sweep) the convergence check.

    Returns:
      The latest row per run of ``bench.csv``.
    """
    models = case_mod.model_labels(models)
    os.makedirs(out, exist_ok=True)
    csv_path = os.path.join(out, "bench.csv")
    cases = accuracy_cases(quick=quick, models=models, scenario_names=scenario_names)
    if extras:
        cases += stiffness_cases(models=models)
        cases += skip_cases(models=models, repeats=2 if quick else 3)
        cases += cost_cases(models=models)
        if not quick:
            cases += convergence_cases(models=models)
    start = time.perf_counter()
    sweep.run_sweep(cases, csv_path, jobs=jobs, scheduler=scheduler, desc="bench", progress=progress)
    # A folder may hold other sweeps (quick and full keys differ): report the runs of this one.
    keys = {c.key for c in cases}
    rows = [r for r in results.latest_rows(results.read_rows(csv_path)) if r["key"] in keys]
    write_reports(rows, out, csv_path=csv_path, wall=time.perf_counter() - start, jobs=jobs, quick=quick,
                  scheduler=scheduler)
    return rows


def write_reports(rows: Sequence[dict], out: str, *, csv_path: str, wall: float = math.nan, jobs: int = 1,
                  quick: bool = False, scheduler=None) -> None:
    """Write the work-precision PNGs, the stiffness grid and ``pareto.md`` from the rows."""
    accuracy = [r for r in rows if r["scenario"] in scenarios.SCENARIOS
                and not json.loads(r.get("params") or "{}").get("save_positions")]
    for name in dict.fromkeys(r["scenario"] for r in accuracy):
        plots.work_precision(accuracy, name, os.path.join(out, f"work_precision_{name}.png"))
    swing = [r for r in rows if r["scenario"] == "swing"]
    if swing:
        shapes, start = {}, scenarios.swing_scene(50).cable.particles
        for r in swing:
            p = results.positions_path(csv_path, r["key"])
            x = np.load(p) if (r["outcome"] == "stable" and os.path.exists(p)) else None
            shapes.setdefault(r["model"], {})[(int(r["iterations"]), float(r["dt"]))] = x
        order = sorted(shapes, key=case_mod.rank)
        plots.stiffness_grid_png({m: shapes[m] for m in order}, os.path.join(out, "stiffness_grid.png"),
                                 iterations=STIFFNESS_ITERATIONS, dts=STIFFNESS_DTS, start=np.asarray(start),
                                 time=scenarios.SWING_TIME)
    skip = [r for r in rows if r["scenario"] == "skip"]
    conv = [r for r in rows if json.loads(r.get("params") or "{}").get("save_positions")
            and r["scenario"] in CONVERGENCE_SCENARIOS]
    md = [f"# mjcable bench{' --quick' if quick else ''}\n",
          f"Machine: {platform.machine()}, {os.cpu_count()} CPU(s), {platform.processor() or platform.platform()}; "
          f"ran on {sweep.describe_workers(jobs=jobs, scheduler=scheduler)}; {len(rows)} runs in the CSV"
          + (f"; this call took {wall:.0f} s wall time." if math.isfinite(wall) else "."),
          "",
          "Errors: `catenary`, `cantilever`, `table`, `drape`: RMS distance (m) of the particles to the reference "
          "(catenary, heavy elastica, ideal rest on the table, ideal drape over the peg); `chain`: relative error "
          "of the mode-1 angular frequency; `energy`: the largest change of `Simulator.energy()` over 10 s of an "
          "undamped swing, relative to the swing's energy. Cost: wall time of the stepping per simulated second.\n",
          "## Pareto fronts\n", plots.pareto_markdown(accuracy)]
    cost_keys = {c.key for c in cost_cases(models=[m for m in dict.fromkeys(r["model"] for r in rows)
                                                   if m in case_mod.MODEL_LABELS])}
    cost = [r for r in rows if r["key"] in cost_keys]
    if cost:
        md += ["## Cost at equal error\n",
               f"Each model's cheapest stable run on `{COST_SCENARIO}` with an RMS error within {COST_TARGET:g} m, "
               f"over n_segments {list(COST_SEGMENTS)} × dt {list(COST_DTS)} s × substeps (particle models "
               f"{list(COST_PARTICLE_SUBSTEPS)} at one iteration; native models 1, the default and 4× it), "
               f"2 s simulated, each run capped at {TIME_CAP_COST:g} s of wall time.\n",
               plots.cheapest_markdown(cost, COST_TARGET)]
    if swing:
        md += ["## Stiffness effects (thesis §3.4.3)\n",
               f"A 1 m cable (E·A = {scenarios.SWING_STRETCH_STIFFNESS:g} N) pinned at one end, released "
               f"horizontal, one substep; image: `stiffness_grid.png`.\n",
               plots.stiffness_grid_markdown(swing, iterations=STIFFNESS_ITERATIONS, dts=STIFFNESS_DTS)]
    if skip:
        md += ["## Skip what a scene doesn't need\n",
               "The hang scene (no obstacles) against the same scene with a floor 1.73 m below the cable "
               "(never touched, but contact detection must run) and, for MuJoCo's models, with its collision "
               "pipeline disabled (`mjDSBL_CONTACT`: the floor of what skipping contacts can save). Fastest of the "
               "repeats (the least disturbed by other processes), wall time per simulated second.\n",
               _skip_markdown(skip)]
    if conv:
        md += ["## Convergence of the contact scenes\n",
               "Each model's finest setting at dt and dt/2: the RMS change is the result's own uncertainty; where it "
               "is below the error, the error against the ideal rest state is the model's, not unconverged noise. "
               "(drape: the change is measured like its error, as distances to the other run's curve, so slip along "
               "the peg counts in neither.)\n",
               _convergence_markdown(conv, csv_path)]
    md += ["## Outcomes\n", plots.outcome_markdown(rows)]
    with atomic_write(os.path.join(out, "pareto.md")) as f:
        f.write("\n".join(md))


def cli_bench(args) -> int:
    """Entry point of ``mjcable bench``: ``args`` has ``quick`` (bool), ``out`` (folder or None) and ``jobs``
    (int or None); optional ``scheduler`` (address or None), ``models`` and ``scenarios`` (lists of names)."""
    out = getattr(args, "out", None) or "bench_out"
    jobs, scheduler = sweep.workers_of(args)
    rows = run_bench(out, quick=bool(getattr(args, "quick", False)), jobs=jobs, scheduler=scheduler,
                     models=getattr(args, "models", None), scenario_names=getattr(args, "scenarios", None))
    counts = {o: sum(r["outcome"] == o for r in rows) for o in OUTCOMES}
    print(f"wrote {os.path.join(out, 'bench.csv')} ({len(rows)} runs: "
          + ", ".join(f"{v} {k}" for k, v in counts.items() if v) + f"), {os.path.join(out, 'pareto.md')} and PNGs")
    return 0

