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
The world's ``<option gravity>`` is honoured by every model (:attr:`World.gravity`); the Simulator's ``dt``
overrides its timestep. The rest of ``<option>`` (integrator, cone, impratio, ...) is kept, except where a model
needs its own and says so in its module docstring (``joints`` and ``composite`` set the integrator, Jacobian and
medium viscosity they are tuned for).
"""

from __future__ import annotations

import os
from typing import Optional, Union

import mujoco
import numpy as np

__all__ = ["World", "load"]

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

    def start_state(self) -> dict:
        """The world's own start: ``qpos`` (nq,), ``qvel`` (nv,), ``act`` (na,), ``ctrl`` (nu,), ``mpos`` (nmocap, 3)
        and ``mquat`` (nmocap, 4), from :attr:`keyframe` or the default pose."""
        d = self.data
        return dict(qpos=d.qpos.copy(), qvel=d.qvel.copy(), act=d.act.copy(), ctrl=d.ctrl.copy(),
                    mpos=d.mocap_pos.copy(), mquat=d.mocap_quat.copy())


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
