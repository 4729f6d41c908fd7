"""The Simulator's public API on every model of the catalogue, against physics: pin forces of a hanging cable (the
catenary's horizontal tension H = a·w, the weight), exact reset, rollout = repeated steps, settings that rebuild the
same simulator, velocities, energy and point masses."""

import dataclasses

import mujoco
import numpy as np
import pytest
from scipy import optimize

import mjcable
from catalog_params import model_params
from mjcable import catalog
from mjcable.scenes import HANG_LENGTH, HANG_SPAN

G = 9.81
MODELS = mjcable.MODELS
MODEL_PARAMS = model_params()
REST_SECONDS = 4.0  # s: the 20-segment hang, damped at DAMPING, is at rest (checked below)
DAMPING = 6.0  # 1/s


@pytest.fixture(scope="module")
def hang():
    return mjcable.scenes.get("hang", n_segments=20, damping=DAMPING)


@pytest.fixture(scope="module")
def at_rest(hang):
    """Every model's simulator after settling on ``hang`` (shared by the tests that only read it)."""
    sims = {}
    for model in MODELS:
        sim = mjcable.Simulator(hang, model)
        sim.step(REST_SECONDS)
        sims[model] = sim
    return sims


def catenary_parameter(length: float, span: float) -> float:
    """a of the catenary z = a cosh(x / a) of ``length`` over ``span``: 2 a sinh(span / 2a) = length."""
    return optimize.brentq(lambda a: 2 * a * np.sinh(span / (2 * a)) - length, 1e-3 * span, 1e3 * span, xtol=1e-15)


@pytest.mark.parametrize("model", MODEL_PARAMS)
def test_pin_forces_of_a_hanging_cable_carry_its_weight_and_the_catenary_tension(model, hang, at_rest):
    sim = at_rest[model]
    assert np.abs(sim.velocities).max() < 2e-3, "not at rest"
    f = sim.pin_forces
    assert f.shape == (2, 3)
    weight = hang.cable.mass * G
    assert f[:, 2].sum() == pytest.approx(weight, rel=0.01)
    a = catenary_parameter(HANG_LENGTH, HANG_SPAN)
    tension = a * weight / HANG_LENGTH  # H = a·w with w the weight per metre
    # the left pin (x = −span/2) pulls left, the right one right, each with H
    assert -f[0, 0] == pytest.approx(tension, rel=0.02)
    assert f[1, 0] == pytest.approx(tension, rel=0.02)
    np.testing.assert_allclose(f[:, 1], 0.0, atol=1e-6 * weight)
    np.testing.assert_allclose(sim.pin_torques, 0.0, atol=1e-5 * weight * HANG_LENGTH)  # world pins, no clamps


@pytest.mark.parametrize("model", MODEL_PARAMS)
def test_clamped_cantilever_pin_carries_weight_and_moment(model):
    """A clamped horizontal rod (stiff enough for every model at the default dt): the clamp's force is the weight
    and its torque the weight's moment about the root, W·x̄ (x̄ the centre of mass's lever arm), in whatever shape
    the rod settles."""
    cable = mjcable.CableSpec([[0, 0, 1], [0.2, 0, 1]], 10, 0.005, 0.02, young=1e6, damping=20.0)
    scene = mjcable.Scene(cable, pins=(mjcable.Pin(0, clamp=True),))
    sim = mjcable.Simulator(scene, model)
    sim.step(2.0)
    weight = cable.mass * G
    f = sim.pin_forces[0]
    assert f[2] == pytest.approx(weight, rel=0.01)
    x = sim.positions
    lever = np.sum(sim.particle_masses * (x[:, 0] - x[0, 0])) / cable.mass
    # the torque about the root that holds the weight: −y component W·x̄ for a rod along +x under −z gravity
    assert -sim.pin_torques[0, 1] == pytest.approx(weight * lever, rel=0.03)


