"""The pieces every cable environment shares: the task registry, a Physics over a Simulator, a Task base.

:class:`CablePhysics` is a ``dm_control.mujoco.Physics`` that wraps the ``MjModel``/``MjData`` of an
:class:`mjcable.Simulator` (the very same ``MjData``: ``physics.data.ptr is simulator.mj_data``) and steps through
the Simulator, so the native models (stepped by MuJoCo) and the particle solvers (the cable stepped by the solver,
the rigid scene and the proxy capsules by MuJoCo) run, observe and render alike. ``physics.timestep()`` is the
Simulator's ``dt``; one control step is ``control_timestep / dt`` Simulator steps, and the grippers move a
``1 / n``-th of their commanded displacement before each of them, clamped to the task's :class:`Workspace`. The
clamped positions of all ``n`` steps come from one compiled call (:meth:`Workspace.paths`) and go to
:meth:`mjcable.Simulator.step_along`, so the control step runs no Python per step: the particle solvers take it in
one compiled loop (Python only around contact queries), the native models one MuJoCo step after another.

The Physics keeps no copy of the Simulator's state: positions, velocities (the model's own), gripper targets and
released sockets are read from :attr:`CablePhysics.simulator` when asked for, and the pins that are not grippers
stay at their start particles, read from the scene. One Simulator serves every episode of a scene: an episode
starts with :meth:`mjcable.Simulator.reset` (the exact start state, bit for bit); only an episode whose scene differs
(a task drawing a random start shape) builds a new Simulator, with the same model, ``dt`` and settings.

Environment settings (:func:`env_defaults`): the particle family takes ``substeps=10`` unless the caller sets
``substeps``; every other setting is the Simulator's default. At the catalogue's 4 substeps, ``jakobsen`` and
``pbd`` stretch the ``unplug`` task's cable under its pull so much that the plug never comes out; at 10 they let go
as the native models do (``docs/measurements.md``).

So the environments keep 10 substeps for the particle family (the per-step cost stays well under real time); a model
registered in the catalogue as ``"particle"`` gets the same.
"""

from __future__ import annotations

import collections
import dataclasses
import math
from typing import Dict, Optional, Sequence, Tuple

import numpy as np
from dm_control import mujoco
from dm_control.mujoco import wrapper
from dm_control.rl import control
from dm_control.suite import base
from dm_control.utils import containers
from dm_env import specs

from mjcable import catalog, scenes
from mjcable.envs.workspace import Workspace
from mjcable.render.overlays import add_cables
from mjcable.scene import Scene
from mjcable.simulator import Simulator

__all__ = [
    "checked_action",
    "SUITE",
    "CablePhysics",
    "CableTask",
    "make_environment",
    "register",
    "scene_with_pins",
    "models_for",
    "check_model_can",
    "env_defaults",
    "tolerance",
    "DEFAULT_CONTROL_TIMESTEP",
    "MAX_GRIPPER_SPEED",
    "FAMILY_DEFAULTS",
]

SUITE = containers.TaggedTasks()  # task name -> factory(model, *, random, time_limit, control_timestep, **settings)

DEFAULT_CONTROL_TIMESTEP = 0.02  # s between actions (50 Hz)
MAX_GRIPPER_SPEED = 0.5  # m/s per axis: the action bound is this times the control timestep
_ACTION_RTOL = 1e-6  # relative slack on the action bounds (float32 actions exactly at a bound round past it)
_STEP_RTOL = 1e-8  # relative slack when checking that the control timestep is a whole number of dt
_DEFAULT_DT = 0.002  # s, the Simulator's default step
# Settings the environments give every model of a catalogue family unless the caller sets them (measurements in the
# module docstring: at 4 substeps the particle solvers' cable stretches ~2 % under unplug's pull, which then never
# reaches the socket's release force).
FAMILY_DEFAULTS = {"particle": {"substeps": 10}}
_VALUE_AT_MARGIN = 0.1  # dm_control's rewards.tolerance default
_GAUSSIAN_SCALE = math.sqrt(-2.0 * math.log(_VALUE_AT_MARGIN))


