"""The particle solvers' proxy: the scene's world plus one capsule per cable segment, for contacts and rendering.

The particle solvers (``jakobsen``, ``pbd``, ``xpbd``) integrate the cable themselves; MuJoCo only sees its
proxy. Each segment is a mocap body ``segment{i}`` holding a capsule geom ``segment{i}`` (radius: the cable's,
half-length l₀/2) and the site ``particle{i}`` at its start (the last segment also holds ``particle{n}``); the
solver writes the capsules' poses from its particles every step, and ``mj_kinematics`` + ``mj_collision`` give
the contacts with the obstacles. Several cables' particles are numbered in cable order, as the solvers' state
holds them: the segment from one cable's last particle to the next one's first is a gap, a body without a capsule
(it holds that particle's site).

Mocap bodies get no contacts with static geoms (MuJoCo skips pairs of bodies that cannot move), so every capsule
is paired with every obstacle geom (``obstacle{i}``) by an explicit ``<pair>``. The alternative, one free-joint
body per segment, lets MuJoCo's broadphase find the pairs: it is faster in the air but slower in contact, and the
solvers query only near contact, so pairs it is (``docs/measurements.md``).

Gripper pins get their mocap body ``gripper{k}`` (and world/socket pins their anchor site) from
:func:`mjcable.mjcf.world.add_anchor`, as in the native models.
"""

from __future__ import annotations

import mujoco
import numpy as np

from mjcable.mjcf import grasp, snap, world
from mjcable.scene import Scene

__all__ = ["build", "segment_name", "user_collision_geoms", "PROXY_KINDS", "DEFAULT_MARGIN"]

DEFAULT_MARGIN = 0.005  # m, the pairs' margin before the solver first sets it
PROXY_KINDS = ("pairs", "free")  # "free" exists for the measurement above; the solvers use "pairs"


def segment_name(i: int) -> str:
    """Name of the mocap body and capsule geom of cable segment ``i``."""
    return f"segment{i}"


def build(scene: Scene, *, dt: float, contact_margin: float = DEFAULT_MARGIN, proxy: str = "pairs") -> mujoco.MjSpec:
    """The proxy spec of ``scene`` for the particle solvers.

    Args:
      scene: the scene.
      dt: the simulator's step in seconds (MuJoCo's timestep; MuJoCo never steps the proxy).
      contact_margin: the pairs' initial margin in metres (the solver sets the margin every step).
      proxy: ``"pairs"`` (mocap capsules with explicit pairs, used by the solvers) or ``"free"`` (free-joint
        capsules found by MuJoCo's broadphase; for measurements).

    Returns:
      An uncompiled ``mujoco.MjSpec``.

    Example::

        spec = mjcable.build(mjcable.scenes.get("table"), "xpbd")
        mj_model = spec.compile()
    """
    if proxy not in PROXY_KINDS:
        raise ValueError(f"proxy must be one of {PROXY_KINDS}, got {proxy!r}")

    spec = world.new_spec(scene, timestep=dt)
    p = scene.particles
    geom = world.cable_geom(scene)
    n = len(p) - 1
    capsules = []  # (segment, cable) of the real segments: the gaps between cables get a body but no capsule
    for cable, part in zip(scene.cables, scene.cable_slices):
        capsules += [(i, cable) for i in range(part.start, part.stop - 1)]
    shape = dict(capsules)
    for i in range(n):
        d = p[i + 1] - p[i]
        name = segment_name(i)
        body = spec.worldbody.add_body(name=name, pos=0.5 * (p[i] + p[i + 1]), quat=_z_to(d), mocap=proxy == "pairs")
        if proxy == "free" and i in shape:
            body.add_freejoint()
        half = 0.5 * float(np.linalg.norm(d))
        if i in shape:
            half = 0.5 * shape[i].segment_length
            body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_CAPSULE, size=[shape[i].radius, half, 0.0],
                          margin=contact_margin, **geom)
            if scene.world is not None:  # only our pairs: the host's mj_step must never see a capsule
                body.geoms[-1].contype = body.geoms[-1].conaffinity = 0
        body.add_site(name=world.particle_site(i), pos=[0.0, 0.0, -half])
        if i == n - 1:
            body.add_site(name=world.particle_site(n), pos=[0.0, 0.0, half])
    if proxy == "pairs":
        others = user_collision_geoms(spec, scene) + [(f"obstacle{k}", "") for k in range(len(scene.obstacles))]
        for other, body in others:
            near = world.pinned_segments(scene, body)
            for i, _ in capsules:
                if i not in near:
                    spec.add_pair(geomname1=other, geomname2=segment_name(i), condim=3, margin=contact_margin)
    for k, pin in enumerate(scene.pins):
        world.add_anchor(spec, scene, k)
        if pin.on_body and pin.clamp:
            world.add_clamp_anchor(spec, scene, k)
    grasp.add_free_grippers(spec, scene)
    return snap.snap_spec(spec)


def user_collision_geoms(spec: mujoco.MjSpec, scene: Scene) -> list:
    """``(name, body name)`` of the user world's geoms in ``spec`` that collide with the cable under MuJoCo's own filter
    (``contype`` of one against ``conaffinity`` of the other, either way round, with the cable's bits from
    :func:`mjcable.mjcf.world.cable_geom`). The proxy pairs the cable with each by name, so an unnamed one is
    named ``world_geom{j}`` here (j counts the spec's geoms)."""
    if scene.world is None:
        return []
    cable = world.cable_geom(scene)
    ours = {f"obstacle{k}" for k in range(len(scene.obstacles))}
    names = []
    for j, g in enumerate(spec.geoms):
        if g.name in ours or not (g.contype & cable["conaffinity"] or cable["contype"] & g.conaffinity):
            continue
        if not g.name:
            g.name = f"world_geom{j}"
        names.append((g.name, g.parent.name))
    return names


def _z_to(d: np.ndarray) -> np.ndarray:
    """Quaternion (w, x, y, z) turning +z onto the direction of ``d``."""
    d = d / np.linalg.norm(d)
    q = np.array([1.0 + d[2], -d[1], d[0], 0.0])
    norm = np.linalg.norm(q)
    return np.array([0.0, 1.0, 0.0, 0.0]) if norm < 1e-9 else q / norm
