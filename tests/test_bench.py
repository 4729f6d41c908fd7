"""The benchmark machinery: metrics, the model labels, the outcome classifier, the sweep runner (CSV, resume),
plots.

No timing asserts."""

import contextlib
import csv
import dataclasses
import logging
import math
import re

import distributed

import numpy as np
import pytest

import mjcable
from mjcable import catalog, cli, metrics
from mjcable.bench import accuracy, case, plots, results, scenarios, stress, sweep, twist
from mjcable.bench.case import Case
from mjcable.bench.outcome import OUTCOMES
from mjcable.bench.runner import run_case
from mjcable.scene import Box, CableSpec, Capsule, Cylinder, Floor, Scene, Sphere


def _scene(*obstacles):
    cable = CableSpec([[0.0, -0.5, 2.0], [1.0, -0.5, 2.0]], 4, 0.01, 0.1)  # clear of every obstacle below
    return Scene(cable, obstacles=obstacles)


# ------------------------------------------------------------------------------------------------ metrics

def test_strain_and_distances():
    x = np.array([[0.0, 0, 0], [1.1, 0, 0], [2.0, 0, 0]])
    assert metrics.max_strain(x, 1.0) == pytest.approx(0.1)
    assert metrics.rms_distance(x, x + [0, 0.3, 0.4]) == pytest.approx(0.5)
    assert metrics.max_distance(x, x) == 0.0


@pytest.mark.parametrize("obstacle, inside, depth", [
    (Floor(), [0.3, -2.0, -0.02], 0.02),
    (Floor(pos=(0, 0, 1.0), euler=(90.0, 0, 0)), [0.0, 0.03, 0.5], 0.03),  # normal along −y after the rotation
    (Box(size=(0.5, 0.2, 0.1), pos=(0, 0, 1)), [0.3, 0.0, 1.07], 0.03),
    (Sphere(radius=0.2, pos=(1, 1, 1)), [1.0, 1.0, 1.15], 0.05),
    (Cylinder(radius=0.1, half_length=0.5, pos=(0, 0, 1), euler=(90.0, 0, 0)), [0.0, 0.3, 1.08], 0.02),
    (Capsule(radius=0.1, half_length=0.5, pos=(0, 0, 1)), [0.0, 0.0, 1.56], 0.04),
])
def test_signed_distance_and_penetration(obstacle, inside, depth):
    scene = _scene(obstacle)
    p = np.array([inside])
    assert metrics.signed_distances(p, scene)[0, 0] == pytest.approx(-depth, abs=1e-12)
    assert metrics.penetration(p, scene) == pytest.approx(depth + scene.cable.radius, abs=1e-12)


def test_penetration_is_zero_without_obstacles_or_contact():
    assert metrics.penetration(np.zeros((3, 3)), _scene()) == 0.0
    assert metrics.penetration(np.array([[0.0, 0.0, 0.5]]), _scene(Floor())) == 0.0


def test_tunnelling_through_a_table_and_into_a_floor():
    table = Box(size=(0.5, 0.5, 0.02), pos=(0.0, 0.0, 1.0))
    scene = _scene(table, Floor())
    start = np.array([[0.0, 0.0, 1.1], [0.3, 0.0, 1.1], [2.0, 0.0, 1.1]])
    below = start.copy()
    below[:2, 2] = 0.9  # two particles fell through the table (the third was never above it)
    below[2, 2] = 0.5
    assert metrics.crossed(below, scene, start).tolist() == [True, True, False]
    resting = start.copy()
    resting[:, 2] = 1.02 + scene.cable.radius
    assert not np.any(metrics.tunneled(resting, scene, start))
    deep = start.copy()
    deep[2, 2] = -0.05  # far below the floor
    assert metrics.tunneled(deep, scene, start).tolist() == [False, False, True]
    slight = resting.copy()
    slight[0, 2] -= 0.5 * scene.cable.radius  # a soft contact's overlap: not tunnelling
    assert not np.any(metrics.tunneled(slight, scene, start))


