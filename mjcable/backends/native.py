"""The native backend: MuJoCo's own cable models (``springs``, ``joints``, ``composite``, ``flexrod``), ``mj_step``
``substeps`` times per ``dt``.

Read-outs, all from MuJoCo's own state:

* positions: the sites ``particle{i}`` (kinematics recomputed after every step, ``mj_flex`` for flex models);
* velocities: each site's linear velocity from the bodies' com-based velocities ``cvel``,
  v = v_c + ω × (p − c), c the subtree centre of mass ``cvel`` refers to;
* pin forces: a pin held by connect equalities (``pin{k}``, ``pin{k}_clamp``) exerts the equalities' constraint
  forces on the particle sites (``efc_force`` rows, world frame, from the last step's constraint solve); a pin the
  kinematic tree realises (the root of a capsule chain) exerts the force its parent transmits to the root body
  (``cfrc_int`` after ``mj_rnePostConstraint``). Either way the pinned particle's own weight is included;
* pin torques: a clamp held by connects exerts Σ (s − x_i) × f about its particle, over its second and third
  connects' sites s (the neighbour particle or the clamp body's site on the axis, and the roll site) and forces f; a
  clamp the tree's root realises the torque its holder transmits, moved to the particle (through the clamp body and
  its half-segment joint, for a stiff cable's);
* energy: the cable's own kinetic, gravitational and elastic energy (:mod:`mjcable.backends.native_energy`).
"""

from __future__ import annotations

import math
from typing import Callable, Optional

import mujoco
import numpy as np

from mjcable import monitor
from mjcable.backends.grasp import NativeGrasps
from mjcable.backends.native_energy import CableEnergy
from mjcable.backends.protocol import Energy, RunResult
from mjcable.mjcf import cables, data, grasp, joints, rings, world
from mjcable.mjcf.settings import NativeSettings
from mjcable.scene import Scene
from mjcable.solvers.monitor_kernels import CHECK_OK, CHECK_PIN, WARN_DEPTH, step_check
from mjcable.solvers.state import quat_mul, start_frames

__all__ = ["NativeBackend", "spec_builder", "DIVERGENCE_WARNINGS"]

DIVERGENCE_WARNINGS = {  # index into data.warning -> what it means
    int(mujoco.mjtWarning.mjWARN_BADQACC): "MuJoCo reset the state after a bad acceleration (mjWARN_BADQACC)",
    int(mujoco.mjtWarning.mjWARN_BADQVEL): "bad velocity (mjWARN_BADQVEL)",
    int(mujoco.mjtWarning.mjWARN_BADQPOS): "bad position (mjWARN_BADQPOS)",
    int(mujoco.mjtWarning.mjWARN_CONTACTFULL): "contact buffer full (mjWARN_CONTACTFULL)",
    int(mujoco.mjtWarning.mjWARN_CNSTRFULL): "constraint buffer full (mjWARN_CNSTRFULL)",
}
_CONNECT_ROWS = 3  # a connect equality constrains three position components
_WELD_ROWS = 6  # a weld: three position components, then three of orientation


