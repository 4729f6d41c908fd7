"""The sweep: run many :class:`~mjcable.bench.case.Case` s on ``dask.distributed``, one task per case, one CSV row
per run written by the client as it finishes, and an interrupted sweep resumed from its CSV
(:mod:`mjcable.bench.results`).

The cases run on a :class:`distributed.LocalCluster` of ``jobs`` worker processes with one thread each (started
and closed by :func:`run_sweep`), or on an existing cluster (``scheduler``: its address, or a connected
:class:`distributed.Client`). Workers only compute: each task returns its row (final positions included, when the
case asks for them) and the client writes the CSV and the ``.npy`` files, so that workers on other machines need
no access to the output folder. Each task carries the client's catalogue entry of its model (pickled, with
cloudpickle where plain pickle fails), so that a model registered at run time in the client runs on the workers.
``jobs=1`` with no ``scheduler`` runs the cases one after the other in this process, without Dask. The local
cluster's workers are spawned processes: a script that starts one needs the ``if __name__ == "__main__":`` guard.

Example::

    from mjcable.bench.case import Case
    from mjcable.bench.sweep import run_sweep
    rows = run_sweep([Case("catenary", "xpbd", 0.002)], "out/bench.csv", jobs=2)
    rows = run_sweep([Case("catenary", "xpbd", 0.002)], "out/bench.csv", scheduler="tcp://10.0.0.5:8786")
"""

from __future__ import annotations

import contextlib
import logging
import os
from typing import Callable, Iterable, List, Optional, Sequence

import cloudpickle
import dask
import distributed
import numpy as np

from mjcable import _validate, catalog
from mjcable.bench import case as case_mod
from mjcable.bench import results
from mjcable.bench.case import Case
from mjcable.bench.runner import run_case, warm_up_models
from mjcable.io import atomic_write

__all__ = ["run_sweep", "default_jobs", "workers_of", "describe_workers", "ALLOWED_FAILURES"]

ALLOWED_FAILURES = 1  # LocalCluster: a case whose worker died is tried once more, then recorded as diverged


def run_sweep(cases: Iterable[Case], csv_path, *, jobs: int = 1, scheduler=None, desc: str = "sweep",
              progress: bool = True) -> List[dict]:
    """Run the cases not yet in ``csv_path`` and append one row per finished run.

    Args:
      cases: the runs.
      csv_path: the CSV to append to (created with a header when missing), by this process. Cases whose key
        already has a row with an outcome are skipped (resume: :func:`mjcable.bench.results.done_keys`). Each row
        is appended and synced to disk as its run finishes (final positions first, atomically), so a sweep killed
        at any moment loses only the runs in progress; a last row it cut short is removed, with a warning, when
        the sweep resumes (:func:`mjcable.bench.results.repair`).
      jobs: worker processes of the local Dask cluster started for the sweep (1: no cluster, the cases run in
        this process). Must stay 1 when ``scheduler`` is given.
      scheduler: an existing Dask cluster to run on instead: its scheduler's address (e.g.
        ``"tcp://10.0.0.5:8786"``; the client connects and disconnects) or a connected
        :class:`distributed.Client` (left open).
      desc: progress-bar label.
      progress: show a tqdm progress bar.

    Returns:
      The rows written by this call, in completion order.

    Raises:
      ValueError: ``jobs`` < 1, ``jobs`` > 1 together with ``scheduler``, a ``scheduler`` that is neither an
        address nor a client, or ``csv_path`` holds other columns than :data:`~mjcable.bench.results.COLUMNS`.
      RuntimeError: a model registered in this process only whose entry does not pickle, on a worker that lacks it.
      Exception: a defect of a model (:data:`~mjcable.bench.outcome.DEFECTS`), from this process or a worker.
    """
    cases = list(cases)
    jobs = _validate.integer("jobs", jobs, low=1)
    if scheduler is not None and not isinstance(scheduler, (str, distributed.Client)):
        raise ValueError(f"scheduler must be None, an address or a distributed.Client, got {scheduler!r}")
    if scheduler is not None and jobs != 1:
        raise ValueError(f"jobs sizes the local cluster and must stay 1 with a scheduler, got jobs={jobs}")
    results.repair(csv_path)  # a row an interrupted write cut short goes, so that new rows start on a line
    results.check_header(csv_path)
    done = results.done_keys(csv_path)
    seen = set()
    todo = []
    for c in cases:
        if c.key not in done and c.key not in seen:
            seen.add(c.key)
            todo.append(c)
    os.makedirs(os.path.dirname(os.path.abspath(csv_path)), exist_ok=True)
    written = []
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(todo), desc=desc, unit="run", dynamic_ncols=True)
    with open(csv_path, "a", newline="", encoding="utf-8") as f:
        if f.tell() == 0:
            _append(f, results.header_line())

        def record(row):
            if "positions" in row:  # before the row: a row never names positions that are not there
                with atomic_write(results.positions_path(csv_path, row["key"]), "wb") as out:
                    np.save(out, np.asarray(row.pop("positions")))
            _append(f, results.format_line(row))
            written.append(row)
            if bar is not None:
                bar.update(1)
                bar.set_postfix_str(f"{row['scenario']}/{row['model']}: {row['outcome']}", refresh=False)

        if scheduler is None and jobs == 1:
            for c in todo:
                record(run_case(c))
        elif todo:
            with _connect(jobs, scheduler) as client:
                _run_on(client, todo, record)
    if bar is not None:
        bar.close()
    return written


