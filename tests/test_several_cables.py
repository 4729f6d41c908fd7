"""Scenes of several cables (issue 22): the Scene's API, its validation, one-cable scenes left as they were, and the
particle solvers' chains, junctions and cable contacts against physics and independent references."""

import dataclasses
import warnings

import numpy as np
import pytest

import mjcable
from mjcable import catalog, geometry, reference
from mjcable.bench import contact
from mjcable.scene import JUNCTION_TOLERANCE


def cable(points, n=10, **kw):
    return mjcable.CableSpec(points, n, 0.005, 0.06, **kw)


A = cable([[0, 0, 1], [0.6, 0, 1]])                        # 11 particles, ends at x = 0 and 0.6
B = cable([[0.6, 0, 1], [0.6, 0.6, 1]], n=6)               # 7 particles, starts at A's end
C = cable([[0.6, 0, 1], [1.2, 0, 0.9]], n=8)               # 9 particles, starts at A's end
# B and C moved off A's end, 5 cm up and down: cables that must not touch at the start (scenes without junctions)
B_ = cable([[0.6, 0, 1.05], [0.6, 0.6, 1.05]], n=6)
C_ = cable([[0.6, 0, 0.95], [1.2, 0, 0.85]], n=8)


def test_one_cable_scene_keeps_its_cable_and_numbers():
    scene = mjcable.Scene(A, (mjcable.Pin(0),))
    assert scene.cable is A and scene.cables == (A,)
    assert scene.n_particles == 11 and scene.cable_slices == (slice(0, 11),)
    assert scene.particles is A.particles  # the same array: one-cable scenes are unchanged to the bit
    assert mjcable.Scene([A]) == mjcable.Scene(A)  # a sequence of one is the cable itself
    assert scene.junctions == ()


def test_several_cables_concatenate_in_cable_order():
    scene = mjcable.Scene([A, B_, C_])
    assert scene.cable == (A, B_, C_) and scene.cables == (A, B_, C_)
    assert scene.n_particles == 11 + 7 + 9
    assert scene.cable_slices == (slice(0, 11), slice(11, 18), slice(18, 27))
    for c, s in zip(scene.cables, scene.cable_slices):
        np.testing.assert_array_equal(scene.particles[s], c.particles)
    with pytest.raises(ValueError):
        scene.particles[0, 0] = 1.0  # read-only like a cable's


def test_pins_count_within_their_cable():
    pins = (mjcable.Pin(0), mjcable.Pin(-1, cable=1), mjcable.Pin(3, "gripper", cable=2), mjcable.Pin(-1, cable=0))
    scene = mjcable.Scene((A, B_, C_), pins)
    assert [scene.pin_particle(k) for k in range(4)] == [0, 17, 21, 10]
    assert [scene.pin_cable(k) for k in range(4)] == [0, 1, 2, 0]
    np.testing.assert_array_equal(scene.particles[scene.pin_particle(1)], B_.particles[-1])
    assert scene.gripper_pins == (2,)


