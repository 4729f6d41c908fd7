"""Winches of the particle solvers, ``@njit`` (cached, see :mod:`mjcable.solvers._kernel_cache`): a pin that reels
its cable in or pays it out at run time (``Pin(index, "winch")``, :meth:`mjcable.Simulator.reel`).

The cable's particle budget is fixed. A winch holds one particle, the *held* particle ``pin_p[k]``; the particles
between it and the cable's end on the spool side (``winch_end``) are *on the spool*: inverse mass 0, parked on the
held particle, their segments gaps of the state (``seg_cable`` = −1, outside the cable's ``chain_seg`` range), so
that no constraint, bending row, contact between segments or direct-order row acts on them. ``winch_dir`` says which
way the free cable runs: +1 towards higher indices (the spool holds the cable's first particles), −1 towards lower.

Every segment keeps its rest length l₀. The first free segment, from the held particle c to the next particle
c + dir, passes through the winch point W: only its part beyond W, of length r (``winch_len``, in [0, l₀]), is
free cable, and the held particle sits on the cable's line l₀ − r behind the winch,

    x_c = W − (l₀ − r) u,   u the unit direction from the held particle's last point to particle c + dir,

so the free length is r + l₀ · (free segments beyond the first). Each substep (:func:`winch_advance`, before the
prediction) moves r by the reel speed times h; the held particle, moved as a pin, carries the cable with it. When r
reaches 0 (reeling in) particle c + dir has reached the winch: it becomes the held particle and c goes onto the
spool (r += l₀); when r exceeds l₀ (paying out) the held particle is let go with the cable's speed along u and the
last spooled particle becomes the held one (r −= l₀). So the pin is a cursor that moves through the particles, as
Obi Rope's cursors do, without a segment of changing rest length: stretch, bending (curvature and distance rows),
the direct order's banded and block solves and the strain checks all keep seeing segments of length l₀. The
cable's mass per metre ρ stays: the held particle weighs ρ r / 2 (its pin force counts it) and the next one
ρ (r + l₀) / 2, the lumped masses of a first segment of length r. The winch acts as a hinge at W (the bending rows
start at the held particle). The winch's pull is its pin force (``pin_force``, XPBD's estimate from the held
particle's reaction, :func:`mjcable.solvers.kernels._pin_forces`).

A winch on a body (``Pin(..., "winch", body=...)``) takes its point from the user world's host each substep
(:mod:`mjcable.solvers.host_kernels`: the pin's target and trial point ``free``, both shifted here to the held
particle's point behind it), so that the body feels the pull at the winch point.

Limits: reeling in stops when the free cable is down to its last segment (r = 0 with the cable's far end at the
winch); paying out stops with the spool empty (r = l₀). A mass added to a particle (``add_point_mass``) next to the
winch is overwritten by the lumped masses; a winch point closer to an obstacle than the cable's radius lets contacts
of the spooled (zero-length) segments reach the held particle's reaction.
"""

from __future__ import annotations

import math

from mjcable.solvers._kernel_cache import inline as _inline, jit as _jit
from mjcable.solvers.kernels_layout import _TINY_LENGTH

__all__ = ["winch_advance"]


@_inline
def _held_elsewhere(S, p, kp):
    """Whether an active pin other than pin row ``kp`` holds particle ``p``."""
    pin_p, pin_active = S.pin_p, S.pin_active
    for j in range(pin_p.shape[0]):
        if j != kp and pin_active[j] and pin_p[j] == p:
            return True
    return False


@_inline
def _hold(S, k, old, new):
    """Winch ``k``'s pin moves from particle ``old`` to ``new``, and the cable's chain starts (dir +1) or ends
    (dir −1) at ``new``; on a body, its host link follows (the body's inverse mass along the cable)."""
    kp, d, link, cable = S.winch_pin[k], S.winch_dir[k], S.winch_link[k], S.winch_cable[k]
    S.pin_p[kp] = new
    if d > 0:
        S.chain_seg[cable, 0] = new
    else:
        S.chain_seg[cable, 1] = new
    S.react[new, 0] = S.react[new, 1] = S.react[new, 2] = 0.0
    if link >= 0:
        S.link_particle[link] = new
        far = S.winch_far[k]
        S.link_neighbour[link] = new + 2 * d if new + d != far else new + d  # the cable's axis, clear of the winch
        S.w[new] = S.free_w[link]
    else:
        S.w[new] = 0.0
    S.w[old] = 0.0  # (a let-go particle gets its inverse mass from its caller)