def test_energy_of_a_falling_particle_is_conserved():
    masses = np.array([2.0])
    dt = 1e-3
    t = np.array([1.0 - dt, 1.0])
    z = mjcable.reference.free_fall(t, 10.0)
    x = np.zeros((2, 3))
    x[:, 2] = z
    e_start = metrics.potential_energy(np.array([[0, 0, 10.0]]), masses)
    e = metrics.energy(x[1:], x[:1], dt, masses)
    assert e == pytest.approx(e_start, rel=1e-3)


def test_fit_frequency_recovers_a_sine():
    t = np.linspace(0.0, 4.0, 801)
    y = 0.3 + 0.01 * np.cos(3.7 * t + 0.4) + 0.001 * np.cos(11.0 * t)
    assert scenarios.fit_frequency(t, y) == pytest.approx(3.7, rel=1e-3)
    assert math.isnan(scenarios.fit_frequency(t, np.ones_like(t)))


def test_chain_scene_starts_in_mode_one():
    scene = scenarios.chain_scene(20)
    x = scene.cable.particles
    assert x[0] == pytest.approx([0.0, 0.0, scenarios.CHAIN_TOP])
    assert x[-1, 0] == pytest.approx(scenarios.CHAIN_AMPLITUDE, rel=0.05)
    assert scene.cable.length == pytest.approx(1.0, abs=1e-3)


def test_swing_energy_is_the_starts_height_above_hanging_straight():
    # a straight chain tilted by θ from the vertical holds M g (L / 2)(1 − cos θ) above hanging straight down
    theta, top = 0.3, scenarios.CHAIN_TOP
    points = [[0.0, 0.0, top], [math.sin(theta), 0.0, top - math.cos(theta)]]
    scene = Scene(CableSpec(points, 10, 0.005, 0.1), pins=(mjcable.Pin(0),))
    assert scenarios.swing_energy(scene) == pytest.approx(0.1 * 9.81 * 0.5 * (1 - math.cos(theta)), rel=1e-12)


def test_energy_scenario_measures_the_change_of_the_simulators_energy():
    # springs conserve the swing's energy (symplectic Euler); XPBD at one substep damps it numerically
    rows = {m: run_case(Case("energy", m, 0.002, settings=s, params=(("duration", 2.0),)))
            for m, s in (("springs", ()), ("xpbd", (("substeps", 1),)))}
    assert rows["springs"]["outcome"] == rows["xpbd"]["outcome"] == "stable"
    assert rows["springs"]["error"] < 0.005
    assert rows["xpbd"]["error"] > 0.02


# ------------------------------------------------------------------------------------------------ stepping

@pytest.mark.parametrize("model", ["springs", "xpbd"])
def test_the_runner_steps_as_a_user_does(model):
    # the runner advances in whole samples (a particle solver in long rollouts, a native model two calls a sample):
    # the same state, bit for bit, as one Simulator.step(T) of the same case
    case = Case("catenary", model, 0.002, n_segments=8, params=(("duration", 0.3), ("save_positions", 1)))
    row = run_case(case)
    assert row["outcome"] == "stable" and row["steps"] == 150
    sim = mjcable.Simulator(scenarios.get("catenary").make_scene(8, {}), model, dt=0.002)
    sim.step(0.3)
    assert np.array_equal(np.array(row["positions"]), sim.positions)


@pytest.mark.parametrize("model", ["springs", "xpbd"])
def test_the_yank_follows_its_gripper_path_as_step_by_step_moves(model):
    # the speed scenario hands its gripper path to step_along: the state of one move_gripper and step() per step
    params = (("duration", 0.02), ("save_positions", 1), ("speed", 20.0))
    row = run_case(Case("speed", model, 0.002, n_segments=8, params=params))
    assert row["outcome"] == "stable"
    scene = scenarios.yank_scene(8)
    sim = mjcable.Simulator(scene, model, dt=0.002)
    start = np.asarray(scene.cable.particles[0])
    for k in range(row["steps"]):
        travelled = min(max(k * 0.002 - scenarios.YANK_SETTLE, 0.0) * 20.0, scenarios.YANK_DISTANCE)
        sim.move_gripper(0, start + travelled * scenarios.YANK_DIRECTION)
        sim.step()
    assert np.array_equal(np.array(row["positions"]), sim.positions)


