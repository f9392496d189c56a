"""The closed-loop diagram: systems, exported ports, no algebraic loop, committed DOT files."""

from pathlib import Path

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.primitives import LogVectorOutput

from eaplan_drake.diagram import LOGGED_SIGNALS, LoggedSignals, MakeEaplanDiagram
from eaplan_drake.loading import LoadScenario
from eaplan_drake.output.graphviz import DiagramDots
from eaplan_drake.params import Scenario

DIAGRAMS = Path(__file__).resolve().parents[1] / "diagrams"
SYSTEMS = {
    "wind",
    "plant",
    "sequencer",
    "guidance",
    "computation",
    "total_power",
    "sensor",
    "estimator",
    "battery",
    "planner",
}


def test_every_system_is_named_and_key_ports_are_exported():
    diagram = MakeEaplanDiagram(Scenario())
    names = {s.get_name() for s in diagram.GetSystems()}
    assert SYSTEMS <= names
    assert {"log_mux", "log"} <= names  # every logged signal through one sink
    for port in [*LOGGED_SIGNALS, "mission_complete"]:
        assert diagram.HasOutputPort(port)


def test_short_closed_loop_run_stays_finite():
    diagram = MakeEaplanDiagram(LoadScenario(data="planner: {warmup: 2.0}"), log_period=0.0)
    simulator = Simulator(diagram)
    simulator.AdvanceTo(5.0)  # crosses the warm-up: the planner solves a few times
    ctx = simulator.get_context()
    for port in [*LOGGED_SIGNALS, "mission_complete"]:
        assert np.all(np.isfinite(diagram.GetOutputPort(port).Eval(ctx))), port
    assert diagram.GetSubsystemByName("planner").statistics()["solves"] >= 3


def test_logged_signals_split_the_one_sink_into_the_exported_ports():
    diagram = MakeEaplanDiagram(LoadScenario(data="planner: {warmup: 2.0}"), log_period=0.5)
    simulator = Simulator(diagram)
    simulator.AdvanceTo(3.0)  # samples at 0, 0.5, …, 3.0: the last one at the context's time
    ctx = simulator.get_context()
    times, signals = LoggedSignals(diagram, ctx)
    np.testing.assert_allclose(times, np.arange(7) * 0.5, rtol=0, atol=1e-12)
    assert list(signals) == list(LOGGED_SIGNALS)
    for name, values in signals.items():
        now = diagram.GetOutputPort(name).Eval(ctx)
        assert values.shape == (7, now.size), name
        np.testing.assert_array_equal(values[-1], now, err_msg=name)
    unlogged = MakeEaplanDiagram(Scenario(), log_period=0.0)
    with pytest.raises(ValueError, match="no 'log' sink"):
        LoggedSignals(unlogged, unlogged.CreateDefaultContext())


def test_predicted_soc_is_logged_nan_before_the_planner_acts_and_finite_after():
    scenario = LoadScenario(data="planner: {policy: mpc, warmup: 2.0}")
    diagram = MakeEaplanDiagram(scenario, log_period=0.5)
    simulator = Simulator(diagram)
    simulator.AdvanceTo(4.0)
    times, signals = LoggedSignals(diagram, simulator.get_context())
    predicted = signals["predicted_soc"]
    assert predicted.shape == (times.size, 2)
    assert np.all(np.isnan(predicted[times < 2.0]))
    after = predicted[times > 2.0]
    assert after.size and np.all(np.isfinite(after))
    reserve = scenario.battery.reserve_soc
    assert np.all(after[:, 1] > reserve)  # reserve + a positive margin
    assert np.all((after[:, 0] > 0.0) & (after[:, 0] < 1.0))


def test_the_estimator_behind_an_averaging_sensor_uses_r_over_n():
    rates = "simulation: {max_step: 0.01}\nestimator: {rate: 10, measurement_noise: 0.3}\n"
    for averaging, n in ((False, 1), (True, 10)):
        text = rates + f"sensor: {{rate: 10, averaging: {str(averaging).lower()}}}\n"
        diagram = MakeEaplanDiagram(LoadScenario(data=text), log_period=0.0)
        assert diagram.GetSubsystemByName("sensor").base_steps_per_sample == n
        R = diagram.GetSubsystemByName("estimator").params.measurement_noise
        assert R == pytest.approx(0.3 / n, rel=1e-15)


