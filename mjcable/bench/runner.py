"""Running one :class:`~mjcable.bench.case.Case`: build the simulator, step it under a wall-clock cap, sample the
state, classify the outcome (:mod:`mjcable.bench.outcome`) and measure the error; one CSV row
(:mod:`mjcable.bench.results`) per case.

The runner steps the way a user does, so that its wall times are a user's: a particle solver runs
:data:`CALL_INTERVAL` of simulated time per :meth:`~mjcable.Simulator.rollout` (its compiled step loop, each step's
positions recorded inside it); a native model, whose steps are a Python loop anyway, takes two
:meth:`~mjcable.Simulator.step` calls per sample (all but one step, then one), which keeps MuJoCo's clock at every
sample for the silent-reset check and costs no recorded velocities. A scenario's ``gripper_path`` goes to
:meth:`~mjcable.Simulator.step_along` in the same pairs; a general ``drive`` acts before every sample (every step
while active). Either way the state is sampled every :data:`SAMPLE_INTERVAL` of simulated time (or every step,
whichever is longer), together with the positions one step before it (finite-difference speeds and energies); a
scenario that ``needs_energy`` also records :meth:`~mjcable.Simulator.energy` after every call.

The time cap is a deadline checked between the runner's calls (after the build and after every call of the
simulator), not a signal: it works in any thread, e.g. on a Dask worker's thread (:mod:`mjcable.bench.sweep`). It
counts from the timed build; the untimed warm-up before it (JIT compilation or loading numba's cache) is not
charged to the case. A single build or call is not interrupted: the cap takes effect at the next check.
"""

from __future__ import annotations

import math
import time
import warnings
from typing import Iterable, Optional

import numpy as np

from mjcable import metrics, scenes
from mjcable.bench import case as case_mod
from mjcable.bench import scenarios as scenarios_mod
from mjcable.bench.case import Case
from mjcable.bench.outcome import ENERGY_GROWTH, RESET_TOLERANCE, RUNAWAY_SPEED, STRAIN_LIMIT, Limits, \
    classify_exception, judge
from mjcable.bench.results import empty_row
from mjcable.errors import PhysicsWarning
from mjcable.simulator import Simulator

__all__ = ["run_case", "warm_up_models", "SAMPLE_INTERVAL", "CALL_INTERVAL"]

SAMPLE_INTERVAL = 0.005  # s of simulated time between samples of the state (at least one step)
CALL_INTERVAL = 0.1  # s of simulated time a particle solver runs per call (whole samples), as a user's step(T)


class _TimeCap(BaseException):
    """Raised when a run passes its deadline; a BaseException, so that no ``except Exception`` on the way out
    classifies it as a failure of the model."""


def _check_deadline(deadline: float) -> None:
    """Raise :class:`_TimeCap` when the wall clock (``time.perf_counter``) has passed ``deadline``."""
    if time.perf_counter() > deadline:
        raise _TimeCap()


def run_case(case: Case) -> dict:
    """Run one case and return its CSV row (:func:`mjcable.bench.results.empty_row`, filled in).

    A model that fails numerically gets its outcome (:data:`~mjcable.bench.outcome.OUTCOMES`), never an exception.

    Raises:
      Exception: one of :data:`~mjcable.bench.outcome.DEFECTS` from building or stepping (a broken model).
    """
    row = empty_row(case)
    try:
        scenario = scenarios_mod.get(case.scenario)
        model, settings = case_mod.resolve(case.model)
    except ValueError as exc:
        row.update(outcome="rejected", reason=str(exc))
        return row
    row["error_kind"] = scenario.error_kind
    params = dict(case.params)
    try:
        _run(case, model, {**settings, **dict(scenario.settings), **dict(case.settings)}, scenario, params, row)
    except _TimeCap:
        row.update(outcome="diverged", reason=f"over its time cap of {case.time_cap:g} s wall time "
                                              f"(reached {row['sim_time']:.4g} s simulated)")
        if row["steps"]:
            row["wall_per_sim_s"] = row["step_wall_s"] / row["sim_time"]
    return row


def _run(case: Case, model: str, settings: dict, scenario, params: dict, row: dict) -> None:
    building = True
    try:
        scene = scenario.make_scene(case.n_segments, params)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # e.g. springs capping an unreachable stiffness: recorded via strain
            _warm_up(scene, model, case.dt, settings)
            t0 = time.perf_counter()
            deadline = t0 + case.time_cap
            sim = Simulator(scene, model, dt=case.dt, **settings)
        if scenario.setup is not None:
            scenario.setup(sim, params)
        row["build_s"] = time.perf_counter() - t0
        building = False
        _check_deadline(deadline)
        _simulate(case, scenario, params, scene, sim, row, deadline)
    except Exception as exc:  # noqa: BLE001 - every failure becomes a classified row (defects re-raised)
        outcome, reason = classify_exception(exc, building=building)
        row.update(outcome=outcome, reason=reason)


