"""The guidance loop alone (notebook 02's flights): path error and a short flight."""

import numpy as np
import pytest

from eaplan_drake.coverage import MakeCoveragePlan
from eaplan_drake.params import Scenario
from eaplan_drake.paths import Circle, Line
from eaplan_drake.tracking import FlyTracking, MakeTrackingDiagram, PathError


def test_path_error_is_the_normalised_path_function():
    circle = Circle((0.0, 0.0), 10.0, k_e=0.05).normalised()
    line = Line((0.0, 5.0), (0.0, 1.0), k_e=0.05).normalised()
    p = np.array([[12.0, 0.0], [3.0, 8.0]])
    d = np.vstack([circle.descriptor(), line.descriptor()])
    np.testing.assert_allclose(PathError(p, d), [circle.value(p[0]), line.value(p[1])])
    assert PathError([[12.0, 0.0]], circle.descriptor()[None])[0] == pytest.approx(2.2)


def test_a_short_tracking_flight_follows_the_plan():
    s = Scenario()
    plan = MakeCoveragePlan(s.coverage, s.vehicle, c1=-1000.0, k_e=s.guidance.k_e)
    f = FlyTracking(plan, -1000.0, (5.0, 0.0), t_max=40.0)
    assert not f["complete"] and f["t_end"] == pytest.approx(40.0)
    assert f["position"].shape == (len(f["t"]), 2) and len(f["t"]) == 401
    np.testing.assert_allclose(f["position"][0], s.vehicle.initial_position)
    assert np.max(np.abs(f["phi"][f["t"] > 30.0])) < 1.0  # converged onto the path
    with pytest.raises(ValueError, match="finite"):
        MakeTrackingDiagram(plan, float("nan"), (0.0, 0.0))
