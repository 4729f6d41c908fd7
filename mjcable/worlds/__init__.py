"""User worlds: ready-made :class:`mujoco.MjSpec` scenes (robots, fixtures, cameras) that a cable can be pinned into.

* :mod:`mjcable.worlds.jaco`: the lab of the ``jaco_unplug`` task, a Kinova Jaco arm and hand on a bench facing a
  wall socket.
"""

from mjcable.worlds import jaco
from mjcable.worlds.jaco import grip_and_socket, home_qpos, jaco_lab_spec

__all__ = ["jaco", "jaco_lab_spec", "home_qpos", "grip_and_socket"]
