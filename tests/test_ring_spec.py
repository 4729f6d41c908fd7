"""Ring validation: bad input names the parameter and the value; a cable must start threaded through each ring."""

import pytest

from mjcable import CableSpec, Ring, Scene

ARCH = ((-0.3, 0.0, 0.5), (-0.1, 0.0, 0.95), (0.0, 0.0, 1.0), (0.1, 0.0, 0.95), (0.3, 0.0, 0.5))


def _cable():
    return CableSpec(ARCH, 40, 0.003, 0.05)


def test_a_threaded_cable_is_accepted_and_the_axis_kept_unit():
    scene = Scene(_cable(), rings=(Ring((0.0, 0.0, 1.0), (2.0, 0.0, 0.0), friction=0.3),))
    assert scene.rings[0].axis == (1.0, 0.0, 0.0)
    assert scene.rings[0].hole(0.003) == pytest.approx(0.006)


@pytest.mark.parametrize("ring, match", [
    (dict(pos=(0.0, 0.0, 0.5), axis=(1.0, 0.0, 0.0)), r"crosses the ring's plane 0\.5 m from its centre"),
    (dict(pos=(0.0, 0.0, 1.0), axis=(0.0, 1.0, 0.0)), "never crosses"),
    (dict(pos=(0.0, 0.0, 1.0), axis=(1.0, 0.0, 0.0), radius=0.002), "radius must exceed the cable's radius"),
    (dict(pos=(0.0, 0.0, 1.0), axis=(1.0, 0.0, 0.0), cable=1), r"rings\[0\]\.cable must lie in \[0, 0\]"),
    (dict(pos=(0.0, 0.0, 1.0), axis=(1.0, 0.0, 0.0), stop=99), "got 99"),
    (dict(pos=(0.0, 0.0, 1.0), axis=(1.0, 0.0, 0.0), body="b"), "has no world"),
])
def test_a_ring_the_cable_does_not_pass_through_is_refused(ring, match):
    with pytest.raises(ValueError, match=match):
        Scene(_cable(), rings=(Ring(**ring),))


@pytest.mark.parametrize("kwargs, match", [
    (dict(axis=(0.0, 0.0, 0.0)), "axis must be a non-zero vector"),
    (dict(friction=-0.1), "friction must be a finite number in"),
    (dict(radius=0.0), "radius must be a finite number in"),
])
def test_bad_ring_arguments_name_the_parameter(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Ring(**{"pos": (0.0, 0.0, 1.0), "axis": (1.0, 0.0, 0.0), **kwargs})
