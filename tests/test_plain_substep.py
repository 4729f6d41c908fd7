"""The particle solvers' substep of a plain chain (stretch constraints only, Gauss-Seidel, no contacts) runs
:func:`mjcable.solvers.kernels.plain_substep`, a loop of its own for speed; it must give the general substep's
results bit for bit. Reference: the general pieces :func:`~mjcable.solvers.kernels.begin_substep`,
:func:`~mjcable.solvers.kernels.iterate` and :func:`~mjcable.solvers.kernels.end_substep`, run one at a time through
:func:`~mjcable.solvers.kernels.run_phase` (which never takes the plain path), on a second copy of the same state."""

import dataclasses

import numpy as np
import pytest

import mjcable
from mjcable import catalog
from mjcable.solvers import kernels, kernels_layout, state

STEPS = 40  # 0.08 s at the default dt: the socket's cable swings down past its release force


def _scene(name: str):
    """``name`` with 12 segments; the socket scene's socket without its clamp (a clamp is not plain) and with a
    release force low enough that it lets go within ``STEPS``."""
    scene = mjcable.scenes.get(name, n_segments=12, damping=1.0)
    pins = tuple(dataclasses.replace(p, clamp=False, release_force=0.5) if p.kind == "socket" else p
                 for p in scene.pins)
    return dataclasses.replace(scene, pins=pins)


def _chain(scene, model: str, settings: dict, contacts: int = 0):
    """The solver state of ``scene`` (no MuJoCo parts) and its arrays; ``contacts`` obstacle contacts in it."""
    sim = mjcable.Simulator(scene, model, **settings)
    rules = catalog.get(model).rules(scene, sim.settings, sim.dt / sim.settings.substeps)
    arrays = state.chain_arrays(scene, (rules,), sim.settings, sim.dt)
    arrays.par[0]["n_con"] = contacts
    return kernels_layout.assemble(arrays), arrays, sim.settings


def _run(S, arrays, n_sub: int, iterations: int, whole: bool) -> None:
    """``STEPS`` steps, the first pin's target moving 1 mm a step: whole substeps or the general pieces one phase at a
    time."""
    for step in range(STEPS):
        arrays.pin_to[0] = arrays.pin_from[0] + [0.001, 0.0, -0.0005]
        for sub in range(n_sub):
            if whole:
                kernels.substep(S, sub, n_sub)
            else:
                kernels.run_phase(S, kernels_layout.PHASE_BEGIN, sub, n_sub)
                for _ in range(iterations):
                    kernels.run_phase(S, kernels_layout.PHASE_ITERATE, sub, n_sub)
                kernels.run_phase(S, kernels_layout.PHASE_END, sub, n_sub)
        arrays.pin_from[:] = arrays.pin_to


@pytest.mark.parametrize("model, settings", [
    ("xpbd", dict(order="gauss-seidel", substeps=4, iterations=1)),  # α = 0: stretch_step_rigid
    ("xpbd", dict(order="gauss-seidel", substeps=3, iterations=2, stretch_compliance=1e-5)),  # α > 0
    ("pbd", dict(order="gauss-seidel", substeps=2, iterations=3, stretch_factor=0.7)),  # k < 1
    ("jakobsen", dict(order="gauss-seidel", substeps=2, iterations=2)),  # the square-root approximation
])
@pytest.mark.slow  # kernels.run_phase compiles the step's pieces apart
@pytest.mark.parametrize("scene_name", ["hang", "socket"])
def test_plain_substep_equals_the_general_pieces_bit_for_bit(scene_name, model, settings):
    scene = _scene(scene_name)
    S_fast, fast, s = _chain(scene, model, dict(settings, bending="none"))
    S_slow, slow, _ = _chain(scene, model, dict(settings, bending="none"))
    assert kernels.is_plain(S_fast)  # the plain path is the one under test
    _run(S_fast, fast, s.substeps, s.iterations, whole=True)
    _run(S_slow, slow, s.substeps, s.iterations, whole=False)
    assert np.all(np.isfinite(fast.x)) and np.abs(fast.v).max() > 0.0
    for name in ("x", "v", "x0", "react", "lam_s", "w", "pin_force", "pin_sum", "pin_count", "pin_active"):
        assert np.array_equal(fast[name], slow[name]), name
    if scene_name == "socket":  # a release happened on both paths (the release branch is covered)
        assert not fast.pin_active.all()


def test_a_chain_with_bending_or_contacts_is_not_plain():
    scene = mjcable.scenes.get("hang", n_segments=12)
    S = _chain(scene, "xpbd", dict(order="gauss-seidel", bending="curvature", bend_compliance=1e-3))[0]
    assert not kernels.is_plain(S)
    assert not kernels.is_plain(_chain(scene, "xpbd", dict(order="jacobi"))[0])
    assert kernels.is_plain(_chain(scene, "xpbd", dict(order="gauss-seidel"))[0])
    assert not kernels.is_plain(_chain(scene, "xpbd", dict(order="gauss-seidel"), contacts=1)[0])
