"""The benchmark machinery: metrics, the outcome classifier, the sweep runner (CSV, resume), plots.

No timing asserts."""

import csv
import math

import numpy as np
import pytest

import mjcable
from mjcable import metrics
from mjcable.bench import plots, scenarios, sweep
from mjcable.bench.sweep import Case
from mjcable.scene import Box, CableSpec, Capsule, Cylinder, Floor, Scene, Sphere


def _scene(*obstacles):
    cable = CableSpec([[0.0, 0.0, 2.0], [1.0, 0.0, 2.0]], 4, 0.01, 0.1)
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


# ------------------------------------------------------------------------------------------------ classifier

def _inject(setup):
    """A scenario (hang, 0.2 s) whose setup does something to the built simulator."""
    base = scenarios.SCENARIOS["catenary"]
    return scenarios.Scenario("injected", "test", base.make_scene, duration=0.2, quick_duration=0.2,
                              error_kind="m", evaluate=base.evaluate, setup=setup)


def test_huge_dt_on_springs_is_classified_diverged():
    # springs keeps its explicit springs stable by softening them as h² (see build/springs.py): at a 0.5 s step
    # the cable stretches without bound, which the classifier calls diverged (runaway strain).
    row = sweep.run_case(Case("catenary", "springs", 0.5, settings=(("substeps", 1),), params=(("duration", 2.0),)))
    assert row["outcome"] == "diverged"
    assert "strain" in row["reason"]


def test_energy_growth_and_silent_reset_are_classified_diverged(monkeypatch):
    def kick(sim, params):  # 10 m/s upwards: 5 J of kinetic energy from nowhere
        sim.mj_data.qvel[:] = 0.0
        sim.mj_data.qvel[2::3] = 10.0

    monkeypatch.setitem(scenarios.EXTRA_SCENARIOS, "injected", _inject(kick))
    row = sweep.run_case(Case("injected", "springs", 0.002))
    assert row["outcome"] == "diverged"
    assert "energy" in row["reason"]

    import mujoco

    def reset_later(sim, t, params):
        if t > 0.1:
            mujoco.mj_resetData(sim.mj_model, sim.mj_data)  # what MuJoCo does silently after mjWARN_BADQACC

    scenario = scenarios.Scenario("reset", "test", scenarios.SCENARIOS["chain"].make_scene, duration=0.3,
                                  quick_duration=0.3, error_kind="none", drive=reset_later)
    monkeypatch.setitem(scenarios.EXTRA_SCENARIOS, "reset", scenario)
    row = sweep.run_case(Case("reset", "springs", 0.002))
    assert row["outcome"] == "diverged"
    assert "silent reset" in row["reason"]


def test_nan_and_time_cap_are_classified_diverged(monkeypatch):
    def poison(sim, params):
        sim.mj_data.qpos[5] = np.nan

    monkeypatch.setitem(scenarios.EXTRA_SCENARIOS, "injected", _inject(poison))
    row = sweep.run_case(Case("injected", "springs", 0.002))
    assert row["outcome"] == "diverged"
    row = sweep.run_case(Case("catenary", "springs", 0.002, time_cap=0.01))
    assert row["outcome"] == "diverged"
    assert "time cap" in row["reason"]


def test_bad_settings_are_rejected_not_crashed():
    row = sweep.run_case(Case("catenary", "springs", 0.002, settings=(("iterations", 3),)))
    assert row["outcome"] == "rejected"
    row = sweep.run_case(Case("nonexistent", "springs", 0.002))
    assert row["outcome"] == "rejected"


# ------------------------------------------------------------------------------------------------ sweep

def _tiny_cases():
    return [Case("catenary", label, 0.005, n_segments=8, params=(("duration", 0.05),),
                 settings=() if sweep.solver_is_native(label) else (("iterations", 2), ("substeps", 1)))
            for label in sweep.MODEL_LABELS]


def test_sweep_writes_csv_and_resumes(tmp_path):
    path = tmp_path / "out" / "bench.csv"
    rows = sweep.run_sweep(_tiny_cases(), path, jobs=1, progress=False)
    assert len(rows) == len(sweep.MODEL_LABELS)
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        assert reader.fieldnames == sweep.COLUMNS
        written = list(reader)
    assert {r["model"] for r in written} == set(sweep.MODEL_LABELS)
    assert {r["scenario"] for r in written} == {"catenary"}
    for r in written:
        assert r["outcome"] in sweep.OUTCOMES, r
    springs = next(r for r in written if r["model"] == "springs")
    assert springs["outcome"] == "stable"
    assert float(springs["error"]) < 0.05  # the start shape already lies near the catenary
    assert float(springs["sim_time"]) == pytest.approx(0.05)

    # Resume: nothing to do; after losing the last row, only that run again.
    rerun = sweep.run_sweep(_tiny_cases(), path, jobs=1, progress=False)
    assert len(rerun) == sum(r["outcome"] == "unavailable" for r in written)  # only unavailable models again
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[:-1]) + "\n")
    again = sweep.run_sweep(_tiny_cases(), path, jobs=1, progress=False)
    assert len(again) >= 1
    assert len(sweep.latest_rows(sweep.read_rows(path))) == len(sweep.MODEL_LABELS)


def test_sweep_in_worker_processes(tmp_path):
    path = tmp_path / "bench.csv"
    cases = [c for c in _tiny_cases() if c.model in ("springs", "xpbd")]
    rows = sweep.run_sweep(cases, path, jobs=2, progress=False)
    assert sorted(r["model"] for r in rows) == ["springs", "xpbd"]
    assert all(r["outcome"] in sweep.OUTCOMES for r in rows)


def test_stress_load_scenario_adds_the_mass():
    row = sweep.run_case(Case("load", "springs", 0.002, params=(("duration", 0.02), ("load", 10.0))))
    assert row["outcome"] in ("stable", "diverged", "tunneled")
    scene = scenarios.hanging_scene(10)
    sim = mjcable.Simulator(scene, "springs", dt=0.002)
    import mujoco

    body = sim.mj_model.site_bodyid[mujoco.mj_name2id(sim.mj_model, mujoco.mjtObj.mjOBJ_SITE, "particle10")]
    before = float(sim.mj_model.body_mass[body])
    start = sim.positions
    scenarios.attach_end_load(sim, 0.5)
    assert sim.mj_model.body_mass[body] == pytest.approx(before + 0.5)
    assert sim.positions == pytest.approx(start)


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