@pytest.mark.parametrize("model", MODEL_PARAMS)
def test_reset_restores_the_start_exactly(model):
    scene = mjcable.scenes.get("socket", n_segments=12, damping=1.0)
    sim = mjcable.Simulator(scene, model)
    x0, v0 = sim.positions, sim.velocities
    g0 = sim.gripper_positions
    sim.move_gripper(1, g0[0] + [0.02, 0.0, 0.01])
    sim.step(0.1)
    first = sim.positions
    sim.reset()
    assert sim.steps == 0 and sim.time == 0.0
    np.testing.assert_array_equal(sim.positions, x0)
    np.testing.assert_array_equal(sim.velocities, v0)
    np.testing.assert_array_equal(sim.gripper_positions, g0)
    sim.move_gripper(1, g0[0] + [0.02, 0.0, 0.01])
    sim.step(0.1)
    np.testing.assert_array_equal(sim.positions, first)  # the same run again, bit for bit


@pytest.mark.parametrize("model", MODEL_PARAMS)
def test_rollout_equals_repeated_steps(model):
    scene = mjcable.scenes.get("table", n_segments=12)
    stepped = mjcable.Simulator(scene, model)
    rolled = mjcable.Simulator(scene, model)
    times, xs, vs = [], [], []
    for _ in range(25):
        stepped.step()
        times.append(stepped.time)
        xs.append(stepped.positions)
        vs.append(stepped.velocities)
    traj = rolled.rollout(25 * rolled.dt + 0.3 * rolled.dt)  # the remainder carries over, as in step
    assert traj.positions.shape == (25, 13, 3) and traj.velocities.shape == (25, 13, 3) and traj.times.shape == (25,)
    np.testing.assert_array_equal(traj.times, times)
    np.testing.assert_array_equal(traj.positions, xs)
    np.testing.assert_array_equal(traj.velocities, vs)
    np.testing.assert_array_equal(traj.positions[-1], rolled.positions)  # the last row is the final state
    sparse = rolled.rollout(0.7 * rolled.dt + 10 * rolled.dt, every=4)  # 11 steps with the carried 0.3 dt
    assert len(sparse) == 3 and rolled.steps == 36  # rows after steps 4, 8 and the last, 11
    np.testing.assert_allclose(np.diff(sparse.times), [4 * rolled.dt, 3 * rolled.dt])
    np.testing.assert_array_equal(sparse.positions[-1], rolled.positions)


def test_rollout_validates_and_records_the_current_state_without_a_whole_step(hang):
    sim = mjcable.Simulator(hang, "xpbd")
    traj = sim.rollout(0.0)
    assert len(traj) == 1 and traj.times[0] == 0.0
    np.testing.assert_array_equal(traj.positions[0], sim.positions)
    with pytest.raises(ValueError, match="every"):
        sim.rollout(0.1, every=0)
    with pytest.raises(ValueError, match="seconds"):
        sim.rollout(-1.0)


@pytest.mark.parametrize("model", MODEL_PARAMS)
def test_settings_rebuild_the_same_simulator(model):
    scene = mjcable.scenes.get("table", n_segments=10)
    sim = mjcable.Simulator(scene, model, dt=0.004)
    assert isinstance(sim.settings, catalog.get(model).settings)
    with pytest.raises(dataclasses.FrozenInstanceError):
        sim.settings.substeps = 3
    again = mjcable.Simulator(sim.scene, sim.model, dt=sim.dt, **dataclasses.asdict(sim.settings))
    assert again.settings == sim.settings
    sim.step(0.1)
    again.step(0.1)
    np.testing.assert_array_equal(again.positions, sim.positions)


@pytest.mark.parametrize("model", MODEL_PARAMS)
def test_velocities_are_the_rate_of_change_of_positions(model):
    scene = mjcable.Scene(mjcable.CableSpec([[0, 0, 2], [0.5, 0, 2.2], [1, 0, 2]], 10, 0.005, 0.1))
    sim = mjcable.Simulator(scene, model, dt=0.001)
    sim.step(0.2)
    x0, v0 = sim.positions, sim.velocities
    sim.step()
    x1, v1 = sim.positions, sim.velocities
    # the centre of mass of a free cable falls with g: v_z = −g t (to the integrators' first order in dt)
    com_v = np.average(v1, axis=0, weights=sim.particle_masses)
    assert com_v[2] == pytest.approx(-G * sim.time, rel=0.02)
    np.testing.assert_allclose((x1 - x0) / sim.dt, 0.5 * (v0 + v1), atol=0.02)


