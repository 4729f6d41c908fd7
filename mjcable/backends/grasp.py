"""Free grippers at run time (``Scene.grippers``): grasp a particle, follow the gripper, release it.

The grasped particle is held where it is when the gripper closes, at a fixed offset in the gripper's frame (zero when
the gripper was moved onto it first): closing never yanks the cable. Validation is the Simulator's
(:meth:`mjcable.Simulator.grasp`); these classes trust their arguments.

* :class:`ParticleGrasps` (``jakobsen``, ``pbd``, ``xpbd``, ``cosserat``): one pin row of the solver state per free
  gripper after the scene's pins (:func:`add_pin_rows`), inactive while the gripper is open. Grasping points the row
  at the particle (``pin_p``), sets its target to the particle's position (gripper + offset), activates it and gives
  the particle inverse mass 0; the compiled step then moves and measures it like a gripper pin. Releasing
  deactivates the row and gives the particle back 1 / m.
* :class:`NativeGrasps` (``springs``, ``joints``, ``composite``, ``flexrod``): one connect equality per free gripper
  (:mod:`mjcable.mjcf.grasp`), re-targeted at run time: its first site becomes the grasped particle's
  (``mjModel.eq_obj1id``), the gripper's site ``grasp{g}`` moves to the particle's offset (``mjModel.site_pos``),
  and ``mjData.eq_active`` switches it.
"""

from __future__ import annotations

import mujoco
import numpy as np

from mjcable.mjcf import cables, grasp as grasp_spec
from mjcable.scene import Scene

__all__ = ["ParticleGrasps", "NativeGrasps", "add_pin_rows", "PIN_ROW_FIELDS"]

#: the solver state's per-pin fields, with what an open free gripper's row holds (a ``(P, 3)`` field's rows zero)
PIN_ROW_FIELDS = {"pin_p": 0, "pin_from": 0.0, "pin_to": 0.0, "pin_active": False, "pin_release": np.inf,
                  "pin_force": 0.0, "pin_sum": 0.0, "pin_count": 0.0, "start_from": 0.0, "start_to": 0.0,
                  "target": 0.0}


def add_pin_rows(arrays, scene: Scene) -> None:
    """Append one inactive pin row per free gripper of ``scene`` to the state's arrays (in place, before the state
    is packed): row ``len(scene.pins) + g`` is free gripper ``g``'s. An inactive row moves nothing and feels nothing;
    the substep only zeroes its particle's reaction at the start of a substep, which it does for every held particle
    anyway."""
    count = len(scene.grippers)
    if not count:
        return
    for name, fill in PIN_ROW_FIELDS.items():
        old = arrays[name]
        arrays[name] = np.concatenate([old, np.full((count,) + old.shape[1:], fill, dtype=old.dtype)])