def tolerance(x: float, low: float, high: float, margin: float) -> float:
    """``dm_control.utils.rewards.tolerance(x, bounds=(low, high), margin=margin)`` (its default Gaussian sigmoid,
    0.1 at ``margin`` outside the bounds) for one number, in plain floats: 1 inside ``[low, high]``, falling off
    as ``exp(-(d / margin)² ln 10)`` with the distance ``d`` to the nearer bound.

    Args:
      x: the value (units of the bounds).
      low, high: the bounds (``low <= high``; either may be infinite).
      margin: the distance (> 0) at which the reward falls to 0.1.
    """
    if low <= x <= high:
        return 1.0
    d = (low - x if x < low else x - high) / margin
    return math.exp(-0.5 * (d * _GAUSSIAN_SCALE) ** 2)


def env_defaults(model: str) -> dict:
    """The settings the environments give ``model`` unless the caller sets them: its catalogue family's entry of
    :data:`FAMILY_DEFAULTS`, restricted to the fields its settings dataclass has.

    Raises:
      ValueError: ``model`` is not in the catalogue.
    """
    entry = catalog.get(model)
    fields = {f.name for f in dataclasses.fields(entry.settings)}
    return {k: v for k, v in FAMILY_DEFAULTS.get(entry.family, {}).items() if k in fields}


