"""The mpc reads the remaining-time staircase by its steps (StaircaseSteps): plans that fly the
same repetitions are priced alike, so c1 does not follow sub-second turn-length differences."""

import numpy as np
import pytest

from eaplan_drake.planning.mpc import StaircaseSteps


def test_each_step_takes_its_longest_time():
    t = [10.0, 10.4, 10.9, 70.0, 70.5, 130.0]
    np.testing.assert_array_equal(StaircaseSteps(t, 1.0), [10.9, 10.9, 10.9, 70.5, 70.5, 130.0])


def test_order_of_the_grid_is_kept():
    # the staircase of a grid need not ascend: within a step a larger c1 may turn shorter
    t = np.array([70.5, 10.4, 130.0, 10.9, 70.0, 10.0])
    np.testing.assert_array_equal(StaircaseSteps(t, 1.0), [70.5, 10.9, 130.0, 10.9, 70.5, 10.9])


def test_steps_are_never_shorter_and_gaps_stay():
    rng = np.random.default_rng(3)
    reps = rng.integers(0, 6, size=40) * 55.0
    t = reps + rng.uniform(0.0, 0.9, size=40)
    out = StaircaseSteps(t, 1.0)
    assert np.all(out >= t)
    assert np.all(out - t < 0.9 + 1e-12)  # no step absorbs another (55 s apart)
    for r in np.unique(reps):
        on_step = reps == r
        assert np.all(out[on_step] == t[on_step].max())


def test_a_chain_of_small_gaps_is_one_step():
    # single linkage: each gap below the resolution joins (a field whose turns grow by < h)
    np.testing.assert_array_equal(StaircaseSteps([0.0, 0.9, 1.8, 2.7], 1.0), [2.7] * 4)
    np.testing.assert_array_equal(StaircaseSteps([0.0, 1.0, 2.0], 1.0), [0.0, 1.0, 2.0])


@pytest.mark.parametrize("t", [[], [5.0], [3.0, 3.0]])
def test_small_and_equal(t):
    out = StaircaseSteps(t, 1.0)
    assert out.shape == (len(t),)
    if len(t):
        assert np.all(out == max(t))


def _Reversals(c1) -> int:
    d = np.diff(np.asarray(c1, dtype=float))
    d = d[np.abs(d) > 1e-9]
    return int(np.sum(np.sign(d[1:]) != np.sign(d[:-1])))


@pytest.mark.parametrize("world", [0, 14])
def test_the_mpc_does_not_chatter_along_a_step(world):
    # certify's worlds 0 and 14: c1 reversed 40 and 18 times when the grid's remaining times
    # were read one by one (sub-second turn-length differences at the edge of the risk budget)
    from eaplan_drake.simulation import Simulate
    from eaplan_drake.studies.certify import CertifyStudy
    from eaplan_drake.studies.sweep import StudyFlights

    flights = StudyFlights(CertifyStudy("survey", world + 1, changing=False))
    scenario = next(s for k, s in flights if k["world"] == world and k["policy"] != "lowest")
    log = Simulate(scenario)
    assert log.summary["status"] == "complete"
    assert _Reversals(np.asarray(log["path_parameters"])[:, 0]) <= 2
