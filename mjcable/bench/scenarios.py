"""Benchmark scenarios: a scene, how long to run it, what to drive, and its error against an independent reference.

The accuracy scenarios (:data:`SCENARIOS`), first five of shape and frequency and one of energy:

* ``catenary``: the ``hang`` scene damped to rest; error = RMS distance in metres of the particles to the
  inextensible catenary (:func:`mjcable.reference.catenary`).
* ``chain``: a chain pinned at its top, released from a small mode-1 displacement, undamped; error = relative
  error |ω / ω₁ − 1| of the swing's angular frequency (fitted to the centre of mass's x) against
  ω₁ = (z₁ / 2) √(g / L).
* ``cantilever``: a clamped horizontal rod (q L³ / E I ≈ 2) damped to rest; error = RMS distance in metres of
  the particles to the heavy elastica at their arc lengths (:func:`mjcable.reference.cantilever`).
* ``table``: the ``table`` scene (a wavy cable dropped 25 cm onto a table); error = RMS distance in metres to the
  ideal rest state (:func:`mjcable.reference.table_rest`).
* ``drape``: the ``drape`` scene (a straight cable falls onto a peg); error = RMS distance in metres of the
  particles to the ideal drape (two vertical strands hanging from the peg,
  :func:`mjcable.reference.drape_rest_distance`).
* ``energy``: the ``chain`` released from a 20 cm mode-1 swing (:data:`ENERGY_AMPLITUDE`), undamped (damping 0;
  ``joints`` and ``composite`` keep their ball joints' whip damping, ``flexrod`` its edge equality's), for
  :data:`ENERGY_DURATION` s; error = the largest change of :meth:`mjcable.Simulator.energy` (kinetic + gravity +
  the model's own elastic energy) from its start, relative to the swing's energy, the start's energy above the
  chain hanging straight down (:func:`swing_energy`). A conservative integrator keeps it near 0; the implicit
  particle solvers lose energy by numerical damping, faster at larger substeps; an unconverged Gauss-Seidel chain
  also stretches, which lowers its weight's energy (its hard rows store none).

And the contact families (scenes and measurements in :mod:`mjcable.bench.contact`):

* ``capstan_mu0.2`` and ``capstan_mu0.5``: a rope hanging over a horizontal peg (half a turn), μ = 0.2 and 0.5.
  The run simulates the first probe (legs at 0.85 of the heavy-rope law's ratio) for its settling second; the
  measurement then continues it and bisects the factor of the law at which the rope slips
  (:func:`mjcable.bench.contact.capstan_slip_factor`, to 2 %); error = |found / law − 1|, the relative error of the
  slip ratio against (L_long − β) / (L_short + β) = e^{μπ} (:func:`mjcable.reference.heavy_capstan_ratio`). Here
  ``n_segments`` is the rope's segments *per metre* (its length changes with the probe). ``--quick``: μ = 0.5 only,
  with at most :data:`CAPSTAN_QUICK_STEPS` bisection steps (about 2 % when the slip lies between 0.85 and 1.15, 7 %
  below 0.85), at most 6 probes of 3 simulated seconds.
* ``incline_stick``, ``incline_slide``: a cable lying down the slope of a box tilted about y, μ = 0.5, tilted
  just below the friction angle (tan θ = 0.95 μ: it must stick) and at 35° (it slides at g (sin θ − μ cos θ));
  ``incline_stick_across``, ``incline_slide_across``: the same with the cable lying across the slope (a cable whose
  bodies can roll rolls). The centre of mass's travel down the slope is fitted to s₀ + a t² / 2
  (:func:`mjcable.bench.contact.fit_acceleration`); error = |a − a_ref| / a_ref when it should slide, |a| / (g sin θ)
  when it should stick (:func:`mjcable.reference.incline_acceleration`).

And the pulley family (scene and measurement in :mod:`mjcable.bench.pulley`): ``pulley`` (two boxes of 2 and 1 kg
on a rope over a pulley on a frictionless hinge in a user world: relative error of the heavy box's acceleration,
fitted over 0.15-0.6 s, against the heavy-rope Atwood machine with the pulley's inertia) and ``pulley_slip`` (the
same run: |ω R_c / v_box − 1| over the window's second half, 0 without slip).

And the winch family (:mod:`mjcable.bench.winch`): a winch reels a 1 kg box on 1 m of rope (0.5 kg/m) in by 0.3 m
at 0.1 m/s and pays it out again: ``winch`` (metres: the larger of the box's rise's error against the reeled length
and its distance from its start at the end) and ``winch_pull`` (relative: the larger of the winch's pull's error
against the weight it holds while reeling steadily and the mass per metre's from the pull at two lengths); models
without winches are ``rejected``.

And the ring family (:mod:`mjcable.bench.ring`): ``ring`` (two boxes of 2 and 1 kg on a light rope through a
frictionless ring above them: relative error of the heavy box's acceleration, fitted over 0.1-0.5 s, against the
heavy-rope Atwood machine), ``ring_hold`` (rim friction μ = 0.3, m₁ / m₂ = 0.85 e^{μπ}: the heavy box's creep in m/s
once the start's slack is taken up, 0 when it holds) and ``ring_slide`` (m₁ / m₂ = 1.15 e^{μπ}: relative error of
its acceleration against the kinetic capstan law); models without rings are ``rejected``.

And the harness family (:mod:`mjcable.bench.harness`): ``harness``, the Y-harness (three cables of 0.6 m from
pins at three heights to one junction) damped to rest: largest distance in metres to the discrete reference
(:func:`mjcable.reference_harness.y_harness`); ``n_segments`` per leg; models that cannot hold several cables
with junctions are ``rejected``.

And the twist family (scenes, paths and errors in :mod:`mjcable.bench.twist`), for the models with material frames
(the others are ``rejected``): ``torsion`` (a clamped rod's end turned by π: relative error of the end torque
against G·J φ / L) and ``arc`` (its end carried onto a quarter circle with the arc's tangent: largest distance in
metres from the arc), ``greenhill`` (twisted until it buckles: relative error of the buckling torque against
2.86 π B / L; not in ``--quick``: a 10 s ramp) and ``curved_rest`` (a quarter circle with ``rest_shape="start"``,
pulled aside and let go: largest distance in metres from its start shape; models without curved rest shapes are
``rejected``).

And the knot family (:mod:`mjcable.bench.knot`): ``knot``, a rope in a loose overhand knot pulled taut by grippers
with self-collision on; error = its least self-distance over the run in radii, ``tunneled`` when below one radius
or when the knot came undone. Its stress family varies the pull's ``speed``.

Stress scenarios (:data:`STRESS_SCENARIOS`) vary one parameter each: ``stiffness`` (E·A on the drape), ``bending`` (E of a cantilever), ``segments``
(n_segments on the table drop), ``speed`` (a gripper yanks the cable's end), ``load`` (a heavy mass at the end of
a light cable hanging from one pin) and ``plate`` (a cable dropped from the height at which it hits a 4 mm plate at
``speed`` m/s: does it tunnel?). :data:`EXTRA_SCENARIOS`: ``swing`` (the thesis's stiffness-effect grid) and
``skip`` (the timing of what skipping unneeded contact work saves).

Damping in the static scenarios only speeds up settling: it never changes a static equilibrium.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable, Dict, Optional

import mujoco
import numpy as np
from scipy import optimize

from mjcable import reference, scenes
from mjcable.bench import contact, harness, knot, pulley, ring, twist, winch
from mjcable.scene import Box, CableSpec, Cylinder, Floor, Pin, Scene

__all__ = [
    "Scenario",
    "SCENARIOS",
    "STRESS_SCENARIOS",
    "EXTRA_SCENARIOS",
    "get",
    "chain_scene",
    "cantilever_scene",
    "table_scene",
    "yank_scene",
    "hanging_scene",
    "swing_scene",
    "fit_frequency",
    "CHAIN_AMPLITUDE",
    "ENERGY_AMPLITUDE",
    "ENERGY_DURATION",
    "swing_energy",
    "CANTILEVER_YOUNG",
    "CAPSTAN_MUS",
    "CAPSTAN_QUICK_MU",
    "CAPSTAN_QUICK_STEPS",
]

RADIUS = 0.005  # m, cable radius of the built-in scenes
MASS = 0.1  # kg per metre of cable
CHAIN_TOP = 1.5  # m, height of the chain's pin
CHAIN_AMPLITUDE = 0.01  # m, mode-1 displacement of the free end (1 % of L: frequency shift ~(A/L)² = 1e-4)
CHAIN_CONTROL_POINTS = 9
ENERGY_AMPLITUDE = 0.2  # m, the energy scenario's mode-1 displacement of the free end (swing energy ≈ 7.6 mJ)
ENERGY_DURATION = 10.0  # s
_FFT_PADDING = 16  # zero padding of the chain's periodogram (finer first guess of the frequency)
CANTILEVER_YOUNG = 1e9  # Pa: q L³ / (E I) = 0.981 / (1e9 · 4.9e-10) ≈ 2.0, a large deflection (δ ≈ 0.23 L)
CANTILEVER_HEIGHT = 1.0  # m
DAMPING_CATENARY = 8.0  # 1/s, about critical for the catenary's slowest mode (ω ≈ 3.8 rad/s)
DAMPING_CANTILEVER = 15.0  # 1/s, about critical for the cantilever's first mode (ω ≈ 7.8 rad/s)
DAMPING_CONTACT = 5.0  # 1/s for the table and drape
TABLE_TOP = 0.75  # m, height of the benchmark tables' top face
TABLE_HALF_SIZE = (0.6, 0.4, 0.02)  # m
TABLE_DROP = 0.1  # m from the table top to the benchmark table drop's cable
YANK_DISTANCE = 0.5  # m travelled by the gripper
YANK_DIRECTION = np.array([-1.0, 0.0, 1.0]) / math.sqrt(2.0)  # away from the cable and up
YANK_SETTLE = 0.2  # s at rest before the yank
YANK_AFTER = 0.5  # s after the gripper stops
SWING_STRETCH_STIFFNESS = 20.0  # N: E·A of the stiffness-effect cable (W L / (2 E A) ≈ 2.5 % hanging)
SWING_TIME = 0.25  # s, when the thesis took its stiffness-effect pictures
UNUSED_FLOOR_HEIGHT = -1.0  # m, a floor the hanging cable (lowest point 0.73 m) never reaches
CAPSTAN_MUS = (0.2, 0.5)  # one scenario each
CAPSTAN_QUICK_MU = 0.5  # the one --quick runs: the particle solvers do not hold at 0.85 of the law there
CAPSTAN_STEPS = 6  # bisection steps at most: 2 % from any first bracket in [0.3, 2]
CAPSTAN_QUICK_STEPS = 4  # --quick: 2 % from [0.85, 1.15], 7 % from [0.3, 0.85]
CAPSTAN_QUICK_TIME_CAP = 150.0  # s: joints and composite take ~25 s for their 6 probes on an idle core
INCLINE_MU = 0.5
INCLINE_STICK_TILT = math.degrees(math.atan(0.95 * INCLINE_MU))  # just below the friction angle: it sticks
INCLINE_SLIDE_TILT = 35.0  # degrees: a = g (sin θ − μ cos θ) = 1.61 m/s², 0.8 m in the run's second
PLATE_DURATION = 1.6  # s: the fall from 10 m/s's height (1.02 s) and half a second on the plate


@dataclasses.dataclass(frozen=True)
class Scenario:
    """One benchmark scenario.

    Attributes:
      name: label in the CSV's ``scenario`` column.
      description: one line for reports.
      make_scene: ``(n_segments, params) → Scene``; ``params`` is the case's dict of scenario parameters.
      duration: simulated seconds (full sweep).
      quick_duration: simulated seconds in ``--quick`` sweeps.
      error_kind: what ``error`` means (units) in the CSV.
      evaluate: ``(scene, final_positions, history) → error``; ``history`` holds sampled ``times`` (s) and
        ``com_x`` (m) for the chain.
      drive: optional ``(sim, t, params) → None`` acting on the simulator at simulated time ``t``, before each
        sample of the state (before each step until ``drive_end``), e.g. a disturbance; a gripper that follows a
        known path is a ``gripper_path`` instead.
      gripper_path: optional ``(scene, times, params) → path``: the grippers' positions (``(steps, G, 3)``, metres,
        ``scene.gripper_pins`` order) commanded before the steps that start at ``times`` (``(steps,)``, s); the runner
        hands it to :meth:`mjcable.Simulator.step_along` until ``drive_end``, after which the grippers stay.
      gripper_turns: optional ``(scene, times, params) → orientations`` (``(steps, G, 4)`` unit quaternions) that go
        with ``gripper_path`` (``step_along``'s ``orientations``).
      drive_end: simulated time after which ``drive`` and ``gripper_path`` no longer move anything; the run lasts
        ``duration + drive_end(params)``.
      passive: no energy is injected (energy growth means divergence).
      setup: optional ``(sim, params) → None`` applied once after the simulator is built (e.g. an end load).
      needs_com_x: sample the centre of mass's x for ``evaluate`` (the chain's frequency).
      needs_energy: sample :meth:`mjcable.Simulator.energy` for ``evaluate`` (``history["energy"]``, J, at the start
        and after every call of the simulator).
      needs_wrench: hand the final :attr:`~mjcable.Simulator.pin_torques` and ``pin_forces`` to ``evaluate``
        (``history["pin_torques"]``, N·m, and ``history["pin_forces"]``, N, each ``(pins, 3)``).
      strain_limit: segment strain beyond which the run counts as diverged (``None``: the sweep's
        ``STRAIN_LIMIT``; ``math.inf`` for the stiffness-effect grid, whose point is to show the stretch).
      in_quick: run in ``--quick`` sweeps (accuracy scenarios).
      quick_params: ``(name, value)`` scenario parameters of its ``--quick`` cases (e.g. fewer bisection steps).
      quick_time_cap: wall-clock seconds its ``--quick`` cases may take (``None``: the sweep's cap), for a run
        that measures with more simulations than the one it times (the capstan's bisection).
      settings: ``(name, value)`` model settings the scenario needs (e.g. ``self_collision``), under the case's own.
      verdict: optional ``(scene, final_positions) → (outcome, reason) or None``: a stable run's outcome by the
        scenario's own rule (a knot that came undone is ``tunneled``), after its error is measured.
    """

    name: str
    description: str
    make_scene: Callable[[int, dict], Scene]
    duration: float
    quick_duration: float
    error_kind: str
    evaluate: Optional[Callable[[Scene, np.ndarray, dict], float]] = None
    drive: Optional[Callable] = None
    gripper_path: Optional[Callable[[Scene, np.ndarray, dict], np.ndarray]] = None
    gripper_turns: Optional[Callable[[Scene, np.ndarray, dict], np.ndarray]] = None
    drive_end: Callable[[dict], float] = lambda params: 0.0
    passive: bool = True
    setup: Optional[Callable] = None
    needs_com_x: bool = False
    needs_energy: bool = False
    needs_wrench: bool = False
    strain_limit: Optional[float] = None
    in_quick: bool = True
    quick_params: tuple = ()
    quick_time_cap: Optional[float] = None
    settings: tuple = ()
    verdict: Optional[Callable] = None


# ------------------------------------------------------------------------------------------------------ scenes


def _cable(points, n_segments: int, **fields) -> CableSpec:
    fields = {"radius": RADIUS, "mass": MASS, "damping": 0.0, "friction": 1.0, **fields}
    return CableSpec(points, n_segments, fields.pop("radius"), fields.pop("mass"), **fields)


def chain_scene(n_segments: int = 50, *, amplitude: float = CHAIN_AMPLITUDE, length: float = 1.0,
                **fields) -> Scene:
    """A chain hanging from a world pin at ``CHAIN_TOP``, displaced along x by ``amplitude`` (free end) in its
    mode-1 shape J₀(z₁ √((L − s)/L)), undamped unless ``damping`` is given. No obstacles.

    The rest length is that of the Catmull-Rom curve through the displaced points (within 1e-4 of ``length``);
    the reference frequency uses ``scene.cable.length``.
    """
    s = np.linspace(0.0, length, CHAIN_CONTROL_POINTS)
    x = amplitude * reference.chain_mode_shape(s, length)  # 0 at the pin (J₀(z₁) = 0), amplitude at the free end
    points = np.stack([x, np.zeros_like(s), CHAIN_TOP - s], axis=1)
    return Scene(_cable(points, n_segments, **fields), pins=(Pin(0),), name="chain")


def cantilever_scene(n_segments: int = 50, *, young: float = CANTILEVER_YOUNG, length: float = 1.0,
                     **fields) -> Scene:
    """A straight horizontal rod along +x from (0, 0, ``CANTILEVER_HEIGHT``), clamped at its first particle."""
    fields = {"damping": DAMPING_CANTILEVER, **fields}
    points = [[0.0, 0.0, CANTILEVER_HEIGHT], [length, 0.0, CANTILEVER_HEIGHT]]
    return Scene(_cable(points, n_segments, young=young, **fields), pins=(Pin(0, clamp=True),), name="cantilever")


def table_scene(n_segments: int = 50, **fields) -> Scene:
    """The benchmark's table drop: a wavy cable lying in one horizontal plane 10 cm above a table (floor below).

    Unlike the built-in ``table`` scene (a 3D wave for the demo), every particle starts at the same height, so the
    ideal rest state is known exactly (:func:`mjcable.reference.table_rest`).
    """
    z = TABLE_TOP + TABLE_DROP
    points = [[-0.45, -0.1, z], [-0.15, 0.1, z], [0.15, -0.1, z], [0.45, 0.1, z]]
    fields = {"damping": DAMPING_CONTACT, **fields}
    return Scene(_cable(points, n_segments, **fields), obstacles=(Floor(), _table()), name="table")


def _table() -> Box:
    return Box(size=TABLE_HALF_SIZE, pos=(0.0, 0.0, TABLE_TOP - TABLE_HALF_SIZE[2]))


def yank_scene(n_segments: int = 50, **fields) -> Scene:
    """A straight cable lying on a table, its first particle held by a gripper (floor below)."""
    z = TABLE_TOP + RADIUS
    points = [[-0.45, 0.0, z], [0.45, 0.0, z]]
    fields = {"damping": 0.2, **fields}
    return Scene(_cable(points, n_segments, **fields), pins=(Pin(0, "gripper"),), obstacles=(Floor(), _table()),
                 name="yank")


def hanging_scene(n_segments: int = 50, *, length: float = 1.0, **fields) -> Scene:
    """A cable hanging straight down from a world pin at ``CHAIN_TOP`` (the load scenario), floor below."""
    points = [[0.0, 0.0, CHAIN_TOP], [0.0, 0.0, CHAIN_TOP - length]]
    fields = {"damping": 1.0, **fields}
    return Scene(_cable(points, n_segments, **fields), pins=(Pin(0),), obstacles=(Floor(),), name="hanging")


def swing_scene(n_segments: int = 50, **fields) -> Scene:
    """The stiffness-effect scene: a 1 m cable pinned at one end, released straight and horizontal at 1 m height."""
    points = [[-0.5, 0.0, 1.0], [0.5, 0.0, 1.0]]
    return Scene(_cable(points, n_segments, **fields), pins=(Pin(0),), name="swing")


# --------------------------------------------------------------------------------------------------- measures


def fit_frequency(times, values) -> float:
    """Angular frequency in rad/s of the dominant oscillation in ``values(times)`` (uniformly sampled).

    The highest peak of the zero-padded, Hann-windowed periodogram of the de-meaned signal gives a first guess,
    refined by a least-squares fit of c + a cos(ωt) + b sin(ωt) within ±25 % (variable projection: linear in c,
    a, b). Returns NaN when the signal does not oscillate (fewer than three crossings of its mean).
    """
    t = np.asarray(times, dtype=np.float64)
    y = np.asarray(values, dtype=np.float64)
    if len(t) < 8 or not np.all(np.isfinite(y)):
        return math.nan
    y0 = y - y.mean()
    sign = np.signbit(y0)
    if np.count_nonzero(sign[1:] != sign[:-1]) < 3:
        return math.nan
    step = float(np.mean(np.diff(t)))
    size = _FFT_PADDING * len(t)
    spectrum = np.abs(np.fft.rfft(y0 * np.hanning(len(t)), n=size))
    omega = 2.0 * math.pi * np.fft.rfftfreq(size, d=step)
    guess = float(omega[1 + int(np.argmax(spectrum[1:]))])

    def residual(w):
        basis = np.stack([np.ones_like(t), np.cos(w[0] * t), np.sin(w[0] * t)], axis=1)
        coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
        return basis @ coef - y

    fit = optimize.least_squares(residual, [guess], bounds=([0.75 * guess], [1.25 * guess]), xtol=1e-14,
                                 ftol=1e-14)
    return float(fit.x[0])


def _catenary_error(scene: Scene, x: np.ndarray, history: dict) -> float:
    curve = reference.catenary(x[0], x[-1], scene.cable.length)
    return float(np.sqrt(np.mean(reference.distance_to_curve(x, curve) ** 2)))


def _chain_error(scene: Scene, x: np.ndarray, history: dict) -> float:
    omega = fit_frequency(history["times"], history["com_x"])
    return abs(omega / reference.chain_frequency(scene.cable.length) - 1.0)


def _cantilever_reference(scene: Scene) -> np.ndarray:
    cable = scene.cable
    q = cable.linear_density * reference.G
    shape = reference.cantilever(cable.length, q, cable.bending_stiffness)
    s = np.arange(cable.n_particles) * cable.segment_length
    xz = shape.at_arclength(s)
    origin = np.asarray(cable.particles[0])
    return origin + np.stack([xz[:, 0], np.zeros(len(s)), xz[:, 1]], axis=1)


def _cantilever_error(scene: Scene, x: np.ndarray, history: dict) -> float:
    ref = _cantilever_reference(scene)
    return float(np.sqrt(np.mean(np.sum((x - ref) ** 2, axis=1))))


def _table_error(scene: Scene, x: np.ndarray, history: dict) -> float:
    table = next(ob for ob in scene.obstacles if isinstance(ob, Box))
    top = table.pos[2] + table.size[2]  # the scene's table is not rotated
    ref = reference.table_rest(scene.cable.particles, top, scene.cable.radius)
    return float(np.sqrt(np.mean(np.sum((x - ref) ** 2, axis=1))))


def _drape_error(scene: Scene, x: np.ndarray, history: dict) -> float:
    peg = next(ob for ob in scene.obstacles if isinstance(ob, Cylinder))  # horizontal, along y
    d = reference.drape_rest_distance(x, peg.pos, peg.radius, scene.cable.radius)
    return float(np.sqrt(np.mean(d**2)))


def swing_energy(scene: Scene) -> float:
    """The energy in J that a chain hanging from a pin at its top (``chain_scene``) holds at its start above its
    rest, hanging straight down: M g (z_c − (z_pin − L / 2)), z_c the start's centre of mass (an inextensible
    chain; lumped masses put the straight chain's centre of mass at its middle)."""
    cable = scene.cable
    m = cable.particle_masses
    z_pin = float(cable.particles[scene.pin_particle(0), 2])
    return cable.mass * reference.G * (float(m @ cable.particles[:, 2]) / cable.mass - (z_pin - cable.length / 2))


def _energy_drift(scene: Scene, x: np.ndarray, history: dict) -> float:
    energy = history["energy"]
    return float(np.max(np.abs(energy - energy[0]))) / swing_energy(scene)


def _capstan_setup(sim, params: dict) -> None:
    """Hand the run's simulator and bisection steps to the measurement (:func:`_capstan_error`)."""
    sim.scene.runs.update(sim=sim, steps=int(params.get("steps", CAPSTAN_STEPS)))


def _capstan_error(scene: Scene, x: np.ndarray, history: dict) -> float:
    """The run simulated the first probe's settling: finish it, bisect the slip factor, return |factor − 1|."""
    run = scene.runs
    sim = run.pop("sim")
    first = contact.finish_probe(sim, settled=x[-1])
    search = contact.capstan_slip_factor(sim.model, sim.dt, dataclasses.asdict(sim.settings), mu=scene.mu,
                                         steps=run.pop("steps"), segments_per_metre=scene.segments_per_metre,
                                         first_speed=first)
    return abs(search.factor - 1.0)


def _capstan(mu: float) -> Scenario:
    return Scenario(
        f"capstan_mu{mu:g}",
        f"rope over a peg (half a turn), μ = {mu:g}; n_segments per metre; relative error of the slip ratio "
        "against the heavy-rope capstan law (bisected)",
        lambda n, p: contact.capstan_scene(contact.FIRST_PROBES[0], mu=mu, segments_per_metre=n),
        duration=contact.SETTLE_TIME, quick_duration=contact.SETTLE_TIME, error_kind="relative",
        evaluate=_capstan_error, setup=_capstan_setup, in_quick=mu == CAPSTAN_QUICK_MU,
        quick_params=(("steps", CAPSTAN_QUICK_STEPS),), quick_time_cap=CAPSTAN_QUICK_TIME_CAP)


def _incline_error(scene: Scene, x: np.ndarray, history: dict) -> float:
    box = scene.obstacles[0]
    tilt = math.radians(box.euler[1])
    a = contact.fit_acceleration(history["times"], contact.incline_travel(scene, history["com_x"]))
    ref = reference.incline_acceleration(box.friction, tilt)
    return abs(a - ref) / (ref if ref > 0 else reference.G * math.sin(tilt))


def _incline(name: str, tilt: float, across: bool) -> Scenario:
    sticks = math.tan(math.radians(tilt)) <= INCLINE_MU
    return Scenario(
        name, f"cable {'across' if across else 'down'} a {tilt:.3g}° slope, μ = {INCLINE_MU:g} "
        f"({'sticks' if sticks else 'slides'}); error of the fitted acceleration",
        lambda n, p: contact.incline_scene(INCLINE_MU, tilt, n_segments=n, across=across),
        duration=1.0, quick_duration=1.0, error_kind="of g sin θ" if sticks else "relative",
        evaluate=_incline_error, needs_com_x=True)


def _elongation(scene: Scene, x: np.ndarray, history: dict) -> float:
    return float(np.sum(np.linalg.norm(np.diff(x, axis=0), axis=1)) / scene.cable.length - 1.0)


def _yank_path(scene: Scene, times: np.ndarray, params: dict) -> np.ndarray:
    """The yanking gripper at ``times`` (S,): at rest for ``YANK_SETTLE``, then ``YANK_DISTANCE`` along
    ``YANK_DIRECTION`` at ``speed`` m/s. Returns (S, 1, 3) positions in metres."""
    start = np.asarray(scene.cable.particles[scene.pin_particle(0)])
    travelled = np.clip((np.asarray(times) - YANK_SETTLE) * float(params["speed"]), 0.0, YANK_DISTANCE)
    return (start + travelled[:, None] * YANK_DIRECTION)[:, None, :]


def _load_setup(sim, params: dict) -> None:
    """The ``load`` scenario's end mass: ``load`` times the cable's mass, a point mass at the last particle."""
    sim.add_point_mass(-1, float(params["load"]) * sim.scene.cable.mass)


def _skip_scene(n_segments: int, params: dict) -> Scene:
    scene = scenes.get("hang", n_segments=n_segments, damping=DAMPING_CATENARY)
    if params.get("variant") == "unused_floor":
        scene = dataclasses.replace(scene, obstacles=(Floor(pos=(0.0, 0.0, UNUSED_FLOOR_HEIGHT)),))
    return scene


def _skip_setup(sim, params: dict) -> None:
    """``contact_off``: MuJoCo's whole collision pipeline disabled (native models), the floor of what skipping
    contacts can save."""
    if params.get("variant") != "contact_off":
        return
    if sim.family != "native":
        raise ValueError(f"variant 'contact_off' applies to MuJoCo's native models only, got model {sim.model!r} "
                         f"of family {sim.family!r}")
    sim.mj_model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT


SCENARIOS: Dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario("catenary", "1 m cable pinned 0.8 m apart, damped to rest; RMS distance to the catenary",
                 lambda n, p: scenes.get("hang", n_segments=n, damping=DAMPING_CATENARY),
                 duration=3.0, quick_duration=2.0, error_kind="m", evaluate=_catenary_error),
        Scenario("chain", "chain pinned at its top swinging in mode 1; relative error of ω₁",
                 lambda n, p: chain_scene(n), duration=5.0, quick_duration=3.5, error_kind="relative",
                 evaluate=_chain_error, needs_com_x=True),
        Scenario("energy", "chain pinned at its top, released from a 20 cm mode-1 swing, undamped; largest change of "
                 "Simulator.energy() over 10 s, relative to the swing's energy",
                 lambda n, p: chain_scene(n, amplitude=ENERGY_AMPLITUDE), duration=ENERGY_DURATION,
                 quick_duration=ENERGY_DURATION, error_kind="of the swing energy", evaluate=_energy_drift,
                 needs_energy=True),
        Scenario("cantilever", "clamped horizontal rod, q L³/EI ≈ 2, damped to rest; RMS distance to the elastica",
                 lambda n, p: cantilever_scene(n), duration=3.0, quick_duration=2.0, error_kind="m",
                 evaluate=_cantilever_error),
        Scenario("table", "wavy cable dropped 25 cm onto a table; RMS distance to the ideal rest",
                 lambda n, p: table_scene(n), duration=1.5, quick_duration=1.0, error_kind="m",
                 evaluate=_table_error),
        Scenario("drape", "straight cable falls onto a peg; RMS distance to the ideal drape",
                 lambda n, p: scenes.get("drape", n_segments=n, damping=DAMPING_CONTACT),
                 duration=3.0, quick_duration=2.0, error_kind="m", evaluate=_drape_error),
        *(_capstan(mu) for mu in CAPSTAN_MUS),
        _incline("incline_stick", INCLINE_STICK_TILT, across=False),
        _incline("incline_slide", INCLINE_SLIDE_TILT, across=False),
        _incline("incline_stick_across", INCLINE_STICK_TILT, across=True),
        _incline("incline_slide_across", INCLINE_SLIDE_TILT, across=True),
        Scenario("harness", "Y-harness: three 0.6 m cables from pins at three heights to one junction, damped to rest; "
                 "largest distance to the discrete reference (several cables with junctions)",
                 lambda n, p: harness.y_harness_scene(n), duration=6.0, quick_duration=6.0, error_kind="m",
                 evaluate=harness.y_harness_error),
        *(Scenario(name, f"{what}; the Atwood machine over a pulley on a frictionless hinge (m₁ = 2 kg, m₂ = 1 kg, "
                   "I / R_c² = 0.46 kg, μ = 1), fitted over 0.15-0.6 s", lambda n, p: pulley.atwood_scene(n),
                   duration=pulley.DURATION + pulley.SAMPLE_EVERY, quick_duration=pulley.DURATION + pulley.SAMPLE_EVERY,
                   error_kind="relative", evaluate=evaluate, drive=pulley.bench_drive, passive=False)
          for name, what, evaluate in (
              ("pulley", "relative error of the heavy box's acceleration against the heavy-rope Atwood machine",
               pulley.acceleration_error),
              ("pulley_slip", "slip: |rim speed / box speed − 1|", pulley.slip_error))),
        *(Scenario(name, f"{what}; a winch reels a 1 kg box on 1 m of rope (0.5 kg/m) in by 0.3 m at 0.1 m/s and "
                   "pays it out again", lambda n, p: winch.lift_scene(n), duration=winch.TOTAL,
                   quick_duration=winch.TOTAL, error_kind=kind, evaluate=evaluate, drive=winch.bench_drive,
                   passive=False)
          for name, what, kind, evaluate in (
              ("winch", "the box's rise against the reeled length, and its return", "m", winch.travel_error),
              ("winch_pull", "the winch's pull against the weight it holds while reeling, and the rope's mass per "
               "metre from the pull", "relative", winch.pull_error))),
        *(Scenario(name, f"{what}; the Atwood machine through a ring (m₂ = 1 kg, the rope turned through π)",
                   scene, duration=duration + ring.SAMPLE_EVERY, quick_duration=duration + ring.SAMPLE_EVERY,
                   error_kind=kind, evaluate=evaluate, drive=ring.bench_drive, passive=False)
          for name, what, scene, duration, kind, evaluate in (
              ("ring", "frictionless, m₁ = 2 kg: relative error of the heavy box's acceleration against the "
               "heavy-rope Atwood machine", lambda n, p: ring.atwood_scene(n), ring.DURATION, "relative",
               ring.acceleration_error),
              ("ring_hold", "μ = 0.3, m₁ / m₂ = 0.85 e^{μπ}: the heavy box's creep in m/s over 0.7-1 s (0: it holds)",
               lambda n, p: ring.hold_scene(n), ring.HOLD_DURATION, "m/s", ring.hold_error),
              ("ring_slide", "μ = 0.3, m₁ / m₂ = 1.15 e^{μπ}: relative error of the heavy box's acceleration "
               "against the kinetic capstan law", lambda n, p: ring.slide_scene(n), ring.DURATION, "relative",
               ring.acceleration_error))),
        Scenario("torsion", "rod clamped at both ends in zero gravity, one end turned by π; relative error of the "
                 "end torque against G·J φ / L (models with material frames)",
                 lambda n, p: twist.twist_scene(n), duration=1.5, quick_duration=1.5, error_kind="relative",
                 evaluate=twist.torsion_error, gripper_path=twist.torsion_path, gripper_turns=twist.torsion_turns,
                 drive_end=lambda p: twist.TORSION_RAMP, passive=False, setup=twist.require_frames,
                 needs_wrench=True),
        Scenario("arc", "rod clamped at both ends in zero gravity, one end carried onto a quarter circle with its "
                 "tangent; largest distance to the arc (models with material frames)",
                 lambda n, p: twist.twist_scene(n), duration=1.0, quick_duration=1.0, error_kind="m",
                 evaluate=twist.arc_error, gripper_path=twist.arc_path, gripper_turns=twist.arc_turns,
                 drive_end=lambda p: twist.ARC_SWEEP, passive=False, setup=twist.require_frames),
        Scenario("greenhill", "rod clamped at both ends in zero gravity with a 1 mm bow, one end sliding and twisted "
                 "to 1.2 M_c over 10 s; relative error of the torque at which it buckles against 2.86 π B / L (models "
                 "with material frames)",
                 lambda n, p: twist.greenhill_scene(n), duration=0.0, quick_duration=0.0, error_kind="relative",
                 evaluate=twist.greenhill_error, drive=twist.greenhill_drive,
                 drive_end=lambda p: twist.GREENHILL_RAMP, passive=False, setup=twist.greenhill_setup,
                 in_quick=False),
        Scenario("curved_rest", "quarter circle with rest_shape='start' in zero gravity, clamped at one end, the "
                 "other let go after a pull aside; largest distance from the start shape (models with curved rest "
                 "shapes)",
                 lambda n, p: twist.curved_scene(n), duration=4.0, quick_duration=4.0, error_kind="m",
                 evaluate=twist.curved_error, drive=twist.curved_drive, drive_end=lambda p: twist.PULL_TIME,
                 passive=False),
        Scenario("knot", "rope in a loose overhand knot, self-collision on, its ends pulled apart by grippers until "
                 "taut (2 N); least distance between two segments over the run, in radii (tunneled: below 1, or the "
                 "knot undone)",
                 lambda n, p: knot.knot_scene(n), duration=0.0, quick_duration=0.0, error_kind="r",
                 evaluate=knot.knot_error, drive=knot.knot_drive, drive_end=lambda p: knot.DURATION, passive=False,
                 setup=knot.knot_setup, settings=(("self_collision", True),), verdict=knot.knot_verdict),
    )
}