@pytest.mark.parametrize("model", ["cosserat", "joints"])
def test_the_twist_family_turns_its_gripper_as_step_by_step_moves(model):
    # the torsion scenario hands its gripper's turn to step_along with the path: the state of one move_gripper with
    # its orientation and step() per step; its error is the end torque's against G·J φ / L (joints: C = E·I, +50 %)
    params = (("duration", 0.3), ("save_positions", 1))
    row = run_case(Case("torsion", model, 0.002, n_segments=8, params=params))
    assert row["outcome"] == "stable"
    scene = twist.twist_scene(8)
    sim = mjcable.Simulator(scene, model, dt=0.002)
    end = np.asarray(scene.cable.particles[-1])
    for k in range(row["steps"]):
        sim.move_gripper(1, end, twist.turn([1, 0, 0], twist.TORSION_ANGLE * min(k * 0.002 / twist.TORSION_RAMP, 1)))
        sim.step()
    assert np.array_equal(np.array(row["positions"]), sim.positions)
    c = scene.cable
    expected = abs(sim.pin_torques[1, 0] / (c.torsion_stiffness * twist.TORSION_ANGLE / twist.LENGTH) - 1.0)
    assert row["error"] == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("name, reason", [("torsion", "no material frames"), ("arc", "no material frames"),
                                          ("greenhill", "no material frames"), ("curved_rest", "rest_shape")])
def test_the_twist_family_rejects_models_without_frames(name, reason):
    row = run_case(Case(name, "xpbd", 0.002, n_segments=8, params=(("duration", 0.1),)))
    assert row["outcome"] == "rejected" and reason in row["reason"]


@pytest.mark.parametrize("name, bar", [("greenhill", 0.05), ("curved_rest", 1e-4)])
def test_greenhill_and_curved_rest_measure_cosserat_within_the_issue_bars(name, bar):
    # the issue's must-show bars: the buckling torque within 5 % of 2.86 π B / L; the curved rest shape returned to
    # within 0.1 mm after the pull and release
    row = run_case(Case(name, "cosserat", 0.002, 50))
    assert row["outcome"] == "stable" and row["error"] < bar


# ------------------------------------------------------------------------------------------------ classifier

def _inject(setup):
    """A scenario (hang, 0.2 s) whose setup does something to the built simulator."""
    base = scenarios.SCENARIOS["catenary"]
    return scenarios.Scenario("injected", "test", base.make_scene, duration=0.2, quick_duration=0.2,
                              error_kind="m", evaluate=base.evaluate, setup=setup)


def test_huge_dt_on_springs_is_classified_diverged():
    # springs keeps its explicit springs stable by softening them as h² (see build/springs.py): at a 0.5 s step
    # the cable stretches without bound, which the classifier calls diverged (runaway strain).
    row = run_case(Case("catenary", "springs", 0.5, settings=(("substeps", 1),), params=(("duration", 2.0),)))
    assert row["outcome"] == "diverged"
    assert "strain" in row["reason"]


def test_energy_growth_and_silent_reset_are_classified_diverged(monkeypatch):
    def kick(sim, params):  # 10 m/s upwards: 5 J of kinetic energy from nowhere
        sim.mj_data.qvel[:] = 0.0
        sim.mj_data.qvel[2::3] = 10.0

    monkeypatch.setitem(scenarios.EXTRA_SCENARIOS, "injected", _inject(kick))
    row = run_case(Case("injected", "springs", 0.002))
    assert row["outcome"] == "diverged"
    assert "energy" in row["reason"]

    import mujoco

    def reset_later(sim, t, params):
        if t > 0.1:
            mujoco.mj_resetData(sim.mj_model, sim.mj_data)  # what MuJoCo does silently after mjWARN_BADQACC

    scenario = scenarios.Scenario("reset", "test", scenarios.SCENARIOS["chain"].make_scene, duration=0.3,
                                  quick_duration=0.3, error_kind="none", drive=reset_later)
    monkeypatch.setitem(scenarios.EXTRA_SCENARIOS, "reset", scenario)
    row = run_case(Case("reset", "springs", 0.002))
    assert row["outcome"] == "diverged"
    assert "silent reset" in row["reason"]