def _warm_up(scene, model: str, dt: float, settings: dict) -> None:
    """Build the same model once and take a step, so that JIT compilation and cache loading (numba) stay out of
    the timed stepping; failures are left for the real run to report."""
    try:
        sim = Simulator(scene, model, dt=dt, **settings)
        sim.step()
        sim.rollout(dt)
    except Exception:  # noqa: BLE001 - failures are left for the timed build to report
        pass


def warm_up_models(labels: Iterable[str]) -> None:
    """Compile the kernels of each particle model among ``labels`` once in this process (numba writes its cache),
    so that parallel workers load the cache instead of compiling the same functions at the same time."""
    for label in dict.fromkeys(labels):
        if label not in case_mod.MODEL_LABELS or case_mod.family(label) != "particle":
            continue
        model, fixed = case_mod.resolve(label)
        for name in ("table", "hang"):
            for extra in ({}, {"young": 1e7}):
                scene = scenes.get(name, n_segments=4, **extra)
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    _warm_up(scene, model, 0.002, fixed)


def _limits(scenario, params: dict, sim, scale: float) -> Limits:
    """The run's limits: the scenario's strain limit, the runaway speed above the driven one, energy growth on a
    passive scene, and MuJoCo's clock where MuJoCo steps the model."""
    return Limits(strain=STRAIN_LIMIT if scenario.strain_limit is None else scenario.strain_limit,
                  speed=RUNAWAY_SPEED + float(params.get("speed", 0.0)),
                  energy=ENERGY_GROWTH * scale if scenario.passive else math.inf,
                  clock=RESET_TOLERANCE * sim.dt if sim.family == "native" else math.inf)


