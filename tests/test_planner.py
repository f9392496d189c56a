"""Tests of the planner-scheduler (paper 003 Eq. 16, Alg. 2): NLP, integer mapping, path rule,
and the PlannerScheduler system."""

import itertools
import math

import numpy as np
import pytest
from pydrake.autodiffutils import ExtractGradient, ExtractValue, InitializeAutoDiff
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from eaplan_drake.energy.battery import (
    MaxDeliverablePower,
    PowerBudget,
    RintCurrent,
    SocAfter,
    SocDerivative,
    SocDerivativeSlope,
    TimeToSoc,
)
from eaplan_drake.energy.computation import LoadComputationTable
from eaplan_drake.flight.coverage import ScalingFactors
from eaplan_drake.params import BatteryParams, PlannerParams
from eaplan_drake.planning.paper import MakePlannerProgram, Planner
from eaplan_drake.planning.planner import PlannerScheduler
from eaplan_drake.planning.policies import MakePolicy
from eaplan_drake.planning.prediction import (
    ChoosePathParameter,
    CoverageTimeModel,
    FreeResponse,
    SimpsonSoc,
    SimpsonSocSensitivity,
    SimpsonSocSteps,
    StepLoads,
)
from eaplan_drake.planning.prediction import TimeToReserve as PureTimeToReserve

ORDER = 3
PERIOD = 46.0
COVERAGE_TIMES = (270.0, 706.0)  # reference: full survey at c1 = −1000 and at c1 = 0 [s]
# A reference-like energy state: mean 30 W with harmonics (q = [α0, α1, β1, α2, β2, α3, β3]).
Q_REF = np.array([30.0, 3.0, 1.0, 1.5, -0.5, 0.3, 0.2])


@pytest.fixture(scope="module")
def table():
    return LoadComputationTable("pednet_jetson_nano")


@pytest.fixture(scope="module")
def table2():
    return LoadComputationTable("two_parameters")


@pytest.fixture(scope="module")
def planner(table):
    return Planner(PlannerParams(), table, ORDER, BatteryParams(), COVERAGE_TIMES)