def test_clamp_neighbour_stays_in_the_pins_cable():
    scene = mjcable.Scene((A, B_), (mjcable.Pin(-1, clamp=True), mjcable.Pin(0, clamp=True, cable=1),
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
        mjcable.Scene((A, B_, C_), (pin,))


def test_two_pins_on_one_global_particle_are_refused():
    with pytest.raises(ValueError, match=r"pins\[0\] and pins\[1\] both hold particle 17 \(cable 1, index 6\)"):
        mjcable.Scene((A, B_, C_), (mjcable.Pin(-1, cable=1), mjcable.Pin(6, cable=1)))
    mjcable.Scene((A, B_, C_), (mjcable.Pin(0, cable=1), mjcable.Pin(0, cable=2)))  # same index, other cable: fine


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
        mjcable.Scene((A, B_), junctions=mjcable.Junction((0, -1), (1, 0)))


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
    scene = mjcable.Scene((A, B_))
    with pytest.raises(ValueError, match=r"with_cable applies to a scene of one cable, this one has 2; use "
                                         r"dataclasses.replace"):
        scene.with_cable(n_segments=20)
    assert mjcable.Scene(A).with_cable(n_segments=20).cable.n_segments == 20


def test_max_tension_counts_every_cables_weight():
    scene = mjcable.Scene((A, B_, C_))
    assert scene.max_tension == pytest.approx(9.81 * (A.mass + B_.mass + C_.mass), rel=1e-15)


def test_scenes_pickle_and_compare():
    import pickle
    scene = mjcable.Scene((A, B), (mjcable.Pin(0, cable=1),), junctions=(mjcable.Junction((0, -1), (1, 0)),))
    assert pickle.loads(pickle.dumps(scene)) == scene
    assert hash(scene) == hash(dataclasses.replace(scene))


def _unable(capability):
    return [n for n in catalog.names() if not getattr(catalog.get(n), capability)]


@pytest.mark.parametrize("model", _unable("several_cables"))
def test_a_model_without_several_cables_refuses_them_up_front(model):
    scene = mjcable.Scene((A, B_), name="pair")
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


# -- the particle solvers: one state, several chains (issue 22) --------------------------------------------------

G = 9.81
PARTICLE = ("jakobsen", "pbd", "xpbd")
ROD = pytest.param("cosserat", marks=pytest.mark.slow)  # the Cosserat rod's several cables (its own compile: slow)
SETTLED = {"jakobsen": {}, "pbd": {}, "xpbd": {}, "cosserat": {}}  # converged statics (catenary test): the defaults


def _sagging(start, end, length, n, **fields):
    """A cable of ``length`` metres and ``n`` segments from ``start`` to ``end`` through a lowered midpoint, the sag
    found so that its chords add up to ``length`` exactly (so that cables of one segment length can be built)."""
    from scipy import optimize

    p0, p1 = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    mid = 0.5 * (p0 + p1)

    def make(depth):
        return mjcable.CableSpec([p0, mid - [0.0, 0.0, depth], p1], n, 0.005, 0.1 * length, **fields)

    depth = optimize.brentq(lambda d: make(d).segment_length * n - length, 1e-4, length, xtol=1e-14)
    return make(depth)


@pytest.mark.parametrize("model", PARTICLE + (ROD,))
def test_two_cables_hang_as_two_catenaries(model):
    """Two cables, each pinned at its ends, side by side in one state: each settles on its own discrete catenary
    and its pins carry its own weight."""
    a = _sagging([-0.4, 0.0, 1.0], [0.4, 0.0, 1.0], 1.0, 50, damping=20.0)
    b = _sagging([-0.3, 0.3, 1.2], [0.3, 0.3, 1.2], 0.8, 40, damping=20.0)
    pins = (mjcable.Pin(0), mjcable.Pin(-1), mjcable.Pin(0, cable=1), mjcable.Pin(-1, cable=1))
    scene = mjcable.Scene((a, b), pins)
    sim = mjcable.Simulator(scene, model, **SETTLED[model])
    sim.step(1.5)
    x, forces = sim.positions, sim.pin_forces
    for c, (cab, part) in enumerate(zip(scene.cables, scene.cable_slices)):
        ref = reference.discrete_catenary(cab.particles[0], cab.particles[-1], cab.segment_length * cab.n_segments,
                                          cab.n_segments, masses=cab.particle_masses)
        assert np.max(np.linalg.norm(x[part] - ref, axis=1)) < 1e-3
        np.testing.assert_allclose(forces[2 * c:2 * c + 2].sum(axis=0), [0.0, 0.0, cab.mass * G],
                                   atol=0.01 * cab.mass * G)


def test_elastic_energy_counts_each_cables_own_rows():
    """Two elastic cables (E·A) hanging side by side: the stretch energy is the sum of each one's ½ (E·A / l₀) C²
    over its own segments (the gap between them stores nothing), and gravity's is −Σ m g·x."""
    ea = 50.0
    cables = (_sagging([-0.4, 0.0, 1.0], [0.4, 0.0, 1.0], 1.0, 50, damping=20.0, stretch_stiffness=ea),
              _sagging([-0.3, 0.3, 1.2], [0.3, 0.3, 1.2], 0.8, 40, damping=20.0, stretch_stiffness=ea))
    pins = (mjcable.Pin(0), mjcable.Pin(-1), mjcable.Pin(0, cable=1), mjcable.Pin(-1, cable=1))
    scene = mjcable.Scene(cables, pins)
    sim = mjcable.Simulator(scene, "xpbd")
    sim.step(1.0)
    x = sim.positions
    expected = 0.0
    for cab, part in zip(scene.cables, scene.cable_slices):
        strain = np.linalg.norm(np.diff(x[part], axis=0), axis=1) - cab.segment_length
        expected += 0.5 * ea / cab.segment_length * float(np.sum(strain**2))
    energy = sim.energy(parts=True)
    assert energy.stretch == pytest.approx(expected, rel=1e-9) and expected > 0.0
    masses = np.concatenate([cab.particle_masses for cab in scene.cables])
    assert energy.gravity == pytest.approx(G * float(masses @ x[:, 2]), rel=1e-12)  # −Σ m g·x, g = −G ẑ


@pytest.mark.parametrize("model", PARTICLE + ("cosserat",))  # (cosserat: the quick suite's one several-cables case)
def test_y_harness_settles_on_the_reference(model):
    """Three 0.6 m cables joined at one junction (two Junctions), their free ends pinned at different heights: the
    particles within 1 mm of the discrete three-leg reference (mjcable.reference_harness.y_harness), the pins carry
    the harness' weight (1 %) and each junction's force holds its leg's end (tension and weight, 2 %)."""
    from mjcable.reference_harness import y_harness

    junction = [0.0, 0.05, 0.6]
    ends = [[-0.4, 0.0, 1.0], [0.4, 0.0, 0.9], [0.0, 0.45, 0.8]]
    cables = tuple(_sagging(e, junction, 0.6, 30, damping=20.0) for e in ends)
    scene = mjcable.Scene(cables, tuple(mjcable.Pin(0, cable=k) for k in range(3)),
                          junctions=(mjcable.Junction((0, -1), (1, -1)), mjcable.Junction((0, -1), (2, -1))))
    sim = mjcable.Simulator(scene, model, **SETTLED[model])
    sim.step(3.0)
    ref = y_harness(ends, [0.6] * 3, [c.mass for c in cables], [30] * 3)
    x = sim.positions
    for part, leg in zip(scene.cable_slices, ref.legs):  # a leg runs from the junction to its pin
        assert np.max(np.linalg.norm(x[part][::-1] - leg, axis=1)) < 1e-3
    weight = sum(c.mass for c in cables) * G
    np.testing.assert_allclose(sim.pin_forces.sum(axis=0), [0.0, 0.0, weight], atol=0.01 * weight)
    for j, k in enumerate((1, 2)):  # junction j holds leg k's end: its tension along the leg, and its weight
        leg = ref.legs[k]
        along = (leg[1] - leg[0]) / np.linalg.norm(leg[1] - leg[0])
        held = -ref.tensions[k] * along + [0.0, 0.0, cables[k].particle_masses[-1] * G]
        np.testing.assert_allclose(sim.junction_forces[j], held, atol=0.02 * np.linalg.norm(held))


@pytest.mark.parametrize("model", PARTICLE + (ROD,))
@pytest.mark.parametrize("dt", [0.002, 0.005])
def test_a_cable_thrown_onto_another_never_passes_through(model, dt):
    """A free cable falls across a pinned one at right angles, striking it at 5 m/s: their centrelines never come
    closer than half the sum of their radii, at any recorded step."""
    r = 0.005
    low = mjcable.CableSpec([[-0.5, 0.0, 1.0], [0.5, 0.0, 1.0]], 50, r, 0.1)
    height = 5.0**2 / (2.0 * G)  # falls 5 m/s onto it
    up = mjcable.CableSpec([[0.05, -0.4, 1.0 + 2 * r + height], [0.05, 0.4, 1.0 + 2 * r + height]], 40, r, 0.08)
    scene = mjcable.Scene((low, up), (mjcable.Pin(0), mjcable.Pin(-1)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # (a limp cable whipping over a rail strains 10 %: not what is tested)
        sim = mjcable.Simulator(scene, model, dt=dt)
        traj = sim.rollout(0.8)
    first, second = scene.cable_slices
    speeds = -np.diff(traj.positions[:, second, 2].mean(axis=1)) / dt
    assert speeds.max() > 4.5  # it struck at about 5 m/s
    closest = min(float(geometry.segment_distances(x[first], x[second]).min()) for x in traj.positions)
    assert r <= closest < 2 * r + 1e-3  # it struck the rail, and never came within half the sum of the radii


# The rope over a taut cable (the capstan law with R_c = r₁ + r₂, mjcable.bench.contact's peg version).
CAPSTAN_MU = 0.3
CAPSTAN_RADIUS = 0.015  # m, both cables: R_c = 0.03 m, the peg's R_c in mjcable.bench.contact's capstan
TAUT_SEGMENTS = 21  # the taut cable's (an odd count: the rope lies over a segment's middle)


def _rope_over_cable(factor: float, *, held: bool = False, radii: tuple = (CAPSTAN_RADIUS,) * 2) -> mjcable.Scene:
    """The capstan's rope (legs at ``factor`` times the heavy-rope law's ratio, R_c = r₁ + r₂, ``radii`` the rope's
    and the cable's) over a horizontal cable of the rope's segment length along y through the peg's axis, pinned
    straight (taut) at both ends, or with ``held`` at every particle."""
    rope_radius, taut_radius = radii
    rope = contact.capstan_scene(factor, mu=CAPSTAN_MU, peg_radius=taut_radius, radius=rope_radius).cable
    span = TAUT_SEGMENTS * rope.segment_length
    taut = mjcable.CableSpec([[0.0, -span / 2, 0.0], [0.0, span / 2, 0.0]], TAUT_SEGMENTS, taut_radius,
                             contact.LINEAR_DENSITY * span, damping=contact.CAPSTAN_DAMPING, friction=CAPSTAN_MU)
    pins = range(TAUT_SEGMENTS + 1) if held else (0, -1)
    return mjcable.Scene((rope, taut), tuple(mjcable.Pin(k, cable=1) for k in pins), name="rope over cable")


def _slide_speed(model: str, dt: float, factor: float, *, held: bool = False, radii: tuple = (CAPSTAN_RADIUS,) * 2,
                 **settings) -> float:
    """The rope's long end's mean speed (m/s) relative to the taut cable's middle over seconds 1 to 3."""
    scene = _rope_over_cable(factor, held=held, radii=radii)
    rope, taut = scene.cable_slices
    middle = (taut.start + taut.stop) // 2
    sim = mjcable.Simulator(scene, model, dt=dt, **settings)
    sim.step(contact.SETTLE_TIME)
    start = sim.positions[rope.stop - 1] - sim.positions[middle]
    sim.step(contact.MEASURE_TIME)
    return float(np.linalg.norm(sim.positions[rope.stop - 1] - sim.positions[middle] - start)) / contact.MEASURE_TIME


@pytest.mark.parametrize("model, dt, settings", [
    ("xpbd", 0.002, {}), ("xpbd", 0.005, {}), ("xpbd", 0.0005, {}),
    # the Gauss-Seidel sweeps leave the cable pinned taut 4 cm of sag, on which the rope bounces
    # (docs/measurements.md); the direct order keeps it straight (the tension's geometric stiffness)
    ("pbd", 0.002, {}), ("jakobsen", 0.002, {}),  # their defaults take the direct order with several cables
    # the limp rod's direct solve carries the tension's geometric stiffness as xpbd's does (Tournier et al. 2015),
    # without which the rope slides at 0.85 (docs/measurements.md, 2026-11-27)
    pytest.param("cosserat", 0.002, {}, marks=pytest.mark.slow),
])
def test_rope_over_a_taut_cable_obeys_the_heavy_capstan_law(model, dt, settings):
    """Held (slower than 2 mm/s) at 0.85 e^{μπ} of the heavy-rope ratio with R_c = r₁ + r₂, sliding (faster than
    100 mm/s) at 1.15 e^{μπ}."""
    assert _slide_speed(model, dt, 0.85, **settings) < contact.HOLD_SPEED
    assert _slide_speed(model, dt, 1.15, **settings) > contact.SLIDE_SPEED


@pytest.mark.slow
@pytest.mark.parametrize("model, settings", [("xpbd", {}), ("pbd", dict(order="direct"))])
def test_rope_over_a_thinner_taut_cable_obeys_the_capstan_law_with_the_sum_of_the_radii(model, settings):
    """A rope of radius 20 mm over a taut cable of half its radius (10 mm): held at 0.85 and sliding at 1.15 of the
    heavy-rope ratio with R_c = r₁ + r₂ = 30 mm, each cable's own radius in their contacts (the distance itself:
    ``tests/test_cable_properties.py``)."""
    radii = (2.0 * CAPSTAN_RADIUS / 1.5, CAPSTAN_RADIUS / 1.5)
    assert _slide_speed(model, 0.002, 0.85, radii=radii, **settings) < contact.HOLD_SPEED
    assert _slide_speed(model, 0.002, 1.15, radii=radii, **settings) > contact.SLIDE_SPEED


@pytest.mark.parametrize("model", ["pbd", pytest.param("jakobsen", marks=pytest.mark.slow),
                                   pytest.param("cosserat", marks=pytest.mark.slow)])
def test_a_rope_over_a_held_cable_obeys_the_capstan_law_in_gauss_seidel_sweeps(model):
    """The capstan law over the same cable held at every particle, on one Gauss-Seidel sweep per substep (the point
    chains' order chosen; the rod's contacts sweep in any order): the sweep splits the wrap's normal load unevenly
    between the chords' contacts, and the friction of each contact between two cables has the load pooled over its
    particles' contacts as its cone."""
    sweeps = {} if model == "cosserat" else dict(order="gauss-seidel")
    assert _slide_speed(model, 0.002, 0.85, held=True, **sweeps) < contact.HOLD_SPEED
    assert _slide_speed(model, 0.002, 1.15, held=True, **sweeps) > contact.SLIDE_SPEED


def test_a_ring_closed_by_a_junction_hangs_from_one_pin():
    """A loop (a junction of one cable's two ends) hanging from one pin: the ends stay one point and the pin carries
    its weight."""
    ring = mjcable.CableSpec([[0.2, 0, 1], [0, 0, 1.2], [-0.2, 0, 1], [0, 0, 0.8], [0.2, 0, 1]], 40, 0.005, 0.1,
                             damping=20.0)
    top = int(np.argmax(ring.particles[:, 2]))
    scene = mjcable.Scene(ring, (mjcable.Pin(top),), junctions=(mjcable.Junction((0, 0), (0, -1)),))
    sim = mjcable.Simulator(scene, "xpbd")
    sim.step(2.0)
    x = sim.positions
    assert np.linalg.norm(x[0] - x[-1]) < 1e-4
    np.testing.assert_allclose(sim.pin_forces[0], [0.0, 0.0, ring.mass * G], atol=0.01 * ring.mass * G)
    assert x[:, 2].min() < 0.85  # it hangs as a loop below its pin


@pytest.mark.parametrize("model", (ROD,))
def test_cables_of_differing_radius_are_refused_naming_it(model):
    thick = mjcable.CableSpec([[0.0, 0.3, 1.0], [0.6, 0.3, 1.0]], 10, 0.01, 0.06)
    with pytest.raises(ValueError, match=r"cables\[1\]: model 'cosserat' holds one radius for all cables, got "
                                         r"0.01 against cables\[0\]'s 0.005"):
        mjcable.Simulator(mjcable.Scene((A, thick)), model)


@pytest.mark.slow
def test_cosserat_cables_apart_move_as_each_alone():
    """Two stiff Cosserat rods (bend–twist rows, the banded solve) hanging apart in one state: the gap between them
    couples nothing, so each moves as it does simulated alone (the same rows, the same arithmetic)."""
    a = _sagging([-0.4, 0.0, 1.0], [0.4, 0.0, 1.0], 1.0, 40, damping=5.0, young=2e6, start_twist=1.0)
    b = _sagging([-0.3, 0.5, 1.2], [0.3, 0.5, 1.2], 0.8, 32, damping=5.0, young=2e6)
    pins = (mjcable.Pin(0), mjcable.Pin(-1), mjcable.Pin(0, cable=1), mjcable.Pin(-1, cable=1))
    scene = mjcable.Scene((a, b), pins)
    both = mjcable.Simulator(scene, "cosserat")
    both.step(0.5)
    x, frames, offset = both.positions, both.frames, 0
    for c, part in enumerate(scene.cable_slices):
        alone = mjcable.Simulator(scene.cable_scene(c), "cosserat")
        alone.step(0.5)
        np.testing.assert_allclose(x[part], alone.positions, rtol=0.0, atol=1e-12)
        n = scene.cables[c].n_segments
        np.testing.assert_allclose(frames[offset:offset + n], alone.frames, rtol=0.0, atol=1e-12)
        offset += n
    assert np.max(np.abs(x[scene.cable_slices[0]] - a.particles)) > 1e-3  # (it moved: the twist and the sag)


def test_cosserat_refuses_what_its_rod_state_cannot_hold():
    """A clamped junction between two cables, and a clamp at a cable end inside the state (not the first cable's
    start or the last one's end), name themselves."""
    leg = cable([[0.6, 0, 1], [0.6, 0.6, 1]])
    welded = mjcable.Scene((A, leg), junctions=(mjcable.Junction((0, -1), (1, 0), clamp=True),))
    with pytest.raises(ValueError, match=r"junctions\[0\]: model 'cosserat' welds .* scene of one cable only"):
        mjcable.Simulator(welded, "cosserat")
    above = cable([[0.6, 0, 1.05], [0.6, 0.6, 1.05]])  # A's segment length, clear of A
    inner = mjcable.Scene((A, above), (mjcable.Pin(-1, clamp=True),))
    with pytest.raises(ValueError, match=r"pins\[0\]: model 'cosserat' clamps the rod's first or last particle "
                                         r"\(0 or 21; of several cables"):
        mjcable.Simulator(inner, "cosserat")


def test_cable_scene_is_one_cable_with_its_own_pins():
    pins = (mjcable.Pin(0), mjcable.Pin(-1, "gripper", cable=1), mjcable.Pin(2, cable=1))
    scene = mjcable.Scene((A, B, C_), pins, obstacles=(mjcable.Floor(pos=(0, 0, 0.5)),),
                          junctions=(mjcable.Junction((0, -1), (1, 0)),))
    one = scene.cable_scene(1)
    assert one.cable is B and one.junctions == () and one.obstacles == scene.obstacles
    assert one.pins == (mjcable.Pin(-1, "gripper"), mjcable.Pin(2))
    assert scene.cable_scene(2).pins == () and scene.cable_scene(0).pins == (mjcable.Pin(0),)
    alone = mjcable.Scene(A, (mjcable.Pin(0),))
    assert alone.cable_scene(0) is alone
    assert [scene.cable_of(i) for i in (0, 10, 11, 17, 18, 26)] == [0, 0, 1, 1, 2, 2]


def test_cables_must_not_start_inside_each_other():
    """Two cables whose surfaces overlap at the start (away from a junction that joins them there) are refused, as a
    cable inside an obstacle is: the contacts would throw them apart. Touching is fine, and so is a junction."""
    with pytest.raises(ValueError, match=r"cables 0 and 1 start inside each other: segment 9 of cable 0 and segment 0 "
                                         r"of cable 1 are 0 m apart, 0.01 m less than their radii's sum 0.01 m"):
        mjcable.Scene((A, B))
    mjcable.Scene((A, B), junctions=(mjcable.Junction((0, -1), (1, 0)),))
    over = cable([[0.3, -0.3, 1.0 + 0.0099], [0.3, 0.3, 1.0 + 0.0099]])  # across A, 0.1 mm into it
    with pytest.raises(ValueError, match=r"cables 0 and 1 start inside each other: segment 4 of cable 0 and "
                                         r"segment 4 of cable 1 are 0.0099 m apart"):
        mjcable.Scene((A, over))
    mjcable.Scene((A, cable([[0.3, -0.3, 1.01], [0.3, 0.3, 1.01]])))  # lying on A: touching
    with pytest.raises(ValueError, match=r"cables 0 and 2 start inside each other"):  # C meets A's end unjoined
        mjcable.Scene((A, B, C), junctions=(mjcable.Junction((0, -1), (1, 0)),))
