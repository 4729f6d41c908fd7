"""MuJoCo's warnings through Python's logging, so that no ``MUJOCO_LOG.TXT`` appears in the user's working folder.

Without a user warning handler MuJoCo prints each warning to stdout and appends it to ``MUJOCO_LOG.TXT`` in the
working folder (MuJoCo 3.17 and 4.0 alike); with one, it does neither. :func:`route_warnings` (run when mjcable is
imported) installs a handler that hands each message to the logger :data:`LOGGER` (``"mjcable"``, level
WARNING: on stderr unless the application configures logging), unless the process already has a handler of its
own (dm_control, once imported, puts its own in place, which logs through absl: MuJoCo's warnings stay in Python
either way). MuJoCo still counts every warning in ``mjData.warning``, which the Simulator reads to detect divergence.
"""

from __future__ import annotations

import logging

import mujoco

__all__ = ["LOGGER", "route_warnings"]

LOGGER = logging.getLogger("mjcable")  # the package's logger; messages start with "MuJoCo: "


def _to_logger(message: str) -> None:
    """MuJoCo's warning handler. It must not raise: an exception here becomes ``mju_error``, which ends the
    process where MuJoCo was called from compiled code (:mod:`mjcable.solvers.host_kernels`)."""
    try:
        LOGGER.warning("MuJoCo: %s", message)
    except Exception:  # noqa: BLE001 - see above; logging reports its own handlers' failures
        pass


def route_warnings() -> None:
    """Send MuJoCo's warnings to :data:`LOGGER` unless a handler is installed already (the user's, or ours)."""
    if mujoco.get_mju_user_warning() is None:
        mujoco.set_mju_user_warning(_to_logger)