def _Fourier(q, t, period):
    """Closed-form y(t) of the scaled model: α0 + Σ α_j cos(ωjt) + β_j sin(ωjt)."""
    w = 2.0 * math.pi / period
    y = np.full_like(t, q[0])
    for j in range(1, (len(q) - 1) // 2 + 1):
        y += q[2 * j - 1] * np.cos(w * j * t) + q[2 * j] * np.sin(w * j * t)
    return y


def _BruteForceC2(table, q, soc, c_prev, battery=None, h=1.0):
    """Largest grid value whose exact y ≤ b·Q_c·V holds at the start and end of the first step."""
    battery = battery or BatteryParams()
    f = _Fourier(q, np.array([0.0, 0.5 * h, h]), PERIOD)
    best = table.lower[0]
    for c in table.parameter_grids[0]:
        y = f + table.power([c]) - table.power(c_prev)
        b1 = SimpsonSoc(y, soc, battery, h)[1]
        if y[0] <= PowerBudget(soc, battery) and y[2] <= PowerBudget(b1, battery):
            best = max(best, c)
    return best


# -- pure helpers -------------------------------------------------------------------------------


def test_free_response_matches_fourier_series():
    t = 0.5 * np.arange(101)
    f = FreeResponse(Q_REF, ORDER, PERIOD, 0.5, t.size)
    np.testing.assert_allclose(f, _Fourier(Q_REF, t, PERIOD), atol=1e-9)


def test_simpson_soc_exact_for_constant_and_accurate_for_periodic_load():
    battery = BatteryParams()
    b = SimpsonSoc(np.full(21, 35.0), 0.9, battery, 1.0)
    np.testing.assert_allclose(b, SocAfter(0.9, 35.0, np.arange(11.0), battery), atol=1e-14)
    # Periodic load: Simpson (RK4) per 1 s step vs a fine trapezoid over 10 s.
    t_fine = np.linspace(0.0, 10.0, 200_001)
    bdot = SocDerivative(_Fourier(Q_REF, t_fine, PERIOD), battery)
    exact = 0.9 + np.sum(0.5 * (bdot[1:] + bdot[:-1]) * np.diff(t_fine))
    b = SimpsonSoc(_Fourier(Q_REF, 0.5 * np.arange(21), PERIOD), 0.9, battery, 1.0)
    assert abs(b[-1] - exact) < 1e-10


def test_simpson_soc_sensitivity_is_the_analytic_derivative():
    battery = BatteryParams()
    V, R = battery.voltage, battery.internal_resistance
    # Constant load y over a step h: Δb = −h k_b I(y)/Q_c, ∂Δb/∂y = −h k_b / (Q_c sqrt(V² − 4Ry)).
    y = np.array([10.0, 35.0, 1000.0])
    loads = np.broadcast_to(y, (3, 3))
    expected = -2.0 * battery.k_b / (battery.capacity * np.sqrt(V * V - 4.0 * R * y))
    np.testing.assert_allclose(SimpsonSocSensitivity(loads, battery, 2.0), expected, rtol=1e-12)
    # A periodic load: against central differences of the rollout's steps.
    f = _Fourier(Q_REF, 0.5 * np.arange(13), PERIOD)
    eps = 1e-4
    up = np.diff(SimpsonSocSteps(StepLoads(f, eps), 0.9, battery, 1.0))
    down = np.diff(SimpsonSocSteps(StepLoads(f, -eps), 0.9, battery, 1.0))
    np.testing.assert_allclose(
        SimpsonSocSensitivity(StepLoads(f), battery, 1.0), (up - down) / (2 * eps), rtol=1e-7
    )


def test_rollout_saturates_at_brownout_like_rint_current():
    """Above V²/(4 R_r) the load draws V/(2 R_r) (RintCurrent), never NaN, and ∂ḃ/∂y = 0."""
    battery = BatteryParams()
    p_max = MaxDeliverablePower(battery.voltage, battery.internal_resistance)
    i_max = battery.voltage / (2.0 * battery.internal_resistance)
    assert RintCurrent(2.0 * p_max, battery.voltage, battery.internal_resistance) == i_max
    b = SimpsonSoc(np.full(5, 2.0 * p_max), 0.9, battery, 0.5)
    np.testing.assert_allclose(b, 0.9 - battery.k_b * i_max / battery.capacity * 0.5 * np.arange(3))
    assert SocDerivativeSlope(2.0 * p_max, battery) == 0.0
    # The paper NLP's constraint uses the same rollout (c̃2 = 0 is c_prev here, so y = f).
    table = LoadComputationTable("pednet_jetson_nano")
    program = MakePlannerProgram(PlannerParams(horizon=2), table, battery)
    program.SetData(np.full(5, 2.0 * p_max), 0.9, [2.0])
    _, _, soc = program.Outputs(np.zeros((2, 1)))
    np.testing.assert_allclose(soc, SimpsonSoc(np.full(5, 2.0 * p_max), 0.9, battery, 1.0))
    assert np.all(np.isfinite(program._OutputConstraint(np.zeros(4))))
    # t_b: the first brown-out sample.
    f = np.full(2 * 10 + 1, 30.0)
    f[6] = 2.0 * p_max  # the node between steps 2 and 3 (t = 3 s)
    assert PureTimeToReserve(f, [0.0], 0.9, battery, 1.0) == 3.0


def test_coverage_time_model_is_eq10_scaling_factors():
    model = CoverageTimeModel((-1000.0, 0.0), COVERAGE_TIMES)
    nu, tau = ScalingFactors((-1000.0, 0.0), COVERAGE_TIMES)
    assert (model.nu, model.tau) == (nu[0], tau[0])
    flat = CoverageTimeModel((-500.0, -500.0), (300.0, 300.0))
    assert (flat.nu, flat.tau, flat(-500.0)) == (0.0, 300.0, 300.0)


def test_snopt_solves_the_same_nlp(table):
    """planner.solver = snopt: same relaxed optimum as IPOPT (to the solvers' tolerances)."""
    ipopt = Planner(PlannerParams(), table, ORDER, BatteryParams(), COVERAGE_TIMES)
    snopt = Planner(PlannerParams(solver="snopt"), table, ORDER, BatteryParams(), COVERAGE_TIMES)
    for soc in (1.0, 0.68, 0.5):
        a, slack_a = _Relaxed(ipopt, soc, [10.0])
        b, slack_b = _Relaxed(snopt, soc, [10.0])
        np.testing.assert_allclose(b, a, atol=0.05)  # IPOPT's barrier stays ≈ 0.03 off a bound
        np.testing.assert_allclose(slack_b, slack_a, atol=1e-3)
    continuous = Planner(
        PlannerParams(solver="snopt"), table, ORDER, BatteryParams(), COVERAGE_TIMES, integer=False
    )
    sol = continuous.Plan(Q_REF, 0.68, PERIOD, 0.5, [10.0], 0.0)
    assert sol.success and sol.feasible


def test_output_constraint_jacobian_matches_finite_differences(table2):
    program = MakePlannerProgram(PlannerParams(horizon=4), table2, BatteryParams())
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
                y0 - PowerBudget(soc[:-1], BatteryParams()),
                y1 - PowerBudget(soc[1:], BatteryParams()),
            )
        ),
        atol=1e-12,
    )


