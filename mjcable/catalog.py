"""The catalogue of cable models: one registry that everything else asks which models exist.

Each :class:`ModelEntry` holds a model's name, its family (``"native"``: MuJoCo steps it; ``"particle"``: one of
our solvers steps it and MuJoCo gives the contacts), its frozen settings dataclass (keyword-only, validated once,
defaults documented on the class), its ``MjSpec`` builder and its backend. The Simulator, ``mjcable.build``,
the bench, the renderer, the environments and the CLI all derive their model lists from here
(:func:`names`); ``mjcable.MODELS``, ``NATIVE_MODELS`` and ``PARTICLE_MODELS`` are live views of it.

A model that the installed MuJoCo cannot run is not registered: ``composite`` needs MuJoCo's cable plugin, which
MuJoCo 4 removed. :func:`unavailable` names such models with the reason, and asking for one (:func:`get`,
:func:`build`, ``Simulator``) raises a ``ValueError`` with that reason.

Adding a model takes one module (its builder and, for a particle model, its ``rules``) and one :func:`register`
call::

    from mjcable import catalog
    from mjcable.backends.particle import ParticleBackend, proxy_builder
    from mjcable.solvers import xpbd
    from mjcable.solvers.settings import XPBDSettings

    catalog.register(catalog.ModelEntry(
        name="xpbd-gs", family="particle", settings=XPBDSettings, build=proxy_builder,
        backend=ParticleBackend, rules=xpbd.rules, summary="XPBD, Gauss-Seidel by default"))
"""

from __future__ import annotations

import dataclasses
import warnings
from typing import Any, Callable, Dict, Optional

import mujoco

from mjcable import _validate
from mjcable.backends.native import NativeBackend, spec_builder
from mjcable.backends.particle import ParticleBackend, proxy_builder
from mjcable.mjcf import composite, flexrod, joints, springs
from mjcable.mjcf.settings import CompositeSettings, FlexrodSettings, JointsSettings, SpringsSettings
from mjcable.scene import REST_SHAPES, CableSpec, Scene
from mjcable.solvers import cosserat, jakobsen, pbd, xpbd
from mjcable.solvers.settings import CosseratSettings, JakobsenSettings, PBDSettings, XPBDSettings

__all__ = ["ModelEntry", "FAMILIES", "register", "unregister", "get", "names", "unavailable", "check_model",
           "make_settings", "build", "check_scene", "check_dt", "check_substep", "honouring", "MIN_DT"]

FAMILIES = ("native", "particle")


