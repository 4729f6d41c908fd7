"""Rings in the particle backend (``Scene.rings``; the constraint: :mod:`mjcable.solvers.ring_kernels`).

Each ring's centre is a hub particle after the cables' (:func:`mjcable.solvers.state.ring_fields`) held by one pin
row of the solver state after the scene's pins and the free grippers' rows (:func:`add_ring_rows`). A world ring's
row is a world pin: its force is the ring's force on the cable. A body ring's row is coupled to the user's world
exactly as a body pin's (:mod:`mjcable.backends.host`): one more host link (:func:`body_links`) whose site is the
ring's centre in its body (:func:`add_sites`, in the proxy's spec) and whose direction, in place of a pin's
neighbour, is the cable's pull on the ring (``ring_dir``; the link's neighbour ``−1 − r``).
"""

from __future__ import annotations

import mujoco
import numpy as np

from mjcable.backends.grasp import PIN_ROW_FIELDS
from mjcable.scene import Scene

__all__ = ["add_ring_rows", "add_sites", "body_links", "ring_site", "ring_rows"]


def ring_site(k: int) -> str:
    """The name of body ring ``k``'s site (its centre, in its body) in the proxy's spec."""
    return f"ring{k}"


def add_sites(spec: mujoco.MjSpec, scene: Scene) -> None:
    """A site at each body ring's centre in its body (:func:`ring_site`)."""
    for k, ring in enumerate(scene.rings):
        if ring.body is not None:
            spec.body(ring.body).add_site(name=ring_site(k), pos=ring.pos)


def ring_rows(scene: Scene) -> np.ndarray:
    """``(R,)`` the solver state's pin rows of ``scene``'s rings' hubs: after its pins and free grippers'."""
    return np.arange(len(scene.rings), dtype=np.int64) + len(scene.pins) + len(scene.grippers)


def add_ring_rows(arrays, scene: Scene) -> None:
    """Append one active pin row per ring (:func:`ring_rows`, after :func:`~mjcable.backends.grasp.add_pin_rows`),
    holding its hub at the ring's centre (in place, before the state is packed)."""
    count = len(scene.rings)
    if not count:
        return
    hubs = arrays["ring_p"]
    for name, fill in PIN_ROW_FIELDS.items():
        old = arrays[name]
        arrays[name] = np.concatenate([old, np.full((count,) + old.shape[1:], fill, dtype=old.dtype)])
    rows = ring_rows(scene)
    arrays["pin_p"][rows] = hubs
    for name in ("pin_from", "pin_to", "start_from", "start_to", "target"):
        arrays[name][rows] = arrays["x"][hubs]
    arrays["pin_active"][rows] = True


def body_links(scene: Scene, mj_model: mujoco.MjModel, arrays) -> dict:
    """The host links of the body rings (:class:`mjcable.backends.host.Host`'s ``link_*`` fields, to append to the
    body pins'): pin row, hub particle, neighbour ``−1 − r`` (the ring's pull direction), body and site."""
    on_body = [k for k, ring in enumerate(scene.rings) if ring.body is not None]
    bodies = np.array([mj_model.body(scene.rings[k].body).id for k in on_body], dtype=np.int64)
    index = np.array(on_body, dtype=np.int64)
    return dict(link_pin=ring_rows(scene)[index], link_particle=arrays["ring_p"][index],
                link_neighbour=-1 - index, link_body=bodies,
                link_site=np.array([mj_model.site(ring_site(k)).id for k in on_body], dtype=np.int64))
