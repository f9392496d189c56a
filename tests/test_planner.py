"""Tests of the PlannerScheduler system (planning/planner.py): ports, update times, statistics,
fallback and the predicted-SoC port."""

import math

import numpy as np
import pytest
from planner_cases import COVERAGE_TIMES, ORDER, PERIOD, Q_REF
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from eaplan_drake.params import BatteryParams, FaultModelParams, PlannerParams
from eaplan_drake.planning.planner import PlannerScheduler
from eaplan_drake.planning.policies import MakePolicy

# -- the system ---------------------------------------------------------------------------------

GRID = np.linspace(-1000.0, 0.0, 21)


def _Policy(params, table, integer=True):
    """The policy ``params.policy`` names for these tests' battery, coverage times and grid."""
    return MakePolicy(
        params,
        table,
        ORDER,
        BatteryParams(),
        coverage_time_bounds=COVERAGE_TIMES,
        path_parameter_grid=GRID,
        integer=integer,
    )


def _Scheduler(params, table, c2_0, policy=None, integer=True):
    """A PlannerScheduler around ``params.policy`` (the paper's by default in these tests)."""
    policy = policy or _Policy(params, table, integer)
    return PlannerScheduler(
        params,
        policy=policy,
        table=table,
        order=ORDER,
        initial_path_parameter=params.initial_path_parameters[0],
        initial_computation_parameters=c2_0,
    )


def _Diagram(system, soc=0.68, q=Q_REF, publish_period=0.1):
    builder = DiagramBuilder()
    builder.AddSystem(system)
    for name, value in (
        ("energy_coefficients", q),
        ("mean_power_variance", [1e-4]),
        ("soc", [soc]),
        ("period", [PERIOD]),
        ("coverage_remaining", [0.5]),
        ("remaining_time", np.linspace(135.0, 353.0, GRID.size)),
    ):
        source = builder.AddSystem(ConstantVectorSource(np.asarray(value, dtype=float)))
        builder.Connect(source.get_output_port(), system.GetInputPort(name))
    logs = [
        LogVectorOutput(system.GetOutputPort(name), builder, publish_period=publish_period)
        for name in ("path_parameters", "computation_parameters", "mission_feasible")
    ]
    return builder.Build(), logs


def test_system_ports(table, table2):
    system = _Scheduler(PlannerParams(policy="paper"), table2, [2.0, 4.0])
    sizes = {
        "energy_coefficients": 7,
        "mean_power_variance": 1,
        "soc": 1,
        "period": 1,
        "coverage_remaining": 1,
        "remaining_time": GRID.size,
    }
    assert system.num_input_ports() == len(sizes)
    for name, size in sizes.items():
        assert system.GetInputPort(name).size() == size
    assert system.GetOutputPort("path_parameters").size() == 1
    assert system.GetOutputPort("computation_parameters").size() == 2
    assert system.GetOutputPort("mission_feasible").size() == 1
    assert system.table is table2
    assert system.policy.name == "paper"
    context = system.CreateDefaultContext()  # outputs need no input (no direct feedthrough)
    np.testing.assert_array_equal(
        system.GetOutputPort("computation_parameters").Eval(context), [2, 4]
    )
    assert system.GetOutputPort("path_parameters").Eval(context)[0] == 0.0
    assert system.GetOutputPort("mission_feasible").Eval(context)[0] == 1.0
    for port in ("path_parameters", "computation_parameters", "mission_feasible"):
        for i in range(len(sizes)):
            assert not system.HasDirectFeedthrough(i, system.GetOutputPort(port).get_index())
    with pytest.raises(ValueError, match="initial_computation_parameters"):
        _Scheduler(PlannerParams(policy="paper"), table, [12.0])
    with pytest.raises(ValueError, match="coverage_time_bounds"):
        MakePolicy(
            PlannerParams(policy="paper"),
            table,
            ORDER,
            BatteryParams(),
            coverage_time_bounds=(0.0, 10.0),
            path_parameter_grid=GRID,
        )
    with pytest.raises(ValueError, match="policy: must be a PlannerPolicy"):
        PlannerScheduler(
            PlannerParams(),
            policy=object(),
            table=table,
            order=ORDER,
            initial_path_parameter=0.0,
            initial_computation_parameters=[2.0],
        )
    with pytest.raises(ValueError, match="planner.period"):
        _Scheduler(PlannerParams(policy="paper", period=-1.0), table, [2.0], policy=system.policy)


def test_system_copies_its_params_and_uses_the_given_policy(table):
    params = PlannerParams(policy="paper", warmup=2.0, period=1.0)
    policy = _Policy(params, table)
    system = _Scheduler(params, table, [10.0], policy=policy)
    assert system.policy is policy  # the scheduler never builds its own
    params.period, params.warmup, params.path_parameter_grid_size = 5.0, 0.0, 3
    assert system.params.period == 1.0 and system.params.warmup == 2.0
    assert system.GetInputPort("remaining_time").size() == GRID.size
    diagram, _ = _Diagram(system)
    simulator = Simulator(diagram)
    simulator.AdvanceTo(4.5)
    assert system.statistics()["solves"] == 3  # t = 2, 3, 4: the copied period and warm-up


