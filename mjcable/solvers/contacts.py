"""Contacts of the particle cable with the MuJoCo scene, through MuJoCo's own collision pipeline.

Once per step the proxy capsules (one per segment, posed from the particles) go through ``mj_collision`` with a
margin that covers the distance the cable can travel in one step; each contact becomes a constraint on the
segment's axis point at fraction s, measured against the obstacle's shape (type, size and pose, one row of
``Contacts.shapes`` per obstacle) in every substep and iteration, with Coulomb friction against anchors that
persist across steps (:mod:`mjcable.solvers.contact_kernels`). While the cable's bounding box touches no
obstacle's, the query is skipped.

MuJoCo's contact (read in :func:`mjcable.solvers.query_kernels.contacts_from_mujoco`): ``dist`` (negative in
penetration), ``pos`` (midway between the surfaces), ``frame[:3]`` (the normal from ``geom[0]`` to ``geom[1]``).
With n the normal pointing from the obstacle to the cable, the obstacle's surface point is q = pos − (dist/2) n and
the capsule's axis point pos + (dist/2 + radius) n.
"""

from __future__ import annotations

import mujoco
import numpy as np

from mjcable.scene import Scene
from mjcable.solvers import kernels, query_kernels

__all__ = ["ObstacleContacts"]


class ObstacleContacts:
    """Queries cable-obstacle contacts from the compiled proxy model.

    Args:
      scene: the scene.
      mj_model, mj_data: the compiled proxy (``mjcable.mjcf.proxy``) and its data, kinematics current.
      segment_geoms: ``(n_segments,)`` geom ids of the proxy capsules.
    """

    def __init__(self, scene: Scene, mj_model: mujoco.MjModel, mj_data: mujoco.MjData, segment_geoms: np.ndarray):
        self.mj_model, self.mj_data = mj_model, mj_data
        self.radius = scene.cable.radius
        self.obstacle_geoms = np.array([mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_GEOM, f"obstacle{k}")
                                        for k in range(len(scene.obstacles))], dtype=np.int64)
        self.segment_of_geom = np.full(mj_model.ngeom, -1, dtype=np.int64)
        self.segment_of_geom[segment_geoms] = np.arange(len(segment_geoms))
        self.shape_of_geom = np.full(mj_model.ngeom, -1, dtype=np.int64)
        self.shape_of_geom[self.obstacle_geoms] = np.arange(len(self.obstacle_geoms))
        #: (B, kernels.N_SH): each obstacle's MuJoCo type, size, world position and rotation (static)
        self.shapes = np.zeros((len(self.obstacle_geoms), kernels.N_SH))
        g = self.obstacle_geoms
        self.shapes[:, kernels.SH_TYPE] = mj_model.geom_type[g]
        self.shapes[:, kernels.SH_SIZE:kernels.SH_SIZE + 3] = mj_model.geom_size[g]
        self.shapes[:, kernels.SH_POS:kernels.SH_POS + 3] = mj_data.geom_xpos[g]
        self.shapes[:, kernels.SH_ROT:kernels.SH_ROT + 9] = mj_data.geom_xmat[g]
        self._margin = None
        # Static obstacles: world bounding boxes, planes as half-spaces (normal, point).
        planes = mj_model.geom_type[self.obstacle_geoms] == mujoco.mjtGeom.mjGEOM_PLANE
        self._plane_n = np.ascontiguousarray(mj_data.geom_xmat[self.obstacle_geoms[planes]].reshape(-1, 3, 3)[:, :, 2])
        self._plane_p = np.ascontiguousarray(mj_data.geom_xpos[self.obstacle_geoms[planes]])
        boxes = self.obstacle_geoms[~planes]
        rot = mj_data.geom_xmat[boxes].reshape(-1, 3, 3)
        aabb = mj_model.geom_aabb[boxes]
        center = mj_data.geom_xpos[boxes] + np.einsum("kij,kj->ki", rot, aabb[:, :3])
        half = np.einsum("kij,kj->ki", np.abs(rot), aabb[:, 3:])
        self._box_lo, self._box_hi = np.ascontiguousarray(center - half), np.ascontiguousarray(center + half)
        self._seg = np.zeros(0, dtype=np.int64)
        self._geo = np.zeros((0, 7))
        self._lam = np.zeros(0)

    @property
    def bounds(self) -> tuple:
        """The static obstacles as :meth:`touching` tests them: world boxes (lo, hi (B, 3)) and planes (unit normal,
        point (F, 3)), for a compiled step loop that must test exactly the same."""
        return self._box_lo, self._box_hi, self._plane_n, self._plane_p

    def touching(self, x: np.ndarray, reach: float) -> bool:
        """Whether the bounding box of particles ``x`` (n, 3), grown by ``reach`` metres, touches any obstacle's."""
        return kernels.touches_obstacles(x, reach, self._box_lo, self._box_hi, self._plane_n, self._plane_p)

    def query(self, x: np.ndarray, margin: float, out: kernels.Contacts) -> kernels.Contacts:
        """Contacts of the proxy capsules (posed from ``x`` (n + 1, 3) beforehand) closer than ``margin`` metres.

        Returns:
          ``out`` with its obstacle-contact arrays replaced by views of this query's buffers: segment (C,),
          [s, n, offset, μ, shape row] (C, 7), multipliers (C,), and the obstacles' shapes.
        """
        m, d = self.mj_model, self.mj_data
        if margin != self._margin:
            m.pair_margin[:] = margin
            self._margin = margin
        mujoco.mj_collision(m, d)
        ncon = d.ncon
        if ncon > len(self._seg):
            self._seg = np.zeros(2 * ncon, dtype=np.int64)
            self._geo = np.zeros((2 * ncon, 7))
            self._lam = np.zeros(2 * ncon)
        count = 0
        if ncon:
            con = d.contact
            count = query_kernels.contacts_from_mujoco(con.geom, con.dist, con.pos, con.frame, self.segment_of_geom,
                                                       self.shape_of_geom, m.geom_friction, x, self.radius, self._seg,
                                                       self._geo)
        return out._replace(seg=self._seg[:count], geo=self._geo[:count], lam=self._lam[:count], shapes=self.shapes)
