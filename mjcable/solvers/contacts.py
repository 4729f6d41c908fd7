"""Contacts of the particle cable with the MuJoCo scene, through MuJoCo's own collision pipeline.

Once per step the proxy capsules (one per segment, posed from the particles) go through ``mj_collision`` with a
margin that covers the distance the cable can travel in one step (in the compiled step loop, through MuJoCo's C
API: :func:`mjcable.solvers.query_kernels.query_obstacles`; through the bindings where that is unavailable:
:meth:`ObstacleContacts.query`); each contact becomes a constraint on the
segment's axis point at fraction s, measured against the obstacle's shape (type, size and pose, one row of
the state's ``shape_*`` per obstacle) in every substep and iteration, with Coulomb friction against anchors that
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
from mjcable.solvers import kernels_layout as layout, query_kernels
from mjcable.solvers.state import shared_cable

__all__ = ["ObstacleContacts"]


class ObstacleContacts:
    """Queries cable-obstacle contacts from the compiled proxy model.

    Args:
      scene: the scene.
      mj_model, mj_data: the compiled proxy (``mjcable.mjcf.proxy``) and its data, kinematics current.
      segment_geoms: ``(n,)`` geom ids of the proxy capsules of the state's segments (−1: a gap between cables).
      pairs: the proxy's pairs (ids) of the cable with obstacles: all of them, but the user world's own pairs.

    Attributes:
      friction: ``(ngeom, 3)`` the model's geom friction with each obstacle's sliding μ replaced by a cable
        contact's: the obstacle's when its priority is higher than the cable's (the scene's own obstacles), else
        the larger of the cable's and the geom's (MuJoCo's rule for equal priorities).
    """

    def __init__(self, scene: Scene, mj_model: mujoco.MjModel, mj_data: mujoco.MjData, segment_geoms: np.ndarray,
                 pairs: slice = slice(None)):
        self.mj_model, self.mj_data = mj_model, mj_data
        self.pairs = pairs
        #: the geoms the cable is paired with: the scene's obstacles and, in a user world, its collidable geoms
        self.obstacle_geoms = np.unique(mj_model.pair_geom1[pairs]).astype(np.int64)
        self.segment_of_geom = np.full(mj_model.ngeom, -1, dtype=np.int64)
        real = segment_geoms >= 0  # (a gap between two cables has no capsule)
        self.segment_of_geom[segment_geoms[real]] = np.flatnonzero(real)
        self.shape_of_geom = np.full(mj_model.ngeom, -1, dtype=np.int64)
        self.shape_of_geom[self.obstacle_geoms] = np.arange(len(self.obstacle_geoms))
        g = self.obstacle_geoms
        # Coulomb's μ of a cable contact: MuJoCo's rule, the higher priority geom's μ (the scene's obstacles have
        # priority 1), the larger of the two for equal priorities
        ours = mj_model.geom_priority[g] > 0
        # (a user world's geoms take the cable's μ: one for all cables)
        mu_cable = shared_cable(scene, ("friction",)).friction if not np.all(ours) else 0.0
        self.friction = np.array(mj_model.geom_friction)
        self.friction[g, 0] = np.where(ours, mj_model.geom_friction[g, 0],
                                       np.maximum(mj_model.geom_friction[g, 0], mu_cable))
        body = mj_model.geom_bodyid[g]
        #: (M,) the geoms of obstacles on bodies that move (their shapes' poses are refreshed by every query)
        self.moving_geoms = g[(mj_model.body_weldid[body] != 0) | (mj_model.body_mocapid[body] >= 0)]
        #: (B,), (B, 3), (B, 3), (B, 3, 3), (B,): each obstacle's MuJoCo type, size (m), world position (m) and
        #: rotation, and whether it moves
        self.shape_type = mj_model.geom_type[g].astype(np.int64)
        self.shape_size = np.array(mj_model.geom_size[g], dtype=np.float64)
        self.shape_pos = np.zeros((len(g), 3))
        self.shape_rot = np.zeros((len(g), 3, 3))
        self.shape_moves = np.isin(g, self.moving_geoms)
        self._refresh_shapes(g)
        # Static obstacles: world bounding boxes, planes as half-spaces (normal, point); with a moving obstacle the
        # bounds cover all space (every step queries).
        planes = mj_model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE
        self._plane_n = np.ascontiguousarray(mj_data.geom_xmat[g[planes]].reshape(-1, 3, 3)[:, :, 2])
        self._plane_p = np.ascontiguousarray(mj_data.geom_xpos[g[planes]])
        boxes = g[~planes]
        rot = mj_data.geom_xmat[boxes].reshape(-1, 3, 3)
        aabb = mj_model.geom_aabb[boxes]
        center = mj_data.geom_xpos[boxes] + np.einsum("kij,kj->ki", rot, aabb[:, :3])
        half = np.einsum("kij,kj->ki", np.abs(rot), aabb[:, 3:])
        if len(self.moving_geoms):
            half[:] = np.inf
        self._box_lo, self._box_hi = np.ascontiguousarray(center - half), np.ascontiguousarray(center + half)

    @property
    def moving(self) -> bool:
        """Whether any obstacle moves (its shape is refreshed from ``mj_data`` by every query)."""
        return len(self.moving_geoms) > 0

    def arrays(self) -> dict:
        """The state's fields of the contact query (:data:`~mjcable.solvers.kernels_layout.FIELDS`): the obstacles'
        shapes, bounds and geom maps, the proxy's pair margins and the geoms' poses (views of the model and data)."""
        m, d = self.mj_model, self.mj_data
        g = self.moving_geoms
        moving = np.stack([g, self.shape_of_geom[g]], axis=1).astype(np.int64).reshape(-1, 2)
        return dict(shape_type=self.shape_type, shape_size=self.shape_size, shape_pos=self.shape_pos,
                    shape_rot=self.shape_rot, shape_moves=self.shape_moves, box_lo=self._box_lo, box_hi=self._box_hi,
                    plane_n=self._plane_n, plane_p=self._plane_p, pair_margin=m.pair_margin, segment_of_geom=self.segment_of_geom,
                    shape_of_geom=self.shape_of_geom, geom_friction=self.friction, moving=moving,
                    geom_xpos=d.geom_xpos, geom_xmat=d.geom_xmat)

    def disable(self) -> None:
        """Switch the cable's pairs off (an impossible margin) so that a host ``mj_step`` never sees the proxy; the
        next query switches them back on."""
        self.mj_model.pair_margin[self.pairs] = layout.PAIRS_OFF

    def _refresh_shapes(self, geoms: np.ndarray) -> None:
        d = self.mj_data
        rows = self.shape_of_geom[geoms]
        self.shape_pos[rows] = d.geom_xpos[geoms]
        self.shape_rot[rows] = d.geom_xmat[geoms].reshape(-1, 3, 3)

    def query(self, S, margin: float) -> int:
        """The query of :func:`~mjcable.solvers.query_kernels.query_obstacles` through the bindings
        (``mujoco.mj_collision``), with the proxy posed from the state's particles beforehand: the contacts closer
        than ``margin`` metres into the state ``S``'s buffers (grown to hold them). Returns their number."""
        m, d = self.mj_model, self.mj_data
        m.pair_margin[self.pairs] = margin
        query_kernels.refresh_moving(S)  # as the compiled query does
        mujoco.mj_collision(m, d)
        ncon = d.ncon
        query_kernels.reserve_contacts(S, ncon)
        if not ncon:
            return 0
        con = d.contact
        c = np.ascontiguousarray  # (one compiled version for every contact count)
        return query_kernels.contacts_from_mujoco(S, c(con.geom), c(con.dist), c(con.pos), c(con.frame))
