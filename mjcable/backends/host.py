"""A user's MuJoCo world as the particle solvers' host: lock-step stepping, two-way coupling through body pins and
through the cable's contacts with the world's bodies.

With ``Scene(world=...)`` the particle backend's ``mj_data`` is the user's world with the proxy capsules in it, and
MuJoCo steps that world (robot, objects, actuators) with ``mj_step`` once per solver substep h = dt / substeps (the
model's timestep is h). The proxy capsules take no part in those steps: they have no contact bits and their pairs
are switched off (:meth:`~mjcable.solvers.contacts.ObstacleContacts.disable`) while the host steps.

Coupling scheme of a body pin (particle p held at the point b(q) fixed in a body), once per substep:

1. the body's inverse mass at the point along the cable, w_b = nᵀ J M⁻¹ Jᵀ n (J the point's translational
   Jacobian, M the world's joint-space mass matrix, n the unit vector from p to its neighbour), from MuJoCo's
   ``mj_jac`` and ``mj_solveM``;
2. a trial ``mj_step`` of the world without the cable gives the point's free path b_free (state saved before and
   restored after, ``mj_getState``/``mj_setState``, so the step is repeated exactly);
3. the solver's substep treats p as a particle of inverse mass w_b predicted at b_free: the cable's constraints
   move it by Δ = x_p − b_free. That displacement is what a constant force F = Δ / (w_b h²) does to the body in one
   semi-implicit step, so the cable pulls the body with F + m_p g (m_p the particle's own lumped mass, which the
   body carries), applied at the point (``xfrc_applied``: force and its moment about the body's centre of mass);
4. the real ``mj_step`` with that force; the particle is put where the body point went, with the body point's
   velocity. ``Simulator.pin_forces`` reports −(F + m_p g), the force holding the particle, averaged over the step's
   substeps as for other pins.

The coupling is implicit in the body's inertia along the cable (a heavy box hanging from a light cable is held in
one substep), and exact where J M⁻¹ Jᵀ is isotropic, e.g. a free body pinned at a point on a principal axis through
its centre of mass, pulled along it. Its limits: the scalar w_b ignores how the body answers sideways to the
cable and, in the world's own constraints (contacts, joint limits, other equalities), how it answers at all during
the substep; what the body does instead shows up as the next substep's starting mismatch, which the particle then
follows. With Gauss-Seidel orders, a mass ratio w_b / w_cable far below 1 needs iterations (or ``order="direct"``)
to carry the body's weight without stretch, as any heavy end mass does.

Two-way contacts. The cable's contacts with the world's geoms (:mod:`mjcable.solvers.contacts`) act on the
world's dynamic bodies (not welded to the world nor to a mocap body: ``body_weldid`` ≠ 0 and not mocap), once per
substep:

1. after every host step the moving obstacles' shapes are refreshed (:meth:`ObstacleContacts.refresh_moving`), so
   the solver's substep meets each body where it is;
2. the solver's substep treats every obstacle as immovable and sums, per obstacle, the impulses its contacts gave
   the cable (:func:`~mjcable.solvers.contact_kernels.collect_impulses`): j = Σ_c λₙ_c n_c (normal) + Σ_p f_p
   (each free particle's friction impulse), in kg·m, so that j / h = Σ m_p Δx_p / h is the momentum the contact
   projections gave the cable, with its moment about the origin from the contact points;
3. the real ``mj_step`` applies −j / h² to the body (``xfrc_applied``: the force and its moment about the body's
   centre of mass ``xipos``), equal and opposite to what the body did to the cable. Self contacts give nothing.

Momentum is exchanged exactly (a box braked by a cable sliding on it keeps M v_box + Σ m_p v_p to 1e-14), but the
scheme is explicit in the body: it does not move under the contact within the substep and answers in its own step.
With the cable pinned to the body's surface by the contact (normal contact, sticking friction), the relative velocity
along the contact is multiplied by −m / M every substep (m the cable mass the contacts move with the body, M the
body's effective mass 1/(nᵀ J M⁻¹ Jᵀ n) along the contact): stable for m / M < 1, whatever h. Beyond, the normal
contact chatters (measured, ``scripts/bench_two_way_limit.py``: a 0.1 kg cable lying on a box on a spring settles to
1e-13 m for m / M ≤ 1, chatters by 2 µm at m / M = 1.25, 0.4 mm at 2 and 3 mm at 5–10, its mean sag still Hooke's
within 1.1 %), and sticking friction becomes a bounded stick-slip cycle (the cone caps each substep's impulse at
μ λₙ). Where the world's own constraints hold the body along the contact (a box resting on a table under the cable)
its effective mass is that of what holds it, and a box 10 times lighter than the cable on it stays at rest. Pins
keep their scheme above; a pinned particle's contact shares (held particles collect ∇C Δλ) count in j.
A cable squeezed between a body and another face rubs on both (:mod:`~mjcable.solvers.contact_kernels`: a particle's
cone sums the normal impulses of opposite faces, and its friction is shared among the obstacles in proportion to
them): a weight of mass W lying on a cable on a table takes μ (2 W + m) g to pull the cable out and is dragged by
μ W g, within 1 % with ``xpbd``'s direct order (``tests/test_two_way_contacts.py``). Measured limit: under such a
squeeze the body's explicit contact force alternates between about 0 and 2 W g from substep to substep, and with
Gauss-Seidel orders (``pbd``, ``jakobsen``, ``xpbd`` with ``order="gauss-seidel"``) the single sweep then keeps
only about a quarter of the friction (a strict xfail records it).

Compiled substeps. Without a per-substep callback (PBD's user constraints keep the Python loop), ``substeps`` runs all
its substeps, MuJoCo's calls included, in one compiled call (:func:`mjcable.solvers.host_kernels.host_substeps`,
through MuJoCo's C API: :func:`mjcable.solvers.capi.host_functions`), with the Python loop's results bit for bit (the
reductions they share, n and w_b, are the kernels' :func:`~mjcable.solvers.host_kernels.pin_axis_jacobian` and
:func:`~mjcable.solvers.host_kernels.dot`). The first step after each reset stays in Python, so that a MuJoCo *error*
of the starting state (``mju_error``, e.g. an arena too small) is a Python exception: inside the compiled call it
would end the process (see :mod:`mjcable.solvers.host_kernels`). ``Host.compiled = False`` forces the Python loop.
"""

