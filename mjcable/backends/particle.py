"""The particle backend behind :class:`mjcable.Simulator` for ``jakobsen``, ``pbd`` and ``xpbd`` (and any particle
model the catalogue registers with its own ``rules``).

:meth:`ParticleBackend.run` takes whole steps in one compiled call (:func:`mjcable.solvers.kernels.run_steps`) on the
solver's packed state (:class:`~mjcable.solvers.kernels_layout.SolverState`): each step queries its contacts
(``mj_collision`` through MuJoCo's C API, :mod:`mjcable.solvers.capi`; Python's ``mujoco.mj_collision`` where that
is unavailable), runs ``substeps`` substeps of ``iterations`` iterations (in a user world each with the world's
``mj_step``, :mod:`mjcable.backends.host`) and passes the divergence checks; the proxy capsules are posed from the
particles once, at the end, so that ``mj_data`` renders the cable. The state is assembled from explicit parts, each
built once: the chain (:func:`mjcable.solvers.state.chain_arrays`), the contact query
(:class:`~mjcable.solvers.contacts.ObstacleContacts` and the C API's views of the proxy's ``mjData``) and the host
world (:class:`~mjcable.backends.host.Host`). PBD's user constraints, Python callables, are the one case that steps
in Python, piece by piece (:func:`mjcable.solvers.kernels.run_phase`).
"""

from __future__ import annotations

import math
import time
from typing import Optional

import mujoco
import numpy as np

from mjcable.backends import host as host_world
from mjcable.backends import rings as rings_
from mjcable.backends.grasp import ParticleGrasps, add_pin_rows
from mjcable import monitor
from mjcable.backends.protocol import MAX_DISTANCE, MAX_SPEED, Energy, RunResult
from mjcable.mjcf import proxy, world
from mjcable.scene import Scene
from mjcable.solvers import capi, convergence, kernels, kernels_layout as layout, query_kernels
from mjcable.solvers.contacts import ObstacleContacts
from mjcable.solvers.energy import elastic_energy, rod_energy
from mjcable.solvers.settings import ParticleSettings
from mjcable.solvers import winches
from mjcable.solvers.state import StateArrays, cable_rules, chain_arrays, quat_mul
from mjcable.solvers.user_constraints import iteration_factor

__all__ = ["ParticleBackend", "proxy_builder"]
#: the fields reset() copies back: the chain, its constraints, pins and direct system, friction, the parameters
_RESET = ("x", "v", "x0", "w", "mass", "react", "dx", "relax", "prev", "par", "rest", "lam_s", "rest_d", "lam_d",
          "lam_b", "clamp_pq", "clamp_pin", "clamp_dir", "lam_c", "pin_p", "pin_from", "pin_to", "pin_active",
          "pin_release", "pin_force", "pin_sum", "pin_count", "band", "grad", "rhs", "fric_n", "fric_mu",
          "fric_slid", "fric_nsum", "fric_impulse", "fric_normal", "fric_ob", "anchor", "anchor_ob", "q", "q0",
          "omega", "lam_ss", "lam_bt", "lam_end", "clamp_q", "clamp_qfrom", "clamp_qto", "clamp_react",
          "clamp_wq", "lam_j", "junction_sum", "lam_weld", "ring_seg", "ring_t", "ring_mode", "ring_lam",
          "ring_dir") + winches.RESET_FIELDS
_NO_PATH = (np.zeros(0, dtype=np.int64), np.zeros((0, 0, 3)))  # run()'s path when it has none


def proxy_builder(scene: Scene, settings: ParticleSettings, dt: float) -> mujoco.MjSpec:
    """The catalogue's builder for a particle model: the proxy spec (:func:`mjcable.mjcf.proxy.build`)."""
    h = dt / settings.substeps if scene.world is not None else dt  # a user world steps in lock step, per substep
    with world.user_names(scene):
        spec = proxy.build(scene, dt=h, contact_margin=settings.contact_margin)
        rings_.add_sites(spec, scene)
        return world.finish(spec, scene)