def _append(f, line: str) -> None:
    """Append ``line`` to the open CSV ``f`` and put it on disk (flush and fsync) before the next run is recorded."""
    f.write(line)
    f.flush()
    os.fsync(f.fileno())


def default_jobs() -> int:
    """Worker processes to use by default: the CPU count (at least 1)."""
    return max(1, os.cpu_count() or 1)


def workers_of(args) -> tuple:
    """``(jobs, scheduler)`` for :func:`run_sweep` from the command line's ``args`` (``jobs``: int or None,
    ``scheduler``: address or None): a local cluster of ``--jobs`` (default :func:`default_jobs`) workers, or the
    cluster at ``--scheduler``.

    Raises:
      ValueError: both ``--jobs`` and ``--scheduler``.
    """
    jobs, scheduler = getattr(args, "jobs", None), getattr(args, "scheduler", None) or None
    if scheduler is None:
        return (default_jobs() if jobs is None else int(jobs)), None
    if jobs is not None:
        raise ValueError(f"--jobs sizes the local cluster and does not go with --scheduler {scheduler}, got --jobs "
                         f"{jobs}")
    return 1, scheduler


def describe_workers(*, jobs: int = 1, scheduler=None) -> str:
    """Where :func:`run_sweep` with these arguments runs the cases, in words (for reports)."""
    if isinstance(scheduler, distributed.Client):
        scheduler = scheduler.scheduler.address
    if scheduler is not None:
        return f"the workers of the Dask cluster at {scheduler}"
    if jobs == 1:
        return "1 process (no Dask)"
    return f"{jobs} worker processes (Dask LocalCluster)"


@contextlib.contextmanager
def _connect(jobs: int, scheduler):
    """A client of ``scheduler`` (address or client), or of a fresh local cluster of ``jobs`` single-threaded worker
    processes on 127.0.0.1 (no dashboard); closed on exit unless it was passed in."""
    if isinstance(scheduler, distributed.Client):
        yield scheduler
    elif scheduler is not None:
        with distributed.Client(scheduler) as client:
            yield client
    else:
        with dask.config.set({"distributed.scheduler.allowed-failures": ALLOWED_FAILURES}):
            cluster = distributed.LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True,
                                               host="127.0.0.1", dashboard_address=None,
                                               silence_logs=logging.ERROR)
        with cluster, distributed.Client(cluster) as client:
            yield client


def _run_on(client: distributed.Client, todo: Sequence[Case], record: Callable[[dict], None]) -> None:
    """Warm the particle models up on one worker (numba writes its cache once), then submit one task per case and
    record the rows as they complete. A case whose worker died gets a ``diverged`` row; any other exception of a
    task (a defect) cancels the rest and is raised here, as is an interrupt."""
    entries = {}  # model → the catalogue entry the tasks carry (None: left to the workers' own import)
    for c in todo:
        if c.model in case_mod.MODEL_LABELS:
            model = case_mod.resolve(c.model)[0]
            entries.setdefault(model, _shippable(catalog.get(model)))
    warm_up = client.submit(_warm_up_task, tuple(e for e in entries.values() if e is not None),
                            tuple(dict.fromkeys(c.model for c in todo)), pure=False)
    try:
        warm_up.result()
    except distributed.KilledWorker:  # a model that crashes its process: its cases will say so, row by row
        pass
    warm_up.release()
    pending = {}
    for c in todo:
        model = case_mod.resolve(c.model)[0] if c.model in case_mod.MODEL_LABELS else None
        pending[client.submit(_case_task, c, model, entries.get(model), pure=False)] = c
    try:
        for fut in distributed.as_completed(list(pending)):
            c = pending.pop(fut)
            try:
                row = fut.result()
            except distributed.KilledWorker as exc:  # e.g. a crash in compiled code: the case still gets its row
                row = results.empty_row(c)
                row.update(outcome="diverged", reason=f"worker failed: {type(exc).__name__}: {exc}")
            fut.release()
            record(row)
    except BaseException:  # a defect (or Ctrl-C): drop the runs not finished
        client.cancel(list(pending))
        raise


def _shippable(entry: catalog.ModelEntry) -> Optional[catalog.ModelEntry]:
    """``entry`` when it pickles (cloudpickle: closures and functions of ``__main__`` by value), else ``None``."""
    try:
        cloudpickle.dumps(entry)
    except Exception:  # noqa: BLE001 - any failure means: not shippable
        return None
    return entry


def _adopt(entries: Iterable[catalog.ModelEntry]) -> None:
    """Register the client's catalogue entries in this (worker) process, over any of the same name."""
    for entry in entries:
        catalog.register(entry, replace=True)


def _warm_up_task(entries: tuple, labels: Sequence[str]) -> None:
    """Worker task: adopt the client's entries, then :func:`~mjcable.bench.runner.warm_up_models`."""
    _adopt(entries)
    warm_up_models(label for label in labels if label in case_mod.MODEL_LABELS)


def _case_task(case: Case, model: Optional[str], entry: Optional[catalog.ModelEntry]) -> dict:
    """Worker task: run one case with the client's catalogue entry of its model (``model``: ``None`` for a label
    the client did not know, which the run rejects)."""
    if entry is not None:
        _adopt((entry,))
    if model is not None and model not in catalog.names():
        raise RuntimeError(f"model {model!r} is registered in the client only and its catalogue entry does not "
                           "pickle: register it with picklable functions, or run the sweep with jobs=1")
    return run_case(case)
