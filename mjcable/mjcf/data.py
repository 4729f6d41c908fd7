"""``mjData`` for a model with MuJoCo's cable plugin: :func:`new_data`.

The plugin's ``init`` (``mujoco.elasticity.cable``, MuJoCo 3.x) runs inside ``mj_makeData`` before MuJoCo
initialises the new ``mjData``: it zeroes the mocap quaternions, copies ``qpos0`` and runs ``mj_kinematics`` to
measure each segment's length, its stiffness divisor. The mocap positions it reads are whatever the allocator's
memory held. Where a cable hangs from a mocap gripper (the chain is the gripper body's child), a NaN there makes
every elastic torque NaN from the first step (MuJoCo then resets the state, ``mjWARN_BADQACC``), and a huge finite
value rounds the segments' lengths, so the stiffness is silently off. Which one a process gets depends on what its
heap held before; in the test suite half the builds after a NaN-filled array failed
(``tests/test_composite_spec.py``).

:func:`new_data` has glibc fill the new ``mjData``'s memory with zeros while MuJoCo allocates it (``mallopt``'s
``M_PERTURB``, set for that call only), so the plugin measures the chain at the mocap bodies' zero positions: the
lengths are exact whatever the heap held. Elsewhere (no glibc) it is ``mujoco.MjData``.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import threading

import mujoco

__all__ = ["new_data"]

_M_PERTURB = -6  # glibc's mallopt parameter: fill allocated memory with the complement of its low byte
_ZERO_FILL = 0xFF  # allocated bytes become 0xFF ^ 0xFF = 0; freed bytes become 0xFF (a NaN pattern, as before)
_LOCK = threading.Lock()


def _mallopt():
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or None)
        mallopt = libc.mallopt
    except (OSError, AttributeError):  # pragma: no cover - not glibc
        return None
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    return mallopt


_MALLOPT = _mallopt()


def new_data(model: mujoco.MjModel) -> mujoco.MjData:
    """A new ``mujoco.MjData`` of ``model``, allocated zero-filled where the model has plugins (module docstring)."""
    if not model.nplugin or _MALLOPT is None:
        return mujoco.MjData(model)
    with _LOCK:
        _MALLOPT(_M_PERTURB, _ZERO_FILL)
        try:
            return mujoco.MjData(model)
        finally:
            _MALLOPT(_M_PERTURB, 0)
