"""Settings of MuJoCo's native cable models: frozen, keyword-only dataclasses validated on construction.

Each native model has its own class so that its defaults are documented where they live:
``Simulator(scene, "springs").settings`` is a :class:`SpringsSettings` with ``substeps=10``.
"""

from __future__ import annotations

import dataclasses

from mjcable import _validate

__all__ = ["NativeSettings", "SpringsSettings", "JointsSettings", "CompositeSettings", "FlexrodSettings"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class NativeSettings:
    """Settings shared by MuJoCo's native cable models.

    Args:
      substeps: MuJoCo steps per ``dt`` (>= 1); MuJoCo's timestep is ``dt / substeps``.
      self_collision: let non-adjacent cable segments collide.
    """

    substeps: int = 1
    self_collision: bool = False

    def __post_init__(self):
        _validate.integer("substeps", self.substeps, low=1, high=_validate.MAX_SUBSTEPS)
        _validate.boolean("self_collision", self.self_collision)


@dataclasses.dataclass(frozen=True, kw_only=True)
class SpringsSettings(NativeSettings):
    """``springs``: 10 MuJoCo steps per ``dt`` by default, because MuJoCo integrates spring forces explicitly (a
    nearly inextensible spring chain needs small steps; see :mod:`mjcable.mjcf.springs`)."""

    substeps: int = 10


@dataclasses.dataclass(frozen=True, kw_only=True)
class JointsSettings(NativeSettings):
    """``joints``: one MuJoCo step per ``dt`` (the ball-joint chain is stable at dt; see :mod:`mjcable.mjcf.joints`)."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class CompositeSettings(NativeSettings):
    """``composite``: one MuJoCo step per ``dt`` (see :mod:`mjcable.mjcf.composite`)."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class FlexrodSettings(NativeSettings):
    """``flexrod``: one MuJoCo step per ``dt``; a bending-stiff rod needs
    :func:`mjcable.mjcf.flexrod.stable_substeps` (its bending is explicit)."""
