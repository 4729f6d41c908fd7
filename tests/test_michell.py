"""Michell's instability of a closed twisted ring (issue 22's must-show, ``cosserat``): a naturally straight,
untwisted isotropic rod, its start frames twisted by Φ (``CableSpec.start_twist``), closed into a circle of radius R
by a clamped junction of its own two ends, without gravity.

The threshold (Michell 1889; Goriely 2006, "Twisted elastic rings and the rediscoveries of Michell's instability",
J. Elasticity 84): with B = E·I the bending and C = G·J the torsional stiffness and Tw = Φ / 2π the ring's twist in
turns, the circle is stable while Tw < Tw_c = √3 B / C. Sketch: the junction keeps the link Lk = Tw + Wr, so a
writhing perturbation turns twist into writhe; the twist relaxes along the ring far faster than the ring bends (the
torsional waves of a thin rod are fast), so Tw = Lk − Wr stays uniform. Out-of-plane mode m (z ∝ cos mθ; m = 1 is a
rigid tilt) then changes the energy, to second order, by a positive factor times (m² − 1)(m² − 1 − Γ²), Γ = C Tw / B
(= C τ R / B with τ the twist per length): mode m is unstable once Γ² > m² − 1, and m = 2 goes first, at Γ = √3.
For a round section B / C = E I / (G · 2I) = 1 + ν, so Tw_c = √3 (1 + ν) = 2.598 turns at the library's ν = 0.5.

The growth rate: the ring's out-of-plane motion has the time scale Ω = √(B / (μ R⁴)) (μ the mass per length), and
near the threshold mode 2 grows at σ with σ² = c Ω² (Tw² / Tw_c² − 1), c a number of order one (the untwisted
ring's mode-2 frequency, ω² = Ω² m² (m² − 1)² / (m² + B / C) = 6.5 Ω², fixes the scale). With c ≥ 2, at 1.2 × the
threshold σ ≥ Ω √(2 · 0.44) = 26 /s here, so a perturbation of 1e-4 R grows past 0.1 R (a factor 1000, half of the
start's perturbation in the growing mode) within (ln 1000 + ln 2) / σ ≤ 0.29 s: the ring runs 0.35 s. The rates
measured (docs/measurements.md) give c = 3.3–3.7 and put the model's threshold at 0.98–0.985 × Tw_c (32 to 128
segments).

Undamped (damping = 0: nothing here changes the equilibria), 64 segments, the direct order.
"""

import math

import mujoco
import numpy as np
import pytest

import mjcable
from mjcable import CableSpec, Junction, Pin, Scene
from mjcable.scene import POISSON
from mjcable.solvers.state import quat_mul, start_frames

R, N, RADIUS, MASS, YOUNG = 0.1, 64, 0.002, 0.01, 1e8
EPS = 1e-4  # the start's out-of-plane perturbation, mode 2, in units of R
TW_C = math.sqrt(3.0) * (1.0 + POISSON)  # Michell's threshold in turns (module docstring)
T_END = 0.35  # s (module docstring)
ZERO_G = '<mujoco><option gravity="0 0 0"/><worldbody/></mujoco>'


def _ring(twist_turns: float, eps: float = EPS) -> Scene:
    theta = np.linspace(0.0, 2.0 * math.pi, 4 * N + 1)
    points = np.stack([R * np.cos(theta), R * np.sin(theta), eps * R * np.cos(2.0 * theta)], axis=1)
    cable = CableSpec(points, N, RADIUS, MASS, young=YOUNG, start_twist=2.0 * math.pi * twist_turns)
    return Scene(cable, junctions=(Junction((0, 0), (0, -1), clamp=True),),
                 world=mujoco.MjSpec.from_string(ZERO_G))


def _out_of_plane(x: np.ndarray) -> float:
    """The particles' largest distance from their best-fit plane, in units of R (rigid motions leave it)."""
    centred = x - x.mean(axis=0)
    normal = np.linalg.svd(centred, full_matrices=False)[2][2]
    return float(np.abs(centred @ normal).max()) / R