@dataclasses.dataclass(frozen=True, kw_only=True)
class ModelEntry:
    """One cable model.

    Attributes:
      name: the model's name (``Simulator(scene, name)``).
      family: ``"native"`` (MuJoCo steps it) or ``"particle"`` (a particle solver steps it).
      settings: its frozen, keyword-only settings dataclass; ``settings()`` holds the defaults.
      build: ``(scene, settings, dt) -> mujoco.MjSpec``, the model (native) or its proxy (particle).
      backend: ``(scene, entry, dt, settings) -> Backend`` (:class:`mjcable.backends.protocol.Backend`).
      rules: particle models only: ``(scene, settings, h) -> Rules``, the kernels' parameters.
      summary: one line for listings.
      ignores: the cable's properties the model does not use, as ``(CableSpec field, what the model does instead)``
        pairs (a mapping is taken too); a Simulator warns when a scene sets one (:mod:`mjcable.prechecks`).
      check: ``(scene, settings, dt) -> None`` or ``None``: the model's own stability rules, checked when a Simulator
        is made (warning with :class:`~mjcable.errors.PhysicsWarning`, or raising ``ValueError``).
      twist: the model has a torsional stiffness of its own (G·J, from ``CableSpec.shear_modulus``).
      rest_shapes: the ``CableSpec.rest_shape`` values it honours.
      frames: it has material frames (:attr:`mjcable.Simulator.frames`, a gripper's ``orientation``).
      sections: it bends anisotropically (``CableSpec.section`` with unequal semi-axes).
      several_cables: it simulates a scene of several cables (``Scene(cable=(...))``), with contacts between them.
      junctions: it joins cables at ``Scene.junctions`` (and closes loops).
      rings: it threads cables through ``Scene.rings`` (sliding, with friction on the rim).
      winches: it reels ``Pin(..., "winch")`` pins (:meth:`mjcable.Simulator.reel`).
      start_twist: it starts a cable's frames twisted by ``CableSpec.start_twist``.
    """

    name: str
    family: str
    settings: type
    build: Callable[[Scene, Any, float], mujoco.MjSpec]
    backend: Callable[..., Any]
    rules: Optional[Callable] = None
    summary: str = ""
    ignores: tuple = ()
    check: Optional[Callable] = None
    twist: bool = False
    rest_shapes: tuple = ("straight",)
    frames: bool = False
    sections: bool = False
    several_cables: bool = False
    junctions: bool = False
    rings: bool = False
    winches: bool = False
    start_twist: bool = False

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name or not self.name.replace("-", "_").isidentifier():
            raise ValueError(f"name must be a non-empty identifier (dashes allowed), got {self.name!r}")
        _validate.choice("family", self.family, FAMILIES)
        if not (isinstance(self.settings, type) and dataclasses.is_dataclass(self.settings)):
            raise ValueError(f"settings must be a dataclass type, got {self.settings!r}")
        for field in ("build", "backend"):
            if not callable(getattr(self, field)):
                raise ValueError(f"{field} must be callable, got {getattr(self, field)!r}")
        if self.family == "particle" and not callable(self.rules):
            raise ValueError(f"rules must be callable for a particle model, got {self.rules!r}")
        fields = {f.name for f in dataclasses.fields(CableSpec)}
        try:
            ignores = tuple((str(k), str(v)) for k, v in dict(self.ignores).items())
        except (TypeError, ValueError):
            ignores = None
        if ignores is None or not {k for k, _ in ignores} <= fields:
            raise ValueError(f"ignores must pair CableSpec fields {sorted(fields)} with what the model does instead, "
                             f"got {self.ignores!r}")
        object.__setattr__(self, "ignores", ignores)  # a tuple: entries pickle and hash
        if self.check is not None and not callable(self.check):
            raise ValueError(f"check must be callable or None, got {self.check!r}")
        for shape in self.rest_shapes:
            _validate.choice("rest_shapes", shape, REST_SHAPES)


_REGISTRY: Dict[str, ModelEntry] = {}
_UNAVAILABLE: Dict[str, str] = {}  # model name -> why the installed MuJoCo cannot run it


def register(entry: ModelEntry, *, replace: bool = False) -> ModelEntry:
    """Add ``entry`` to the catalogue (``replace=True`` to overwrite a model of the same name). Returns it."""
    if not isinstance(entry, ModelEntry):
        raise ValueError(f"entry must be a catalog.ModelEntry, got {type(entry).__name__}")
    if entry.name in _REGISTRY and not replace:
        raise ValueError(f"model {entry.name!r} is already registered; pass replace=True to overwrite it")
    _REGISTRY[entry.name] = entry
    return entry


def unregister(name: str) -> None:
    """Remove model ``name`` from the catalogue."""
    check_model(name)
    del _REGISTRY[name]


def names(family: Optional[str] = None) -> tuple:
    """Names of the registered models in registration order, all or those of one ``family``."""
    if family is not None:
        _validate.choice("family", family, FAMILIES)
    return tuple(n for n, e in _REGISTRY.items() if family is None or e.family == family)


def unavailable() -> Dict[str, str]:
    """``{name: reason}`` of the built-in models that the installed MuJoCo cannot run (not registered): on MuJoCo 4,
    ``composite`` (no cable plugin); empty on MuJoCo 3.x."""
    return dict(_UNAVAILABLE)


def honouring(field: str) -> tuple:
    """Names of the registered models that use the ``CableSpec`` field ``field`` (not in their ``ignores``)."""
    return tuple(n for n, e in _REGISTRY.items() if field not in dict(e.ignores))


def check_model(name) -> str:
    """``name``, checked to be a registered model.

    Raises:
      ValueError: ``name`` is not registered; for a model of :func:`unavailable`, the reason it is missing.
    """
    if isinstance(name, str) and name in _UNAVAILABLE and name not in _REGISTRY:
        raise ValueError(_UNAVAILABLE[name])
    if not isinstance(name, str) or name not in _REGISTRY:
        raise ValueError(f"model must be one of {names()}, got {name!r}")
    return name


def get(name: str) -> ModelEntry:
    """The catalogue entry of model ``name``."""
    return _REGISTRY[check_model(name)]


