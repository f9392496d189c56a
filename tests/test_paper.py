"""Tests of the paper's planner (planning/paper.py, paper 003 Eq. 16, Alg. 2): the NLP, its
Jacobian, the integer mapping and the fallback."""

import itertools
import math

import numpy as np
import pytest
from planner_cases import COVERAGE_TIMES, ORDER, PERIOD, Q_REF, BruteForceC2, Fourier
from pydrake.autodiffutils import ExtractGradient, ExtractValue, InitializeAutoDiff

from eaplan_drake.energy.battery import (
    PowerBudget,
    TimeToSoc,
)
from eaplan_drake.params import AUTHORS_K_B, BatteryParams, PlannerParams
from eaplan_drake.planning.paper import MakePlannerProgram, Planner
from eaplan_drake.planning.prediction import (
    FreeResponse,
    SimpsonSoc,
)


def PaperBattery() -> BatteryParams:
    """The papers' battery: 3.2 Ah at 14.8 V with the authors' scaling k_b = 0.00183."""
    return BatteryParams(k_b=AUTHORS_K_B)


@pytest.fixture(scope="module")
def planner(table):
    return Planner(PlannerParams(), table, ORDER, PaperBattery(), COVERAGE_TIMES)


def test_snopt_solves_the_same_nlp(table):
    """planner.solver = snopt: same relaxed optimum as IPOPT (to the solvers' tolerances)."""
    ipopt = Planner(PlannerParams(), table, ORDER, PaperBattery(), COVERAGE_TIMES)
    snopt = Planner(PlannerParams(solver="snopt"), table, ORDER, PaperBattery(), COVERAGE_TIMES)
    for soc in (1.0, 0.68, 0.5):
        a, slack_a = _Relaxed(ipopt, soc, [10.0])
        b, slack_b = _Relaxed(snopt, soc, [10.0])
        np.testing.assert_allclose(b, a, atol=0.05)  # IPOPT's barrier stays ≈ 0.03 off a bound
        np.testing.assert_allclose(slack_b, slack_a, atol=1e-3)
    continuous = Planner(
        PlannerParams(solver="snopt"), table, ORDER, PaperBattery(), COVERAGE_TIMES, integer=False
    )
    sol = continuous.Plan(Q_REF, 0.68, PERIOD, 0.5, [10.0], 0.0)
    assert sol.success and sol.feasible


def test_output_constraint_jacobian_matches_finite_differences(table2):
    program = MakePlannerProgram(PlannerParams(horizon=4), table2, PaperBattery())
    f = FreeResponse(Q_REF, ORDER, PERIOD, 0.5, 9)
    program.SetData(f, 0.7, [6.0, 4.0])
    rng = np.random.default_rng(3)
    x = rng.uniform(0.0, 1.0, 4 * 2 + 4)
    out = program._OutputConstraint(InitializeAutoDiff(x))
    J = ExtractGradient(out)
    np.testing.assert_allclose(ExtractValue(out).ravel(), program._OutputConstraint(x), atol=1e-12)
    eps = 1e-6
    J_fd = np.column_stack(
        [
            (program._OutputConstraint(x + eps * e) - program._OutputConstraint(x - eps * e))
            / (2 * eps)
            for e in np.eye(x.size)
        ]
    )
    np.testing.assert_allclose(J, J_fd, atol=1e-6)
    # Row layout: step starts then step ends; the SoC of the model is Simpson's.
    y0, y1, soc = program.Outputs(x[:8])
    np.testing.assert_allclose(
        program._OutputConstraint(np.concatenate((x[:8], np.zeros(4)))),
        np.concatenate(
            (
                y0 - PowerBudget(soc[:-1], PaperBattery()),
                y1 - PowerBudget(soc[1:], PaperBattery()),
            )
        ),
        atol=1e-12,
    )


def test_program_variables_and_bounds(table):
    program = MakePlannerProgram(PlannerParams(horizon=5), table, PaperBattery())
    assert program.computation_variables.shape == (5, 1)
    assert program.path_variables.shape == (5,)
    assert program.slack_variables.shape == (5,)
    assert program.prog.num_vars() == 15
    assert len(program.prog.generic_constraints()) == 1


# -- the step: NLP + integer mapping ------------------------------------------------------------


def _Relaxed(planner, soc, c_prev):
    """(relaxed c2 over the horizon, slack [W]) of the planner's NLP for Q_REF."""
    x, status, _ = planner.Relax(planner.ResponseRows(PERIOD) @ Q_REF, soc, c_prev)
    assert x is not None, status
    N, sigma = planner.horizon, planner.table.num_parameters
    relaxed = planner.lower + np.clip(x[: N * sigma].reshape(N, sigma), 0.0, 1.0) * planner.span
    return relaxed, x[N * sigma + N :]


