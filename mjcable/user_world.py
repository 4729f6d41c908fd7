"""A user's own MuJoCo world around the cable: a robot, tables, objects, actuators, sensors, cameras, lights.

``Scene(cable, pins, obstacles, world=...)`` takes an MJCF path (``str`` or ``os.PathLike``) or a
``mujoco.MjSpec``; :class:`World` loads it once, keeps a private copy (a user's spec is copied, never mutated), and
compiles it once to check what the scene asks of it (body names, where a body pin's point is, the keyframe the
simulation starts from). Every model then builds into a fresh copy (:meth:`World.spec`):

* native models add their cable's bodies, joints, tendons or flex after the user's, so the user's joints,
  actuators and sensors keep their order and indices (``ctrl[0]`` still means what it meant);
* particle solvers add their proxy capsules (mocap bodies, no degrees of freedom) and step the user's world with
  ``mj_step`` in lock step with the solver.

Relative asset paths in an MJCF file resolve against the file's folder (MuJoCo's own rule for ``from_file``).
At the start, the cable must lie clear of every geom of the world it can collide with (:meth:`World.start_depth`,
measured by MuJoCo's own ``mj_geomDistance``), and a body pin's weight on the cable (:meth:`World.hanging_weight`)
enters the models' stability rules.

The world's ``<option gravity>`` is honoured by every model (:attr:`World.gravity`); the Simulator's ``dt``
overrides its timestep. The rest of ``<option>`` (integrator, cone, impratio, ...) is kept, except where a model
needs its own and says so in its module docstring (``joints`` and ``composite`` set the integrator, Jacobian and
medium viscosity they are tuned for).
"""

from __future__ import annotations

import dataclasses
import functools
import os
from typing import Iterable, Optional, Tuple, Union

import mujoco
import numpy as np

__all__ = ["World", "load", "Depth"]

# The collision bits every model gives the cable's geoms and the scene's obstacles (mjcable.mjcf.world uses them): a
# world's geom the cable can touch has OBSTACLE_CONTYPE in its contype or CABLE_CONTYPE in its conaffinity.
CABLE_CONTYPE = 2  # cable geoms collide with obstacles (conaffinity 1), not with each other unless asked
OBSTACLE_CONTYPE = 1

_RELATIVE_ROUND_OFF = 1e-9  # relative: a Jacobian column this small (of the largest entry, or 1) moves nothing

WorldLike = Union[str, "os.PathLike[str]", mujoco.MjSpec]