def test_nan_and_time_cap_are_classified_diverged(monkeypatch):
    def poison(sim, params):
        sim.mj_data.qpos[5] = np.nan

    monkeypatch.setitem(scenarios.EXTRA_SCENARIOS, "injected", _inject(poison))
    row = run_case(Case("injected", "springs", 0.002))
    assert row["outcome"] == "diverged"
    row = run_case(Case("catenary", "springs", 0.002, time_cap=0.01))
    assert row["outcome"] == "diverged"
    assert "time cap" in row["reason"]


def test_bad_settings_are_rejected_not_crashed():
    row = run_case(Case("catenary", "springs", 0.002, settings=(("iterations", 3),)))
    assert row["outcome"] == "rejected"
    row = run_case(Case("nonexistent", "springs", 0.002))
    assert row["outcome"] == "rejected"
    row = run_case(Case("catenary", "xpbd-direct", 0.002))  # the old label: xpbd is the direct order now
    assert row["outcome"] == "rejected" and "xpbd-gs" in row["reason"]


def test_a_broken_model_fails_loudly():
    # a model whose code is missing is a defect, not an outcome: run_case raises it instead of recording a row
    with _registered("broken", backend=_missing_backend):
        with pytest.raises(ImportError, match="not_written_yet"):
            run_case(Case("catenary", "broken", 0.005, n_segments=4, params=(("duration", 0.01),)))


def _missing_backend(*args, **kwargs):
    raise ImportError("No module named 'not_written_yet'")


# ------------------------------------------------------------------------------------------------ labels


@contextlib.contextmanager
def _registered(name, **fields):
    """A copy of the xpbd entry registered as ``name`` (with ``fields`` replaced) for the block's duration."""
    catalog.register(dataclasses.replace(catalog.get("xpbd"), name=name, **fields))
    try:
        yield name
    finally:
        catalog.unregister(name)


def test_labels_are_the_catalogue_plus_the_gauss_seidel_variant():
    labels = case.labels()
    assert [m for m in labels if m in catalog.names()] == list(catalog.names())
    assert set(labels) == set(catalog.names()) | {"xpbd-gs"}
    assert all(labels[m] == (m, {}) for m in catalog.names())
    assert catalog.make_settings("xpbd").order == "direct"  # so plain xpbd is the direct order ...
    assert case.settings_of("xpbd-gs").order == "gauss-seidel"  # ... and the variant keeps Gauss-Seidel
    assert case.family("xpbd-gs") == "particle"
    with pytest.raises(ValueError, match="xpbd-direct"):
        case.model_labels(["xpbd-direct"])
    # the CSV records the order each label ran
    assert results.empty_row(Case("catenary", "xpbd", 0.002))["order"] == "direct"
    assert results.empty_row(Case("catenary", "xpbd-gs", 0.002))["order"] == "gauss-seidel"


def test_settings_grids_follow_each_model_settings():
    def grid(label):
        return [dict(c.settings) for c in accuracy.accuracy_cases(quick=False, models=[label],
                                                                  scenario_names=["catenary"])]

    # native: substeps 1, the model's default d and 4 d (MuJoCo's step never below 5e-4 s / d)
    d = catalog.make_settings("springs").substeps
    springs = [c for c in accuracy.accuracy_cases(quick=False, models=["springs"], scenario_names=["catenary"])
               if c.settings]
    assert {dict(c.settings)["substeps"] for c in springs} == {1, d, 4 * d}
    assert min(c.dt / dict(c.settings)["substeps"] for c in springs) >= accuracy.NATIVE_MIN_STEP / d * (1 - 1e-9)
    # the direct order converges the stretch chain in one iteration: its grid has no more
    assert {g["iterations"] for g in grid("xpbd") if g} == {1}
    assert max(g["iterations"] for g in grid("xpbd-gs") if g) > 1
    assert [c for c in accuracy.convergence_cases(models=["xpbd"])][0].settings == (("iterations", 1),
                                                                                    ("substeps", 4))
    # quick and stress runs take every model's defaults
    assert all(c.settings == () for c in accuracy.accuracy_cases(quick=True) + stress.stress_cases(quick=True))


