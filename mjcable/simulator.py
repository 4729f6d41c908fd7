"""One :class:`Simulator` over MuJoCo's native cable models and the particle solvers.

MuJoCo warnings (above all ``mjWARN_BADQACC``, after which MuJoCo silently resets the state), NaNs and runaway
positions or speeds become :class:`~mjcable.errors.SimulationDivergedError` here.
"""

from __future__ import annotations

import math
from typing import Optional

import mujoco
import numpy as np

from mjcable.build import NATIVE_MODELS, START_KEY, build, check_dt, check_model, native_settings
from mjcable.build import world
from mjcable.errors import SimulationDivergedError
from mjcable.scene import Scene

__all__ = ["Simulator", "MAX_SPEED", "MAX_DISTANCE"]

MAX_SPEED = 200.0  # m/s: a cable particle faster than this has diverged
MAX_DISTANCE = 1e3  # m from the origin: a particle further away has run off
_DIVERGENCE_WARNINGS = {  # int keys: index into data.warning
    int(mujoco.mjtWarning.mjWARN_BADQACC): "MuJoCo reset the state after a bad acceleration (mjWARN_BADQACC)",
    int(mujoco.mjtWarning.mjWARN_BADQVEL): "bad velocity (mjWARN_BADQVEL)",
    int(mujoco.mjtWarning.mjWARN_BADQPOS): "bad position (mjWARN_BADQPOS)",
    int(mujoco.mjtWarning.mjWARN_CONTACTFULL): "contact buffer full (mjWARN_CONTACTFULL)",
    int(mujoco.mjtWarning.mjWARN_CNSTRFULL): "constraint buffer full (mjWARN_CNSTRFULL)",
}
_STEP_EPS = 1e-9  # fraction of dt forgiven when counting whole steps in an accumulated duration


