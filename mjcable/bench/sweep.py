"""The sweep runner: one :class:`Case` per run, run in worker processes, one CSV row per run written as it finishes,
and an interrupted sweep resumed from its CSV.

Every run ends in exactly one ``outcome`` (:data:`OUTCOMES`):

* ``stable``: ran its whole duration with no sign of divergence or tunnelling;
* ``diverged``: NaN or runaway state (a particle faster than :data:`RUNAWAY_SPEED` m/s plus the driven speed, a
  segment stretched beyond :data:`STRAIN_LIMIT`), energy growth (passive scenes: kinetic + potential energy above
  its start value by more than :data:`ENERGY_GROWTH` m g L), a MuJoCo warning or silent reset
  (:class:`~mjcable.errors.SimulationDivergedError`), any other exception while stepping, or over its time cap;
* ``tunneled``: a particle ended up inside or beyond an obstacle (:func:`mjcable.metrics.tunneled`);
* ``unavailable``: the model cannot be built in this installation (its module is missing); re-run on resume;
* ``rejected``: mjcable's own validation refused the settings or scene up front with a ``ValueError`` (not a
  failure; a ``ValueError`` from MuJoCo while building counts as ``diverged``).

The ``reason`` column says what was detected; ``error`` holds the scenario's error against its reference.
"""

from __future__ import annotations

import concurrent.futures as futures
import contextlib
import csv
import dataclasses
import hashlib
import json
import math
import multiprocessing
import os
import signal
import time
import traceback
import warnings
from typing import Iterable, List, Optional, Sequence

import numpy as np

from mjcable import metrics
from mjcable.bench import scenarios as scenarios_mod
from mjcable.errors import SimulationDivergedError

__all__ = [
    "Case",
    "MODEL_LABELS",
    "model_labels",
    "OUTCOMES",
    "COLUMNS",
    "run_case",
    "run_sweep",
    "read_rows",
    "positions_path",
    "latest_rows",
    "ENERGY_GROWTH",
    "STRAIN_LIMIT",
    "RUNAWAY_SPEED",
]

# Model labels in the CSV's ``model`` column → (Simulator model, fixed settings).
MODEL_LABELS = {
    "springs": ("springs", {}),
    "joints": ("joints", {}),
    "composite": ("composite", {}),
    "flexrod": ("flexrod", {}),
    "jakobsen": ("jakobsen", {}),
    "pbd": ("pbd", {}),
    "xpbd": ("xpbd", {}),
    "xpbd-direct": ("xpbd", {"order": "direct"}),
}
OUTCOMES = ("stable", "diverged", "tunneled", "unavailable", "rejected")
COLUMNS = [
    "key", "scenario", "model", "solver", "dt", "n_segments", "substeps", "iterations", "order", "params",
    "outcome", "reason", "error", "error_kind", "max_strain", "final_strain", "max_penetration", "residual_speed",
    "wall_per_sim_s", "step_wall_s", "build_s", "sim_time", "steps", "time_cap_s", "started",
]
ENERGY_GROWTH = 0.5  # of m g L: a passive cable whose kinetic + potential energy grows by more has diverged
STRAIN_LIMIT = 1.0  # a segment stretched to more than twice its rest length is no longer a cable
RUNAWAY_SPEED = 50.0  # m/s on top of the driven speed: a particle faster than this has run away
SAMPLE_INTERVAL = 0.005  # s of simulated time between samples of the state (at least one step)
_PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # .../mjcable
_RESET_TOLERANCE = 0.5  # in steps: MuJoCo's clock may lag the simulator's by this much before we call it a reset


@dataclasses.dataclass(frozen=True)
class Case:
    """One run.

    Attributes:
      scenario: a name from :data:`~mjcable.bench.scenarios.SCENARIOS` or ``STRESS_SCENARIOS``.
      model: a label from :data:`MODEL_LABELS`.
      dt: step in seconds.
      n_segments: cable segments.
      settings: ``(name, value)`` pairs passed to :class:`mjcable.Simulator` (substeps, iterations, ...).
      params: ``(name, value)`` pairs of scenario parameters (``stiffness``, ``speed``, ``load``, ``variant``;
        ``duration`` overrides the scenario's simulated seconds; ``save_positions`` keeps the final positions).
      quick: use the scenario's ``quick_duration``.
      time_cap: wall-clock seconds after which the run is stopped and counted as ``diverged``.
    """

    scenario: str
    model: str
    dt: float
    n_segments: int = 50
    settings: tuple = ()
    params: tuple = ()
    quick: bool = False
    time_cap: float = 60.0

    @property
    def key(self) -> str:
        """A stable identifier of the run (the time cap does not change what is run)."""
        return json.dumps([self.scenario, self.model, float(self.dt), int(self.n_segments),
                           sorted(self.settings), sorted(self.params), bool(self.quick)], sort_keys=True)


