"""XPBD's direct order (one banded solve of the whole chain per iteration) against physics: it survives large
rotations within a substep (a gripper yanking a straight cable, a pin moving more than a segment per substep), and
where one linearised solve already works it still gives the stated stiffness and the catenary."""

import math

import numpy as np
import pytest

import mjcable
from mjcable import reference
from mjcable.bench.scenarios import yank_scene

G = 9.81
UP_AND_AWAY = np.array([-1.0, 0.0, 1.0]) / math.sqrt(2.0)  # the gripper pulls away from the cable and up
YANK_DISTANCE = 0.5  # m
# An inextensible cable solved with one iteration per substep keeps some stretch where contacts are projected after
# the solve (about 10 % on the first step of a yank along a table with friction μ = 1); a quarter of a segment's
# length is a cable still, far from the runaway (≥ 150 %) of an unguarded linearised solve.
YANK_STRAIN_BOUND = 0.25
RUNAWAY = 3.0  # strain: an unguarded linearised solve passes this within a few steps and grows without bound


def _strain(x: np.ndarray, rest: float) -> np.ndarray:
    return np.abs(np.linalg.norm(np.diff(x, axis=0), axis=1) / rest - 1.0)


def _yank(model: str, speed: float, dt: float, after: float) -> tuple:
    """Pull the gripper of :func:`yank_scene` 0.5 m up and away at ``speed`` m/s, then hold it for ``after`` s
    (4 substeps of 1 iteration, the stress sweep's settings). Returns (largest strain seen, final positions,
    gripper target)."""
    scene = yank_scene(50)
    sim = mjcable.Simulator(scene, model, dt=dt, substeps=4, iterations=1, order="direct")
    start = np.asarray(scene.cable.particles[0])
    target = start + YANK_DISTANCE * UP_AND_AWAY
    worst = 0.0
    for k in range(round((YANK_DISTANCE / speed + after) / dt)):
        sim.move_gripper(0, start + min((k + 1) * dt * speed, YANK_DISTANCE) * UP_AND_AWAY)
        sim.step()
        x = sim.positions
        assert np.all(np.isfinite(x))
        worst = max(worst, float(np.max(_strain(x, scene.cable.segment_length))))
    return worst, sim.positions, target


@pytest.mark.parametrize("model", ["xpbd", "pbd", "jakobsen"])
def test_direct_order_survives_a_20_m_s_yank_at_2_ms(model):
    """The gripper moves 1 cm per substep, more than half a segment (1.8 cm), at 45° to a cable lying straight on
    a table: a single linearised solve flings the next particle sideways and ran away (strain 150 %)."""
    worst, x, target = _yank(model, speed=20.0, dt=0.002, after=0.1)
    assert worst < YANK_STRAIN_BOUND
    np.testing.assert_allclose(x[0], target, atol=1e-12)  # the held end is where the gripper is


def test_direct_order_survives_a_pin_moving_more_than_a_segment_per_substep():
    """2 m/s at dt = 50 ms: the gripper jumps 2.5 cm per substep, more than a segment, where Newton steps on the
    linearised chain do not converge and Gauss-Seidel projections take over. The cable is dragged off the table's
    edge and whips round the gripper at 12.5 ms substeps (strain up to about 1.5 in the swing: one iteration does
    not converge there), but it never runs away, and once the swing has died down it is a cable again."""
    worst, x, _ = _yank("xpbd", speed=2.0, dt=0.05, after=2.0)
    assert worst < RUNAWAY
    assert np.max(_strain(x, yank_scene(50).cable.segment_length)) < YANK_STRAIN_BOUND


def test_one_direct_iteration_shrinks_the_stretch_of_a_jump():
    """A free cable (no obstacles) whose held end jumps by 0.55 segment lengths at 45° within one substep: one
    iteration must leave every segment nearer its rest length than the jump left the first one (the unguarded
    solve stretched the second segment by 65 % after a 45 % jump)."""
    cable = mjcable.CableSpec([[0.0, 0.0, 1.0], [0.9, 0.0, 1.0]], 50, 0.005, 0.1)
    scene = mjcable.Scene(cable, pins=(mjcable.Pin(0, "gripper"),))
    sim = mjcable.Simulator(scene, "xpbd", dt=0.0005, substeps=1, iterations=1, order="direct")
    l0 = cable.segment_length
    p0, p1 = np.asarray(cable.particles[0]), np.asarray(cable.particles[1])
    jumped = p0 + 0.55 * l0 * UP_AND_AWAY
    jump_strain = np.linalg.norm(p1 - jumped) / l0 - 1.0  # the stretch the jump gives the first segment
    sim.move_gripper(0, jumped)
    sim.step()
    assert np.max(_strain(sim.positions, l0)) < jump_strain