def spec_builder(generate: Callable[..., mujoco.MjSpec], *,
                 frames: bool = False) -> Callable[[Scene, NativeSettings, float], mujoco.MjSpec]:
    """The catalogue's builder ``(scene, settings, dt) -> MjSpec`` for a native generator
    ``generate(scene, *, timestep, self_collision)``: MuJoCo steps at ``dt / substeps``, and a scene where nothing
    can touch skips MuJoCo's collision pipeline altogether. In a user world the cable goes into the user's spec
    (:func:`mjcable.mjcf.world.finish`). Several cables, junctions and loops: :func:`mjcable.mjcf.cables.assemble`
    (``frames``: the model's cable is segment bodies, whose clamped junctions are welds)."""

    model = generate.__module__.rsplit(".", 1)[-1]

    def build(scene: Scene, settings: NativeSettings, dt: float) -> mujoco.MjSpec:
        options = dict(timestep=dt / settings.substeps, self_collision=settings.self_collision)
        with world.user_names(scene):
            if len(scene.cables) > 1 or scene.junctions:
                made = cables.assemble(scene, generate, model, frames=frames, **options)
            else:
                made = generate(scene, **options)
            if scene.grippers:
                grasp.add_free_grippers(made, scene, timestep=options["timestep"])
            if scene.rings:
                rings.add_rings(made, scene, model, timestep=options["timestep"])
            spec = world.finish(made, scene)
        if (not scene.obstacles and not scene.rings and scene.world is None and not settings.self_collision
                and len(scene.cables) == 1):
            spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
        return spec

    build.__doc__ = f"MjSpec of a scene for {generate.__module__}, MuJoCo stepping at dt / substeps."
    return build


def _name2id(m: mujoco.MjModel, kind, name: str) -> int:
    return mujoco.mj_name2id(m, kind, name)


