"""mjcable.Batch and mjcable.envs.BatchEnv: n copies stepped together equal n single Simulators (environments) bit
for bit, at any thread count; bad input and divergence are reported naming the key or the copy."""

import numpy as np
import pytest

import mjcable
from mjcable.batch import PARAMS, BatchDivergedError

SECONDS = 0.3  # s: the table cable (dropped from 0.25 m) lands after about 0.23 s, so contacts are in play


@pytest.fixture(scope="module")
def table():
    return mjcable.scenes.get("table", n_segments=12)


def _params(n):
    return {"damping": np.linspace(0.2, 2.0, n), "young": np.linspace(0.0, 2e6, n), "mass": np.linspace(0.05, 0.2, n),
            "friction": np.linspace(0.2, 1.0, n), "stretch_stiffness": np.linspace(500.0, 2000.0, n)}


@pytest.mark.parametrize("model", ["xpbd", "springs", "cosserat"])
def test_copies_equal_single_simulators_built_with_their_params(table, model):
    n = 3
    params = _params(n)
    batch = mjcable.Batch(table, model, n, threads=2, params=params)
    batch.step(SECONDS)
    traj = batch.rollout(0.02, every=4)
    assert batch.positions.shape == batch.velocities.shape == (n, 13, 3)
    assert traj.positions.shape == traj.velocities.shape == (n, len(traj.times), 13, 3)
    for i in (0, n - 1):  # the base values' copy and one with every parameter different
        cable = {key: float(values[i]) for key, values in params.items()}
        single = mjcable.Simulator(table.with_cable(**cable), model)
        single.step(SECONDS)
        alone = single.rollout(0.02, every=4)
        assert np.array_equal(batch.positions[i], single.positions)
        assert np.array_equal(batch.velocities[i], single.velocities)
        assert np.array_equal(traj.positions[i], alone.positions) and np.array_equal(traj.times, alone.times)
    # the parameters took effect: the copies differ (a batch ignoring params would fail the equalities above too)
    assert not np.array_equal(batch.positions[0], batch.positions[n - 1])
    assert batch.time == pytest.approx(SECONDS + 0.02) and batch.steps == single.steps


def test_threads_give_identical_results_and_reset_repeats_the_run(table):
    runs = {}
    for threads in (1, 2):
        batch = mjcable.Batch(table, "pbd", 4, threads=threads, params={"damping": [0.1, 0.5, 1.0, 3.0]})
        runs[threads] = batch.rollout(SECONDS, every=50)
        assert batch.threads == threads
    assert np.array_equal(runs[1].positions, runs[2].positions)
    assert np.array_equal(runs[1].velocities, runs[2].velocities)
    batch.reset()
    assert batch.time == 0.0
    assert np.array_equal(batch.rollout(SECONDS, every=50).positions, runs[2].positions)
    batch.close()


def test_default_threads_and_no_params(table):
    batch = mjcable.Batch(table, "xpbd", 2)
    assert 1 <= batch.threads <= 2 and batch.scenes == (table, table) and len(batch) == 2
    batch.step()  # one step, as Simulator.step()
    assert batch.steps == 1
    assert np.array_equal(batch.positions[0], batch.positions[1])


@pytest.mark.parametrize("params, match", [
    ({"radius": [0.01, 0.01]}, r"unknown key\(s\) \['radius'\]; allowed keys: \['young'"),
    ({"damping": [0.1, 0.2, 0.3]}, r"params\['damping'\] must have shape \(2,\).*got shape \(3,\)"),
    ({"damping": [[0.1, 0.2]]}, r"params\['damping'\] must have shape \(2,\)"),
    ({"mass": ["a", "b"]}, r"params\['mass'\] must be an array of 2 numbers"),
    ({"damping": [0.1, -1.0]}, r"copy 1: damping must be .*got -1"),
    ([0.1, 0.2], r"params must be a dict"),
])
def test_bad_params_are_rejected_naming_the_key(table, params, match):
    with pytest.raises(ValueError, match=match):
        mjcable.Batch(table, "xpbd", 2, params=params)