@pytest.mark.parametrize("dt", [0.02, 0.002])
def test_direct_hanging_elongation_is_w_l_over_2_e_a_at_one_iteration(dt):
    """A cable of weight W hanging from its top stretches by ∫ T ds / E·A = W L / (2 E·A) (tension T(s) = W s / L
    at height s above its free end); also for lumped particles, whose segment tensions sum to the same."""
    ea, length, mass = 50.0, 1.0, 0.1
    cable = mjcable.CableSpec([[0, 0, 1.5], [0, 0, 1.5 - length]], 50, 0.005, mass, stretch_stiffness=ea,
                              damping=20.0)
    sim = mjcable.Simulator(mjcable.Scene(cable, pins=(mjcable.Pin(0),)), "xpbd", dt=dt, iterations=1,
                            order="direct")
    sim.step(1.0)
    x = sim.positions
    elongation = float(x[0, 2] - x[-1, 2]) - length
    assert elongation == pytest.approx(mass * G * length / (2.0 * ea), rel=1e-3)


def test_direct_catenary_within_a_millimetre():
    sim = mjcable.Simulator(mjcable.scenes.get("hang", damping=8.0), "xpbd", iterations=1, order="direct")
    sim.step(2.0)
    x = sim.positions
    curve = reference.catenary(x[0], x[-1], sim.scene.cable.length)
    assert np.max(reference.distance_to_curve(x, curve)) < 1e-3


# -- fine segments: the tension's transverse waves -------------------------------------------------------------

FINE_SEGMENTS = 1600
# A hanging chain's tension T carries transverse waves at c = √(T / μ) (μ: mass per length; about 2.4 m/s at the top
# of the hang scene, from the catenary). A solve that takes the segment directions from the predicted positions
# ([M16] drops the geometric stiffness λ ∇²C) makes the transverse restoring force explicit: stable only for a
# Courant number c h / l₀ below about 1 (h the substep). At 1600 segments (l₀ = 0.625 mm) that is 1.95 with the
# default 4 substeps of 2 ms and 0.49 with 16; the direct order includes the geometric stiffness there.
INEXTENSIBLE_STRAIN = 1e-6  # as test_solvers' inextensible hang: a converged α = 0 chain keeps its rest length
SETTLE = 0.3  # s: the scene starts off its catenary (spline points), so its waves run through the whole chain


def _fine_hang(substeps: int, segments: int = FINE_SEGMENTS) -> tuple:
    """(largest strain, direct solves per substep) of the hang with ``segments`` segments after SETTLE seconds."""
    with pytest.warns(UserWarning, match="larger than a segment"):  # the default radius: no contacts here
        scene = mjcable.scenes.get("hang", n_segments=segments)
    sim = mjcable.Simulator(scene, "xpbd", substeps=substeps)
    sim.step(SETTLE)
    solves = sim.diagnostics["direct_solves"] / (sim.steps * substeps)
    return float(np.max(_strain(sim.positions, scene.cable.segment_length))), solves


def test_direct_order_keeps_a_fine_chain_inextensible_below_the_transverse_courant_limit():
    """1600 segments at 16 substeps (c h / l₀ ≈ 0.5): one solve per substep converges as at 50 segments."""
    strain, solves = _fine_hang(16)
    assert strain <= INEXTENSIBLE_STRAIN
    assert solves == 1.0


def test_direct_order_keeps_a_fine_chain_inextensible_at_default_substeps():
    """1600 segments at the default 4 substeps (c h / l₀ ≈ 2): with the geometric stiffness one solve per substep
    is stable and converged, as below the limit."""
    strain, solves = _fine_hang(4)
    assert strain <= INEXTENSIBLE_STRAIN
    assert solves == 1.0


def test_direct_order_keeps_a_chain_inextensible_where_it_switches_to_the_geometric_stiffness():
    """600 segments at the default 4 substeps (c h / l₀ ≈ 0.73 at the top): the solve without the geometric
    stiffness leaves 1e-4 there; the direct order must not."""
    strain, _ = _fine_hang(4, segments=600)
    assert strain <= INEXTENSIBLE_STRAIN
