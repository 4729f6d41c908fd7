"""The particle solvers: Jakobsen's Verlet relaxation, PBD and XPBD on numba kernels, colliding through MuJoCo.

``mjcable.Simulator(scene, "xpbd", dt=0.002, substeps=10, order="direct")`` builds a :class:`ParticleBackend`
through :func:`make_backend`. The settings (keyword-only, validated by :func:`solver_settings`):

========================  ======================================================  =============================
setting                   meaning                                                 models
========================  ======================================================  =============================
``substeps`` (1)          substeps per ``dt``                                     all
``iterations`` (1)        constraint iterations per substep                       all
``order``                 ``"gauss-seidel"``, ``"jacobi"`` or ``"direct"``        all
``omega`` (1.0)           Jacobi relaxation in (0, 2]                             all
``bending`` ("auto")      ``"none"``, ``"curvature"``, ``"distance"``             all
``contact_margin``        metres added to one step's travel for the query         all
``self_collision``        collide non-adjacent segments                           all
``stiffness`` (1.0)       stretch k in [0, 1]                                     jakobsen, pbd
``bend_stiffness``        bending k in [0, 1] (default: derived from E·I)         jakobsen, pbd
``sqrt_approx``           Jakobsen's square-root approximation                    jakobsen
``integrator``            ``"euler"`` or ``"verlet"`` prediction                  pbd
``constraints``           :class:`UserConstraint` objects                         pbd
``stretch_compliance``    α of the stretch constraints (m/N), default l₀/E·A      xpbd
``bend_compliance``       α of the bending constraints, default 1/(E·I·l₀)        xpbd
========================  ======================================================  =============================

Module map: :mod:`~mjcable.solvers.settings` (validation), :mod:`~mjcable.solvers.state` (arrays),
:mod:`~mjcable.solvers.kernels` (every ``@njit`` projection, citing paper and equation),
:mod:`~mjcable.solvers.contacts` (``mj_collision`` queries), :mod:`~mjcable.solvers.jakobsen`,
:mod:`~mjcable.solvers.pbd`, :mod:`~mjcable.solvers.xpbd` (each model's rules: how the physical cable becomes
compliances and stiffnesses), :mod:`~mjcable.solvers.backend` (the step).
"""

from __future__ import annotations

from mjcable.scene import Scene
from mjcable.solvers.backend import ParticleBackend
from mjcable.solvers.pbd import UserConstraint
from mjcable.solvers.settings import MODEL_SETTINGS, SolverSettings, solver_settings

__all__ = ["make_backend", "ParticleBackend", "SolverSettings", "solver_settings", "UserConstraint",
           "PARTICLE_SOLVERS"]

PARTICLE_SOLVERS = tuple(MODEL_SETTINGS)


def make_backend(scene: Scene, model: str, dt: float, settings: dict) -> ParticleBackend:
    """The particle backend for ``model`` (``"jakobsen"``, ``"pbd"`` or ``"xpbd"``).

    Args:
      scene: the scene.
      model: the particle model.
      dt: the simulator's step in seconds (> 0).
      settings: keyword settings (see the table in this module's docstring).

    Raises:
      ValueError: an unknown setting for the model or a value out of its range.

    Example::

        backend = make_backend(mjcable.scenes.get("hang"), "xpbd", 0.002, {"substeps": 10})
        backend.step()
    """
    return ParticleBackend(scene, model, dt, dict(settings))
