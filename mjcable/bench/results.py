"""The sweep's CSV: its columns, one row per run, reading it back, and which runs a resumed sweep may skip.

A row's ``key`` is its :attr:`~mjcable.bench.case.Case.key`; ``solver`` is the catalogue model behind the label,
and ``substeps``, ``iterations`` and ``order`` are the values the run used (the model's defaults where the case
gives none; empty where the model has no such setting). Final positions, when a case's params ask for them, are
kept as ``.npy`` files next to the CSV (:func:`positions_path`).

The CSV holds one line per row (:func:`format_line`), appended as runs finish, so a killed sweep leaves at most its
last row cut short: :func:`repair` removes it before a sweep resumes, and :func:`read_rows` leaves out, with a
warning, any row cut short or garbled.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import os
import re
import time
import warnings
from typing import Iterable, Iterator, List, Tuple

from mjcable.bench import case as case_mod
from mjcable.bench.outcome import OUTCOMES

__all__ = ["COLUMNS", "TEXT_COLUMNS", "empty_row", "format_row", "format_line", "header_line", "read_rows",
           "repair", "latest_rows", "done_keys", "positions_path", "check_header"]

COLUMNS = [
    "key", "scenario", "model", "solver", "dt", "n_segments", "substeps", "iterations", "order", "params",
    "outcome", "reason", "error", "error_kind", "max_strain", "final_strain", "max_penetration", "residual_speed",
    "wall_per_sim_s", "step_wall_s", "build_s", "sim_time", "steps", "time_cap_s", "started",
]
TEXT_COLUMNS = ("key", "scenario", "model", "solver", "order", "params", "outcome", "reason", "error_kind", "started")
_LINE = re.compile(rb"[^\n]*\n|[^\n]+\Z")  # a line of the file with its end, or the last one without


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
    """``row`` as the CSV writer takes it: every column, floats to 6 significant digits, NaN as empty, line breaks
    in text as spaces (one line per row)."""
    out = {}
    for k in COLUMNS:
        v = row.get(k, "")
        if isinstance(v, float):
            v = "" if math.isnan(v) else f"{v:.6g}"
        elif isinstance(v, str):
            v = " ".join(v.splitlines())
        out[k] = v
    return out


def read_rows(path) -> List[dict]:
    """All rows of a sweep CSV (numbers parsed where they parse, empty cells as NaN), in file order; [] when it
    does not exist. A row cut short by an interrupted write (the last one, without its line end) or garbled (a
    number of cells other than the header's) is left out with a warning naming the file and the row."""
    if not os.path.exists(path):
        return []
    with open(path, "rb") as f:
        data = f.read()
    rows, header = [], None
    for number, line, end, cells in _records(data):
        if header is None:
            header = cells
        elif len(cells) != len(header) or (end == len(data) and not data.endswith(b"\n")):
            warnings.warn(f"{path}: row {number} (line {line}) is cut short or garbled (an interrupted write?); "
                          "left out", stacklevel=2)
        else:
            rows.append(dict(zip(header, cells)))
    for row in rows:
        for k, v in row.items():
            if k in TEXT_COLUMNS:
                continue
            try:
                row[k] = float(v) if v != "" else math.nan
            except ValueError:
                pass
    return rows


def repair(path) -> None:
    """Cut a row that an interrupted write left without its line end (the last one, possibly the header) off the
    CSV at ``path``, with a warning naming the file and the row, so that the rows appended next start on a line of
    their own and the cut run goes again."""
    if not os.path.exists(path):
        return
    with open(path, "rb") as f:
        data = f.read()
    if not data or data.endswith(b"\n"):
        return
    start = data.rfind(b"\n") + 1  # where the last line, the one without its end, starts
    number = sum(1 for _ in _records(data[:start]))  # the rows before it (0: it is the header)
    line = data.count(b"\n", 0, start) + 1
    with open(path, "r+b") as f:
        f.truncate(start)
        f.flush()
        os.fsync(f.fileno())
    what = "the header" if number == 0 else f"row {number}"
    warnings.warn(f"{path}: {what} (line {line}) was cut short by an interrupted write; removed it "
                  f"({len(data) - start} bytes) before resuming", stacklevel=2)


def format_line(row: dict) -> str:
    """``row`` as one line of the CSV (:func:`format_row`, the CSV writer's quoting, ``\\r\\n`` at the end)."""
    out = io.StringIO()
    csv.DictWriter(out, fieldnames=COLUMNS).writerow(format_row(row))
    return out.getvalue()


def header_line() -> str:
    """The CSV's header line."""
    out = io.StringIO()
    csv.writer(out).writerow(COLUMNS)
    return out.getvalue()


def _records(data: bytes) -> Iterator[Tuple[int, int, int, List[str]]]:
    """``(row number, line number, end offset in bytes, cells)`` of each line of the CSV bytes ``data`` (row 0:
    the header; blank lines skipped). Each line is read on its own (this version writes one line per row), so an
    unbalanced quote in a garbled line cannot swallow the rows after it; bytes that do not decode as UTF-8 become
    replacement characters."""
    number = 0
    for line, m in enumerate(_LINE.finditer(data), start=1):
        cells = next(csv.reader([m.group().decode("utf-8", "replace")]), [])
        if cells:
            yield number, line, m.end(), cells
            number += 1


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