def test_system_outputs_change_only_at_update_times(table):
    params = PlannerParams(policy="paper", warmup=2.0, period=1.0)
    system = _Scheduler(params, table, [10.0])
    diagram, logs = _Diagram(system)
    simulator = Simulator(diagram)
    simulator.AdvanceTo(6.5)
    context = simulator.get_context()
    stats = system.statistics()
    assert stats["solves"] == 5  # t = 2, 3, 4, 5, 6
    assert stats["failures"] == 0
    assert len(stats["step_times"]) == 5 and stats["median_step_time"] > 0.0
    for log in logs:
        log = log.FindLog(context)
        t, data = log.sample_times(), log.data()
        assert np.all(np.isfinite(data))
        jumps = np.flatnonzero(np.any(np.diff(data, axis=1) != 0.0, axis=0))
        for j in jumps:  # a change between samples t_j, t_{j+1} brackets an update time ≥ warm-up
            k = math.floor(t[j + 1] + 1e-9)
            assert t[j] <= k <= t[j + 1] and k >= 2.0
    c2 = logs[1].FindLog(context).data()[0]
    assert np.all(c2[logs[1].FindLog(context).sample_times() <= 2.0] == 10.0)  # warm-up
    assert c2[-1] < 10.0  # the planner acted (budget 32 W is below the initial load)
    assert set(c2) <= set(table.parameter_grids[0])


def test_system_static_holds_initial_parameters(table):
    params = PlannerParams(policy="static", warmup=0.0)
    params.initial_path_parameters = [-1000.0]
    system = _Scheduler(params, table, [2.0])
    diagram, logs = _Diagram(system, soc=1.0)
    simulator = Simulator(diagram)
    simulator.AdvanceTo(3.0)
    context = simulator.get_context()
    np.testing.assert_array_equal(logs[0].FindLog(context).data(), -1000.0)
    np.testing.assert_array_equal(logs[1].FindLog(context).data(), 2.0)
    assert system.statistics()["solves"] == 0


def test_system_forced_failure_is_counted_and_falls_back(table):
    params = PlannerParams(policy="paper", warmup=0.0, max_iterations=1)
    system = _Scheduler(params, table, [10.0], integer=False)  # continuous c2 solves the NLP
    diagram, logs = _Diagram(system, soc=1.0)
    simulator = Simulator(diagram)
    simulator.AdvanceTo(2.5)
    stats = system.statistics()
    assert stats["solves"] == 3 and stats["failures"] == 3
    context = simulator.get_context()
    c1 = logs[0].FindLog(context).data()[0]
    c2 = logs[1].FindLog(context).data()[0]
    # Deterministic fallback: c1 kept, the largest c2 the exact check admits (all of it at b = 1).
    np.testing.assert_array_equal(c1, 0.0)
    np.testing.assert_array_equal(c2, 10.0)
    system.reset_statistics()
    assert system.statistics()["solves"] == 0


def test_mpc_decision_predicts_its_end_soc_and_the_port_shows_it(table):
    # the point belief: the port's update at t = 1 then plans as the decision at t = 0 did (a
    # learning belief also learns from the second flown between them)
    point = FaultModelParams().PointModel()
    params = PlannerParams(policy="mpc", warmup=1.0, period=1.0, fault_model=point)
    policy = _Policy(params, table)
    system = _Scheduler(params, table, [10.0], policy=policy)
    assert system.GetOutputPort("predicted_soc").size() == 2
    context = system.CreateDefaultContext()
    assert np.all(np.isnan(system.GetOutputPort("predicted_soc").Eval(context)))
    diagram, _ = _Diagram(system)
    dcontext = diagram.CreateDefaultContext()
    sc = system.GetMyContextFromRoot(dcontext)
    observation = system.Observe(sc)
    decision = policy.Plan(observation, policy.InitialMemory())
    step = policy.Step(observation, policy.InitialMemory())
    assert math.isfinite(decision.predicted_end_soc) and math.isfinite(decision.required_end_soc)
    j = int(np.argmin(np.abs(policy.problem.grid - decision.path_parameter)))
    assert decision.required_end_soc == pytest.approx(
        BatteryParams().reserve_soc + float(step.margin.At(step.t_rem[j]))
    )
    if decision.feasible:
        assert decision.predicted_end_soc >= decision.required_end_soc - 1e-9
    simulator = Simulator(diagram)
    simulator.AdvanceTo(1.5)  # one update at t = 1 from the same (constant) inputs
    port = system.GetOutputPort("predicted_soc").Eval(
        system.GetMyContextFromRoot(simulator.get_context())
    )
    np.testing.assert_allclose(port, [decision.predicted_end_soc, decision.required_end_soc])
    # A policy that does not predict leaves NaN.
    paper = _Policy(PlannerParams(policy="paper"), table)
    observation = system.Observe(sc)
    d = paper.Plan(observation, paper.InitialMemory())
    assert math.isnan(d.predicted_end_soc) and math.isnan(d.required_end_soc)


def test_planner_params_power_model_and_solver_are_validated():
    from eaplan_drake.errors import ScenarioError

    with pytest.raises(ScenarioError, match="planner.power_model"):
        PlannerParams(power_model="cubic").Validate()
    with pytest.raises(ScenarioError, match="planner.solver"):
        PlannerParams(solver="gurobi").Validate()
