"""Fuzz (issue 20): over random scenes, settings and steps, no model returns a cable stretched to twice its rest
length, or a world pin torn away, without an error or a warning.

Hypothesis draws the built-in scene, the cable (segments, radius, mass, stiffness, damping), ``dt`` from 0.1 ms to
1 s, and each model's settings within their documented ranges, 250 examples per model (derandomized: the same
examples on every run). Any ``ValueError`` at construction is a refusal (fine); the judgement of what came back is
made from the positions alone, independently of the monitor.
"""

import warnings

import hypothesis.strategies as st
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings

import mjcable
from catalog_params import model_params

EXAMPLES = int(__import__("os").environ.get("FUZZ_EXAMPLES", 250))  # per model: 1,500 over the six models MuJoCo 3 and 4 share
PARTICLE = set(mjcable.catalog.names("particle"))


@st.composite
def _case(draw, model):
    scene = draw(st.sampled_from(mjcable.scenes.names()))
    cable = dict(n_segments=draw(st.integers(2, 60)),
                 mass=draw(st.floats(1e-3, 1.0)),
                 young=draw(st.sampled_from([0.0, 1e5, 1e7, 1e9])),
                 stretch_stiffness=draw(st.sampled_from([None, 1.0, 100.0, 1e4, 1e6])),
                 damping=draw(st.sampled_from([0.0, 0.5, 5.0])))
    dt = draw(st.floats(1e-4, 1.0))
    options = dict(substeps=draw(st.integers(1, 16)))
    if model in PARTICLE:
        options["iterations"] = draw(st.integers(1, 8))
    return scene, cable, dt, options


ELASTIC = mjcable.catalog.honouring("stretch_stiffness")  # the models whose stretch is E·A


def _wrong(sim, scene) -> list:
    """A cable stretched to twice its rest length (or, elastic, to 20 times its static stretch m g / E·A under its
    own weight), or a world pin's particle torn a tenth of the cable off."""
    x = sim.positions
    cable = scene.cable
    l0 = cable.segment_length
    wrong = []
    strain = float(np.max(np.linalg.norm(np.diff(x, axis=0), axis=1)) / l0 - 1.0)
    static = 0.0 if sim.model not in ELASTIC or cable.stretch_stiffness is None else (
        cable.mass * 9.81 / cable.stretch_stiffness)
    if not strain < max(1.0, 20.0 * static):
        wrong.append(f"strain {strain:.3g}")
    for k, pin in enumerate(scene.pins):
        i = scene.pin_particle(k)
        if pin.kind == "world" and not np.linalg.norm(x[i] - scene.cable.particles[i]) < 0.1 * l0 * len(x):
            wrong.append(f"world pin {k} torn away")
    return wrong


@pytest.mark.slow
@pytest.mark.parametrize("model", model_params(models=[m for m in mjcable.catalog.names() if m != "composite"]))
def test_no_silent_wrong_result(model):
    @settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck))
    @given(_case(model))
    def run(case):
        name, cable, dt, options = case
        with warnings.catch_warnings(record=True) as heard:
            warnings.simplefilter("always")
            try:
                scene = mjcable.scenes.get(name, **cable)
                sim = mjcable.Simulator(scene, model, dt=dt, **options)
            except ValueError:
                return  # refused up front, with the reason
            try:
                sim.step(int(np.clip(0.3 / dt, 3, 60)) * dt)  # 0.3 s, within 3 to 60 steps
            except mjcable.SimulationDivergedError:
                return
        wrong = _wrong(sim, scene)
        said = [w for w in heard if issubclass(w.category, UserWarning)]
        assert not wrong or said, f"{model} {case}: {wrong} without an error or a warning"

    run()