STRESS_SCENARIOS: Dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario("stiffness", "drape with axial stiffness E·A (N)",
                 lambda n, p: scenes.get("drape", n_segments=n, damping=DAMPING_CONTACT,
                                         stretch_stiffness=float(p["stiffness"])),
                 duration=1.0, quick_duration=1.0, error_kind="none"),
        Scenario("bending", "clamped cantilever with Young's modulus `young` (Pa): explicit bending blows up",
                 lambda n, p: cantilever_scene(n, young=float(p["young"])),
                 duration=1.0, quick_duration=1.0, error_kind="none"),
        Scenario("segments", "table drop with n_segments",
                 lambda n, p: table_scene(n),
                 duration=1.0, quick_duration=1.0, error_kind="none"),
        Scenario("speed", "a gripper yanks the cable's end 0.5 m at the given speed (m/s)",
                 lambda n, p: yank_scene(n), duration=YANK_AFTER, quick_duration=YANK_AFTER,
                 error_kind="none", gripper_path=_yank_path, passive=False,
                 drive_end=lambda p: YANK_SETTLE + YANK_DISTANCE / float(p["speed"])),
        Scenario("load", "light cable hanging from one pin with an end mass of `load` times its own",
                 lambda n, p: hanging_scene(n), duration=1.0, quick_duration=1.0, error_kind="none",
                 setup=_load_setup),
        Scenario("plate", "cable dropped onto a 4 mm plate, hitting it at `speed` m/s (no floor below)",
                 lambda n, p: contact.plate_scene(float(p["speed"]), n_segments=n),
                 duration=PLATE_DURATION, quick_duration=PLATE_DURATION, error_kind="none"),
    )
}

