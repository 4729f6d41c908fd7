"""Whole-step speed: ``Simulator.step(1.0)`` against the least work that does the same physics, on this machine.

Prints a markdown table (the README's "Speed" section shows one) of:

* ``hang`` (50 segments, ``xpbd`` with ``order="gauss-seidel", substeps=4, iterations=1``): ``step(1.0)``, 500
  steps from the start state, against :func:`minimal_loop` doing the same 2,000 substeps on the same particles;
* ``table`` (the same settings): ``step(1.0)`` with the cable lying on the table, against the compiled substep
  kernel plus the ``mj_collision`` queries the step made, on a second simulator's state; and ``step(1.0)`` from the
  start (the cable falls for 0.2 s first);
* cost against length: ``hang`` on ``xpbd`` (defaults) at 50, 400 and 1600 segments (:func:`bench_length.measure`);
* the Cosserat rod against ``xpbd`` (both defaults): ``step(1.0)`` from the start on ``hang`` and ``table`` at 50
  and 200 segments, side by side (:func:`bench_cosserat`; the issue's bar is 2×), and ``cosserat``'s ``hang`` at
  400 and 1600 segments (linear: 4×);
* several cables: four ``table`` cables of 50 segments side by side against one, ``xpbd`` defaults
  (:func:`bench_cables.measure`; the issue's bar is 4.5×);
* a resting cable: ``table`` at rest against ``hang``, 200 segments, ``xpbd`` defaults (:func:`bench_skip.measure`);
* ``mjcable bench``'s runner against ``Simulator.step(T)`` on the same case (:func:`bench_runner.measure_bench_vs_step`);
* every native model's ``step(1.0)`` on ``hang`` (their path is unchanged: this shows they keep their speed);
* the ``unplug`` environment on ``xpbd``: 200 control steps against a bare Simulator rebuilt from the environment's
  own, stepping the same simulated time (:func:`bench_env.bench`; the issue's bar is 1.3×);
* a :class:`mjcable.Batch` of 32 ``table`` cables on ``xpbd`` (defaults): ``step(1.0)`` on 2 threads against 1
  (:func:`bench_batch.measure`; the issue's bar is 1.7× on an idle 2-core machine).

Every time is the best of ``--repeats`` runs (default 3; the machine may be shared: the table states the load);
numba compile time is excluded (warm-up calls first, kernels cached on disk).

Usage::

    python scripts/bench_speed.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import time
import warnings

import mujoco
import numba
import numpy as np

import bench_batch  # scripts/bench_batch.py, beside this script
import bench_cables  # scripts/bench_cables.py, beside this script
import bench_env  # scripts/bench_env.py, beside this script
import bench_length  # scripts/bench_length.py, beside this script
import bench_runner  # scripts/bench_runner.py, beside this script
import bench_skip  # scripts/bench_skip.py, beside this script
import mjcable
from mjcable import catalog
from mjcable.backends.particle import ParticleBackend
from mjcable.solvers import kernels

SETTINGS = dict(order="gauss-seidel", substeps=4, iterations=1)  # the setting for both ratios
SECONDS = 1.0


@numba.njit(cache=True)
def minimal_loop(x, v, x0, w, rest, h, gz, n_sub):
    """The least a particle chain's substep can do: predict with gravity (no damping), one Gauss-Seidel sweep of
    mass-weighted distance projections (α = 0), velocity update; scalar code, no temporaries."""
    n = x.shape[0]
    for _ in range(n_sub):
        for i in range(n):
            x0[i, 0], x0[i, 1], x0[i, 2] = x[i, 0], x[i, 1], x[i, 2]
            if w[i] > 0.0:
                v[i, 2] += h * gz
                x[i, 0] += h * v[i, 0]
                x[i, 1] += h * v[i, 1]
                x[i, 2] += h * v[i, 2]
        for i in range(n - 1):
            dx, dy, dz = x[i, 0] - x[i + 1, 0], x[i, 1] - x[i + 1, 1], x[i, 2] - x[i + 1, 2]
            length = math.sqrt(dx * dx + dy * dy + dz * dz)
            wsum = w[i] + w[i + 1]
            if wsum == 0.0 or length == 0.0:
                continue
            s = (rest[i] - length) / (wsum * length)
            x[i, 0] += w[i] * s * dx
            x[i, 1] += w[i] * s * dy
            x[i, 2] += w[i] * s * dz
            x[i + 1, 0] -= w[i + 1] * s * dx
            x[i + 1, 1] -= w[i + 1] * s * dy
            x[i + 1, 2] -= w[i + 1] * s * dz
        inv_h = 1.0 / h
        for i in range(n):
            v[i, 0] = (x[i, 0] - x0[i, 0]) * inv_h
            v[i, 1] = (x[i, 1] - x0[i, 1]) * inv_h
            v[i, 2] = (x[i, 2] - x0[i, 2]) * inv_h


@numba.njit
def substep_loop(S, steps, substeps):
    """``steps`` × ``substeps`` of the particle solver's substep kernel on the solver state ``S``, in compiled code."""
    for _ in range(steps):
        for sub in range(substeps):
            kernels.substep(S, sub, substeps)


