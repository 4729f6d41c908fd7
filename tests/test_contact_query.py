"""The particle solvers' contact query (``mjcable.solvers.query_kernels.contacts_from_mujoco``) against geometry."""

import mjcable


def test_a_cable_resting_on_a_table_has_one_contact_per_particle():
    """A straight cable lying on a flat face touches it at every particle, once: MuJoCo gives each of the two
    capsules meeting at a particle an end contact there (a few 1e-6 of the segment off its end), and the query
    keeps one, so that the solver does not project the same constraint twice."""
    scene = mjcable.scenes.get("table")
    sim = mjcable.Simulator(scene, "xpbd")
    sim.step(1.0)
    z = sim.positions[:, 2]
    assert z.max() - z.min() < 1e-6  # at rest on the table top, every particle on it
    assert sim.diagnostics["contacts"] == scene.cable.n_segments + 1