def _simulate(case: Case, scenario, params: dict, scene, sim, row: dict, deadline: float) -> None:
    dt = case.dt
    duration = params.get("duration", scenario.quick_duration if case.quick else scenario.duration)
    duration = float(duration) + scenario.drive_end(params)
    total_steps = max(1, int(round(duration / dt)))
    per_sample = max(1, int(round(SAMPLE_INTERVAL / dt)))
    per_call = per_sample * max(1, int(round(CALL_INTERVAL / (per_sample * dt))))
    masses = sim.particle_masses  # the scenario's setup may have added a load
    scale = float(masses.sum()) * 9.81 * max(sum(c.length for c in scene.cables), 1e-3)
    x0 = np.asarray(scene.particles)
    drive_end = scenario.drive_end(params)
    limits = _limits(scenario, params, sim, scale)

    x = sim.positions
    previous = x
    e_ref = metrics.energy(x, None, dt, masses)  # a passive cable's kinetic + potential energy can only fall
    max_strain = metrics.scene_strain(x, scene)
    max_pen = metrics.penetration(x, scene)
    times, com_x = [0.0], [float(np.dot(masses, x[:, 0]) / masses.sum())]
    energies = [sim.energy()] if scenario.needs_energy else []
    step_wall = 0.0
    steps = 0
    reason, outcome = "", "stable"
    with warnings.catch_warnings(record=True) as heard:  # the physics monitor's warnings classify the run too
        warnings.simplefilter("always", PhysicsWarning)
        try:
            while steps < total_steps and outcome == "stable":
                driving = steps * dt < drive_end + dt
                count = min(per_sample, total_steps - steps)
                path = turns = None
                if scenario.drive is not None:
                    scenario.drive(sim, steps * dt, params)
                    if driving:
                        count = 1  # the drive acts between steps while it is active
                elif scenario.gripper_path is not None and driving:
                    at = (steps + np.arange(count)) * dt
                    path = scenario.gripper_path(scene, at, params)
                    if scenario.gripper_turns is not None:
                        turns = scenario.gripper_turns(scene, at, params)
                t0 = time.perf_counter()
                if scenario.drive is None and path is None and sim.family == "particle":
                    samples = _sample_chunk(sim, min(per_call, total_steps - steps), per_sample)
                else:
                    samples = _sample_pair(sim, count, path, turns)
                step_wall += time.perf_counter() - t0
                if scenario.needs_energy:
                    energies.append(sim.energy())
                start, steps = steps, steps + samples[-1][0]
                row.update(step_wall_s=step_wall, sim_time=steps * dt, steps=steps)  # progress, kept on a time cap
                last = len(samples) - 1
                for k, (taken, previous, x) in enumerate(samples):
                    at = start + taken
                    strain = metrics.scene_strain(x, scene)
                    max_strain = max(max_strain, strain)
                    max_pen = max(max_pen, metrics.penetration(x, scene))
                    if scenario.needs_com_x:
                        times.append(at * dt)
                        com_x.append(float(np.dot(masses, x[:, 0]) / masses.sum()))
                    verdict = judge(limits, time=at * dt, strain=strain,
                                    speed=float(np.sqrt(np.max(np.sum((x - previous) ** 2, axis=1)))) / dt,
                                    energy_growth=metrics.energy(x, previous, dt, masses) - e_ref,
                                    mj_time=float(sim.mj_data.time) if k == last else at * dt,
                                    crossed=int(np.sum(metrics.crossed(x, scene, x0))))
                    if verdict is not None:
                        outcome, reason = verdict
                        break
                _check_deadline(deadline)
        except Exception as exc:  # noqa: BLE001 - classified, the monitor's errors too (defects re-raised)
            outcome, reason = classify_exception(exc, building=False)
    monitored = [str(w.message) for w in heard if issubclass(w.category, PhysicsWarning)]
    if outcome == "stable" and monitored:
        tunnelled = [text for text in monitored if ": depth at step" in text]
        outcome, reason = ("tunneled", tunnelled[0]) if tunnelled else ("stable", "; ".join(monitored))
    row.update(outcome=outcome, reason=reason, max_strain=max_strain, max_penetration=max_pen,
               step_wall_s=step_wall, sim_time=steps * dt, steps=steps,
               wall_per_sim_s=step_wall / (steps * dt) if steps else math.nan)
    if outcome == "stable":
        stuck = metrics.tunneled(x, scene, x0)
        if np.any(stuck):
            outcome, reason = "tunneled", f"{int(np.sum(stuck))} particle(s) inside or beyond an obstacle at the end"
            row.update(outcome=outcome, reason=reason)
    if params.get("save_positions"):
        row["positions"] = x.tolist()
    if outcome != "stable":
        return
    row["final_strain"] = metrics.scene_strain(x, scene)
    row["residual_speed"] = float(np.sqrt(np.max(np.sum((x - previous) ** 2, axis=1)))) / dt
    if scenario.evaluate is not None:
        history = {"times": np.array(times), "com_x": np.array(com_x), "energy": np.array(energies)}
        if scenario.needs_wrench:
            history.update(pin_torques=sim.pin_torques, pin_forces=sim.pin_forces)
        try:
            row["error"] = float(scenario.evaluate(scene, x, history))
        except Exception as exc:  # noqa: BLE001 - a failed measurement is recorded, not raised
            row["reason"] = f"error measurement failed: {type(exc).__name__}: {exc}"
    if scenario.verdict is not None:
        found = scenario.verdict(scene, x)
        if found is not None:
            row.update(outcome=found[0], reason=found[1])


def _sample_pair(sim, count: int, path: Optional[np.ndarray] = None, turns: Optional[np.ndarray] = None) -> list:
    """Advance ``count`` steps in two calls, ``count - 1`` steps and then one (:meth:`Simulator.step`, or
    :meth:`Simulator.step_along` the ``(count, G, 3)`` gripper ``path``, with ``(count, G, 4)`` orientations
    ``turns`` if given), and return the one sample at the end: ``[(steps taken, positions one step before,
    positions)]``, positions (n, 3) in metres."""
    if count > 1:
        if path is None:
            sim.step((count - 1) * sim.dt)
        else:
            sim.step_along(path[:-1], orientations=None if turns is None else turns[:-1])
    previous = sim.positions
    if path is None:
        sim.step()
    else:
        sim.step_along(path[-1:], orientations=None if turns is None else turns[-1:])
    return [(count, previous, sim.positions)]


def _sample_chunk(sim, count: int, per_sample: int) -> list:
    """Advance ``count`` steps in one :meth:`Simulator.rollout` (a particle solver's compiled loop, each step's
    positions recorded inside it) and return the samples every ``per_sample`` steps and at the end, as
    :func:`_sample_pair` does."""
    before = sim.positions
    x = sim.rollout(count * sim.dt).positions  # (count, n, 3): after steps 1..count of the call
    ends = sorted({*range(per_sample, count + 1, per_sample), count})
    return [(k, x[k - 2] if k > 1 else before, x[k - 1]) for k in ends]
