"""Head-to-head benchmarks and stress tests of the cable models.

Modules: :mod:`~mjcable.bench.case` (a run and the model labels), :mod:`~mjcable.bench.runner` (running one),
:mod:`~mjcable.bench.outcome` (how it ended), :mod:`~mjcable.bench.results` (the CSV), :mod:`~mjcable.bench.sweep`
(many runs, resumable), :mod:`~mjcable.bench.scenarios`, :mod:`~mjcable.bench.accuracy` (``bench``),
:mod:`~mjcable.bench.stress` (``stress``), :mod:`~mjcable.bench.plots` and :mod:`~mjcable.bench.videos` (a video of
each family that shows a feature, ``mjcable render --family``).

``mjcable bench`` (:func:`cli_bench`) runs every model on the accuracy scenarios and writes a CSV, work-precision
plots and Pareto tables; ``mjcable stress`` (:func:`cli_stress`) maps where each model diverges or tunnels.
``python -m mjcable.bench [bench|stress] [--quick] [--out DIR] [--jobs N | --scheduler ADDRESS]`` runs either
without the CLI. The runs go to ``dask.distributed`` (:mod:`~mjcable.bench.sweep`): a local cluster of ``--jobs``
worker processes, or an existing cluster at ``--scheduler``; this process writes the outputs.

Example::

    from mjcable import bench
    rows = bench.run_bench("bench_out", quick=True, jobs=2)
"""

from __future__ import annotations

import argparse
from typing import Optional, Sequence

from mjcable.bench.accuracy import cli_bench, run_bench
from mjcable.bench.stress import cli_stress, run_stress
from mjcable.bench.case import MODEL_LABELS, Case
from mjcable.bench.outcome import OUTCOMES
from mjcable.bench.results import read_rows
from mjcable.bench.runner import run_case
from mjcable.bench.sweep import run_sweep
from mjcable.bench import videos  # noqa: F401  (a video of each family that shows a feature: mjcable.bench.videos)

__all__ = [
    "cli_bench",
    "cli_stress",
    "run_bench",
    "run_stress",
    "run_case",
    "run_sweep",
    "read_rows",
    "Case",
    "MODEL_LABELS",
    "OUTCOMES",
    "add_arguments",
    "main",
]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the flags shared by ``bench`` and ``stress``: ``--quick``, ``--out``, ``--jobs`` or ``--scheduler``,
    ``--models``."""
    parser.add_argument("--quick", action="store_true", help="reduced sweep (bench < 4 min, stress < 10 min)")
    parser.add_argument("--out", default=None, help="output folder (default bench_out / stress_out)")
    workers = parser.add_mutually_exclusive_group()
    workers.add_argument("--jobs", type=int, default=None,
                         help="worker processes of a local Dask cluster (default: CPU count; 1: in this process)")
    workers.add_argument("--scheduler", default=None, metavar="ADDRESS",
                         help="run on the existing Dask cluster whose scheduler is at ADDRESS; this process writes "
                              "every output")
    parser.add_argument("--models", nargs="+", default=None, choices=list(MODEL_LABELS),
                        help="model labels to run (default all): every catalogue model, plus "
                             + ", ".join(f"{k} ({m} with {s})" for k, (m, s) in MODEL_LABELS.items() if s))


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``python -m mjcable.bench [bench|stress] [--quick] [--out DIR] [--jobs N | --scheduler ADDRESS]
    [--models ...]``."""
    parser = argparse.ArgumentParser(prog="python -m mjcable.bench", description=__doc__.splitlines()[0])
    parser.add_argument("command", nargs="?", default="bench", choices=("bench", "stress"))
    add_arguments(parser)
    args = parser.parse_args(argv)
    if args.jobs is not None and args.jobs < 1:
        parser.error(f"--jobs must be >= 1, got {args.jobs}")
    return cli_bench(args) if args.command == "bench" else cli_stress(args)
