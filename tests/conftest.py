"""Shared fixtures and independent references for the tests."""

import os

# Offscreen rendering on EGL: MuJoCo reads MUJOCO_GL when it is first imported, and some test modules import mujoco
# before mjcable (which sets the same default).
os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pytest
from scipy import optimize


def catenary_at_arc(length: float, span: float, height: float, s: np.ndarray) -> np.ndarray:
    """Points of the inextensible catenary of ``length`` hung between (−span/2, 0, height) and (span/2, 0, height),
    at arc lengths ``s`` from the left end. Derived here, independent of mjcable: 2 a sinh(span / 2a) = length."""
    a = optimize.brentq(lambda a: 2 * a * np.sinh(span / (2 * a)) - length, 1e-3 * span, 1e3 * span, xtol=1e-15)
    x = a * np.arcsinh(s / a - np.sinh(span / (2 * a)))
    z = height + a * (np.cosh(x / a) - np.cosh(span / (2 * a)))
    return np.stack([x, np.zeros_like(x), z], axis=-1)


@pytest.fixture
def catenary():
    return catenary_at_arc


# The quick suite (the README's test command, under 5 minutes from a clean clone on 2 cores) runs the tests
# parametrized over models on a point chain and a rod (xpbd, cosserat; the native models have their own tests in it);
# their cases on the other models run with the slow tests (`-m slow`, which CI runs too). MJCABLE_QUICK_ALL_MODELS=1
# keeps every model's cases quick (CI's MuJoCo-4 job, which runs no slow tests).
SLOW_MODELS = frozenset({"springs", "joints", "composite", "flexrod", "jakobsen", "pbd"})


@pytest.hookimpl(tryfirst=True)  # before pytest's -m selection reads the marks
def pytest_collection_modifyitems(config, items):
    if os.environ.get("MJCABLE_QUICK_ALL_MODELS"):
        return
    for item in items:
        spec = getattr(item, "callspec", None)
        models = [v for v in spec.params.values() if isinstance(v, str)] if spec is not None else []
        models.append(getattr(getattr(item, "cls", None), "model", None))  # the conformance suites' classes
        if any(m in SLOW_MODELS for m in models) and item.get_closest_marker("slow") is None:
            item.add_marker(pytest.mark.slow)
