"""The bench's knot family (issue 22 item 5): a rope in a loose overhand knot pulled taut, every model."""

import warnings

import numpy as np
import pytest

import mjcable
from mjcable import metrics
from mjcable.bench import knot, stress
from mjcable.bench.case import Case
from mjcable.bench.runner import run_case


@pytest.mark.slow
def test_the_knot_row_is_the_least_self_distance_of_a_step_by_step_pull():
    # the runner drives the knot before every step as a user would (knot.knot_drive, then Simulator.step): its
    # error is that run's least distance between two segments in radii, bit for bit, and the knot held
    row = run_case(Case("knot", "xpbd", 0.002, n_segments=60, params=(("save_positions", 1),)))
    assert row["outcome"] == "stable", row["reason"]
    scene = knot.knot_scene(60)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mjcable.PhysicsWarning)
        sim = mjcable.Simulator(scene, "xpbd", self_collision=True)
        knot.knot_setup(sim, {})
        for _ in range(row["steps"]):
            knot.knot_drive(sim, sim.time, {})
            sim.step()
    assert np.array_equal(np.array(row["positions"]), sim.positions)
    skip = scene.cable.overlapping_neighbours()
    least = min(min(scene.runs["distance"]), metrics.self_distance(sim.positions, skip=skip)[0])
    assert row["error"] == pytest.approx(least / scene.cable.radius, rel=1e-12) and row["error"] >= 1.0


@pytest.mark.parametrize("model, outcome, reason", [
    pytest.param("springs", "tunneled", "", marks=pytest.mark.slow),  # spheres at the particles: the strands slip between them
    ("flexrod", "rejected", "self_collision=True needs a radius of at most half a segment"),
])
def test_native_models_that_cannot_hold_the_knot_are_classified(model, outcome, reason):
    row = run_case(Case("knot", model, 0.002, n_segments=100))
    assert row["outcome"] == outcome and reason in row["reason"]


def test_the_knot_is_a_stress_family_over_the_pull_speed():
    cases = [c for c in stress.stress_cases(quick=True, models=["xpbd"]) if c.scenario == "knot"]
    assert sorted((dict(c.params)["speed"], c.dt) for c in cases) == [(0.1, 0.002), (0.1, 0.01), (2.0, 0.002),
                                                                       (2.0, 0.01)]