def test_bad_scenario_is_rejected_before_building():
    s = Scenario()
    s.computation.initial_parameters = [10.0, 2.0]  # the PedNet table has one parameter
    with pytest.raises(ValueError, match="computation.initial_parameters"):
        MakeEaplanDiagram(s)


def test_committed_dot_files_match_the_code():
    dots = DiagramDots()
    committed = {p.stem: p.read_text() for p in DIAGRAMS.glob("*.dot")}
    assert set(committed) == set(dots), "run `eaplan-drake diagram` to regenerate diagrams/"
    for name, dot in dots.items():
        assert committed[name] == dot, f"diagrams/{name}.dot is stale: run `eaplan-drake diagram`"


def test_the_builders_make_an_open_loop_flight_at_constant_parameters():
    """An engineer's own diagram from the builders: the flight side at constant c1, the energy
    side at constant c2, no planner. The aircraft moves at its ground speed and the SoC falls as
    the Rint closed form says for the true power drawn."""
    from pydrake.systems.framework import DiagramBuilder

    from eaplan_drake.diagram import (
        AddEnergyLoop,
        AddGuidedAircraft,
        EnergyLoopArguments,
        GuidedAircraftArguments,
    )
    from eaplan_drake.energy.battery import SocDerivative
    from eaplan_drake.resolve import ResolveScenario

    resolved = ResolveScenario(Scenario())
    s, table, plan = resolved.scenario, resolved.table, resolved.plan
    builder = DiagramBuilder()
    aircraft = AddGuidedAircraft(
        builder,
        plan,
        **GuidedAircraftArguments(resolved),
        initial_path_parameter=-1000.0,
        path_parameter=-1000.0,
    )
    energy = AddEnergyLoop(
        builder,
        table,
        **EnergyLoopArguments(resolved, aircraft),
        computation_parameters=[4.0],
    )
    true_power = energy.total_power.get_output_port()
    logger = LogVectorOutput(true_power, builder, publish_period=s.simulation.max_step)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(10.0)
    ctx = simulator.get_context()

    def Value(system, port):
        return system.GetOutputPort(port).Eval(system.GetMyContextFromRoot(ctx))

    assert Value(energy.computation, "power")[0] == pytest.approx(table.power([4.0]), abs=1e-12)
    p0 = np.asarray(s.vehicle.initial_position)
    travelled = np.linalg.norm(Value(aircraft.plant, "position") - p0)
    assert 10.0 * (s.vehicle.airspeed - s.wind.speed) - 1.0 < travelled
    assert travelled < 10.0 * (s.vehicle.airspeed + s.wind.speed) + 1.0
    # The battery's updates at t_k = 0, h, …, 10 s − h discharge at the power held from the
    # previous update (0 at the first): b(10 s) = b0 + h Σ_{k<999} ḃ(y(t_k)).
    y = logger.FindLog(ctx).data()[0]
    h = s.simulation.max_step
    expected = s.battery.initial_soc + h * np.sum(SocDerivative(y[:999], s.battery))
    assert Value(energy.battery, "soc")[0] == pytest.approx(expected, abs=1e-9)


def test_a_plan_source_passed_to_the_diagram_is_the_one_flown():
    from eaplan_drake.flight.planfile import LoadPlanFile

    s = Scenario()
    plan = LoadPlanFile(
        "reference",
        s.vehicle,
        c1=0.0,
        k_e=s.guidance.k_e,
        c1_bounds=tuple(s.planner.path_parameter_bounds),
    )
    diagram = MakeEaplanDiagram(s, plan_source=plan, log_period=0.0)
    sequencer = diagram.GetSubsystemByName("sequencer")
    context = sequencer.GetMyContextFromRoot(diagram.CreateDefaultContext())
    assert sequencer.ActiveStage(context).path.descriptor().tolist() == (
        plan.Stages(0.0)[0].path.descriptor().tolist()
    )