def make_settings(name: str, **settings):
    """Model ``name``'s validated settings dataclass with ``settings`` overriding its defaults.

    Raises:
      ValueError: an unknown model, a setting the model does not take, or a value outside its range.

    Example::

        s = catalog.make_settings("xpbd", substeps=10)   # XPBDSettings(substeps=10, order='direct', ...)
    """
    cls = get(name).settings
    allowed = [f.name for f in dataclasses.fields(cls)]
    unknown = sorted(set(settings) - set(allowed))
    if unknown:
        raise ValueError(f"unknown setting(s) {unknown} for model {name!r}; allowed: {sorted(allowed)}")
    return cls(**settings)


#: s: the shortest step or substep a Simulator takes. Below it a second takes over a billion steps, and float64 time
#: (``mj_data.time``, the steps' count × dt) no longer resolves a step after a few hours of simulated time.
MIN_DT = 1e-9


def check_dt(dt) -> float:
    """``dt`` in seconds, checked finite and at least :data:`MIN_DT`."""
    return _validate.number("dt", dt, low=MIN_DT, unit="s")


def check_substep(dt: float, settings) -> None:
    """``dt / settings.substeps`` (where the settings have substeps) at least :data:`MIN_DT`.

    Raises:
      ValueError: naming ``substeps``, ``dt`` and the largest substep count that ``dt`` allows."""
    substeps = getattr(settings, "substeps", 1)
    if dt / substeps < MIN_DT:
        most = max(k for k in (int(dt / MIN_DT), int(dt / MIN_DT) + 1) if dt / k >= MIN_DT)  # round-off either way
        raise ValueError(f"substeps must leave a substep dt / substeps of at least {MIN_DT:g} s, got substeps="
                         f"{substeps} at dt={dt:g} s (at most {most} substeps at that dt)")


def check_scene(scene: Scene, model: str) -> None:
    """What model ``model`` can't honour of ``scene``: several cables or junctions for a model that takes one cable,
    a cable's ``rest_shape`` it has no means for, or an anisotropic ``section`` for a model that bends isotropically,
    a winch for a model that can't reel one, is a ``ValueError``; a ``shear_modulus`` given to a model without a
    twist stiffness of its own a warning.

    Raises:
      ValueError: naming what the model can't do (several cables, junctions, ``rest_shape`` or ``section``), the
        scene's value, and the models that can.
    """
    entry = get(model)
    for capability, what, wanted in (("several_cables", f"several cables ({len(scene.cables)})",
                                      len(scene.cables) > 1),
                                     ("junctions", f"junctions ({len(scene.junctions)})", bool(scene.junctions)),
                                     ("rings", f"rings ({len(scene.rings)})", bool(scene.rings))):
        if wanted and not getattr(entry, capability):
            takers = tuple(n for n, e in _REGISTRY.items() if getattr(e, capability))
            raise ValueError(f"{model}: {what} in scene {scene.name!r}: model {model!r} does not simulate them yet; "
                             f"use one of {takers}" if takers else
                             f"{model}: {what} in scene {scene.name!r}: model {model!r} does not simulate them yet, "
                             f"and no registered model does")
    winches = [k for k, pin in enumerate(scene.pins) if pin.kind == "winch"]
    if winches and not entry.winches:
        raise ValueError(f"pins[{winches[0]}] is a winch, which model {model!r} can't reel: "
                         f"{_NO_WINCH['frames' if entry.frames else entry.family]}; "
                         f"use one of {tuple(n for n, e in _REGISTRY.items() if e.winches)}")
    for cable in scene.cables:
        _check_cable(cable, model, entry)


#: why a model without winches can't reel one: a native model, a particle model with material frames
_NO_WINCH = {"native": "its segments are MuJoCo bodies and joints (or flex edges) compiled once with the scene, "
                       "and paying a cable out would need segments switched in and out at run time",
             "frames": "its segments carry material frames and rest curvatures per segment, which a winch's cursor "
                       "moving through the particles does not carry along",
             "particle": "it is not registered with winches=True (its rules don't hold a winch's cursor)"}