@pytest.mark.parametrize("model", MODEL_PARAMS)
def test_energy_of_a_free_fall_is_conserved_and_damping_only_removes_it(model):
    cable = mjcable.CableSpec([[0, 0, 2], [1, 0, 2]], 10, 0.005, 0.1)
    sim = mjcable.Simulator(mjcable.Scene(cable), model, dt=0.001)
    e0 = sim.energy()
    assert e0 == pytest.approx(cable.mass * G * 2.0, rel=1e-6)  # at rest at z = 2: m g z
    sim.step(0.3)
    assert sim.energy() == pytest.approx(e0, abs=0.02 * cable.mass * G * 0.3**2 * G / 2)
    damped = mjcable.Simulator(mjcable.scenes.get("hang", n_segments=10, damping=5.0), model)
    energies = []
    for _ in range(10):
        damped.step(0.1)
        energies.append(damped.energy())
    assert energies[-1] < energies[0]


@pytest.mark.parametrize("model", MODEL_PARAMS)
def test_point_mass_adds_its_weight_to_the_pins_and_survives_reset(model, hang):
    sim = mjcable.Simulator(hang, model)
    load = 0.05  # kg at the middle particle
    sim.add_point_mass(10, load)
    assert sim.particle_masses.sum() == pytest.approx(hang.cable.mass + load, rel=1e-12)
    sim.step(REST_SECONDS)
    assert sim.pin_forces[:, 2].sum() == pytest.approx((hang.cable.mass + load) * G, rel=0.01)
    sim.reset()
    assert sim.particle_masses.sum() == pytest.approx(hang.cable.mass + load, rel=1e-12)
    with pytest.raises(ValueError, match="mass"):
        sim.add_point_mass(0, -1.0)
    with pytest.raises(ValueError, match="index"):
        sim.add_point_mass(21, 0.1)


def test_a_registered_model_runs_in_the_simulator_with_no_other_edit(hang):
    entry = dataclasses.replace(catalog.get("xpbd"), name="throwaway", summary="a test copy of xpbd")
    catalog.register(entry)
    try:
        assert "throwaway" in mjcable.MODELS and "throwaway" in mjcable.PARTICLE_MODELS
        sim = mjcable.Simulator(hang, "throwaway")
        sim.step(0.1)
        ref = mjcable.Simulator(hang, "xpbd")
        ref.step(0.1)
        np.testing.assert_array_equal(sim.positions, ref.positions)
        with pytest.raises(ValueError, match="already registered"):
            catalog.register(entry)
    finally:
        catalog.unregister("throwaway")
    assert "throwaway" not in mjcable.MODELS
    with pytest.raises(ValueError, match="model must be one of"):
        mjcable.Simulator(hang, "throwaway")


def test_catalogue_entries_are_validated():
    good = catalog.get("xpbd")
    with pytest.raises(ValueError, match="family"):
        dataclasses.replace(good, name="x", family="other")
    with pytest.raises(ValueError, match="rules"):
        dataclasses.replace(good, name="x", rules=None)
    with pytest.raises(ValueError, match="settings"):
        dataclasses.replace(good, name="x", settings=dict)
    with pytest.raises(ValueError, match="unknown setting"):
        catalog.make_settings("springs", iterations=3)


@pytest.mark.slow  # PBD's user constraints compile the step's pieces apart (kernels.run_phase)
def test_settings_with_user_constraints_rebuild_the_same_simulator(hang):
    floor = mjcable.solvers.UserConstraint(particles=(10,), function=lambda p: p[0, 2] - 0.8, inequality=True)
    sim = mjcable.Simulator(hang, "pbd", constraints=[floor])
    again = mjcable.Simulator(sim.scene, sim.model, dt=sim.dt, **dataclasses.asdict(sim.settings))
    assert again.settings == sim.settings  # asdict turned the constraint into a mapping; the settings rebuild it
    sim.step(0.2)
    again.step(0.2)
    np.testing.assert_array_equal(again.positions, sim.positions)
    assert sim.positions[10, 2] > 0.8 - 1e-9  # the user's floor holds


