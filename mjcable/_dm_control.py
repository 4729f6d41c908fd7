"""Whether dm_control runs on the installed MuJoCo: checked when :mod:`mjcable.envs` is imported (and by
``export.check_file``, which loads with dm_control where it runs).

dm-control 1.0.50 imports on MuJoCo 4 but fails on the first ``Physics`` it builds (its bindings ask ``MjModel`` for
fields MuJoCo 4 removed, ``flex_vertedge`` first). :func:`check` builds one empty ``Physics``, so it finds whatever a
dm_control release does not support rather than comparing version numbers; the combination that works is the one
the ``envs`` extra installs (``pip install "mjcable[envs]"``), read from the installed package's metadata, so that
widening the range is one line of ``pyproject.toml``.
"""

from __future__ import annotations

import functools
import importlib.metadata
from typing import Optional

__all__ = ["check", "problem"]

_PROBE_XML = "<mujoco/>"
_EXTRA = 'extra == "envs"'


def _envs_requirements() -> str:
    """The ``envs`` extra's requirements from mjcable's installed metadata, e.g.
    ``dm-control==1.0.50, mujoco<4,>=3.17``; a pointer to the extra where there is no metadata."""
    try:
        requires = importlib.metadata.requires("mjcable") or []
    except importlib.metadata.PackageNotFoundError:
        requires = []
    extra = [r.split(";")[0].strip() for r in requires if _EXTRA in r.replace("'", '"')]
    return ", ".join(extra) if extra else "the versions of the envs extra in mjcable's pyproject.toml"


def _installed(name: str) -> str:
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


def check() -> None:
    """Return quietly where dm_control is installed and builds a ``Physics`` on the installed MuJoCo.

    Raises:
      ImportError: dm_control is missing, or fails on the installed MuJoCo; the message names the installed
        versions, the ones that work and the command that installs them.
    """
    message = problem()
    if message is not None:
        raise ImportError(message)


@functools.cache
def problem() -> Optional[str]:
    """``None`` where dm_control is installed and builds a ``Physics`` on the installed MuJoCo; otherwise what is
    wrong, which versions work and what to install."""
    fix = (f'mjcable.envs needs dm_control on a MuJoCo it supports: {_envs_requirements()}. Install them with '
           f'python -m pip install "mjcable[envs]" (in a separate virtual environment if you want to keep MuJoCo '
           f'{_installed("mujoco")} for the rest of mjcable: everything but the environments runs on MuJoCo 3.17 to '
           f'4.x).')
    try:
        from dm_control import mujoco as dm_mujoco
    except ImportError as error:
        return f"dm_control cannot be imported ({error}). {fix}"
    try:
        dm_mujoco.Physics.from_xml_string(_PROBE_XML)
    except (AttributeError, TypeError) as error:
        return (f"dm-control {_installed('dm-control')} does not run on MuJoCo {_installed('mujoco')} "
                f"({type(error).__name__}: {error}). {fix}")
    return None