class CablePhysics(mujoco.Physics):
    """A ``dm_control`` Physics stepped by an :class:`mjcable.Simulator`, with named cable read-outs.

    Create it with :meth:`from_simulator`; tasks start episodes with :meth:`start` and command grippers with
    :meth:`command_grippers`. Every read-out comes from :attr:`simulator` (or, for fixed pins, its scene).
    """

    @classmethod
    def from_simulator(cls, simulator: Simulator) -> "CablePhysics":
        """A Physics sharing ``simulator``'s ``MjModel`` and ``MjData``; a scene that differs at :meth:`start` gets a
        new Simulator of the same model, ``dt`` and settings."""
        if not isinstance(simulator, Simulator):
            raise ValueError(f"simulator must be an mjcable.Simulator, got {type(simulator).__name__}")
        physics = cls.__new__(cls)
        physics._warnings_cause_exception = True
        physics._workspace = None
        physics._commands = {}  # gripper displacements between the task's before_step and the next step
        physics._attach(simulator)
        return physics

    def _attach(self, simulator: Simulator) -> None:
        self._sim = simulator
        scene = simulator.scene
        n_pins = len(scene.pins)
        # the gripper pins, then the free grippers numbered len(scene.pins) + g (the Simulator's move_gripper numbers)
        self._grippers = list(scene.gripper_pins) + list(range(n_pins, n_pins + len(scene.grippers)))
        self._sockets = [k for k, pin in enumerate(scene.pins) if pin.kind == "socket"]  # the pins that can let go
        anchors = [scene.particles[scene.pin_particle(k)] for k in range(len(scene.pins))]
        self._anchors = np.array(anchors, dtype=np.float64).reshape(-1, 3)  # the pins' start particles (the scene's)
        self._anchors.setflags(write=False)
        self._gripper_rows = np.array(self._grippers, dtype=np.int64)  # rows of pin_positions that grippers fill
        self._engaged_by = {}  # released sockets -> (n_pins,) bool, read-only: pins_engaged without rebuilding it
        self._reload_from_data(wrapper.MjData(simulator.mj_data))

    # --- episodes -------------------------------------------------------------------------------------------------

    def start(self, scene: Scene, workspace: Workspace) -> None:
        """Start an episode of ``scene`` with grippers clamped to ``workspace``: the Simulator reset to its start state
        if it holds ``scene``, else a new Simulator of ``scene`` (same model, ``dt`` and settings).

        Raises:
          ValueError: ``workspace`` is not ``scene``'s, or a gripper's start position lies outside it (a task design
            error).
        """
        if workspace.scene != scene:
            raise ValueError("workspace.scene must be the scene being started")
        sim = self._sim
        if scene != sim.scene:
            self._attach(Simulator(scene, sim.model, dt=sim.dt, **dataclasses.asdict(sim.settings)))
        else:
            sim.reset()
        self._commands = {}
        pins, engaged = self.pin_positions(), self.pins_engaged()
        for k in self._grippers:
            excess = workspace.violation(k, pins[k], pins, engaged)
            if excess > 0.0:
                raise ValueError(f"gripper {k} starts {excess:.3g} m outside its workspace at "
                                 f"{pins[k]}; widen the workspace or move the start")
        self._workspace = workspace

    def reset(self, keyframe_id=None) -> None:
        """Reset the Simulator to its scene's exact start state (:meth:`mjcable.Simulator.reset`)."""
        if keyframe_id is not None:
            raise ValueError(f"keyframe_id is not supported by a cable Physics (episodes start from the scene), "
                             f"got {keyframe_id!r}")
        self._commands = {}
        self._sim.reset()

    def copy(self, share_model=False):
        raise NotImplementedError("a CablePhysics cannot be copied: its state lives in an mjcable.Simulator; "
                                  "build another environment with mjcable.envs.load instead")

    # --- stepping -------------------------------------------------------------------------------------------------

    def command_grippers(self, displacements: Dict[int, np.ndarray]) -> None:
        """Move grippers by ``displacements`` ({gripper: (3,) metres}) over the next :meth:`step`: gripper pins by
        their index into ``scene.pins``, free gripper ``g`` as ``len(scene.pins) + g``."""
        for k in displacements:
            if k not in self._grippers:
                raise ValueError(f"displacements must be keyed by grippers {tuple(self._grippers)} (gripper pins, then "
                                 f"free grippers as len(scene.pins) + g), got {k!r}")
        self._commands = {k: np.asarray(d, dtype=np.float64) for k, d in displacements.items()}

    def step(self, nstep: int = 1) -> None:
        """Advance ``nstep`` Simulator steps of ``dt``, moving the commanded grippers ``1 / nstep`` of the way
        before each.

        The grippers' clamped positions after every step are computed in one call (:meth:`Workspace.paths`), again
        for the remaining steps if a socket lets go part way (its tether then no longer holds), and the steps run in
        one :meth:`mjcable.Simulator.step_along` (a gripper that does not move in a step is not sent anywhere);
        with no gripper commanded, in one :meth:`mjcable.Simulator.step`.

        Raises:
          mjcable.SimulationDivergedError: the simulation diverged.
          dm_control.rl.control.PhysicsError: MuJoCo raised another warning.
        """
        if self._commands and self._workspace is None:
            raise RuntimeError("start an episode (physics.start) before commanding grippers")
        commands, self._commands = self._commands, {}
        with self.check_invalid_state():
            if commands:
                self._step_moving(commands, nstep)
            else:
                self._advance(nstep)

    def _advance(self, count: int) -> None:
        """``count`` Simulator steps in one call."""
        sim = self._sim
        target = sim.steps + count
        sim.step(count * sim.dt)
        while sim.steps < target:  # pragma: no cover - a carried remainder rounding the count down
            sim.step()

    def _step_moving(self, commands: Dict[int, np.ndarray], nstep: int) -> None:
        """``nstep`` steps with the grippers on their clamped paths (:meth:`Workspace.paths`), taken by
        :meth:`mjcable.Simulator.step_along`; while a socket holds, the Simulator stops after a step in which one
        lets go, and the rest of the path is recomputed without its tether."""
        sim, grippers = self._sim, tuple(commands)
        done = 0
        while done < nstep:
            released = sim.released
            watch = not released.issuperset(self._sockets)
            path, _ = self._workspace.paths(commands, nstep, self.pin_positions(), self._engaged(released),
                                            steps=nstep - done)
            done += sim.step_along(path, pins=grippers, until_release=watch)

    def render(self, height=240, width=320, camera_id=-1, overlays=(), depth=False, segmentation=False,
               scene_option=None, render_flag_overrides=None, scene_callback=None) -> np.ndarray:
        """dm_control's ``Physics.render``; unless given a ``scene_callback`` (or asked for depth or segmentation),
        it also draws every cable's centreline as capsules of its radius in its colour, so that every model shows the
        same continuous cables (the springs model's own geoms are small beads, the particle solvers' are proxy capsules).
        """
        if scene_callback is None and not (depth or segmentation):
            scene_callback = _draw_centreline
        return super().render(height=height, width=width, camera_id=camera_id, overlays=overlays, depth=depth,
                              segmentation=segmentation, scene_option=scene_option,
                              render_flag_overrides=render_flag_overrides, scene_callback=scene_callback)

    def timestep(self) -> float:
        """The Simulator's step ``dt`` in seconds."""
        return self._sim.dt

    def time(self) -> float:
        """Simulated time of the episode in seconds."""
        return self._sim.time

    # --- read-outs ------------------------------------------------------------------------------------------------

    @property
    def simulator(self) -> Simulator:
        """The :class:`mjcable.Simulator` this Physics steps (the same one across episodes of the same scene)."""
        return self._sim

    @property
    def scene(self) -> Scene:
        return self._sim.scene

    @property
    def workspace(self) -> Optional[Workspace]:
        return self._workspace

    def centreline(self) -> np.ndarray:
        """``(Σ (nᵢ + 1), 3)`` centreline particles of every cable in cable order, metres (one cable:
        ``(n_segments + 1, 3)``; ``scene.cable_slices`` cuts them, :meth:`cable_centreline` gives one)."""
        return self._sim.positions

    def centreline_velocity(self) -> np.ndarray:
        """``(Σ (nᵢ + 1), 3)`` particle velocities in m/s of every cable in cable order, the model's own
        (:attr:`mjcable.Simulator.velocities`)."""
        return self._sim.velocities

    def cable_centreline(self, c: int) -> np.ndarray:
        """``(n_c + 1, 3)`` the centreline particles of cable ``c`` (an index into ``scene.cables``), metres.

        Raises:
          ValueError: ``c`` is not a cable of the scene.
        """
        count = len(self.scene.cables)
        if isinstance(c, bool) or not isinstance(c, (int, np.integer)) or not 0 <= c < count:
            raise ValueError(f"c must be a cable index in [0, {count - 1}], got {c!r}")
        return self._sim.positions[self.scene.cable_slices[c]]

    def gripper_positions(self) -> np.ndarray:
        """``(n_grippers, 3)`` commanded gripper positions in metres: the gripper pins in the order of
        ``scene.gripper_pins``, then the free grippers (``scene.grippers``)."""
        return self._sim.gripper_positions

    def anchors(self) -> np.ndarray:
        """``(n_pins, 3)`` the pins' start particles in metres, from the scene (where world pins and sockets stay)."""
        return self._anchors.copy()

    def pin_positions(self) -> np.ndarray:
        """``(n_pins + n_free_grippers, 3)`` fixed sides of the pins in metres: grippers where they are commanded, the
        other pins (world pins, sockets) at their start particles; then the free grippers (row ``len(scene.pins) +
        g``, as :meth:`mjcable.Simulator.move_gripper` numbers them), where they are commanded: the rows
        :class:`Workspace` clamps."""
        pins = np.empty((len(self._anchors) + len(self.scene.grippers), 3))
        pins[:len(self._anchors)] = self._anchors
        pins[self._gripper_rows] = self._sim.gripper_positions
        return pins

    def pins_engaged(self) -> np.ndarray:
        """``(n_pins,)`` bool: whether each pin still holds the cable (a released socket does not)."""
        return self._engaged(self._sim.released).copy()

    def _engaged(self, released: frozenset) -> np.ndarray:
        """:meth:`pins_engaged` for ``released``, read-only (built once per set of released sockets)."""
        engaged = self._engaged_by.get(released)
        if engaged is None:
            engaged = np.ones(len(self._anchors), dtype=bool)
            engaged[list(released)] = False
            engaged.setflags(write=False)
            self._engaged_by[released] = engaged
        return engaged


