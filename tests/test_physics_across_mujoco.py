"""The same physics on every MuJoCo mjcable supports (3.17 and 4.x): ``springs``, ``joints``, ``flexrod`` and
``xpbd`` against the analytic references of :mod:`mjcable.reference` and ``conftest``, with the tolerances of the
models' own tests. Parametrised over what the installed MuJoCo's catalogue has, and free of dm_control and the cable
plugin, so both CI jobs run it (the MuJoCo-4 job with ``-m "not slow and not envs and not composite"``)."""

import mujoco
import numpy as np
import pytest

import mjcable
from mjcable import reference
from mjcable.bench import contact
from mjcable.mjcf import flexrod
from mjcable.scene import GRAVITY, CableSpec, Pin, Scene
from mjcable.scenes import HANG_HEIGHT, HANG_LENGTH, HANG_SPAN

CROSS_VERSION = ("springs", "joints", "flexrod", "xpbd")
MODELS = [m for m in CROSS_VERSION if m in mjcable.catalog.names()]
BENDING = [m for m in MODELS if m != "springs"]  # springs' next-neighbour springs are a qualitative bending model
CATENARY_TOL = 5e-3  # m, every particle at rest (tests/test_native.py)
REST_SPEED = 1e-3  # m/s
BEAM_TOL = 0.10  # relative: discrete chain vs beam theory (tests/test_capsule_chains.py)
CAPSTAN_MU = 0.2  # friction coefficient of the peg (tests/test_contact_families.py)
G = -GRAVITY[2]


def test_every_cross_version_model_is_installed():
    """All four run on MuJoCo 3.17 and 4.x: none may silently drop out of the parametrisation."""
    assert MODELS == list(CROSS_VERSION), f"MuJoCo {mujoco.__version__} lacks {set(CROSS_VERSION) - set(MODELS)}"


@pytest.mark.parametrize("model", MODELS)
def test_hanging_cable_settles_to_the_catenary(model, catenary):
    scene = mjcable.scenes.get("hang", n_segments=50, damping=3.0)
    sim = mjcable.Simulator(scene, model)
    sim.step(6.0)
    p = sim.positions
    sim.step(0.02)
    assert np.linalg.norm(sim.positions - p, axis=1).max() / 0.02 < REST_SPEED
    s = np.arange(scene.cable.n_particles) * scene.cable.segment_length
    error = np.linalg.norm(p - catenary(HANG_LENGTH, HANG_SPAN, HANG_HEIGHT, s), axis=1)
    assert error.max() < CATENARY_TOL, f"{model} on MuJoCo {mujoco.__version__}: {error.max() * 1e3:.2f} mm"
    assert HANG_HEIGHT - p[:, 2].min() == pytest.approx(reference.catenary_sag(HANG_LENGTH, HANG_SPAN),
                                                        abs=CATENARY_TOL)


@pytest.mark.parametrize("model", BENDING)
def test_clamped_cantilever_matches_beam_theory(model):
    length, n, radius, mass, young = 0.5, 40, 0.005, 0.02, 6e8  # tip deflection about 2 % of the length
    scene = Scene(CableSpec([[0.0, 0.0, 1.0], [length, 0.0, 1.0]], n, radius, mass, young=young, damping=20.0),
                  pins=(Pin(0, clamp=True),))
    settings = {"substeps": flexrod.stable_substeps(scene, 0.002)} if model == "flexrod" else {}
    sim = mjcable.Simulator(scene, model, **settings)
    sim.step(2.0)
    q = mass * G / length
    beam = reference.beam_tip_deflection(length, q, scene.cable.bending_stiffness)
    assert 1.0 - sim.positions[-1, 2] == pytest.approx(beam, rel=BEAM_TOL), f"MuJoCo {mujoco.__version__}"


@pytest.mark.parametrize("model", MODELS)
def test_rope_over_a_peg_holds_below_the_capstan_law_and_slides_above(model):
    """Held at 0.85 of the heavy-rope capstan ratio, sliding at 1.15 (the bench's capstan scene and thresholds)."""
    hold = contact.capstan_end_speed(model, 0.002, {}, factor=0.85, mu=CAPSTAN_MU)
    slide = contact.capstan_end_speed(model, 0.002, {}, factor=1.15, mu=CAPSTAN_MU)
    assert hold < contact.HOLD_SPEED, f"{model} on MuJoCo {mujoco.__version__}: slides at {hold} m/s"
    assert slide > contact.SLIDE_SPEED, f"{model} on MuJoCo {mujoco.__version__}: holds at {slide} m/s"
