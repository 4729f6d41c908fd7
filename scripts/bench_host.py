"""The user-world host's control step: the ``jaco_unplug`` environment (the Jaco arm stepped by MuJoCo once per
solver substep, :mod:`mjcable.backends.host`) on a particle model against a native model on the same task.

Each run loads the environment (``mjcable.envs.load(task, model, random=0)``), resets it and takes ``--steps``
control steps of seeded random actions (``rng.uniform(spec.minimum, spec.maximum, spec.shape)``, one per step); the
models are timed interleaved, ``--repeats`` times each, and the best run of each counts (the machine may be
shared). Prints ms per control step of each.

Usage::

    MUJOCO_GL=egl python scripts/bench_host.py                          # jaco_unplug: xpbd and joints, 50 steps
    MUJOCO_GL=egl python scripts/bench_host.py --models pbd flexrod --steps 100
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mjcable import envs


def _run(env, actions) -> float:
    """Seconds for the control steps of ``actions`` from a reset."""
    env.reset()
    start = time.perf_counter()
    for a in actions:
        env.step(a)
    return time.perf_counter() - start


def bench(task: str = "jaco_unplug", models=("xpbd", "joints"), *, steps: int = 50, repeats: int = 3,
          seed: int = 0) -> dict:
    """Best-of-``repeats`` ms per control step of each model (``{model: ms}``)."""
    loaded = {m: envs.load(task, m, random=0) for m in models}
    spec = next(iter(loaded.values())).action_spec()
    rng = np.random.default_rng(seed)
    actions = [rng.uniform(spec.minimum, spec.maximum, spec.shape) for _ in range(steps)]
    best = {m: np.inf for m in models}
    for env in loaded.values():  # warm-up: compile and touch everything once
        _run(env, actions[:2])
    for _ in range(repeats):
        for m, env in loaded.items():
            best[m] = min(best[m], _run(env, actions))
    return {m: 1e3 * t / steps for m, t in best.items()}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="jaco_unplug")
    parser.add_argument("--models", nargs="+", default=["xpbd", "joints"])
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    r = bench(args.task, tuple(args.models), steps=args.steps, repeats=args.repeats, seed=args.seed)
    print(", ".join(f"{args.task} {m}: {ms:.2f} ms per control step" for m, ms in r.items()))


if __name__ == "__main__":
    main()