def test_program_variables_and_bounds(table):
    program = MakePlannerProgram(PlannerParams(horizon=5), table, BatteryParams())
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
    violation = f0 + table.power([2.0]) - table.power([10.0]) - PowerBudget(soc, BatteryParams())
    assert violation > 0.0
    # The NLP measures the violation (start or end of each step) with its smooth ĝ.
    y_start, y_end, soc_nodes = planner.program.Outputs(np.zeros((6, 1)))
    budget = PowerBudget(soc_nodes, BatteryParams())
    violation_hat = np.maximum(y_start - budget[:-1], y_end - budget[1:])
    np.testing.assert_allclose(slack, violation_hat, atol=1e-4)
    assert slack[0] == pytest.approx(violation, abs=0.35)  # 2 × the fit error of ĝ


IN_BETWEEN_SOC = (0.62, 0.64, 0.66, 0.68, 0.70, 0.71, 0.72, 0.73, 0.74)


@pytest.mark.parametrize("soc", IN_BETWEEN_SOC)
def test_in_between_gives_largest_admissible_grid_value(planner, table, soc):
    sol = planner.Plan(Q_REF, soc, PERIOD, 0.5, [10.0], 0.0)
    assert sol.success
    assert sol.computation_parameters[0] == _BruteForceC2(table, Q_REF, soc, [10.0])


def test_in_between_cases_are_exercised(planner, table):
    """The sweep above really covers interior grid values, not only the extremes."""
    chosen = {_BruteForceC2(table, Q_REF, s, [10.0]) for s in IN_BETWEEN_SOC}
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
    planner = Planner(PlannerParams(), table2, ORDER, BatteryParams(), COVERAGE_TIMES)
    battery = BatteryParams()
    f = _Fourier(Q_REF, np.array([0.0, 0.5, 1.0]), PERIOD)
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
    assert _BruteForceC2(table, Q_REF, soc, [10.0]) <= c < table.upper[0]
    f = _Fourier(Q_REF, np.array([0.0, 0.5, 1.0]), PERIOD)
    y = f + table.power([c]) - table.power([10.0])
    b1 = SimpsonSoc(y, soc, battery, 1.0)[1]
    assert y[0] <= PowerBudget(soc, battery) + 1e-9 and y[2] <= PowerBudget(b1, battery) + 1e-9
    return f


def test_non_integer_parameters_are_feasible_and_above_the_grid_choice(table):
    battery = BatteryParams()
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
        PlannerParams(power_model="linear"), table, ORDER, BatteryParams(), COVERAGE_TIMES
    )
    assert planner.program.surrogate.kind == "linear"
    assert planner.Plan(Q_REF, 1.0, PERIOD, 0.5, [2.0], 0.0).computation_parameters[0] == 10.0
    assert planner.Plan(Q_REF, 0.5, PERIOD, 0.5, [10.0], 0.0).computation_parameters[0] == 2.0


def test_integer_step_needs_no_nlp_and_decides_as_after_a_solve(planner, table):
    """The mapping never reads the relaxed optimum: an iteration limit that makes every solve
    fail changes nothing for integer parameters."""
    params = PlannerParams(max_iterations=1)
    limited = Planner(params, table, ORDER, BatteryParams(), COVERAGE_TIMES)
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
    battery = BatteryParams()
    failing = Planner(params, table, ORDER, battery, COVERAGE_TIMES, integer=False)
    soc = 0.68
    sol = failing.Plan(Q_REF, soc, PERIOD, 0.5, [10.0], -300.0)
    assert not sol.success
    assert "solver failed" in sol.status
    assert sol.path_parameter == -300.0  # kept
    _AssertStepFeasible(table, battery, soc, sol.computation_parameters[0])
    bad = failing.Plan(Q_REF, math.nan, PERIOD, 0.5, [10.0], 0.0)
    assert not bad.success and "invalid input" in bad.status


