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
to carry the body's weight without stretch, as any heavy end mass does. w_b comes from M, while MuJoCo's Euler step
divides by M + h·D (its implicit joint damping): where a joint's h·b is not small against the body's inertia, the
body moves less than the coupling assumed.

A clamp, both ways. The point chains' (``xpbd``, ``pbd``, ``jakobsen``) holds the tangent along directions d_m fixed
in the body, C_m = (2 / l₀²) d_m · (x_q − x_p) (q the neighbour): the directions are predicted where the trial step
turns the body (R d_local, ``clamp_local``) and turn in the solve with the body's inverse rotational inertia
W = J_r M⁻¹ J_rᵀ (``clamp_wq``, in the world; the rows' J W Jᵀ gains (2 / l₀²)² (d_a × e)ᵀ W (d_b × e), e = x_q − x_p,
in the direct system and in each Gauss-Seidel projection); the pinned particle's share reaches the body as its
pull, and the directions' share, τ = Σ ∇_θ C Δλ = Σ (2 / l₀²) Δλ d_m × e (``clamp_react``), goes to the body as
the torque τ / h², so the body feels the clamp's moment (the neighbour's constraint force applied at the
neighbour). ``cosserat``'s (a rod with frames) holds the segment's whole frame in the body, both ways: the
clamp's frame is predicted where the trial step turns the body (q_body ⊗ q_local, ``clamp_qlocal``) and turns in
the rod's solve with the body's inverse rotational inertia W = J_r M⁻¹ J_rᵀ (``mj_jac``'s rotational Jacobian,
``mj_solveM``; :mod:`mjcable.solvers.cosserat_kernels`); the torque it received, τ = Σ R_c ∇_c Cᵀ Δλ / h², goes to
the body with the pin's force (``xfrc_applied``), so the real step turns the body where the solve turned the frame
(exactly for a hinge). As with w_b, W ignores the cross terms between the point's translation and the body's turn,
and between two clamps or pins in one body.

Two-way contacts. The cable's contacts with the world's geoms (:mod:`mjcable.solvers.contacts`) act on the
world's dynamic bodies (not welded to the world nor to a mocap body: ``body_weldid`` ≠ 0 and not mocap), once per
substep:

1. after every host step the moving obstacles' shapes are refreshed
   (:func:`~mjcable.solvers.query_kernels.refresh_moving`), so the solver's substep meets each body where it is;