def test_plenty_of_battery_gives_highest_configuration(planner, table):
    sol = planner.Plan(Q_REF, 1.0, PERIOD, 0.5, [2.0], -1000.0)
    assert sol.success and sol.feasible
    assert sol.computation_parameters[0] == table.upper[0]
    np.testing.assert_array_equal(sol.computation_trajectory, table.upper[0])
    # Integer parameters: the exact mapping decides, no NLP is solved.
    assert sol.relaxed_computation is None and sol.slack is None and sol.solve_time == 0.0
    relaxed, slack = _Relaxed(planner, 1.0, [2.0])
    assert np.max(slack) < 1e-4
    assert relaxed.min() > 9.9  # the relaxed optimum is the top too
    # c1: t_b is long enough for the remaining half survey at c1 = 0 (rate limit 500 per step).
    assert sol.time_to_reserve > 0.5 * COVERAGE_TIMES[1]
    assert sol.path_parameter == -500.0
    # A rise smaller than the deadband (250 m²) is held; a larger one is taken.
    assert planner.Plan(Q_REF, 1.0, PERIOD, 0.5, [10.0], -100.0).path_parameter == -100.0
    assert planner.Plan(Q_REF, 1.0, PERIOD, 0.5, [10.0], -300.0).path_parameter == 0.0


def test_budget_below_lowest_power_gives_lowest_and_uses_slack(planner, table):
    soc = 0.5  # budget 23.7 W < y at the lowest fps (≈ 30 − (10.2 − 5.2) ≈ 25 W)
    sol = planner.Plan(Q_REF, soc, PERIOD, 0.5, [10.0], 0.0)
    assert sol.success and not sol.feasible
    assert sol.computation_parameters[0] == table.lower[0]
    relaxed, slack = _Relaxed(planner, soc, [10.0])
    np.testing.assert_allclose(relaxed, table.lower[0], atol=1e-3)
    f0 = Q_REF[0] + Q_REF[1] + Q_REF[3] + Q_REF[5]
    violation = f0 + table.power([2.0]) - table.power([10.0]) - PowerBudget(soc, PaperBattery())
    assert violation > 0.0
    # The NLP measures the violation (start or end of each step) with its smooth ĝ.
    y_start, y_end, soc_nodes = planner.program.Outputs(np.zeros((6, 1)))
    budget = PowerBudget(soc_nodes, PaperBattery())
    violation_hat = np.maximum(y_start - budget[:-1], y_end - budget[1:])
    np.testing.assert_allclose(slack, violation_hat, atol=1e-4)
    assert slack[0] == pytest.approx(violation, abs=0.35)  # 2 × the fit error of ĝ


IN_BETWEEN_SOC = (0.62, 0.64, 0.66, 0.68, 0.70, 0.71, 0.72, 0.73, 0.74)


@pytest.mark.parametrize("soc", IN_BETWEEN_SOC)
def test_in_between_gives_largest_admissible_grid_value(planner, table, soc):
    sol = planner.Plan(Q_REF, soc, PERIOD, 0.5, [10.0], 0.0)
    assert sol.success
    assert sol.computation_parameters[0] == BruteForceC2(table, Q_REF, soc, [10.0])


def test_in_between_cases_are_exercised(planner, table):
    """The sweep above really covers interior grid values, not only the extremes."""
    chosen = {BruteForceC2(table, Q_REF, s, [10.0]) for s in IN_BETWEEN_SOC}
    assert chosen == set(table.parameter_grids[0])


def test_lowering_soc_never_raises_c2(planner):
    chosen = []
    for soc in np.linspace(1.0, 0.35, 40):
        sol = planner.Plan(Q_REF, soc, PERIOD, 0.5, [10.0], 0.0)
        assert sol.success
        chosen.append(sol.computation_parameters[0])
    assert np.all(np.diff(chosen) <= 0.0)
    assert chosen[0] == 10.0 and chosen[-1] == 2.0


def test_two_parameter_table_maps_to_best_admissible_grid_point(table2):
    planner = Planner(PlannerParams(), table2, ORDER, PaperBattery(), COVERAGE_TIMES)
    battery = PaperBattery()
    f = Fourier(Q_REF, np.array([0.0, 0.5, 1.0]), PERIOD)
    g_prev = table2.power([10.0, 10.0])
    for soc in (0.95, 0.68, 0.66, 0.4):
        sol = planner.Plan(Q_REF, soc, PERIOD, 0.5, [10.0, 10.0], 0.0)
        assert sol.success
        best, best_score = table2.lower, math.inf
        for c in itertools.product(*table2.parameter_grids):
            y = f + table2.power(c) - g_prev
            b1 = SimpsonSoc(y, soc, battery, 1.0)[1]
            ok = y[0] <= PowerBudget(soc, battery) and y[2] <= PowerBudget(b1, battery)
            u = (np.array(c) - table2.lower) / (table2.upper - table2.lower)
            score = np.sum((1.0 - u) ** 2)
            if ok and score < best_score - 1e-12:
                best, best_score = np.array(c), score
        np.testing.assert_array_equal(sol.computation_parameters, best)


