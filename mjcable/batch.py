"""Many copies of one scene stepped together: :class:`Batch`, ``n`` :class:`~mjcable.Simulator` s on a thread pool.

Copy ``i`` is exactly ``Simulator(batch.scenes[i], model, dt=dt, **settings)``: the same object, stepped by the same
code, so its results equal a single Simulator's bit for bit, whatever the number of threads. What makes the threads
run at once is that the heavy work of every model releases Python's GIL:

* particle solvers (``jakobsen``, ``pbd``, ``xpbd``): a copy's ``step(T)`` is one compiled ``nogil`` call
  (:mod:`mjcable.solvers._kernel_cache`) that also runs the contact queries, calling MuJoCo's
  ``mj_kinematics``/``mj_collision`` on the copy's own proxy ``MjData`` through MuJoCo's C API
  (:mod:`mjcable.solvers.capi`); only the Python glue around that call holds the GIL. This is numba's ``prange``
  over copies in effect (one proxy ``MjData`` per copy), with each copy still a whole Simulator;
* native models (``springs``, ``joints``, ``composite``, ``flexrod``): ``mj_step`` on each copy's own
  ``MjModel``/``MjData`` releases it (as ``mujoco.rollout``'s threads do).

Why not ``mujoco.rollout`` for the native models: it returns the states after each step but not the solver's warm
start (``qacc_warmstart``), so a second call cannot continue bit for bit where a Simulator would; it applies
grippers and sockets as open-loop controls rather than the Simulator's per-step interpolation and release; and it
stops a diverged rollout by repeating its last state instead of raising. ``mujoco.batch.Batch`` (new in 3.17) keeps
each simulation's full integration state, but steps all of them once per call: the Simulator's per-step work (a
gripper's interpolated move, a socket's release on its constraint force, MuJoCo's warnings and the runaway checks)
would have to be done again, for all copies, in Python between its calls. Stepping the Simulators themselves keeps
every guarantee of :class:`~mjcable.Simulator` (divergence checks per step, identical results) and already runs
``springs`` 1.78× faster on 2 threads than on 1 (``scripts/bench_batch.py``, 32 ``table`` copies).

Divergence: every copy finishes its share of a :meth:`Batch.step` (or :meth:`Batch.rollout`) even when another one
diverges; then :class:`BatchDivergedError` (a :class:`~mjcable.errors.SimulationDivergedError`) names the first
copy that diverged (``copy``) and lists all of them (``copies``). The copies then stand at different times, so the
batch refuses to step again until :meth:`Batch.reset`.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import os
import threading
import weakref
from typing import Mapping, Optional

import numpy as np

from mjcable import _validate, catalog
from mjcable.errors import SimulationDivergedError
from mjcable.scene import Scene
from mjcable.simulator import Simulator, Trajectory

__all__ = ["Batch", "BatchTrajectory", "BatchDivergedError", "PARAMS"]

#: CableSpec fields a Batch may vary per copy (``params``).
PARAMS = ("young", "stretch_stiffness", "damping", "friction", "mass")


class BatchDivergedError(SimulationDivergedError):
    """One or more copies of a :class:`Batch` diverged.

    Attributes:
      copy: index of the first copy that diverged.
      copies: indices of all copies that diverged in the call, ascending.
      errors: their :class:`~mjcable.errors.SimulationDivergedError` s, in the order of ``copies``.
      model, step, time, reason: those of the first copy's error (``reason`` names the copy).
    """

    def __init__(self, errors: Mapping[int, SimulationDivergedError], n: int):
        self.copies = tuple(sorted(errors))
        self.copy = self.copies[0]
        self.errors = tuple(errors[i] for i in self.copies)
        first = self.errors[0]
        others = f" (diverged too: copies {list(self.copies[1:])})" if len(self.copies) > 1 else ""
        super().__init__(first.model, first.step, first.time,
                         f"copy {self.copy} of the batch of {n}{others}: {first.reason}")


@dataclasses.dataclass(frozen=True)
class BatchTrajectory:
    """States recorded by :meth:`Batch.rollout`: :class:`mjcable.Trajectory`'s fields with a leading copy axis.

    Attributes:
      times: ``(k,)`` simulated time in seconds of each row (the same for every copy).
      positions: ``(n, k, N, 3)`` particle positions in metres (N = ``scene.n_particles``, cable order).
      velocities: ``(n, k, N, 3)`` particle velocities in m/s.
    """

    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray

    def __len__(self) -> int:
        return len(self.times)

    def copy(self, i: int) -> Trajectory:
        """Copy ``i``'s rows as a :class:`mjcable.Trajectory` (views, no copies of the arrays)."""
        return Trajectory(times=self.times, positions=self.positions[i], velocities=self.velocities[i])


