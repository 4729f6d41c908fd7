"""How much slower a dm_control cable environment's control step is than the bare physics it runs.

Times ``--steps`` control steps of an environment (``mjcable.envs.load(task, model, random=seed)``, a seeded random
policy whose actions are each held for ``--hold`` control steps, so the grippers also run into the workspace's
walls) against a bare :class:`mjcable.Simulator` rebuilt from the environment's own (``physics.simulator``: the same
scene, ``dt`` and settings) stepping the same simulated time, ``control_timestep`` per call. Each is timed
``--repeats`` times from its start state, interleaved, and the best run of each counts. Prints control steps per
second of both and their ratio (environment time over bare time; issue 11 asks for at most 1.3 on ``unplug`` with
``xpbd``), in wall-clock time and in this process's CPU time (``time.process_time``: steadier on a shared machine).

The bare Simulator's cable does not do what the environment's does (its gripper stays put, its socket holds), so
part of the ratio is physics, not the environment's Python: a third Simulator, the "replay", makes the
:meth:`mjcable.Simulator.step_along` calls (the same gripper paths) that one run of the environment made, recorded
before the timed runs (an episode's physics depends on the actions only, for tasks whose scene does not change between
episodes, as ``unplug``'s), and environment over replay is the environment's own cost. ``--profile`` also prints where the environment's time
goes (cProfile, top entries).

Usage::

    MUJOCO_GL=egl python scripts/bench_env.py                      # unplug, xpbd
    MUJOCO_GL=egl python scripts/bench_env.py --task drape --model pbd --profile
"""

from __future__ import annotations

import argparse
import cProfile
import dataclasses
import pstats
import sys
import time

import numpy as np

import mjcable
from mjcable import envs

BAR = 1.3  # issue 11: the unplug environment's control step at most this many times the bare Simulator's


def _timed(run) -> tuple:
    """(wall-clock seconds, CPU seconds of this process) that ``run()`` took."""
    wall, cpu = time.perf_counter(), time.process_time()
    run()
    return time.perf_counter() - wall, time.process_time() - cpu


def bench(task: str = "unplug", model: str = "xpbd", *, steps: int = 200, hold: int = 10, repeats: int = 5,
          seed: int = 0) -> dict:
    """Best-of-``repeats`` seconds for ``steps`` control steps of the environment, of the bare Simulator and of the
    replay of the environment's gripper paths.

    Returns:
      ``{"env_s", "bare_s", "replay_s"}``, each (wall-clock, CPU) seconds, ``"env_rate", "bare_rate"`` control steps
      per wall-clock second, ``"ratio"`` and ``"cpu_ratio"`` (environment over bare), ``"own_ratio"`` (environment
      over replay, CPU) and whether the random policy pulled a socket out (``"released"``, the last environment run).
    """
    env = envs.load(task, model, random=seed, time_limit=10.0 * steps)  # no episode ends inside a timed run
    spec = env.action_spec()
    rng = np.random.default_rng(seed)
    actions = [a for a in (rng.uniform(spec.minimum, spec.maximum, spec.shape) for _ in range(-(-steps // hold)))
               for _ in range(hold)][:steps]
    env.reset()
    for a in actions[: 2 * hold]:  # warm up: compiled kernels, caches
        env.step(a)
    sim = env.physics.simulator
    bare, replay = (mjcable.Simulator(sim.scene, sim.model, dt=sim.dt, **dataclasses.asdict(sim.settings))
                    for _ in range(2))
    control_timestep = env.control_timestep()
    bare.step(2 * hold * control_timestep)
    calls = []  # the environment's step_along calls of its last run: (path taken, keywords)
    step_along = sim.step_along

    def recording(path, **kwargs):
        taken = step_along(path, **kwargs)
        calls.append((np.array(path[:taken]), kwargs))
        return taken

    def run_env():
        for a in actions:
            env.step(a)

    def run_bare():
        for _ in range(steps):
            bare.step(control_timestep)

    def run_replay():
        for path, kwargs in calls:
            replay.step_along(path, **kwargs)

    sim.step_along = recording  # this instance only; the same call, plus a copy of the path taken
    env.reset()
    run_env()
    sim.step_along = step_along
    run_replay()  # warm up the replay's path through the loop
    times = {"env_s": [], "bare_s": [], "replay_s": []}
    for _ in range(repeats):
        env.reset()
        times["env_s"].append(_timed(run_env))
        bare.reset()
        times["bare_s"].append(_timed(run_bare))
        replay.reset()
        times["replay_s"].append(_timed(run_replay))
    best = {k: (min(t[0] for t in v), min(t[1] for t in v)) for k, v in times.items()}
    (e, ec), (b, bc), (_, rc) = best["env_s"], best["bare_s"], best["replay_s"]
    return {**best, "env_rate": steps / e, "bare_rate": steps / b, "ratio": e / b, "cpu_ratio": ec / bc,
            "own_ratio": ec / rc, "released": bool(env.physics.simulator.released)}


def profile(task: str, model: str, *, steps: int, hold: int, seed: int, top: int = 25) -> None:
    """Print cProfile's top entries (cumulative time) of ``steps`` control steps of the environment."""
    env = envs.load(task, model, random=seed, time_limit=10.0 * steps)
    spec = env.action_spec()
    rng = np.random.default_rng(seed)
    actions = [rng.uniform(spec.minimum, spec.maximum, spec.shape) for _ in range(-(-steps // hold))]
    env.reset()
    env.step(actions[0])
    profiler = cProfile.Profile()
    profiler.enable()
    for k in range(steps):
        env.step(actions[k // hold])
    profiler.disable()
    pstats.Stats(profiler, stream=sys.stdout).sort_stats("cumulative").print_stats(top)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="unplug", choices=envs.names())
    parser.add_argument("--model", default="xpbd", help="a model of mjcable.catalog (default xpbd)")
    parser.add_argument("--steps", type=int, default=200, help="control steps per timed run (default 200)")
    parser.add_argument("--hold", type=int, default=10, help="control steps each random action is held")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs of each; the best counts (default 5)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--profile", action="store_true", help="also print the environment's cProfile")
    args = parser.parse_args(argv)
    for name in ("steps", "hold", "repeats"):
        if getattr(args, name) < 1:
            parser.error(f"--{name} must be an integer >= 1, got {getattr(args, name)}")
    r = bench(args.task, args.model, steps=args.steps, hold=args.hold, repeats=args.repeats, seed=args.seed)
    print(f"{args.task} on {args.model}, {args.steps} control steps, best of {args.repeats}"
          f"{' (the socket let go)' if r['released'] else ''}:")
    print(f"  environment      {r['env_rate']:8.0f} control steps/s")
    print(f"  bare Simulator   {r['bare_rate']:8.0f} control steps/s (same simulated time per step)")
    print(f"  ratio            {r['ratio']:8.2f} x   (issue 11's bar: <= {BAR:g} on unplug with xpbd)")
    print(f"  ratio, CPU time  {r['cpu_ratio']:8.2f} x")
    print(f"  environment over the replay of its gripper paths (its own cost, CPU time): {r['own_ratio']:.2f} x")
    if args.profile:
        profile(args.task, args.model, steps=args.steps, hold=args.hold, seed=args.seed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
