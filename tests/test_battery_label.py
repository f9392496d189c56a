"""A battery entered as on its label (capacity and cells, or energy) and the two Ah-to-seconds
conversions: the physical one (default) and the authors' scaling of the reference scenarios."""

import pytest

from eaplan_drake.energy.battery import RintCurrent, TimeToSoc
from eaplan_drake.errors import ScenarioError
from eaplan_drake.loading import LoadNamedScenario, LoadScenario
from eaplan_drake.params import AUTHORS_K_B, PHYSICAL_K_B, BatteryParams

LOAD = 30.0  # W, a small fixed-wing's cruise


def DeliveredWh(params: BatteryParams, load: float = LOAD) -> float:
    """Energy the pack delivers at the terminals from full to empty under a constant load [Wh],
    from the model's own time to empty (not from the label arithmetic)."""
    return load * TimeToSoc(1.0, 0.0, load, params) / 3600.0


def InternalWh(params: BatteryParams, load: float = LOAD) -> float:
    """Energy the internal source gives from full to empty, V I t [Wh] (terminal + R_r losses)."""
    current = RintCurrent(load, params.Voltage(), params.internal_resistance)
    return params.Voltage() * current * TimeToSoc(1.0, 0.0, load, params) / 3600.0


@pytest.mark.parametrize(
    "label",
    [
        {"capacity": 3.2, "cells": 4},
        {"capacity_mah": 3200.0, "cells": 4},
        {"capacity_mah": 3200.0, "voltage": 14.8},
        {"capacity": 3.2},  # the default 14.8 V is 4S
    ],
)
def test_a_3200_mah_4s_pack_delivers_its_physical_47_wh(label):
    params = BatteryParams(**label)
    params.Validate()
    assert params.Capacity() == pytest.approx(3.2, rel=1e-12)
    assert params.Voltage() == pytest.approx(14.8, rel=1e-12)
    assert InternalWh(params) == pytest.approx(3.2 * 14.8, rel=1e-9)  # Q_c V, exactly
    assert DeliveredWh(params) == pytest.approx(47.36, rel=0.01)  # R_r I² t is < 1 %
    assert params.Energy() == pytest.approx(47.36 * 3600.0, rel=1e-12)


def test_a_pack_entered_as_47_wh_delivers_47_wh():
    for label in ({"energy_wh": 47.0}, {"energy_wh": 47.0, "cells": 6}):
        params = BatteryParams(**label)
        params.Validate()
        assert InternalWh(params) == pytest.approx(47.0, rel=1e-9)
        assert DeliveredWh(params) == pytest.approx(47.0, rel=0.01)
    assert BatteryParams(energy_wh=47.0, cells=6).Capacity() == pytest.approx(47.0 / 22.2)


def test_the_authors_scaling_holds_6_6_times_less_energy_than_the_label():
    authors = BatteryParams(capacity=3.2, k_b=AUTHORS_K_B)
    physical = BatteryParams(capacity=3.2)
    assert physical.k_b == PHYSICAL_K_B
    ratio = DeliveredWh(physical) / DeliveredWh(authors)
    assert ratio == pytest.approx(AUTHORS_K_B * 3600.0, rel=1e-12)
    assert 6.58 < ratio < 6.59
    assert DeliveredWh(authors) == pytest.approx(7.19, rel=0.01)


def test_a_label_in_yaml_and_set_from_the_command_line():
    s = LoadScenario(data="battery: {capacity_mah: 5000, cells: 3}\n")
    assert s.battery.Capacity() == 5.0 and s.battery.Voltage() == pytest.approx(11.1)
    s = LoadScenario(data="battery: {energy_wh: 47}\n")
    assert s.battery.Energy() / 3600.0 == pytest.approx(47.0, rel=1e-12)


@pytest.mark.parametrize(
    "label, message",
    [
        ({"capacity_mah": 3200.0, "energy_wh": 47.0}, "battery.energy_wh: give the pack's size"),
        ({"capacity": 2.0, "capacity_mah": 3200.0}, "battery.capacity_mah: give the pack's size"),
        ({"cells": 4, "voltage": 12.0}, "battery.cells: 4S is 14.8 V nominal"),
        ({"cells": 2.5}, r"battery.cells: "),
        ({"capacity_mah": -1.0}, "battery.capacity_mah: must be >= 0"),
    ],
)
def test_a_label_given_twice_or_wrong_is_one_line_naming_the_key(label, message):
    with pytest.raises(ScenarioError, match=message):
        BatteryParams(**label).Validate()


def test_reference_scenarios_keep_the_authors_scaling_and_survey_its_energy():
    for name in ("plan_I", "plan_II", "plan_i", "plan_ii"):
        assert LoadNamedScenario(name).battery.k_b == AUTHORS_K_B
    papers = BatteryParams(capacity=3.2, k_b=AUTHORS_K_B)
    survey = LoadNamedScenario("survey").battery
    assert survey.k_b == PHYSICAL_K_B
    assert survey.Energy() == pytest.approx(papers.Energy(), rel=1e-5)
    funen = LoadNamedScenario("funen").battery
    assert funen.Energy() == pytest.approx(1.6 * papers.Energy(), rel=1e-5)


def test_a_label_set_over_a_scenario_replaces_its_pack():
    from eaplan_drake.loading import LayerScenario, OverrideFromAssignment

    survey = LoadNamedScenario("survey")  # states capacity: 0.485732 Ah
    sets = ["battery.capacity_mah=3300", "battery.cells=3"]
    s = LayerScenario(survey, [OverrideFromAssignment(a) for a in sets])
    assert s.battery.Capacity() == 3.3 and s.battery.Voltage() == pytest.approx(11.1)
    assert s.battery.capacity == 3.2 and s.battery.voltage == 14.8  # back to "not given"
    s = LayerScenario(s, [OverrideFromAssignment("battery.energy_wh=47")])
    assert s.battery.Energy() / 3600.0 == pytest.approx(47.0) and s.battery.capacity_mah == 0.0
    # within one layer, two sizes are still two sizes
    with pytest.raises(ScenarioError, match="battery.energy_wh: give the pack's size once"):
        LayerScenario(survey, ["battery: {capacity_mah: 3300, energy_wh: 47}\n"])
