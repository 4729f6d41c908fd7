"""Speed of the particle solvers: XPBD's substep against a minimal scalar numba Gauss-Seidel loop, and the table
scene's step with contacts, split into MuJoCo's contact query and the projection.

Usage::

    python scripts/bench_solvers.py            # the two measurements
    python scripts/bench_solvers.py --proxy    # also: explicit pairs vs free-joint proxies in mj_collision

Every number is the minimum over ``--repeats`` runs (the machine may be shared); numba compile time is excluded
(warm-up calls first; kernels are cached on disk).
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import mujoco
import numpy as np

import mjcable
from mjcable import catalog
from mjcable.mjcf import proxy
from mjcable.solvers import kernels, query_kernels, state
from mjcable.solvers.contacts import ObstacleContacts

from bench_speed import minimal_loop  # the same minimal loop as the speed benchmark (scripts/ is on sys.path)

GRAVITY_Z = -9.81


def _best(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def _per_call(fn, calls: int, repeats: int) -> float:
    return _best(lambda: [fn() for _ in range(calls)], repeats) / calls


def _xpbd_chain(scene, dt: float, **settings) -> tuple:
    """The XPBD solver state of ``scene`` built the way the particle backend builds it: ``(chain, settings, h)``."""
    entry = catalog.get("xpbd")
    s = catalog.make_settings("xpbd", **settings)
    h = dt / s.substeps
    rules = entry.rules(scene, s, h)
    return state.new_chain(scene, rules, s, dt), s, h


def _simulator_step(sim, calls: int, repeats: int) -> dict:
    """``sim.step()`` per call, and its split into the backend's contact query, solve and proxy sync per step
    (from ``sim.diagnostics``, which accumulates them)."""
    before, steps = sim.diagnostics, sim.steps
    t_step = _per_call(sim.step, calls, repeats)
    after = sim.diagnostics
    n = sim.steps - steps
    split = {k: (after[f"{k}_s"] - before[f"{k}_s"]) / n for k in ("query", "solve", "sync") if f"{k}_s" in after}
    return {"step": t_step, **split}


def bench_substep(repeats: int, batch: int = 2000, dt: float = 0.002) -> dict:
    """One XPBD substep, 100 particles, one iteration, no contacts (the hang scene, pinned at both ends), in the
    Gauss-Seidel order (like the minimal loop) and the direct order; and ``Simulator.step`` at one substep."""
    scene = mjcable.scenes.get("hang", n_segments=99)
    out = {}
    for order in ("gauss-seidel", "direct"):
        S, _, h = _xpbd_chain(scene, dt, substeps=1, iterations=1, order=order)
        C = state.empty_contacts()
        kernels.run_substeps_flat(*S, *C, int(round(0.1 / h)), kernels.PHASE_ALL, 0)  # hang for 0.1 s
        if order == "gauss-seidel":
            x, v, w = S.x.copy(), S.v.copy(), S.w.copy()
            x0 = x.copy()
            rest = S.rest.copy()
            minimal_loop(x, v, x0, w, rest, h, GRAVITY_Z, 1)
            out["minimal"] = _best(lambda: minimal_loop(x, v, x0, w, rest, h, GRAVITY_Z, batch), repeats) / batch
            out["kernel_call"] = _per_call(lambda: kernels.run_substeps_flat(*S, *C, 1, kernels.PHASE_ALL, 0), 2000,
                                           repeats)
        out[order] = _best(lambda: kernels.run_substeps_flat(*S, *C, batch, kernels.PHASE_ALL, 0), repeats) / batch
    sim = mjcable.Simulator(scene, "xpbd", dt=dt, substeps=1, iterations=1, order="gauss-seidel")
    sim.step(0.1)
    out["simulator"] = _simulator_step(sim, 2000, repeats)
    return out


def bench_table(repeats: int, substeps: int = 10, batch: int = 500) -> dict:
    """The table scene at rest on the table (xpbd at its defaults but ``substeps``, 50 segments): one step's
    contact query and one substep's projection with and without its contacts, on solver state built like the
    backend's from the settled simulator's positions and velocities; and ``Simulator.step`` split by
    ``sim.diagnostics``."""
    scene = mjcable.scenes.get("table")
    sim = mjcable.Simulator(scene, "xpbd", substeps=substeps)
    sim.step(1.5)
    S, s, h = _xpbd_chain(scene, sim.dt, **dataclasses.asdict(sim.settings))
    np.copyto(S.x, sim.positions)
    np.copyto(S.v, sim.velocities)
    # the proxy (one capsule per segment) posed from the particles, and the obstacle contacts it finds
    m = catalog.get("xpbd").build(scene, s, sim.dt).compile()
    d = mujoco.MjData(m)
    n = scene.cable.n_segments
    geoms = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, proxy.segment_name(i)) for i in range(n)])
    query_kernels.proxy_poses(S.x, d.mocap_pos[:n], d.mocap_quat[:n])
    mujoco.mj_kinematics(m, d)
    obstacles = ObstacleContacts(scene, m, d, geoms)
    margin = s.contact_margin + 0.5 * 9.81 * sim.dt**2  # at rest: the margin and one step's fall
    none = state.empty_contacts()
    C = obstacles.query(S.x, margin, none)
    saved = [a.copy() for a in S]

    def restore():
        for a, b in zip(S, saved):
            a[...] = b

    t_query = _per_call(lambda: obstacles.query(S.x, margin, none), 500, repeats)
    t_collision = _per_call(lambda: mujoco.mj_collision(m, d), 500, repeats)
    kernels.run_substeps_flat(*S, *C, 1, kernels.PHASE_ALL, 0)
    restore()
    t_with = _best(lambda: kernels.run_substeps_flat(*S, *C, batch, kernels.PHASE_ALL, 0), repeats) / batch
    restore()
    t_without = _best(lambda: kernels.run_substeps_flat(*S, *none, batch, kernels.PHASE_ALL, 0), repeats) / batch
    restore()
    return dict(contacts=len(C.seg), query=t_query, mj_collision=t_collision, substep=t_with,
                substep_no_contacts=t_without, simulator=_simulator_step(sim, 500, repeats), substeps=substeps,
                order=s.order)


def bench_proxy(repeats: int) -> dict:
    """mj_collision with explicit pairs (mocap capsules) vs free-joint capsules: table scene, 100 segments, the
    cable lying on the table and lifted 0.3 m into the air."""
    scene = mjcable.scenes.get("table", n_segments=100)
    c = scene.cable
    p = c.particles.copy()
    p[:, 2] = 0.75 + 0.9 * c.radius
    pos = np.zeros((c.n_segments, 3))
    quat = np.zeros((c.n_segments, 4))
    query_kernels.proxy_poses(p, pos, quat)
    out = {}
    for kind in proxy.PROXY_KINDS:
        m = proxy.build(scene, dt=0.002, proxy=kind).compile()
        d = mujoco.MjData(m)
        for where, lift in (("contact", 0.0), ("air", 0.3)):
            if kind == "pairs":
                d.mocap_pos[: c.n_segments] = pos + [0, 0, lift]
                d.mocap_quat[: c.n_segments] = quat
            else:
                qpos = d.qpos.reshape(-1, 7)
                qpos[:, :3] = pos + [0, 0, lift]
                qpos[:, 3:] = quat
            mujoco.mj_kinematics(m, d)
            out[kind, where] = _per_call(lambda: mujoco.mj_collision(m, d), 1000, repeats), d.ncon
    return out


def _print_simulator(t: dict, label: str) -> None:
    us = 1e6
    print(f"  {label:40s} {t['step'] * us:8.2f} µs   (backend: query {t['query'] * us:.2f}, solve "
          f"{t['solve'] * us:.2f}, sync {t['sync'] * us:.2f} µs; the rest is the Simulator's checks)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--proxy", action="store_true", help="also compare pairs with free-joint proxies")
    args = parser.parse_args()
    us = 1e6
    s = bench_substep(args.repeats)
    print("XPBD substep, 100 particles, 1 iteration, no contacts")
    print(f"  minimal scalar numba Gauss-Seidel loop   {s['minimal'] * us:8.2f} µs")
    for order in ("gauss-seidel", "direct"):
        print(f"  mjcable xpbd substep, {order:12s}      {s[order] * us:8.2f} µs   ratio {s[order] / s['minimal']:.2f}")
    print(f"  one kernel call, 1 substep               {s['kernel_call'] * us:8.2f} µs   (numba dispatch included)")
    _print_simulator(s["simulator"], "Simulator.step (1 substep, Gauss-Seidel)")
    t = bench_table(args.repeats)
    print(f"table scene, xpbd ({t['order']}), 50 segments at rest, {t['contacts']} contacts, {t['substeps']} "
          "substeps × 1 iteration")
    print(f"  contact query per step                   {t['query'] * us:8.2f} µs   (mj_collision alone "
          f"{t['mj_collision'] * us:.2f} µs)")
    print(f"  substep with contacts                    {t['substep'] * us:8.2f} µs")
    print(f"  substep without contacts                 {t['substep_no_contacts'] * us:8.2f} µs   "
          f"(contact projection {(t['substep'] - t['substep_no_contacts']) * us:.2f} µs)")
    _print_simulator(t["simulator"], f"Simulator.step ({t['substeps']} substeps)")
    if args.proxy:
        p = bench_proxy(args.repeats)
        print("mj_collision, table scene, 100 segments")
        for (kind, where), (sec, ncon) in p.items():
            print(f"  {kind:5s} {where:8s} {sec * us:8.2f} µs   {ncon} contacts")


if __name__ == "__main__":
    main()
