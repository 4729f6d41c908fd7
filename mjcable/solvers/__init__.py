"""The particle solvers: Jakobsen's Verlet relaxation, PBD and XPBD on numba kernels, colliding through MuJoCo.

``mjcable.Simulator(scene, "xpbd", dt=0.002, substeps=10)`` runs one through
:class:`mjcable.backends.particle.ParticleBackend`. Their settings are keyword-only frozen dataclasses, one per
model (:mod:`~mjcable.solvers.settings`), defaults in brackets:

========================  ======================================================  =============================
setting                   meaning                                                 models
========================  ======================================================  =============================
``substeps`` (4)          substeps per ``dt``                                     all
``iterations`` (1)        constraint iterations per substep                       all
``order``                 ``"gauss-seidel"`` (jakobsen, pbd), ``"jacobi"`` or     all
                          ``"direct"`` (xpbd)
``omega`` (1.0)           Jacobi relaxation in (0, 2]                             all
``bending`` ("auto")      ``"none"``, ``"curvature"``, ``"distance"``             all
``contact_margin``        metres added to one step's travel for the query         all
``query_slack``           metres added to a query's margin for later steps' reuse all
``self_collision``        collide non-adjacent segments                           all
``stretch_factor`` (1.0)  stretch k in [0, 1]                                     jakobsen, pbd
``bend_factor``           bending k in [0, 1] (default: derived from E·I)         jakobsen, pbd
``sqrt_approx``           Jakobsen's square-root approximation                    jakobsen
``integrator``            ``"euler"`` or ``"verlet"`` prediction                  pbd
``constraints``           :class:`UserConstraint` objects                         pbd
``stretch_compliance``    α of the stretch constraints (m/N), default l₀/E·A      xpbd
``bend_compliance``       α of the bending constraints, default 1/(E·I·l₀)        xpbd
========================  ======================================================  =============================

Module map: :mod:`~mjcable.solvers.settings` (the settings dataclasses), :mod:`~mjcable.solvers.state` (arrays),
:mod:`~mjcable.solvers.kernels` (the substep and step drivers; it re-exports the projections they call:
:mod:`~mjcable.solvers.constraint_kernels`, the sweeps citing paper and equation,
:mod:`~mjcable.solvers.contact_kernels`, obstacle shapes, contacts and Coulomb friction with anchors,
:mod:`~mjcable.solvers.direct_kernels`, the direct order, :mod:`~mjcable.solvers.host_kernels`, a user world's
host, :mod:`~mjcable.solvers.monitor_kernels`, the divergence checks, and :mod:`~mjcable.solvers.kernels_layout`,
the packed solver state and its parameter record; their numba cache is stamped with all kernel files, :mod:`~mjcable.solvers._kernel_cache`),
:mod:`~mjcable.solvers.query_kernels` (contact queries and proxy poses, from Python and from the step loop),
:mod:`~mjcable.solvers.capi` (MuJoCo's C API for the step loop: entry points and checked struct layout),
:mod:`~mjcable.solvers.contacts` (``mj_collision`` queries), :mod:`~mjcable.solvers.jakobsen`,
:mod:`~mjcable.solvers.pbd`, :mod:`~mjcable.solvers.xpbd`, :mod:`~mjcable.solvers.cosserat` (each model's rules: how
the physical cable becomes compliances and factors; the Cosserat rod's kernels in
:mod:`~mjcable.solvers.cosserat_kernels`), :mod:`~mjcable.solvers.user_constraints` (PBD's user constraints),
:mod:`~mjcable.solvers.energy` (the elastic energy of each model's constraint rows).
"""

from mjcable.solvers import (capi, contact_kernels, cosserat, energy, jakobsen, kernels, pbd, query_kernels, settings,
                             state, user_constraints, xpbd)
from mjcable.solvers.settings import CosseratSettings, JakobsenSettings, ParticleSettings, PBDSettings, XPBDSettings
from mjcable.solvers.user_constraints import UserConstraint

__all__ = ["ParticleSettings", "JakobsenSettings", "PBDSettings", "XPBDSettings", "CosseratSettings",
           "UserConstraint", "jakobsen", "pbd", "xpbd", "cosserat", "kernels", "contact_kernels", "query_kernels",
           "capi", "settings", "state", "user_constraints", "energy"]
