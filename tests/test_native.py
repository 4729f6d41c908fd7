"""MuJoCo's native cable models against physics: the catenary, and one physical cable across models."""

import numpy as np
import pytest

import mjcable
from catalog_params import model_params
from mjcable.scenes import HANG_HEIGHT, HANG_LENGTH, HANG_SPAN

CATENARY_TOL = 5e-3  # m, every particle (the bound for native models at the default dt)


@pytest.fixture(scope="module")
def hang():
    return mjcable.scenes.get("hang", n_segments=50, damping=3.0)


@pytest.mark.slow  # (keeps the quick suite of a cold clone under 5 minutes)
@pytest.mark.parametrize("model", model_params("native"))
def test_settles_to_the_inextensible_catenary(model, hang, catenary):
    sim = mjcable.Simulator(hang, model)  # default dt = 0.002
    sim.step(6.0)
    p = sim.positions
    speed = np.linalg.norm(p - _after(sim, 0.02), axis=1).max() / 0.02
    assert speed < 1e-3, f"not at rest: {speed} m/s"
    s = np.arange(hang.cable.n_particles) * hang.cable.segment_length
    reference = catenary(HANG_LENGTH, HANG_SPAN, HANG_HEIGHT, s)
    error = np.linalg.norm(p - reference, axis=1)
    assert error.max() < CATENARY_TOL, f"{model}: max error {error.max() * 1e3:.2f} mm at particle {error.argmax()}"
    sag = HANG_HEIGHT - p[:, 2].min()
    assert sag == pytest.approx(0.2654, abs=CATENARY_TOL)


def _after(sim, seconds):
    sim.step(seconds)
    return sim.positions


@pytest.mark.parametrize("model", model_params("native"))
def test_same_physical_cable_in_every_model(model, hang):
    sim = mjcable.Simulator(hang, model)
    np.testing.assert_allclose(sim.positions, hang.cable.particles, atol=1e-9)
    assert sim.positions.shape == (51, 3)
    assert np.sum(sim.mj_model.body_mass) == pytest.approx(hang.cable.mass, rel=1e-9)
    chords = np.linalg.norm(np.diff(sim.positions, axis=0), axis=1)
    assert chords.sum() == pytest.approx(HANG_LENGTH, rel=1e-9)


@pytest.mark.parametrize("model", model_params("native"))
@pytest.mark.parametrize("scene_name", mjcable.scenes.names())
def test_builtin_scenes_run_without_warnings(model, scene_name):
    scene = mjcable.scenes.get(scene_name, n_segments=30)
    sim = mjcable.Simulator(scene, model)
    sim.step(1.0)  # raises SimulationDivergedError on any MuJoCo warning, NaN or runaway
    assert np.all(np.isfinite(sim.positions))
    assert not np.any(sim.mj_data.warning.number)
