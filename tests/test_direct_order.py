"""XPBD's direct order (one banded solve of the whole chain per iteration) against physics: it survives large
rotations within a substep (a gripper yanking a straight cable, a pin moving more than a segment per substep), and
where one linearised solve already works it still gives the stated stiffness and the catenary."""

import math

import numpy as np
import pytest

import mjcable
from mjcable import catalog, reference
from mjcable.solvers import direct_kernels, kernels_layout, state
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
    not converge there), but it never runs away: either the physics monitor stops it when a segment passes twice
    its rest length (a strain error with the fix, never NaN, speed or run-off), or once the swing has died down it is
    a cable again."""
    try:
        worst, x, _ = _yank("xpbd", speed=2.0, dt=0.05, after=2.0)
    except mjcable.SimulationDivergedError as error:
        assert error.check == "strain" and "more substeps" in error.fix, error
        return
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


# -- the stretch chain's geometric stiffness, block by block, against a dense solve of the same system ------------

def _dense_geometric_solve(x, w, rest, lam, lam_gs, alpha_t, chord_floor):
    """A dense reference of one direct solve with the stretch rows' geometric stiffness ([T15]: two transverse rows
    per segment in tension, compliance |d| / −λ, right-hand side 0): the Schur system (J W Jᵀ + α̃) Δλ = −C − α̃ λ
    over every row (diagonal × (1 + 1e-10); a row with a zero diagonal keeps Δλ = 0), Δx = W Jᵀ Δλ, then a chord
    step with the same matrix (right-hand side 0 between held particles) where the stretch rows' relative residual
    is at most ``chord_floor``. Returns x, λ and the held particles' Σ ∇C Δλ after it."""
    x, lam = x.copy(), lam.copy()
    n_p = x.shape[0]
    grads, alphas, stretch_of = [], [], []
    for i in range(rest.shape[0]):
        d = x[i] - x[i + 1]
        nrm = d / np.linalg.norm(d)
        frame = [nrm]
        if lam_gs[i] < 0.0:
            t0 = np.cross(nrm, np.eye(3)[np.argmin(np.abs(nrm))])
            t0 /= np.linalg.norm(t0)
            frame += [t0, np.cross(nrm, t0)]
        for k, g in enumerate(frame):
            row = np.zeros(3 * n_p)
            row[3 * i:3 * i + 3], row[3 * i + 3:3 * i + 6] = g, -g
            grads.append(row)
            alphas.append(alpha_t if k == 0 else np.linalg.norm(d) / -lam_gs[i])
            stretch_of.append(i if k == 0 else -1)
    jac, stretch_of = np.array(grads), np.array(stretch_of)
    inv_m = np.repeat(w, 3)
    a = (jac * inv_m) @ jac.T + np.diag(alphas)
    dead = np.diag(a) == 0.0
    a[np.diag_indices_from(a)] *= 1.0 + 1e-10
    a[dead, dead] = 1.0
    react = np.zeros_like(x)

    def residual(chord):  # a chord step leaves the rows between held particles as they are
        rhs = np.zeros(len(alphas))
        for r, i in enumerate(stretch_of):
            if i >= 0 and (not chord or w[i] > 0.0 or w[i + 1] > 0.0):
                rhs[r] = -(np.linalg.norm(x[i] - x[i + 1]) - rest[i]) - alpha_t * lam[i]
        return rhs

    def apply(rhs):
        rhs[dead] = 0.0
        dlam = np.linalg.solve(a, rhs)
        push = (jac.T @ dlam).reshape(-1, 3)
        x[:] += w[:, None] * push
        react[w == 0.0] += push[w == 0.0]
        lam[stretch_of[stretch_of >= 0]] += dlam[stretch_of >= 0]

    apply(residual(False))
    chord = residual(True)
    if np.max(np.abs(chord[stretch_of >= 0]) / rest) <= chord_floor:
        apply(chord)
    return x, lam, react


@pytest.mark.parametrize("jitter", [0.002, 0.2])  # segment lengths: a chord step follows the solve / none does
@pytest.mark.parametrize("stretch_stiffness", [None, 1e4])  # inextensible / compliant (α̃ ≈ w / 12)
def test_the_block_solve_of_the_geometric_stiffness_is_the_dense_solve_of_its_rows(jitter, stretch_stiffness):
    """A 24-segment chain held at one end and at two neighbours in its middle (a segment between held particles),
    its particles jittered by ``jitter`` segment lengths, tensions from the last solve that include compressed
    segments (no transverse rows) and one near zero: the block-tridiagonal solve
    (``direct_kernels._chain_geometric_solve``) must move the particles and multipliers, and load the held
    particles, as a dense solve of every row does."""
    cable = mjcable.CableSpec([[0.0, 0.0, 1.0], [1.2, 0.0, 0.9]], 24, 0.005, 0.1, stretch_stiffness=stretch_stiffness)
    scene = mjcable.Scene(cable, pins=(mjcable.Pin(0), mjcable.Pin(12), mjcable.Pin(13)))
    sim = mjcable.Simulator(scene, "xpbd")
    h = sim.dt / sim.settings.substeps
    rules = catalog.get("xpbd").rules(scene, sim.settings, h)
    arrays = state.chain_arrays(scene, (rules,), sim.settings, sim.dt)
    assert arrays.par[0]["gs_chain"]
    rng = np.random.default_rng(7)
    l0 = cable.segment_length
    arrays.x[:] += jitter * l0 * rng.standard_normal(arrays.x.shape)
    tension = rng.uniform(0.5, 3.0, cable.n_segments)  # N
    tension[[3, 17]] = -0.2  # compressed
    tension[20] = 1e-12  # near zero: its transverse rows are negligible
    arrays.lam_gs[:] = -tension * h * h
    arrays.lam_s[:] = 0.5 * arrays.lam_gs
    alpha_t = arrays.cable_par[0]["alpha_s"] / h**2
    expected = _dense_geometric_solve(arrays.x, arrays.w, arrays.rest, arrays.lam_s, arrays.lam_gs, alpha_t,
                                      direct_kernels._DIRECT_RESIDUAL_FLOOR)
    start = arrays.x.copy()
    direct_kernels._chain_geometric_solve(kernels_layout.assemble(arrays))
    moved = expected[0] - start
    assert np.max(np.abs(moved)) > 0.1 * jitter * l0  # the solve has work to do
    np.testing.assert_allclose(arrays.x - start, moved, rtol=0.0, atol=1e-9 * np.max(np.abs(moved)))
    for got, want in zip((arrays.lam_s, arrays.react), expected[1:]):
        np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-9 * np.max(np.abs(want)))
