"""dm_control environments for lab cable scenes, on any of mjcable's cable models.

Tasks (registered once in :data:`SUITE`, like the dm_control suite):

* ``reach_sag``: both ends held by grippers; move one so that the mid-span sag reaches a random target;
* ``drape``: lay the cable, held at its middle, over a peg so that both ends hang down on either side;
* ``unplug``: pull the plug end out of a socket (it lets go above a force) and carry it to a random target;
* ``untangle``: two cables crossed on a table; pull the one held by a gripper off the other and lay it in a target
  zone without dragging the other (models with ``several_cables`` only; :mod:`mjcable.envs.untangle`);
* ``hang``: pick a cable up from the middle of a table with a free gripper that grasps and lets go (a fourth action
  entry) and hang it on a hook, both halves down (:mod:`mjcable.envs.hang`);
* ``jaco_unplug``: a Kinova Jaco arm (joint position targets) holding one end pulls the plug out of a wall socket
  and carries it to a target (:mod:`mjcable.envs.jaco_unplug`; tag ``"arm"``, the others are ``"benchmarking"``).

Every environment is a ``dm_control.rl.control.Environment``: actions are gripper displacements per control step
(one ``BoundedArraySpec``; ``hang`` adds a grip command; grippers are clamped to a workspace where they can neither
overstretch the cable nor enter an obstacle), observations an ordered dict of float64 arrays (``centreline``, ``centreline_velocity`` of every cable
in cable order, ``grippers`` and the task's values), rewards in [0, 1] and a time limit. The same ``random`` seed gives the same episode.

Example::

    env = mjcable.envs.load("reach_sag", "xpbd", random=0)
    time_step = env.reset()
    spec = env.action_spec()
    while not time_step.last():
        time_step = env.step(np.random.uniform(spec.minimum, spec.maximum, spec.shape))
    frame = env.physics.render(240, 320, camera_id="overview")

Rendering is offscreen (``import mjcable`` sets ``MUJOCO_GL=egl`` unless it is set); :func:`record_episode` writes
an episode as MP4 through :func:`mjcable.render.render_env`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

from mjcable import _dm_control

_dm_control.check()  # a clear ImportError where dm_control is missing or does not run on the installed MuJoCo

import numpy as np  # noqa: E402
from dm_control.rl import control  # noqa: E402

from mjcable import render  # noqa: E402
from mjcable import catalog  # noqa: E402
from mjcable.envs import base, drape, hang, jaco_unplug, reach_sag, unplug, untangle  # noqa: E402, F401  (registers the tasks)
from mjcable.envs.batch import BatchEnv, load_batch  # noqa: E402
from mjcable.envs.base import (  # noqa: E402
    DEFAULT_CONTROL_TIMESTEP, FAMILY_DEFAULTS, MAX_GRIPPER_SPEED, SUITE, CablePhysics, CableTask, env_defaults)
from mjcable.envs.workspace import STRETCH_MARGIN, Workspace  # noqa: E402

__all__ = [
    "load",
    "load_batch",
    "BatchEnv",
    "names",
    "models",
    "record_episode",
    "SUITE",
    "ALL_TASKS",
    "CablePhysics",
    "CableTask",
    "Workspace",
    "DEFAULT_CONTROL_TIMESTEP",
    "MAX_GRIPPER_SPEED",
    "FAMILY_DEFAULTS",
    "env_defaults",
    "STRETCH_MARGIN",
    "POLICIES",
]

ALL_TASKS = tuple(SUITE)  # every registered task name
POLICIES = ("random", "zero")  # policies of record_episode


def names(*tags: str) -> tuple:
    """Names of the registered tasks, optionally only those carrying all ``tags`` (e.g. ``"benchmarking"``)."""
    return tuple(SUITE.tagged(*tags)) if tags else tuple(SUITE)


def models(task: str) -> tuple:
    """The catalogue's models (asked at call time) that can run ``task``: those with every catalogue capability the
    task requires (``untangle``: ``several_cables``; the others: every model).

    Raises:
      ValueError: unknown task.
    """
    if not isinstance(task, str) or task not in SUITE:
        raise ValueError(f"task must be one of {names()}, got {task!r}")
    return base.models_for(SUITE[task].requires)


def load(task: str, model: str = "flexrod", *, random=None, time_limit: Optional[float] = None,
         control_timestep: Optional[float] = None, **settings) -> control.Environment:
    """A cable task on one cable model.

    Args:
      task: one of :func:`names` (``"reach_sag"``, ``"drape"``, ``"unplug"``, ``"untangle"``, ``"hang"``,
        ``"jaco_unplug"``).
      model: a model of the catalogue (:func:`mjcable.catalog.names`).
      random: an int seed, a ``numpy.random.RandomState`` or ``None`` (fresh entropy), as in dm_control.
      time_limit: episode length in seconds (> 0); default the task's (10 s).
      control_timestep: seconds between actions (> 0, a whole number of ``dt``); default 0.02 s.
      **settings: keyword arguments of :class:`mjcable.Simulator`: ``dt`` (default 0.002 s) and the model's
        settings (``substeps``, solver iterations, ...); unset ones take :func:`env_defaults` (10 substeps for
        the particle family, see :mod:`mjcable.envs.base`), then the Simulator's defaults.

    Returns:
      A ``dm_control.rl.control.Environment`` whose ``physics`` is a :class:`CablePhysics`.

    Raises:
      ValueError: unknown task or model, a model the task can't run on (see :func:`models`), bad
        ``time_limit``/``control_timestep`` or Simulator settings.

    Example::

        env = mjcable.envs.load("unplug", "springs", random=3, time_limit=5.0)
    """
    if not isinstance(task, str) or task not in SUITE:
        raise ValueError(f"task must be one of {names()}, got {task!r}")
    catalog.check_model(model)
    if not (random is None or isinstance(random, np.random.RandomState)
            or (isinstance(random, (int, np.integer)) and not isinstance(random, (bool, np.bool_)) and random >= 0)):
        raise ValueError(f"random must be a seed (an integer >= 0), a numpy.random.RandomState or None, "
                         f"got {random!r}")
    return SUITE[task](model, random=random, time_limit=time_limit, control_timestep=control_timestep, **settings)


def record_episode(task: str, model: str, path, *, policy: str = "random", seconds: Optional[float] = None,
                   seed: Optional[int] = 0, width: int = 640, height: int = 480, camera: str = "overview",
                   fps: int = 30, **settings) -> Path:
    """Run one episode of ``task`` on ``model`` and write it as an MP4 video (atomically).

    Args:
      task: task name (see :func:`names`).
      model: cable model name.
      path: output ``.mp4`` path (its folder must exist).
      policy: ``"random"`` (uniform within the action spec) or ``"zero"`` (grippers hold still).
      seconds: how long to record in seconds (> 0); default the task's time limit. The episode's time limit is set
        to it, so the video ends with the episode.
      seed: seeds the task (its ``random``: targets, start) and the random policy; the same seed gives the same
        video.
      width, height: frame size in pixels (even, as H.264 needs).
      camera: camera name (every scene has ``"overview"``).
      fps: frames per second of the video (an integer); frames are taken on the control steps nearest to ``k / fps``.
      **settings: passed to :func:`load` (``control_timestep``, ``dt``, model settings).

    Returns:
      The path written.

    Example::

        mjcable.envs.record_episode("drape", "xpbd", "drape.mp4", seconds=4.0, seed=1)
    """
    if policy not in POLICIES:
        raise ValueError(f"policy must be one of {POLICIES}, got {policy!r}")
    env = load(task, model, random=seed, time_limit=seconds, **settings)
    length = env.task.default_time_limit if seconds is None else seconds
    return render.render_env(env, path, seconds=length, fps=fps, width=width,
                             height=height, camera=camera, policy=policy, seed=seed)