def _best(fn, repeats: int, prepare=None) -> float:
    """Least wall time of ``fn()`` in seconds over ``repeats`` runs (``prepare()`` untimed before each)."""
    return _best_pair(fn, None, repeats, prepare)[0]


def _best_pair(fn, other, repeats: int, prepare=None, prepare_other=None) -> tuple:
    """Least wall times of ``fn()`` and ``other()`` (``None``: not run) in seconds over ``repeats`` runs each,
    alternated so that a change of the machine's load hits both; ``prepare*()`` run untimed before each."""
    best = [math.inf, math.inf]
    for _ in range(repeats):
        for k, (f, prep) in enumerate(((fn, prepare), (other, prepare_other))):
            if f is None:
                continue
            if prep is not None:
                prep()
            t = time.perf_counter()
            f()
            best[k] = min(best[k], time.perf_counter() - t)
    return best[0], best[1]


def _start_arrays(scene, sim) -> tuple:
    """The hanging chain's start state as the minimal loop takes it: positions, velocities (zero), inverse masses
    (0 at the pins) and rest lengths, from the scene alone."""
    cable = scene.cable
    x = np.array(cable.particles, dtype=np.float64)
    w = 1.0 / np.array(cable.particle_masses, dtype=np.float64)
    w[[scene.pin_particle(k) for k in range(len(scene.pins))]] = 0.0
    return x, np.zeros_like(x), x.copy(), w, np.full(cable.n_segments, cable.segment_length)


def bench_hang(repeats: int) -> dict:
    """``step(1.0)`` on ``hang`` from the start state against :func:`minimal_loop` on the same particles."""
    scene = mjcable.scenes.get("hang")
    sim = mjcable.Simulator(scene, "xpbd", **SETTINGS)
    steps = int(round(SECONDS / sim.dt))
    x, v, x0, w, rest = _start_arrays(scene, sim)
    start = [a.copy() for a in (x, v)]
    h = sim.dt / sim.settings.substeps
    n_sub = steps * sim.settings.substeps
    gz = float(sim.mj_model.opt.gravity[2])

    def restore():
        np.copyto(x, start[0])
        np.copyto(v, start[1])

    sim.step(0.01)  # warm-up (compiles or loads the kernels)
    minimal_loop(x, v, x0, w, rest, h, gz, 1)
    minimal = lambda: minimal_loop(x, v, x0, w, rest, h, gz, n_sub)  # noqa: E731
    t_sim, t_min = _best_pair(lambda: sim.step(SECONDS), minimal, repeats, sim.reset, restore)
    assert sim.steps == steps
    return dict(sim=t_sim, minimal=t_min, steps=steps, substeps=n_sub)