def _settings_of(case: Case) -> dict:
    solver, fixed = MODEL_LABELS[case.model]
    return {**fixed, **dict(case.settings)}


class _TimeCap(BaseException):
    """Raised by the wall-clock alarm; a BaseException, so that no library's ``except Exception`` swallows it."""


@contextlib.contextmanager
def _time_cap(seconds: float):
    """Raise :class:`_TimeCap` in this (main) thread after ``seconds`` of wall time (SIGALRM), where possible."""
    usable = hasattr(signal, "setitimer") and _is_main_thread()
    if not usable:
        yield
        return

    def handler(signum, frame):
        raise _TimeCap()

    previous = signal.signal(signal.SIGALRM, handler)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def _caused_by_time_cap(exc: BaseException) -> bool:
    """Whether the alarm interrupted compiled code (numba, MuJoCo) and came back wrapped, e.g. as SystemError."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, _TimeCap):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def _is_main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()


def _empty_row(case: Case) -> dict:
    settings = _settings_of(case) if case.model in MODEL_LABELS else {}
    return {
        "key": case.key, "scenario": case.scenario, "model": case.model,
        "solver": MODEL_LABELS.get(case.model, (case.model,))[0], "dt": case.dt, "n_segments": case.n_segments,
        "substeps": settings.get("substeps", ""), "iterations": settings.get("iterations", ""),
        "order": settings.get("order", ""), "params": json.dumps(dict(case.params), sort_keys=True),
        "outcome": "", "reason": "", "error": math.nan, "error_kind": "", "max_strain": math.nan,
        "final_strain": math.nan, "max_penetration": math.nan, "residual_speed": math.nan,
        "wall_per_sim_s": math.nan, "step_wall_s": math.nan, "build_s": math.nan, "sim_time": 0.0, "steps": 0,
        "time_cap_s": case.time_cap, "started": time.strftime("%Y-%m-%dT%H:%M:%S"),
    }


def run_case(case: Case) -> dict:
    """Run one case and return its CSV row (never raises for a failing model; see :data:`OUTCOMES`)."""
    row = _empty_row(case)
    try:
        scenario = scenarios_mod.get(case.scenario)
        if case.model not in MODEL_LABELS:
            raise ValueError(f"model must be one of {tuple(MODEL_LABELS)}, got {case.model!r}")
    except ValueError as exc:
        row.update(outcome="rejected", reason=str(exc))
        return row
    row["error_kind"] = scenario.error_kind
    params = dict(case.params)
    try:
        with _time_cap(case.time_cap):
            _run(case, scenario, params, row)
    except _TimeCap:
        row.update(outcome="diverged", reason=f"over its time cap of {case.time_cap:g} s wall time "
                                              f"(reached {row['sim_time']:.4g} s simulated)")
        if row["steps"]:
            row["wall_per_sim_s"] = row["step_wall_s"] / row["sim_time"]
    return row


def _classify_exception(exc: BaseException, building: bool) -> tuple:
    if isinstance(exc, SimulationDivergedError):
        return "diverged", exc.reason
    if isinstance(exc, (ImportError, NotImplementedError)) or (
            isinstance(exc, AttributeError) and building and "make_backend" in str(exc)):
        return "unavailable", f"{type(exc).__name__}: {exc}"
    if isinstance(exc, ValueError) and building and _raised_by_mjcable(exc):
        return "rejected", f"ValueError: {exc}"
    tail = traceback.format_exception_only(type(exc), exc)[-1].strip()
    return "diverged", f"exception while {'building' if building else 'stepping'}: {tail}"


def _raised_by_mjcable(exc: BaseException) -> bool:
    """Whether the innermost frame of ``exc`` lies in the mjcable package (its own input validation), rather than
    in MuJoCo or another library (a crash while building, which counts as a failure)."""
    tb = exc.__traceback__
    if tb is None:
        return False
    while tb.tb_next is not None:
        tb = tb.tb_next
    return os.path.abspath(tb.tb_frame.f_code.co_filename).startswith(_PACKAGE_DIR)


def _run(case: Case, scenario, params: dict, row: dict) -> None:
    import mjcable

    solver = MODEL_LABELS[case.model][0]
    settings = _settings_of(case)
    building = True
    try:
        scene = scenario.make_scene(case.n_segments, params)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # e.g. springs capping an unreachable stiffness: recorded via strain
            _warm_up(scene, solver, case.dt, settings)
            t0 = time.perf_counter()
            sim = mjcable.Simulator(scene, solver, dt=case.dt, **settings)
        if scenario.setup is not None:
            scenario.setup(sim, params)
        row["build_s"] = time.perf_counter() - t0
        building = False
        _simulate(case, scenario, params, scene, sim, row)
    except _TimeCap:
        raise
    except Exception as exc:  # noqa: BLE001 - every failure becomes a classified row
        if _caused_by_time_cap(exc):
            raise _TimeCap() from exc
        outcome, reason = _classify_exception(exc, building)
        row.update(outcome=outcome, reason=reason)


def _warm_up(scene, solver: str, dt: float, settings: dict) -> None:
    """Build the same model once and take a step, so that JIT compilation and cache loading (numba) stay out of
    the timed stepping; failures are left for the real run to report."""
    import mjcable

    try:
        mjcable.Simulator(scene, solver, dt=dt, **settings).step()
    except Exception as exc:  # noqa: BLE001
        if _caused_by_time_cap(exc):
            raise _TimeCap() from exc


def warm_up_models(labels: Iterable[str]) -> None:
    """Compile each particle solver's kernels once in this process (numba writes its cache), so that parallel
    workers load the cache instead of compiling the same functions at the same time."""
    from mjcable import scenes

    for label in dict.fromkeys(labels):
        if label not in MODEL_LABELS or solver_is_native(label):
            continue
        solver, fixed = MODEL_LABELS[label]
        for name in ("table", "hang"):
            for extra in ({}, {"young": 1e7}):
                scene = scenes.get(name, n_segments=4, **extra)
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    _warm_up(scene, solver, 0.002, dict(fixed))


def _simulate(case: Case, scenario, params: dict, scene, sim, row: dict) -> None:
    dt = case.dt
    duration = params.get("duration", scenario.quick_duration if case.quick else scenario.duration)
    duration = float(duration) + scenario.drive_end(params)
    total_steps = max(1, int(round(duration / dt)))
    per_sample = max(1, int(round(SAMPLE_INTERVAL / dt)))
    masses = scene.cable.particle_masses.copy()
    if "load" in params:
        masses[-1] += float(params["load"]) * scene.cable.mass
    l0 = scene.cable.segment_length
    scale = float(masses.sum()) * 9.81 * max(scene.cable.length, 1e-3)
    x0 = np.asarray(scene.cable.particles)
    native = solver_is_native(case.model)
    drive_end = scenario.drive_end(params)
    speed_limit = RUNAWAY_SPEED + float(params.get("speed", 0.0))
    strain_limit = STRAIN_LIMIT if scenario.strain_limit is None else scenario.strain_limit

    x = sim.positions
    previous = x
    e_ref = metrics.energy(x, None, dt, masses)  # a passive cable's kinetic + potential energy can only fall
    max_strain = metrics.max_strain(x, l0)
    max_pen = metrics.penetration(x, scene)
    times, com_x = [0.0], [float(np.dot(masses, x[:, 0]) / masses.sum())]
    step_wall = 0.0
    steps = 0
    deadline = time.perf_counter() + case.time_cap
    reason, outcome = "", "stable"
    try:
        while steps < total_steps:
            count = min(per_sample, total_steps - steps)
            if scenario.drive is not None:
                # the drive moves in whole steps: one step at a time while it is active
                if steps * dt < drive_end + dt:
                    count = 1
                scenario.drive(sim, steps * dt, params)
            t0 = time.perf_counter()
            for _ in range(count - 1):
                sim.step()
            step_wall += time.perf_counter() - t0
            previous = sim.positions  # the state one step before the sample: finite-difference velocities
            t0 = time.perf_counter()
            sim.step()
            step_wall += time.perf_counter() - t0
            steps += count
            row.update(step_wall_s=step_wall, sim_time=steps * dt, steps=steps)  # progress, kept on a time cap
            x = sim.positions
            strain = metrics.max_strain(x, l0)
            max_strain = max(max_strain, strain)
            max_pen = max(max_pen, metrics.penetration(x, scene))
            if scenario.needs_com_x:
                times.append(sim.time)
                com_x.append(float(np.dot(masses, x[:, 0]) / masses.sum()))
            if not strain <= strain_limit:  # also NaN
                outcome, reason = "diverged", f"runaway strain {strain:.3g} (limit {strain_limit:g})"
                break
            speed = float(np.sqrt(np.max(np.sum((x - previous) ** 2, axis=1)))) / dt
            if speed > speed_limit:
                outcome, reason = "diverged", f"runaway speed {speed:.3g} m/s (limit {speed_limit:g} m/s)"
                break
            e = metrics.energy(x, previous, dt, masses)
            if scenario.passive and e - e_ref > ENERGY_GROWTH * scale:
                outcome, reason = "diverged", (f"energy grew by {e - e_ref:.3g} J (limit {ENERGY_GROWTH:g} m g L"
                                               f" = {ENERGY_GROWTH * scale:.3g} J)")
                break
            if native and abs(sim.mj_data.time - sim.time) > _RESET_TOLERANCE * dt:
                outcome, reason = "diverged", (f"MuJoCo's clock reads {sim.mj_data.time:.6g} s at simulated "
                                               f"{sim.time:.6g} s: a silent reset")
                break
            through = metrics.crossed(x, scene, x0)
            if np.any(through):
                outcome, reason = "tunneled", (f"{int(np.sum(through))} particle(s) inside or beyond an obstacle "
                                               f"at t = {sim.time:.4g} s")
                break
            if time.perf_counter() > deadline:
                raise _TimeCap()
    except SimulationDivergedError as exc:
        outcome, reason = "diverged", exc.reason
    except _TimeCap:
        raise
    except Exception as exc:  # noqa: BLE001
        if _caused_by_time_cap(exc):
            raise _TimeCap() from exc
        outcome, reason = _classify_exception(exc, building=False)
    row.update(outcome=outcome, reason=reason, max_strain=max_strain, max_penetration=max_pen,
               step_wall_s=step_wall, sim_time=steps * dt, steps=steps,
               wall_per_sim_s=step_wall / (steps * dt) if steps else math.nan)
    if outcome == "stable":
        stuck = metrics.tunneled(x, scene, x0)
        if np.any(stuck):
            outcome, reason = "tunneled", f"{int(np.sum(stuck))} particle(s) inside or beyond an obstacle at the end"
            row.update(outcome=outcome, reason=reason)
    if dict(case.params).get("save_positions"):
        row["positions"] = x.tolist()
    if outcome != "stable":
        return
    row["final_strain"] = metrics.max_strain(x, l0)
    row["residual_speed"] = float(np.sqrt(np.max(np.sum((x - previous) ** 2, axis=1)))) / dt
    if scenario.evaluate is not None:
        history = {"times": np.array(times), "com_x": np.array(com_x)}
        try:
            row["error"] = float(scenario.evaluate(scene, x, history))
        except Exception as exc:  # noqa: BLE001 - a failed measurement is recorded, not raised
            row["reason"] = f"error measurement failed: {type(exc).__name__}: {exc}"


def model_labels(models: Optional[Sequence[str]]) -> tuple:
    """``models`` checked against :data:`MODEL_LABELS` (``None`` or empty: all of them)."""
    labels = tuple(models or MODEL_LABELS)
    for m in labels:
        if m not in MODEL_LABELS:
            raise ValueError(f"models must be among {tuple(MODEL_LABELS)}, got {m!r}")
    return labels


def solver_is_native(label: str) -> bool:
    return MODEL_LABELS.get(label, (label,))[0] in ("springs", "joints", "composite", "flexrod")


# ------------------------------------------------------------------------------------------------------ the CSV


def read_rows(path) -> List[dict]:
    """All rows of a sweep CSV (numbers parsed where they parse), in file order; [] when it does not exist."""
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for row in rows:
        for k, v in row.items():
            if k in ("key", "scenario", "model", "solver", "order", "params", "outcome", "reason", "error_kind",
                     "started"):
                continue
            try:
                row[k] = float(v) if v not in ("", None) else math.nan
            except ValueError:
                pass
    return rows


def latest_rows(rows: Iterable[dict]) -> List[dict]:
    """The last row per ``key`` (a resumed sweep may have re-run an ``unavailable`` case)."""
    out = {}
    for row in rows:
        out[row["key"]] = row
    return list(out.values())


def positions_path(csv_path, key: str) -> str:
    """Where a run's final positions are kept (``.npy`` next to the CSV) when its params ask for them."""
    folder = os.path.join(os.path.dirname(os.path.abspath(csv_path)), "positions")
    os.makedirs(folder, exist_ok=True)
    return os.path.join(folder, hashlib.sha1(key.encode()).hexdigest()[:16] + ".npy")