def _AssertStepFeasible(table, battery, soc, c):
    """c2 = c keeps y ≤ b·Q_c·V at the start and end of the first step, from c_prev = 10, and
    lies between the largest admissible grid value and the top."""
    assert BruteForceC2(table, Q_REF, soc, [10.0]) <= c < table.upper[0]
    f = Fourier(Q_REF, np.array([0.0, 0.5, 1.0]), PERIOD)
    y = f + table.power([c]) - table.power([10.0])
    b1 = SimpsonSoc(y, soc, battery, 1.0)[1]
    assert y[0] <= PowerBudget(soc, battery) + 1e-9 and y[2] <= PowerBudget(b1, battery) + 1e-9
    return f


def test_non_integer_parameters_are_feasible_and_above_the_grid_choice(table):
    battery = PaperBattery()
    continuous = Planner(PlannerParams(), table, ORDER, battery, COVERAGE_TIMES, integer=False)
    soc = 0.68
    sol = continuous.Plan(Q_REF, soc, PERIOD, 0.5, [10.0], 0.0)
    assert sol.success and sol.feasible
    c = sol.computation_parameters[0]
    f = _AssertStepFeasible(table, battery, soc, c)
    # ... and nearly active: a bit more would violate it (at the start or the end of the step).
    y = f + table.power([c + 0.05]) - table.power([10.0])
    b1 = SimpsonSoc(y, soc, battery, 1.0)[1]
    assert y[0] > PowerBudget(soc, battery) or y[2] > PowerBudget(b1, battery)


def test_linear_power_model_gives_same_extremes(table):
    planner = Planner(
        PlannerParams(power_model="linear"), table, ORDER, PaperBattery(), COVERAGE_TIMES
    )
    assert planner.program.surrogate.kind == "linear"
    assert planner.Plan(Q_REF, 1.0, PERIOD, 0.5, [2.0], 0.0).computation_parameters[0] == 10.0
    assert planner.Plan(Q_REF, 0.5, PERIOD, 0.5, [10.0], 0.0).computation_parameters[0] == 2.0


def test_integer_step_needs_no_nlp_and_decides_as_after_a_solve(planner, table):
    """The mapping never reads the relaxed optimum: an iteration limit that makes every solve
    fail changes nothing for integer parameters."""
    params = PlannerParams(max_iterations=1)
    limited = Planner(params, table, ORDER, PaperBattery(), COVERAGE_TIMES)
    for soc in (1.0, *IN_BETWEEN_SOC, 0.5):
        sol = limited.Plan(Q_REF, soc, PERIOD, 0.5, [10.0], -300.0)
        ref = planner.Plan(Q_REF, soc, PERIOD, 0.5, [10.0], -300.0)
        assert sol.success and "no NLP" in sol.status
        np.testing.assert_array_equal(sol.computation_trajectory, ref.computation_trajectory)
        assert sol.path_parameter == ref.path_parameter
        assert sol.time_to_reserve == ref.time_to_reserve
    assert limited.Relax(limited.ResponseRows(PERIOD) @ Q_REF, 0.68, [10.0])[0] is None


def test_forced_failure_keeps_c1_and_takes_the_largest_admissible_c2(table):
    params = PlannerParams(max_iterations=1)
    battery = PaperBattery()
    failing = Planner(params, table, ORDER, battery, COVERAGE_TIMES, integer=False)
    soc = 0.68
    sol = failing.Plan(Q_REF, soc, PERIOD, 0.5, [10.0], -300.0)
    assert not sol.success
    assert "solver failed" in sol.status
    assert sol.path_parameter == -300.0  # kept
    _AssertStepFeasible(table, battery, soc, sol.computation_parameters[0])
    bad = failing.Plan(Q_REF, math.nan, PERIOD, 0.5, [10.0], 0.0)
    assert not bad.success and "invalid input" in bad.status


def test_time_to_reserve_matches_closed_form_for_constant_load(planner):
    battery = PaperBattery()
    q = np.zeros(7)
    q[0] = 35.0
    f = FreeResponse(q, ORDER, PERIOD, 0.5, 2 * 700 + 1)
    t_b = planner.TimeToReserve(f, np.array([0.0]), 0.8)
    assert t_b == pytest.approx(TimeToSoc(0.8, battery.reserve_soc, 35.0, battery), rel=1e-9)
    # With the planned offsets: −5 W over the horizon, then held.
    t_b2 = planner.TimeToReserve(f, np.full(6, -5.0), 0.8)
    assert t_b2 == pytest.approx(TimeToSoc(0.8, battery.reserve_soc, 30.0, battery), rel=1e-9)
    assert planner.TimeToReserve(f, np.array([0.0]), 0.25) == 0.0