from __future__ import annotations

from typing import Callable, Optional

import mujoco
import numpy as np

from mjcable.mjcf import world
from mjcable.scene import Scene
from mjcable.solvers import capi, contact_kernels, host_kernels, kernels
from mjcable.solvers.contacts import ObstacleContacts

__all__ = ["Host"]

_BAD = (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL)
_STATE = mujoco.mjtState.mjSTATE_INTEGRATION
_RIGID = host_kernels.RIGID  # 1/kg: a body point lighter to move than this is held fixed (a body welded to the world)


class Host:
    """Steps the user's world around a particle cable (see the module docstring).

    Args:
      scene: the scene (with a world).
      mj_model, mj_data: the compiled proxy in the user's world; timestep h.
      h: the solver's substep in seconds.
      obstacles: the cable's contacts with the world's geoms (``None``: none); their moving shapes are refreshed
        after every host step, and those on dynamic bodies get the contacts' reactions.

    Attributes:
      impulse: ``(B, 6)`` the contact impulses of the substep per obstacle row, for ``Contacts.impulse``
        (:func:`~mjcable.solvers.contact_kernels.collect_impulses`); ``(0, 6)`` where no obstacle is on a dynamic
        body (the kernels then skip the sums).
      contact_wrench: ``(nbody, 6)`` N, N·m: the last substep's contact force on each body and its moment about the
        body's centre of mass, as applied through ``xfrc_applied``.
    """

    two_way_contacts = True  # class switch: False leaves the world's bodies without the contacts' reactions (tests)
    compiled = True  # class switch: False steps in the Python loop even where the compiled substeps can (tests)

    def __init__(self, scene: Scene, mj_model: mujoco.MjModel, mj_data: mujoco.MjData, h: float,
                 obstacles: Optional[ObstacleContacts] = None):
        self.m, self.d, self.h = mj_model, mj_data, h
        self.obstacles = obstacles
        self.gravity = scene.gravity
        m = mj_model
        pins = [k for k, pin in enumerate(scene.pins) if pin.kind == "body"]
        self.pins = np.array(pins, dtype=np.int64)
        self.particles = np.array([scene.pin_particle(k) for k in pins], dtype=np.int64)
        self.neighbours = np.array([scene.clamp_neighbour(k) for k in pins], dtype=np.int64)
        self.bodies = np.array([m.body(scene.pins[k].body).id for k in pins], dtype=np.int64)
        self.sites = np.array([m.site(world.anchor_site(k)).id for k in pins], dtype=np.int64)
        clamped = [k for k, pin in enumerate(scene.pins) if pin.clamp]
        #: (K, 2) [row in the state's clamp arrays, body id] of the body pins' clamps, and (K, 3, 2) the clamps' two
        #: directions in their bodies' frames (set by reset)
        self._clamps = np.array([(clamped.index(k), int(self.bodies[j])) for j, k in enumerate(pins)
                                 if scene.pins[k].clamp], dtype=np.int64).reshape(-1, 2)
        self._clamp_local = np.zeros((len(self._clamps), 3, 2))
        self._saved = np.zeros(mujoco.mj_stateSize(m, _STATE))
        self._jacp = np.zeros((3, m.nv))
        self._jn = np.zeros((1, m.nv))
        self._solved = np.zeros((1, m.nv))
        self.contact_wrench = np.zeros((m.nbody, 6))
        self.impulse = np.zeros((0, 6))
        self._rows = self._row_bodies = np.zeros(0, dtype=np.int64)
        if obstacles is not None and self.two_way_contacts:
            body = m.geom_bodyid[obstacles.obstacle_geoms]
            weld = m.body_weldid[body]
            dynamic = (weld != 0) & (m.body_mocapid[weld] < 0)  # not welded to the world nor to a mocap body
            #: obstacle rows on dynamic bodies, and their bodies
            self._rows, self._row_bodies = np.flatnonzero(dynamic).astype(np.int64), body[dynamic].astype(np.int64)
            if len(self._rows):
                self.impulse = np.zeros((len(body), 6))
        self._fresh = True  # the first step after a reset runs in Python (see the module docstring)
        self._compiled_args = self._host_arguments(scene)

    def reset(self, S: kernels.Chain) -> None:
        """After the data's reset: the body pins' targets at their points, the clamps' directions in their bodies."""
        mujoco.mj_forward(self.m, self.d)
        points = self.d.site_xpos[self.sites]
        S.pin_from[self.pins] = points
        S.pin_to[self.pins] = points
        for k, (row, b) in enumerate(self._clamps):
            self._clamp_local[k] = self.d.xmat[b].reshape(3, 3).T @ S.clamp_dir[row].T
        self._fresh = True

    def _host_arguments(self, scene: Scene) -> Optional[tuple]:
        """:func:`host_kernels.host_substeps`'s arguments after the state, the contacts, n and h (``capi``, links,
        clamps, gravity, ``mjData`` views, the moving obstacles, the two-way buffers), or ``None`` where MuJoCo's C
        API is unavailable (:func:`capi.host_functions`)."""
        fns = capi.host_functions()
        if fns is None:
            return None
        m, d, o = self.m, self.d, self.obstacles
        c = np.zeros(host_kernels.N_HC, dtype=np.int64)
        H = host_kernels.HC
        c[[H["step"], H["kinematics"], H["get_state"], H["set_state"], H["jac"], H["solve_m"], H["model"], H["data"],
           H["sig"], H["nv"], H["nstate"]]] = (fns.step, fns.kinematics, fns.get_state, fns.set_state, fns.jac,
                                              fns.solve_m, capi.model_address(m), int(d._address), int(_STATE), m.nv,
                                              len(self._saved))
        links = np.zeros((len(self.pins), host_kernels.N_LK), dtype=np.int64)
        L = host_kernels.LK
        links[:, [L["pin"], L["particle"], L["neighbour"], L["body"], L["site"]]] = np.stack(
            [self.pins, self.particles, self.neighbours, self.bodies, self.sites], axis=1).reshape(-1, 5)
        moving = np.zeros((0, 2), dtype=np.int64)
        shapes = np.zeros((0, kernels.N_SH))
        if o is not None:  # the geoms ObstacleContacts.refresh_moving refreshes, and their rows of its shapes
            g = o.moving_geoms
            moving = np.stack([g, o.shape_of_geom[g]], axis=1).astype(np.int64).reshape(-1, 2)
            shapes = o.shapes
        return (c, links, self._clamps, self._clamp_local, np.array(self.gravity, dtype=np.float64), d.site_xpos,
                d.xipos, d.xmat, d.xfrc_applied, d.geom_xpos, d.geom_xmat, d.warning.number,
                np.array([int(w) for w in _BAD], dtype=np.int64), moving, shapes, self.impulse, self._rows,
                self._row_bodies, self.contact_wrench)

    def _inverse_masses(self, S: kernels.Chain, points: np.ndarray) -> np.ndarray:
        """(P,) 1/kg: each body's inverse mass at its pin point along the cable (step 1 of the scheme)."""
        m, d = self.m, self.d
        out = np.zeros(len(self.pins))
        for j in range(len(self.pins)):
            mujoco.mj_jac(m, d, self._jacp, None, points[j], int(self.bodies[j]))
            host_kernels.pin_axis_jacobian(S.x, self.particles[j], self.neighbours[j], self._jacp, self._jn[0])
            mujoco.mj_solveM(m, d, self._solved, self._jn)
            out[j] = host_kernels.dot(self._jn[0], self._solved[0])
        return out

    def substeps(self, S: kernels.Chain, C: kernels.Contacts, n: int,
                 one_substep: Optional[Callable[[], tuple]] = None) -> tuple:
        """``n`` solver substeps, each with its host ``mj_step`` and each taken by ``one_substep()`` (default: the
        kernels' own whole substep, the solver stepping at h). Grippers move linearly towards their targets as in
        the plain path. Returns (finite, sockets released, a divergence reason from MuJoCo's warnings or None).

        Without ``one_substep``, all ``n`` substeps run in one compiled call where MuJoCo's C API is available (but
        for the first step after a reset), with the same results bit for bit (see the module docstring).
        """
        if one_substep is None and self.compiled and not self._fresh and self._compiled_args is not None:
            finite, released, warning = host_kernels.host_substeps(*S, *C, n, self.h, *self._compiled_args)
            return finite, released, None if warning < 0 else _reason(warning)
        self._fresh = False
        m, d, h = self.m, self.d, self.h
        start_from, start_to = S.pin_from.copy(), S.pin_to.copy()
        coupled = len(self.pins) > 0
        finite, released = True, 0
        for sub in range(n):
            target = start_from + ((sub + 1.0) / n) * (start_to - start_from)
            if coupled:
                p0 = d.site_xpos[self.sites].copy()
                arm = p0 - d.xipos[self.bodies]
                w_b = self._inverse_masses(S, p0)
                mujoco.mj_getState(m, d, self._saved, _STATE)
                mujoco.mj_step(m, d)
                mujoco.mj_kinematics(m, d)
                free = d.site_xpos[self.sites].copy()
                for k, (row, b) in enumerate(self._clamps):
                    host_kernels.turn_clamp(d.xmat, b, self._clamp_local[k], S.clamp_dir, row)
                mujoco.mj_setState(m, d, self._saved, _STATE)
                target[self.pins] = free
                free_w = np.where(w_b > _RIGID, w_b, 0.0)
                S.w[self.particles] = free_w
            S.pin_to[:] = target
            two_way = len(self.impulse) > 0
            if two_way:
                self.impulse[:] = 0.0
            if one_substep is not None:
                ok, count = one_substep()
            else:
                ok, count = kernels.run_substeps_flat(*S, *C, 1, kernels.PHASE_ALL, 0)
            finite = finite and ok
            released += count
            if coupled:
                moving = free_w > 0.0
                f = np.zeros_like(free)
                f[moving] = (S.x[self.particles[moving]] - free[moving]) / (free_w[moving, None] * h * h)
                f[moving] += S.mass[self.particles[moving], None] * self.gravity
                f[~moving] = -S.pin_force[self.pins[~moving]]
                # the kernel counted −m g for a moving pin (its particle was free): its step sum takes −f instead
                held = self.pins[moving]
                S.pin_sum[held, kernels.PS_F:kernels.PS_F + 3] += -f[moving] - S.pin_force[held]
                S.pin_force[held] = -f[moving]
                applied = np.zeros((len(self.pins), 6))
                applied[:, :3] = f
                applied[:, 3:] = np.cross(arm, f)
                np.add.at(d.xfrc_applied, self.bodies, applied)
            if two_way:  # −Σ j / h² on each dynamic body, with its moment about the body's centre of mass
                contact_kernels.body_wrenches(self.impulse, self._rows, self._row_bodies, d.xipos, -1.0 / (h * h),
                                              self.contact_wrench, d.xfrc_applied)
            mujoco.mj_step(m, d)
            if coupled:
                np.subtract.at(d.xfrc_applied, self.bodies, applied)
            if two_way:
                d.xfrc_applied -= self.contact_wrench
            mujoco.mj_kinematics(m, d)
            if self.obstacles is not None:
                self.obstacles.refresh_moving()
            if coupled:
                p1 = d.site_xpos[self.sites]
                S.x[self.particles] = p1
                S.v[self.particles] = (p1 - p0) / h
            counts = d.warning.number
            bad = [int(w) for w in _BAD if counts[w] > 0]
            if bad:
                counts[bad] = 0
                return finite, released, _reason(bad[0])
        S.pin_to[:] = start_to
        if coupled:
            S.pin_to[self.pins] = d.site_xpos[self.sites]
        return finite, released, None


def _reason(warning: int) -> str:
    """The divergence reason of MuJoCo's warning code ``warning``."""
    return f"MuJoCo's warning {mujoco.mjtWarning(warning).name} in the user world"
