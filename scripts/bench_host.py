"""The user-world host's control step: the ``jaco_unplug`` environment with a particle model, its host substeps in
one compiled call (:func:`mjcable.solvers.host_kernels.host_substeps`) against the Python loop (``Host.compiled =
False``).

Each run loads the environment (``mjcable.envs.load(task, model, random=0)``), resets it and takes ``--steps``
control steps of seeded random actions (``rng.uniform(spec.minimum, spec.maximum, spec.shape)``, one per step); the
two paths are timed interleaved, ``--repeats`` times each, and the best run of each counts (the machine may be
shared). Prints ms per control step of both and their ratio.

Usage::

    MUJOCO_GL=egl python scripts/bench_host.py                       # jaco_unplug, xpbd, 50 steps, best of 3
    MUJOCO_GL=egl python scripts/bench_host.py --model pbd --steps 100
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mjcable import envs
from mjcable.backends.host import Host


def _run(env, actions) -> float:
    """Seconds for the control steps of ``actions`` from a reset."""
    env.reset()
    start = time.perf_counter()
    for a in actions:
        env.step(a)
    return time.perf_counter() - start


def bench(task: str = "jaco_unplug", model: str = "xpbd", *, steps: int = 50, repeats: int = 3,
          seed: int = 0) -> dict:
    """Best-of-``repeats`` ms per control step with the compiled host and with the Python loop."""
    env = envs.load(task, model, random=0)
    rng = np.random.default_rng(seed)
    spec = env.action_spec()
    actions = [rng.uniform(spec.minimum, spec.maximum, spec.shape) for _ in range(steps)]
    best = {True: np.inf, False: np.inf}
    saved = Host.compiled
    try:
        for compiled in (True, False):  # warm-up: compile and touch everything once
            Host.compiled = compiled
            _run(env, actions[:2])
        for _ in range(repeats):
            for compiled in (True, False):
                Host.compiled = compiled
                best[compiled] = min(best[compiled], _run(env, actions))
    finally:
        Host.compiled = saved
    return {"compiled_ms": 1e3 * best[True] / steps, "python_ms": 1e3 * best[False] / steps}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="jaco_unplug")
    parser.add_argument("--model", default="xpbd")
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    r = bench(args.task, args.model, steps=args.steps, repeats=args.repeats, seed=args.seed)
    print(f"{args.task} {args.model}: compiled host {r['compiled_ms']:.2f} ms per control step, Python host "
          f"{r['python_ms']:.2f} ms ({r['python_ms'] / r['compiled_ms']:.2f}x)")


if __name__ == "__main__":
    main()