class NativeBackend:
    """MuJoCo's own cable models: ``mj_step`` ``settings.substeps`` times per ``dt``.

    Args:
      scene: the scene.
      entry: the model's catalogue entry (its ``build`` makes the spec).
      dt: step in seconds (validated by the Simulator).
      settings: the model's settings dataclass (validated).
    """

    def __init__(self, scene: Scene, entry, dt: float, settings: NativeSettings):
        self.scene, self.name, self.dt, self.settings = scene, entry.name, dt, settings
        self.substeps = settings.substeps
        try:
            self.mj_model = entry.build(scene, settings, dt).compile()
        except ValueError as raw:  # MuJoCo's compiler: say which input it is about
            cable = min(scene.cables, key=lambda c: c.mass / c.n_segments)  # the lightest segments
            error = str(raw).replace("\n", "; ")
            raise ValueError(f"{self.name}: MuJoCo cannot compile this scene ({error}); the cable's mass "
                             f"{cable.mass:g} kg over {cable.n_segments} segments (radius {cable.radius:g} m) gives "
                             f"bodies of {cable.mass / cable.n_segments:g} kg, and MuJoCo needs every moving "
                             "body's mass and inertia above 1e-15 (mjMINVAL)"
                             if "mass and inertia" in error else f"{self.name}: MuJoCo cannot compile this "
                             f"scene: {error}") from None
        self.mj_data = data.new_data(self.mj_model)  # (the cable plugin reads it before MuJoCo initialises it)
        m = self.mj_model
        n = scene.n_particles
        self._sites = np.array([_name2id(m, mujoco.mjtObj.mjOBJ_SITE, cables.particle_name(scene, i))
                                for i in range(n)])
        if np.any(self._sites < 0):
            raise RuntimeError(f"model {self.name!r} lacks particle sites")  # pragma: no cover - a generator bug
        self._site_body = m.site_bodyid[self._sites]
        self._has_frames = entry.frames
        self._gripper_mocap = np.array([int(m.body_mocapid[_name2id(m, mujoco.mjtObj.mjOBJ_BODY,
                                                                     cables.pin_name(scene, k, world.gripper_body))])
                                        for k in scene.gripper_pins], dtype=np.int64)
        self._grasps = NativeGrasps(scene, m, self.mj_data, self._equality_force)
        self._gripper_mocap = np.concatenate([self._gripper_mocap, self._grasps.mocap])  # the free grippers follow
        free = range(len(scene.pins), len(scene.pins) + len(scene.grippers))
        self._mocap_of_pin = dict(zip(scene.gripper_pins + tuple(free), self._gripper_mocap.tolist()))
        # pin k -> (equality ids of pin{k}, pin{k}_clamp and pin{k}_roll, -1 where absent)
        self._pin_eq = np.array([[_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY,
                                           cables.pin_name(scene, k, world.pin_equality, clamp=c, roll=r))
                                  for c, r in ((False, False), (True, False), (False, True))]
                                 for k in range(len(scene.pins))], dtype=np.int64).reshape(-1, 3)
        # geom id -> the ring it belongs to (its capsules and its stop; -1: none)
        self._ring_of_geom = np.full(m.ngeom, -1, dtype=np.int64)
        for k in range(len(scene.rings)):
            names = [rings.ring_geom(k, j) for j in range(rings.SIDES)] + [rings.stop_geom(k)]
            ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name) for name in names]
            self._ring_of_geom[[i for i in ids if i >= 0]] = k
        # junction j -> its connect (or weld) and its clamp's tendon equality (-1: none), and the sites of the
        # clamp's tendon ends, the inward neighbours of particles a and b
        self._junction_eq = np.array([[_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, cables.junction_equality(j, clamp=c))
                                       for c in (False, True)] for j in range(len(scene.junctions))],
                                     dtype=np.int64).reshape(-1, 2)
        self._junction_ends = np.array([[self._sites[cables.inward(scene, i)] for i in scene.junction_particles(j)]
                                        for j in range(len(scene.junctions))], dtype=np.int64).reshape(-1, 2)
        # pin k -> the sites its second (a clamp body's, else the neighbour particle's) and third connects hold
        # (-1: none)
        self._clamp_site = np.array([self._clamp_site_of(k) if self._pin_eq[k, 1] >= 0 else -1
                                     for k in range(len(scene.pins))], dtype=np.int64)
        self._roll_site = np.array([_name2id(m, mujoco.mjtObj.mjOBJ_SITE, self._pin_site(k, world.roll_site))
                                    if self._pin_eq[k, 2] >= 0 else -1 for k in range(len(scene.pins))],
                                   dtype=np.int64)
        self._sockets = [k for k, pin in enumerate(scene.pins) if pin.kind == "socket"]
        self._gripper_from = {}  # mocap id -> its position at the start of the next step (grippers moved since)
        self._gripper_turn = {}  # mocap id -> its orientation at the start of the next step (grippers turned since)
        self._added = np.zeros(n)  # kg of point masses added per particle
        # the physics monitor (mjcable.monitor): limits, rest lengths, and the pins connect equalities hold (the
        # kinematic tree's pins can't tear), with their anchor sites
        self._limits = monitor.limits(scene, entry)
        self._lim = monitor.limits_record(self._limits, dt)
        # segment rest lengths in the particles' order; between two cables no segment (inf: never strained)
        self._rest = np.concatenate([np.append(np.full(c.n_segments, c.segment_length), np.inf)
                                     for c in scene.cables])[:-1]
        self._radius = min(c.radius for c in scene.cables)
        held = [k for k in range(len(scene.pins)) if self._pin_eq[k, 0] >= 0]
        self._check_pins = np.array(held, dtype=np.int64)
        self._check_particles = np.array([scene.pin_particle(k) for k in held], dtype=np.int64)
        self._check_anchors = np.array([_name2id(m, mujoco.mjtObj.mjOBJ_SITE,
                                                 cables.pin_name(scene, k, world.anchor_site)) for k in held],
                                       dtype=np.int64)
        # the depth check's contacts: a cable geom (or the flex) against anything but a body the cable is pinned to
        # (a pin may sit inside its body)
        cable_bodies = np.unique(self._site_body)
        self._cable_geoms = np.isin(m.geom_bodyid, cable_bodies[cable_bodies > 0])
        held = [_name2id(m, mujoco.mjtObj.mjOBJ_BODY, pin.body) for pin in scene.pins if pin.on_body]
        self._held_geoms = np.isin(m.geom_bodyid, held)
        self._energy = CableEnergy(m, self._sites, scene)
        self.reset()
        if self._has_frames:  # models of segment bodies: each segment's body, and its start frame in that body
            self._segment_body, self._frame_offset = self._segment_bodies()

    # -- the step -------------------------------------------------------------------------------------------------

    def reset(self) -> None:
        m, d = self.mj_model, self.mj_data
        world.reset_to_start(m, d)
        mujoco.mj_forward(m, d)
        self._gripper_from, self._gripper_turn = {}, {}
        self._refresh()
        self._last = self.positions()  # the particles before the next step (run()'s divergence checks)

    def run(self, count: int, *, rows: np.ndarray, out_x: np.ndarray, out_v: np.ndarray,
            path: Optional[tuple] = None, until_release: bool = False) -> RunResult:
        """:meth:`mjcable.backends.protocol.Backend.run`: a loop of :meth:`_step`, each followed by the divergence
        checks (:func:`~mjcable.solvers.monitor_kernels.step_check` on the particle sites; MuJoCo's own state is
        watched by its warnings, so the sites stand for the velocities too)."""
        pins, targets = (np.zeros(0, dtype=np.int64), np.zeros((0, 0, 3))) if path is None else path
        moved = np.zeros(targets.shape[:2], dtype=bool)  # (steps, G): whether a gripper's row differs from its last
        if len(targets):
            now = self.mj_data.mocap_pos[[self._mocap_of_pin[int(k)] for k in pins]]
            np.any(targets[:1] != now, axis=2, out=moved[:1])
            np.any(targets[1:] != targets[:-1], axis=2, out=moved[1:])
        released = len(self.released) if until_release else 0
        stored = 0
        warning = None
        x = self._last  # (not read from mj_data: a user may have reset it since)
        for i in range(count):
            if i < len(targets):
                for g in np.flatnonzero(moved[i]).tolist():
                    self.move_gripper(int(pins[g]), targets[i, g])
            previous = x
            reason = self._step()
            x = self.positions()
            v = self.velocities()
            failure = None if reason is None else monitor.Breach("MuJoCo warning", math.nan, reason, i + 1)
            if failure is None:
                found = self._check(x, v, previous, i + 1)
                if found is not None and found.warning:
                    warning = warning or found
                else:
                    failure = found
            if stored < len(rows) and rows[stored] == i + 1:
                out_x[stored], out_v[stored] = x, v
                stored += 1
            self._last = x
            if failure is not None:
                return RunResult(i + 1, stored, failure, warning)
            if until_release and len(self.released) != released:
                return RunResult(i + 1, stored, None, warning)
        return RunResult(count, stored, None, warning)

    def _check(self, x: np.ndarray, v: np.ndarray, previous: np.ndarray, step: int) -> Optional[monitor.Breach]:
        """The physics monitor after a step (:func:`~mjcable.solvers.monitor_kernels.step_check` on the particle
        sites, their velocities and the pins held by connect equalities; then the depth of the cable's contacts)."""
        d = self.mj_data
        lim = self._limits
        check, value, where = step_check(x, np.ascontiguousarray(v), previous, self._rest, self._check_particles,
                                         d.site_xpos[self._check_anchors], d.eq_active[self._pin_eq[self._check_pins,
                                                                                                    0]].astype(bool),
                                         self._lim)
        if check != CHECK_OK:
            where = int(self._check_pins[where]) if check == CHECK_PIN else int(where)
            return monitor.breach(check, value, where, self.scene, lim, step=step)
        ncon = d.ncon
        if ncon:
            contact = d.contact
            dist = contact.dist[:ncon]
            geoms = contact.geom[:ncon]
            known = np.maximum(geoms, 0)
            ours = ((geoms >= 0) & self._cable_geoms[known]).any(axis=1)
            if self.mj_model.nflex:
                ours |= (contact.flex[:ncon] >= 0).any(axis=1)
            ours &= ~((geoms >= 0) & self._held_geoms[known]).any(axis=1)
            deep = ours & (dist < -self._radius)
            if deep.any():
                c = int(np.argmin(np.where(deep, dist, np.inf)))
                return monitor.breach(WARN_DEPTH, -float(dist[c]), -1, self.scene, lim, step=step)
        return None

    def _step(self) -> Optional[str]:
        """One ``dt``: ``substeps`` ``mj_step`` calls. Returns why MuJoCo diverged (its warnings), else ``None``."""
        m, d = self.mj_model, self.mj_data
        if self._gripper_from and self.substeps > 1:
            # A moved gripper travels linearly over the substeps, as the particle backend's pins do: a jump at the
            # first substep would inject energy into the stiff links holding its particle; a turned one turns
            # (normalised linear interpolation of its quaternion, the short way round).
            moved = list(self._gripper_from)
            start = np.array([self._gripper_from[i] for i in moved])
            target = d.mocap_pos[moved].copy()
            turned = list(self._gripper_turn)
            q0 = np.array([self._gripper_turn[i] for i in turned]).reshape(-1, 4)
            q1 = d.mocap_quat[turned].copy()
            q0 *= np.where(np.sum(q0 * q1, axis=1) < 0.0, -1.0, 1.0)[:, None]
            for s in range(1, self.substeps + 1):
                d.mocap_pos[moved] = start + (target - start) * (s / self.substeps)
                if turned:
                    q = q0 + (q1 - q0) * (s / self.substeps)
                    d.mocap_quat[turned] = q / np.linalg.norm(q, axis=1)[:, None]
                mujoco.mj_step(m, d)
                self._release_sockets()
        elif self._sockets:
            for _ in range(self.substeps):
                mujoco.mj_step(m, d)
                self._release_sockets()
        else:
            mujoco.mj_step(m, d, nstep=self.substeps)
        self._gripper_from = {}
        self._gripper_turn = {}
        counts = d.warning.number  # a writable view; MuJoCo's own reset zeroes it, so read and clear per dt
        bad = [w for w in DIVERGENCE_WARNINGS if counts[w] > 0]
        if bad:
            counts[bad] = 0
            return "; ".join(DIVERGENCE_WARNINGS[w] for w in bad)
        self._refresh()
        return None

    def _refresh(self) -> None:
        m, d = self.mj_model, self.mj_data
        mujoco.mj_kinematics(m, d)  # xpos/site_xpos describe the previous state after mj_step
        if m.nflex:
            mujoco.mj_flex(m, d)  # flexvert_xpos too (rendering draws the flex from it)

    def _equality_force(self, eq: int) -> np.ndarray:
        """The (3,) force in N that connect (or weld) equality ``eq`` exerted on its first site (body) in the last
        constraint solve (a weld's first three rows)."""
        d = self.mj_data
        nefc = d.nefc
        rows = np.flatnonzero((d.efc_type[:nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY) & (d.efc_id[:nefc] == eq))
        if len(rows) not in (_CONNECT_ROWS, _WELD_ROWS):  # inactive (a released socket) or not in the last solve
            return np.zeros(3)
        return d.efc_force[rows[:_CONNECT_ROWS]].copy()

    def _release_sockets(self) -> None:
        d = self.mj_data
        for k in self._sockets:
            ids = [int(i) for i in self._pin_eq[k] if i >= 0]
            if not d.eq_active[ids[0]]:
                continue
            total = sum(self._equality_force(i) for i in ids)  # the pin's and the clamp's force on the plug
            if float(np.linalg.norm(total)) > self.scene.pins[k].release_force:
                d.eq_active[ids] = 0

    # -- read-outs ------------------------------------------------------------------------------------------------

    def positions(self) -> np.ndarray:
        return self.mj_data.site_xpos[self._sites].copy()

    def velocities(self) -> np.ndarray:
        m, d = self.mj_model, self.mj_data
        mujoco.mj_comPos(m, d)
        mujoco.mj_comVel(m, d)
        b = self._site_body
        cvel = d.cvel[b]  # [ω, v] at the subtree com of each body's root
        r = d.site_xpos[self._sites] - d.subtree_com[m.body_rootid[b]]
        v = cvel[:, 3:]  # (a copy: fancy indexing) + ω × r, written out (np.cross costs more than the step here)
        v[:, 0] += cvel[:, 1] * r[:, 2] - cvel[:, 2] * r[:, 1]
        v[:, 1] += cvel[:, 2] * r[:, 0] - cvel[:, 0] * r[:, 2]
        v[:, 2] += cvel[:, 0] * r[:, 1] - cvel[:, 1] * r[:, 0]
        return v

    def particle_masses(self) -> np.ndarray:
        return np.concatenate([c.particle_masses for c in self.scene.cables]) + self._added

    def energy(self) -> Energy:
        """The cable's energy: MuJoCo's own terms restricted to the cable, plus flex bending and the cable plugin
        (:mod:`mjcable.backends.native_energy`)."""
        return self._energy(self.mj_model, self.mj_data, self.positions())

    def _tree_wrench(self, k: int) -> np.ndarray:
        """(6,) [torque about the pinned particle, force] that the holder (world or gripper) transmits to the
        body holding pin ``k``'s particle (``cfrc_int``), plus, for a clamp, to the neighbour particle's body when
        that one is welded to the holder too (no joints of its own, as in ``springs``)."""
        m, d = self.mj_model, self.mj_data  # cfrc_int is current: _pin_wrenches ran mj_rnePostConstraint
        i = self.scene.pin_particle(k)
        bodies = [int(self._site_body[i])]
        if self.scene.pins[k].clamp:
            j = int(self._site_body[self.scene.clamp_neighbour(k)])
            if j != bodies[0] and m.body_jntnum[j] == 0:
                bodies.append(j)
        out = np.zeros(6)
        for b in bodies:
            torque, force = d.cfrc_int[b, :3], d.cfrc_int[b, 3:]
            about = d.subtree_com[m.body_rootid[b]] - d.site_xpos[self._sites[i]]
            out[:3] += torque + np.cross(about, force)
            out[3:] += force
        return out

    def pin_forces(self) -> np.ndarray:
        return self._pin_wrenches()[:, 3:]

    def junction_forces(self) -> np.ndarray:
        """``(len(scene.junctions), 3)`` N: the force each junction exerted on cable b in the last constraint solve:
        its connect's (or weld's) on particle b (the equality's first site or body; −that on particle a), plus a
        point-mass clamp's tendon equality's on b's neighbour (its force f pulls the neighbours together along
        the tendon: f (x_b' − x_a') / |x_b' − x_a'| on b')."""
        d = self.mj_data
        out = np.zeros((len(self._junction_eq), 3))
        for j, (eq, clamp) in enumerate(self._junction_eq.tolist()):
            out[j] = self._equality_force(eq)
            if clamp >= 0:
                rows = np.flatnonzero((d.efc_type[:d.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY)
                                      & (d.efc_id[:d.nefc] == clamp))
                span = d.site_xpos[self._junction_ends[j, 1]] - d.site_xpos[self._junction_ends[j, 0]]
                out[j] += float(d.efc_force[rows].sum()) * span / np.linalg.norm(span)
        return out

    def pin_torques(self) -> np.ndarray:
        return self._pin_wrenches()[:, :3]

    def _pin_wrenches(self) -> np.ndarray:
        scene = self.scene
        out = np.zeros((len(scene.pins), 6))
        x = self.mj_data.site_xpos[self._sites]
        if np.any(self._pin_eq[:, 0] < 0):  # pins the kinematic tree holds: their parents' forces, once for all
            m, d = self.mj_model, self.mj_data
            mujoco.mj_comPos(m, d)
            mujoco.mj_comVel(m, d)
            mujoco.mj_rnePostConstraint(m, d)
        for k in range(len(scene.pins)):
            eq, eq_clamp, eq_roll = (int(e) for e in self._pin_eq[k])
            if eq < 0:
                out[k] = self._tree_wrench(k)
                continue
            if not self.mj_data.eq_active[eq]:
                continue
            out[k, 3:] = self._equality_force(eq)
            if eq_clamp >= 0:
                f = self._equality_force(eq_clamp)
                out[k, 3:] += f
                out[k, :3] = np.cross(self.mj_data.site_xpos[self._clamp_site[k]] - x[scene.pin_particle(k)], f)
            if eq_roll >= 0:
                f = self._equality_force(eq_roll)
                out[k, 3:] += f
                out[k, :3] += np.cross(self.mj_data.site_xpos[self._roll_site[k]] - x[scene.pin_particle(k)], f)
        return out

    def _clamp_site_of(self, k: int) -> int:
        """The site that clamped pin ``k``'s second connect holds: its clamp body's (``joints``, ``composite``:
        :func:`mjcable.mjcf.world.clamp_site`), else the neighbour particle's."""
        site = _name2id(self.mj_model, mujoco.mjtObj.mjOBJ_SITE, self._pin_site(k, world.clamp_site))
        return site if site >= 0 else int(self._sites[self.scene.clamp_neighbour(k)])

    def _pin_site(self, k: int, name) -> str:
        """``name(i)`` of pin ``k``'s particle i within its cable, with the cable's prefix (a clamp's sites)."""
        scene = self.scene
        c = scene.pin_cable(k)
        return cables.prefix(scene, c) + name(scene.pin_particle(k) - scene.cable_slices[c].start)

    def gripper_positions(self) -> np.ndarray:
        return self.mj_data.mocap_pos[self._gripper_mocap].copy()

    def frames(self) -> np.ndarray:
        if not self._has_frames:
            raise ValueError(f"frames: model {self.name!r} has no material frames (its cable is point masses, no "
                             "segment bodies); models with frames: cosserat, joints, composite")
        return quat_mul(self.mj_data.xquat[self._segment_body], self._frame_offset)

    def _segment_bodies(self) -> tuple:
        """``(n,)`` the body of each segment and ``(n, 4)`` the segment's start material frame in that body's frame,
        from the start pose: the frames are then the twist-free start frames of every model
        (:func:`mjcable.solvers.state.start_frames`), turned with the bodies. Body j of the capsule chain spans
        particles ``order[j]`` (its origin) to ``order[j + 1]`` (:func:`mjcable.mjcf.joints.tree_order`: backwards
        for a tree rooted at the cable's far end). Several cables: ``(Σ nᵢ,)`` and ``(Σ nᵢ, 4)``, in cable order."""
        scene = self.scene
        bodies, start = [], []
        for c, cable in enumerate(scene.cables):
            first = scene.cable_slices[c].start
            order = joints.tree_order(scene.cable_scene(c)) + first
            own = np.empty(cable.n_segments, dtype=np.int64)
            own[np.minimum(order[:-1], order[1:]) - first] = self._site_body[order[:-1]]
            bodies.append(own)
            start.append(start_frames(cable.particles))
        bodies = np.concatenate(bodies)
        return bodies, quat_mul(self.mj_data.xquat[bodies] * [1.0, -1.0, -1.0, -1.0], np.concatenate(start))

    def move_gripper(self, k: int, position: np.ndarray, orientation: Optional[np.ndarray] = None) -> None:
        i = self._mocap_of_pin[k]
        d = self.mj_data
        if orientation is not None:
            if not self._has_frames:
                raise ValueError(f"orientation: model {self.name!r} can't turn a gripper (its cable has no "
                                 "material frames; models with frames: cosserat, joints, composite)")
            if not self.scene.pins[k].clamp:
                raise ValueError(f"orientation: pins[{k}] is not clamped (clamp=False): a gripper turns only a "
                                 "clamped end")
            self._gripper_turn.setdefault(i, d.mocap_quat[i].copy())
            d.mocap_quat[i] = orientation
        self._gripper_from.setdefault(i, d.mocap_pos[i].copy())
        d.mocap_pos[i] = position

    def add_point_mass(self, index: int, mass: float) -> None:
        """Add ``mass`` at particle ``index``'s site to the body holding it: the body's mass, centre of mass and
        inertia (parallel-axis theorem, re-diagonalised) change as for a point mass there; ``mj_setConst`` then
        refreshes MuJoCo's derived constants, and the state is put back."""
        m, d = self.mj_model, self.mj_data
        site = int(self._sites[index])
        b = int(m.site_bodyid[site])
        old = float(m.body_mass[b])
        new = old + mass
        # everything in the body frame: the old com and principal inertia, the point at the site
        rot = np.empty(9)
        mujoco.mju_quat2Mat(rot, m.body_iquat[b])
        rot = rot.reshape(3, 3)
        c_old = m.body_ipos[b].copy()
        point = m.site_pos[site].copy()
        c_new = (old * c_old + mass * point) / new
        tensor = rot @ np.diag(m.body_inertia[b]) @ rot.T
        for mm, r in ((old, c_old - c_new), (mass, point - c_new)):
            tensor += mm * (np.dot(r, r) * np.eye(3) - np.outer(r, r))
        principal, axes = np.linalg.eigh(tensor)
        if np.linalg.det(axes) < 0:
            axes[:, 0] = -axes[:, 0]
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, axes.ravel())
        m.body_mass[b] = new
        m.body_ipos[b] = c_new
        m.body_iquat[b] = quat
        m.body_inertia[b] = np.maximum(principal, 0.0)
        state = [a.copy() for a in (d.qpos, d.qvel, d.act, d.mocap_pos, d.mocap_quat, d.eq_active)]
        mujoco.mj_setConst(m, d)  # uses d as scratch at qpos0: put the state back
        for dst, src in zip((d.qpos, d.qvel, d.act, d.mocap_pos, d.mocap_quat, d.eq_active), state):
            dst[:] = src
        mujoco.mj_forward(m, d)
        self._refresh()
        self._added[index] += mass

    def reel(self, k: int, speed: float) -> None:
        self.free_length(k)

    def free_length(self, k: int) -> float:
        raise ValueError(f"model {self.name!r} has no winches (catalog.check_scene refuses them)")

    def grasp(self, g: int, index: int) -> None:
        self._grasps.grasp(g, index)

    def release(self, g: int) -> None:
        self._grasps.release(g)

    def gripper_forces(self) -> np.ndarray:
        return self._grasps.forces()

    def ring_forces(self) -> np.ndarray:
        """``(len(scene.rings), 3)`` N: the force each ring exerted on the cable in the last constraint solve, the sum
        of its geoms' contact forces (MuJoCo's contact force acts on geom2 along the frame's normal, −that on
        geom1)."""
        d = self.mj_data
        out = np.zeros((len(self.scene.rings), 3))
        wrench = np.zeros(6)
        for i in range(d.ncon):
            contact = d.contact[i]
            k1, k2 = self._ring_of_geom[contact.geom1], self._ring_of_geom[contact.geom2]
            if max(k1, k2) < 0:
                continue
            mujoco.mj_contactForce(self.mj_model, d, i, wrench)
            force = contact.frame.reshape(3, 3).T @ wrench[:3]  # on geom2, world frame
            if k1 >= 0:
                out[k1] += force  # the ring (geom1) pushes the cable (geom2)
            else:
                out[k2] -= force
        return out

    @property
    def released(self) -> set:
        d = self.mj_data
        return {k for k in self._sockets if not d.eq_active[int(self._pin_eq[k, 0])]}

    def diagnostics(self) -> dict:
        return {"contacts": int(self.mj_data.ncon), "constraints": int(self.mj_data.nefc)}
