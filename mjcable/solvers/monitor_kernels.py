"""The divergence checks every model's steps pass, ``@njit`` (cached, see :mod:`mjcable.solvers._kernel_cache`):
the particle solvers' compiled step loop calls :func:`step_check` after each step, the native backend after each
``mj_step``, so that both stop on the same tests in the same arithmetic."""

from __future__ import annotations

import math

from mjcable.solvers._kernel_cache import jit as _jit
from mjcable.solvers.kernels_layout import CHECK_DISTANCE, CHECK_NON_FINITE, CHECK_OK, CHECK_SPEED

__all__ = ["step_check", "CHECK_OK", "CHECK_NON_FINITE", "CHECK_DISTANCE", "CHECK_SPEED"]


@_jit
def step_check(x, v, prev, dt, max_distance, max_speed):
    """(check, measured value) of a step that moved particles from ``prev`` to ``x`` (N, 3) m with velocities ``v``
    (N, 3) m/s in ``dt`` seconds: ``CHECK_NON_FINITE`` (a NaN or inf in x or v), ``CHECK_DISTANCE`` (the largest
    |coordinate| of x, beyond ``max_distance`` m), ``CHECK_SPEED`` (the fastest particle's travel / dt, beyond
    ``max_speed`` m/s), in that order of precedence, else ``CHECK_OK``."""
    far, top, bad = 0.0, 0.0, 0.0  # bad: NaN once any x or v is non-finite (z − z), without a branch
    for p in range(x.shape[0]):
        d2 = 0.0
        for comp in range(3):
            bad += (x[p, comp] - x[p, comp]) + (v[p, comp] - v[p, comp])
            far = max(far, abs(x[p, comp]))
            d = x[p, comp] - prev[p, comp]
            d2 += d * d
        top = max(top, d2)
    if bad != 0.0:
        return CHECK_NON_FINITE, math.nan
    if far > max_distance:
        return CHECK_DISTANCE, far
    speed = math.sqrt(top) / dt
    if speed > max_speed:
        return CHECK_SPEED, speed
    return CHECK_OK, 0.0
