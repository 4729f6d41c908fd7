"""The physics monitor (issue 20, item 1): every model checks its own physics after every step, and a breach is an
error naming the check and the fix, or a warning, never a silent wrong result.

The checks are tested on hand-made states (the measured values known by construction), then on the cases that used
to come back wrong without a word: a large ``dt`` on ``hang`` and ``table`` for every model, and a light ``flexrod``
cable under a heavy box. A run "comes back right" when its cable keeps within the inextensible tolerance, its pins
hold and no particle sinks into the table: judged here from the positions, independently of the monitor.
"""

import math
import sys
import warnings

import numpy as np
import pytest

import mjcable
from mjcable import monitor
from mjcable.bench.outcome import classify_exception
from mjcable.solvers import monitor_kernels as mk
from catalog_params import model_params

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from test_user_world import _pendulum_scene  # noqa: E402  (a 0.5 kg box on a 5 g cable, tests/)


def _limits(dt=0.01, strain_fail=1.0, strain_warn=0.1, tear=0.05):
    out = np.zeros(1, dtype=monitor.LIMITS)
    out[0] = (dt, 1e3, 200.0, strain_fail, strain_warn, tear)
    return out


def _chain(n=4, l0=0.1):
    x = np.zeros((n + 1, 3))
    x[:, 0] = l0 * np.arange(n + 1)
    return x, np.full(n, l0)


def _check(x, rest, *, v=None, prev=None, pin_to=None, **lim):
    pin_p = np.array([0], dtype=np.int64)
    pin_to = x[:1].copy() if pin_to is None else pin_to
    return mk.step_check(x, np.zeros_like(x) if v is None else v, x.copy() if prev is None else prev, rest, pin_p,
                         pin_to, np.array([True]), _limits(**lim))


def test_a_state_at_rest_passes():
    x, rest = _chain()
    assert _check(x, rest) == (mk.CHECK_OK, 0.0, -1)


def test_a_stretched_segment_warns_then_fails_with_its_strain():
    x, rest = _chain()
    x[3:, 0] += 0.05  # segment 2: 0.15 m for 0.1 m, strain 0.5
    check, value, where = _check(x, rest)
    assert (check, where) == (mk.WARN_STRAIN, 2) and value == pytest.approx(0.5)
    x[3:, 0] += 0.10  # 0.25 m: strain 1.5, beyond twice the rest length
    check, value, where = _check(x, rest)
    assert (check, where) == (mk.CHECK_STRAIN, 2) and value == pytest.approx(1.5)


def test_a_pinned_particle_off_its_pin_is_torn():
    x, rest = _chain()
    check, value, where = _check(x, rest, pin_to=np.array([[0.0, 0.06, 0.08]]))  # 0.1 m away, tear at 0.05
    assert (check, where) == (mk.CHECK_PIN, 0) and value == pytest.approx(0.1)
    released = mk.step_check(x, np.zeros_like(x), x.copy(), rest, np.array([0], dtype=np.int64),
                             np.array([[0.0, 0.06, 0.08]]), np.array([False]), _limits())
    assert released[0] == mk.CHECK_OK  # a socket that let go holds nothing


def test_the_models_own_velocity_is_checked_beside_the_travel():
    x, rest = _chain()
    v = np.zeros_like(x)
    v[2] = [0.0, 300.0, 400.0]  # 500 m/s while the positions did not move
    check, value, _ = _check(x, rest, v=v)
    assert check == mk.CHECK_VELOCITY and value == pytest.approx(500.0)
    prev = x.copy()
    prev[1, 2] -= 3.0  # travelled 3 m in 0.01 s: 300 m/s
    check, value, _ = _check(x, rest, prev=prev)
    assert check == mk.CHECK_SPEED and value == pytest.approx(300.0)


def test_non_finite_comes_first():
    x, rest = _chain()
    x[1, 1] = math.nan
    check, value, _ = _check(x, rest)
    assert check == mk.CHECK_NON_FINITE and math.isnan(value)


# -------------------------------------------------------------------------------- the cases that used to be silent


def _judge(sim, scene) -> list:
    """What is wrong with the cable now, judged from its positions: strain beyond the inextensible tolerance, a world
    pin's particle more than a segment off its start, a particle deeper in an obstacle than the cable's radius."""
    x = sim.positions
    l0 = scene.cable.segment_length
    wrong = []
    strain = float(np.max(np.linalg.norm(np.diff(x, axis=0), axis=1)) / l0 - 1.0)
    if strain > monitor.STRAIN_TOLERANCE:
        wrong.append(f"strain {strain:.3g}")
    for k in range(len(scene.pins)):
        if scene.pins[k].kind != "world":  # the others move
            continue
        i = scene.pin_particle(k)
        off = float(np.linalg.norm(x[i] - scene.cable.particles[i]))
        if off > max(l0, monitor.TEAR_FRACTION * l0 * scene.cable.n_segments):
            wrong.append(f"pin {k} {off:.3g} m off")
    for ob in scene.obstacles:
        depth = -mjcable.geometry.signed_distances(x, ob)[0]
        if np.max(depth) > scene.cable.radius:
            wrong.append(f"{np.max(depth):.3g} m inside {type(ob).__name__}")
    return wrong


