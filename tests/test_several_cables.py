"""Scenes of several cables (issue 22): the Scene's API, its validation, and one-cable scenes left as they were."""

import dataclasses

import numpy as np
import pytest

import mjcable
from mjcable import catalog
from mjcable.scene import JUNCTION_TOLERANCE


def cable(points, n=10, **kw):
    return mjcable.CableSpec(points, n, 0.005, 0.06, **kw)


A = cable([[0, 0, 1], [0.6, 0, 1]])                        # 11 particles, ends at x = 0 and 0.6
B = cable([[0.6, 0, 1], [0.6, 0.6, 1]], n=6)               # 7 particles, starts at A's end
C = cable([[0.6, 0, 1], [1.2, 0, 0.9]], n=8)               # 9 particles, starts at A's end


def test_one_cable_scene_keeps_its_cable_and_numbers():
    scene = mjcable.Scene(A, (mjcable.Pin(0),))
    assert scene.cable is A and scene.cables == (A,)
    assert scene.n_particles == 11 and scene.cable_slices == (slice(0, 11),)
    assert scene.particles is A.particles  # the same array: one-cable scenes are unchanged to the bit
    assert mjcable.Scene([A]) == mjcable.Scene(A)  # a sequence of one is the cable itself
    assert scene.junctions == ()


def test_several_cables_concatenate_in_cable_order():
    scene = mjcable.Scene([A, B, C])
    assert scene.cable == (A, B, C) and scene.cables == (A, B, C)
    assert scene.n_particles == 11 + 7 + 9
    assert scene.cable_slices == (slice(0, 11), slice(11, 18), slice(18, 27))
    for c, s in zip(scene.cables, scene.cable_slices):
        np.testing.assert_array_equal(scene.particles[s], c.particles)
    with pytest.raises(ValueError):
        scene.particles[0, 0] = 1.0  # read-only like a cable's


def test_pins_count_within_their_cable():
    pins = (mjcable.Pin(0), mjcable.Pin(-1, cable=1), mjcable.Pin(3, "gripper", cable=2), mjcable.Pin(-1, cable=0))
    scene = mjcable.Scene((A, B, C), pins)
    assert [scene.pin_particle(k) for k in range(4)] == [0, 17, 21, 10]
    assert [scene.pin_cable(k) for k in range(4)] == [0, 1, 2, 0]
    np.testing.assert_array_equal(scene.particles[scene.pin_particle(1)], B.particles[-1])
    assert scene.grippers == (2,)


def test_clamp_neighbour_stays_in_the_pins_cable():
    scene = mjcable.Scene((A, B), (mjcable.Pin(-1, clamp=True), mjcable.Pin(0, clamp=True, cable=1),
                                   mjcable.Pin(-1, clamp=True, cable=1)))
    assert [scene.clamp_neighbour(k) for k in range(3)] == [9, 12, 16]


def test_junctions_join_global_particles():
    junctions = (mjcable.Junction((0, -1), (1, 0)), mjcable.Junction((0, 10), (2, 0), clamp=True))
    scene = mjcable.Scene((A, B, C), junctions=junctions)
    assert scene.junctions == junctions
    assert scene.junction_particles(0) == (10, 11) and scene.junction_particles(1) == (10, 18)
    assert junctions[1].clamp and not junctions[0].clamp


def test_a_loop_joins_one_cables_ends():
    ring = cable([[1, 0, 1], [0, 1, 1], [-1, 0, 1], [0, -1, 1], [1, 0, 1]], n=16)
    scene = mjcable.Scene(ring, junctions=(mjcable.Junction((0, 0), (0, -1)),))
    assert scene.junction_particles(0) == (0, 16)