class ParticleGrasps:
    """The free grippers of a particle solver's state (see the module docstring).

    Args:
      scene: the scene.
      arrays: the state's arrays (:class:`mjcable.solvers.state.StateArrays`), with :func:`add_pin_rows`' rows.
    """

    def __init__(self, scene: Scene, arrays):
        self.first = len(scene.pins)  # the state's row of free gripper 0
        self.arrays = arrays
        self.offset = np.zeros((len(scene.grippers), 3))  # m: the held point from the gripper

    def reset(self) -> None:
        """Every gripper open (the state's rows come back with the state's reset)."""
        self.offset[:] = 0.0

    def grasp(self, g: int, index: int, gripper: np.ndarray) -> None:
        """Close free gripper ``g`` (at ``gripper`` (3,) m) on particle ``index``, held where it is."""
        a, row = self.arrays, self.first + g
        x = a.x[index]
        self.offset[g] = x - gripper
        a.pin_p[row] = index
        for name in ("pin_from", "pin_to", "start_from", "start_to", "target"):
            a[name][row] = x
        for name in ("pin_force", "pin_sum"):
            a[name][row] = 0.0
        a.pin_count[row] = 0.0
        a.react[index] = 0.0
        a.w[index] = 0.0
        a.pin_active[row] = True

    def release(self, g: int) -> None:
        """Open free gripper ``g``: its particle gets back its inverse mass 1 / m."""
        a, row = self.arrays, self.first + g
        index = a.pin_p[row]
        a.pin_active[row] = False
        a.w[index] = 1.0 / a.mass[index]
        a.react[index] = 0.0
        self.offset[g] = 0.0

    def move(self, g: int, position: np.ndarray) -> None:
        """Free gripper ``g`` to ``position`` (3,) m over the next step (its particle with it, if it holds one)."""
        row = self.first + g
        if self.arrays.pin_active[row]:
            self.arrays.pin_to[row] = position + self.offset[g]

    def path(self, pins: np.ndarray, targets: np.ndarray) -> tuple:
        """``(pins, targets)`` of a ``step_along`` path (``(G,)``, ``(steps, G, 3)`` m) as the compiled loop takes
        them: a holding free gripper's column shifted by its offset, an open one's left out (it moves no row)."""
        free = pins >= self.first
        if not free.any():
            return pins, targets
        rows = self.arrays.pin_active[pins]
        shift = np.zeros((len(pins), 3))
        shift[free] = self.offset[pins[free] - self.first]
        return np.ascontiguousarray(pins[rows]), np.ascontiguousarray((targets + shift)[:, rows])

    def forces(self, rows: np.ndarray) -> np.ndarray:
        """``(n_free, 3)`` N: the free grippers' rows of the pins' forces ``rows`` ``(P + n_free, 3)`` (inactive rows
        zero)."""
        return rows[self.first:self.first + len(self.offset)]


class NativeGrasps:
    """The free grippers of a native model (see the module docstring).

    Args:
      scene: the scene.
      mj_model: its compiled model (its equalities ``grasp{g}`` and sites are re-targeted in place).
      mj_data: its data.
      equality_force: ``eq -> (3,)`` N, the force a connect equality exerted on its first site in the last solve.
    """

    def __init__(self, scene: Scene, mj_model: mujoco.MjModel, mj_data: mujoco.MjData, equality_force):
        m = self.mj_model = mj_model
        self.mj_data = mj_data
        self._force = equality_force
        count = len(scene.grippers)
        self.eq = np.array([m.equality(grasp_spec.grasp_equality(g)).id for g in range(count)], dtype=np.int64)
        self.site = np.array([m.site(grasp_spec.grasp_site(g)).id for g in range(count)], dtype=np.int64)
        self.mocap = np.array([m.body_mocapid[m.body(grasp_spec.free_gripper_body(scene, g)).id]
                               for g in range(count)], dtype=np.int64)
        self.particle_site = np.array([m.site(cables.particle_name(scene, i)).id for i in range(scene.n_particles)],
                                      dtype=np.int64)
        m.site_sameframe[self.site] = 0  # the site moves off its body's origin when the gripper grasps

    def grasp(self, g: int, index: int) -> None:
        """Close free gripper ``g`` on particle ``index``, held where it is in the gripper's frame."""
        m, d = self.mj_model, self.mj_data
        site, eq, mocap = int(self.site[g]), int(self.eq[g]), int(self.mocap[g])
        rot = np.empty(9)
        mujoco.mju_quat2Mat(rot, d.mocap_quat[mocap])
        m.site_pos[site] = rot.reshape(3, 3).T @ (d.site_xpos[self.particle_site[index]] - d.mocap_pos[mocap])
        m.eq_obj1id[eq] = self.particle_site[index]
        d.eq_active[eq] = 1
        mujoco.mj_kinematics(m, d)  # the grasp site where it now is

    def release(self, g: int) -> None:
        self.mj_data.eq_active[int(self.eq[g])] = 0

    def forces(self) -> np.ndarray:
        """``(n_free, 3)`` N: each closed gripper's connect force on its particle in the last solve (0 while open)."""
        d = self.mj_data
        out = np.zeros((len(self.eq), 3))
        for g, eq in enumerate(self.eq.tolist()):
            if d.eq_active[eq]:
                out[g] = self._force(eq)
        return out