def test_a_registered_model_is_benchmarked_like_the_others():
    with _registered("throwaway"):
        assert "throwaway" in case.MODEL_LABELS and "throwaway" in case.model_labels(None)
        assert {"throwaway"} <= {c.model for c in accuracy.accuracy_cases(quick=True)}
        assert {"throwaway"} <= {c.model for c in stress.stress_cases(quick=True)}
        assert {"throwaway"} <= {c.model for c in accuracy.stiffness_cases()}  # a particle model
        variants = {dict(c.params)["variant"] for c in accuracy.skip_cases(models=["throwaway"])}
        assert variants == {"none", "unused_floor"}  # MuJoCo's contact switch is for native models only
        row = run_case(Case("catenary", "throwaway", 0.005, n_segments=8, params=(("duration", 0.1),)))
        assert row["outcome"] == "stable", row["reason"]
        assert row["solver"] == "throwaway" and row["substeps"] == catalog.make_settings("xpbd").substeps
        assert row["error"] < 0.05  # the start shape already lies near the catenary
    assert "throwaway" not in case.MODEL_LABELS


# ------------------------------------------------------------------------------------------------ sweep

def _tiny_cases(labels=None):
    return [Case("catenary", label, 0.005, n_segments=8, params=(("duration", 0.05),),
                 settings=() if case.family(label) == "native" else (("iterations", 2), ("substeps", 1)))
            for label in labels or case.MODEL_LABELS]


def test_sweep_writes_csv_and_resumes(tmp_path):
    path = tmp_path / "out" / "bench.csv"
    rows = sweep.run_sweep(_tiny_cases(), path, jobs=1, progress=False)
    assert len(rows) == len(case.MODEL_LABELS)
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        assert reader.fieldnames == results.COLUMNS
        written = list(reader)
    assert {r["model"] for r in written} == set(case.MODEL_LABELS)
    assert {r["scenario"] for r in written} == {"catenary"}
    for r in written:
        assert r["outcome"] == "stable", r  # 0.05 s of a cable hanging near its rest shape
    springs = next(r for r in written if r["model"] == "springs")
    assert float(springs["error"]) < 0.05  # the start shape already lies near the catenary
    assert float(springs["sim_time"]) == pytest.approx(0.05)

    # Resume: nothing to do; after losing the last row, only that run again; a row with an outcome this version
    # does not write (an older version's "unavailable") is run again too.
    assert sweep.run_sweep(_tiny_cases(), path, jobs=1, progress=False) == []
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[:-1]) + "\n")
    again = sweep.run_sweep(_tiny_cases(), path, jobs=1, progress=False)
    assert [r["key"] for r in again] == [written[-1]["key"]]
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[:-1] + [lines[-1].replace(",stable,", ",unavailable,")]) + "\n")
    assert len(sweep.run_sweep(_tiny_cases(), path, jobs=1, progress=False)) == 1
    assert len(results.latest_rows(results.read_rows(path))) == len(case.MODEL_LABELS)


def _complete_rows(path):
    """The rows of the CSV at ``path``, checked line by line with the csv module (not results): every record has
    every column and ends with its line end."""
    data = path.read_bytes()
    assert data.endswith(b"\r\n")
    records = list(csv.reader(data.decode().splitlines()))
    assert records[0] == results.COLUMNS
    assert all(len(r) == len(results.COLUMNS) for r in records[1:]), records
    return [dict(zip(records[0], r)) for r in records[1:]]


