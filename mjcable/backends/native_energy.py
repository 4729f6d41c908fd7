"""The cable's energy in a compiled native model (``springs``, ``joints``, ``composite``, ``flexrod``): the
:meth:`~mjcable.backends.native.NativeBackend.energy` behind :meth:`mjcable.Simulator.energy`.

MuJoCo computes a model's energy itself (``mjENBL_ENERGY``: ``mj_energyPos``, ``mj_energyVel``, ``mjData.energy``),
but of the whole world (every body's weight, every spring, a user world's robot included) and without two of the
cable's potentials: ``mj_energyPos`` sums gravity, joint springs, tendon springs and 1D flex edge springs, not flex
bending and not a plugin's passive forces. :class:`CableEnergy` therefore sums the same terms as MuJoCo, restricted to
the cable's own bodies, joints, tendons and flex (the bodies of the ``particle{i}`` sites and what hangs on them),
and adds the two MuJoCo leaves out:

* kinetic: ½ q̇ᵀ M q̇ over the cable's degrees of freedom (what ``mj_energyVel`` sums: each body's ½ m |v_c|² +
  ½ ωᵀ I ω, plus the joints' armature ½ a q̇²); the cable's bodies hang from the world or a mocap body, so its block
  of M is its own;
* gravity: −Σ m_b g·x_b over the cable's bodies (centres of mass ``xipos``), as ``mj_energyPos``;
* stretch and bending of ``springs``: the tendon springs ½ k (l − l_s)² (``tendon_lengthspring``, outside it
  zero), a tendon between neighbouring particles stretching, one between next neighbours bending;
* bending and twist of ``joints``: the ball-joint springs ½ k |r|², r = ``mju_subQuat(qpos, qpos_spring)``, the
  rotation vector that MuJoCo's passive torque −k r derives from; its component along the segment (the body's x
  axis) counts as twist, the rest as bending;
* bending and twist of ``composite``: the cable plugin's torques −(k / l) ω per joint with k = (G·J, E·I, E·I) and
  ω the rotation vector of the body in its parent (flat: a straight reference), so its potential is
  ½ Σ (G·J ω_x² + E·I (ω_y² + ω_z²)) / l (``mjcf.composite.plugin_moduli``; J = π r⁴/2, I = π r⁴/4 from the capsule
  radius, l the distance between body origins). The torques are exactly −∇ of it for pure bending or pure twist;
  with both at once they differ from it at third order in the joint's rotation;
* stretch of ``flexrod``: the edge springs ½ k (l − l₀)² (``flex_edgestiffness``, ``flexedge_length``); the
  inextensible cable's edge equality is a constraint and stores none;
* bending of ``flexrod``: the discrete elastic rod MuJoCo applies to a 1D flex, Σᵢ kᵢ |κbᵢ|² over interior vertices,
  κbᵢ = 2 e_{i−1} × eᵢ / (|e_{i−1}||eᵢ| + e_{i−1}·eᵢ), kᵢ = E π r⁴ / (4 (l₀_{i−1} + l₀ᵢ))
  (:mod:`mjcable.mjcf.flexrod`; its forces are −∇ of it to round-off).

Pins held by connect equalities, contacts and the drag store no potential. The tests check every term against
MuJoCo: the sum against ``mj_energyPos`` + ``mj_energyVel`` in a scene of the cable alone (up to the weight of the
bodies that never move), the plugin's and the flex bending's against MuJoCo's passive forces (−∇U).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from mjcable.backends.protocol import Energy
from mjcable.mjcf import cables, composite, joints
from mjcable.scene import Scene

__all__ = ["CableEnergy"]

_TWO_SITES = 2  # a tendon spring between two particle sites


class CableEnergy:
    """The cable's own bodies, degrees of freedom and elastic elements in a compiled native model, and their energy.

    Args:
      m: the compiled model.
      sites: ``(N,)`` site ids of the particles ``particle{i}`` (of every cable, in cable order).
      scene: the scene (the cable plugin's moduli and the flex's Young's modulus come from its cable, as the
        generators configure them).
    """

    def __init__(self, m: mujoco.MjModel, sites: np.ndarray, scene: Scene):
        clamps = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, cables.pin_name(scene, k, joints.clamp_body_name))
                  for k in range(len(scene.pins))]
        bodies = np.unique(np.concatenate([m.site_bodyid[sites], np.array(clamps, dtype=np.int64)]))  # and clamps
        self.bodies = bodies[bodies > 0]
        self.dofs = np.flatnonzero(np.isin(m.dof_bodyid, self.bodies))
        self._tendons(m, sites)
        self._balls(m)
        self._plugin(m, scene)
        self._flexes(m, scene, sites)

    def _tendons(self, m: mujoco.MjModel, sites: np.ndarray) -> None:
        """Spring tendons between two particle sites: ``(T,)`` ids, ``(T, 2)`` particles, ``(T,)`` stretch (True:
        neighbours)."""
        particle = {int(s): i for i, s in enumerate(sites)}
        rows = []
        for t in range(m.ntendon):
            adr, num = int(m.tendon_adr[t]), int(m.tendon_num[t])
            ends = [int(m.wrap_objid[adr + k]) for k in range(num)]
            if (num != _TWO_SITES or m.tendon_stiffness[t] == 0.0 or any(e not in particle for e in ends)
                    or np.any(m.wrap_type[adr:adr + num] != mujoco.mjtWrap.mjWRAP_SITE)):
                continue
            i, j = sorted(particle[e] for e in ends)
            rows.append((t, i, j))
        table = np.array(rows, dtype=np.int64).reshape(-1, 3)
        self.tendon_ends = table[:, 1:]
        self.tendon_stretch = table[:, 2] - table[:, 1] == 1
        self.tendon_k = m.tendon_stiffness[table[:, 0]].copy()
        self.tendon_lower, self.tendon_upper = m.tendon_lengthspring[table[:, 0]].T.copy()

    def _balls(self, m: mujoco.MjModel) -> None:
        """The cable's ball joints with a spring: qpos addresses and stiffness (N·m/rad)."""
        balls = [j for j in range(m.njnt) if m.jnt_bodyid[j] in self.bodies and m.jnt_stiffness[j] > 0.0
                 and m.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL]
        self.ball_qpos = m.jnt_qposadr[balls].astype(np.int64)
        self.ball_k = m.jnt_stiffness[balls].copy()
        self.ball_spring = np.array([m.qpos_spring[a:a + 4] for a in self.ball_qpos]).reshape(-1, 4)

    def _plugin(self, m: mujoco.MjModel, scene: Scene) -> None:
        """The cable plugin's joints (every plugin body after the first, as the plugin pairs them; each cable's
        instance): the body's ``body_quat``, its ball quaternion's qpos address, and the stiffness (G·J, E·I, E·I) / l
        in N·m/rad."""
        quat, qpos, k = [np.zeros((0, 4))], [np.zeros(0, dtype=np.int64)], [np.zeros((0, 3))]
        for c in range(len(scene.cables)):  # one plugin instance per cable
            name = cables.prefix(scene, c) + composite.INSTANCE
            instance = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_PLUGIN, name) if m.nplugin else -1
            chain = [b for b in self.bodies if instance >= 0 and m.body_plugin[b] == instance][1:]
            if not chain:
                continue
            bend, twist = composite.plugin_moduli(scene.cable_scene(c))
            radius = m.geom_size[m.body_geomadr[chain], 0]
            length = np.linalg.norm(m.body_pos[chain], axis=1)
            quat.append(m.body_quat[chain])
            qpos.append((m.jnt_qposadr[m.body_jntadr[chain]] + m.body_dofnum[chain] - 3).astype(np.int64))
            k.append((math.pi * radius**4 / 4.0 / length)[:, None] * np.array([2.0 * twist, bend, bend]))
        self.plugin_quat, self.plugin_qpos, self.plugin_k = (np.concatenate(a) for a in (quat, qpos, k))

    def _flexes(self, m: mujoco.MjModel, scene: Scene, sites: np.ndarray) -> None:
        """The cable's flexes (all vertex bodies the cable's; one per cable): their edge springs and, 1D with E > 0,
        bending."""
        self.flex_edges, self.flex_edge_k, self.flex_bend = [], [], []
        self.flex_rest = m.flexedge_length0.copy()
        particle = {int(b): i for i, b in enumerate(m.site_bodyid[sites])}  # a vertex body's particle
        for f in range(m.nflex):
            start, num = int(m.flex_vertadr[f]), int(m.flex_vertnum[f])
            if not np.all(np.isin(m.flex_vertbodyid[start:start + num], self.bodies)):
                continue
            first = particle[int(m.flex_vertbodyid[start])]
            cable = scene.cables[scene.cable_of(first)]
            edges = np.arange(m.flex_edgeadr[f], m.flex_edgeadr[f] + m.flex_edgenum[f])
            edges = edges[~m.flexedge_rigid[edges].astype(bool)]
            if m.flex_edgestiffness[f] > 0.0 and len(edges):
                self.flex_edges.append(edges)
                self.flex_edge_k.append(float(m.flex_edgestiffness[f]))
            if m.flex_dim[f] == 1 and cable.young > 0.0 and num > 2:
                chain = m.flex_edge[m.flex_edgeadr[f]:m.flex_edgeadr[f] + m.flex_edgenum[f]]
                if not np.array_equal(chain, np.column_stack([np.arange(num - 1), np.arange(1, num)])):
                    raise RuntimeError("a 1D cable flex must list its edges (i, i + 1)")  # pragma: no cover
                rest = m.flexedge_length0[m.flex_edgeadr[f]:m.flex_edgeadr[f] + m.flex_edgenum[f]]
                k = cable.young * math.pi * float(m.flex_radius[f]) ** 4 / 4.0 / (rest[:-1] + rest[1:])
                self.flex_bend.append((start, num, k))

    # -- the energy -----------------------------------------------------------------------------------------------

    def __call__(self, m: mujoco.MjModel, d: mujoco.MjData, positions: np.ndarray) -> Energy:
        """The energy of the state in ``d`` (kinematics and ``mj_flex`` current), ``positions`` the ``(n + 1, 3)``
        particles in metres."""
        mujoco.mj_comPos(m, d)
        mujoco.mj_comVel(m, d)
        b = self.bodies
        mass = m.body_mass[b]
        gravity = -float(np.sum(mass * (d.xipos[b] @ np.asarray(m.opt.gravity))))
        return Energy(kinetic=self._kinetic(m, d), gravity=gravity, **self._elastic(d, positions))

    def _kinetic(self, m: mujoco.MjModel, d: mujoco.MjData) -> float:
        b = self.bodies
        cvel = d.cvel[b]  # [ω, v] at the subtree com of each body's root
        omega = cvel[:, :3]
        v = cvel[:, 3:] + np.cross(omega, d.xipos[b] - d.subtree_com[m.body_rootid[b]])
        local = np.einsum("bji,bj->bi", d.ximat[b].reshape(-1, 3, 3), omega)  # ω in the body's inertia frame
        rotation = np.sum(m.body_inertia[b] * local * local)
        armature = np.sum(m.dof_armature[self.dofs] * d.qvel[self.dofs] ** 2)
        return 0.5 * (float(np.sum(m.body_mass[b] * np.einsum("ij,ij->i", v, v))) + float(rotation)
                      + float(armature))

    def _elastic(self, d: mujoco.MjData, positions: np.ndarray) -> dict:
        parts = dict(stretch=0.0, bending=0.0, twist=0.0)
        if len(self.tendon_k):  # a two-site tendon's length is the distance between its sites
            lo, hi = self.tendon_lower, self.tendon_upper
            length = np.linalg.norm(positions[self.tendon_ends[:, 1]] - positions[self.tendon_ends[:, 0]], axis=1)
            dev = np.where(length > hi, hi - length, np.where(length < lo, lo - length, 0.0))
            e = 0.5 * self.tendon_k * dev * dev
            parts["stretch"] += float(np.sum(e[self.tendon_stretch]))
            parts["bending"] += float(np.sum(e[~self.tendon_stretch]))
        if len(self.ball_qpos):
            q = d.qpos[self.ball_qpos[:, None] + np.arange(4)]
            spring = Rotation.from_quat(self.ball_spring, scalar_first=True)
            r = (spring.inv() * Rotation.from_quat(q, scalar_first=True)).as_rotvec()  # mju_subQuat(q, spring)
            parts["twist"] += float(0.5 * np.sum(self.ball_k * r[:, 0] ** 2))
            parts["bending"] += float(0.5 * np.sum(self.ball_k * (r[:, 1] ** 2 + r[:, 2] ** 2)))
        if len(self.plugin_qpos):
            q = d.qpos[self.plugin_qpos[:, None] + np.arange(4)]
            omega = (Rotation.from_quat(self.plugin_quat, scalar_first=True)
                     * Rotation.from_quat(q, scalar_first=True)).as_rotvec()
            e = 0.5 * self.plugin_k * omega * omega
            parts["twist"] += float(np.sum(e[:, 0]))
            parts["bending"] += float(np.sum(e[:, 1:]))
        for edges, k in zip(self.flex_edges, self.flex_edge_k):
            dev = d.flexedge_length[edges] - self.flex_rest[edges]
            parts["stretch"] += 0.5 * k * float(np.sum(dev * dev))
        for start, num, k in self.flex_bend:
            e = np.diff(d.flexvert_xpos[start:start + num], axis=0)
            a, b = e[:-1], e[1:]
            denom = np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1) + np.einsum("ij,ij->i", a, b)
            kb = 2.0 * np.cross(a, b) / denom[:, None]
            parts["bending"] += float(np.sum(k * np.einsum("ij,ij->i", kb, kb)))
        return parts
