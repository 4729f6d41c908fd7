"""Backends behind :class:`mjcable.Simulator`: one :class:`~mjcable.backends.protocol.Backend` protocol,
implemented by :mod:`~mjcable.backends.native` (MuJoCo's own cable models) and :mod:`~mjcable.backends.particle`
(the numba particle solvers). Which backend a model uses is the catalogue's business (:mod:`mjcable.catalog`)."""

from mjcable.backends import native, particle
from mjcable.backends.protocol import Backend

__all__ = ["Backend", "native", "particle"]