@pytest.mark.slow  # (keeps the quick suite of a cold clone under 5 minutes)
@pytest.mark.parametrize("dt", [0.05, 0.2, 1.0])
@pytest.mark.parametrize("scene_name", ["hang", "table"])
@pytest.mark.parametrize("model", model_params())
def test_a_large_dt_is_right_or_said(model, scene_name, dt):
    """dt of 0.05–1 s used to come back 1.2–72× long, a pin torn 0.8 m off, or 5 m below the floor, silently."""
    scene = mjcable.scenes.get(scene_name)
    with warnings.catch_warnings(record=True) as heard:
        warnings.simplefilter("always")
        try:
            sim = mjcable.Simulator(scene, model, dt=dt)
            sim.step(3.0)
        except mjcable.SimulationDivergedError as error:
            assert error.check in ("strain", "torn pin", "velocity", "speed", "non-finite", "run-off",
                                   "MuJoCo warning"), error
            assert error.model == model and error.step >= 1 and error.fix
            return
    said = [w for w in heard if issubclass(w.category, (mjcable.PhysicsWarning, UserWarning))]
    wrong = _judge(sim, scene)
    assert not wrong or said, f"{model} on {scene_name} at dt = {dt}: {wrong} without a word"


def test_a_heavy_box_on_a_light_flexrod_cable_fails_with_the_fix():
    """A 0.5 kg box on a 5 g flexrod cable at substeps=1 used to stretch it several times its length silently."""
    scene = _pendulum_scene()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mjcable.PhysicsWarning)  # the strain warning on the way
        sim = mjcable.Simulator(scene, "flexrod", substeps=1)
        with pytest.raises(mjcable.SimulationDivergedError) as caught:
            sim.step(2.0)
    error = caught.value
    assert error.check == "strain" and error.value > monitor.STRAIN_FAIL
    text = str(error)
    for part in ("'flexrod'", f"step {error.step}", "check 'strain'", "0.5 kg body 'box' on pin 1", "Fix: use"):
        assert part in text
    x = sim.positions  # the state it stopped at is really that stretched
    assert np.max(np.linalg.norm(np.diff(x, axis=0), axis=1)) / scene.cable.segment_length - 1 > monitor.STRAIN_FAIL


def test_with_enough_substeps_the_box_hangs_without_a_word():
    scene = _pendulum_scene()
    with warnings.catch_warnings():
        warnings.simplefilter("error", mjcable.PhysicsWarning)
        sim = mjcable.Simulator(scene, "flexrod", substeps=4)
        sim.step(1.0)
    assert not _judge(sim, scene)


def test_a_warning_comes_once_per_check():
    scene = mjcable.scenes.get("hang")
    sim = mjcable.Simulator(scene, "xpbd", dt=0.2)  # stretches 20 %: beyond the tolerance, short of failing
    with warnings.catch_warnings(record=True) as heard:
        warnings.simplefilter("always")
        sim.step(1.0)
        sim.step(1.0)
    strain = [w for w in heard if issubclass(w.category, mjcable.PhysicsWarning)]
    assert len(strain) == 1
    text = str(strain[0].message)
    assert text.startswith("xpbd: strain at step ") and "use more substeps" in text
    assert _judge(sim, scene)  # and the cable is indeed stretched beyond the tolerance


def test_an_elastic_cable_may_stretch_as_its_stiffness_says():
    """E·A = 10 N under its own weight stretches by mg / EA ≈ 5 %: within what the model promises, no warning."""
    scene = mjcable.scenes.get("hang", stretch_stiffness=10.0)
    lim = monitor.limits(scene, mjcable.catalog.get("xpbd"))
    assert lim.static_strain == pytest.approx(scene.cable.mass * 9.81 / 10.0, rel=1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("error", mjcable.PhysicsWarning)
        sim = mjcable.Simulator(scene, "xpbd")
        sim.step(2.0)
    strain = np.max(np.linalg.norm(np.diff(sim.positions, axis=0), axis=1)) / scene.cable.segment_length - 1
    assert 0.1 * lim.static_strain < strain < lim.strain_warn


def test_the_sweep_names_the_check():
    error = mjcable.SimulationDivergedError("xpbd", 3, 0.006, "strain 1.5 of segment 2", check="strain", value=1.5)
    assert classify_exception(error, building=False) == ("diverged", "strain: strain 1.5 of segment 2")