def test_composite_is_in_the_catalogue_exactly_where_the_cable_plugin_is():
    """MuJoCo 3.x: composite is registered. MuJoCo 4 (no cable plugin): it is not, and every way of asking for it
    raises a ValueError that says MuJoCo 4 removed the plugin and names the models that bend instead."""
    from mjcable.mjcf import composite

    if composite.missing_plugin() is None:
        assert "composite" in mjcable.MODELS and not catalog.unavailable()
        return
    assert "composite" not in mjcable.MODELS and set(catalog.unavailable()) == {"composite"}
    scene = mjcable.scenes.get("hang")
    for ask in (lambda: mjcable.Simulator(scene, "composite"), lambda: catalog.get("composite"),
                lambda: mjcable.build(scene, "composite"), lambda: composite.build(scene, timestep=0.002)):
        with pytest.raises(ValueError, match=r"MuJoCo 4 removed.*flexrod, joints, and xpbd, pbd or jakobsen"):
            ask()


# --- inputs no step can simulate get a ValueError before anything is built -------------------------------------


@pytest.mark.parametrize("model", ["springs", "xpbd"])
def test_a_step_below_a_nanosecond_is_refused(model):
    scene = mjcable.scenes.get("hang", n_segments=8)
    with pytest.raises(ValueError, match=r"dt must be a finite number in \[1e-09, inf\) s, got 1e-30"):
        mjcable.Simulator(scene, model, dt=1e-30)
    with pytest.raises(ValueError, match=r"substeps must leave a substep dt / substeps of at least 1e-09 s, got "
                                         r"substeps=5000 at dt=1e-06 s \(at most 99\d substeps"):
        mjcable.Simulator(scene, model, dt=1e-6, substeps=5000)
    with pytest.raises(ValueError, match=r"substeps=5000"):
        mjcable.build(scene, model, dt=1e-6, substeps=5000)


def test_a_cable_starting_beyond_the_divergence_distance_is_refused():
    """A start 2 km from the origin is an input no step can take (its first check would call it run off), so it is a
    ValueError naming the distance and the limit, not a SimulationDivergedError."""
    far = mjcable.CableSpec([[2000.0, 0.0, 1.0], [2000.5, 0.0, 1.0]], 8, 0.004, 0.05)
    with pytest.raises(ValueError, match=r"cable starts 2000.5 m from the origin, beyond the 1000 m"):
        mjcable.Simulator(mjcable.Scene(far), "xpbd")


def test_a_world_with_non_finite_gravity_is_refused():
    spec = mujoco.MjSpec.from_string('<mujoco><option gravity="0 0 nan"/><worldbody/></mujoco>')
    cable = mjcable.CableSpec([[0.0, 0.0, 1.0], [0.5, 0.0, 1.0]], 8, 0.004, 0.05)
    with pytest.raises(ValueError, match=r"<option gravity> must be 3 finite numbers in m/s², got \[0.0, 0.0, nan\]"):
        mjcable.Scene(cable, world=spec)


@pytest.mark.parametrize("model", ["joints", "springs"])
def test_a_cable_too_light_for_mujoco_names_its_mass(model):
    cable = mjcable.CableSpec([[0.0, 0.0, 1.0], [0.5, 0.0, 1.0]], 8, 0.004, 1e-30)
    with pytest.raises(ValueError, match=rf"{model}: MuJoCo cannot compile this scene .*the cable's mass 1e-30 kg over "
                                         r"8 segments"):
        mjcable.Simulator(mjcable.Scene(cable), model)


@pytest.mark.parametrize("model", ["springs", "xpbd"])
def test_more_substeps_or_steps_than_one_call_can_take_are_refused(model):
    """substeps=10**9 or step(1e12) used to be accepted and never return."""
    scene = mjcable.scenes.get("hang", n_segments=4)
    with pytest.raises(ValueError, match=r"substeps must be an integer >= 1 and <= 10000, got 1000000000"):
        mjcable.Simulator(scene, model, substeps=10**9)
    sim = mjcable.Simulator(scene, model)
    with pytest.raises(ValueError, match=r"seconds = 1e\+12 is 5e\+14 steps .* beyond the 1e\+09 steps"):
        sim.step(1e12)
    with pytest.raises(ValueError, match=r"would record 500000001 rows .* GiB"):
        sim.rollout(1e6)
    assert sim.steps == 0 and sim.time == 0.0  # refused before anything ran
    sim.step(0.01)
    assert sim.steps == 5