def _deviations(factor: float) -> np.ndarray:
    sim = mjcable.Simulator(_ring(factor * TW_C), "cosserat", dt=0.001)
    out = []
    for _ in range(round(T_END / sim.dt / 10)):
        sim.step(10 * sim.dt)
        out.append(_out_of_plane(sim.positions))
        assert np.linalg.norm(sim.positions[0] - sim.positions[-1]) < 1e-6  # the junction holds
    return np.array(out)


def test_ring_twisted_above_michells_threshold_leaves_the_plane():
    dev = _deviations(1.2)
    assert dev[:5].max() < 3 * EPS  # it starts planar: the weld and junction start in equilibrium
    assert dev.max() > 0.1, dev.max()


@pytest.mark.slow
def test_ring_twisted_below_michells_threshold_stays_planar():
    dev = _deviations(0.8)
    assert dev.max() < 2 * EPS, dev.max()


@pytest.mark.slow
def test_untwisted_ring_keeps_its_circle():
    sim = mjcable.Simulator(_ring(0.0, eps=0.0), "cosserat", dt=0.001)
    sim.step(0.1)
    x = sim.positions[:-1]  # (the last particle is the first one, joined)
    radii = np.linalg.norm(x - x.mean(axis=0), axis=1)
    np.testing.assert_allclose(radii, sim.scene.cable.segment_length / (2.0 * math.sin(math.pi / N)), rtol=1e-6)


def test_start_twist_of_a_rod_clamped_at_both_ends_is_elastic_and_uniform():
    """A straight rod, both ends clamped, its start frames twisted by Φ: at rest from the start, with the end torques
    C Φ / L of a rod twisted by Φ (Saint-Venant) and every segment turned by Φ s / L at its centre. Models without a
    twisted start refuse Φ ≠ 0, the point chains a clamped junction, and ``cosserat`` one outside its direct solve."""
    phi, length = 1.5, 1.0
    cable = CableSpec([[0, 0, 0.5], [length, 0, 0.5]], 50, 0.005, 0.05, young=1e8, start_twist=phi)
    sim = mjcable.Simulator(Scene(cable, pins=(Pin(0, clamp=True), Pin(-1, "gripper", clamp=True)),
                                  world=mujoco.MjSpec.from_string(ZERO_G)), "cosserat")
    sim.step(0.1)
    torque = cable.torsion_stiffness * phi / length
    assert sim.pin_torques[1, 0] == pytest.approx(torque, rel=0.01)
    assert -sim.pin_torques[0, 0] == pytest.approx(torque, rel=0.01)
    assert np.abs(sim.velocities).max() < 1e-6
    turned = quat_mul(sim.frames, start_frames(cable.particles) * [1, -1, -1, -1])
    angle = np.unwrap(2 * np.arctan2(turned[:, 1], turned[:, 0]))
    np.testing.assert_allclose(angle, phi * (np.arange(50) + 0.5) / 50, rtol=0.0, atol=1e-4)
    # models without a twisted start, and the rod's welds between two cables, are refused
    with pytest.raises(ValueError, match="start_twist"):
        mjcable.Simulator(_ring(1.0), "xpbd")
    straight = CableSpec([[0, 0, 1], [1, 0, 1]], 10, RADIUS, MASS, young=YOUNG)
    other = CableSpec([[1, 0, 1], [1, 1, 1]], 10, RADIUS, MASS, young=YOUNG)
    mid = Scene((straight, other), junctions=(Junction((0, -1), (1, 0), clamp=True),))
    with pytest.raises(ValueError, match="clamp"):
        mjcable.Simulator(mid, "cosserat")
    with pytest.raises(ValueError, match="order='direct'"):  # cosserat welds in its direct solve only
        mjcable.Simulator(_ring(1.0), "cosserat", order="gauss-seidel")