2. the solver's substep treats every obstacle as immovable and sums, per obstacle, the impulses its contacts gave
   the cable (:func:`~mjcable.solvers.impulse_kernels.collect_impulses`): j = Σ_c λₙ_c n_c (normal) + Σ_p f_p
   (each free particle's friction impulse), in kg·m, so that j / h = Σ m_p Δx_p / h is the momentum the contact
   projections gave the cable, with its moment about the origin from the contact points;
3. the real ``mj_step`` applies −j / h² to the body (``xfrc_applied``: the force and its moment about the body's
   centre of mass ``xipos``), equal and opposite to what the body did to the cable. Self contacts give nothing.

Momentum is exchanged exactly (a box braked by a cable sliding on it keeps M v_box + Σ m_p v_p to 1e-14), but the
scheme is explicit in the body: it does not move under the contact within the substep and answers in its own step.
With the cable pinned to the body's surface by the contact (normal contact, sticking friction), the relative velocity
along the contact is multiplied by −m / M every substep (m the cable mass the contacts move with the body, M the
body's effective mass 1/(nᵀ J M⁻¹ Jᵀ n) along the contact): stable for m / M < 1, whatever h. Beyond, the normal
contact chatters (``scripts/bench_two_way_limit.py``; ``docs/measurements.md``), and sticking friction becomes a
bounded stick-slip cycle (the cone caps each substep's impulse at
μ λₙ). Where the world's own constraints hold the body along the contact (a box resting on a table under the cable)
its effective mass is that of what holds it, and a box 10 times lighter than the cable on it stays at rest. Pins
keep their scheme above; a pinned particle's contact shares (held particles collect ∇C Δλ) count in j.
A cable squeezed between a body and another face rubs on both (:mod:`~mjcable.solvers.contact_kernels`: a particle's
cone sums the normal impulses of opposite faces, and its friction is shared among the obstacles in proportion to
them): a weight of mass W lying on a cable on a table takes μ (2 W + m) g to pull the cable out and is dragged by
μ W g, within 1 % with ``xpbd``'s direct order (``tests/test_two_way_contacts.py``). Under such a squeeze the
body's explicit contact force alternates from substep to substep, and the Gauss-Seidel orders' single sweep then
keeps only part of the friction (a strict xfail records it; ``docs/measurements.md``).

The host's substeps run inside the particle solvers' compiled step loop (:mod:`mjcable.solvers.host_kernels`,
MuJoCo called through its C API: :func:`mjcable.solvers.capi.host_functions`). A MuJoCo *error* inside such a call
ends the process, so :meth:`Host.reset` steps the world once through the bindings (state restored after): an error of
the starting state (``mju_error``, e.g. an arena too small) is then a ``mujoco.FatalError``.
"""

from __future__ import annotations

from typing import Optional

import mujoco
import numpy as np

from mjcable.mjcf import world
from mjcable.scene import Scene
from mjcable.solvers import capi
from mjcable.solvers.contacts import ObstacleContacts
from mjcable.solvers.state import quat_mul

__all__ = ["Host"]

_BAD = (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL)
_STATE = mujoco.mjtState.mjSTATE_INTEGRATION


class Host:
    """The user's world around a particle cable (see the module docstring): the state's host fields, built once.

    Args:
      scene: the scene (with a world).
      mj_model, mj_data: the compiled proxy in the user's world; timestep h.
      obstacles: the cable's contacts with the world's geoms (``None``: none); those on dynamic bodies get the
        contacts' reactions.
      frames: the cable is a rod with material frames (``cosserat``): a body clamp holds its frame in the body,
        which feels the rod's torque.
      rings: the body rings' links (:func:`mjcable.backends.rings.body_links`), coupled as body pins are (their
        neighbour ``−1 − r``: the direction is ring r's pull, ``ring_dir``).

    Raises:
      RuntimeError: MuJoCo's C API is unavailable (:func:`mjcable.solvers.capi.host_unavailable` says why): the host
        runs only in compiled code.
    """

    def __init__(self, scene: Scene, mj_model: mujoco.MjModel, mj_data: mujoco.MjData,
                 obstacles: Optional[ObstacleContacts] = None, *, frames: bool = False, rings: Optional[dict] = None):
        fns = capi.host_functions()
        if fns is None:
            raise RuntimeError("the particle solvers step a user world through MuJoCo's C API, which is unavailable "
                               f"here: {capi.host_unavailable()}; use a native model (springs, joints, flexrod) in a "
                               "user world")
        self.m, self.d = mj_model, mj_data
        m, d = mj_model, mj_data
        pins = [k for k, pin in enumerate(scene.pins) if pin.on_body]
        self.pins = np.array(pins, dtype=np.int64)
        self.particles = np.array([scene.pin_particle(k) for k in pins], dtype=np.int64)
        self.sites = np.array([m.site(world.anchor_site(k)).id for k in pins], dtype=np.int64)
        bodies = np.array([m.body(scene.pins[k].body).id for k in pins], dtype=np.int64)
        clamped = [k for k, pin in enumerate(scene.pins) if pin.clamp]
        #: (K, 2) [row in the state's clamp arrays, body id] of the body pins' clamps
        self._clamps = np.array([(clamped.index(k), int(bodies[j])) for j, k in enumerate(pins)
                                 if scene.pins[k].clamp], dtype=np.int64).reshape(-1, 2)
        neighbours = np.array([scene.clamp_neighbour(k) for k in pins], dtype=np.int64)
        if rings is not None:  # body rings' hubs: links like the body pins' (mjcable.backends.rings.body_links)
            self.pins = np.concatenate([self.pins, rings["link_pin"]])
            self.particles = np.concatenate([self.particles, rings["link_particle"]])
            self.sites = np.concatenate([self.sites, rings["link_site"]])
            bodies = np.concatenate([bodies, rings["link_body"]])
            neighbours = np.concatenate([neighbours, rings["link_neighbour"]])
        rows = row_bodies = np.zeros(0, dtype=np.int64)
        n_rows = 0  # obstacle rows of the contact impulses (none: no body takes them)
        if obstacles is not None:
            body = m.geom_bodyid[obstacles.obstacle_geoms]
            weld = m.body_weldid[body]
            dynamic = (weld != 0) & (m.body_mocapid[weld] < 0)  # not welded to the world nor to a mocap body
            rows, row_bodies = np.flatnonzero(dynamic).astype(np.int64), body[dynamic].astype(np.int64)
            if len(rows):
                n_rows = len(body)
        nstate = mujoco.mj_stateSize(m, _STATE)
        L = len(self.pins)
        self._saved = np.zeros(nstate)
        #: the state's host fields (kernels_layout.FIELDS) and parameters (kernels_layout.PARAMS)
        self.fields = dict(
            link_pin=self.pins, link_particle=self.particles,
            link_neighbour=neighbours, link_body=bodies,
            link_site=self.sites, link_clamp=self._clamps, clamp_local=np.zeros((len(self._clamps), 3, 2)),
            clamp_qlocal=np.zeros((len(self._clamps) if frames else 0, 4)),
            site_xpos=d.site_xpos, xipos=d.xipos, xmat=d.xmat, xquat=d.xquat, xfrc_applied=d.xfrc_applied,
            warning_number=d.warning.number, bad=np.array([int(w) for w in _BAD], dtype=np.int64),
            wrench_rows=rows, wrench_bodies=row_bodies, contact_wrench=np.zeros((m.nbody, 6)),
            impulse_force=np.zeros((n_rows, 3)), impulse_moment=np.zeros((n_rows, 3)),
            saved=np.zeros(nstate), jacp=np.zeros((3, m.nv)), jn=np.zeros((1, m.nv)), solved=np.zeros((1, m.nv)),
            p0=np.zeros((L, 3)), arm=np.zeros((L, 3)), free=np.zeros((L, 3)), free_w=np.zeros(L),
            force=np.zeros((L, 3)), applied=np.zeros((L, 6)), jacr=np.zeros((3, m.nv)), solved_r=np.zeros((3, m.nv)))
        self.params = dict(host=True, fn_step=fns.step, fn_kinematics=fns.kinematics, fn_get_state=fns.get_state,
                           fn_set_state=fns.set_state, fn_jac=fns.jac, fn_solve_m=fns.solve_m,
                           model=capi.model_address(m), data=int(d._address), state_sig=int(_STATE), nv=m.nv,
                           nstate=nstate)

    def reset(self, arrays: dict) -> None:
        """After the data's reset: the body pins' targets at their points, the clamps' directions (a rod's: frames)
        in their bodies, and one step of the world through the bindings, undone (an error of the starting state
        raises here)."""
        m, d = self.m, self.d
        mujoco.mj_forward(m, d)
        points = d.site_xpos[self.sites]
        arrays["pin_from"][self.pins] = points
        arrays["pin_to"][self.pins] = points
        local, qlocal = arrays["clamp_local"], arrays["clamp_qlocal"]
        for k, (row, b) in enumerate(self._clamps):
            local[k] = d.xmat[b].reshape(3, 3).T @ arrays["clamp_dir"][row].T
            if len(qlocal):  # a rod's clamped frame in its body: q̄_body ⊗ q_clamp
                qlocal[k] = quat_mul(d.xquat[b] * [1.0, -1.0, -1.0, -1.0], arrays["clamp_q"][row])
        warnings = d.warning.number.copy()
        mujoco.mj_getState(m, d, self._saved, _STATE)
        mujoco.mj_step(m, d)
        mujoco.mj_setState(m, d, self._saved, _STATE)
        d.warning.number[:] = warnings
        mujoco.mj_forward(m, d)


def reason(warning: int) -> str:
    """The divergence reason of MuJoCo's warning code ``warning``."""
    return f"MuJoCo's warning {mujoco.mjtWarning(warning).name} in the user world"
