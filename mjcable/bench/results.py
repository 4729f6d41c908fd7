"""The sweep's CSV: its columns, one row per run, reading it back, and which runs a resumed sweep may skip.

A row's ``key`` is its :attr:`~mjcable.bench.case.Case.key`; ``solver`` is the catalogue model behind the label,
and ``substeps``, ``iterations`` and ``order`` are the values the run used (the model's defaults where the case
gives none; empty where the model has no such setting). Final positions, when a case's params ask for them, are
kept as ``.npy`` files next to the CSV (:func:`positions_path`).
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import os
import time
from typing import Iterable, List

from mjcable.bench import case as case_mod
from mjcable.bench.outcome import OUTCOMES

__all__ = ["COLUMNS", "TEXT_COLUMNS", "empty_row", "format_row", "read_rows", "latest_rows", "done_keys",
           "positions_path", "check_header"]

COLUMNS = [
    "key", "scenario", "model", "solver", "dt", "n_segments", "substeps", "iterations", "order", "params",
    "outcome", "reason", "error", "error_kind", "max_strain", "final_strain", "max_penetration", "residual_speed",
    "wall_per_sim_s", "step_wall_s", "build_s", "sim_time", "steps", "time_cap_s", "started",
]
TEXT_COLUMNS = ("key", "scenario", "model", "solver", "order", "params", "outcome", "reason", "error_kind", "started")


def _used_settings(case: case_mod.Case) -> tuple:
    """``(solver, settings object or dict)`` the case runs with (the given settings when they do not validate)."""
    try:
        model, fixed = case_mod.resolve(case.model)
    except ValueError:
        return case.model, dict(case.settings)
    try:
        return model, case_mod.settings_of(case.model, **dict(case.settings))
    except ValueError:
        return model, {**fixed, **dict(case.settings)}


def empty_row(case: case_mod.Case) -> dict:
    """The CSV row of ``case`` before it ran: what is run filled in, every measurement empty (NaN)."""
    solver, settings = _used_settings(case)

    def used(name):
        value = settings.get(name, "") if isinstance(settings, dict) else getattr(settings, name, "")
        return "" if value is None else value

    return {
        "key": case.key, "scenario": case.scenario, "model": case.model, "solver": solver, "dt": case.dt,
        "n_segments": case.n_segments, "substeps": used("substeps"), "iterations": used("iterations"),
        "order": used("order"), "params": json.dumps(dict(case.params), sort_keys=True),
        "outcome": "", "reason": "", "error": math.nan, "error_kind": "", "max_strain": math.nan,
        "final_strain": math.nan, "max_penetration": math.nan, "residual_speed": math.nan,
        "wall_per_sim_s": math.nan, "step_wall_s": math.nan, "build_s": math.nan, "sim_time": 0.0, "steps": 0,
        "time_cap_s": case.time_cap, "started": time.strftime("%Y-%m-%dT%H:%M:%S"),
    }


def format_row(row: dict) -> dict:
    """``row`` as the CSV writer takes it: every column, floats to 6 significant digits, NaN as empty."""
    out = {}
    for k in COLUMNS:
        v = row.get(k, "")
        if isinstance(v, float):
            v = "" if math.isnan(v) else f"{v:.6g}"
        out[k] = v
    return out


def read_rows(path) -> List[dict]:
    """All rows of a sweep CSV (numbers parsed where they parse, empty cells as NaN), in file order; [] when it
    does not exist."""
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for row in rows:
        for k, v in row.items():
            if k in TEXT_COLUMNS:
                continue
            try:
                row[k] = float(v) if v not in ("", None) else math.nan
            except ValueError:
                pass
    return rows


def latest_rows(rows: Iterable[dict]) -> List[dict]:
    """The last row per ``key`` (a resumed sweep may have run a case again)."""
    out = {}
    for row in rows:
        out[row["key"]] = row
    return list(out.values())


def done_keys(path) -> set:
    """Keys of the runs in the CSV at ``path`` that a resumed sweep skips: those whose latest row holds one of
    :data:`~mjcable.bench.outcome.OUTCOMES` (a row of an interrupted write, or an outcome an older version wrote,
    is run again)."""
    return {r["key"] for r in latest_rows(read_rows(path)) if r.get("outcome") in OUTCOMES}


def check_header(path) -> None:
    """Refuse to append to an existing, non-empty CSV with other columns than :data:`COLUMNS`.

    Raises:
      ValueError: the header differs.
    """
    if not (os.path.exists(path) and os.path.getsize(path) > 0):
        return
    with open(path, newline="") as f:
        header = next(csv.reader(f), [])
    if header != COLUMNS:
        raise ValueError(f"csv_path {str(path)!r} has other columns ({len(header)}) than this version writes "
                         f"({len(COLUMNS)}): resume into a fresh folder")


def positions_path(csv_path, key: str) -> str:
    """Where a run's final positions are kept (``.npy`` in ``positions/`` next to the CSV; the folder is created)
    when its params ask for them."""
    folder = os.path.join(os.path.dirname(os.path.abspath(csv_path)), "positions")
    os.makedirs(folder, exist_ok=True)
    return os.path.join(folder, hashlib.sha1(key.encode()).hexdigest()[:16] + ".npy")
