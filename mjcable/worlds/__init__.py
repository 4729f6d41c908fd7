"""User worlds: ready-made :class:`mujoco.MjSpec` scenes (robots, fixtures, cameras) that a cable can be pinned into,
and parts to add to your own.

* :mod:`mjcable.worlds.jaco`: the lab of the ``jaco_unplug`` task, a Kinova Jaco arm and hand on a bench facing a
  wall socket.
* :mod:`mjcable.worlds.pulley`: :func:`~mjcable.worlds.pulley.add_pulley` adds a pulley (a cylinder on a
  frictionless hinge) to a spec.
"""

from mjcable.worlds import jaco, pulley
from mjcable.worlds.jaco import grip_and_socket, home_qpos, jaco_lab_spec
from mjcable.worlds.pulley import add_pulley

__all__ = ["jaco", "jaco_lab_spec", "home_qpos", "grip_and_socket", "pulley", "add_pulley"]
