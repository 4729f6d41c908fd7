import dataclasses
import re
import warnings

import numpy as np
import pytest

import mjcable

PTS = [[0, 0, 1], [0.5, 0, 0.8], [1, 0, 1]]


def cable(**kw):
    args = dict(points=PTS, n_segments=20, radius=0.005, mass=0.1)
    args.update(kw)
    return mjcable.CableSpec(args.pop("points"), args.pop("n_segments"), args.pop("radius"), args.pop("mass"), **args)


@pytest.mark.parametrize(
    "overrides, parameter",
    [
        (dict(points=[[0, 0, 0]]), "points"),
        (dict(points=[[0, 0, 0], [0, 0, 0], [1, 0, 0]]), "points"),
        (dict(points=[[0, 0, 0], [np.nan, 0, 0]]), "points"),
        (dict(points=[[0, 0, 0], [1, np.inf, 0]]), "points"),
        (dict(n_segments=0), "n_segments"),
        (dict(n_segments=2.5), "n_segments"),
        (dict(radius=0.0), "radius"),
        (dict(radius=-1e-3), "radius"),
        (dict(mass=0.0), "mass"),
        (dict(mass=np.nan), "mass"),
        (dict(young=-1.0), "young"),
        (dict(damping=-0.1), "damping"),
        (dict(friction=-0.5), "friction"),
        (dict(stretch_stiffness=0.0), "stretch_stiffness"),
        (dict(kind="bspline"), "kind"),
    ],
)
def test_bad_cable_names_the_parameter(overrides, parameter):
    with pytest.raises(ValueError, match=parameter) as err:
        cable(**overrides)
    value = next(iter(overrides.values()))
    if not isinstance(value, list):
        assert str(value) in str(err.value)  # the bad value is in the message


def test_cable_derived_quantities():
    c = cable(young=2e9, stretch_stiffness=1e4)
    assert c.particles.shape == (21, 3)
    assert c.particle_masses.sum() == pytest.approx(0.1, rel=1e-14)
    assert c.length == pytest.approx(c.segment_length * 20)
    assert c.bending_stiffness == pytest.approx(2e9 * np.pi * 0.005**4 / 4)
    with pytest.raises(ValueError):
        c.particles[0, 0] = 1.0  # the start state is read-only
    with pytest.raises(dataclasses.FrozenInstanceError):
        c.mass = 1.0


@pytest.mark.parametrize("index", [21, -22, 100])
def test_pin_index_out_of_range(index):
    with pytest.raises(ValueError, match=r"pins\[0\]\.index.*\[-21, 20\]"):
        mjcable.Scene(cable(), pins=(mjcable.Pin(index),))


def test_two_pins_on_one_particle():
    with pytest.raises(ValueError, match="two pins on one particle"):
        mjcable.Scene(cable(), pins=(mjcable.Pin(20), mjcable.Pin(-1, "gripper")))


@pytest.mark.parametrize(
    "kwargs, parameter",
    [
        (dict(index=0, kind="hook"), "kind"),
        (dict(index=0, kind="socket"), "release_force"),
        (dict(index=0, kind="socket", release_force=-1.0), "release_force"),
        (dict(index=0, kind="world", release_force=1.0), "release_force"),
        (dict(index=1.5), "index"),
    ],
)
def test_bad_pin(kwargs, parameter):
    with pytest.raises(ValueError, match=parameter):
        mjcable.Pin(**kwargs)


@pytest.mark.parametrize(
    "make, parameter",
    [
        (lambda: mjcable.Box(size=(0.1, 0.0, 0.1)), "size"),
        (lambda: mjcable.Sphere(radius=-1.0), "radius"),
        (lambda: mjcable.Cylinder(radius=0.1, half_length=0.0), "half_length"),
        (lambda: mjcable.Floor(pos=(0, 0)), "pos"),
        (lambda: mjcable.Capsule(friction=-1.0), "friction"),
    ],
)
def test_bad_obstacles(make, parameter):
    with pytest.raises(ValueError, match=parameter):
        make()


def test_unknown_scene_and_model_names():
    with pytest.raises(ValueError, match="scene must be one of"):
        mjcable.scenes.get("trampoline")
    with pytest.raises(ValueError, match="n_segmentz"):
        mjcable.scenes.get("hang", n_segmentz=10)
    scene = mjcable.scenes.get("table", n_segments=10)
    with pytest.raises(ValueError, match="model must be one of .*'rubber'"):
        mjcable.build(scene, "rubber")
    with pytest.raises(ValueError, match="model must be one of"):
        mjcable.Simulator(scene, "rubber")
    with pytest.raises(ValueError, match="dt"):
        mjcable.Simulator(scene, "springs", dt=0.0)
    with pytest.raises(ValueError, match="substeps"):
        mjcable.Simulator(scene, "springs", substeps=0)
    with pytest.raises(ValueError, match="unknown setting"):
        mjcable.Simulator(scene, "springs", iterationz=3)


