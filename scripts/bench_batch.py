"""Throughput of :class:`mjcable.Batch` on 1 and on 2 threads: ``n`` copies of the ``table`` scene stepped together.

For each model: a ``Batch`` of ``--n`` (default 32) ``table`` cables (default settings) per thread count, each
timed ``batch.step(--seconds)`` from the start state (the cables fall onto the table and lie there; every step
queries contacts once they touch), best of ``--repeats`` (default 3), the thread counts alternated so that a change
of the machine's load hits all of them. Prints throughput in cable-steps per second (copies × steps / wall time),
the ratio to 1 thread (the issue's bar: 2 threads >= 1.7× 1 thread for ``xpbd`` on an idle 2-core machine) and
the load average, and checks that copy 0 equals a single :class:`mjcable.Simulator` bit for bit.

``--env TASK`` measures :class:`mjcable.envs.BatchEnv` the same way instead: ``--n`` environments of ``TASK`` on
the model, ``--seconds`` of control steps of a seeded random policy from ``reset()``, in environment control steps
per second.

Usage::

    python scripts/bench_batch.py                       # xpbd, 32 cables, 1.0 s, threads 1 and 2
    python scripts/bench_batch.py --model joints --seconds 0.2
    python scripts/bench_batch.py --env reach_sag --n 8 --seconds 1.0
"""

from __future__ import annotations

import argparse
import math
import os
import time

import numpy as np

import mjcable

SCENE = "table"


def _load() -> str:
    return ", ".join(f"{x:.2f}" for x in os.getloadavg()) if hasattr(os, "getloadavg") else "n/a"


def measure(model: str = "xpbd", *, n: int = 32, seconds: float = 1.0, threads=(1, 2), repeats: int = 3) -> dict:
    """Best wall time of ``Batch(table, model, n, threads=t).step(seconds)`` from the start state per ``t``.

    Returns:
      ``{"times": {t: seconds}, "throughput": {t: cable-steps/s}, "steps": steps per copy, "identical": whether
      copy 0 after the step equals a single Simulator's positions bit for bit, "load": load average at the end}``.
    """
    scene = mjcable.scenes.get(SCENE)
    batches = {t: mjcable.Batch(scene, model, n, threads=t) for t in threads}
    for b in batches.values():  # warm-up: kernels compiled or loaded, worker threads started
        b.step(0.01)
    best = {t: math.inf for t in threads}
    for _ in range(repeats):
        for t, b in batches.items():
            b.reset()
            start = time.perf_counter()
            b.step(seconds)
            best[t] = min(best[t], time.perf_counter() - start)
    steps = next(iter(batches.values())).steps
    single = mjcable.Simulator(scene, model)
    single.step(seconds)
    identical = all(np.array_equal(b.positions[0], single.positions) for b in batches.values())
    for b in batches.values():
        b.close()
    return {"times": best, "throughput": {t: n * steps / best[t] for t in threads}, "steps": steps,
            "identical": identical, "load": _load()}


def measure_env(task: str, model: str = "xpbd", *, n: int = 8, seconds: float = 1.0, threads=(1, 2),
                repeats: int = 3) -> dict:
    """Best wall time of ``seconds`` of control steps (a seeded uniform random policy) of ``load_batch(task, model,
    n, threads=t)`` from ``reset()``, per ``t``. Returns ``{"times", "throughput" (env control steps/s), "steps"
    (control steps per environment), "load"}``."""
    batches = {t: mjcable.envs.load_batch(task, model, n, random=0, threads=t, time_limit=seconds) for t in threads}
    spec = next(iter(batches.values())).action_spec()
    steps = int(round(seconds / next(iter(batches.values())).envs[0].control_timestep()))
    actions = np.random.default_rng(0).uniform(spec.minimum, spec.maximum, (steps, n) + spec.shape)
    best = {t: math.inf for t in threads}
    for _ in range(repeats):
        for t, b in batches.items():
            b.reset()
            start = time.perf_counter()
            for a in actions:
                b.step(a)
            best[t] = min(best[t], time.perf_counter() - start)
    for b in batches.values():
        b.close()
    return {"times": best, "throughput": {t: n * steps / best[t] for t in threads}, "steps": steps, "load": _load()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", action="append", help="model(s) to measure (default xpbd; repeat the flag)")
    parser.add_argument("--n", type=int, default=32, help="copies per batch (default 32)")
    parser.add_argument("--seconds", type=float, default=1.0, help="simulated seconds per run (default 1.0)")
    parser.add_argument("--threads", default="1,2", help="comma-separated thread counts (default 1,2)")
    parser.add_argument("--repeats", type=int, default=3, help="runs per measurement; the best counts (default 3)")
    parser.add_argument("--env", help="measure mjcable.envs.BatchEnv on this task instead")
    args = parser.parse_args()
    threads = tuple(int(t) for t in args.threads.split(","))
    if args.repeats < 1 or args.n < 1 or min(threads) < 1 or not args.seconds > 0:
        parser.error("--repeats, --n and --threads must be >= 1 and --seconds > 0")
    print(f"{os.cpu_count()} cores, load average {_load()} (1, 5, 15 min) at the start; best of {args.repeats}.\n")
    if args.env:
        print("| task | model | environments × control steps | threads | wall time | env steps/s | ratio to 1 thread |")
        print("|---|---|---:|---:|---:|---:|---:|")
        for model in args.model or ["xpbd"]:
            r = measure_env(args.env, model, n=args.n, seconds=args.seconds, threads=threads, repeats=args.repeats)
            for t in threads:
                print(f"| {args.env} | {model} | {args.n} × {r['steps']} | {t} | {r['times'][t] * 1e3:.0f} ms | "
                      f"{r['throughput'][t]:,.1f} | {r['throughput'][t] / r['throughput'][threads[0]]:.2f}× |")
            print(f"\nload average after {model}: {r['load']}")
        return
    print("| model | copies × steps | threads | wall time | cable-steps/s | ratio to 1 thread | copy 0 == Simulator |")
    print("|---|---:|---:|---:|---:|---:|---|")
    for model in args.model or ["xpbd"]:
        r = measure(model, n=args.n, seconds=args.seconds, threads=threads, repeats=args.repeats)
        base = r["throughput"][threads[0]]
        for t in threads:
            print(f"| {model} | {args.n} × {r['steps']} | {t} | {r['times'][t] * 1e3:.0f} ms | "
                  f"{r['throughput'][t]:,.0f} | {r['throughput'][t] / base:.2f}× | "
                  f"{'yes' if r['identical'] else 'NO'} |")
        print(f"\nload average after {model}: {r['load']}")
        if not r["identical"]:
            raise SystemExit(f"copy 0 of the {model} batch differs from a single Simulator")


if __name__ == "__main__":
    main()