def _draw_centreline(physics: CablePhysics, scn) -> None:
    """Append every cable's centreline to the ``mjvScene`` as capsules of its radius in its colour (per frame, not
    per step)."""
    add_cables(scn, physics.scene, physics.centreline(), 0.0)


class CableTask(base.Task):
    """Base of the cable tasks: gripper-displacement actions, cable observations, a workspace clamp.

    Subclasses set ``name`` (the registry key), ``physics_class`` (a :class:`CablePhysics` subclass with the task's
    read-outs), ``controlled`` (the grippers the action moves, in order: gripper pins, free grippers as
    ``len(scene.pins) + g``) and, where their scenes need them, the
    catalogue capabilities ``requires`` (``("several_cables",)``: loading on another model is a ``ValueError``), implement :meth:`make_scene`,
    :meth:`make_workspace`, :meth:`task_observations` and :meth:`get_reward`, draw their episode's random values from
    ``self.random`` in :meth:`make_scene` / :meth:`sample_episode`, and register with :func:`register`.

    Args:
      random: an int seed, a ``numpy.random.RandomState`` or ``None``, as in dm_control.
      control_timestep: seconds between actions (> 0); the action bound is ``MAX_GRIPPER_SPEED`` times it.
    """

    controlled: Sequence[int] = ()
    requires: Tuple[str, ...] = ()  # catalogue capabilities the task's scenes need, e.g. ("several_cables",)
    default_time_limit: float = math.inf  # s, set by :func:`register`

    def __init__(self, *, random=None, control_timestep: float = DEFAULT_CONTROL_TIMESTEP):
        super().__init__(random=random)
        self._max_step = MAX_GRIPPER_SPEED * control_timestep
        self._action_spec = specs.BoundedArray((3 * len(self.controlled),), np.float64, -self._max_step,
                                               self._max_step, name="gripper_displacement")
        self._action_words = dict(what=f"x, y, z displacement in metres of grippers {tuple(self.controlled)}",
                                  per=f" per control step (gripper speed <= {MAX_GRIPPER_SPEED:g} m/s)")

    # --- to implement ---------------------------------------------------------------------------------------------

    def make_scene(self) -> Scene:
        """The scene of the next episode (may draw from ``self.random``)."""
        raise NotImplementedError

    def make_workspace(self, scene: Scene) -> Workspace:
        raise NotImplementedError

    def sample_episode(self, physics: CablePhysics) -> None:
        """Draw the episode's random values (targets) from ``self.random``; called after the scene started."""

    def task_observations(self, physics: CablePhysics) -> dict:
        """Task values to append to the observation: name -> float64 array."""
        return {}

    # --- dm_control Task ------------------------------------------------------------------------------------------

    def initialize_episode(self, physics: CablePhysics) -> None:
        scene = self.make_scene()
        physics.start(scene, self.make_workspace(scene))
        self.sample_episode(physics)
        super().initialize_episode(physics)

    def action_spec(self, physics: CablePhysics) -> specs.BoundedArray:
        """Displacements of the controlled grippers over one control step: ``(3 * len(controlled),)`` metres."""
        return self._action_spec

    def before_step(self, action, physics: CablePhysics) -> None:
        a = checked_action(action, self._action_spec, self._max_step, unit="m", **self._action_words)
        physics.command_grippers({k: a[3 * i: 3 * i + 3] for i, k in enumerate(self.controlled)})

    def get_observation(self, physics: CablePhysics) -> collections.OrderedDict:
        """``centreline`` (Σ (nᵢ + 1), 3) m and ``centreline_velocity`` (Σ (nᵢ + 1), 3) m/s of every cable in cable
        order (one cable: (n+1, 3)), ``grippers`` (n_grippers, 3) m, then the task's values; all float64."""
        obs = collections.OrderedDict()
        obs["centreline"] = physics.centreline()
        obs["centreline_velocity"] = physics.centreline_velocity()
        obs["grippers"] = physics.gripper_positions()
        for name, value in self.task_observations(physics).items():
            obs[name] = np.asarray(value, dtype=np.float64)
        return obs


