"""The Cosserat rod's direct solves (mjcable.solvers.cosserat_direct_kernels), below the Simulator: the block LDLᵀ
against numpy's dense solve, and a limp rope's stretch–shear-only solve against the full system's."""

import numpy as np
import pytest

import mjcable
from mjcable import catalog
from mjcable.backends.particle import ParticleBackend
from mjcable.solvers.cosserat_direct_kernels import block_ldlt_solve


@pytest.mark.parametrize("blocks", [1, 2, 3, 40])
def test_block_ldlt_solves_a_block_banded_system_as_numpy_does(blocks):
    rng = np.random.default_rng(blocks)
    n = 3 * blocks
    near = np.zeros((n, n), dtype=bool)  # 3 × 3 blocks (k, j) with |k − j| ≤ 2
    for k in range(blocks):
        near[3 * k:3 * k + 3, max(0, 3 * k - 6):3 * k + 9] = True
    a = np.where(near, rng.standard_normal((n, n)), 0.0)
    a = a + a.T + 2.0 * n * np.eye(n)  # symmetric, diagonally dominant: positive definite
    band = np.zeros((n, 9))  # lower band storage, band[i, i − j] = A[i, j]
    for i in range(n):
        for j in range(max(0, i - 8), i + 1):
            band[i, i - j] = a[i, j]
    rhs = rng.standard_normal(n)
    y = rhs.copy()
    block_ldlt_solve(band, y, np.zeros((8, 3, 3)))
    np.testing.assert_allclose(y, np.linalg.solve(a, rhs), rtol=0.0, atol=1e-12)


@pytest.mark.parametrize("scene_name", ["hang", "table"])
def test_a_limp_ropes_stretch_shear_solve_moves_it_as_the_full_system_does(scene_name):
    """E·I = G·J = 0: the bend–twist rows' compliance 1/(ε l₀) (ε = 1e-12 N·m²) makes them free joints, so leaving
    them out of the direct solve (``rod_limp``) must take the same steps, to round-off."""
    scene = mjcable.scenes.get(scene_name, n_segments=20)
    runs = []
    for limp in (True, False):
        backend = ParticleBackend(scene, catalog.get("cosserat"), 0.002, catalog.make_settings("cosserat"))
        assert backend.arrays.par[0]["rod_limp"]  # a rope: the rules choose the stretch–shear solve
        backend.arrays.par[0]["rod_limp"] = limp
        n = scene.cable.n_particles
        result = backend.run(100, rows=np.zeros(0, dtype=np.int64), out_x=np.zeros((0, n, 3)),
                             out_v=np.zeros((0, n, 3)))
        assert result.failure is None
        runs.append((backend.arrays.x.copy(), backend.arrays.q.copy()))
    moved = np.abs(runs[0][0] - scene.cable.particles).max()
    assert moved > 1e-2  # the rope fell or swung: the comparison is not of a rope at rest
    np.testing.assert_allclose(runs[0][0], runs[1][0], rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(np.abs(np.sum(runs[0][1] * runs[1][1], axis=1)), 1.0, rtol=0.0, atol=1e-9)