@pytest.mark.parametrize("pin, message", [
    (mjcable.Pin(0, cable=3), r"pins\[0\].cable must lie in \[0, 2\].*got 3"),
    (mjcable.Pin(7, cable=1), r"pins\[0\].index must lie in \[-7, 6\] for cable 1 of 7 particles, got 7"),
    (mjcable.Pin(-10, cable=2), r"pins\[0\].index must lie in \[-9, 8\] for cable 2 of 9 particles, got -10"),
])
def test_pin_out_of_its_cable_names_it(pin, message):
    with pytest.raises(ValueError, match=message):
        mjcable.Scene((A, B, C), (pin,))


def test_two_pins_on_one_global_particle_are_refused():
    with pytest.raises(ValueError, match=r"pins\[0\] and pins\[1\] both hold particle 17 \(cable 1, index 6\)"):
        mjcable.Scene((A, B, C), (mjcable.Pin(-1, cable=1), mjcable.Pin(6, cable=1)))
    mjcable.Scene((A, B, C), (mjcable.Pin(0, cable=1), mjcable.Pin(0, cable=2)))  # same index, other cable: fine


def test_pin_cable_must_be_a_non_negative_integer():
    with pytest.raises(ValueError, match=r"cable must be an integer >= 0, got -1"):
        mjcable.Pin(0, cable=-1)
    with pytest.raises(ValueError, match=r"cable must be an integer >= 0, got 1.0"):
        mjcable.Pin(0, cable=1.0)


@pytest.mark.parametrize("junction, message", [
    (mjcable.Junction((0, -1), (5, 0)), r"junctions\[0\].b.cable must lie in \[0, 2\].*got 5"),
    (mjcable.Junction((0, 11), (1, 0)), r"junctions\[0\].a.index must lie in \[-11, 10\].*got 11"),
    (mjcable.Junction((0, -1), (0, 10)), r"junctions\[0\] joins particle 10 \(cable 0, index 10\) to itself"),
    (mjcable.Junction((0, 0), (1, 0)), r"junctions\[0\]: its particles \(0, 0\) at \[0.0, 0.0, 1.0\] and \(1, 0\) at "
                                       r"\[0.6, 0.0, 1.0\] start 0.6 m apart \(allowed: 1e-06 m\)"),
])
def test_bad_junction_names_it(junction, message):
    with pytest.raises(ValueError, match=message):
        mjcable.Scene((A, B, C), junctions=(junction,))


def test_junction_tolerance_is_a_distance_between_start_points():
    off = cable([[0.6, 0, 1 + 0.5 * JUNCTION_TOLERANCE], [0.6, 0.6, 1]], n=6)
    mjcable.Scene((A, off), junctions=(mjcable.Junction((0, -1), (1, 0)),))
    far = cable([[0.6, 0, 1 + 3 * JUNCTION_TOLERANCE], [0.6, 0.6, 1]], n=6)
    with pytest.raises(ValueError, match=r"start 3e-06 m apart \(allowed: 1e-06 m\)"):
        mjcable.Scene((A, far), junctions=(mjcable.Junction((0, -1), (1, 0)),))


def test_a_junction_given_twice_is_refused():
    with pytest.raises(ValueError, match=r"junctions\[0\] and junctions\[1\] both join particles"):
        mjcable.Scene((A, B), junctions=(mjcable.Junction((0, -1), (1, 0)), mjcable.Junction((1, 0), (0, -1))))


@pytest.mark.parametrize("value, message", [
    ((0, 1, 2), r"a must be a \(cable, index\) pair of integers, got \(0, 1, 2\)"),
    (3, r"a must be a \(cable, index\) pair of integers, got 3"),
    ((-1, 0), r"a\[0\] \(cable\) must be an integer >= 0, got -1"),
    ((0, 0.5), r"a\[1\] \(index\) must be an integer"),
])
def test_junction_ends_are_checked(value, message):
    with pytest.raises(ValueError, match=message):
        mjcable.Junction(value, (1, 0))
    with pytest.raises(ValueError, match="clamp must be a bool"):
        mjcable.Junction((0, 0), (1, 0), clamp=1)