def checked_action(action, spec: specs.BoundedArray, bound, *, unit: str, what: str, per: str = "") -> np.ndarray:
    """``action`` as a float64 array of ``spec``'s shape, each entry within ±``bound`` (a number, or one per entry
    of ``spec``'s shape; in ``unit``); entries up to ``_ACTION_RTOL`` past it, float32 round-off, are put onto the
    bound. ``what`` says what the entries are and ``per`` qualifies the bound in the messages.

    Raises:
      ValueError: not an array, the wrong shape, a non-finite entry or one beyond the bound, naming it.
    """
    try:
        a = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"action must be an array of shape {spec.shape} in {unit}, got {action!r}") from exc
    if a.shape != spec.shape:
        raise ValueError(f"action must have shape {spec.shape} ({what}), got shape {a.shape}: {action!r}")
    scalar = np.ndim(bound) == 0
    if not (all(-bound <= x <= bound for x in a.ravel().tolist()) if scalar  # (a plain loop: the common case)
            else bool(np.all(np.abs(a) <= bound))):  # beyond a bound, or NaN
        size = np.abs(a)
        if not np.all(np.isfinite(a)):
            raise ValueError(f"action must be finite, got {action!r}")
        slack = bound + _ACTION_RTOL * np.asarray(bound)
        if not np.all(size <= slack):
            allowed = f"[{-bound:g}, {bound:g}]" if scalar else f"±{np.asarray(bound).tolist()} (entry by entry)"
            raise ValueError(f"action entries must lie in {allowed} {unit}{per}, got "
                             f"{a[size > slack].tolist()} in {action!r}")
        a = np.clip(a, -np.asarray(bound), bound)  # within the slack: onto the bound
    return a


