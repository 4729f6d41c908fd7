"""Argument checks, each raising ``ValueError`` that names the parameter, the bad value and the allowed range.

Every public boundary of mjcable (dataclass construction, ``Simulator``, render and bench options) validates with
these, once; kernels trust their inputs.

Example::

    dt = number("dt", dt, low=0.0, low_open=True)      # "dt must be a finite number in (0, inf), got -1"
    n = integer("n_segments", n, low=1, high=MAX_SEGMENTS)
"""

from __future__ import annotations

import math
import os
from typing import Any, Optional, Sequence, Tuple

import numpy as np

__all__ = ["number", "optional_number", "integer", "boolean", "choice", "vec3", "path_like", "set_field", "Vec3"]

Vec3 = Tuple[float, float, float]
_REAL = (int, float, np.integer, np.floating)
_INTEGRAL = (int, np.integer)


MAX_SUBSTEPS = 10_000  # substeps (and iterations) per step beyond which one step costs seconds to minutes

def _interval(low: float, high: float, low_open: bool, high_open: bool) -> str:
    return f"{'(' if low_open else '['}{low:g}, {high:g}{')' if high_open or high == math.inf else ']'}"


def number(name: str, value: Any, *, low: float = -math.inf, high: float = math.inf, low_open: bool = False,
           high_open: bool = False, unit: str = "") -> float:
    """``value`` as a float, checked finite and inside [low, high] (ends open as asked).

    Raises:
      ValueError: ``value`` is not a real number (bools are not), is not finite, or lies outside the interval.
    """
    ok = not isinstance(value, (bool, np.bool_)) and isinstance(value, _REAL)
    v = float(value) if ok else math.nan
    ok = ok and math.isfinite(v) and (v > low if low_open else v >= low) and (v < high if high_open else v <= high)
    if not ok:
        what = f" {unit}" if unit else ""
        raise ValueError(f"{name} must be a finite number in {_interval(low, high, low_open, high_open)}{what}, "
                         f"got {value!r}")
    return v


def optional_number(name: str, value: Any, **bounds) -> Optional[float]:
    """``None``, or :func:`number` of ``value``."""
    return None if value is None else number(name, value, **bounds)


def integer(name: str, value: Any, *, low: int = -(2**62), high: int = 2**62) -> int:
    """``value`` as an int, checked inside [low, high] (bools are not integers here)."""
    ok = not isinstance(value, (bool, np.bool_)) and isinstance(value, _INTEGRAL) and low <= value <= high
    if not ok:
        upper = "" if high >= 2**62 else f" and <= {high}"
        raise ValueError(f"{name} must be an integer >= {low}{upper}, got {value!r}")
    return int(value)


def boolean(name: str, value: Any) -> bool:
    """``value`` as a bool (Python or numpy bool only)."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be a bool, got {value!r}")
    return bool(value)


def choice(name: str, value: Any, allowed: Sequence) -> Any:
    """``value``, checked to be one of ``allowed``."""
    if isinstance(value, (list, dict, np.ndarray)) or value not in tuple(allowed):
        raise ValueError(f"{name} must be one of {tuple(allowed)}, got {value!r}")
    return value


def vec3(name: str, value: Any, *, unit: str = "") -> Tuple[float, float, float]:
    """``value`` as three finite floats."""
    try:
        v = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be 3 finite numbers{' in ' + unit if unit else ''}, got {value!r}") from exc
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be 3 finite numbers{' in ' + unit if unit else ''}, got {value!r}")
    return tuple(float(x) for x in v)


def path_like(name: str, value: Any) -> str:
    """``value`` (a ``str`` or ``os.PathLike``) as a ``str`` path."""
    if not isinstance(value, (str, os.PathLike)):
        raise ValueError(f"{name} must be a file path (str or os.PathLike), got {value!r}")
    return os.fspath(value)


def set_field(obj, name: str, value) -> None:
    """Write a validated ``value`` into field ``name`` of the frozen dataclass ``obj`` (in its ``__post_init__``)."""
    object.__setattr__(obj, name, value)
