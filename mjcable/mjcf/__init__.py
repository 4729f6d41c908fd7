"""MJCF generators (``mujoco.MjSpec``): one module per cable model, all from the same :class:`~mjcable.scene.Scene`.

* :mod:`~mjcable.mjcf.world`: the rigid world every model shares (options, obstacles, lights, camera, pin anchors);
* :mod:`~mjcable.mjcf.springs`, :mod:`~mjcable.mjcf.joints`, :mod:`~mjcable.mjcf.composite`,
  :mod:`~mjcable.mjcf.flexrod`: MuJoCo's native cable models;
* :mod:`~mjcable.mjcf.proxy`: the particle solvers' proxy (one capsule per segment, for contacts and rendering);
* :mod:`~mjcable.mjcf.grasp`: the free grippers (``Scene.grippers``) every model gets;
* :mod:`~mjcable.mjcf.rings`: the rings (``Scene.rings``) of the native models, tori of capsules;
* :mod:`~mjcable.mjcf.settings`: the native models' settings dataclasses;
* :mod:`~mjcable.mjcf.snap`: round-off snapping, so that a generated model is the same on every machine.

``mjcable.build(scene, model, *, dt=0.002, **settings)`` (in :mod:`mjcable.catalog`) picks the generator of a
model from the catalogue.
"""

from mjcable.mjcf import composite, flexrod, grasp, joints, proxy, rings, settings, snap, springs, world

__all__ = ["world", "springs", "joints", "composite", "flexrod", "proxy", "settings", "snap", "grasp", "rings"]