class World:
    """A loaded user world (build it with :func:`load`; ``Scene`` does).

    Attributes:
      source: the MJCF file's absolute path, or ``None`` for a spec given in memory.
      keyframe: name of the world's keyframe the simulation starts from (``None``: the world's default pose).
      gravity: ``(3,)`` m/s², the world's ``<option gravity>``.
      timestep: s, the world's own timestep (the Simulator's ``dt`` overrides it).
      model, data: the world compiled alone, posed at its start (``mj_forward`` done); read-only use.
    """

    def __init__(self, spec: mujoco.MjSpec, source: Optional[str], keyframe: Optional[str]):
        self._spec = spec
        self.source = source
        try:
            self.model = spec.copy().compile()
        except ValueError as error:
            raise ValueError(f"world: MuJoCo cannot compile {source or 'the given MjSpec'}: {error}") from None
        self.data = mujoco.MjData(self.model)
        self.keyframe = keyframe
        if keyframe is not None:
            if not isinstance(keyframe, str):
                raise ValueError(f"keyframe must be the name of one of the world's keyframes, got {keyframe!r}")
            key = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_KEY, keyframe)
            if key < 0:
                names = [self.model.key(i).name for i in range(self.model.nkey)]
                raise ValueError(f"keyframe {keyframe!r} is not in the world; its keyframes are {names}")
            mujoco.mj_resetDataKeyframe(self.model, self.data, key)
        mujoco.mj_forward(self.model, self.data)
        self.gravity = np.array(self.model.opt.gravity, dtype=np.float64)
        if not np.all(np.isfinite(self.gravity)):
            raise ValueError(f"world: <option gravity> must be 3 finite numbers in m/s², got {self.gravity.tolist()} "
                             f"in {source or 'the given MjSpec'}")
        self.timestep = float(self.model.opt.timestep)

    def __repr__(self) -> str:
        where = self.source or "MjSpec"
        return f"World({where!r}, nbody={self.model.nbody}, nq={self.model.nq}, nu={self.model.nu})"

    def spec(self) -> mujoco.MjSpec:
        """A fresh copy of the world's spec, for a model to build into."""
        return self._spec.copy()

    def body_id(self, name: str, *, what: str = "body") -> int:
        """The id of body ``name``; a ``ValueError`` naming ``what`` and listing a few bodies if it is absent."""
        if not isinstance(name, str) or not name:
            raise ValueError(f"{what} must be the name of a body of the world, got {name!r}")
        i = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, name)
        if i < 0:
            names = [self.model.body(b).name for b in range(1, self.model.nbody)]
            shown = ", ".join(repr(n) for n in names[:12]) + (" ..." if len(names) > 12 else "")
            raise ValueError(f"{what} {name!r} is not a body of the world; its bodies are {shown or 'none'}")
        return i

    def body_pose(self, name: str) -> tuple:
        """``(position (3,), rotation matrix (3, 3))`` of body ``name``'s frame at the world's start, in metres."""
        i = self.body_id(name)
        return self.data.xpos[i].copy(), self.data.xmat[i].reshape(3, 3).copy()

    def body_point(self, name: str, offset) -> np.ndarray:
        """World position (3,) m at the start of the point ``offset`` (3,) m fixed in body ``name``'s frame."""
        pos, rot = self.body_pose(name)
        return pos + rot @ np.asarray(offset, dtype=np.float64)

    def hanging_weight(self, name: str, offset) -> float:
        """The force in newtons that holds body ``name`` against gravity at the point ``offset`` (3,) m of its frame,
        where nothing else holds the degrees of freedom that move it: the least-squares F of Jᵀ F = c over those
        degrees of freedom (J the point's Jacobian, c MuJoCo's bias force at rest: gravity), at the world's start.
        Degrees of freedom that an actuator drives or a joint spring holds count as held (a servoed arm hangs
        nothing on its hand; a box on a free joint or on unactuated slides hangs its whole weight). Used for the
        tension a body pin puts on the cable (the models' stability rules)."""
        m = self.model
        body = self.body_id(name)
        if m.nv == 0:  # a world that nothing moves
            return 0.0
        d = mujoco.MjData(m)
        d.qpos[:], d.mocap_pos[:], d.mocap_quat[:] = self.data.qpos, self.data.mocap_pos, self.data.mocap_quat
        mujoco.mj_forward(m, d)  # qvel = 0: the bias force is gravity's alone
        jac = np.zeros((3, m.nv))
        mujoco.mj_jac(m, d, jac, None, self.body_point(name, offset), body)
        moving = np.abs(jac).max(axis=0) > _RELATIVE_ROUND_OFF * max(float(np.abs(jac).max()), 1.0)
        free = moving & ~self._held_dofs
        if not free.any():
            return 0.0
        force = np.linalg.lstsq(jac[:, free].T, d.qfrc_bias[free], rcond=None)[0]
        return float(np.linalg.norm(force))

    @functools.cached_property
    def _held_dofs(self) -> np.ndarray:
        """``(nv,)`` bool: degrees of freedom an actuator drives (through its joint) or a joint spring holds."""
        m = self.model
        held = np.zeros(m.nv, dtype=bool)
        for joint in range(m.njnt):
            if m.jnt_stiffness[joint] > 0.0:
                held[_dofs(m, joint)] = True
        for a in range(m.nu):
            if int(m.actuator_trntype[a]) in (mujoco.mjtTrn.mjTRN_JOINT.value, mujoco.mjtTrn.mjTRN_JOINTINPARENT.value):
                held[_dofs(m, int(m.actuator_trnid[a, 0]))] = True
        return held

    def start_depth(self, points, radius: float, ignore: Iterable[Tuple[str, Iterable[int]]] = (),
                    held: Iterable[int] = ()) -> Optional["Depth"]:
        """How deep the deepest of ``points`` (n, 3) m, each a sphere of ``radius`` m, starts inside a geom of the world
        that the cable can collide with (MuJoCo's filter: ``contype`` of one against ``conaffinity`` of the other,
        with the cable's bits :data:`CABLE_CONTYPE`, :data:`OBSTACLE_CONTYPE`), at the world's start pose; ``None`` if none
        reaches into one. MuJoCo measures each distance (``mj_geomDistance`` against a probe sphere), after a
        bounding-sphere cull.

        Args:
          ignore: ``(body name, point indices)`` pairs: those points never touch that body's geoms (the particles
            next to a body pin, which starts inside or on the body it is fastened to).
          held: indices of points that touch nothing (pinned particles: a plug held in its socket).
        """
        m, d, probe = self._probe
        points = np.asarray(points, dtype=np.float64)
        geoms = [g for g in range(m.ngeom) if g != probe and m.geom_bodyid[g] != m.geom_bodyid[probe]
                 and (m.geom_contype[g] & OBSTACLE_CONTYPE or CABLE_CONTYPE & m.geom_conaffinity[g])]
        held = set(int(i) for i in held)
        skip = {}
        for body, indices in ignore:
            skip.setdefault(self.body_id(body), set()).update(int(i) for i in indices)
        m.geom_size[probe, 0] = m.geom_rbound[probe] = radius
        deepest = None
        for g in geoms:
            near = np.linalg.norm(points - d.geom_xpos[g], axis=1) <= m.geom_rbound[g] + radius
            if m.geom_rbound[g] == 0.0:  # a plane: no bounding sphere
                near[:] = True
            for i in np.flatnonzero(near):
                if i in held or i in skip.get(int(m.geom_bodyid[g]), ()):
                    continue
                d.geom_xpos[probe] = points[i]
                try:
                    distance = mujoco.mj_geomDistance(m, d, probe, g, radius, None)
                except (mujoco.FatalError, ValueError):  # a geom type MuJoCo measures no distance to
                    break
                if distance < 0.0 and (deepest is None or -distance > deepest.depth):
                    deepest = Depth(depth=-distance, particle=int(i), geom=_name(m, mujoco.mjtObj.mjOBJ_GEOM, g),
                                    body=_name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.geom_bodyid[g])))
        return deepest

    @functools.cached_property
    def _probe(self) -> tuple:
        """``(model, data, geom)``: the world with one more geom, a sphere (contype and conaffinity 0) on a mocap
        body, posed at the world's start; :meth:`start_depth` moves it and sets its radius."""
        spec = self._spec.copy()
        body = spec.worldbody.add_body(mocap=True)
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[1.0, 0.0, 0.0], contype=0, conaffinity=0, margin=0.0,
                      gap=0.0)
        m = spec.compile()
        d = mujoco.MjData(m)
        d.qpos[:] = self.data.qpos
        d.mocap_pos[:-1], d.mocap_quat[:-1] = self.data.mocap_pos, self.data.mocap_quat
        mujoco.mj_kinematics(m, d)
        return m, d, m.ngeom - 1

    def start_state(self) -> dict:
        """The world's own start: ``qpos`` (nq,), ``qvel`` (nv,), ``act`` (na,), ``ctrl`` (nu,), ``mpos`` (nmocap, 3)
        and ``mquat`` (nmocap, 4), from :attr:`keyframe` or the default pose."""
        d = self.data
        return dict(qpos=d.qpos.copy(), qvel=d.qvel.copy(), act=d.act.copy(), ctrl=d.ctrl.copy(),
                    mpos=d.mocap_pos.copy(), mquat=d.mocap_quat.copy())