# -- path rule ----------------------------------------------------------------------------------


def test_path_rule_matches_brute_force():
    model = CoverageTimeModel((-1000.0, 0.0), COVERAGE_TIMES)
    assert model(-1000.0) == pytest.approx(270.0) and model(0.0) == pytest.approx(706.0)
    grid = np.linspace(-1000.0, 0.0, 100_001)  # 0.01 m² resolution
    rng = np.random.default_rng(7)
    for _ in range(200):
        t_b = rng.uniform(0.0, 800.0)
        fraction = rng.uniform(0.0, 1.0) if rng.uniform() > 0.1 else 0.0
        fits = grid[fraction * (model.nu * grid + model.tau) <= t_b]
        expected = fits.max() if fits.size else -1000.0
        assert ChoosePathParameter(t_b, fraction, model) == pytest.approx(expected, abs=0.011)


def test_path_rule_rate_limit_and_edges():
    model = CoverageTimeModel((-1000.0, 0.0), COVERAGE_TIMES)
    assert ChoosePathParameter(1e9, 1.0, model, previous=-1000.0, max_step=500.0) == -500.0
    assert ChoosePathParameter(0.0, 1.0, model, previous=0.0, max_step=300.0) == -300.0
    assert ChoosePathParameter(0.0, 0.0, model) == 0.0  # nothing left to cover
    assert ChoosePathParameter(100.0, 1.0, model) == -1000.0  # even c̲1 does not fit
    # Hysteresis: a rise below the deadband is held, a cut is always taken.
    assert ChoosePathParameter(1e9, 1.0, model, previous=-100.0, deadband=250.0) == -100.0
    assert ChoosePathParameter(1e9, 1.0, model, previous=-300.0, deadband=250.0) == 0.0
    assert ChoosePathParameter(0.0, 1.0, model, previous=-990.0, deadband=250.0) == -1000.0
    with pytest.raises(ValueError, match="coverage_time_bounds"):
        CoverageTimeModel((-1000.0, 0.0), (706.0, 270.0))


def test_time_to_reserve_matches_closed_form_for_constant_load(planner):
    battery = BatteryParams()
    q = np.zeros(7)
    q[0] = 35.0
    f = FreeResponse(q, ORDER, PERIOD, 0.5, 2 * 700 + 1)
    t_b = planner.TimeToReserve(f, np.array([0.0]), 0.8)
    assert t_b == pytest.approx(TimeToSoc(0.8, battery.reserve_soc, 35.0, battery), rel=1e-9)
    # With the planned offsets: −5 W over the horizon, then held.
    t_b2 = planner.TimeToReserve(f, np.full(6, -5.0), 0.8)
    assert t_b2 == pytest.approx(TimeToSoc(0.8, battery.reserve_soc, 30.0, battery), rel=1e-9)
    assert planner.TimeToReserve(f, np.array([0.0]), 0.25) == 0.0


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
    params = PlannerParams(policy="mpc", warmup=1.0, period=1.0)
    policy = _Policy(params, table)
    system = _Scheduler(params, table, [10.0], policy=policy)
    assert system.GetOutputPort("predicted_soc").size() == 2
    context = system.CreateDefaultContext()
    assert np.all(np.isnan(system.GetOutputPort("predicted_soc").Eval(context)))
    diagram, _ = _Diagram(system)
    dcontext = diagram.CreateDefaultContext()
    sc = system.GetMyContextFromRoot(dcontext)
    decision = policy.Plan(system.Observe(sc), policy.InitialMemory())
    pb = policy.problem
    assert math.isfinite(decision.predicted_end_soc) and math.isfinite(decision.required_end_soc)
    j = int(np.argmin(np.abs(pb.grid - decision.path_parameter)))
    assert decision.required_end_soc == pytest.approx(
        BatteryParams().reserve_soc + float(pb.Margin(pb.t_rem[j]))
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
