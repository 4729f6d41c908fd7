"""The particle backend behind :class:`mjcable.Simulator` for ``jakobsen``, ``pbd`` and ``xpbd``.

One :meth:`ParticleBackend.step` advances exactly one ``dt``: query contacts (once, with a margin), run
``substeps`` substeps of ``iterations`` iterations in one numba call, then pose the proxy capsules from the
particles so that ``mj_data`` renders the cable.
"""

from __future__ import annotations

import math
import time
from typing import Optional

import mujoco
import numpy as np

from mjcable.build import proxy, world
from mjcable.scene import GRAVITY, Scene
from mjcable.solvers import jakobsen, kernels, pbd, query_kernels, xpbd
from mjcable.solvers.contacts import ObstacleContacts
from mjcable.solvers.settings import solver_settings
from mjcable.solvers.state import empty_contacts, new_chain

__all__ = ["ParticleBackend", "RULES"]

RULES = {"jakobsen": jakobsen.rules, "pbd": pbd.rules, "xpbd": xpbd.rules}
_SELF_CONTACT_CAPACITY = 8  # initial self-contact buffer per segment (grown on demand)


class ParticleBackend:
    """A particle solver stepping a scene, with MuJoCo's proxy for contacts and rendering.

    Args:
      scene: the scene.
      model: ``"jakobsen"``, ``"pbd"`` or ``"xpbd"``.
      dt: step in seconds (> 0, validated by the Simulator).
      settings: the model's settings (:class:`~mjcable.solvers.settings.SolverSettings`).

    Attributes:
      mj_model, mj_data: the compiled proxy; its capsules follow the cable after every step.
      state: the solver arrays (:class:`~mjcable.solvers.kernels.Chain`).
      released: pin numbers (indices into ``scene.pins``) of sockets that have let go.
      last_contact_count: obstacle contacts found by the last step's query (0 when skipped).
      last_self_contact_count: self contacts found by the last step.
      queries: number of steps that ran MuJoCo's collision query.
      timing: cumulative seconds spent in ``"query"`` (contacts), ``"solve"`` (the substeps) and ``"sync"``
        (posing the proxy).
    """

    def __init__(self, scene: Scene, model: str, dt: float, settings: dict):
        self.settings = solver_settings(model, **settings)
        self.scene, self.model, self.dt = scene, model, dt
        s = self.settings
        self.h = dt / s.substeps
        self.rules = RULES[model](scene, s, self.h)
        n_particles = scene.cable.n_particles
        self._user = [(c, c.resolved(n_particles)) for c in s.constraints]
        self.state = new_chain(scene, self.rules, s, dt)
        self.mj_model = proxy.build(scene, dt=dt, **settings).compile()
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
        self._gripper_mocap = {k: int(m.body_mocapid[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY,
                                                                       world.gripper_body(k))])
                               for k in scene.grippers}
        # views into mj_data, taken once (MjData's buffers do not move): the proxy's poses are written in place
        self._pose_pos = self.mj_data.mocap_pos[:n]
        self._pose_quat = self.mj_data.mocap_quat[:n]
        first = int(self._sites[0])
        contiguous = np.array_equal(self._sites, np.arange(first, first + n_particles))
        self._site_pos = self.mj_data.site_xpos[first:first + n_particles] if contiguous else None
        mujoco.mj_kinematics(m, self.mj_data)
        self._obstacles = ObstacleContacts(scene, m, self.mj_data, self._segment_geoms) if scene.obstacles else None
        self.contacts = empty_contacts()
        self._self_pair = np.zeros((_SELF_CONTACT_CAPACITY * n, 2), dtype=np.int64)
        self._self_geo = np.zeros((_SELF_CONTACT_CAPACITY * n, 5))
        self.released = set()
        self.last_contact_count = 0
        self.last_self_contact_count = 0
        self.queries = 0
        self.timing = {"query": 0.0, "solve": 0.0, "sync": 0.0}
        self._sync()

    # -- the step -------------------------------------------------------------------------------------------------

    def step(self) -> Optional[str]:
        """Advance one ``dt``. Returns a reason string if the state became non-finite, else ``None``."""
        t0 = time.perf_counter()
        self._find_contacts()
        t1 = time.perf_counter()
        if self._user:
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
        self.mj_data.time += self.dt
        self.timing["query"] += t1 - t0
        self.timing["solve"] += t2 - t1
        self.timing["sync"] += time.perf_counter() - t2
        if not finite:
            return "non-finite particle state (NaN or inf) in the particle solver"
        return None

    def _find_contacts(self) -> None:
        S, s = self.state, self.settings
        contacts = self.contacts
        speed = math.sqrt(float(np.max(np.einsum("ij,ij->i", S.v, S.v))))
        # the distance a particle can travel in one step, plus the configured margin
        margin = s.contact_margin + speed * self.dt + 0.5 * float(np.linalg.norm(GRAVITY)) * self.dt**2
        if not math.isfinite(margin):  # a diverged state: leave it to the divergence check
            margin = s.contact_margin
        self.last_contact_count = 0
        if self._obstacles is not None:
            if self._obstacles.touching(S.x, margin + self.scene.cable.radius):
                contacts = self._obstacles.query(S.x, margin, contacts)
                self.queries += 1
            else:
                contacts = contacts._replace(seg=contacts.seg[:0], geo=contacts.geo[:0], lam=contacts.lam[:0])
            self.last_contact_count = len(contacts.seg)
        if s.self_collision:
            reach = 2.0 * self.scene.cable.radius + margin
            count = query_kernels.find_self_contacts(S.x, reach, self._self_pair, self._self_geo)
            while count < 0:
                cap = 2 * self._self_pair.shape[0]
                self._self_pair = np.zeros((cap, 2), dtype=np.int64)
                self._self_geo = np.zeros((cap, 5))
                count = query_kernels.find_self_contacts(S.x, reach, self._self_pair, self._self_geo)
            contacts = contacts._replace(pair=self._self_pair[:count], sgeo=self._self_geo[:count],
                                         slam=np.zeros(count))
            self.last_self_contact_count = count
        self.contacts = contacts

    def _substeps_with_user_constraints(self) -> tuple:
        """The same substeps as :func:`kernels.run_substeps`, with PBD user constraints projected in Python after
        the built-in ones in every iteration."""
        S, C, s = self.state, self.contacts, self.settings
        n = s.substeps
        released = 0
        finite = True
        for sub in range(n):
            kernels.run_substeps_flat(*S, *C, n, kernels.PHASE_BEGIN, sub)
            for _ in range(s.iterations):
                kernels.run_substeps_flat(*S, *C, n, kernels.PHASE_ITERATE, sub)
                for constraint, idx in self._user:
                    constraint.project(S.x, S.w, idx, pbd.iteration_stiffness(constraint.stiffness, s.iterations))
            finite, count = kernels.run_substeps_flat(*S, *C, n, kernels.PHASE_END, sub)
            released += count
        return finite, released

    def _sync(self) -> None:
        """Pose the proxy capsules (and particle sites) from the particles."""
        x = self.state.x
        query_kernels.proxy_poses(x, self._pose_pos, self._pose_quat)
        mujoco.mj_kinematics(self.mj_model, self.mj_data)
        mujoco.mj_camlight(self.mj_model, self.mj_data)  # cameras and lights (a renderer reads cam_xpos)
        # the exact particles (the capsules keep their rest length, so their end sites are off by the strain)
        if self._site_pos is not None:
            self._site_pos[:] = x
        else:  # pragma: no cover - proxy.build keeps the particle sites contiguous
            self.mj_data.site_xpos[self._sites] = x

    # -- the Simulator's interface --------------------------------------------------------------------------------

    def positions(self) -> np.ndarray:
        """``(n_segments + 1, 3)`` particle positions in metres (a copy)."""
        return self.state.x.copy()

    def move_gripper(self, k: int, position: np.ndarray) -> None:
        """Move the gripper of ``scene.pins[k]`` to ``position`` (3,) m: its particle reaches it linearly over the
        next step's substeps."""
        self.state.pin_to[k] = position
        self.mj_data.mocap_pos[self._gripper_mocap[k]] = position

    @property
    def time(self) -> float:
        return float(self.mj_data.time)

    def set_particle_mass(self, i: int, mass: float) -> None:
        """Give particle ``i`` the lumped ``mass`` in kg (> 0), e.g. to hang a load on the cable's end; a held
        particle stays held (its mass then only enters its pin's force)."""
        if isinstance(mass, bool) or not isinstance(mass, (int, float)) or not 0.0 < mass < math.inf:
            raise ValueError(f"mass must be a finite number > 0 (kg), got {mass!r}")
        n = self.scene.cable.n_particles
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not -n <= i < n:
            raise ValueError(f"i must be a particle index in [{-n}, {n - 1}], got {i!r}")
        S = self.state
        S.mass[i] = mass
        if S.w[i] > 0.0:
            S.w[i] = 1.0 / mass

    # -- diagnostics ----------------------------------------------------------------------------------------------

    def pin_forces(self) -> np.ndarray:
        """``(n_pins, 3)`` force in newtons each pin exerted on its particle in the last substep (XPBD's λ / h²
        summed over the constraints on the held particle, plus its weight); zero rows for released sockets."""
        f = self.state.pin_force.copy()
        f[~self.state.pin_active] = 0.0
        return f
