"""Winches in the particle solvers' state: the winch fields of :data:`~mjcable.solvers.kernels_layout.FIELDS` for a
scene's ``Pin(index, "winch")`` pins, the spool's start (:func:`arrays`) and the free length (:func:`free_length`).
The compiled side, and how a winch reels (a pin that moves through the particles as a cursor, every segment keeping
its rest length): :mod:`mjcable.solvers.winch_kernels`.

A winch at particle ``index`` of its cable (``Pin.index`` >= 0) holds that particle, and the particles before it are
on the spool at the start: ``Pin(50, "winch")`` on a cable of 150 segments starts with 100 segments free and pays out
up to 50 more; ``Pin(0, "winch")`` starts with the whole cable free and can only reel in. A negative index counts
from the cable's end, and the spool holds the particles after it (``Pin(-51, "winch")``: the last 50 segments).
The spooled particles start parked at the winch point, the held particle's start position.
"""

from __future__ import annotations

import numpy as np

from mjcable.scene import Scene

__all__ = ["winch_pins", "arrays", "free_length", "check_free", "RESET_FIELDS"]

#: the fields a winch changes as it reels, which a reset copies back (beside the chain's)
RESET_FIELDS = ("winch_u", "winch_len", "winch_speed", "seg_cable", "chain_seg", "link_particle", "link_neighbour",
                "free_w", "start_from", "start_to")


def winch_pins(scene: Scene) -> tuple:
    """Indices into ``scene.pins`` of its winches."""
    return tuple(k for k, pin in enumerate(scene.pins) if pin.kind == "winch")


def direction(scene: Scene, k: int) -> int:
    """+1 if winch ``k``'s free cable runs to higher particle indices (its spool at the cable's start), else −1."""
    return 1 if scene.pins[k].index >= 0 else -1


def arrays(scene: Scene, a: dict) -> dict:
    """The winch fields for ``scene``, and the chain ``a`` (the state's arrays, host fields included) changed in place
    to the spool's start: the spooled particles parked at the winch with inverse mass 0, their segments gaps
    (``seg_cable`` −1, outside ``chain_seg``), the held particle's lumped mass that of a cable end."""
    ks = winch_pins(scene)
    n = len(ks)
    out = dict(winch_pin=np.array(ks, dtype=np.int64), winch_cable=np.zeros(n, dtype=np.int64),
               winch_dir=np.zeros(n, dtype=np.int64), winch_end=np.zeros(n, dtype=np.int64),
               winch_far=np.zeros(n, dtype=np.int64), winch_link=np.full(n, -1, dtype=np.int64),
               winch_at=np.zeros((n, 3)), winch_u=np.zeros((n, 3)), winch_len=np.zeros(n), winch_speed=np.zeros(n),
               winch_rho=np.zeros(n), winch_l0=np.zeros(n))
    x = a["x"]
    for row, k in enumerate(ks):
        pin = scene.pins[k]
        c = pin.cable
        part, cable = scene.cable_slices[c], scene.cables[c]
        d = direction(scene, k)
        held = scene.pin_particle(k)
        end, far = (part.start, part.stop - 1) if d > 0 else (part.stop - 1, part.start)
        l0 = cable.segment_length
        out["winch_cable"][row], out["winch_dir"][row] = c, d
        out["winch_end"][row], out["winch_far"][row] = end, far
        links = np.flatnonzero(a["link_pin"] == k)
        if len(links):  # a body winch: the body's inverse mass along the cable, taken clear of the winch point
            out["winch_link"][row] = links[0]
            a["link_neighbour"][links[0]] = held + 2 * d if held + d != far else held + d
        out["winch_at"][row] = x[held]
        axis = x[held + d] - x[held]
        out["winch_u"][row] = axis / np.linalg.norm(axis)
        out["winch_len"][row], out["winch_l0"][row] = l0, l0
        out["winch_rho"][row] = cable.mass / (cable.n_segments * l0)
        spooled = np.arange(min(end, held), max(end, held) + 1)
        spooled = spooled[spooled != held]
        for name in ("x", "x0", "prev", "query_x"):
            a[name][spooled] = x[held]
        a["w"][spooled] = 0.0
        a["seg_cable"][np.arange(min(end, held), max(end, held))] = -1
        a["chain_seg"][c, 0 if d > 0 else 1] = held
        a["mass"][held] = 0.5 * out["winch_rho"][row] * l0
    return out


def free_length(a: dict, row: int) -> float:
    """m: winch ``row``'s free cable (the state's arrays ``a``): the first segment's part beyond the winch point and
    the segments after it."""
    held = int(a["pin_p"][a["winch_pin"][row]])
    beyond = abs(int(a["winch_far"][row]) - held - int(a["winch_dir"][row]))  # full segments after the first
    return float(a["winch_len"][row] + a["winch_l0"][row] * beyond)


def check_free(a: dict, index: int) -> None:
    """Raise unless particle ``index`` (global) is off every winch's spool and not held by a winch, now (the state's
    arrays ``a``)."""
    for row in range(len(a["winch_pin"])):
        k = int(a["winch_pin"][row])
        held, end = int(a["pin_p"][k]), int(a["winch_end"][row])
        if min(held, end) <= index <= max(held, end):
            raise ValueError(f"index: particle {index} is {'held by' if index == held else 'on the spool of'} "
                             f"winch pins[{k}] now; grasp a particle of the free cable")