class _NativeBackend:
    """MuJoCo's own cable models: ``mj_step`` ``substeps`` times per ``dt``."""

    def __init__(self, scene: Scene, model: str, dt: float, settings: dict):
        s = native_settings(model, **settings)
        self.substeps = s.substeps
        spec = build(scene, model, dt=dt, **settings)
        self.spec = spec
        self.mj_model = spec.compile()
        self.mj_data = mujoco.MjData(self.mj_model)
        key = mujoco.mj_name2id(self.mj_model, mujoco.mjtObj.mjOBJ_KEY, START_KEY)
        if key >= 0:
            mujoco.mj_resetDataKeyframe(self.mj_model, self.mj_data, key)
        mujoco.mj_forward(self.mj_model, self.mj_data)
        m = self.mj_model
        n = scene.cable.n_particles
        self._sites = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, world.particle_site(i))
                                for i in range(n)])
        if np.any(self._sites < 0):
            raise RuntimeError(f"model {model!r} lacks particle sites")  # pragma: no cover - a generator bug
        self._mocap = {k: int(m.body_mocapid[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, world.gripper_body(k))])
                       for k in scene.grippers}
        self._sockets = []  # (release force, [equality ids])
        for k, pin in enumerate(scene.pins):
            if pin.kind == "socket":
                ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, world.pin_equality(k, clamp=c))
                       for c in (False, True)]
                self._sockets.append((pin.release_force, [i for i in ids if i >= 0]))
        self._socket_pins = [k for k, pin in enumerate(scene.pins) if pin.kind == "socket"]
        self._gripper_from = {}  # mocap id -> its position at the start of the next step (grippers moved since)

    def step(self) -> Optional[str]:
        m, d = self.mj_model, self.mj_data
        if self._gripper_from and self.substeps > 1:
            # A moved gripper travels linearly over the substeps, as the particle backend's pins do: a jump at the
            # first substep would inject energy into the stiff links holding its particle.
            moved = list(self._gripper_from)
            start = np.array([self._gripper_from[i] for i in moved])
            target = d.mocap_pos[moved].copy()
            for s in range(1, self.substeps + 1):
                d.mocap_pos[moved] = start + (target - start) * (s / self.substeps)
                mujoco.mj_step(m, d)
                if self._sockets:
                    self._release_sockets()
        elif self._sockets:
            for _ in range(self.substeps):
                mujoco.mj_step(m, d)
                self._release_sockets()
        else:
            mujoco.mj_step(m, d, nstep=self.substeps)
        self._gripper_from = {}
        counts = d.warning.number  # a writable view; MuJoCo's own reset zeroes it, so read and clear per dt
        bad = [w for w in _DIVERGENCE_WARNINGS if counts[w] > 0]
        if bad:
            counts[bad] = 0
            return "; ".join(_DIVERGENCE_WARNINGS[w] for w in bad)
        mujoco.mj_kinematics(m, d)  # xpos/site_xpos describe the previous state after mj_step
        if m.nflex:
            mujoco.mj_flex(m, d)  # flexvert_xpos too (rendering draws the flex from it)
        return None

    def _release_sockets(self) -> None:
        d = self.mj_data
        rows = d.efc_type[: d.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY
        for release_force, ids in self._sockets:
            if not d.eq_active[ids[0]]:
                continue
            # the socket's force on the plug: the pin's and (if clamped) the clamp's connect forces together
            total = np.zeros(3)
            for i in ids:
                total += d.efc_force[: d.nefc][rows & (d.efc_id[: d.nefc] == i)][:3]
            if float(np.linalg.norm(total)) > release_force:
                d.eq_active[ids] = 0

    def positions(self) -> np.ndarray:
        return self.mj_data.site_xpos[self._sites].copy()

    def move_gripper(self, k: int, position: np.ndarray) -> None:
        i = self._mocap[k]
        self._gripper_from.setdefault(i, self.mj_data.mocap_pos[i].copy())
        self.mj_data.mocap_pos[i] = position

    @property
    def released(self) -> set:
        """Pin numbers of the sockets that have let go."""
        return {k for k, (_, ids) in zip(self._socket_pins, self._sockets) if not self.mj_data.eq_active[ids[0]]}

    @property
    def time(self) -> float:
        return float(self.mj_data.time)


class Simulator:
    """Simulate a scene with one cable model.

    Args:
      scene: the scene.
      model: ``"springs"``, ``"joints"``, ``"composite"``, ``"flexrod"`` (MuJoCo's native models) or
        ``"jakobsen"``, ``"pbd"``, ``"xpbd"`` (particle solvers).
      dt: step in seconds (> 0).
      **settings: model settings: ``substeps`` and ``self_collision`` for native models (MuJoCo steps at
        ``dt / substeps``); see :mod:`mjcable.solvers` for the particle solvers.

    Example::

        sim = mjcable.Simulator(mjcable.scenes.get("hang"), "flexrod")
        sim.step(1.0)
        sim.positions  # (n_segments + 1, 3), metres
    """

    def __init__(self, scene: Scene, model: str, *, dt: float = 0.002, **settings):
        if not isinstance(scene, Scene):
            raise ValueError(f"scene must be an mjcable.Scene, got {type(scene).__name__}")
        check_model(model)
        self.dt = check_dt(dt)
        self.scene = scene
        self.model = model
        if model in NATIVE_MODELS:
            self._backend = _NativeBackend(scene, model, self.dt, settings)
        else:
            from mjcable import solvers

            self._backend = solvers.make_backend(scene, model, self.dt, settings)
        self._steps = 0
        self._pending = 0.0
        self._positions = self._backend.positions()
        self._check(self._positions, None)

    @property
    def mj_model(self) -> mujoco.MjModel:
        return self._backend.mj_model

    @property
    def mj_data(self) -> mujoco.MjData:
        return self._backend.mj_data

    @property
    def positions(self) -> np.ndarray:
        """``(n_segments + 1, 3)`` centreline particles in world coordinates (metres), from the first control point."""
        return self._positions.copy()

    @property
    def time(self) -> float:
        """Simulated time in seconds actually reached (a whole number of steps)."""
        return self._steps * self.dt

    @property
    def steps(self) -> int:
        """Number of steps of ``dt`` taken."""
        return self._steps

    def step(self, seconds: Optional[float] = None) -> None:
        """Advance by whole steps of ``dt``; the remainder of ``seconds`` carries over to the next call.

        Args:
          seconds: duration in seconds (>= 0); ``None`` takes exactly one step.

        Raises:
          SimulationDivergedError: NaN, runaway state or a MuJoCo warning.
        """
        if seconds is None:
            count = 1
        else:
            if isinstance(seconds, bool) or not isinstance(seconds, (int, float)) or not 0 <= seconds < math.inf:
                raise ValueError(f"seconds must be a finite number >= 0, got {seconds!r}")
            self._pending += float(seconds)
            count = int(math.floor(self._pending / self.dt + _STEP_EPS))
            self._pending = max(self._pending - count * self.dt, 0.0)
        for _ in range(count):
            reason = self._backend.step()
            self._steps += 1
            previous = self._positions
            self._positions = self._backend.positions()
            self._check(self._positions, previous, reason)

    def _check(self, x: np.ndarray, previous: Optional[np.ndarray], reason: Optional[str] = None) -> None:
        if reason is None and not np.all(np.isfinite(x)):
            reason = "non-finite particle positions (NaN or inf)"
        if reason is None and np.max(np.abs(x)) > MAX_DISTANCE:
            reason = f"a particle ran off beyond {MAX_DISTANCE:g} m"
        if reason is None and previous is not None:
            speed = float(np.sqrt(np.max(np.sum((x - previous) ** 2, axis=1)))) / self.dt
            if speed > MAX_SPEED:
                reason = f"a particle moved at {speed:.3g} m/s (limit {MAX_SPEED:g} m/s)"
        if reason is not None:
            raise SimulationDivergedError(self.model, self._steps, self.time, reason)

    @property
    def released(self) -> frozenset:
        """Pin numbers (indices into ``scene.pins``) of the sockets that have let go."""
        return frozenset(self._backend.released)

    def move_gripper(self, pin_number: int, position) -> None:
        """Move the gripper of ``scene.pins[pin_number]`` to ``position`` (3,), metres, world frame; it travels
        there linearly over the next step's substeps."""
        grippers = self.scene.grippers
        if pin_number not in grippers:
            raise ValueError(f"pin_number must index a gripper pin, one of {grippers}, got {pin_number!r}")
        pos = np.asarray(position, dtype=np.float64)
        if pos.shape != (3,) or not np.all(np.isfinite(pos)):
            raise ValueError(f"position must be 3 finite numbers in metres, got {position!r}")
        self._backend.move_gripper(pin_number, pos)