def _check_cable(cable: CableSpec, model: str, entry: ModelEntry) -> None:
    """:func:`check_scene` of one cable."""
    if cable.rest_shape not in entry.rest_shapes:
        takers = tuple(n for n, e in _REGISTRY.items() if cable.rest_shape in e.rest_shapes)
        raise ValueError(f"rest_shape must be one of {entry.rest_shapes} for model {model!r}, got "
                         f"{cable.rest_shape!r} (models with that rest shape: {takers})")
    if cable.start_twist != 0.0 and not entry.start_twist:
        raise ValueError(f"start_twist must be 0 for model {model!r}, which starts its frames untwisted, got "
                         f"{cable.start_twist!r} rad (models with a twisted start: "
                         f"{tuple(n for n, e in _REGISTRY.items() if e.start_twist)})")
    if cable.anisotropic and not entry.sections:
        raise ValueError(f"section must be circular (a = b) for model {model!r}, which bends isotropically, got "
                         f"section={cable.section!r} (models with anisotropic sections: "
                         f"{tuple(n for n, e in _REGISTRY.items() if e.sections)})")
    if cable.shear_modulus is not None and not entry.twist:
        warnings.warn(f"model {model!r} has no torsional stiffness of its own: CableSpec.shear_modulus = "
                      f"{cable.shear_modulus:g} Pa is not used (models with twist: "
                      f"{tuple(n for n, e in _REGISTRY.items() if e.twist)})", stacklevel=4)


def build(scene: Scene, model: str, *, dt: float = 0.002, **settings) -> mujoco.MjSpec:
    """The MuJoCo spec of ``scene`` for ``model``.

    Args:
      scene: the scene.
      model: a name from :func:`names`.
      dt: the simulator's step in seconds (> 0); native models step MuJoCo at ``dt / substeps``.
      **settings: the model's settings (see its entry's settings dataclass).

    Returns:
      An uncompiled ``mujoco.MjSpec``: the whole model for native models, the proxy (the scene plus one capsule
      per segment, for contacts and rendering) for particle models. ``spec.compile()`` gives the ``MjModel``.

    Example::

        spec = mjcable.build(mjcable.scenes.get("hang"), "flexrod")
        mj_model = spec.compile()
    """
    if not isinstance(scene, Scene):
        raise ValueError(f"scene must be an mjcable.Scene, got {type(scene).__name__}")
    entry = get(model)
    dt = check_dt(dt)
    made = make_settings(model, **settings)
    check_substep(dt, made)
    check_scene(scene, model)
    return entry.build(scene, made, dt)


for _module, _settings, _summary, _missing in (
        (springs, SpringsSettings, "point masses joined by spring tendons (MuJoCo)", None),
        (joints, JointsSettings, "ball-joint capsule chain (MuJoCo)", None),
        (composite, CompositeSettings, "MuJoCo's cable plugin (composite)", composite.missing_plugin()),
        (flexrod, FlexrodSettings, "1D flexcomp, a discrete elastic rod (MuJoCo)", None)):
    if _missing is not None:
        _UNAVAILABLE[_module.__name__.rsplit(".", 1)[1]] = _missing
        continue
    register(ModelEntry(name=_module.__name__.rsplit(".", 1)[1], family="native", settings=_settings,
                        build=spec_builder(_module.build, frames=_module in (joints, composite)),
                        backend=NativeBackend, summary=_summary,
                        ignores=getattr(_module, "IGNORES", {}), check=getattr(_module, "precheck", None),
                        twist=_module is composite, frames=_module in (joints, composite),
                        several_cables=True, junctions=True, rings=True))
for _module, _settings, _summary in (
        (jakobsen, JakobsenSettings, "Jakobsen's Verlet relaxation"),
        (pbd, PBDSettings, "Position Based Dynamics"),
        (xpbd, XPBDSettings, "Extended Position Based Dynamics, direct (banded) order")):
    register(ModelEntry(name=_module.__name__.rsplit(".", 1)[1], family="particle", settings=_settings,
                        build=proxy_builder, backend=ParticleBackend, rules=_module.rules, summary=_summary,
                        ignores=getattr(_module, "IGNORES", {}), several_cables=True, junctions=True,
                        winches=True, rings=True))
register(ModelEntry(name="cosserat", family="particle", settings=CosseratSettings, build=proxy_builder,
                    backend=ParticleBackend, rules=cosserat.rules, twist=True, rest_shapes=REST_SHAPES, frames=True,
                    sections=True, several_cables=True, junctions=True, start_twist=True,
                    ignores=getattr(cosserat, "IGNORES", {}),
                    summary="XPBD Cosserat rod: material frames, twist, curved rest shapes, direct solve"))