def bench_table(repeats: int) -> dict:
    """``step(1.0)`` on ``table`` with the cable at rest on the table, against the substep kernel plus the
    ``mj_collision`` queries the step made (none while nothing moves: the last query's contacts are kept), on a
    particle backend's state and contacts (built directly, below the Simulator: the reference is the kernel
    alone); and ``step(1.0)`` from the start (the cable falls, lands and comes to rest)."""
    scene = mjcable.scenes.get("table")
    sim = mjcable.Simulator(scene, "xpbd", **SETTINGS)
    sim.step(0.01)
    t_start = _best(lambda: sim.step(SECONDS), repeats, prepare=sim.reset)
    sim.reset()
    sim.step(1.5)  # lying on the table
    before = sim.diagnostics["queries"]
    ref = ParticleBackend(scene, catalog.get("xpbd"), sim.dt, sim.settings)
    n = scene.cable.n_particles
    ref.run(int(round(1.5 / sim.dt)), rows=np.zeros(0, dtype=np.int64), out_x=np.zeros((0, n, 3)),
            out_v=np.zeros((0, n, 3)))
    S, arrays = ref.state, ref.arrays
    saved = {k: arrays[k].copy() for k in ("x", "v", "x0", "pin_from", "pin_to", "fric_n", "fric_mu", "fric_slid",
                                     "fric_nsum", "fric_impulse", "fric_normal", "fric_ob", "anchor", "anchor_ob")}
    steps = int(round(SECONDS / sim.dt))
    substeps = sim.settings.substeps
    m, d = ref.mj_model, ref.mj_data
    queries = {"n": 0}

    def restore():
        for k, a in saved.items():
            np.copyto(arrays[k], a)

    def timed():
        start = sim.diagnostics["queries"]
        sim.step(SECONDS)
        queries["n"] = sim.diagnostics["queries"] - start

    sim.step(SECONDS)  # the queries of a second at rest, which the reference makes too
    queries["n"] = sim.diagnostics["queries"] - before

    def reference():
        for k in range(queries["n"]):
            mujoco.mj_collision(m, d)
        substep_loop(S, steps, substeps)

    t_sim, t_ref = _best_pair(timed, reference, repeats, prepare_other=restore)
    return dict(sim=t_sim, reference=t_ref, start=t_start, contacts=sim.diagnostics["contacts"],
                ref_contacts=ref.diagnostics()["contacts"], steps=steps, queries=queries["n"])


def bench_native(repeats: int) -> dict:
    """Every native model's ``step(1.0)`` on ``hang`` (default settings) from the start state."""
    scene = mjcable.scenes.get("hang")
    out = {}
    for model in catalog.names("native"):
        try:
            sim = mjcable.Simulator(scene, model)
        except (NotImplementedError, ImportError) as exc:  # a model not written yet
            out[model] = exc
            continue
        sim.step(0.01)
        out[model] = _best(lambda: sim.step(SECONDS), repeats, prepare=sim.reset)
    return out


def bench_cosserat(repeats: int) -> dict:
    """``step(1.0)`` from the start of ``cosserat`` and ``xpbd`` (defaults) on ``hang`` and ``table`` at 50 and 200
    segments, alternated run by run ({(scene, n): (cosserat s, xpbd s)})."""
    out = {}
    for name in ("hang", "table"):
        for n in (50, 200):
            with warnings.catch_warnings():  # the default radius exceeds a fine chain's segment: contacts still work
                warnings.simplefilter("ignore", UserWarning)
                scene = mjcable.scenes.get(name, n_segments=n)
            sims = [mjcable.Simulator(scene, model) for model in ("cosserat", "xpbd")]
            for sim in sims:
                sim.step(0.01)  # warm-up (compiles or loads the kernels)
            step = [lambda sim=sim: sim.step(SECONDS) for sim in sims]
            out[name, n] = _best_pair(step[0], step[1], repeats, sims[0].reset, sims[1].reset)
    return out


