"""The particle backend behind :class:`mjcable.Simulator` for ``jakobsen``, ``pbd`` and ``xpbd`` (and any particle
model the catalogue registers with its own ``rules``).

One :meth:`ParticleBackend.step` advances exactly one ``dt``: query contacts (once, with a margin), run
``substeps`` substeps of ``iterations`` iterations in one numba call, then pose the proxy capsules from the
particles so that ``mj_data`` renders the cable. :meth:`ParticleBackend.run` takes many steps with the same
results, bit for bit: in one compiled loop (:func:`~mjcable.solvers.kernels.run_steps_flat`, the Simulator's
divergence checks included) that queries contacts itself through MuJoCo's C API (:mod:`mjcable.solvers.capi`;
Python's query where that is unavailable, or an obstacle moves), and the proxy posed once at the end.
"""

from __future__ import annotations

import time
from typing import Optional

import mujoco
import numpy as np

from mjcable.backends.host import Host
from mjcable.mjcf import proxy, world
from mjcable.scene import Scene
from mjcable.solvers import capi, kernels, query_kernels
from mjcable.solvers.contacts import ObstacleContacts
from mjcable.solvers.settings import ParticleSettings
from mjcable.solvers.state import empty_contacts, new_chain
from mjcable.solvers.user_constraints import iteration_factor

__all__ = ["ParticleBackend", "proxy_builder"]
_SELF_CONTACT_CAPACITY = 8  # initial self-contact buffer per segment (grown on demand)
_NON_FINITE = "non-finite particle state (NaN or inf) in the particle solver"
_NO_BUFFERS = (np.zeros(0, dtype=np.int64), np.zeros((0, 7)), np.zeros(0))  # obstacle contacts of a scene with none


def proxy_builder(scene: Scene, settings: ParticleSettings, dt: float) -> mujoco.MjSpec:
    """The catalogue's builder for a particle model: the proxy spec (:func:`mjcable.mjcf.proxy.build`)."""
    h = dt / settings.substeps if scene.world is not None else dt  # a user world steps in lock step, per substep
    with world.user_names(scene):
        return world.finish(proxy.build(scene, dt=h, contact_margin=settings.contact_margin), scene)


def _obstacle_bounds(obstacles: Optional[ObstacleContacts]) -> tuple:
    """The static obstacles as :meth:`ObstacleContacts.touching` tests them, for the step driver
    (:attr:`ObstacleContacts.bounds`); empty for none."""
    if obstacles is None:
        return tuple(np.zeros((0, 3)) for _ in range(4))
    return obstacles.bounds


