"""Round-off snapping of generated specs, so that a generated model is the same on every machine.

The generators compute frames, positions and keyframes in floating point: a cable that is straight on paper gives
relative quaternions a few 1e-15 off the identity, and whether a component comes out as 0 or as 1e-17 depends on
the machine's floating-point library. Both compile to the same physics, but ``MjSpec.to_xml`` omits an attribute
at its default (``quat="1 0 0 0"``, ``pos="0 0 0"``), so the XML would differ between machines. :func:`snap_spec`
rounds such values to their exact form before a spec is compiled or saved:

* a unit quaternion within :data:`SNAP_TOLERANCE` of the identity, of either sign (the same rotation), becomes
  exactly (1, 0, 0, 0);
* any other number below :data:`SNAP_TOLERANCE` in magnitude (positions in metres, axes, quaternion components,
  keyframe entries) becomes exactly 0.

Every native generator and the particle proxy end with :func:`snap_spec`, so ``mjcable.build``, the ``Simulator``
and ``mjcable export`` all see the same snapped spec. The changes are below 1e-12 m or rad: physics results differ
only at round-off level.
"""

from __future__ import annotations

import mujoco
import numpy as np

__all__ = ["snap_spec", "snap_vector", "snap_quaternion", "SNAP_TOLERANCE"]

SNAP_TOLERANCE = 1e-12  # |x| below this (m, rad, unitless) is round-off of an exact 0; far above float64's ~1e-16
_IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])

# Vector attributes of each kind of spec element that the generators write (positions, orientations, axes, ...).
_VECTORS = {
    "bodies": ("pos", "ipos"),
    "frames": ("pos",),
    "geoms": ("pos", "fromto", "size"),
    "sites": ("pos", "fromto", "size"),
    "joints": ("pos", "axis"),
    "cameras": ("pos",),
    "lights": ("pos", "dir"),
    "keys": ("qpos", "qvel", "mpos"),
}
_QUATERNIONS = {"bodies": ("quat", "iquat"), "frames": ("quat",), "geoms": ("quat",), "sites": ("quat",),
                "cameras": ("quat",)}


def snap_vector(values) -> np.ndarray:
    """A copy of ``values`` (any shape) with every entry below :data:`SNAP_TOLERANCE` in magnitude set to exactly 0
    (NaNs, MuJoCo's "unset" marker, stay NaN)."""
    v = np.array(values, dtype=np.float64)
    v[np.abs(v) < SNAP_TOLERANCE] = 0.0
    return v


def snap_quaternion(quat) -> np.ndarray:
    """``(4,)`` quaternion (w, x, y, z): exactly (1, 0, 0, 0) within :data:`SNAP_TOLERANCE` of ±identity, else
    :func:`snap_vector` of it."""
    q = np.asarray(quat, dtype=np.float64)
    if min(np.abs(q - _IDENTITY).max(), np.abs(q + _IDENTITY).max()) < SNAP_TOLERANCE:
        return _IDENTITY.copy()
    return snap_vector(q)


def _snap_attribute(element, attribute: str, snap) -> None:
    old = np.asarray(getattr(element, attribute), dtype=np.float64)
    if old.size == 0:
        return
    new = snap(old)
    if not np.array_equal(new, old, equal_nan=True):  # write only what changes (unset NaNs stay unset)
        setattr(element, attribute, new)


def snap_spec(spec: mujoco.MjSpec) -> mujoco.MjSpec:
    """Snap round-off in ``spec`` in place (see the module docstring) and return it.

    Covers bodies, frames, geoms, sites, joints, cameras, lights, keyframes (``mquat`` per mocap body) and the
    statistic's centre.
    """
    for kind, attributes in _VECTORS.items():
        for element in getattr(spec, kind):
            for attribute in attributes:
                _snap_attribute(element, attribute, snap_vector)
    for kind, attributes in _QUATERNIONS.items():
        for element in getattr(spec, kind):
            for attribute in attributes:
                _snap_attribute(element, attribute, snap_quaternion)
    for key in spec.keys:
        _snap_attribute(key, "mquat", lambda q: np.concatenate([snap_quaternion(x) for x in q.reshape(-1, 4)]))
    spec.stat.center = snap_vector(spec.stat.center)
    return spec
