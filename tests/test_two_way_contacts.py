"""Two-way contacts of the particle solvers in a user world (issue 10): the world's bodies feel the cable through
its contacts (:mod:`mjcable.backends.host`), normal and friction, as equal and opposite forces.

Physics references, measured in MuJoCo's own terms:

* statics: a box on a table carrying a cable that lies on its top presses the table with (M + m) g (MuJoCo's
  contact force, ``mj_contactForce``); a box held up by a spring sags by (M + m) g / k;
* kinetic friction: a box sliding on a frictionless slide under a cable at rest decelerates at μ m g / M while
  the cable slides on it, and the momentum M v_box + Σ m_p v_p stays M v₀ (Newton's third law);

both far from what an uncoupled world gives (the box carrying only its own weight, 17 % less; sliding on at v₀).
"""

import warnings

import mujoco
import numpy as np
import pytest

from mjcable import CableSpec, Scene, Simulator

SOLVERS = ("xpbd", "pbd", "jakobsen")
G = 9.81
HALF, RADIUS, CABLE_MASS, MU = 0.1, 0.005, 0.1, 0.3


def _sim(xml: str, model: str, **kw) -> Simulator:
    # a straight cable lying on the box's top (z = 2 HALF), well inside its edges, so that the box carries all of it
    z = 2 * HALF + RADIUS
    cable = CableSpec([[-0.06, 0, z], [0.06, 0, z]], 12, RADIUS, CABLE_MASS, friction=MU)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Simulator(Scene(cable, (), world=mujoco.MjSpec.from_string(xml)), model, dt=0.002, **kw)


# ---------------------------------------------------------------------------------------------------------- weight

BOX_MASS = 0.5
TABLE_XML = f"""<mujoco><worldbody>
  <geom name="table" type="box" size="0.5 0.5 0.05" pos="0 0 -0.05"/>
  <body name="box" pos="0 0 {HALF}"><freejoint/>
    <geom name="box" type="box" size="{HALF} {HALF} {HALF}" mass="{BOX_MASS}"/></body>
  </worldbody></mujoco>"""


def _table_load(sim: Simulator, steps: int = 25) -> float:
    """N: the table's normal force on the box (MuJoCo's contact forces between the two), averaged over steps."""
    m, d = sim.mj_model, sim.mj_data
    table, box = m.geom("table").id, m.geom("box").id
    f6 = np.zeros(6)
    total = 0.0
    for _ in range(steps):
        sim.step()
        for i in range(d.ncon):
            if {int(d.contact.geom1[i]), int(d.contact.geom2[i])} == {table, box}:
                mujoco.mj_contactForce(m, d, i, f6)
                total += f6[0]
    return total / steps


@pytest.mark.parametrize("model", SOLVERS)
def test_a_box_carries_the_weight_of_a_cable_lying_on_it(model):
    sim = _sim(TABLE_XML, model)
    sim.step(0.5)
    load = _table_load(sim)
    weight = (BOX_MASS + CABLE_MASS) * G
    assert load == pytest.approx(weight, rel=0.02), f"{model}: table load {load:.4f} N, (M + m) g {weight:.4f} N"
    # the cable rests on the box's top
    top = sim.mj_data.body("box").xpos[2] + HALF
    assert np.allclose(sim.positions[:, 2], top + RADIUS, atol=1e-4)


SPRING_K = 200.0  # N/m


def _spring_xml(mass: float) -> str:
    return f"""<mujoco><worldbody>
  <body name="box" pos="0 0 {HALF}"><joint name="lift" type="slide" axis="0 0 1" stiffness="{SPRING_K}" damping="5"/>
    <geom name="box" type="box" size="{HALF} {HALF} {HALF}" mass="{mass}"/></body>
  </worldbody></mujoco>"""


@pytest.mark.parametrize("mass", [0.5, 0.125])
def test_a_box_on_a_spring_sags_under_the_cable_on_it(mass):
    """Hooke: the box sinks by (M + m) g / k, also for a box only 1.25 times the cable's mass (inside the explicit
    coupling's limit m / M < 1, see mjcable.backends.host), and comes to rest."""
    sim = _sim(_spring_xml(mass), "xpbd")
    sim.step(1.5)
    sag = []
    for _ in range(25):
        sim.step()
        sag.append(-sim.mj_data.joint("lift").qpos[0])
    expected = (mass + CABLE_MASS) * G / SPRING_K
    assert np.mean(sag) == pytest.approx(expected, rel=0.01)
    assert np.std(sag) < 1e-3 * expected


# -------------------------------------------------------------------------------------------------------- friction

V0 = 0.3  # m/s


def _slide_xml(mass: float) -> str:
    # a frictionless slide joint carries the box (and everything on it) vertically
    return f"""<mujoco><worldbody>
  <body name="box" pos="0 0 {HALF}"><joint name="slide" type="slide" axis="1 0 0"/>
    <geom name="box" type="box" size="{HALF} {HALF} {HALF}" mass="{mass}" friction="{MU}"/></body>
  </worldbody></mujoco>"""