class ParticleBackend:
    """A particle solver stepping a scene, with MuJoCo's proxy for contacts and rendering.

    Args:
      scene: the scene.
      entry: the model's catalogue entry; its ``rules(scene, settings, h)`` turns the physical cable into the
        kernels' parameters (:class:`~mjcable.solvers.state.Rules`) and its ``build`` makes the proxy spec.
      dt: step in seconds (> 0, validated by the Simulator).
      settings: the model's validated settings (a :class:`~mjcable.solvers.settings.ParticleSettings`).

    Attributes:
      mj_model, mj_data: the compiled proxy; its capsules follow the cable after every step.
      state: the solver arrays (:class:`~mjcable.solvers.kernels.Chain`).
      released: pin numbers (indices into ``scene.pins``) of sockets that have let go.
      compiled_steps: class switch: ``False`` leaves :attr:`runs_steps` false, so that the Simulator takes every
        step through :meth:`step` (the Python path that :meth:`run` must equal bit for bit; for tests and
        measurements).
      compiled_query: class switch: ``False`` makes :meth:`run`'s compiled loop return to Python for every contact
        query (``mujoco.mj_collision`` from Python) instead of querying through MuJoCo's C API itself
        (:mod:`mjcable.solvers.capi`); both give the same results bit for bit. The loop queries itself only where
        the C API's layout checks out (:func:`mjcable.solvers.capi.layout`) and no obstacle moves.
    """

    compiled_steps = True
    compiled_query = True

    def __init__(self, scene: Scene, entry, dt: float, settings: ParticleSettings):
        self.settings = s = settings
        self.scene, self.name, self.dt = scene, entry.name, dt
        self.h = dt / s.substeps
        self.rules = entry.rules(scene, s, self.h)
        n_particles = scene.cable.n_particles
        self._user = [(c, c.resolved(n_particles)) for c in getattr(s, "constraints", ())]
        self.state = new_chain(scene, self.rules, s, dt)
        self._start = {name: a.copy() for name, a in self.state._asdict().items()}  # reset() copies these back
        self.mj_model = entry.build(scene, s, dt).compile()
        self.mj_data = mujoco.MjData(self.mj_model)
        m = self.mj_model
        n = scene.cable.n_segments
        bodies = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, proxy.segment_name(i)) for i in range(n)]
        mocap = m.body_mocapid[bodies]
        if not np.array_equal(mocap, np.arange(n)):  # pragma: no cover - proxy.build adds the segments first
            raise RuntimeError("proxy segments must be the first mocap bodies")
        self._segment_geoms = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, proxy.segment_name(i))
                                        for i in range(n)])
        self._sites = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, world.particle_site(i))
                                for i in range(n_particles)])
        self._gripper_mocap = np.array([int(m.body_mocapid[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY,
                                                                             world.gripper_body(k))])
                                        for k in scene.grippers], dtype=np.int64)
        self._mocap_of_pin = dict(zip(scene.grippers, self._gripper_mocap.tolist()))
        self._pin_mocap = np.full(len(scene.pins), -1, dtype=np.int64)  # pin -> its gripper's mocap id (-1: none)
        self._pin_mocap[list(scene.grippers)] = self._gripper_mocap
        first = int(self._gripper_mocap[0]) if len(self._gripper_mocap) else 0
        self._gripper_rows = (slice(first, first + len(self._gripper_mocap))  # a slice copies faster than an index
                              if np.array_equal(self._gripper_mocap, np.arange(first, first + len(self._gripper_mocap)))
                              else self._gripper_mocap)
        # views into mj_data, taken once (MjData's buffers do not move): the proxy's poses are written in place
        self._pose_pos = self.mj_data.mocap_pos[:n]
        self._pose_quat = self.mj_data.mocap_quat[:n]
        first = int(self._sites[0])
        contiguous = np.array_equal(self._sites, np.arange(first, first + n_particles))
        self._site_pos = self.mj_data.site_xpos[first:first + n_particles] if contiguous else None
        self._start_pose()
        ours = slice(0 if scene.world is None else scene.world.model.npair, m.npair)
        self._obstacles = ObstacleContacts(scene, m, self.mj_data, self._segment_geoms, ours) if m.npair > ours.start \
            else None
        self._host = Host(scene, m, self.mj_data, self.h, self._obstacles) if scene.world is not None else None
        self._grow_self_buffers(_SELF_CONTACT_CAPACITY * n)
        self._loop_query = self._query_arguments()
        self._loop_can_query = self._loop_query is not None
        if self._loop_query is None:  # the loop returns for every query: its query arguments are never read
            self._loop_query = self._inert_query_arguments()
        self._gravity = float(np.linalg.norm(self.mj_model.opt.gravity))  # m/s²
        self._fall = 0.5 * self._gravity * dt**2  # m: what gravity adds to one step's travel
        # run()'s buffers: the step driver's limits (kernels.LIM), positions before a step, mj_data.time
        self._lim = np.zeros(len(kernels.LIM))
        self._lim[[kernels.LIM["dt"], kernels.LIM["contact_margin"], kernels.LIM["fall"], kernels.LIM["radius"]]] = (
            dt, s.contact_margin, self._fall, scene.cable.radius)
        self._prev = np.zeros((n_particles, 3))
        self._clock = np.zeros(1)
        self._bounds = _obstacle_bounds(self._obstacles)
        self._no_path = (np.zeros(0, dtype=np.int64), np.zeros((0, 0, 3)))  # run()'s path when it has none
        self.timing = {"query": 0.0, "solve": 0.0, "sync": 0.0}
        self.reset()

    def _grow_self_buffers(self, capacity: int) -> None:
        capacity = max(capacity, 1)
        self._self_pair = np.zeros((capacity, 2), dtype=np.int64)
        self._self_geo = np.zeros((capacity, 5))
        self._self_lam = np.zeros((capacity, 2))

    def _query_arguments(self) -> Optional[tuple]:
        """What :func:`kernels.run_steps_flat` needs to query contacts itself, but its buffers (``capi``, the
        ``mjData`` views, pose and margin views, geom maps; :meth:`run` adds the buffers), or ``None`` where it
        cannot: MuJoCo's C API unavailable (:func:`capi.layout`) or an obstacle that moves."""
        o, m = self._obstacles, self.mj_model
        if o is None:  # self contacts at most: no MuJoCo call
            return self._inert_query_arguments()
        lay = capi.layout()
        if lay is None or o.moving:
            return None
        arg = np.zeros(kernels.N_CAPI, dtype=np.int64)
        views = capi.data_views(self.mj_data, lay)
        self._views = views  # the views borrow mj_data's memory
        C = kernels.CAPI
        arg[[C["kinematics"], C["collision"], C["model"], C["data"], C["ncon"], C["contact"], C["arena"], C["stride"],
             C["dist"], C["pos"], C["frame"], C["geom"], C["pair_start"], C["pair_stop"]]] = (
            lay.kinematics, lay.collision, capi.model_address(m), views.address, lay.ncon // 4, lay.contact // 8,
            views.arena_address, lay.contact_size, lay.dist, lay.pos, lay.frame, lay.geom, o.pairs.start, o.pairs.stop)
        return (arg, views.struct_i32, views.struct_i64, views.arena_f64, views.arena_i32, self._pose_pos,
                self._pose_quat, m.pair_margin, o.segment_of_geom, o.shape_of_geom, o.friction)

    def _inert_query_arguments(self) -> tuple:
        """:meth:`_query_arguments` for a loop that never calls MuJoCo (typed alike, so that one compiled loop
        serves all)."""
        nothing = np.zeros(0, dtype=np.int64)
        return (np.zeros(kernels.N_CAPI, dtype=np.int64), np.zeros(0, dtype=np.int32), nothing, np.zeros(0),
                np.zeros(0, dtype=np.int32), self._pose_pos, self._pose_quat, self.mj_model.pair_margin, nothing,
                nothing, np.zeros((0, 3)))

    def _start_pose(self) -> None:
        """MuJoCo's data at the start: the model's start keyframe (a user world's start) or its default pose."""
        m, d = self.mj_model, self.mj_data
        world.reset_to_start(m, d)
        mujoco.mj_kinematics(m, d)

    @property
    def runs_steps(self) -> bool:
        """Whether :meth:`run` can take the Simulator's steps: always, but with PBD's user constraints (projected
        in Python between iterations), in a user world (stepped by MuJoCo between substeps) or with
        :attr:`compiled_steps` off."""
        return self.compiled_steps and not self._user and self._host is None

    def reset(self) -> None:
        """Copy the start state back into the solver's arrays (in place), and the proxy back to its start pose."""
        for name, a in self.state._asdict().items():
            np.copyto(a, self._start[name])
        self._start_pose()
        if self._host is not None:
            self._host.reset(self.state)
        self._posed = False
        self.contacts = empty_contacts(shapes=None if self._obstacles is None else self._obstacles.shapes)
        if self._host is not None:  # the contacts' impulses on the world's bodies (none for static obstacles)
            self.contacts = self.contacts._replace(impulse=self._host.impulse)
        self.released = set()
        self.last_contact_count = 0
        self.last_self_contact_count = 0
        self.queries = 0
        self._sync()

    # -- the step -------------------------------------------------------------------------------------------------

    def step(self) -> Optional[str]:
        """Advance one ``dt``. Returns a reason string if the state became non-finite, else ``None``."""
        t0 = time.perf_counter()
        self._find_contacts()
        t1 = time.perf_counter()
        if self._host is not None:
            if self._obstacles is not None:
                self._obstacles.disable()
            finite, released, warning = self._host.substeps(self.state, self.contacts, self.settings.substeps,
                                                            (lambda: self._user_substep(1, 0)) if self._user else None)
            if warning:
                return warning
        elif self._user:
            finite, released = self._substeps_with_user_constraints()
        else:
            finite, released = kernels.run_substeps_flat(*self.state, *self.contacts, self.settings.substeps,
                                                         kernels.PHASE_ALL, 0)
        t2 = time.perf_counter()
        S = self.state
        S.pin_from[:] = S.pin_to
        if released:
            self.released.update(int(k) for k in np.flatnonzero(~S.pin_active))
        self._sync()
        if self._host is None:  # a user world's mj_step keeps the time
            self.mj_data.time += self.dt
        self.timing["query"] += t1 - t0
        self.timing["solve"] += t2 - t1
        self.timing["sync"] += time.perf_counter() - t2
        return None if finite else _NON_FINITE

    def run(self, count: int, *, max_distance: float, max_speed: float, rows: np.ndarray, out_x: np.ndarray,
            out_v: np.ndarray, path: Optional[tuple] = None, until_release: bool = False) -> tuple:
        """Up to ``count`` steps with the results of as many :meth:`step` calls, bit for bit, stopping after a step
        that fails a divergence check; ``mj_data`` is posed once, at the end. With a gripper ``path``, the results
        of :meth:`move_gripper` for the moving grippers before each of those calls.

        The steps run in one compiled loop (:func:`kernels.run_steps_flat`), which also runs their contact queries
        (a step whose reach touches an obstacle's bounding box, or every step with self-collision) through MuJoCo's
        C API; without it (:attr:`compiled_query` off, :func:`capi.layout` ``None``, a moving obstacle), or when
        a query overflows the loop's buffers, the loop returns to Python for that step's ``mj_collision``.

        Args:
          count: steps to take (>= 1).
          max_distance, max_speed: the Simulator's runaway limits (m from the origin, m/s).
          rows: ``(R,)`` ascending step numbers (1..count) after which to record the state, into ``out_x`` and
            ``out_v`` ``(R, n_segments + 1, 3)`` (m, m/s).
          path: ``(pins, targets)`` or ``None``: before step ``k`` the gripper of ``scene.pins[pins[g]]`` (``pins``
            (G,) int64) moves to ``targets[k, g]`` (``(count, G, 3)`` m, C-contiguous), as :meth:`move_gripper` (a
            gripper sent where it already is stays bit for bit: its target and mocap body hold the same numbers).
          until_release: also stop after a step in which a socket let go.

        Returns:
          (steps taken, rows recorded, the solver's divergence reason or ``None``, the positions (N, 3) before
          the last step if a check stopped the run, else ``None``: the caller checks that step again and raises).
        """
        S, s, lim, clock = self.state, self.settings, self._lim, self._clock
        lim[kernels.LIM["max_distance"]], lim[kernels.LIM["max_speed"]] = max_distance, max_speed
        clock[0] = self.mj_data.time
        solo = bool(s.self_collision)
        pins, targets = self._no_path if path is None else path
        done = stored = 0
        reason = previous = None
        query = self._loop_query
        query[0][kernels.CAPI["enabled"]] = self.compiled_query and self._loop_can_query
        counts = np.zeros(3, dtype=np.int64)
        while done < count:
            t0 = time.perf_counter()
            # (the loop moves the grippers itself; the query does not need them: with no user world, which runs_steps
            # requires, a gripper is a mocap body with a visual geom only, world.add_anchor)
            self._find_contacts()
            t1 = time.perf_counter()
            chunk = rows[stored:] - done if len(rows) > stored else rows[:0]
            buffers = self._obstacles.buffers if self._obstacles is not None else _NO_BUFFERS
            k, finite, released, stopped, recorded = kernels.run_steps_flat(
                *S, *self.contacts, s.substeps, count - done, solo, lim, *self._bounds, self._prev, chunk,
                out_x[stored:], out_v[stored:], clock, targets[done:], pins, until_release, *query, *buffers,
                self._self_pair, self._self_geo, self._self_lam, counts)
            self._posed = False
            self.timing["query"] += t1 - t0
            self.timing["solve"] += time.perf_counter() - t1
            done += k
            stored += recorded
            if query[0][kernels.CAPI["enabled"]] and self._obstacles is not None:  # the loop may have set the margins
                self._obstacles.forget_margin()
            if k > 1:  # the loop's later steps: their contacts (queried in the loop) or none
                n_con, n_self = int(counts[kernels.COUNT_CONTACTS]), int(counts[kernels.COUNT_SELF])
                self.last_contact_count, self.last_self_contact_count = n_con, n_self
                seg, geo, lam = buffers
                self.contacts = self.contacts._replace(
                    seg=seg[:n_con], geo=geo[:n_con], lam=lam[:n_con], pair=self._self_pair[:n_self],
                    sgeo=self._self_geo[:n_self], slam=self._self_lam[:n_self])
            if released:
                self.released.update(int(pin) for pin in np.flatnonzero(~S.pin_active))
            if stopped:
                reason = None if finite else _NON_FINITE
                previous = self._prev.copy()
                break
            if released and until_release:
                break
        self.queries += int(counts[kernels.COUNT_QUERIES])
        if done and len(targets):  # the grippers' mocap bodies where the loop sent them (pin_to holds it)
            self.mj_data.mocap_pos[self._pin_mocap[pins]] = S.pin_to[pins]
        t2 = time.perf_counter()
        self.mj_data.time = float(clock[0])
        self._sync()
        self.timing["sync"] += time.perf_counter() - t2
        return done, stored, reason, previous

    def _find_contacts(self) -> None:
        S, s = self.state, self.settings
        contacts = self.contacts
        # the distance a particle can travel in one step, plus the configured margin (the margin alone for a diverged
        # state: left to the divergence check)
        margin = kernels.step_margin(S.v, s.contact_margin, self.dt, self._fall)
        self.last_contact_count = 0
        if self._obstacles is not None:
            if self._obstacles.touching(S.x, margin + self.scene.cable.radius):
                if not self._posed:  # run() poses the proxy only at its end: mj_collision needs it now
                    self._pose()
                contacts = self._obstacles.query(S.x, margin, contacts)
                self.queries += 1
            else:
                contacts = contacts._replace(seg=contacts.seg[:0], geo=contacts.geo[:0], lam=contacts.lam[:0])
            self.last_contact_count = len(contacts.seg)
        if s.self_collision:
            reach = 2.0 * self.scene.cable.radius + margin
            count = query_kernels.find_self_contacts(S.x, reach, self._self_pair, self._self_geo)
            while count < 0:
                self._grow_self_buffers(2 * self._self_pair.shape[0])
                count = query_kernels.find_self_contacts(S.x, reach, self._self_pair, self._self_geo)
            contacts = contacts._replace(pair=self._self_pair[:count], sgeo=self._self_geo[:count],
                                         slam=self._self_lam[:count])  # (zeroed by every substep)
            self.last_self_contact_count = count
        self.contacts = contacts

    def _user_substep(self, n: int, sub: int) -> tuple:
        """Substep ``sub`` of ``n``, as :func:`kernels.run_substeps` takes it, with PBD user constraints projected in
        Python after the built-in ones in every iteration. Returns (finite, sockets released)."""
        S, C, s = self.state, self.contacts, self.settings
        kernels.run_substeps_flat(*S, *C, n, kernels.PHASE_BEGIN, sub)
        for _ in range(s.iterations):
            kernels.run_substeps_flat(*S, *C, n, kernels.PHASE_ITERATE, sub)
            for constraint, idx in self._user:
                constraint.project(S.x, S.w, idx, iteration_factor(constraint.factor, s.iterations))
        return kernels.run_substeps_flat(*S, *C, n, kernels.PHASE_END, sub)

    def _substeps_with_user_constraints(self) -> tuple:
        """The same substeps as :func:`kernels.run_substeps`, with PBD user constraints (:meth:`_user_substep`)."""
        n = self.settings.substeps
        released = 0
        finite = True
        for sub in range(n):
            finite, count = self._user_substep(n, sub)
            released += count
        return finite, released

    def _pose(self) -> None:
        """Pose the proxy capsules from the particles and run MuJoCo's kinematics (what ``mj_collision`` needs)."""
        query_kernels.proxy_poses(self.state.x, self._pose_pos, self._pose_quat)
        mujoco.mj_kinematics(self.mj_model, self.mj_data)
        self._posed = True

    def _sync(self) -> None:
        """Pose the proxy capsules (and particle sites) from the particles: ``mj_data`` current for its readers."""
        x = self.state.x
        self._pose()
        mujoco.mj_camlight(self.mj_model, self.mj_data)  # cameras and lights (a renderer reads cam_xpos)
        # the exact particles (the capsules keep their rest length, so their end sites are off by the strain)
        if self._site_pos is not None:
            self._site_pos[:] = x
        else:  # pragma: no cover - proxy.build keeps the particle sites contiguous
            self.mj_data.site_xpos[self._sites] = x

    # -- the Simulator's interface --------------------------------------------------------------------------------

    def positions(self) -> np.ndarray:
        return self.state.x.copy()

    def velocities(self) -> np.ndarray:
        return self.state.v.copy()

    def particle_masses(self) -> np.ndarray:
        return self.state.mass.copy()

    def gripper_positions(self) -> np.ndarray:
        return self.mj_data.mocap_pos[self._gripper_rows].copy()

    def move_gripper(self, k: int, position: np.ndarray) -> None:
        """Move the gripper of ``scene.pins[k]`` to ``position`` (3,) m: its particle reaches it linearly over the
        next step's substeps."""
        self.state.pin_to[k] = position
        self.mj_data.mocap_pos[self._mocap_of_pin[k]] = position

    def add_point_mass(self, index: int, mass: float) -> None:
        """Add ``mass`` kg to particle ``index``'s lumped mass (in the start state too, so :meth:`reset` keeps it);
        a held particle stays held (its mass then enters its pin's force)."""
        S = self.state
        for arrays in (S, self._start):
            m, w = (arrays.mass, arrays.w) if arrays is S else (arrays["mass"], arrays["w"])
            m[index] += mass
            if w[index] > 0.0:
                w[index] = 1.0 / m[index]

    def pin_forces(self) -> np.ndarray:
        """Each pin's force on its particle, averaged over the last step's substeps: F̄ = Σ_s F_s / n = J / dt,
        J the impulse the pin gave its particle in the step, F_s its force in substep s (XPBD's force estimate
        ∇Cᵀλ / h² over the constraints on the held particle, plus its weight; a host body pin's coupling force:
        :func:`mjcable.solvers.kernels.end_substep`). Sockets let go on this same mean (as native sockets on
        MuJoCo's constraint force of one step): one substep's force is not a measure of the pull, since a
        positional solver settles a violation (a contact's penetration, the stretch it leaves) within one substep,
        as a force spike of that substep. Zero rows before the first step and for released sockets."""
        S = self.state
        count = S.pin_sum[:, kernels.PS_N, None]
        f = np.divide(S.pin_sum[:, kernels.PS_F:kernels.PS_F + 3], count, out=np.zeros((len(count), 3)),
                      where=count > 0)
        f[~S.pin_active] = 0.0
        return f

    def pin_torques(self) -> np.ndarray:
        """A clamp's torque about its particle p: (x_q − x_p) × f_q, f_q = Σₘ ∇_q Cₘ λₘ / h² the clamp's force on
        the neighbour q (:func:`mjcable.solvers.kernels.clamp_sweep`: ∇_q Cₘ = (2 / l₀²) dₘ)."""
        S = self.state
        out = np.zeros((len(self.scene.pins), 3))
        scale = 2.0 / self.scene.cable.segment_length**2
        for kc, (p, q) in enumerate(S.clamp_pq):
            k = int(S.clamp_pin[kc])
            if S.pin_active[k]:
                f = scale * (S.lam_c[kc] @ S.clamp_dir[kc]) / self.h**2
                out[k] = np.cross(S.x[q] - S.x[p], f)
        return out

    def diagnostics(self) -> dict:
        """``contacts`` and ``self_contacts`` found by the last step, ``queries`` (steps that ran MuJoCo's collision
        query) and cumulative seconds in ``query_s`` (the queries run from Python), ``solve_s`` (the solver, and the
        queries the compiled loop runs itself) and ``sync_s``."""
        return {"contacts": self.last_contact_count, "self_contacts": self.last_self_contact_count,
                "queries": self.queries, **{f"{k}_s": v for k, v in self.timing.items()}}