def _done_keys(path) -> set:
    return {r["key"] for r in latest_rows(read_rows(path)) if r.get("outcome") not in ("", "unavailable")}


def _format(row: dict) -> dict:
    out = {}
    for k in COLUMNS:
        v = row.get(k, "")
        if isinstance(v, float):
            v = "" if math.isnan(v) else f"{v:.6g}"
        out[k] = v
    return out


def run_sweep(cases: Iterable[Case], csv_path, *, jobs: int = 1, desc: str = "sweep",
              progress: bool = True) -> List[dict]:
    """Run the cases not yet in ``csv_path`` and append one row per finished run.

    Args:
      cases: the runs.
      csv_path: the CSV to append to (created with a header when missing). Cases whose key already has a row with
        an outcome other than ``unavailable`` are skipped (resume).
      jobs: worker processes (1: run in this process).
      desc: progress-bar label.
      progress: show a tqdm progress bar.

    Returns:
      The rows written by this call, in completion order.
    """
    cases = list(cases)
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise ValueError(f"jobs must be an integer >= 1, got {jobs!r}")
    if os.path.exists(csv_path) and os.path.getsize(csv_path) > 0:
        with open(csv_path, newline="") as f:
            header = next(csv.reader(f), [])
        if header != COLUMNS:
            raise ValueError(f"csv_path {str(csv_path)!r} has other columns ({len(header)}) than this version writes "
                             f"({len(COLUMNS)}): resume into a fresh folder")
    done = _done_keys(csv_path)
    seen = set()
    todo = []
    for c in cases:
        if c.key not in done and c.key not in seen:
            seen.add(c.key)
            todo.append(c)
    os.makedirs(os.path.dirname(os.path.abspath(csv_path)), exist_ok=True)
    new_file = not os.path.exists(csv_path) or os.path.getsize(csv_path) == 0
    written = []
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(todo), desc=desc, unit="run", dynamic_ncols=True)
    with open(csv_path, "a", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=COLUMNS)
        if new_file:
            writer.writeheader()
            f.flush()

        def record(row):
            if "positions" in row:
                np.save(positions_path(csv_path, row["key"]), np.asarray(row.pop("positions")))
            writer.writerow(_format(row))
            f.flush()
            written.append(row)
            if bar is not None:
                bar.update(1)
                bar.set_postfix_str(f"{row['scenario']}/{row['model']}: {row['outcome']}", refresh=False)

        if jobs == 1 or len(todo) <= 1:
            for c in todo:
                record(run_case(c))
        else:
            warm_up_models(c.model for c in todo)
            ctx = multiprocessing.get_context("spawn")
            with futures.ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as pool:
                pending = {pool.submit(run_case, c): c for c in todo}
                for fut in futures.as_completed(pending):
                    c = pending[fut]
                    try:
                        row = fut.result()
                    except Exception as exc:  # noqa: BLE001 - a worker that died still gets its row
                        row = _empty_row(c)
                        row.update(outcome="diverged", reason=f"worker failed: {type(exc).__name__}: {exc}")
                    record(row)
    if bar is not None:
        bar.close()
    return written


def default_jobs() -> int:
    """Worker processes to use by default: the CPU count (at least 1)."""
    return max(1, os.cpu_count() or 1)

