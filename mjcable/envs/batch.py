"""``n`` environments of one task stepped together: :class:`BatchEnv` and :func:`load_batch`.

The environments are ordinary ``dm_control`` environments (:func:`mjcable.envs.load`), each with its own Simulator,
task and random state; :meth:`BatchEnv.step` takes one action per environment and returns their ``TimeStep`` s, the
same, bit for bit, as stepping each environment alone (whatever the number of threads).

How parallel it is: the environments step on a thread pool (as :class:`mjcable.Batch`'s copies do). What overlaps
between threads is the work that releases Python's GIL: the particle solvers' compiled steps (a control step's
gripper path, contact queries included, is one ``nogil`` call: ``Simulator.step_along``) and MuJoCo's ``mj_step``.
dm_control's step and the tasks' action checks, rewards and observations are Python and hold the GIL, so they run
one environment at a time: a model whose control steps are short (``pbd``) gains nothing from threads there
(``scripts/bench_batch.py --env``; ``docs/measurements.md``).
"""

from __future__ import annotations

import os
from typing import Optional, Sequence

import numpy as np
from dm_control.rl import control

from mjcable import _validate
from mjcable.batch import BatchDivergedError, ChunkPool

__all__ = ["BatchEnv", "load_batch"]


class BatchEnv:
    """``n`` dm_control environments of one task stepped together (see the module docstring).

    Args:
      envs: the environments (a sequence of ``dm_control.rl.control.Environment`` with equal action specs).
      threads: worker threads (>= 1); ``None``: ``os.cpu_count()``; never more than ``len(envs)``.

    Example::

        batch = mjcable.envs.load_batch("reach_sag", "xpbd", 4, random=0)
        steps = batch.reset()
        spec = batch.action_spec()
        steps = batch.step(np.zeros((4,) + spec.shape))   # a list of 4 TimeSteps
    """

    def __init__(self, envs: Sequence[control.Environment], *, threads: Optional[int] = None):
        envs = tuple(envs)
        if not envs or not all(isinstance(e, control.Environment) for e in envs):
            raise ValueError(f"envs must be a non-empty sequence of dm_control Environments, got {envs!r}")
        spec = envs[0].action_spec()
        for i, e in enumerate(envs[1:], start=1):
            other = e.action_spec()
            if other.shape != spec.shape:
                raise ValueError(f"envs[{i}] has action shape {other.shape}, envs[0] {spec.shape}: a batch needs equal "
                                 f"action specs")
        threads = (os.cpu_count() or 1) if threads is None else _validate.integer("threads", threads, low=1)
        self.envs = envs
        self.n = len(envs)
        self._pool = ChunkPool(self.n, threads, "mjcable-env")
        self.threads = self._pool.threads

    def _map(self, work) -> list:
        """``work(i)`` for every environment (each thread its chunk, in order), all of them even if one raises; then
        :class:`mjcable.batch.BatchDivergedError` naming the environments that diverged, or the first other error."""
        out, errors = self._pool.run(work)
        if errors:
            raise BatchDivergedError(errors, self.n)
        return out

    def reset(self) -> list:
        """Start a new episode in every environment; their first ``TimeStep`` s."""
        return self._map(lambda i: self.envs[i].reset())

    def step(self, actions) -> list:
        """One control step of every environment.

        Args:
          actions: ``(n,) + action_spec().shape`` array, row ``i`` for environment ``i`` (each row checked by its
            task as ``env.step`` checks it).

        Returns:
          The ``n`` ``TimeStep`` s, in order.

        Raises:
          ValueError: ``actions`` of the wrong shape (or a row its task rejects).
          mjcable.batch.BatchDivergedError: an environment's simulation diverged (the others have stepped; reset the
            batch).
        """
        shape = (self.n,) + tuple(self.action_spec().shape)
        try:
            a = np.asarray(actions, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"actions must be an array of shape {shape}, got {actions!r}") from exc
        if a.shape != shape:
            raise ValueError(f"actions must have shape {shape} (one row per environment), got shape {a.shape}")
        return self._map(lambda i: self.envs[i].step(a[i]))

    def action_spec(self):
        """The action spec of one environment (every environment's)."""
        return self.envs[0].action_spec()

    def observation_spec(self):
        """The observation spec of one environment (every environment's)."""
        return self.envs[0].observation_spec()

    def close(self) -> None:
        """Stop the worker threads (a later step starts them again) and close the environments."""
        self._pool.close()
        for e in self.envs:
            e.close()

    def __enter__(self) -> "BatchEnv":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __len__(self) -> int:
        return self.n


def load_batch(task: str, model: str = "flexrod", n: int = 1, *, random=None, threads: Optional[int] = None,
               **kwargs) -> BatchEnv:
    """``n`` environments of ``task`` on ``model`` (each :func:`mjcable.envs.load`) as a :class:`BatchEnv`.

    Args:
      task, model: as for :func:`mjcable.envs.load`.
      n: number of environments (>= 1).
      random: ``None`` (fresh entropy for each), an int seed ``s`` (environment ``i`` gets ``s + i``, so environment
        ``i`` equals ``load(task, model, random=s + i)``), or a sequence of ``n`` seeds or ``RandomState`` s.
      threads: worker threads (>= 1); ``None``: ``os.cpu_count()``.
      **kwargs: the rest of :func:`mjcable.envs.load`'s arguments (``time_limit``, ``control_timestep``, ``dt``,
        model settings), the same for every environment.

    Raises:
      ValueError: a bad ``n``, ``random`` or ``threads``, or anything :func:`mjcable.envs.load` rejects.
    """
    from mjcable.envs import load  # the package imports this module

    n = _validate.integer("n", n, low=1)
    if random is None or isinstance(random, (int, np.integer)) and not isinstance(random, bool):
        seeds = [None if random is None else int(random) + i for i in range(n)]
    elif isinstance(random, (list, tuple)) and len(random) == n:
        seeds = list(random)
    else:
        raise ValueError(f"random must be None, an int seed or a sequence of {n} seeds or RandomStates, got {random!r}")
    if threads is not None:
        _validate.integer("threads", threads, low=1)
    return BatchEnv([load(task, model, random=s, **kwargs) for s in seeds], threads=threads)
