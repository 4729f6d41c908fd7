"""One :class:`Simulator` over every model of the catalogue: MuJoCo's native cable models and the particle solvers.

MuJoCo warnings (above all ``mjWARN_BADQACC``, after which MuJoCo silently resets the state), NaNs and runaway
positions or speeds become :class:`~mjcable.errors.SimulationDivergedError` here. Everything below the Simulator
(the backends of :mod:`mjcable.backends`) is reached only through it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import signal
import threading
import time
from typing import Optional

import mujoco
import numpy as np

from mjcable import _validate, catalog, joins, monitor, prechecks, winch_control
from mjcable.backends.protocol import MAX_DISTANCE, MAX_SPEED, Backend
from mjcable.errors import SimulationDivergedError
from mjcable.scene import Scene

__all__ = ["Simulator", "Trajectory", "MAX_SPEED", "MAX_DISTANCE", "MAX_STEPS", "MAX_ROLLOUT_BYTES"]

_STEP_EPS = 1e-9  # fraction of dt forgiven when counting whole steps in an accumulated duration
_CALL_SECONDS = 0.1  # s of wall time one call of the backend's run aims at: Ctrl-C stops a long run within about this
_FIRST_CALL = 16  # steps of a run's first call, before its wall time per step is known
_GROWTH = 4.0  # the most a call's step count grows over the last one's
MAX_STEPS = 10**9  # steps one call of step or rollout may take
MAX_ROLLOUT_BYTES = 8 * 2**30  # the most memory one rollout may record into


@contextlib.contextmanager
def _deferred_interrupt():
    """Within the block, Ctrl-C (SIGINT) only sets the returned event, so that a run of steps stops at a whole step;
    only in the main thread with Python's default handler installed (elsewhere the event is never set)."""
    event = threading.Event()
    if threading.current_thread() is not threading.main_thread() or (
            signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield event
        return
    previous = signal.signal(signal.SIGINT, lambda signum, frame: event.set())
    try:
        yield event
    finally:
        signal.signal(signal.SIGINT, previous)


@dataclasses.dataclass(frozen=True)
class Trajectory:
    """States recorded by :meth:`Simulator.rollout`, in the spirit of ``mujoco.rollout``.

    Attributes:
      times: ``(k,)`` simulated time in seconds of each row.
      positions: ``(k, N, 3)`` particle positions in metres, N = ``scene.n_particles`` (``n_segments + 1`` for one
        cable; several cables in cable order, cut with ``scene.cable_slices``).
      velocities: ``(k, N, 3)`` particle velocities in m/s.
    """

    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray

    def __len__(self) -> int:
        return len(self.times)


class Simulator:
    """Simulate a scene with one cable model.

    Args:
      scene: the scene.
      model: a model of the catalogue (:func:`mjcable.catalog.names`): ``"springs"``, ``"joints"``,
        ``"composite"``, ``"flexrod"`` (MuJoCo's native models), ``"jakobsen"``, ``"pbd"``, ``"xpbd"`` (particle
        solvers).
      dt: step in seconds (> 0).
      **settings: the model's settings, keyword-only (its settings dataclass, e.g.
        :class:`mjcable.solvers.settings.XPBDSettings`; :attr:`settings` holds them with the defaults filled in).

    Raises:
      ValueError: an unknown model, a setting the model does not take, a value out of range, or a scene the model
        cannot simulate.

    Warns:
      PhysicsWarning: what the model would get wrong about the scene at these settings, with the fix
        (:mod:`mjcable.prechecks`: a cable property the model ignores, a substep beyond the model's stability rule,
        a rod or chain that the solver's iterations leave softer than stated).

    Example::

        sim = mjcable.Simulator(mjcable.scenes.get("hang"), "flexrod")
        sim.step(1.0)
        sim.positions  # (n_segments + 1, 3), metres
        same = mjcable.Simulator(sim.scene, sim.model, dt=sim.dt, **dataclasses.asdict(sim.settings))
    """

    def __init__(self, scene: Scene, model: str, *, dt: float = 0.002, **settings):
        if not isinstance(scene, Scene):
            raise ValueError(f"scene must be an mjcable.Scene, got {type(scene).__name__}")
        entry = catalog.get(model)
        self.dt = catalog.check_dt(dt)
        self.settings = catalog.make_settings(model, **settings)
        catalog.check_substep(self.dt, self.settings)
        catalog.check_scene(scene, model)
        far = float(np.max(np.abs(scene.particles)))
        if far > MAX_DISTANCE:
            raise ValueError(f"scene: the cable starts {far:.6g} m from the origin, beyond the {MAX_DISTANCE:g} m past "
                             "which a particle counts as run off (mjcable.simulator.MAX_DISTANCE); place the scene "
                             "nearer the origin")
        self.settings = prechecks.resolve_order(scene, entry, self.settings, self.dt)
        self.settings = prechecks.resolve_iterations(scene, entry, self.settings, self.dt)
        prechecks.check(scene, entry, self.settings, self.dt)
        self.scene = scene
        # the gripper pins, then the free grippers (numbered len(pins) + g)
        self._grippers = scene.gripper_pins + tuple(range(len(scene.pins), len(scene.pins) + len(scene.grippers)))
        # step_along's default pins (numba: kept writable)
        self._gripper_pins = np.array(self._grippers, dtype=np.int64)
        self.model = model
        self.family = entry.family
        backend = entry.backend(scene, entry, self.dt, self.settings)
        if not isinstance(backend, Backend):  # pragma: no cover - a catalogue entry's bug
            raise TypeError(f"model {model!r}'s backend {type(backend).__name__} does not implement Backend")
        self._backend: Backend = backend
        n = scene.n_particles
        self._no_rows = (np.zeros(0, dtype=np.int64), np.zeros((0, n, 3)))  # _run's "record nothing"
        self._step_seconds = None  # wall seconds per step of the last call of the backend's run (None: none yet)
        self._warned = set()  # the checks a PhysicsWarning was given for
        self._start_steps()

    def _start_steps(self) -> None:
        self._grasped = [None] * len(self.scene.grippers)  # the particle each free gripper holds
        self._steps = 0
        self._pending = 0.0
        self._positions = self._backend.positions()
        if not np.all(np.isfinite(self._positions)):
            raise SimulationDivergedError(self.model, 0, 0.0, "non-finite particle state (NaN or inf) at the start",
                                          check="non-finite")

    # -- state ----------------------------------------------------------------------------------------------------

    @property
    def mj_model(self) -> mujoco.MjModel:
        """The compiled MuJoCo model: the cable model itself (native) or the proxy (particle solvers)."""
        return self._backend.mj_model

    @property
    def mj_data(self) -> mujoco.MjData:
        """Its data, current after every step (kinematics included)."""
        return self._backend.mj_data

    @property
    def positions(self) -> np.ndarray:
        """``(scene.n_particles, 3)`` centreline particles in world coordinates (metres), from the first control point;
        several cables in cable order (``scene.cable_slices`` cuts them)."""
        return self._positions.copy()

    @property
    def velocities(self) -> np.ndarray:
        """``(scene.n_particles, 3)`` particle velocities in m/s, from the model's own state (cable order)."""
        return self._backend.velocities()

    @property
    def particle_masses(self) -> np.ndarray:
        """``(scene.n_particles,)`` lumped particle masses in kg, point masses added with :meth:`add_point_mass`
        included (capsule chains: each segment's mass split between its two particles)."""
        return self._backend.particle_masses()

    @property
    def pin_forces(self) -> np.ndarray:
        """``(len(scene.pins), 3)`` force in newtons each pin exerts on the cable at its pinned particle, world frame.

        The pins together carry the whole cable's weight at rest, the pinned particles' own share included; a
        clamp's force is included (its torque is :attr:`pin_torques`); a released socket's row is zero. Native
        models report the last constraint solve (the state at the start of the last MuJoCo step), the particle
        solvers the force averaged over the last step's substeps (the step's impulse / dt). Sockets let go on the
        same quantity."""
        return self._backend.pin_forces()

    @property
    def junction_forces(self) -> np.ndarray:
        """``(len(scene.junctions), 3)`` force in newtons each junction exerts on its particle b (the second of its
        pair; equal and opposite on a), world frame, averaged over the last step as :attr:`pin_forces`; zero rows
        before the first step."""
        return self._backend.junction_forces() if self.scene.junctions else np.zeros((0, 3))

    @property
    def ring_forces(self) -> np.ndarray:
        """``(len(scene.rings), 3)`` N each ring's force on its cable, as :attr:`pin_forces` (0 once it let go)."""
        return self._backend.ring_forces() if self.scene.rings else np.zeros((0, 3))

    @property
    def pin_torques(self) -> np.ndarray:
        """``(len(scene.pins), 3)`` N·m each pin's torque on the cable about its particle (non-zero for clamps only)."""
        return self._backend.pin_torques()

    @property
    def frames(self) -> np.ndarray:
        """``(n_segments, 4)`` the segments' material frames, unit quaternions (w, x, y, z) rotating each segment's
        body axes (d₁, d₂, d₃; d₃ along the segment) into the world, for models that have them (``cosserat``;
        ``joints`` and ``composite``: their capsule bodies' frames, x along the segment turned to d₃).

        Raises:
          ValueError: the model has no material frames (its message names the model)."""
        return self._backend.frames()

    @property
    def gripper_positions(self) -> np.ndarray:
        """``(len(scene.gripper_pins) + len(scene.grippers), 3)`` commanded gripper positions in metres: the gripper
        pins in ``scene.gripper_pins`` order, then the free grippers."""
        return self._backend.gripper_positions()

    @property
    def gripper_forces(self) -> np.ndarray:
        """``(len(scene.grippers), 3)`` force in newtons each free gripper exerts on its particle, world frame, as
        :attr:`pin_forces`; zero while it is open and before the first step after it closes."""
        return self._backend.gripper_forces()

    @property
    def grasped(self) -> tuple:
        """``(len(scene.grippers),)``: the global particle each free gripper holds, ``None`` where it is open."""
        return tuple(self._grasped)

    @property
    def released(self) -> frozenset:
        """Pin numbers (indices into ``scene.pins``) of the sockets that have let go."""
        return frozenset(self._backend.released)

    @property
    def diagnostics(self) -> dict:
        """Counters of the last step (e.g. ``contacts``) and, for particle solvers, cumulative timings in seconds."""
        return dict(self._backend.diagnostics())

    @property
    def time(self) -> float:
        """Simulated time in seconds actually reached (a whole number of steps)."""
        return self._steps * self.dt

    @property
    def steps(self) -> int:
        """Number of steps of ``dt`` taken since the start (or the last :meth:`reset`)."""
        return self._steps

    def energy(self, *, parts: bool = False):
        """The cable's energy in J: kinetic + gravitational + elastic, each from the model's own state and its own
        potential (stretch, bending and twist where the model has them; a user world's other bodies are left out).

        Args:
          parts: return the breakdown, a frozen :class:`mjcable.Energy` (``kinetic``, ``gravity``, ``stretch``,
            ``bending``, ``twist``, ``total``), instead of the total.

        Returns:
          ``float`` (the total) or :class:`mjcable.Energy`. Gravity's zero is the world origin (−Σ mᵢ g·xᵢ).

        What each model stores (README, "Energy"): ``springs`` its tendon springs; ``joints`` its ball-joint springs
        (bending and twist); ``composite`` the cable plugin's bending and twist; ``flexrod`` its edge springs and
        discrete-rod bending; ``xpbd`` ½ C²/α of its compliant rows; ``pbd`` and ``jakobsen`` the compliance their
        factors act with; rigid segments and hard constraints (an inextensible cable) store none.

        Example::

            e = sim.energy(parts=True)
            e.total == e.kinetic + e.gravity + e.stretch + e.bending + e.twist
        """
        energy = self._backend.energy()
        return energy if parts else energy.total

    # -- stepping -------------------------------------------------------------------------------------------------

    def _count(self, seconds: Optional[float]) -> int:
        """Whole steps in ``seconds`` plus the carried remainder (``None``: exactly one); the rest carries over."""
        if seconds is None:
            return 1
        seconds = _validate.number("seconds", seconds, low=0.0, unit="s")
        if (self._pending + seconds) / self.dt > MAX_STEPS:
            raise ValueError(f"seconds = {seconds:g} is {seconds / self.dt:.3g} steps of dt = {self.dt:g} s, beyond "
                             f"the {MAX_STEPS:.0e} steps one call may take (mjcable.simulator.MAX_STEPS: days of wall "
                             "time at any model's speed); step in shorter calls")
        self._pending += seconds
        count = int(math.floor(self._pending / self.dt + _STEP_EPS))
        self._pending = max(self._pending - count * self.dt, 0.0)
        return count

    def _run(self, count: int, rows: np.ndarray, out_x: np.ndarray, out_v: np.ndarray, path: Optional[tuple] = None,
             until_release: bool = False) -> int:
        """``count`` steps through the backend's ``run``, recording the state after the steps ``rows`` (R,)
        (ascending, 1..count) into ``out_x``, ``out_v`` (R, N, 3), the grippers following ``path`` (``(pins,
        targets)`` of :meth:`step_along`) and, with ``until_release``, stopping after a step in which a socket let
        go. Returns the steps taken.

        The steps go to the backend in calls of about ``_CALL_SECONDS`` of wall time each (how a run is split changes
        nothing, bit for bit), so that Ctrl-C stops a long run between two calls, at a whole step.

        Raises:
          SimulationDivergedError: naming the step that failed its checks.
          KeyboardInterrupt: Ctrl-C; the steps taken so far count."""
        done = stored = 0
        per_call = _FIRST_CALL if self._step_seconds is None else max(1, int(_CALL_SECONDS / self._step_seconds))
        with _deferred_interrupt() as interrupted:
            while done < count:
                k = min(per_call, count - done)
                last = stored + int(np.searchsorted(rows[stored:], done + k, side="right"))  # rows within this call
                call_path = None if path is None else (path[0], path[1][done:done + k])
                start = time.perf_counter()
                result = self._backend.run(k, rows=rows[stored:last] - done, out_x=out_x[stored:last],
                                           out_v=out_v[stored:last], path=call_path, until_release=until_release)
                elapsed = time.perf_counter() - start
                done += result.steps
                stored += result.recorded
                self._steps += result.steps
                self._positions = self._backend.positions()
                if result.warning is not None:
                    self._warn(result.warning, self._steps - result.steps + result.warning.step)
                if result.failure is not None:
                    found = result.failure
                    raise SimulationDivergedError(self.model, self._steps, self.time, found.reason, check=found.check,
                                                  value=found.value, fix=self._fix(found.check))
                if interrupted.is_set():
                    raise KeyboardInterrupt
                if result.steps < k:  # a socket let go (until_release)
                    break
                self._step_seconds = max(elapsed, 1e-9) / k
                per_call = max(1, min(int(_GROWTH * k), int(_CALL_SECONDS / self._step_seconds)))
        return done

    def _fix(self, check: str) -> str:
        return monitor.fix(self.scene, self.model, self.settings, self.dt, check)

    def _warn(self, found: monitor.Breach, step: int) -> None:
        """A :class:`~mjcable.errors.PhysicsWarning` for ``found`` at ``step``, once per check and Simulator."""
        if found.check not in self._warned:
            self._warned.add(found.check)
            monitor.warn(found, self.model, step, step * self.dt, self._fix(found.check))

    def step(self, seconds: Optional[float] = None) -> None:
        """Advance by whole steps of ``dt``; the remainder of ``seconds`` carries over to the next call.

        Args:
          seconds: duration in seconds (>= 0); ``None`` takes exactly one step.

        Raises:
          SimulationDivergedError: NaN, runaway state or a MuJoCo warning.
        """
        rows, none = self._no_rows
        self._run(self._count(seconds), rows, none, none)

    def step_along(self, path, *, pins=None, orientations=None, until_release: bool = False) -> int:
        """Take one step of ``dt`` per row of ``path``, the grippers moved to that row before the step.

        Step ``i`` is :meth:`move_gripper` of each gripper whose ``path[i]`` entry differs from its commanded position
        (a gripper that stays is not sent anywhere), then one :meth:`step`, with identical results; the particle
        solvers take the whole path in one compiled loop (with Python only around contact queries) instead of one
        Python step each. The remainder that :meth:`step` carries is left alone.

        Args:
          path: ``(steps, len(pins), 3)`` gripper positions in metres, world frame, finite; ``steps`` >= 0.
          pins: the gripper pins (indices into ``scene.pins``) of ``path``'s columns, distinct; default
            ``scene.gripper_pins``.
          orientations: ``(steps, len(pins), 4)`` unit quaternions (w, x, y, z), each gripper's turn from its start
            orientation at that row (see :meth:`move_gripper`: clamped grippers of a model with frames); step ``i``
            is then :meth:`move_gripper` of every gripper with ``path[i]`` and ``orientations[i]``, and one
            :meth:`step`.
          until_release: stop after the first step in which a socket lets go (a caller whose path respects the
            socket's hold, e.g. a tether to it, recomputes the rest of it).

        Returns:
          The number of steps taken: ``steps``, or fewer if ``until_release`` stopped it.

        Raises:
          ValueError: ``pins`` not distinct gripper pins, ``path`` not of that shape or not finite, or
            ``orientations`` not of its shape, not unit quaternions, or given to a model or pin that can't turn.
          SimulationDivergedError: NaN, runaway state or a MuJoCo warning (at the step it happened).

        Example::

            start = sim.gripper_positions[0]
            path = start + np.linspace(0.0, 1.0, 51)[1:, None, None] * [0.05, 0.0, 0.0]  # 5 cm in 50 steps
            sim.step_along(path)
        """
        pins = self._path_pins(pins)
        try:
            targets = np.ascontiguousarray(path, dtype=np.float64)
        except (TypeError, ValueError):
            targets = None
        if targets is None or targets.ndim != 3 or targets.shape[1:] != (len(pins), 3):
            raise ValueError(f"path must be an array of shape (steps, {len(pins)}, 3) in metres (one row of gripper "
                             f"positions per step), got {path!r}")
        if not np.isfinite(targets).all():
            raise ValueError(f"path must be finite, got {path!r}")
        rows, none = self._no_rows
        if orientations is None:
            return self._run(len(targets), rows, none, none, (pins, targets), bool(until_release))
        if np.any(pins >= len(self.scene.pins)):
            raise ValueError(f"orientations: free grippers (pins >= {len(self.scene.pins)}, got {pins.tolist()}) can't "
                             "turn (they hold a point); move them in a path without orientations")
        turns = self._turns(orientations, targets.shape[:2])
        for i in range(len(targets)):  # (a model or pin that can't turn raises at the first row, before a step)
            released = self.released
            for g, k in enumerate(pins):
                self._backend.move_gripper(int(k), targets[i, g], turns[i, g])
            self.step()
            if until_release and self.released != released:
                return i + 1
        return len(targets)

    @staticmethod
    def _turns(orientations, shape: tuple) -> np.ndarray:
        """``orientations`` as ``(steps, G, 4)`` unit quaternions (normalised), for a path of ``shape`` (steps, G).

        Raises:
          ValueError: not of that shape, not finite, or a row's norm off 1 by more than 1e-6."""
        try:
            turns = np.array(orientations, dtype=np.float64)
        except (TypeError, ValueError):
            turns = None
        if turns is None or turns.shape != (*shape, 4):
            raise ValueError(f"orientations must be an array of shape {(*shape, 4)} (a unit quaternion (w, x, y, z) "
                             f"per step and gripper), got {orientations!r}")
        norms = np.linalg.norm(turns, axis=-1)
        if not np.isfinite(turns).all() or np.any(np.abs(norms - 1.0) > 1e-6):
            raise ValueError(f"orientations must be finite unit quaternions (norm 1 within 1e-6), got {orientations!r}")
        return turns / norms[..., None]

    def _path_pins(self, pins) -> np.ndarray:
        """``pins`` as a (G,) int64 array of distinct gripper pins (``None``: ``scene.gripper_pins``).

        Raises:
          ValueError: not a sequence of distinct gripper pins."""
        grippers = self._grippers
        if pins is None or (type(pins) is tuple and pins == grippers and all(type(k) is int for k in pins)):
            return self._gripper_pins
        try:
            given = list(pins)
        except TypeError:
            given = None
        if (given is None or any(isinstance(k, (bool, np.bool_)) or not isinstance(k, (int, np.integer))
                                 or k not in grippers for k in given) or len(set(given)) != len(given)):
            raise ValueError(f"pins must be distinct gripper pins, from {grippers}, got {pins!r}")
        return np.array([int(k) for k in given], dtype=np.int64)

    def rollout(self, seconds: float, *, every: Optional[int] = None) -> Trajectory:
        """Advance like :meth:`step` (the same steps and remainder rule, identical results) and record the state.

        Args:
          seconds: duration in seconds (>= 0).
          every: record every ``every``-th step (an integer >= 1; ``None``: every step). The last row is always the
            final state; with no whole step to take, the one row is the current state.

        Returns:
          A :class:`Trajectory` of ``k`` rows.

        Example::

            traj = sim.rollout(1.0, every=10)   # traj.positions: (50, n_segments + 1, 3) at dt = 0.002
        """
        stride = 1 if every is None else _validate.integer("every", every, low=1)
        if seconds is not None and not isinstance(seconds, bool) and isinstance(seconds, (int, float, np.number)):
            planned = int(max(float(seconds), 0.0) / self.dt / stride) + 1  # rows, before _count takes the steps
            size = planned * 2 * self._positions.size * 8
            if size > MAX_ROLLOUT_BYTES:
                raise ValueError(f"rollout({seconds!r}, every={every!r}) would record {planned} rows of positions and "
                                 f"velocities, {size / 2**30:.3g} GiB (limit {MAX_ROLLOUT_BYTES / 2**30:g} GiB, "
                                 "mjcable.simulator.MAX_ROLLOUT_BYTES); record less often (a larger every) or "
                                 "roll out in shorter calls")
        count = self._count(seconds)
        rows = np.arange(1, count + 1, dtype=np.int64)
        rows = rows[(rows % stride == 0) | (rows == count)].tolist() or [0]
        shape = (len(rows),) + self._positions.shape
        start = self._steps
        times, pos, vel = (np.array(rows, dtype=np.int64) + start) * self.dt, np.empty(shape), np.empty(shape)
        if count == 0:
            pos[0], vel[0] = self._positions, self._backend.velocities()
        else:
            self._run(count, np.array(rows, dtype=np.int64), pos, vel)
        return Trajectory(times=times, positions=pos, velocities=vel)

    def reset(self) -> None:
        """Back to the exact start state: positions, velocities, time, grippers and sockets, bit for bit, every free
        gripper open at its start position (point masses added with :meth:`add_point_mass` stay)."""
        self._backend.reset()
        self._start_steps()

    # -- actions --------------------------------------------------------------------------------------------------

    def move_gripper(self, pin_number: int, position, orientation=None) -> None:
        """Move the gripper of ``scene.pins[pin_number]`` to ``position`` (3,), metres, world frame; it travels
        there linearly over the next step's substeps.

        ``orientation``: a unit quaternion (4,) (w, x, y, z), the gripper's turn from its start orientation; a
        clamped gripper of a model with frames (``cosserat``, ``joints``, ``composite``) turns the frame it holds
        with it (interpolated over the step's substeps), twisting or bending the cable. Other models, and grippers
        that are not clamped, raise a ``ValueError`` when it is given."""
        grippers = self._grippers
        if isinstance(pin_number, bool) or pin_number not in grippers:
            raise ValueError(f"pin_number must index a gripper pin, one of {grippers} (free gripper g: len(scene.pins) "
                             f"+ g), got {pin_number!r}")
        try:  # called once per step by environments: one conversion, no tuple round trip
            pos = np.array(position, dtype=np.float64)
        except (TypeError, ValueError):
            pos = None
        if pos is None or pos.shape != (3,) or not np.isfinite(pos).all():
            raise ValueError(f"position must be 3 finite numbers in metres, got {position!r}")
        if orientation is None:
            self._backend.move_gripper(int(pin_number), pos)
            return
        if pin_number >= len(self.scene.pins):
            raise ValueError(f"orientation: free gripper {pin_number - len(self.scene.pins)} (pin_number "
                             f"{pin_number}) holds a point, it can't turn; drop orientation")
        try:
            quat = np.array(orientation, dtype=np.float64)
        except (TypeError, ValueError):
            quat = None
        if quat is None or quat.shape != (4,) or not np.isfinite(quat).all() or abs(np.linalg.norm(quat) - 1) > 1e-6:
            raise ValueError(f"orientation must be a unit quaternion (w, x, y, z) of 4 finite numbers with norm 1 "
                             f"(within 1e-6), got {orientation!r}")
        self._backend.move_gripper(int(pin_number), pos, quat / np.linalg.norm(quat))

    def add_point_mass(self, index: int, mass: float) -> None:
        """Add a point mass of ``mass`` kg at particle ``index`` (negative counts from the end), e.g. a load on the
        cable's end. It stays through :meth:`reset`.

        Native models add it to the body holding the particle (mass, centre of mass and inertia as for a point
        mass at the particle); particle solvers to the particle's lumped mass. A held particle stays held: its mass
        then enters its pin's force.
        """
        n = self.scene.n_particles
        index = _validate.integer("index", index, low=-n, high=n - 1) % n
        mass = _validate.number("mass", mass, low=0.0, low_open=True, unit="kg")
        self._backend.add_point_mass(index, mass)

    # -- winches --------------------------------------------------------------------------------------------------

    def reel(self, k: int, speed: float) -> None:
        """Reel winch ``scene.pins[k]`` at ``speed`` m/s from the next step on, until changed: positive pays out,
        negative reels in, 0 stops. The free length changes by ``speed`` per second with the mass per metre kept,
        until the spool is empty or one segment is left free; the pull is :attr:`pin_forces` ``[k]`` (README,
        *Winches*). Raises ``ValueError``: ``k`` not a winch pin's index, ``speed`` not a finite number."""
        self._backend.reel(winch_control.winch_pin(self.scene, k), _validate.number("speed", speed, unit="m/s"))

    def free_length(self, k: int) -> float:
        """m: the cable winch ``scene.pins[k]`` has paid out, from the winch point to the cable's free end along its
        segments' rest lengths. Raises ``ValueError``: ``k`` not a winch pin's index."""
        return self._backend.free_length(winch_control.winch_pin(self.scene, k))

    # -- free grippers --------------------------------------------------------------------------------------------

    def grasp(self, g: int, index: Optional[int] = None) -> int:
        """Close free gripper ``g`` (``scene.grippers[g]``) on particle ``index``: from the next step on the particle
        follows the gripper, moved with ``move_gripper(len(scene.pins) + g, position)`` or :meth:`step_along`,
        as a gripper pin's does, and :attr:`gripper_forces` reports what the gripper holds.

        The particle is held where it is when the gripper closes, at a fixed offset from the gripper (zero when the
        gripper was moved onto it first): closing never yanks the cable (:mod:`mjcable.backends.grasp`).

        Args:
          g: the free gripper, 0 <= g < ``len(scene.grippers)``.
          index: the global particle index (negative counts from the end); ``None``: the particle nearest to the
            gripper that no pin or other gripper holds.

        Returns the grasped particle's global index.

        Raises:
          ValueError: ``g`` out of range or closed, ``index`` out of range or held by a pin or another gripper.

        Example::

            sim.grasp(0)   # the particle nearest to free gripper 0, moved as move_gripper(len(sim.scene.pins), ...)"""
        g = joins.free_gripper(self.scene, g)
        if self._grasped[g] is not None:
            raise ValueError(f"g: free gripper {g} already holds particle {self._grasped[g]}; release it first")
        gripper = self.gripper_positions[len(self.scene.gripper_pins) + g]
        index = joins.grasp_target(self.scene.n_particles, self._held(), index, self._positions, gripper)
        self._backend.grasp(g, index)
        self._grasped[g] = index
        return index

    def release(self, g: int) -> int:
        """Open free gripper ``g``: its particle is free from the next step on (with the velocity it has).

        Returns the particle it held.

        Raises:
          ValueError: ``g`` out of range, or the gripper open already."""
        g = joins.free_gripper(self.scene, g)
        index = self._grasped[g]
        if index is None:
            raise ValueError(f"g: free gripper {g} holds nothing (it is open); grasp before releasing")
        self._backend.release(g)
        self._grasped[g] = None
        return index

    def _held(self) -> dict:
        """Particle -> what holds it: the scene's pins (but released sockets) and the closed free grippers."""
        held = {self.scene.pin_particle(k): f"pins[{k}]" for k in range(len(self.scene.pins))
                if k not in self.released}
        held.update({i: f"free gripper {g}" for g, i in enumerate(self._grasped) if i is not None})
        return held
