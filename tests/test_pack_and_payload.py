"""A pack below its label (``battery.health``) and a payload off its table
(``computation.power_offset``): what the plant draws and holds, and what the estimator and the
planner are told."""

import dataclasses as dc

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from eaplan_drake.diagram import MakeEaplanDiagram
from eaplan_drake.energy.battery import Battery, RintCurrent, UsablePack
from eaplan_drake.energy.computation import ComputationLoad, LoadComputationTable
from eaplan_drake.loading import LoadScenario
from eaplan_drake.params import BatteryParams


def _SocAfter(params: BatteryParams, power: float, t_end: float) -> float:
    builder = DiagramBuilder()
    load = builder.AddSystem(ConstantVectorSource([power]))
    battery = builder.AddSystem(Battery(params, time_step=0.01))
    builder.Connect(load.get_output_port(), battery.GetInputPort("power"))
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(t_end)
    return battery.GetOutputPort("soc").Eval(battery.GetMyContextFromRoot(simulator.get_context()))[
        0
    ]


def test_a_worn_pack_discharges_one_over_its_health_as_fast():
    """Under a constant 35 W the SoC falls by k_b I(y) t / (h Q_c) (t = 99.99 s of discharge by
    t = 100 s: the first update only samples the load): 1/h times the nominal pack's fall
    (Lemma III.3 on the usable capacity)."""
    nominal = BatteryParams()
    worn = dc.replace(nominal, health=0.8)
    current = RintCurrent(35.0, nominal.voltage, nominal.internal_resistance)
    drop = nominal.k_b * current * 99.99
    assert 1.0 - _SocAfter(nominal, 35.0, 100.0) == pytest.approx(drop / nominal.capacity, rel=1e-9)
    assert 1.0 - _SocAfter(worn, 35.0, 100.0) == pytest.approx(
        drop / (0.8 * nominal.capacity), rel=1e-9
    )


def test_the_battery_keeps_the_nominal_parameters_and_steps_the_usable_pack():
    worn = BatteryParams(health=0.85)
    battery = Battery(worn, time_step=0.01)
    assert battery.params.capacity == 3.2 and battery.params.health == 0.85
    assert battery.model.params.capacity == pytest.approx(0.85 * 3.2)
    assert UsablePack(BatteryParams()) is not None
    nominal = BatteryParams()
    assert UsablePack(nominal) is nominal  # health 1: the same parameters, bit for bit


def test_the_payload_draws_off_the_table_and_the_table_power_is_what_it_says():
    table = LoadComputationTable("pednet_jetson_nano")
    load = ComputationLoad(table, power_offset=-1.5)
    ctx = load.CreateDefaultContext()
    for c2 in (2.0, 7.0, 10.0):
        load.GetInputPort("computation_parameters").FixValue(ctx, [c2])
        assert load.GetOutputPort("table_power").Eval(ctx)[0] == table.power([c2])
        assert load.GetOutputPort("power").Eval(ctx)[0] == pytest.approx(table.power([c2]) - 1.5)
    exact = ComputationLoad(table)
    ctx = exact.CreateDefaultContext()
    exact.GetInputPort("computation_parameters").FixValue(ctx, [7.0])
    assert exact.GetOutputPort("power").Eval(ctx)[0] == table.power([7.0])
    with pytest.raises(ValueError, match="power_offset"):
        ComputationLoad(table, power_offset=float("nan"))


def test_the_plant_draws_the_offset_and_the_estimator_is_told_the_table():
    s = LoadScenario(data="computation: {power_offset: 2.0}\nplanner: {policy: static}")
    diagram = MakeEaplanDiagram(s, log_period=0.0)
    simulator = Simulator(diagram)
    simulator.Initialize()
    ctx = simulator.get_context()
    computation = diagram.GetSubsystemByName("computation")
    estimator = diagram.GetSubsystemByName("estimator")
    c_ctx = computation.GetMyContextFromRoot(ctx)
    told = estimator.GetInputPort("computation_power").Eval(estimator.GetMyContextFromRoot(ctx))
    drawn = computation.GetOutputPort("power").Eval(c_ctx)[0]
    assert told[0] == computation.GetOutputPort("table_power").Eval(c_ctx)[0]
    assert drawn == pytest.approx(told[0] + 2.0)
    total = diagram.GetSubsystemByName("total_power")
    plant = diagram.GetSubsystemByName("plant")
    motion = plant.GetOutputPort("motion_power").Eval(plant.GetMyContextFromRoot(ctx))[0]
    y = total.get_output_port().Eval(total.GetMyContextFromRoot(ctx))[0]
    assert y == pytest.approx(motion + drawn)
    assert np.isfinite(y)


def test_the_pack_and_payload_keys_are_checked_and_named():
    from eaplan_drake.params import ScenarioError

    for data, match in (
        ("battery: {health: 1.2}", r"battery.health: must be in \[0.1, 1\]"),
        ("battery: {health: 0.05}", r"battery.health: must be in \[0.1, 1\]"),
        (
            "computation: {power_offset: -101}",
            r"computation.power_offset: must be in \[-100, 100\]",
        ),
        ("computation: {power_offset: .nan}", "computation.power_offset: must be finite"),
    ):
        with pytest.raises(ScenarioError, match=match):
            LoadScenario(data=data)


@pytest.mark.parametrize(
    "label",
    [{"capacity": 3.2, "cells": 4}, {"capacity_mah": 3200.0, "cells": 4}, {"energy_wh": 47.36}],
    ids=["Ah", "mAh", "Wh"],
)
def test_the_health_scales_a_pack_however_its_label_is_given(label):
    from eaplan_drake.params import BatteryParams

    nominal = BatteryParams(**label)
    worn = UsablePack(BatteryParams(**label, health=0.85))
    assert worn.Capacity() == pytest.approx(0.85 * nominal.Capacity(), rel=1e-12)
    assert worn.Voltage() == nominal.Voltage() and worn.health == 1.0