def _machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg()) if hasattr(os, "getloadavg") else "n/a"
    return (f"{cpu}, {os.cpu_count()} cores, load average {load} (1, 5, 15 min); Python "
            f"{platform.python_version()}, numpy {np.__version__}, numba {numba.__version__}, "
            f"mujoco {mujoco.__version__}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3, help="runs per measurement; the best counts (default 3)")
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error(f"--repeats must be >= 1, got {args.repeats}")
    ms = 1e3
    setting = ", ".join(f"{k}={v!r}" for k, v in SETTINGS.items())
    print(f"Machine: {_machine()}")
    print(f"Best of {args.repeats}.\n")
    print("| measurement | time | reference | ratio |")
    print("|---|---:|---:|---:|")
    h = bench_hang(args.repeats)
    print(f"| `hang`, 50 segments, xpbd ({setting}): `step(1.0)` ({h['steps']} steps) vs minimal numba loop "
          f"({h['substeps']} substeps) | {h['sim'] * ms:.2f} ms | {h['minimal'] * ms:.2f} ms | "
          f"{h['sim'] / h['minimal']:.2f}× |")
    t = bench_table(args.repeats)
    print(f"| `table`, 50 segments, same settings, at rest on the table ({t['contacts']} contacts, {t['queries']} "
          f"queries): `step(1.0)` vs the substep kernel + the `mj_collision` queries it made ({t['ref_contacts']} "
          f"contacts) | {t['sim'] * ms:.2f} ms | "
          f"{t['reference'] * ms:.2f} ms | {t['sim'] / t['reference']:.2f}× |")
    print(f"| `table`, same settings: `step(1.0)` from the start (falls, then lands) | {t['start'] * ms:.2f} ms | "
          f"| |")
    e = bench_env.bench("unplug", "xpbd", repeats=max(args.repeats, 3))
    print(f"| `unplug` environment, xpbd (defaults): 200 control steps of a seeded random policy vs a bare Simulator "
          f"rebuilt from the environment's own, stepping the same simulated time ({e['env_rate']:,.0f} vs "
          f"{e['bare_rate']:,.0f} control steps/s) | {e['env_s'][0] * ms:.2f} ms | {e['bare_s'][0] * ms:.2f} ms | "
          f"{e['ratio']:.2f}× |")
    b = bench_batch.measure("xpbd", n=32, seconds=SECONDS, threads=(1, 2), repeats=args.repeats)
    print(f"| `mjcable.Batch` of 32 `table` cables, xpbd (defaults): `step(1.0)` on 2 threads vs 1 (ratio: 1-thread "
          f"time / 2-thread time; {b['throughput'][2]:,.0f} vs {b['throughput'][1]:,.0f} cable-steps/s; copy 0 "
          f"{'equals' if b['identical'] else 'DIFFERS FROM'} a Simulator) | {b['times'][2] * ms:.2f} ms | "
          f"{b['times'][1] * ms:.2f} ms | {b['times'][1] / b['times'][2]:.2f}× |")
    lengths = bench_length.measure(ns=(50, 400, 1600), repeats=args.repeats)
    print(f"| `hang`, xpbd (defaults), wall s per simulated s at 1600 segments vs 400 (50: "
          f"{lengths[50]:.4f} s/s) | {lengths[1600]:.4f} s/s | {lengths[400]:.4f} s/s | "
          f"{lengths[1600] / lengths[400]:.2f}× |")
    for (name, n), (t_rod, t_xpbd) in bench_cosserat(args.repeats).items():
        print(f"| `{name}`, {n} segments: cosserat vs xpbd (defaults), `step(1.0)` from the start | "
              f"{t_rod * ms:.2f} ms | {t_xpbd * ms:.2f} ms | {t_rod / t_xpbd:.2f}× |")
    rods = bench_length.measure(ns=(400, 1600), repeats=args.repeats, model="cosserat")
    print(f"| `hang`, cosserat (defaults), wall s per simulated s at 1600 segments vs 400 | {rods[1600]:.4f} s/s | "
          f"{rods[400]:.4f} s/s | {rods[1600] / rods[400]:.2f}× |")
    rest = bench_skip.measure(model="xpbd", n_segments=200, repeats=args.repeats)
    print(f"| `table` at rest, 200 segments, xpbd (defaults): `step(1.0)` vs the same cable's `hang` `step(1.0)` "
          f"({rest['queries_per_step']:.2f} queries per step, {rest['contacts']} contacts) | "
          f"{rest['table_s'] * ms:.2f} ms | {rest['hang_s'] * ms:.2f} ms | {rest['ratio']:.2f}× |")
    c = bench_cables.measure("xpbd", repeats=args.repeats)
    print(f"| four `table` cables of 50 segments side by side vs one, xpbd (defaults): `step(1.0)` from the start "
          f"| {c['several'] * ms:.2f} ms | {c['one'] * ms:.2f} ms | {c['ratio']:.2f}× |")
    r = bench_runner.measure_bench_vs_step(model="xpbd", repeats=args.repeats)
    print(f"| `mjcable bench`'s runner on the catenary (50 segments), xpbd (defaults): wall s per simulated s vs "
          f"`Simulator.step(T)` of the same case | {r['bench_wall_per_sim_s']:.4f} s/s | "
          f"{r['step_wall_per_sim_s']:.4f} s/s | {r['ratio']:.2f}× |")
    for model, sec in bench_native(args.repeats).items():
        shown = f"{sec * ms:.2f} ms" if isinstance(sec, float) else f"unavailable ({type(sec).__name__})"
        print(f"| `hang`, 50 segments, {model} (native, defaults): `step(1.0)` | {shown} | | |")


if __name__ == "__main__":
    main()
