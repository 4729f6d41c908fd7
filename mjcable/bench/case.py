"""What one benchmark run is: a :class:`Case`, and the model labels of the CSV's ``model`` column.

Every model of the catalogue (:func:`mjcable.catalog.names`) is a label of its own, at its defaults; a model
registered at run time is a label at once. :data:`VARIANTS` adds the few labels that run a model with fixed
settings for a comparison (``xpbd-gs``: XPBD in the Gauss-Seidel order, against the direct order that ``xpbd``
takes by default). :data:`MODEL_LABELS` is a live, read-only view ``{label: (model, settings)}`` of both.

Example::

    from mjcable.bench.case import Case, MODEL_LABELS
    MODEL_LABELS["xpbd-gs"]            # ('xpbd', {'order': 'gauss-seidel'})
    Case("catenary", "xpbd-gs", 0.002, settings=(("substeps", 8),))
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping
from typing import Iterator, Optional, Sequence

from mjcable import catalog

__all__ = [
    "Case",
    "VARIANTS",
    "MODEL_LABELS",
    "labels",
    "resolve",
    "family",
    "settings_of",
    "model_labels",
    "rank",
]

# label → (catalogue model, fixed settings): the labels besides the catalogue's own names. A variant whose model is
# not registered is left out; a registered model of the same name takes the label.
VARIANTS = {
    "xpbd-gs": ("xpbd", (("order", "gauss-seidel"),)),
}


def labels() -> dict:
    """Every model label, ``{label: (model, settings dict)}``, in catalogue order with each model's variants
    right after it."""
    names = catalog.names()
    out = {}
    for name in names:
        out[name] = (name, {})
        for label, (model, fixed) in VARIANTS.items():
            if model == name and label not in names:
                out[label] = (model, dict(fixed))
    return out


class _Labels(Mapping):
    """The live view behind :data:`MODEL_LABELS` (each lookup asks the catalogue)."""

    def __getitem__(self, label: str) -> tuple:
        return labels()[label]

    def __iter__(self) -> Iterator[str]:
        return iter(labels())

    def __len__(self) -> int:
        return len(labels())

    def __repr__(self) -> str:
        return f"MODEL_LABELS({labels()!r})"


MODEL_LABELS: Mapping = _Labels()


def resolve(label: str) -> tuple:
    """``(model, settings dict)`` of ``label``.

    Raises:
      ValueError: ``label`` is not a model label.
    """
    table = labels()
    if not isinstance(label, str) or label not in table:
        raise ValueError(f"model must be one of {tuple(table)}, got {label!r}")
    model, fixed = table[label]
    return model, dict(fixed)


def family(label: str) -> str:
    """The catalogue family (``"native"`` or ``"particle"``) of the model behind ``label``."""
    return catalog.get(resolve(label)[0]).family


def settings_of(label: str, **settings):
    """The validated settings dataclass that ``label`` runs with ``settings`` on top of its fixed ones.

    Raises:
      ValueError: an unknown label, a setting the model does not take, or a value outside its range.
    """
    model, fixed = resolve(label)
    return catalog.make_settings(model, **{**fixed, **settings})


def model_labels(models: Optional[Sequence[str]]) -> tuple:
    """``models`` checked to be model labels (``None`` or empty: all of them, in :func:`labels` order)."""
    table = labels()
    chosen = tuple(models or table)
    for m in chosen:
        if m not in table:
            raise ValueError(f"models must be among {tuple(table)}, got {m!r}")
    return chosen


def rank(label: str) -> int:
    """``label``'s position in :func:`labels` (the order of tables and plots); unknown labels after all."""
    order = list(labels())
    return order.index(label) if label in order else len(order)


@dataclasses.dataclass(frozen=True)
class Case:
    """One run.

    Attributes:
      scenario: a name from :data:`~mjcable.bench.scenarios.SCENARIOS`, ``STRESS_SCENARIOS`` or
        ``EXTRA_SCENARIOS``.
      model: a label from :data:`MODEL_LABELS`.
      dt: step in seconds.
      n_segments: cable segments.
      settings: ``(name, value)`` pairs passed to :class:`mjcable.Simulator` on top of the label's fixed settings
        (substeps, iterations, ...); empty: the model's defaults.
      params: ``(name, value)`` pairs of scenario parameters (``stiffness``, ``speed``, ``load``, ``variant``;
        ``duration`` overrides the scenario's simulated seconds; ``save_positions`` keeps the final positions).
      quick: use the scenario's ``quick_duration``.
      time_cap: wall-clock seconds after which the run is stopped and counted as ``diverged``.
    """

    scenario: str
    model: str
    dt: float
    n_segments: int = 50
    settings: tuple = ()
    params: tuple = ()
    quick: bool = False
    time_cap: float = 60.0

    @property
    def key(self) -> str:
        """A stable identifier of the run (the time cap does not change what is run)."""
        return json.dumps([self.scenario, self.model, float(self.dt), int(self.n_segments),
                           sorted(self.settings), sorted(self.params), bool(self.quick)], sort_keys=True)
