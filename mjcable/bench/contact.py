"""The contact families' scenes and measurements: a rope over a peg (the capstan law), a cable on an incline
(Coulomb's stick/slide threshold and sliding acceleration) and a cable falling fast onto a thin plate (tunnelling).

Every function here takes a model label's ``(model, dt, settings)`` or a :class:`~mjcable.scene.Scene`, so that
all models are measured alike; :mod:`mjcable.bench.scenarios` wraps them into the sweep's scenarios.

* **capstan**: :func:`capstan_scene` hangs a limp rope over a horizontal peg (half a turn, θ = π) with legs whose
  heavy-rope ratio (:func:`mjcable.reference.heavy_capstan_ratio`) is ``factor`` times the law's e^{μπ} (its start
  clear of the peg, cut into it, or dropped onto it);
  :func:`capstan_end_speed` runs one probe (the long end's mean speed over seconds 1 to 3, after 1 s of settling)
  and :func:`capstan_slip_factor` bisects the factor at which the rope slides.
* **incline**: :func:`incline_scene` lays a cable down (or across) the slope of a tilted box;
  :func:`fit_acceleration` fits the centre of mass's travel down the slope to s(t) = s₀ + a t² / 2.
* **plate**: :func:`plate_scene` drops a cable from the height at which it reaches a given speed onto a 4 mm plate.

Example::

    from mjcable.bench import contact
    contact.capstan_end_speed("flexrod", 0.002, {}, factor=0.85, mu=0.2)    # ≈ 1e-3 m/s: holds
    contact.capstan_slip_factor("flexrod", 0.002, {}, mu=0.2).factor       # ≈ 0.94: slips 6 % below the law
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Callable, Optional

import numpy as np

from mjcable import _validate, geometry, reference
from mjcable.errors import SimulationDivergedError
from mjcable.scene import Box, CableSpec, Cylinder, Scene
from mjcable.simulator import Simulator

__all__ = [
    "CapstanScene",
    "capstan_scene",
    "capstan_end_speed",
    "finish_probe",
    "SlipSearch",
    "capstan_slip_factor",
    "incline_scene",
    "incline_travel",
    "fit_acceleration",
    "plate_scene",
    "plate_fall_time",
    "PEG_RADIUS",
    "SHORT_LEG",
    "START_CLEARANCE",
    "MAX_LIFT",
    "SETTLE_TIME",
    "MEASURE_TIME",
    "HOLD_SPEED",
    "SLIDE_SPEED",
    "SLIP_SPEED",
    "FACTOR_RANGE",
    "FIRST_PROBES",
    "PLATE_THICKNESS",
]

RADIUS = 0.005  # m, cable radius (as the other benchmark scenes)
LINEAR_DENSITY = 0.1  # kg/m
# capstan
PEG_RADIUS = 0.03  # m
PEG_HEIGHT = 0.0  # m, the peg's axis; nothing below it (a rope that slides off falls freely)
SHORT_LEG = 0.3  # m below the peg's axis
START_CLEARANCE = 5e-4  # m between the peg and the start arc's chords (the default: clear of the peg)
MAX_LIFT = 0.1  # m: the highest start above the peg that capstan_scene takes (a rope dropped onto it)
CAPSTAN_DAMPING = 2.0  # 1/s: settles the legs' swing within the first second
ARC_POINTS = 19  # control points on the start half circle (10° apart)
SETTLE_TIME = 1.0  # s before the end's speed is measured
MEASURE_TIME = 2.0  # s over which it is averaged
HOLD_SPEED = 2e-3  # m/s: slower, the rope holds
SLIDE_SPEED = 0.1  # m/s: faster, it slides
SLIP_SPEED = 0.02  # m/s: the bisection's line between holding (creep included) and slipping
FACTOR_RANGE = (0.3, 2.0)  # the bisected factor's range, in units of the law's ratio
FIRST_PROBES = (0.85, 1.15)  # the hold and slide probes, the first bracket tried
SLIP_TOLERANCE = 0.02  # relative width of the final bracket
# incline
INCLINE_HALF_SIZE = (1.2, 0.4, 0.02)  # m: along the slope, across it, half thickness
INCLINE_HEIGHT = 1.0  # m, the box's centre
INCLINE_START = -0.9  # m along the slope (uphill of the centre) where the cable starts
INCLINE_LENGTH = 0.6  # m of cable
# plate
PLATE_THICKNESS = 0.004  # m
PLATE_HALF_SIZE = (0.6, 0.6, PLATE_THICKNESS / 2)  # m
PLATE_CLEARANCE = 0.01  # m between the plate and the cable's surface at the start (the rest is the fall's height)
PLATE_CABLE_LENGTH = 0.6  # m


# ------------------------------------------------------------------------------------------------------ capstan


@dataclasses.dataclass(frozen=True)
class CapstanScene(Scene):
    """A :class:`~mjcable.scene.Scene` of a rope over a peg, with its design.

    Attributes:
      mu: friction coefficient of the rope and the peg.
      factor: the design's heavy-rope ratio in units of the law's, ratio / e^{μπ}.
      short, long: the legs in metres below the peg's axis once the rope lies on the peg (start legs plus half of
        the start arc's excess length each).
      contact_radius: R_c in metres, the peg's radius plus the rope's.
      peg_height: z in metres of the peg's axis.
      segments_per_metre: the rope's resolution it was built with.
      runs: scratch of one benchmark run (its simulator and bisection steps, handed by the scenario's setup to
        its measurement); not part of the scene.
    """

    mu: float = dataclasses.field(default=0.0, kw_only=True)
    factor: float = dataclasses.field(default=1.0, kw_only=True)
    short: float = dataclasses.field(default=SHORT_LEG, kw_only=True)
    long: float = dataclasses.field(default=SHORT_LEG, kw_only=True)
    contact_radius: float = dataclasses.field(default=PEG_RADIUS + RADIUS, kw_only=True)
    peg_height: float = dataclasses.field(default=PEG_HEIGHT, kw_only=True)
    segments_per_metre: int = dataclasses.field(default=50, kw_only=True)
    runs: dict = dataclasses.field(default_factory=dict, kw_only=True, compare=False, repr=False)

    @property
    def ratio(self) -> float:
        """The heavy-rope ratio (L_long − β) / (L_short + β) of the design."""
        return reference.heavy_capstan_ratio(self.long, self.short, self.mu, self.contact_radius)


def capstan_scene(factor: float, *, mu: float, segments_per_metre: int = 50, peg_radius: float = PEG_RADIUS,
                  radius: float = RADIUS, damping: float = CAPSTAN_DAMPING,
                  clearance: float = START_CLEARANCE, lift: float = 0.0) -> CapstanScene:
    """A limp rope hanging over a horizontal peg (along y), legs of :data:`SHORT_LEG` and the long leg at which the
    heavy-rope ratio is ``factor`` · e^{μπ}; no pins, nothing else.

    The rope starts on a half circle above the peg of radius √((R_c + ``clearance``)² + l₀² / 4) (R_c = peg radius
    + rope radius, l₀ the segment), so that the middles of its chords start ``clearance`` from the peg (negative:
    the chords cut into it), and straight vertical legs, all raised by ``lift`` (the rope drops onto the peg).
    Once the rope lies on the peg the start arc's excess length (its chords' length less π R_c) has gone to the
    legs; the start legs are shorter than the design's by half of it each. (How the excess splits, the chords on
    the wrapped arc and the contacts' penetration shift the legs by up to about 1 % of the ratio.)

    Args:
      factor: the ratio in units of the law (> 0).
      mu: friction coefficient of rope and peg (>= 0).
      segments_per_metre: segments per metre of rope (the rope's length changes with ``factor``; its segments stay
        the same length).
      peg_radius, radius: metres.
      damping: the rope's damping rate in 1/s.
      clearance: metres between the peg and the start arc's chords, in (−``radius``, ``peg_radius``]: the
        default :data:`START_CLEARANCE` starts the rope clear of the peg, a negative one with its chords cutting
        into it.
      lift: metres in [0, :data:`MAX_LIFT`] by which the start shape is raised: the rope falls that far onto the
        peg.
    """
    factor = _validate.number("factor", factor, low=0.0, low_open=True)
    mu = _validate.number("mu", mu, low=0.0)
    per_metre = _validate.integer("segments_per_metre", segments_per_metre, low=1)
    rc = _validate.number("peg_radius", peg_radius, low=0.0, low_open=True, unit="m") + _validate.number(
        "radius", radius, low=0.0, low_open=True, unit="m")
    clearance = _validate.number("clearance", clearance, low=-radius, high=peg_radius, low_open=True, unit="m")
    lift = _validate.number("lift", lift, low=0.0, high=MAX_LIFT, unit="m")
    long = reference.heavy_capstan_long_leg(SHORT_LEG, mu, rc, factor=factor)
    total = SHORT_LEG + long + math.pi * rc
    n = max(4, int(round(per_metre * total)))
    l0 = total / n  # the start arc is longer than π R_c: the total is kept, so the chords are l0 at most
    start = math.sqrt((rc + clearance) ** 2 + 0.25 * l0 * l0)  # the chords' middles at R_c + clearance
    chords = math.pi * start * (1.0 - l0 * l0 / (24.0 * start * start))  # the chords on the start half circle
    half_excess = 0.5 * (chords - math.pi * rc)
    short0, long0 = SHORT_LEG - half_excess, long - half_excess
    z = PEG_HEIGHT + lift
    # leg control points at twice the arc's spacing, doubling away from the arc: the spline stays straight
    step = start * math.pi / (ARC_POINTS - 1)

    def depths(leg):
        return [d for d in step * 2.0 ** np.arange(1, 30) if d < leg - step] + [leg]

    left = [[-start, 0.0, z - d] for d in reversed(depths(short0))]
    arc = [[-start * math.cos(a), 0.0, z + start * math.sin(a)] for a in np.linspace(0.0, math.pi, ARC_POINTS)]
    right = [[start, 0.0, z - d] for d in depths(long0)]
    cable = CableSpec(left + arc + right, n, radius, LINEAR_DENSITY * total, damping=damping, friction=mu)
    peg = Cylinder(radius=peg_radius, half_length=0.1, pos=(0.0, 0.0, PEG_HEIGHT), euler=(90.0, 0.0, 0.0))
    return CapstanScene(cable, obstacles=(peg,), name="capstan", mu=mu, factor=factor, short=SHORT_LEG, long=long,
                        contact_radius=rc, peg_height=PEG_HEIGHT, segments_per_metre=per_metre)


def capstan_end_speed(model: str, dt: float, settings: dict, *, factor: float, mu: float,
                      segments_per_metre: int = 50, clearance: float = START_CLEARANCE, lift: float = 0.0) -> float:
    """One probe: the long end's mean speed in m/s over seconds :data:`SETTLE_TIME` to
    :data:`SETTLE_TIME` + :data:`MEASURE_TIME` of :func:`capstan_scene` (``factor``, ``mu``, and the start's
    ``clearance`` and ``lift``) simulated by ``model`` at ``dt`` with ``settings``. Holding: below
    :data:`HOLD_SPEED`; sliding: above :data:`SLIDE_SPEED`; NaN when the simulation diverged.

    Raises:
      Exception: what building the simulator or stepping it raises, but for a divergence (NaN).
    """
    scene = capstan_scene(factor, mu=mu, segments_per_metre=segments_per_metre, clearance=clearance,
                          lift=lift)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulator(scene, model, dt=dt, **settings)
    try:
        sim.step(SETTLE_TIME)
    except SimulationDivergedError:
        return math.nan
    return finish_probe(sim, settled=sim.positions[-1])


def finish_probe(sim: Simulator, *, settled) -> float:
    """The end of a probe: step ``sim`` (a capstan scene simulated for :data:`SETTLE_TIME`) for
    :data:`MEASURE_TIME` more and return its long end's mean speed in m/s from ``settled`` ((3,), metres, its
    position at the settling time); NaN when it diverges."""
    start = np.array(settled, dtype=np.float64)
    try:
        sim.step(MEASURE_TIME)
    except SimulationDivergedError:
        return math.nan
    speed = float(np.linalg.norm(sim.positions[-1] - start)) / MEASURE_TIME
    return speed if math.isfinite(speed) else math.nan


@dataclasses.dataclass(frozen=True)
class SlipSearch:
    """The result of :func:`capstan_slip_factor`.

    Attributes:
      factor: the estimated slip factor (the bracket's geometric middle; its low end when the rope slid at every
        probe, its high end when it held at every probe).
      low, high: the bracket in units of the law: held (end slower than :data:`SLIP_SPEED`) at ``low``, slipped at
        ``high`` (``low`` = 0: slipped at the range's low end; ``high`` = inf: held at its high end).
      probes: ``((factor, end speed in m/s), ...)`` in the order run.
    """

    factor: float
    low: float
    high: float
    probes: tuple

    @property
    def bracketed(self) -> bool:
        return 0.0 < self.low and math.isfinite(self.high)


def capstan_slip_factor(model: str, dt: float, settings: dict, *, mu: float, steps: int = 6,
                        segments_per_metre: int = 50, first_speed: Optional[float] = None,
                        probe: Optional[Callable[[float], float]] = None) -> SlipSearch:
    """Bisect the factor (of the law's ratio e^{μπ}) at which the rope over the peg starts to slip.

    The probes :data:`FIRST_PROBES` (0.85, 1.15) come first; where the rope holds or slips at both the bracket
    extends to the ends of :data:`FACTOR_RANGE`. Then up to ``steps`` geometric bisections, stopping once the
    bracket is narrower than 2 % (from 0.85 to 1.15 four steps, from 0.3 to 0.85 six). A probe slips when the
    end's mean speed (:func:`capstan_end_speed`) exceeds :data:`SLIP_SPEED` or is NaN (diverged): creep slower
    than that counts as holding. At most 3 + ``steps`` probes of 3 simulated seconds each.

    Args:
      model, dt, settings: what to run (a model label's model and settings).
      mu: friction coefficient.
      steps: bisection steps after the first bracket (>= 0).
      segments_per_metre: the rope's resolution.
      first_speed: the end speed in m/s of the first probe (0.85), when already measured.
      probe: ``factor → end speed`` in m/s, replacing :func:`capstan_end_speed` (tests).
    """
    steps = _validate.integer("steps", steps, low=0)
    if probe is None:
        def probe(f):
            return capstan_end_speed(model, dt, settings, factor=f, mu=mu, segments_per_metre=segments_per_metre)
    runs = []
    known = {} if first_speed is None else {FIRST_PROBES[0]: float(first_speed)}

    def slips(f: float) -> bool:
        v = known.pop(f) if f in known else probe(f)
        runs.append((f, v))
        return not v <= SLIP_SPEED  # NaN slips

    lo_end, hi_end = FACTOR_RANGE
    first, second = FIRST_PROBES
    if slips(first):
        low, high = (0.0, lo_end) if slips(lo_end) else (lo_end, first)
    elif slips(second):
        low, high = first, second
    else:
        low, high = (hi_end, math.inf) if not slips(hi_end) else (second, hi_end)
    for _ in range(steps):
        if not (low > 0 and math.isfinite(high)) or high / low - 1.0 <= SLIP_TOLERANCE:
            break
        mid = math.sqrt(low * high)
        low, high = (low, mid) if slips(mid) else (mid, high)
    estimate = high if low == 0 else (low if not math.isfinite(high) else math.sqrt(low * high))
    return SlipSearch(estimate, low, high, tuple(runs))


# ------------------------------------------------------------------------------------------------------ incline


def incline_scene(mu: float, tilt: float, *, n_segments: int = 50, across: bool = False) -> Scene:
    """A straight cable lying on a box tilted ``tilt`` degrees about y (downhill along +x), near its upper edge,
    down the slope (or ``across`` it: then a model whose bodies can roll about the cable's axis rolls); cable and
    box have friction ``mu``. Nothing else.

    Args:
      mu: friction coefficient (>= 0).
      tilt: degrees in [0, 60].
      n_segments: the cable's segments.
      across: lay the cable horizontally across the slope instead of down it.
    """
    mu = _validate.number("mu", mu, low=0.0)
    tilt = _validate.number("tilt", tilt, low=0.0, high=60.0, unit="degrees")
    box = Box(size=INCLINE_HALF_SIZE, pos=(0.0, 0.0, INCLINE_HEIGHT), euler=(0.0, tilt, 0.0), friction=mu)
    rot = geometry.rotation(box.euler)
    top = INCLINE_HALF_SIZE[2] + RADIUS
    half = 0.5 * INCLINE_LENGTH
    ends = [[INCLINE_START, -half, top], [INCLINE_START, half, top]] if _validate.boolean("across", across) else \
        [[INCLINE_START - half, 0.0, top], [INCLINE_START + half, 0.0, top]]
    points = np.asarray(box.pos) + np.asarray(ends) @ rot.T
    cable = CableSpec(points, n_segments, RADIUS, LINEAR_DENSITY * INCLINE_LENGTH, friction=mu)
    return Scene(cable, obstacles=(box,), name="incline")


def incline_travel(scene: Scene, com_x) -> np.ndarray:
    """Travel in metres down the slope of :func:`incline_scene`'s cable from its centre of mass's x (``(m,)``,
    metres, the first at the start)."""
    box = scene.obstacles[0]
    downhill = geometry.rotation(box.euler)[:, 0]  # the box's +x, in the vertical xz plane
    com_x = np.asarray(com_x, dtype=np.float64)
    return (com_x - com_x[0]) / downhill[0]


def fit_acceleration(times, travel) -> float:
    """Least-squares a in m/s² of s(t) = s₀ + a t² / 2 over ``times`` (s) and ``travel`` (m), both ``(m,)``:
    motion from rest, s₀ taking up the contact's first settling."""
    t = np.asarray(times, dtype=np.float64)
    s = np.asarray(travel, dtype=np.float64)
    if len(t) < 3 or len(t) != len(s) or not np.all(np.isfinite(s)):
        return math.nan
    basis = np.stack([np.ones_like(t), 0.5 * t * t], axis=1)
    coef, *_ = np.linalg.lstsq(basis, s, rcond=None)
    return float(coef[1])


# -------------------------------------------------------------------------------------------------------- plate


def plate_scene(speed: float, *, n_segments: int = 50) -> Scene:
    """A straight horizontal cable above a :data:`PLATE_THICKNESS` thick plate, high enough that it falls onto it
    at ``speed`` m/s (h = v² / 2g above a clearance of :data:`PLATE_CLEARANCE`); no floor: a cable that tunnels
    falls on below it.

    Args:
      speed: impact speed in m/s (>= 0).
      n_segments: the cable's segments.
    """
    speed = _validate.number("speed", speed, low=0.0, unit="m/s")
    plate = Box(size=PLATE_HALF_SIZE, pos=(0.0, 0.0, 0.0))
    z = PLATE_HALF_SIZE[2] + RADIUS + PLATE_CLEARANCE + speed * speed / (2.0 * reference.G)
    points = [[-0.5 * PLATE_CABLE_LENGTH, 0.1, z], [0.5 * PLATE_CABLE_LENGTH, -0.1, z]]
    cable = CableSpec(points, n_segments, RADIUS, LINEAR_DENSITY * PLATE_CABLE_LENGTH, friction=0.5)
    return Scene(cable, obstacles=(plate,), name="plate")


def plate_fall_time(speed: float) -> float:
    """Seconds until the cable of :func:`plate_scene` (``speed``) reaches the plate."""
    return math.sqrt(2.0 * (PLATE_CLEARANCE + speed * speed / (2.0 * reference.G)) / reference.G)