@pytest.mark.parametrize("cut", ["mid_row", "line_end", "header"])
def test_resume_removes_a_row_an_interrupted_write_cut_short(tmp_path, cut):
    path = tmp_path / "bench.csv"
    cases = _tiny_cases(["springs", "xpbd"])
    sweep.run_sweep(cases, path, jobs=1, progress=False)
    data = path.read_bytes()
    last = data[:-2].rfind(b"\n") + 1  # where the last row starts
    at = {"mid_row": (last + len(data)) // 2, "line_end": len(data) - 1, "header": data.index(b",", 20)}[cut]
    path.write_bytes(data[:at])  # a kill while the row (or the header) was being written
    where = "the header (line 1)" if cut == "header" else "row 2 (line 3)"
    if cut != "header":
        with pytest.warns(UserWarning, match=rf"{re.escape(str(path))}: row 2 \(line 3\) is cut short"):
            assert [r["key"] for r in results.read_rows(path)] == [cases[0].key]
    with pytest.warns(UserWarning, match=rf"{re.escape(str(path))}: {re.escape(where)} was cut short"):
        again = sweep.run_sweep(cases, path, jobs=1, progress=False)
    assert [r["key"] for r in again] == [c.key for c in (cases if cut == "header" else cases[-1:])]
    rows = _complete_rows(path)
    assert sorted(r["key"] for r in rows) == sorted(c.key for c in cases)  # each run once, every row whole
    assert all(r["outcome"] == "stable" for r in rows)


def test_a_garbled_row_is_left_out_with_a_warning_and_run_again(tmp_path):
    path = tmp_path / "bench.csv"
    cases = _tiny_cases(["springs", "xpbd"])
    sweep.run_sweep(cases, path, jobs=1, progress=False)
    header, first, second = path.read_bytes().split(b"\r\n")[:3]
    path.write_bytes(b"\r\n".join([header, first[:len(first) // 2], second, b""]))  # whole lines, one short
    with pytest.warns(UserWarning, match=r"row 1 \(line 2\) is cut short or garbled"):
        assert results.done_keys(path) == {cases[1].key}
    with pytest.warns(UserWarning, match="garbled"):
        again = sweep.run_sweep(cases, path, jobs=1, progress=False)
    assert [r["key"] for r in again] == [cases[0].key]
    with pytest.warns(UserWarning, match="garbled"):
        assert sorted(r["key"] for r in results.latest_rows(results.read_rows(path))) == sorted(c.key for c in cases)
    # a reason with line breaks still makes one line: a garbled line never runs into the next
    assert results.format_line({**results.empty_row(cases[0]), "reason": "two\nlines"}).count("\n") == 1


@contextlib.contextmanager
def _cluster(processes):
    """A Dask cluster of one single-threaded worker: a process listening on 127.0.0.1, or (``processes=False``) a
    thread of this process reached in memory."""
    where = {"host": "127.0.0.1"} if processes else {}
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=processes, dashboard_address=None,
                                  silence_logs=logging.ERROR, **where) as cluster:
        yield cluster


def test_sweep_on_a_dask_cluster_writes_rows_resumes_and_caps_time(tmp_path):
    path = tmp_path / "out" / "bench.csv"
    saved = Case("catenary", "xpbd", 0.005, n_segments=8, params=(("duration", 0.05), ("save_positions", 1)))
    # 10 s of simulated time (50 000 MuJoCo steps): far more than a 0.1 s cap allows, checked on the worker's
    # thread, where no signal could interrupt it
    capped = Case("catenary", "springs", 0.002, params=(("duration", 10.0),), time_cap=0.1)
    cases = _tiny_cases(["springs", "xpbd"]) + [saved, capped]
    with _cluster(processes=False) as cluster, distributed.Client(cluster) as client:
        rows = sweep.run_sweep(cases, path, scheduler=client, progress=False)
        assert sorted(r["key"] for r in rows) == sorted(c.key for c in cases)
        written = {r["key"]: r for r in results.read_rows(path)}
        assert set(written) == {c.key for c in cases}
        for c in cases[:3]:
            assert written[c.key]["outcome"] == "stable", written[c.key]
            assert written[c.key]["sim_time"] == pytest.approx(0.05)
            assert written[c.key]["error"] < 0.05  # the start shape already lies near the catenary
        assert written[capped.key]["outcome"] == "diverged"
        assert "time cap" in written[capped.key]["reason"]
        assert written[capped.key]["sim_time"] < 10.0
        # the client saved the final positions the worker sent back: a hanging cable between its pins
        x = np.load(results.positions_path(path, saved.key))
        assert x.shape == (9, 3)
        assert np.all(x[:, 2] <= max(x[0, 2], x[-1, 2]) + 1e-9)

        # resume: nothing to do; after losing the last row, only that run again
        assert sweep.run_sweep(cases, path, scheduler=client, progress=False) == []
        lines = path.read_text().splitlines()
        path.write_text("\n".join(lines[:-1]) + "\n")
        again = sweep.run_sweep(cases, path, scheduler=client, progress=False)
    assert [r["key"] for r in again] == [rows[-1]["key"]]
    assert len(results.latest_rows(results.read_rows(path))) == len(cases)


def test_local_jobs_and_a_scheduler_exclude_each_other(tmp_path):
    with pytest.raises(ValueError, match="jobs"):
        sweep.run_sweep(_tiny_cases(["springs"]), tmp_path / "b.csv", jobs=2, scheduler="tcp://127.0.0.1:1")
    with pytest.raises(ValueError, match="scheduler"):
        sweep.run_sweep(_tiny_cases(["springs"]), tmp_path / "b.csv", scheduler=8786)
    assert not (tmp_path / "b.csv").exists()
    # the command line: a local cluster of --jobs workers (default: the CPU count), or --scheduler, never both
    parser = cli.build_parser()
    assert sweep.workers_of(parser.parse_args(["stress", "--scheduler", "tcp://127.0.0.1:1"])) == (
        1, "tcp://127.0.0.1:1")
    assert sweep.workers_of(parser.parse_args(["bench", "--jobs", "3"])) == (3, None)
    assert sweep.workers_of(parser.parse_args(["bench"])) == (sweep.default_jobs(), None)
    with pytest.raises(SystemExit):
        parser.parse_args(["bench", "--jobs", "2", "--scheduler", "tcp://127.0.0.1:1"])


@pytest.mark.slow  # (keeps the quick suite of a cold clone under 5 minutes)
def test_sweep_on_worker_processes_runs_a_model_registered_here(tmp_path):
    # The worker is a process of its own that never saw "throwaway": each task carries the client's catalogue entry.
    path = tmp_path / "bench.csv"
    with _registered("throwaway"), _cluster(processes=True) as cluster:
        rows = sweep.run_sweep(_tiny_cases(["springs", "throwaway"]), path, scheduler=cluster.scheduler_address,
                               progress=False)
    assert sorted(r["model"] for r in rows) == ["springs", "throwaway"]
    assert all(r["outcome"] == "stable" and r["error"] < 0.05 for r in rows), rows
    assert len(results.read_rows(path)) == 2


@pytest.mark.slow
def test_cli_bench_on_a_scheduler_runs_a_model_registered_here(tmp_path, capsys):
    out = tmp_path / "bench"
    with _registered("throwaway"), _cluster(processes=True) as cluster:
        status = cli.main(["bench", "--quick", "--scheduler", cluster.scheduler_address, "--out", str(out),
                           "--models", "throwaway"])
        defaults = {c.key for c in accuracy.accuracy_cases(quick=True, models=["throwaway"])}
        expected = {c.key for c in accuracy.accuracy_cases(quick=True, models=["throwaway"])
                    + accuracy.stiffness_cases(models=["throwaway"])
                    + accuracy.skip_cases(models=["throwaway"], repeats=2)
                    + accuracy.cost_cases(models=["throwaway"])}
    assert status == 0
    rows = results.read_rows(out / "bench.csv")
    assert {r["key"] for r in rows} == expected and len(rows) == len(expected)
    assert {r["model"] for r in rows} == {"throwaway"}
    catenary = [r for r in rows if r["scenario"] == "catenary" and r["key"] in defaults]  # not the equal-error grid
    assert catenary and all(r["outcome"] == "stable" and r["error"] < 0.05 for r in catenary), catenary
    assert all(r["outcome"] in OUTCOMES for r in rows)
    assert cluster.scheduler_address in (out / "pareto.md").read_text()
    assert f"{len(expected)} runs" in capsys.readouterr().out


@pytest.mark.parametrize("model", ["springs", "xpbd"])
def test_stress_load_scenario_adds_the_mass_at_the_end(model):
    load = 10.0
    scene = scenarios.hanging_scene(10)
    sim = mjcable.Simulator(scene, model, dt=0.002)
    start = sim.positions
    scenarios.STRESS_SCENARIOS["load"].setup(sim, {"load": load})
    added = sim.particle_masses - scene.cable.particle_masses
    assert added[-1] == pytest.approx(load * scene.cable.mass)
    assert added[:-1] == pytest.approx(0.0)
    assert sim.positions == pytest.approx(start)
    row = run_case(Case("load", model, 0.002, n_segments=10, params=(("duration", 0.02), ("load", load))))
    assert row["outcome"] == "stable", row["reason"]


# ------------------------------------------------------------------------------------------------ plots

def _row(model, cost, error, scenario="catenary", outcome="stable", **kw):
    return dict(scenario=scenario, model=model, wall_per_sim_s=cost, error=error, outcome=outcome, dt=0.002,
                substeps=1.0, iterations=math.nan, n_segments=50.0, max_strain=0.0, max_penetration=0.0,
                error_kind="m", params="{}", reason="", key=f"{model}{cost}{error}", **kw)


def test_pareto_front_keeps_only_undominated_runs():
    rows = [_row("a", 1.0, 1.0), _row("a", 2.0, 0.5), _row("a", 3.0, 0.7), _row("a", 0.5, 2.0),
            _row("a", 0.1, 0.01, outcome="diverged")]
    front = plots.pareto_front(rows)
    assert [(r["wall_per_sim_s"], r["error"]) for r in front] == [(0.5, 2.0), (1.0, 1.0), (2.0, 0.5)]


def test_plots_and_tables_are_written(tmp_path):
    rows = [_row("springs", 1.0, 1e-3), _row("springs", 3.0, 1e-4), _row("xpbd", 0.2, 1e-2),
            _row("joints", 1.0, math.nan, outcome="diverged")]
    assert plots.work_precision(rows, "catenary", str(tmp_path / "wp.png"))
    assert (tmp_path / "wp.png").stat().st_size > 1000
    md = plots.pareto_markdown(rows)
    assert "| springs |" in md and "| joints | (no stable run" in md
    md = plots.cheapest_markdown(rows, 5e-4)
    assert "| springs | yes | 50 | 0.002 | 1 | – | 0.0001 | 3 |" in md  # the cheaper run misses 5e-4
    assert "| xpbd | no: its lowest error |" in md and "| joints | no stable run (diverged) |" in md
    stress = [dict(_row("springs", 1.0, math.nan, scenario="speed", outcome=o), dt=dt, params=f'{{"speed": {v}}}')
              for o, dt, v in (("stable", 0.002, 1.0), ("diverged", 0.05, 20.0), ("tunneled", 0.05, 1.0))]
    assert plots.stability_map(stress, "springs", str(tmp_path / "map.png"))
    assert "diverged" in plots.outcome_markdown(stress)


def test_contact_penetration_agrees_with_geometry():
    import mujoco

    scene = scenarios.table_scene(10)
    sim = mjcable.Simulator(scene, "springs", dt=0.002)
    m, d = sim.mj_model, sim.mj_data
    depth = 0.003
    drop = scene.cable.particles[0, 2] - (scenarios.TABLE_TOP + scene.cable.radius - depth)
    for i in range(scene.cable.n_particles):  # each free particle has slide joints x, y, z: lower z
        body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"cable{i}")
        d.qpos[m.jnt_qposadr[m.body_jntadr[body] + 2]] = -drop
    mujoco.mj_kinematics(m, d)
    x = d.site_xpos[[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, f"particle{i}") for i in range(11)]]
    assert metrics.penetration(x, scene) == pytest.approx(depth, abs=1e-9)
    assert metrics.contact_penetration(m, d) == pytest.approx(depth, abs=1e-6)