# Scenarios of their own: the thesis's stiffness-effect grid and the skip-what-is-not-needed timing.
EXTRA_SCENARIOS: Dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario("swing", "1 m cable (E·A = 20 N) pinned at one end, released horizontal; its shape at t = 0.25 s; "
                 "error = elongation (length / rest length − 1)",
                 lambda n, p: swing_scene(n, stretch_stiffness=SWING_STRETCH_STIFFNESS),
                 duration=SWING_TIME, quick_duration=SWING_TIME, error_kind="elongation", evaluate=_elongation,
                 strain_limit=math.inf),
        Scenario("skip", "hang (no obstacles) vs hang with an unused floor 2 m below vs collision disabled; "
                 "error = RMS distance to the catenary",
                 _skip_scene, duration=2.0, quick_duration=2.0, error_kind="m", evaluate=_catenary_error,
                 setup=_skip_setup),
    )
}


def get(name: str) -> Scenario:
    """A scenario (accuracy, stress or extra) by name."""
    for table in (SCENARIOS, STRESS_SCENARIOS, EXTRA_SCENARIOS):
        if name in table:
            return table[name]
    names = tuple(SCENARIOS) + tuple(STRESS_SCENARIOS) + tuple(EXTRA_SCENARIOS)
    raise ValueError(f"scenario must be one of {names}, got {name!r}")
