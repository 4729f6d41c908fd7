"""The sweep: run many :class:`~mjcable.bench.case.Case` s, in worker processes, one CSV row per run written as it
finishes, and an interrupted sweep resumed from its CSV (:mod:`mjcable.bench.results`).

Example::

    from mjcable.bench.case import Case
    from mjcable.bench.sweep import run_sweep
    rows = run_sweep([Case("catenary", "xpbd", 0.002)], "out/bench.csv", jobs=1)
"""

from __future__ import annotations

import concurrent.futures as futures
from concurrent.futures.process import BrokenProcessPool
import csv
import multiprocessing
import os
import pickle
from typing import Iterable, List

import numpy as np

from mjcable import _validate, catalog
from mjcable.bench import case as case_mod
from mjcable.bench import results
from mjcable.bench.case import Case
from mjcable.bench.runner import run_case, warm_up_models

__all__ = ["run_sweep", "default_jobs"]


def _shippable(entries) -> tuple:
    """The catalogue entries that pickle (their functions are module-level); the others (e.g. the native models'
    builders, closures) are left to the workers' own import of mjcable, which registers them too."""
    out = []
    for entry in entries:
        try:
            pickle.dumps(entry)
        except (pickle.PicklingError, AttributeError, TypeError):
            continue
        out.append(entry)
    return tuple(out)


def _adopt_models(entries: tuple, needed: tuple) -> None:
    """Worker initialiser: register the parent's catalogue entries (a model registered at run time included) and
    check that every model the sweep runs is known here."""
    for entry in entries:
        catalog.register(entry, replace=True)
    missing = sorted(set(needed) - set(catalog.names()))
    if missing:
        raise RuntimeError(f"models {missing} are registered in the parent process only and do not pickle: "
                           "register them with module-level functions, or run the sweep with jobs=1")


def run_sweep(cases: Iterable[Case], csv_path, *, jobs: int = 1, desc: str = "sweep",
              progress: bool = True) -> List[dict]:
    """Run the cases not yet in ``csv_path`` and append one row per finished run.

    Args:
      cases: the runs.
      csv_path: the CSV to append to (created with a header when missing). Cases whose key already has a row with
        an outcome are skipped (resume: :func:`mjcable.bench.results.done_keys`).
      jobs: worker processes (1: run in this process). Workers are spawned and get this process's catalogue
        entries of the models they run, so a model registered at run time must pickle (module-level functions)
        or be registered by an import that the workers make too.
      desc: progress-bar label.
      progress: show a tqdm progress bar.

    Returns:
      The rows written by this call, in completion order.

    Raises:
      ValueError: ``jobs`` < 1, or ``csv_path`` holds other columns than :data:`~mjcable.bench.results.COLUMNS`.
      Exception: a defect of a model (:data:`~mjcable.bench.outcome.DEFECTS`), from this process or a worker.
    """
    cases = list(cases)
    jobs = _validate.integer("jobs", jobs, low=1)
    results.check_header(csv_path)
    done = results.done_keys(csv_path)
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
        writer = csv.DictWriter(f, fieldnames=results.COLUMNS)
        if new_file:
            writer.writeheader()
            f.flush()

        def record(row):
            if "positions" in row:
                np.save(results.positions_path(csv_path, row["key"]), np.asarray(row.pop("positions")))
            writer.writerow(results.format_row(row))
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
            models = tuple(sorted({case_mod.resolve(c.model)[0] for c in todo if c.model in case_mod.MODEL_LABELS}))
            entries = _shippable(catalog.get(m) for m in models)
            ctx = multiprocessing.get_context("spawn")
            with futures.ProcessPoolExecutor(max_workers=jobs, mp_context=ctx, initializer=_adopt_models,
                                             initargs=(entries, models)) as pool:
                pending = {pool.submit(run_case, c): c for c in todo}
                try:
                    for fut in futures.as_completed(pending):
                        c = pending[fut]
                        try:
                            row = fut.result()
                        except BrokenProcessPool as exc:  # a worker that died still gets its row
                            row = results.empty_row(c)
                            row.update(outcome="diverged", reason=f"worker failed: {type(exc).__name__}: {exc}")
                        record(row)
                except BaseException:  # a defect (or Ctrl-C): drop the queued runs, let the running ones end
                    for fut in pending:
                        fut.cancel()
                    raise
    if bar is not None:
        bar.close()
    return written


def default_jobs() -> int:
    """Worker processes to use by default: the CPU count (at least 1)."""
    return max(1, os.cpu_count() or 1)