@pytest.mark.parametrize("name", mjcable.scenes.names())
def test_builtin_scenes_have_equal_chords_and_overrides(name):
    scene = mjcable.scenes.get(name, n_segments=30)
    chords = np.linalg.norm(np.diff(scene.cable.particles, axis=0), axis=1)
    assert scene.cable.n_segments == 30
    np.testing.assert_allclose(chords, chords[0], rtol=1e-9)


def test_hang_scene_is_one_metre_over_eighty_centimetres():
    for n in (10, 50, 100):
        scene = mjcable.scenes.get("hang", n_segments=n)
        assert scene.cable.length == pytest.approx(1.0, rel=1e-9)
        p = scene.cable.particles
        assert np.linalg.norm(p[-1] - p[0]) == pytest.approx(0.8, rel=1e-12)


def test_too_many_segments_is_refused_before_anything_is_allocated():
    with pytest.raises(ValueError, match="n_segments") as err:
        cable(n_segments=10**9)
    assert "1000000000" in str(err.value) and str(mjcable.scene.MAX_SEGMENTS) in str(err.value)
    with pytest.raises(ValueError, match="n_segments"):
        cable(n_segments=mjcable.scene.MAX_SEGMENTS + 1)


@pytest.mark.slow
def test_a_straight_cable_of_max_segments_resamples():
    """A straight 1 m cable of MAX_SEGMENTS segments (100,000) has its equal chords (it was refused as "folding
    back on itself"): particle i lies i/n of the way along the line."""
    n = mjcable.scene.MAX_SEGMENTS
    c = mjcable.CableSpec([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0]], n, 1e-6, 0.1)
    exact = np.array([0.0, 0.0, 1.0]) + np.arange(n + 1)[:, None] / n * np.array([1.0, 0.0, 0.0])
    assert np.abs(c.particles - exact).max() < 1e-9
    assert c.length == pytest.approx(1.0, rel=1e-9)


@pytest.mark.parametrize("field, value, bad", [
    ("obstacles", mjcable.Floor(), mjcable.Floor()),
    ("pins", mjcable.Pin(0), mjcable.Pin(0)),
    ("obstacles", "floor", "floor"),
    ("pins", 0, 0),
    ("obstacles[0]", [mjcable.Pin(0)], mjcable.Pin(0)),
])
def test_scene_wants_sequences_of_pins_and_obstacles(field, value, bad):
    with pytest.raises(ValueError, match=re.escape(field)) as err:
        mjcable.Scene(cable(), **{field.split("[")[0]: value})
    assert repr(bad) in str(err.value)


def straight(z, radius=0.005):
    """A straight 1 m cable along x at height z (m)."""
    return mjcable.CableSpec([[-0.5, 0.0, z], [0.5, 0.0, z]], 20, radius, 0.1)


@pytest.mark.parametrize("obstacle, depth", [
    (mjcable.Box(size=(0.2, 0.2, 0.1), pos=(0.0, 0.0, 0.92)), 0.025),  # top 2 cm above the centreline, + radius
    (mjcable.Sphere(radius=0.1, pos=(0.0, 0.0, 1.0)), 0.105),  # the centre of a particle, + radius
    (mjcable.Floor(pos=(0.0, 0.0, 1.001)), 0.006),
])
def test_a_cable_starting_inside_an_obstacle_is_refused(obstacle, depth):
    with pytest.raises(ValueError, match=r"obstacles\[1\]") as err:
        mjcable.Scene(straight(1.0), obstacles=(mjcable.Floor(), obstacle))
    message = str(err.value)
    assert type(obstacle).__name__ in message
    assert f"{depth:.4g} m deep" in message


def test_a_cable_touching_an_obstacle_is_accepted():
    """Lying on a surface (its radius above it, up to START_CONTACT_TOLERANCE of round-off) is fine; deeper is not."""
    r = 0.005
    tolerance = mjcable.scene.START_CONTACT_TOLERANCE
    mjcable.Scene(straight(r), obstacles=(mjcable.Floor(),))
    mjcable.Scene(straight(r - 0.5 * tolerance), obstacles=(mjcable.Floor(),))
    table = mjcable.Box(size=(0.6, 0.4, 0.02), pos=(0.0, 0.0, 0.68))
    mjcable.Scene(straight(0.7 + r), obstacles=(table,))
    with pytest.raises(ValueError, match=r"obstacles\[0\] \(Floor"):
        mjcable.Scene(straight(r - 2 * tolerance), obstacles=(mjcable.Floor(),))


def test_a_radius_larger_than_a_segment_warns():
    with pytest.warns(UserWarning, match="radius = 0.06 m is larger than a segment .*overlap.*unreliable"):
        straight(1.0, radius=0.06)  # 1 m in 20 segments of 5 cm
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        straight(1.0, radius=0.04)