class ParticleBackend:
    """A particle solver stepping a scene, with MuJoCo's proxy for contacts and rendering.

    Args:
      scene: the scene.
      entry: the model's catalogue entry; its ``rules(scene, settings, h)`` turns the physical cable into the
        kernels' parameters (:class:`~mjcable.solvers.state.Rules`) and its ``build`` makes the proxy spec.
      dt: step in seconds (> 0, validated by the Simulator).
      settings: the model's validated settings (a :class:`~mjcable.solvers.settings.ParticleSettings`).

    Attributes:
      mj_model, mj_data: the compiled proxy; its capsules follow the cable after every run.
      state: the packed solver state (:class:`~mjcable.solvers.kernels_layout.SolverState`).
      arrays: its fields as numpy arrays sharing its memory (:class:`~mjcable.solvers.state.StateArrays`).
      released: pin numbers (indices into ``scene.pins``) of sockets that have let go.
    """

    def __init__(self, scene: Scene, entry, dt: float, settings: ParticleSettings):
        self.settings = s = convergence.resolve_iterations(scene, entry, settings, dt)  # iterations=None
        self.scene, self.name, self.dt = scene, entry.name, dt
        self.h = dt / s.substeps
        self.rules = cable_rules(entry.rules, scene, s, self.h)
        n_particles = scene.n_particles
        self._user = [(c, c.resolved(n_particles)) for c in getattr(s, "constraints", ())]
        a = self.arrays = chain_arrays(scene, self.rules, s, dt)
        add_pin_rows(a, scene)  # an inactive pin row per free gripper
        rings_.add_ring_rows(a, scene)  # then a pin row per ring's hub
        self._grasps = ParticleGrasps(scene, a)
        self._par = a.par[0]  # the parameter record (a view: reads and writes go to the state)
        self._limits = lim = monitor.limits(scene, entry)
        for name, value in dict(max_distance=MAX_DISTANCE, max_speed=MAX_SPEED, strain_fail=lim.strain_fail,
                                strain_warn=lim.strain_warn, tear=lim.tear, depth_check=True, check_where=-1,
                                warn_where=-1, warn_step=-1).items():
            self._par[name] = value
        self.mj_model = entry.build(scene, s, dt).compile()
        self.mj_data = mujoco.MjData(self.mj_model)
        m, d = self.mj_model, self.mj_data
        n = n_particles - 1
        bodies = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, proxy.segment_name(i)) for i in range(n)]
        if not np.array_equal(m.body_mocapid[bodies], np.arange(n)):  # pragma: no cover - proxy.build adds them first
            raise RuntimeError("proxy segments must be the first mocap bodies")
        # each segment's capsule (−1: a gap between two cables has none)
        segment_geoms = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, proxy.segment_name(i))
                                  for i in range(n)])
        sites = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, world.particle_site(i))
                          for i in range(n_particles)])
        if not np.array_equal(sites, np.arange(sites[0], sites[0] + n_particles)):  # pragma: no cover
            raise RuntimeError("proxy particle sites must be contiguous")
        self._site_pos = d.site_xpos[sites[0]:sites[0] + n_particles]
        grippers = scene.gripper_pins + tuple(range(len(scene.pins), len(scene.pins) + len(scene.grippers)))
        gripper_mocap = np.array([int(m.body_mocapid[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY,
                                                                       world.gripper_body(k))])
                                  for k in grippers], dtype=np.int64)  # (the free grippers' bodies follow the pins')
        self._gripper_mocap = gripper_mocap
        self._mocap_of_pin = dict(zip(grippers, gripper_mocap.tolist()))
        # pin (or free gripper) -> its gripper's mocap id (-1: none)
        self._pin_mocap = np.full(len(scene.pins) + len(scene.grippers), -1, dtype=np.int64)
        self._pin_mocap[list(grippers)] = gripper_mocap
        a.update(pose_pos=d.mocap_pos[:n], pose_quat=d.mocap_quat[:n])  # views: the proxy is posed in place
        world.reset_to_start(m, d)
        mujoco.mj_kinematics(m, d)  # the obstacles' poses, which ObstacleContacts reads
        ours = slice(0 if scene.world is None else scene.world.model.npair, m.npair)
        self._obstacles = o = (ObstacleContacts(scene, m, d, segment_geoms, ours) if m.npair > ours.start
                               else None)
        self._views = None
        if o is not None:
            a.update(o.arrays())
            self._connect_query()
        self._host = (host_world.Host(scene, m, d, o, frames=a.q.shape[0] > 0, rings=rings_.body_links(scene, m, a))
                      if scene.world is not None else None)
        if self._host is not None:
            a.update(self._host.fields)
            for name, value in self._host.params.items():
                self._par[name] = value
        # a query's contacts may be kept by later steps only with static obstacles and no user world
        self._par["keep_queries"] = o is not None and not o.moving and self._host is None
        a.update(winches.arrays(scene, a))  # (after the host's fields: a winch on a body follows its link)
        self._winches = {k: row for row, k in enumerate(winches.winch_pins(scene))}
        self.state = layout.assemble(a)
        self._start = {name: a[name].copy() for name in _RESET}  # reset() copies these back
        self.timing = {"solve": 0.0, "sync": 0.0}
        self.reset()

    def _connect_query(self) -> None:
        """The compiled query's parameters and views of the proxy's ``mjData`` (:mod:`mjcable.solvers.capi`), or
        Python's query (``QUERY_PYTHON``) where MuJoCo's C API is unavailable."""
        lay = capi.layout()
        par, o = self._par, self._obstacles
        if lay is None:
            par["query"] = layout.QUERY_PYTHON
            return
        views = self._views = capi.data_views(self.mj_data, lay)  # the views borrow mj_data's memory
        self.arrays.update(struct_i32=views.struct_i32, struct_i64=views.struct_i64, arena_f64=views.arena_f64,
                           arena_i32=views.arena_i32)
        for name, value in dict(query=layout.QUERY_COMPILED, fn_kinematics=lay.kinematics, fn_collision=lay.collision,
                                model=capi.model_address(self.mj_model), data=views.address, ncon_word=lay.ncon // 4,
                                contact_word=lay.contact // 8, arena=views.arena_address,
                                contact_size=lay.contact_size, off_dist=lay.dist, off_pos=lay.pos,
                                off_frame=lay.frame, off_geom=lay.geom, pair_start=o.pairs.start,
                                pair_stop=o.pairs.stop).items():
            par[name] = value

    def reset(self) -> None:
        """Copy the start state back (in place), the proxy back to its start pose; the first query and, in a user
        world, the first world step run once through the bindings (so that a MuJoCo error of the starting state is a
        ``mujoco.FatalError``, not the end of the process)."""
        a = self.arrays
        for name, start in self._start.items():
            np.copyto(a[name], start)
        m, d = self.mj_model, self.mj_data
        world.reset_to_start(m, d)
        mujoco.mj_kinematics(m, d)
        if self._host is not None:
            self._host.reset(a)
        if self._obstacles is not None:
            self._pose()
            self._obstacles.query(self.state, self.settings.contact_margin)
            if self._host is not None:
                self._obstacles.disable()
        self._par["time"] = d.time
        self.released = set()
        self._grasps.reset()
        self._sync()

    # -- the steps ------------------------------------------------------------------------------------------------

    def run(self, count: int, *, rows: np.ndarray, out_x: np.ndarray, out_v: np.ndarray,
            path: Optional[tuple] = None, until_release: bool = False) -> RunResult:
        """:meth:`mjcable.backends.protocol.Backend.run` in one compiled call (:func:`kernels.run_steps`), returning
        to Python only for a contact query the C API can't make, or, with PBD's user constraints, step by step."""
        path_pins, path_targets = _NO_PATH if path is None else path
        pins, targets = self._grasps.path(path_pins, path_targets)  # (free grippers: held ones shifted, open ones out)
        par = self._par
        t0 = time.perf_counter()
        if self._user:
            done, stored, failure, warning = self._run_user(count, rows, out_x, out_v, pins, targets, until_release)
        else:
            done = stored = 0
            failure = warning = None
            given = False
            while done < count:
                chunk = rows[stored:] - done if len(rows) > stored else rows[:0]
                k, outcome, released, recorded = kernels.run_steps(
                    self.state, count - done, given, chunk, out_x[stored:], out_v[stored:], targets[done:], pins,
                    until_release)
                done += k
                stored += recorded
                given = False
                if released:
                    self._note_released()
                if outcome == layout.RUN_QUERY:
                    self._python_query()
                    given = True
                elif outcome == layout.RUN_DIVERGED:
                    failure = self._breach()
                elif outcome == layout.RUN_WARNING:
                    failure = monitor.Breach("MuJoCo warning", math.nan, host_world.reason(par["warning"]))
                if warning is None and par["warn_check"] != layout.CHECK_OK:
                    warning = self._warning(done - k)
                if failure is not None or outcome == layout.RUN_RELEASED:
                    break
        t1 = time.perf_counter()
        if done and len(path_targets):  # the grippers' mocap bodies where the loop sent them
            self.mj_data.mocap_pos[self._pin_mocap[path_pins]] = path_targets[min(done, len(path_targets)) - 1]
        if self._host is None:  # a user world's mj_step keeps the time
            self.mj_data.time = par["time"]
        self._sync()
        self.timing["solve"] += t1 - t0
        self.timing["sync"] += time.perf_counter() - t1
        return RunResult(done, stored, failure, warning)

    def _breach(self) -> monitor.Breach:
        """The check that stopped the last step."""
        par = self._par
        return monitor.breach(int(par["check"]), float(par["check_value"]), int(par["check_where"]), self.scene,
                              self._limits)

    def _warning(self, before: int) -> monitor.Breach:
        """The first warning-level check of the last call (``before`` steps of this run preceded it), cleared."""
        par = self._par
        found = monitor.breach(int(par["warn_check"]), float(par["warn_value"]), int(par["warn_where"]), self.scene,
                               self._limits, step=before + int(par["warn_step"]))
        par["warn_check"], par["warn_step"] = layout.CHECK_OK, -1
        return found

    def _note_released(self) -> None:
        self.released.update(int(k) for k in np.flatnonzero(~self.arrays.pin_active[:len(self.scene.pins)]))

    def _python_query(self) -> None:
        """The next step's obstacle contacts through the bindings (:meth:`ObstacleContacts.query`), at the margin the
        compiled loop asked for."""
        self._pose()
        par = self._par
        par["n_con"] = self._obstacles.query(self.state, float(par["margin"]))
        par["queries"] += 1

    def _run_user(self, count, rows, out_x, out_v, pins, targets, until_release) -> tuple:
        """:func:`kernels.run_steps`' steps piece by piece (:func:`kernels.run_phase`), with PBD's user constraints
        projected in Python after the built-in ones in every iteration. Returns (steps, rows stored, failure, warning)."""
        S, a, s, par = self.state, self.arrays, self.settings, self._par
        n = s.substeps
        stored = 0
        warning = None
        host = self._host is not None
        for step in range(count):
            if step < len(targets):
                a.pin_to[pins] = targets[step]
            if not kernels.run_phase(S, kernels.STEP_BEGIN, 0, 1):
                self._python_query()
                kernels.run_phase(S, kernels.STEP_BEGIN, 1, 1)
            par["warning"] = -1
            released = 0
            for sub in range(n):
                if host:
                    kernels.run_phase(S, layout.PHASE_HOST_BEFORE, sub, n)
                k, m = (0, 1) if host else (sub, n)
                kernels.run_phase(S, layout.PHASE_BEGIN, k, m)
                for _ in range(s.iterations):
                    kernels.run_phase(S, layout.PHASE_ITERATE, k, m)
                    for constraint, idx in self._user:
                        constraint.project(a.x, a.w, idx, iteration_factor(constraint.factor, s.iterations))
                released += kernels.run_phase(S, layout.PHASE_END, k, m)
                if host and kernels.run_phase(S, layout.PHASE_HOST_AFTER, sub, n):
                    break
            passed = kernels.run_phase(S, kernels.STEP_END, 0, 1)
            if warning is None and par["warn_check"] != layout.CHECK_OK:
                par["warn_step"] = 1
                warning = self._warning(step)
            if stored < len(rows) and rows[stored] == step + 1:
                out_x[stored], out_v[stored] = a.x[:out_x.shape[1]], a.v[:out_v.shape[1]]
                stored += 1
            if released:
                self._note_released()
            if par["warning"] >= 0:
                return step + 1, stored, monitor.Breach("MuJoCo warning", math.nan,
                                                        host_world.reason(par["warning"])), warning
            if not passed:
                return step + 1, stored, self._breach(), warning
            if until_release and released:
                return step + 1, stored, None, warning
        return count, stored, None, warning

    def _pose(self) -> None:
        """Pose the proxy capsules from the particles and run MuJoCo's kinematics (what ``mj_collision`` needs)."""
        a = self.arrays
        query_kernels.proxy_poses(a.x[:self.scene.n_particles], a.pose_pos, a.pose_quat)
        mujoco.mj_kinematics(self.mj_model, self.mj_data)

    def _sync(self) -> None:
        """Pose the proxy capsules (and particle sites) from the particles: ``mj_data`` current for its readers."""
        self._pose()
        mujoco.mj_camlight(self.mj_model, self.mj_data)  # cameras and lights (a renderer reads cam_xpos)
        # the exact particles (the capsules keep their rest length, so their end sites are off by the strain)
        self._site_pos[:] = self.arrays.x[:self.scene.n_particles]

    # -- the Simulator's interface --------------------------------------------------------------------------------

    def positions(self) -> np.ndarray:
        return self.arrays.x[:self.scene.n_particles].copy()  # (the rings' hubs follow the cables' particles)

    def velocities(self) -> np.ndarray:
        return self.arrays.v[:self.scene.n_particles].copy()

    def particle_masses(self) -> np.ndarray:
        return self.arrays.mass[:self.scene.n_particles].copy()

    def energy(self) -> Energy:
        """½ Σ mᵢ|vᵢ|², −Σ mᵢ g·xᵢ and the constraint rows' potential (:mod:`mjcable.solvers.energy`: XPBD's
        ½ C²/α; PBD's and Jakobsen's factors as the compliance they act with; hard rows none)."""
        a = self.arrays
        par = self._par
        g = np.array([par["gx"], par["gy"], par["gz"]], dtype=np.float64)
        twist = 0.0
        if len(a.q):  # a rod with frames: its rows' potential (and its segments' rotational kinetic energy)
            stretch, bending, twist = rod_energy(a)
            spin = 0.5 * float(np.sum(a.inertia * a.omega * a.omega))
        else:
            (stretch, bending), spin = elastic_energy(a), 0.0
        return Energy(kinetic=0.5 * float(np.sum(a.mass * np.einsum("ij,ij->i", a.v, a.v))) + spin,
                      gravity=-float(np.sum(a.mass * (a.x @ g))), stretch=stretch, bending=bending, twist=twist)

    def gripper_positions(self) -> np.ndarray:
        return self.mj_data.mocap_pos[self._gripper_mocap].copy()

    def move_gripper(self, k: int, position: np.ndarray, orientation: Optional[np.ndarray] = None) -> None:
        """Move the gripper of ``scene.pins[k]`` to ``position`` (3,) m: its particle reaches it linearly over the
        next step's substeps; with ``orientation`` (4,) (w, x, y, z), a clamped gripper of a rod with frames turns
        the frame it holds to ``orientation ⊗ q_start`` (q_start the frame at the start, the gripper's start
        orientation the identity), slerped over the substeps."""
        a = self.arrays
        if orientation is not None:
            rows = np.flatnonzero(a.clamp_pin == k) if a.q.shape[0] else ()
            if not len(rows):
                raise ValueError(f"orientation: model {self.name!r} can't turn the gripper of pins[{k}]"
                                 + (" (not clamped: pass clamp=True to its Pin)" if a.q.shape[0] else
                                    " (its cable has no material frames; models with frames: cosserat, joints, "
                                    "composite)"))
            row = int(rows[0])
            start = self._start["q"][a.clamp_seg[row]]
            a.clamp_qto[row] = quat_mul(orientation, start)
            self.mj_data.mocap_quat[self._mocap_of_pin[k]] = orientation
        if k < len(self.scene.pins):
            a.pin_to[k] = position
        else:
            self._grasps.move(k - len(self.scene.pins), position)
        self.mj_data.mocap_pos[self._mocap_of_pin[k]] = position

    def frames(self) -> np.ndarray:
        """``(n_segments, 4)`` the segments' material frames (w, x, y, z), body to world: d₃ along the segment
        (several cables: ``(Σ nᵢ, 4)`` in cable order, without the gaps between them)."""
        if not self.arrays.q.shape[0]:
            raise ValueError(f"frames: model {self.name!r} has no material frames (its particles carry positions "
                             "only); models with frames: cosserat, joints, composite")
        return self.arrays.q[self.arrays.seg_cable >= 0]

    def add_point_mass(self, index: int, mass: float) -> None:
        """Add ``mass`` kg to particle ``index``'s lumped mass (in the start state too, so :meth:`reset` keeps it);
        a held particle stays held (its mass then enters its pin's force)."""
        for arrays in (self.arrays, self._start):
            m, w = arrays["mass"], arrays["w"]
            m[index] += mass
            if w[index] > 0.0:
                w[index] = 1.0 / m[index]

    def pin_forces(self) -> np.ndarray:
        """Each pin's force on its particle, averaged over the last step's substeps: F̄ = Σ_s F_s / n = J / dt,
        J the impulse the pin gave its particle in the step, F_s its force in substep s (XPBD's force estimate
        ∇Cᵀλ / h² over the constraints on the held particle, plus its weight; a host body pin's coupling force).
        Sockets let go on this same mean (:func:`mjcable.solvers.kernels._pin_forces`). Zero rows before the first
        step and for released sockets."""
        return self._pin_rows()[:len(self.scene.pins)]

    def _pin_rows(self) -> np.ndarray:
        """``(P + n_free, 3)`` N: the mean force of every pin row over the last step (zero for inactive rows)."""
        a = self.arrays
        count = a.pin_count[:, None]
        f = np.divide(a.pin_sum, count, out=np.zeros((len(count), 3)), where=count > 0)
        f[~a.pin_active] = 0.0
        return f

    def reel(self, k: int, speed: float) -> None:
        """Winch ``scene.pins[k]`` reels at ``speed`` m/s from the next substep on (positive pays out)."""
        self.arrays.winch_speed[self._winches[k]] = speed

    def free_length(self, k: int) -> float:
        """m: the free cable of winch ``scene.pins[k]`` (:func:`mjcable.solvers.winches.free_length`)."""
        return winches.free_length(self.arrays, self._winches[k])

    def grasp(self, g: int, index: int) -> None:
        winches.check_free(self.arrays, index)
        self._grasps.grasp(g, index, self.mj_data.mocap_pos[self._gripper_mocap[len(self.scene.gripper_pins) + g]])

    def release(self, g: int) -> None:
        self._grasps.release(g)

    def gripper_forces(self) -> np.ndarray:
        """``(n_free, 3)`` N: each free gripper's force on its particle, as :meth:`pin_forces` (0 while open)."""
        return self._grasps.forces(self._pin_rows())
    def ring_forces(self) -> np.ndarray:
        """``(R, 3)`` N each ring's force on its cable, averaged over the last step as :meth:`pin_forces` (its hub's
        pin row: :mod:`mjcable.backends.rings`); zero once it let go and before the first step."""
        f = self._pin_rows()[rings_.ring_rows(self.scene)]
        f[self.arrays.ring_mode == layout.RING_LET_GO] = 0.0
        return f

    def junction_forces(self) -> np.ndarray:
        """``(J, 3)`` N each junction's force on its particle b (equal and opposite on a), averaged over the last
        step's substeps as :meth:`pin_forces` (:mod:`mjcable.solvers.junction_kernels`); zero before the first
        step."""
        count = int(self._par["junction_count"])
        return self.arrays.junction_sum / count if count else np.zeros_like(self.arrays.junction_sum)

    def pin_torques(self) -> np.ndarray:
        """A clamp's torque about its particle p: (x_q − x_p) × f_q, f_q = Σₘ ∇_q Cₘ λₘ / h² the clamp's force on
        the neighbour q (:func:`mjcable.solvers.kernels.clamp_sweep`: ∇_q Cₘ = (2 / l₀²) dₘ); for a body clamp
        whose body turns, the negative of the torque its body received, −Σ ∇_θ C Δλ / h² (the same torque, taken
        where each correction was made while the clamp turned); for a rod with frames, the torque that holds its
        frame, −Σ R ∇_b Cᵀ λ / h² (:mod:`mjcable.solvers.cosserat_kernels`), axial torque included."""
        a = self.arrays
        out = np.zeros((len(self.scene.pins), 3))
        for kc, (p, q) in enumerate(a.clamp_pq):
            scale = 2.0 * float(a.cable_par[a.seg_cable[min(p, q)]]["inv_l0sq"])
            k = int(a.clamp_pin[kc])
            if not a.pin_active[k]:
                continue
            if a.q.shape[0] or np.trace(a.clamp_wq[kc]) > 0.0:
                out[k] = -a.clamp_react[kc] / self.h**2
            else:
                f = scale * (a.lam_c[kc] @ a.clamp_dir[kc]) / self.h**2
                out[k] = np.cross(a.x[q] - a.x[p], f)
        return out

    def diagnostics(self) -> dict:
        """``contacts`` and ``self_contacts`` found by the last step, ``queries`` (steps that ran MuJoCo's collision
        query since the last reset), ``direct_solves`` (the direct order's banded solves since the last reset: one
        per substep and iteration where each converges) and cumulative seconds in ``solve_s`` (the compiled steps,
        their queries included) and ``sync_s`` (posing the proxy for ``mj_data``'s readers)."""
        par = self._par
        return {"contacts": int(par["n_con"]), "self_contacts": int(par["n_self"]), "queries": int(par["queries"]),
                "direct_solves": int(par["direct_solves"]),
                **{f"{k}_s": v for k, v in self.timing.items()}}