def _slide(model: str, mass: float, duration: float = 0.2) -> tuple:
    """The box sent off at V0 under a cable at rest: times, box velocity and the cable's mean velocity (along x),
    and the momentum along x, for ``duration`` s."""
    sim = _sim(_slide_xml(mass), model)
    sim.step(0.05)  # the cable settles on the box
    sim.mj_data.joint("slide").qvel[0] = V0
    masses = sim.particle_masses
    t, box, cable, momentum = [], [], [], []
    for _ in range(int(round(duration / sim.dt))):
        sim.step()
        v = sim.velocities[:, 0]
        t.append(sim.time)
        box.append(sim.mj_data.joint("slide").qvel[0])
        cable.append(float(masses @ v) / float(masses.sum()))
        momentum.append(mass * box[-1] + float(masses @ v))
    return tuple(map(np.array, (t, box, cable, momentum)))


@pytest.mark.parametrize("model", SOLVERS)
def test_a_cable_sliding_on_a_box_brakes_it_with_kinetic_friction(model):
    mass = 0.5
    t, box, cable, momentum = _slide(model, mass)
    sliding = box - cable > 0.05 * V0
    assert sliding.sum() > 10
    # the box's deceleration while the cable slides on it: μ m g / M (a straight line through the sliding phase)
    decel = -np.polyfit(t[sliding][2:], box[sliding][2:], 1)[0]
    expected = MU * CABLE_MASS * G / mass
    assert decel == pytest.approx(expected, rel=0.05), f"{model}: box decelerates at {decel:.4f}, μmg/M {expected:.4f}"
    # equal and opposite: momentum kept, and both end at the common velocity M v₀ / (M + m)
    np.testing.assert_allclose(momentum, mass * V0, rtol=0.01)
    assert box[-1] == pytest.approx(mass * V0 / (mass + CABLE_MASS), rel=0.01)
    assert cable[-1] == pytest.approx(box[-1], rel=0.01)


# --------------------------------------------------------------------------------------------------------- squeeze

WEIGHT = 0.5
SQUEEZE_MASS, SQUEEZE_PULL = 0.05, 0.02  # kg of cable; m/s of the gripper
DRAG_STIFFNESS = 1000.0  # N/m: the spring that holds the weight against the cable's drag along it
SQUEEZE_XML = f"""<mujoco><worldbody>
  <geom name="table" type="box" size="0.5 0.2 0.05" pos="0 0 -0.05" friction="{MU}"/>
  <body name="weight" pos="0 0 {2 * RADIUS + 0.02}"><joint name="lift" type="slide" axis="0 0 1"/>
    <joint name="drag" type="slide" axis="1 0 0" stiffness="{DRAG_STIFFNESS}" damping="20"/>
    <geom name="weight" type="box" size="0.05 0.05 0.02" mass="{WEIGHT}" friction="{MU}"/></body>
  </worldbody></mujoco>"""


def _squeeze(model: str, **kw) -> tuple:
    """A cable on a table with a weight (on a vertical slide) lying on its middle, pulled out from under it at a
    steady speed by a gripper at its end: the mean pull (N, along the cable) and the mean drag on the weight (N,
    from the stretch of the spring that holds it) while it slides."""
    from mjcable import Pin
    cable = CableSpec([[-0.2, 0, RADIUS], [0.2, 0, RADIUS]], 20, RADIUS, SQUEEZE_MASS, friction=MU)
    scene = Scene(cable, (Pin(20, "gripper"),), (), world=mujoco.MjSpec.from_string(SQUEEZE_XML))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulator(scene, model, dt=0.002, **kw)
    sim.step(0.3)
    start = sim.gripper_positions[0].copy()
    pull, on_weight = [], []
    for k in range(500):
        sim.move_gripper(0, start + [SQUEEZE_PULL * (k + 1) * sim.dt, 0.0, 0.0])
        sim.step()
        if k >= 200:
            pull.append(sim.pin_forces[0][0])
            on_weight.append(DRAG_STIFFNESS * sim.mj_data.joint("drag").qpos[0])
    return float(np.mean(pull)), float(np.mean(on_weight))


def test_a_cable_squeezed_under_a_weight_rubs_on_both_faces():
    """Coulomb on both faces: pulling the cable out from under a weight W takes μ (2 W + m) g (the weight's face
    μ W g, the table's μ (W + m) g), and the weight is dragged along by μ W g while it rests on the cable. With the
    two faces' normals cancelling in the particles' friction cone, the pull would be μ m g only."""
    pull, on_weight = _squeeze("xpbd")
    assert pull == pytest.approx(MU * G * (2 * WEIGHT + SQUEEZE_MASS), rel=0.03)
    assert on_weight == pytest.approx(MU * WEIGHT * G, rel=0.03)


@pytest.mark.xfail(strict=True, reason="known limitation: with Gauss-Seidel orders a squeezing body's explicit "
                                        "contact force alternates between 0 and 2 W g from substep to substep, "
                                        "and the single sweep then keeps about a quarter of the friction")
def test_gauss_seidel_orders_lose_friction_under_a_chattering_squeeze():
    pull, _ = _squeeze("xpbd", order="gauss-seidel")
    assert pull == pytest.approx(MU * G * (2 * WEIGHT + SQUEEZE_MASS), rel=0.1)
