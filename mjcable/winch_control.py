"""The check of a winch's number for :meth:`mjcable.Simulator.reel` and :meth:`mjcable.Simulator.free_length`. A
winch is a ``Pin(index, "winch")`` (:class:`mjcable.scene.Pin`); how the particle solvers reel:
:mod:`mjcable.solvers.winch_kernels`. Models that can't reel one raise at the Simulator's construction
(:func:`mjcable.catalog.check_scene`)."""

from __future__ import annotations

from mjcable import _validate
from mjcable.scene import Scene

__all__ = ["winch_pin"]


def winch_pin(scene: Scene, k) -> int:
    """``k`` checked as the index of a winch pin of ``scene.pins``.

    Raises:
      ValueError: ``k`` is not an integer, or not a winch pin's index (naming the pin's kind where it is one)."""
    winches = tuple(j for j, pin in enumerate(scene.pins) if pin.kind == "winch")
    k = _validate.integer("k", k)
    if k not in winches:
        raise ValueError(f"k must be the index of a winch pin of scene.pins, one of {winches}, got {k}"
                         + (f" (a {scene.pins[k].kind!r} pin)" if 0 <= k < len(scene.pins) else ""))
    return k