@dataclasses.dataclass(frozen=True)
class Depth:
    """Where a cable starts inside a world geom (:meth:`World.start_depth`): ``depth`` m (the cable's radius
    included), the ``particle``, and the ``geom`` and its ``body`` (names, or ``"#id"`` for unnamed ones)."""

    depth: float
    particle: int
    geom: str
    body: str


def _name(m: mujoco.MjModel, kind, i: int) -> str:
    return mujoco.mj_id2name(m, kind, i) or f"#{i}"


def _dofs(m: mujoco.MjModel, joint: int) -> slice:
    """The degrees of freedom of ``joint``."""
    width = {mujoco.mjtJoint.mjJNT_FREE.value: 6, mujoco.mjtJoint.mjJNT_BALL.value: 3}.get(int(m.jnt_type[joint]), 1)
    start = int(m.jnt_dofadr[joint])
    return slice(start, start + width)


def load(world: WorldLike, *, keyframe: Optional[str] = None) -> World:
    """Load ``world``: an MJCF path (``str`` or ``os.PathLike``) or a ``mujoco.MjSpec`` (copied, never mutated).

    Raises:
      ValueError: not a path or spec, a missing file, an unknown keyframe, or a world MuJoCo cannot compile.
    """
    if isinstance(world, World):
        if keyframe == world.keyframe:
            return world
        return World(world.spec(), world.source, keyframe)
    if isinstance(world, mujoco.MjSpec):
        return World(world.copy(), None, keyframe)
    if isinstance(world, (str, os.PathLike)):
        path = os.path.abspath(os.fspath(world))
        if not os.path.isfile(path):
            raise ValueError(f"world must be an existing MJCF file or an MjSpec, got {os.fspath(world)!r} "
                             f"(no such file: {path})")
        try:
            spec = mujoco.MjSpec.from_file(path)
        except ValueError as error:
            raise ValueError(f"world: MuJoCo cannot read {path}: {error}") from None
        return World(spec, path, keyframe)
    raise ValueError(f"world must be an MJCF path (str or os.PathLike) or a mujoco.MjSpec, got "
                     f"{type(world).__name__}")
