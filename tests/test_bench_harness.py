"""The bench's harness family (issue 22): the Y-harness through the runner, against the discrete reference."""

import numpy as np
import pytest

from mjcable import catalog
from mjcable.bench import harness
from mjcable.bench.case import Case
from mjcable.bench.runner import run_case


def test_the_harness_scene_is_the_references_three_legs():
    """Three legs of exactly LEG metres from their pins (pinned, index 0) to one point joined by two junctions; the
    reference's pins are the scene's and its junction balances the three legs (its own tests)."""
    scene = harness.y_harness_scene(12)
    assert len(scene.cables) == 3 and len(scene.junctions) == 2
    for c, cable in enumerate(scene.cables):
        assert cable.length == pytest.approx(harness.LEG, abs=1e-12)
        np.testing.assert_allclose(cable.particles[0], harness.PINS[c], atol=1e-12)
        np.testing.assert_allclose(cable.particles[-1], harness.JUNCTION, atol=1e-12)
    ref = harness.y_harness_reference(scene)
    np.testing.assert_allclose([leg[-1] for leg in ref.legs], harness.PINS, atol=1e-9)
    assert harness.y_harness_error(scene, scene.particles) > 0.01  # the start is not the rest


@pytest.mark.slow  # (keeps the quick suite of a cold clone under 5 minutes)
def test_the_harness_family_measures_a_native_model_within_a_millimetre():
    row = run_case(Case("harness", "joints", 0.002, n_segments=20))
    assert row["outcome"] == "stable", row["reason"]
    assert 0.0 < row["error"] < 1e-3, row["error"]


def test_a_model_without_several_cables_is_rejected_with_its_reason():
    without = [m for m in catalog.names() if not catalog.get(m).several_cables]
    if not without:
        pytest.skip("every model holds several cables")
    row = run_case(Case("harness", without[0], 0.002, n_segments=8))
    assert row["outcome"] == "rejected" and "several cables" in row["reason"], row