def _check_seconds(name: str, value, *, allow_none: bool) -> Optional[float]:
    if value is None and allow_none:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 < float(value) < math.inf:
        raise ValueError(f"{name} must be a finite number of seconds > 0, got {value!r}")
    return float(value)


def make_environment(task: CableTask, physics_class: type, model: str, *, time_limit: float,
                     control_timestep: float, settings: dict) -> control.Environment:
    """Build the Simulator of ``task``'s first scene, wrap it in ``physics_class`` and make the Environment."""
    dt = catalog.check_dt(settings.get("dt", _DEFAULT_DT))
    n = control_timestep / dt
    if abs(n - round(n)) > _STEP_RTOL * n or round(n) < 1:
        raise ValueError(f"control_timestep must be a whole number (>= 1) of Simulator steps dt = {dt:g} s, "
                         f"got {control_timestep!r}")
    simulator = Simulator(task.make_scene(), model, **{**settings, "dt": dt})
    physics = physics_class.from_simulator(simulator)
    return control.Environment(physics, task, time_limit=time_limit, control_timestep=control_timestep)


def register(default_time_limit: float, *tags: str):
    """Register a task class as ``SUITE[name]``; its factory builds the Environment on any model."""

    def wrap(task_class):
        def factory(model: str = "flexrod", *, random=None, time_limit: Optional[float] = None,
                    control_timestep: Optional[float] = None, **settings) -> control.Environment:
            catalog.check_model(model)
            check_model_can(task_class, model)
            limit = _check_seconds("time_limit", time_limit, allow_none=True) or default_time_limit
            step = _check_seconds("control_timestep", control_timestep, allow_none=True) or DEFAULT_CONTROL_TIMESTEP
            task = task_class(random=random, control_timestep=step)
            return make_environment(task, task_class.physics_class, model, time_limit=limit,
                                    control_timestep=step, settings={**env_defaults(model), **settings})

        task_class.default_time_limit = default_time_limit
        factory.requires = task_class.requires
        factory.__name__ = task_class.name
        factory.__qualname__ = task_class.name
        factory.__doc__ = task_class.__doc__
        SUITE.add(*tags)(factory)
        return task_class

    return wrap


def models_for(requires: Sequence[str]) -> tuple:
    """The catalogue's models (asked at call time) that have every capability of ``requires`` (names of boolean
    fields of :class:`mjcable.catalog.ModelEntry`, e.g. ``"several_cables"``)."""
    return tuple(m for m in catalog.names() if all(getattr(catalog.get(m), c) for c in requires))


def check_model_can(task_class: type, model: str) -> None:
    """Raise unless ``model`` has every capability the task class ``requires``.

    Raises:
      ValueError: naming the task, the capabilities ``model`` lacks and the models that have them.
    """
    missing = [c for c in task_class.requires if not getattr(catalog.get(model), c)]
    if missing:
        raise ValueError(f"model must simulate {' and '.join(missing)} (catalogue capabilities) for task "
                         f"{task_class.name!r}, got {model!r}; use one of {models_for(task_class.requires)}")


def scene_with_pins(name: str, pins: tuple, **cable) -> Scene:
    """Built-in scene ``name`` (with ``CableSpec`` overrides ``cable``) holding the cable by ``pins`` instead."""
    s = scenes.get(name, **cable)
    return Scene(s.cable, pins=tuple(pins), obstacles=s.obstacles, name=s.name)