@pytest.mark.parametrize("value, message", [
    ((), "cable must be a CableSpec or a non-empty sequence of them, got an empty sequence"),
    ((A, "rope"), r"cable\[1\] must be a CableSpec, got str"),
    ("rope", "cable must be a CableSpec or a non-empty sequence of them, got str"),
])
def test_bad_cable_sequence(value, message):
    with pytest.raises(ValueError, match=message):
        mjcable.Scene(value)


def test_junctions_must_be_a_sequence_of_junctions():
    with pytest.raises(ValueError, match="junctions must be a sequence of Junction instances"):
        mjcable.Scene((A, B), junctions=mjcable.Junction((0, -1), (1, 0)))


def test_every_cable_must_start_clear_of_the_obstacles():
    low = cable([[0, 0.3, 0.002], [0.6, 0.3, 0.002]])  # its radius 5 mm reaches 3 mm into the floor
    with pytest.raises(ValueError, match=r"obstacles\[0\] \(Floor at pos=\(0.0, 0.0, 0.0\)\) holds the cable's "
                                         r"start: particle 0 of cable 1 at \[0.0, 0.3, 0.002\] is 0.003 m deep"):
        mjcable.Scene((A, low), obstacles=(mjcable.Floor(),))
    with pytest.raises(ValueError, match=r"holds the cable's start: particle 0 at"):  # one cable: as before
        mjcable.Scene(low, obstacles=(mjcable.Floor(),))


def test_every_cable_must_start_clear_of_the_world():
    world = """<mujoco><worldbody><geom name="slab" type="box" pos="0 0.3 0" size="1 1 0.01"/></worldbody></mujoco>"""
    import mujoco
    low = cable([[0, 0.3, 0.012], [0.6, 0.3, 0.012]])  # 3 mm into the slab's top at z = 0.01
    with pytest.raises(ValueError, match=r"world geom 'slab' .* particle \d+ of cable 1 at .* is 0.003 m deep"):
        mjcable.Scene((A, low), world=mujoco.MjSpec.from_string(world))


def test_with_cable_refuses_several_cables():
    scene = mjcable.Scene((A, B))
    with pytest.raises(ValueError, match=r"with_cable applies to a scene of one cable, this one has 2; use "
                                         r"dataclasses.replace"):
        scene.with_cable(n_segments=20)
    assert mjcable.Scene(A).with_cable(n_segments=20).cable.n_segments == 20


def test_max_tension_counts_every_cables_weight():
    scene = mjcable.Scene((A, B, C))
    assert scene.max_tension == pytest.approx(9.81 * (A.mass + B.mass + C.mass), rel=1e-15)


def test_scenes_pickle_and_compare():
    import pickle
    scene = mjcable.Scene((A, B), (mjcable.Pin(0, cable=1),), junctions=(mjcable.Junction((0, -1), (1, 0)),))
    assert pickle.loads(pickle.dumps(scene)) == scene
    assert hash(scene) == hash(dataclasses.replace(scene))


def _unable(capability):
    return [n for n in catalog.names() if not getattr(catalog.get(n), capability)]


@pytest.mark.parametrize("model", _unable("several_cables"))
def test_a_model_without_several_cables_refuses_them_up_front(model):
    scene = mjcable.Scene((A, B), name="pair")
    with pytest.raises(ValueError, match=rf"^{model}: several cables \(2\) in scene 'pair': model '{model}' "):
        mjcable.Simulator(scene, model)
    with pytest.raises(ValueError, match=rf"^{model}: several cables \(2\)"):
        mjcable.build(scene, model)


@pytest.mark.parametrize("model", _unable("junctions"))
def test_a_model_without_junctions_refuses_them_up_front(model):
    ring = cable([[1, 0, 1], [0, 1, 1], [-1, 0, 1], [0, -1, 1], [1, 0, 1]], n=16)
    scene = mjcable.Scene(ring, junctions=(mjcable.Junction((0, 0), (0, -1)),), name="ring")
    with pytest.raises(ValueError, match=rf"^{model}: junctions \(1\) in scene 'ring': model '{model}' "):
        mjcable.Simulator(scene, model)
