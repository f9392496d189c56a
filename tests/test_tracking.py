"""The guidance loop alone (notebook 02's flights): path error and a short flight per plant."""

import numpy as np
import pytest

from eaplan_drake.flight.coverage import MakeCoveragePlan
from eaplan_drake.flight.paths import Circle, Line
from eaplan_drake.params import Scenario
from eaplan_drake.studies.tracking import FlyTracking, MakeTrackingDiagram, PathError


def test_path_error_is_the_normalised_path_function():
    circle = Circle((0.0, 0.0), 10.0, k_e=0.05).normalised()
    line = Line((0.0, 5.0), (0.0, 1.0), k_e=0.05).normalised()
    p = np.array([[12.0, 0.0], [3.0, 8.0]])
    d = np.vstack([circle.descriptor(), line.descriptor()])
    np.testing.assert_allclose(PathError(p, d), [circle.value(p[0]), line.value(p[1])])
    assert PathError([[12.0, 0.0]], circle.descriptor()[None])[0] == pytest.approx(2.2)


@pytest.mark.parametrize("plant", ["continuous", "exact_arc"])
def test_a_short_tracking_flight_follows_the_plan(plant):
    s = Scenario()
    s.simulation.plant = plant
    plan = MakeCoveragePlan(s.coverage, s.vehicle, c1=-1000.0, k_e=s.guidance.k_e)
    f = FlyTracking(s, plan, -1000.0, t_max=40.0)
    assert not f["complete"] and f["t_end"] == pytest.approx(40.0)
    assert f["position"].shape == (len(f["t"]), 2) and len(f["t"]) == 401
    np.testing.assert_allclose(f["position"][0], s.vehicle.initial_position)
    assert np.max(np.abs(f["phi"][f["t"] > 30.0])) < 1.0  # converged onto the path
    with pytest.raises(ValueError, match="finite"):
        MakeTrackingDiagram(s, plan, float("nan"))


def test_tracking_takes_its_plant_from_the_scenario():
    s = Scenario()
    plan = MakeCoveragePlan(s.coverage, s.vehicle, c1=-1000.0, k_e=s.guidance.k_e)
    for name, has_continuous_state in (("continuous", True), ("exact_arc", False)):
        s.simulation.plant = name
        plant = MakeTrackingDiagram(s, plan, 0.0).GetSubsystemByName("plant")
        assert (plant.num_continuous_states() == 3) == has_continuous_state
