"""Test parameters over the models of the catalogue, with the markers that the CI jobs select on.

``composite`` needs MuJoCo's cable plugin (MuJoCo 3.x only): its parameters carry the ``composite`` marker, so that
``-m "not composite"`` selects them out; on MuJoCo 4 the catalogue does not hold it, so parametrisations over the
catalogue leave it out by themselves. Import as ``from catalog_params import model_params`` (pytest puts ``tests/``
on the path).
"""

import pytest

import mjcable

__all__ = ["model_params", "marked"]


def marked(model):
    """``model`` as a test parameter: ``pytest.param(model, marks=composite)`` for ``composite``, else the name."""
    return pytest.param(model, marks=pytest.mark.composite) if model == "composite" else model


def model_params(family=None, *, models=None) -> list:
    """The catalogue's models (all, or one ``family``), or the names ``models``, as test parameters (:func:`marked`)."""
    names = mjcable.catalog.names(family) if models is None else models
    return [marked(m) for m in names]