@_inline
def _spool(S, k, c):
    """Reeling in: particle c + dir reached the winch; it becomes the held particle and c goes onto the spool."""
    d, l0, rho = S.winch_dir[k], S.winch_l0[k], S.winch_rho[k]
    new = c + d
    _hold(S, k, c, new)
    S.seg_cable[min(c, new)] = -1
    S.mass[c] = rho * l0 * (0.5 if c == S.winch_end[k] else 1.0)
    S.v[c, 0] = S.v[c, 1] = S.v[c, 2] = 0.0


@_inline
def _unspool(S, k, c, speed, ux, uy, uz):
    """Paying out: the held particle c is let go, moving with the cable at ``speed`` along u (its mass that of an
    inner particle until :func:`winch_advance` sets the lumped masses), and particle c − dir leaves the spool."""
    d, l0, rho = S.winch_dir[k], S.winch_l0[k], S.winch_rho[k]
    new = c - d
    _hold(S, k, c, new)
    S.seg_cable[min(c, new)] = S.winch_cable[k]
    S.mass[c] = rho * l0
    S.w[c] = 1.0 / S.mass[c]
    S.react[c, 0] = S.react[c, 1] = S.react[c, 2] = 0.0
    S.v[c, 0], S.v[c, 1], S.v[c, 2] = speed * ux, speed * uy, speed * uz


@_jit
def winch_advance(S):
    """Every winch's substep (module docstring), before the prediction: r += speed · h, the held particle passed on
    where r leaves [0, l₀], the lumped masses at the winch, the held particle's target W − (l₀ − r) u (a world
    winch: ``pin_from``, ``pin_to`` and the host's ``start_from``, ``start_to``; a body winch: ``pin_to`` and the
    host's trial point ``free``) and the spooled particles parked on it."""
    h = S.par[0].h
    x, pin_p = S.x, S.pin_p
    for k in range(S.winch_pin.shape[0]):
        kp, d, l0, rho, link = S.winch_pin[k], S.winch_dir[k], S.winch_l0[k], S.winch_rho[k], S.winch_link[k]
        end, far, speed = S.winch_end[k], S.winch_far[k], S.winch_speed[k]
        if link >= 0:  # the body's point this substep (the host's trial step)
            wx, wy, wz = S.pin_to[kp, 0], S.pin_to[kp, 1], S.pin_to[kp, 2]
        else:
            wx, wy, wz = S.winch_at[k, 0], S.winch_at[k, 1], S.winch_at[k, 2]
        c = pin_p[kp]
        u = S.winch_u[k]
        back = l0 - S.winch_len[k]  # the cable's direction: from the held particle's last point to the next one
        ex = x[c + d, 0] - (wx - back * u[0])
        ey = x[c + d, 1] - (wy - back * u[1])
        ez = x[c + d, 2] - (wz - back * u[2])
        norm = math.sqrt(ex * ex + ey * ey + ez * ez)
        if norm > _TINY_LENGTH:
            u[0], u[1], u[2] = ex / norm, ey / norm, ez / norm
        r = S.winch_len[k] + speed * h
        while r <= 0.0 and c + d != far:
            _spool(S, k, c)
            c += d
            r += l0
        while r > l0 and c != end:
            _unspool(S, k, c, speed, u[0], u[1], u[2])
            c -= d
            r -= l0
        r = min(max(r, 0.0), l0)
        S.winch_len[k] = r
        S.mass[c] = 0.5 * rho * r  # the lumped masses of a first segment of length r
        q = c + d
        if q != far:
            S.mass[q] = 0.5 * rho * (r + l0)
            if S.w[q] > 0.0 and not _held_elsewhere(S, q, kp):
                S.w[q] = 1.0 / S.mass[q]
        back = l0 - r
        bx, by, bz = wx - back * u[0], wy - back * u[1], wz - back * u[2]
        S.pin_to[kp, 0], S.pin_to[kp, 1], S.pin_to[kp, 2] = bx, by, bz
        if link >= 0:
            S.free[link, 0], S.free[link, 1], S.free[link, 2] = bx, by, bz
        else:
            S.pin_from[kp, 0], S.pin_from[kp, 1], S.pin_from[kp, 2] = bx, by, bz
            S.start_from[kp, 0], S.start_from[kp, 1], S.start_from[kp, 2] = bx, by, bz
            S.start_to[kp, 0], S.start_to[kp, 1], S.start_to[kp, 2] = bx, by, bz
        lo, hi = (end, c - 1) if d > 0 else (c + 1, end)  # the spooled particles (none where c is the end)
        for p in range(lo, hi + 1):
            x[p, 0], x[p, 1], x[p, 2] = bx, by, bz
