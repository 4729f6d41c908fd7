import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import mjcable

POINTS = [[0.0, 0.0, 1.0], [0.3, 0.1, 0.7], [0.6, -0.2, 0.9], [1.0, 0.0, 1.2]]


@pytest.mark.parametrize("kind", ["centripetal", "uniform"])
def test_passes_through_control_points(kind):
    curve = mjcable.CatmullRom(POINTS, kind=kind)
    t = np.linspace(0.0, 1.0, len(POINTS))
    np.testing.assert_allclose(curve.position(t), POINTS, atol=1e-14)


def test_uniform_kind_uses_the_thesis_quarter_handles():
    # Bézier handles ±¼·(p[i+1] − p[i−1]) at interior points: the derivative there is 3·¼·(p[i+1] − p[i−1]) per
    # piece of the normalised parameter, i.e. ¾·(p[i+1] − p[i−1])·(m − 1) with respect to t.
    p = np.array(POINTS)
    curve = mjcable.CatmullRom(p, kind="uniform")
    pieces = len(p) - 1
    np.testing.assert_allclose(curve.derivative(1 / 3), 0.75 * (p[2] - p[0]) * pieces, rtol=1e-12)
    np.testing.assert_allclose(curve.derivative(0.0), 0.75 * (p[1] - p[0]) * pieces, rtol=1e-12)


@pytest.mark.parametrize("kind", ["centripetal", "uniform"])
def test_two_points_give_a_straight_cable(kind):
    curve = mjcable.CatmullRom([[0, 0, 0], [1, 2, 2]], kind=kind)
    assert curve.length == pytest.approx(3.0, rel=1e-12)
    p = mjcable.resample(curve, 7)
    direction = np.array([1, 2, 2]) / 3.0
    along = p @ direction
    np.testing.assert_allclose(p, along[:, None] * direction[None], atol=1e-14)
    np.testing.assert_allclose(np.diff(along), 3.0 / 7, rtol=1e-12)


def test_arc_length_of_a_quarter_circle_like_curve_matches_dense_polyline():
    curve = mjcable.CatmullRom(POINTS)
    x = curve.position(np.linspace(0, 1, 200001))
    polyline = np.linalg.norm(np.diff(x, axis=0), axis=1).sum()
    assert curve.length == pytest.approx(polyline, rel=1e-8)


def test_centripetal_has_no_cusp_where_uniform_does():
    # A tight zig-zag: centripetal Catmull-Rom keeps a non-zero speed everywhere (Yuksel et al. 2011).
    pts = [[0, 0, 0], [1, 0, 0], [1.05, 0.0, 0.0], [0.2, 0.05, 0]]
    speed = np.linalg.norm(mjcable.CatmullRom(pts).derivative(np.linspace(0, 1, 3001)), axis=1)
    assert speed.min() > 1e-3


@settings(max_examples=25, deadline=None)
@given(
    pts=st.lists(st.tuples(*[st.floats(-1, 1)] * 3), min_size=2, max_size=6),
    n=st.integers(1, 120),
    kind=st.sampled_from(["centripetal", "uniform"]),
)
def test_resample_equal_chords_on_curve(pts, n, kind):
    pts = np.array(pts)
    if np.min(np.linalg.norm(np.diff(pts, axis=0), axis=1)) < 1e-2 or np.linalg.norm(pts[-1] - pts[0]) < 1e-2:
        return
    curve = mjcable.CatmullRom(pts, kind=kind)
    try:
        p = mjcable.resample(curve, n)
    except ValueError:
        return  # a curve too curly for n equal chords is refused loudly, not silently
    assert p.shape == (n + 1, 3)
    np.testing.assert_array_equal(p[0], curve.position(0.0))
    np.testing.assert_array_equal(p[-1], curve.position(1.0))
    chords = np.linalg.norm(np.diff(p, axis=0), axis=1)
    assert np.max(np.abs(chords - chords.mean())) <= chord_tolerance(chords.mean(), n, p)
    # every particle lies on the curve: its distance to a dense sampling is below the sampling's resolution
    dense = curve.position(np.linspace(0, 1, 20001))
    gaps = np.linalg.norm(dense[None] - p[:, None], axis=2).min(axis=1)
    step = np.linalg.norm(np.diff(dense, axis=0), axis=1).max()
    assert gaps.max() <= step


def chord_tolerance(chord, n, particles):
    """The documented accuracy of equal chords: 1e-9 relative, or 4 n ε |x| where floating point cannot do better."""
    return max(1e-9 * chord, 4 * n * np.finfo(float).eps * np.abs(particles).max())


@pytest.mark.parametrize("offset, n", [(0.0, 4_000), (0.0, 10_000), (100.0, 20_000)])
def test_a_straight_line_resamples_into_many_segments(offset, n):
    """A straight 1 m line has equal chords at any resolution (these were refused as "folding back" when the
    march's round-off, n ε |x|, outgrew 1e-9 of the chord): particle i lies i/n of the way along it."""
    start, end = np.array([offset, 0.0, 0.5]), np.array([offset + 1.0, 0.0, 0.5])
    p = mjcable.resample(mjcable.CatmullRom([start, end]), n)
    exact = start + np.arange(n + 1)[:, None] / n * (end - start)
    assert np.abs(p - exact).max() < 1e-9
    chords = np.linalg.norm(np.diff(p, axis=0), axis=1)
    assert np.abs(chords - 1.0 / n).max() <= chord_tolerance(1.0 / n, n, p)


@pytest.mark.parametrize(
    "points, match",
    [
        ([[0, 0, 0]], "at least 2"),
        ([[0, 0, 0], [0, 0, 0], [1, 0, 0]], "repeat"),
        ([[0, 0, 0], [np.nan, 0, 0]], "finite"),
        ([[0, 0, 0], [np.inf, 0, 0]], "finite"),
        ([[0, 0], [1, 0]], "shape"),
    ],
)
def test_bad_control_points(points, match):
    with pytest.raises(ValueError, match="points") as err:
        mjcable.CatmullRom(points)
    assert match in str(err.value)


def test_bad_kind_and_segments():
    with pytest.raises(ValueError, match="kind"):
        mjcable.CatmullRom(POINTS, kind="chordal")
    with pytest.raises(ValueError, match="n_segments"):
        mjcable.resample(mjcable.CatmullRom(POINTS), 0)