def test_bad_arguments_are_rejected(table):
    for kwargs, match in [({"n": 0}, "n must be an integer >= 1"), ({"n": 2, "threads": 0}, "threads"),
                          ({"n": 2, "dt": -1.0}, "dt"), ({"n": 2, "substeps": 0}, "substeps")]:
        with pytest.raises(ValueError, match=match):
            mjcable.Batch(table, "xpbd", **kwargs)
    with pytest.raises(ValueError, match="model"):
        mjcable.Batch(table, "nope", 2)
    with pytest.raises(ValueError, match="scene"):
        mjcable.Batch("table", "xpbd", 2)
    assert set(PARAMS) <= {f for f in mjcable.CableSpec.__dataclass_fields__}
    batch = mjcable.Batch(table, "xpbd", 2)
    with pytest.raises(ValueError, match="seconds"):
        batch.step(-1.0)
    with pytest.raises(ValueError, match="every"):
        batch.rollout(0.1, every=0)


def test_divergence_names_the_copy_after_the_others_have_stepped(table):
    batch = mjcable.Batch(table, "xpbd", 4, threads=2)
    reference = mjcable.Simulator(table, "xpbd")
    reference.step(0.1)

    def diverge(seconds=None):
        raise mjcable.SimulationDivergedError("xpbd", 7, 0.014, "a particle moved at 1e3 m/s")

    batch.simulators[2].step = diverge  # copy 2 blows up; the others must still take their steps
    with pytest.raises(mjcable.SimulationDivergedError, match="copy 2 of the batch of 4") as info:
        batch.step(0.1)
    assert isinstance(info.value, BatchDivergedError) and info.value.copy == 2 and info.value.copies == (2,)
    assert info.value.step == 7
    for i in (0, 1, 3):
        assert np.array_equal(batch.positions[i], reference.positions)
    with pytest.raises(RuntimeError, match=r"copies \[2\] of this batch diverged; call reset\(\)"):
        batch.step(0.1)
    del batch.simulators[2].step
    batch.reset()
    batch.step(0.1)
    assert np.array_equal(batch.positions[2], reference.positions)


@pytest.mark.envs
@pytest.mark.slow  # about 7 s
def test_batch_env_equals_single_environments():
    actions = np.random.default_rng(0).uniform(-1.0, 1.0, (4, 2, 3)) * 0.005  # reach_sag: one gripper, 3 numbers
    batch = mjcable.envs.load_batch("reach_sag", "xpbd", 2, random=5, threads=2, time_limit=1.0)
    first = batch.reset()
    steps = [batch.step(a) for a in actions]
    for i in range(2):
        env = mjcable.envs.load("reach_sag", "xpbd", random=5 + i, time_limit=1.0)
        alone = env.reset()
        for key in alone.observation:
            assert np.array_equal(alone.observation[key], first[i].observation[key])
        for a, rows in zip(actions, steps):
            alone = env.step(a[i])
            assert alone.reward == rows[i].reward
            for key in alone.observation:
                assert np.array_equal(alone.observation[key], rows[i].observation[key])
    assert not np.array_equal(steps[-1][0].observation["centreline"], steps[-1][1].observation["centreline"])
    with pytest.raises(ValueError, match=r"actions must have shape \(2, 3\)"):
        batch.step(np.zeros(3))
    with pytest.raises(ValueError, match="random must be"):
        mjcable.envs.load_batch("reach_sag", "xpbd", 2, random=[1])
    batch.close()


def test_params_with_a_missing_value_name_it():
    """A per-copy field left to its default for some copies only is a ValueError that shows the list, not "nan"."""
    with pytest.raises(ValueError, match=r"params\['stretch_stiffness'\] must be an array of 2 numbers \(shape "
                                         r"\(2,\)\), got \[None, 100\]"):
        mjcable.Batch(mjcable.scenes.get("table", n_segments=8), "xpbd", 2, params={"stretch_stiffness": [None, 100]})