class ChunkPool:
    """``n`` items run on up to ``threads`` worker threads, in contiguous chunks, one chunk per thread (each thread
    runs its items in order); with one thread the items run one after another in the calling thread. Shared by
    :class:`Batch` and :class:`mjcable.envs.BatchEnv`.

    Args:
      n: number of items (>= 1).
      threads: worker threads (>= 1); never more than ``n`` are used.
      name: the worker threads' name prefix.
    """

    def __init__(self, n: int, threads: int, name: str):
        self.n, self.threads, self.name = n, min(threads, n), name
        self._chunks = [range(i * n // self.threads, (i + 1) * n // self.threads) for i in range(self.threads)]
        self._pool = None
        self._lock = threading.Lock()

    def run(self, work) -> tuple:
        """``work(i)`` for every item, all of them even if one raises.

        Returns:
          (``n`` results in order, ``{i: SimulationDivergedError}`` of the items that diverged).

        Raises:
          Any other error of an item, after every item has run.
        """
        out, errors, other = [None] * self.n, {}, []

        def chunk(items):
            for i in items:
                try:
                    out[i] = work(i)
                except SimulationDivergedError as exc:
                    errors[i] = exc
                except Exception as exc:  # noqa: BLE001 - re-raised below, after every item has run
                    other.append(exc)

        if self.threads == 1:
            chunk(range(self.n))
        else:
            list(self._executor().map(chunk, self._chunks))
        if other:
            raise other[0]
        return out, errors

    def _executor(self) -> concurrent.futures.ThreadPoolExecutor:
        with self._lock:
            if self._pool is None:
                self._pool = concurrent.futures.ThreadPoolExecutor(self.threads, thread_name_prefix=self.name)
                self._finalizer = weakref.finalize(self, self._pool.shutdown, wait=False)
            return self._pool

    def close(self) -> None:
        """Stop the worker threads (a later :meth:`run` starts them again); also on garbage collection."""
        with self._lock:
            if self._pool is not None:
                self._finalizer()
                self._pool = None


def _copy_scenes(scene: Scene, n: int, params) -> tuple:
    """The ``n`` scenes of a batch: ``scene`` with the cable fields of ``params`` (key -> (n,) values) replaced."""
    if params is None:
        return (scene,) * n
    if not isinstance(params, Mapping):
        raise ValueError(f"params must be a dict of per-copy CableSpec fields {PARAMS} -> arrays of shape ({n},), "
                         f"got {params!r}")
    unknown = sorted(str(k) for k in params if k not in PARAMS)
    if unknown:
        raise ValueError(f"params has unknown key(s) {unknown}; allowed keys: {list(PARAMS)}")
    columns = {}
    for key, value in params.items():
        if isinstance(value, (list, tuple)) and any(v is None for v in value):
            raise ValueError(f"params[{key!r}] must be an array of {n} numbers (shape ({n},)), got {value!r}: a "
                             "field can't be left to its default for some copies only")
        try:
            a = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"params[{key!r}] must be an array of {n} numbers (shape ({n},)), got {value!r}") from exc
        if a.shape != (n,):
            raise ValueError(f"params[{key!r}] must have shape ({n},) (one value per copy), got shape {a.shape}")
        columns[key] = a
    out = []
    for i in range(n):
        try:
            out.append(scene.with_cable(**{key: float(a[i]) for key, a in columns.items()}))
        except ValueError as exc:  # CableSpec's own check names the field, value and range
            raise ValueError(f"params, copy {i}: {exc}") from exc
    return tuple(out)


class Batch:
    """``n`` copies of a scene on one cable model, stepped together on a thread pool.

    Args:
      scene: the scene (:class:`mjcable.Scene`).
      model: a model of the catalogue (:func:`mjcable.catalog.names`).
      n: number of copies (>= 1).
      dt: step in seconds (> 0), the same for every copy.
      threads: worker threads (>= 1); ``None``: ``os.cpu_count()``. Never more than ``n`` are used; with 1 the
        copies step one after another in the calling thread.
      params: per-copy cable fields, ``{field: (n,) values}`` with fields from :data:`PARAMS` (``young`` Pa,
        ``stretch_stiffness`` N, ``damping`` 1/s, ``friction``, ``mass`` kg); the other fields are ``scene``'s.
        ``None``: every copy is ``scene``.
      **settings: the model's settings, keyword-only, as for :class:`mjcable.Simulator`.

    Raises:
      ValueError: a bad ``n``, ``threads`` or ``params`` (naming the key, the shape or value, and the allowed keys),
        or anything :class:`mjcable.Simulator` rejects; checked before any copy is built.

    Copy ``i`` equals ``mjcable.Simulator(batch.scenes[i], model, dt=dt, **settings)`` bit for bit (see the module
    docstring for how the threads run and what a divergence does).

    Example::

        batch = mjcable.Batch(mjcable.scenes.get("table"), "xpbd", 8, params={"damping": np.linspace(0.1, 2, 8)})
        batch.step(0.5)
        batch.positions   # (8, N, 3), metres
        traj = batch.rollout(0.5, every=25)   # traj.positions: (8, 10, N, 3)
    """

    def __init__(self, scene: Scene, model: str, n: int, *, dt: float = 0.002, threads: Optional[int] = None,
                 params: Optional[Mapping] = None, **settings):
        if not isinstance(scene, Scene):
            raise ValueError(f"scene must be an mjcable.Scene, got {type(scene).__name__}")
        catalog.check_model(model)
        n = _validate.integer("n", n, low=1)
        threads = (os.cpu_count() or 1) if threads is None else _validate.integer("threads", threads, low=1)
        catalog.check_dt(dt)
        catalog.make_settings(model, **settings)  # every setting checked before anything is built
        self.scenes = _copy_scenes(scene, n, params)
        self.scene, self.model, self.n = scene, model, n
        self._sims = tuple(Simulator(s, model, dt=dt, **settings) for s in self.scenes)
        self.dt, self.settings = self._sims[0].dt, self._sims[0].settings
        self._pool = ChunkPool(n, threads, "mjcable-batch")
        self.threads = self._pool.threads
        self._diverged = None  # the copies of the last BatchDivergedError, until reset()

    # -- the pool -------------------------------------------------------------------------------------------------

    def _map(self, work) -> list:
        """``work(i)`` for every copy (:class:`ChunkPool`: in its thread's chunk, in order), every copy even if
        another raises; their results. Raises :class:`BatchDivergedError` for the copies that diverged; any other
        error after all have run."""
        if self._diverged is not None:
            raise RuntimeError(f"copies {list(self._diverged)} of this batch diverged; call reset() before stepping "
                               f"it again")
        out, errors = self._pool.run(work)
        if errors:
            self._diverged = tuple(sorted(errors))
            raise BatchDivergedError(errors, self.n)
        return out

    def close(self) -> None:
        """Stop the worker threads (a later step starts them again); also on garbage collection."""
        self._pool.close()

    def __enter__(self) -> "Batch":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- state ----------------------------------------------------------------------------------------------------

    @property
    def simulators(self) -> tuple:
        """The ``n`` :class:`mjcable.Simulator` s, one per copy (for per-copy actions such as ``move_gripper`` and
        read-outs such as ``pin_forces``; step them through the batch)."""
        return self._sims

    @property
    def positions(self) -> np.ndarray:
        """``(n, N, 3)`` centreline particles of every copy in metres."""
        return np.stack([s.positions for s in self._sims])

    @property
    def velocities(self) -> np.ndarray:
        """``(n, N, 3)`` particle velocities of every copy in m/s."""
        return np.stack([s.velocities for s in self._sims])

    @property
    def time(self) -> float:
        """Simulated time in seconds every copy has reached (copy 0's after a divergence, see the module
        docstring)."""
        return self._sims[0].time

    @property
    def steps(self) -> int:
        """Steps of ``dt`` taken since the start (or the last :meth:`reset`)."""
        return self._sims[0].steps

    # -- stepping -------------------------------------------------------------------------------------------------

    def step(self, seconds: Optional[float] = None) -> None:
        """Advance every copy as :meth:`mjcable.Simulator.step` does (whole steps of ``dt``, the remainder carried).

        Args:
          seconds: duration in seconds (>= 0); ``None`` takes exactly one step.

        Raises:
          BatchDivergedError: a copy diverged (after every copy has taken its steps).
          RuntimeError: a copy diverged in an earlier call and the batch was not :meth:`reset`.
        """
        if seconds is not None:
            seconds = _validate.number("seconds", seconds, low=0.0, unit="s")
        self._map(lambda i: self._sims[i].step(seconds))

    def rollout(self, seconds: float, *, every: Optional[int] = None) -> BatchTrajectory:
        """Advance like :meth:`step` and record every copy's states, as :meth:`mjcable.Simulator.rollout` does.

        Args:
          seconds: duration in seconds (>= 0).
          every: record every ``every``-th step (an integer >= 1; ``None``: every step); the last row is the final
            state.

        Returns:
          A :class:`BatchTrajectory`: ``times`` (k,), ``positions`` and ``velocities`` (n, k, N, 3).

        Raises:
          BatchDivergedError, RuntimeError: as :meth:`step`.
        """
        seconds = _validate.number("seconds", seconds, low=0.0, unit="s")
        if every is not None:
            _validate.integer("every", every, low=1)
        out = self._map(lambda i: self._sims[i].rollout(seconds, every=every))
        return BatchTrajectory(times=out[0].times, positions=np.stack([t.positions for t in out]),
                               velocities=np.stack([t.velocities for t in out]))

    def reset(self) -> None:
        """Every copy back to its exact start state (:meth:`mjcable.Simulator.reset`); clears a divergence."""
        for s in self._sims:
            s.reset()
        self._diverged = None

    def __len__(self) -> int:
        return self.n

    def __repr__(self) -> str:
        return (f"Batch({self.scene.name!r}, {self.model!r}, n={self.n}, dt={self.dt:g}, threads={self.threads}, "
                f"time={self.time:g})")
