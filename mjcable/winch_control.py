"""The :class:`mjcable.Simulator`'s winch methods (:meth:`~WinchControl.reel`, :meth:`~WinchControl.free_length`),
mixed into it from here. A winch is a ``Pin(index, "winch")`` (:class:`mjcable.scene.Pin`); how the particle solvers
reel: :mod:`mjcable.solvers.winch_kernels`. Models that can't reel one raise at the Simulator's construction
(:func:`mjcable.catalog.check_scene`)."""

from __future__ import annotations

from mjcable import _validate

__all__ = ["WinchControl"]


class WinchControl:
    """Winch methods of :class:`mjcable.Simulator` (which provides ``scene`` and ``_backend``)."""

    def reel(self, k: int, speed: float) -> None:
        """Reel winch ``scene.pins[k]`` at ``speed`` m/s from the next step on, until changed: positive pays the
        cable out, negative reels it in, 0 stops. The free length (:meth:`free_length`) changes by ``speed`` per
        second, with the cable's mass per metre kept, until the spool is empty (paying out) or one segment is left
        free (reeling in); the winch's pull is its pin force (:attr:`pin_forces` ``[k]``).

        Raises:
          ValueError: ``k`` not a winch pin's index, or ``speed`` not a finite number.

        Example::

            scene = Scene(cable, pins=(Pin(50, "winch"), Pin(-1, "body", body="box")), world="crane.xml")
            sim = Simulator(scene, "xpbd")
            sim.reel(0, -0.1)   # lift the box at 0.1 m/s
            sim.step(3.0)
            sim.free_length(0)  # 0.3 m less than at the start
        """
        k = self._winch(k)
        self._backend.reel(k, _validate.number("speed", speed, unit="m/s"))

    def free_length(self, k: int) -> float:
        """m: the cable winch ``scene.pins[k]`` has paid out, from the winch point to the cable's free end along the
        cable's segments (their rest lengths).

        Raises:
          ValueError: ``k`` not a winch pin's index."""
        return self._backend.free_length(self._winch(k))

    def _winch(self, k) -> int:
        """``k`` checked as the index of a winch pin."""
        winches = tuple(j for j, pin in enumerate(self.scene.pins) if pin.kind == "winch")
        k = _validate.integer("k", k)
        if k not in winches:
            raise ValueError(f"k must be the index of a winch pin of scene.pins, one of {winches}, got {k}"
                             + (f" (a {self.scene.pins[k].kind!r} pin)" if 0 <= k < len(self.scene.pins) else ""))
        return k
