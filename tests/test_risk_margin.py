"""The planner's risk reserve (eaplan_drake.planning.risk_margin and the mpc's ``reserve: risk``):
the tabulated excess risk against the exact bounds of eaplan_drake.planning.risk, the required
margin it inverts, and the mpc that keeps every decision within ε and agrees with brute force."""

import dataclasses as dc

import numpy as np
import pytest

from eaplan_drake.flight.coverage import MakeCoveragePlan
from eaplan_drake.params import (
    BatteryParams,
    CoverageParams,
    FaultModelParams,
    PlannerParams,
    VehicleParams,
)
from eaplan_drake.planning.margins import RiskMemory
from eaplan_drake.planning.policies import MakePolicy
from eaplan_drake.planning.risk import (
    EmpiricalDrops,
    ExcessRiskBounds,
    ExponentialDrops,
    FaultModel,
    UniformDrops,
)
from eaplan_drake.planning.risk_margin import (
    UNREACHABLE_MARGIN,
    ExcessRiskTable,
    FaultModelFromParams,
    RiskTable,
)
from eaplan_drake.studies.worlds import BruteForceAgreement, RandomPlannerObservation

GRID = np.linspace(-1000.0, 0.0, 21)
MODELS = {
    "uniform": FaultModel(0.003, UniformDrops(0.0, 0.15)),
    "exponential": FaultModel(0.004, ExponentialDrops(0.06)),
    "empirical": FaultModel(0.003, EmpiricalDrops((0.06, 0.09, 0.12))),
}


def _States(n=200, seed=1):
    rng = np.random.default_rng(seed)
    tau_0 = rng.uniform(10.0, 500.0, n)
    tau_p = tau_0 + rng.uniform(0.0, 150.0, n)
    m_0 = rng.uniform(0.0, 0.3, n)
    m_p = np.maximum(m_0 - rng.uniform(0.0, 0.15, n), -0.01)
    return tau_p, m_p, tau_0, m_0


@pytest.mark.parametrize("kind", ["uniform", "exponential"])
def test_the_table_is_conservative_and_close_to_the_exact_bounds(kind):
    model = MODELS[kind]
    tau_p, m_p, tau_0, m_0 = _States()
    lower, upper = ExcessRiskBounds(model, tau_p, m_p, tau_0, m_0, cells=512)
    fast = ExcessRiskTable(model, 2000.0).Risk(tau_p, m_p, tau_0, m_0)
    assert np.all(fast >= lower - 1e-9)  # never below the exact value
    assert np.max(fast - upper) <= 0.005  # and at most a grid step of Q above it


def test_empirical_sizes_stay_within_the_quadrature_tolerance():
    model = MODELS["empirical"]
    tau_p, m_p, tau_0, m_0 = _States()
    lower, upper = ExcessRiskBounds(model, tau_p, m_p, tau_0, m_0, cells=512)
    fast = ExcessRiskTable(model, 2000.0).Risk(tau_p, m_p, tau_0, m_0)
    assert np.all(fast >= lower - 0.01) and np.all(fast <= upper + 0.01)


@pytest.mark.parametrize("kind", sorted(MODELS))
def test_the_lowest_plan_has_no_excess_and_more_spending_more(kind):
    table = RiskTable(MODELS[kind], 600.0)
    assert table.Risk(300.0, 0.12, 300.0, 0.12) == 0.0
    risks = table.Risk(300.0, np.array([0.11, 0.08, 0.04, 0.0]), 300.0, 0.12)
    assert np.all(np.diff(risks) >= 0.0) and risks[-1] > risks[0]
    longer = table.Risk(np.array([300.0, 350.0, 450.0]), 0.08, 300.0, 0.12)
    assert np.all(np.diff(longer) >= -1e-12)


def test_the_required_margin_is_the_smallest_within_eps():
    table = RiskTable(MODELS["uniform"], 700.0)
    times = np.linspace(250.0, 620.0, 21)
    m_req = table.RequiredMargin(times, 247.0, 0.3, 0.05)
    finite = np.isfinite(m_req)
    assert finite[0] and m_req[0] <= 0.3  # the lowest plan's own time: within reach
    assert np.all(table.Risk(times[finite], m_req[finite], 247.0, 0.3) <= 0.05)
    below = np.maximum(m_req[finite] - 0.3 / 32**2 - 1e-9, 0.0)
    positive = m_req[finite] > 0.3 / 32**2
    assert np.all(table.Risk(times[finite], below, 247.0, 0.3)[positive] > 0.05)
    # thin world: a lowest plan 0.03 above its floor leaves almost nothing to spend
    thin = table.RequiredMargin(times[:3], 247.0, 0.03, 0.05)
    assert np.all(thin >= 0.0) and thin[0] <= 0.03
    assert np.all(table.RequiredMargin(times, 247.0, -0.01, 0.05) == 0.0)
    assert np.isinf(
        RiskTable(MODELS["uniform"], 5000.0).RequiredMargin([5000.0], 100.0, 0.02, 0.01)[0]
    )


def _RequiredMarginReadingEveryTrial(table, times, tau_0, m_0, eps, baseline):
    """m_req by the search of :meth:`ExcessRiskTable.RequiredMargin` reading all 33 trials of
    each stage (the reference for its coarse-to-fine reading)."""
    tau = np.asarray(times, dtype=float)[:, None]
    lo, width = np.zeros(tau.shape[0]), np.full(tau.shape[0], m_0)
    fail_0 = table.LowestFailure(tau_0, m_0)
    if baseline is not None:
        fail_0 = np.minimum(fail_0, baseline)
    for stage in range(2):
        trial = lo[:, None] + width[:, None] * np.arange(33) / 32
        ok = table._Excess(tau, trial, np.asarray(tau_0), np.asarray(m_0), fail_0) <= eps
        if stage == 0:
            found = ok[:, -1]
        first = np.where(ok.any(axis=1), np.argmax(ok, axis=1), 32)
        hi = np.take_along_axis(trial, first[:, None], axis=1)[:, 0]
        lo = np.where(first > 0, hi - width / 32, hi)
        width = hi - lo
    return np.where(found, hi, np.inf)


@pytest.mark.parametrize("kind", sorted(MODELS))
def test_the_coarse_to_fine_search_equals_reading_every_trial(kind):
    """The search reads 12 of each stage's 33 trial margins (the excess falls as the margin
    grows); on random states its m_req is bit for bit that of reading all 33."""
    table = RiskTable(MODELS[kind], 1000.0)
    rng = np.random.default_rng(7)
    for _ in range(150):
        tau_0 = rng.uniform(10.0, 500.0)
        times = np.sort(tau_0 + rng.uniform(0.0, 400.0, 21))
        times[0] = tau_0
        m_0 = rng.uniform(0.001, 0.4)
        eps = float(rng.choice([0.01, 0.025, 0.05, 0.2]))
        baseline = None if rng.random() < 0.5 else float(rng.uniform(0.0, 0.3))
        got = table.RequiredMargin(times, tau_0, m_0, eps, baseline)
        want = _RequiredMarginReadingEveryTrial(table, times, tau_0, m_0, eps, baseline)
        assert np.array_equal(got, want)


def test_fault_model_params_build_each_size_distribution():
    assert FaultModelFromParams(FaultModelParams()) == FaultModel(0.003, UniformDrops(0.0, 0.15))
    exp = FaultModelFromParams(FaultModelParams(sizes="exponential", size_mean=0.05))
    assert exp.sizes == ExponentialDrops(0.05)
    emp = FaultModelFromParams(FaultModelParams(sizes="empirical", size_values=[0.05, 0.1]))
    assert emp.sizes == EmpiricalDrops((0.05, 0.1))


@pytest.fixture(scope="module")
def plan():
    return MakeCoveragePlan(CoverageParams(), VehicleParams(), c1=0.0, k_e=0.05)


def _RiskPolicy(table, **planner):
    return MakePolicy(
        PlannerParams(reserve="risk", **planner),
        table,
        3,
        BatteryParams(),
        coverage_time_bounds=(1, 2),
        path_parameter_grid=GRID,
    )


def test_every_risk_decision_keeps_its_excess_risk_within_eps(table, plan):
    policy = _RiskPolicy(table, risk=0.05)
    exact = FaultModelFromParams(FaultModelParams())
    rng = np.random.default_rng(7)
    initial = policy.InitialMemory()
    warm = policy.program.variables.size
    memory = initial
    checked = 0
    while checked < 40:
        o = RandomPlannerObservation(rng, plan, GRID, table.parameter_grids[0])
        step = policy.Step(o, memory)  # a fresh mission: no drop yet, budget ε/2, no anchor
        if not step.Lowest().feasible:
            continue
        assert step.risk_budget == policy.Budget(0)
        d = policy.Plan(o, memory)
        memory = np.concatenate((d.memory[:warm], initial[warm:]))
        j = int(np.flatnonzero(GRID == d.path_parameter)[0])
        t_rem, margin = step.t_rem, step.margin
        floor = margin.At(t_rem[j]) - margin.FaultReserve(t_rem[j])
        d_end = step.SocAt(float(table.power(d.computation_parameters)), t_rem[j])
        m_p = d_end - BatteryParams().reserve_soc - floor
        low = step.Lowest()
        m_0 = (
            low.end_soc
            - BatteryParams().reserve_soc
            - (margin.At(t_rem[0]) - margin.FaultReserve(t_rem[0]))
        )
        _, upper = ExcessRiskBounds(exact, t_rem[j], m_p, t_rem[0], m_0, cells=256)
        assert upper <= policy.Budget(0) + 0.01, (checked, upper)  # up to the table's step
        checked += 1


def test_a_lower_baseline_never_lowers_the_required_margin():
    table = RiskTable(MODELS["uniform"], 600.0)
    times = np.array([247.0, 260.0, 300.0, 400.0])
    own = table.LowestFailure(247.0, 0.2)
    plain = table.RequiredMargin(times, 247.0, 0.2, 0.02)
    assert np.array_equal(table.RequiredMargin(times, 247.0, 0.2, 0.02, own), plain)
    assert np.array_equal(table.RequiredMargin(times, 247.0, 0.2, 0.02, 1.0), plain)
    anchored = table.RequiredMargin(times, 247.0, 0.2, 0.02, 0.5 * own)
    assert np.all(anchored >= plain) and np.any(anchored > plain)


def test_the_mission_budget_is_halved_after_each_drop_and_anchored_there(table, plan):
    policy = _RiskPolicy(table, risk=0.04)
    h = policy.problem.step_length
    assert [policy.Budget(k) for k in range(3)] == [0.02, 0.01, 0.005]
    rng = np.random.default_rng(3)
    while True:
        o = RandomPlannerObservation(rng, plan, GRID, table.parameter_grids[0])
        step = policy.Step(o, policy.InitialMemory())
        if step.Lowest().feasible and o.soc > 0.5:
            break
    d = policy.Plan(o, policy.InitialMemory())
    tail = RiskMemory(d.memory[-len(RiskMemory.get_fields()) :])
    assert tail.drops == 0 and step.risk_budget == 0.02
    assert tail.anchor_end == pytest.approx(o.time + step.t_rem[0])
    anchor_end = tail.anchor_end
    steady = dc.replace(o, time=o.time + h, soc=tail.predicted_soc)
    assert policy.Step(steady, d.memory).risk_budget == 0.02
    d = policy.Plan(steady, d.memory)
    tail = RiskMemory(d.memory[-len(RiskMemory.get_fields()) :])
    assert tail.drops == 0 and tail.anchor_end == anchor_end  # the anchor holds
    dropped = dc.replace(o, time=o.time + 2 * h, soc=tail.predicted_soc - 0.05)
    step = policy.Step(dropped, d.memory)
    assert step.risk_budget == 0.01  # the next budget, anchored anew
    d = policy.Plan(dropped, d.memory)
    tail = RiskMemory(d.memory[-len(RiskMemory.get_fields()) :])
    assert tail.drops == 1 and tail.size_1 == pytest.approx(0.05, abs=1e-3)  # its size, kept
    assert tail.anchor_end == pytest.approx(dropped.time + step.t_rem[0])


@pytest.mark.slow
def test_risk_nlp_first_move_equals_brute_force_on_random_feasible_states(table, plan):
    """The NLP relaxation with the risk reserve agrees with enumeration in >= 99 % of 200 random
    feasible planner states."""
    policy = _RiskPolicy(table)
    rng = np.random.default_rng(2025)
    agree, total = BruteForceAgreement(policy, plan, GRID, table.parameter_grids[0], rng, 200)
    assert agree / total >= 0.99, f"{agree} of {total}"
    assert 0.0 < UNREACHABLE_MARGIN <= 0.05


@pytest.mark.slow
def test_after_a_drop_the_fallback_flies_the_lowest_plan_to_the_end():
    from eaplan_drake.loading import LoadNamedScenario
    from eaplan_drake.simulation import Simulate

    layers = [
        "planner: {reserve: risk, after_drop: lowest, warmup: 20.0}",
        "battery: {faults: [{time: 60.0, soc_drop: 0.05}]}",
        "simulation: {time_limit: 120.0}",
    ]
    scenario = LoadNamedScenario("survey", layers)
    log = Simulate(scenario)
    after = log.times > 60.0 + 2.0 * scenario.planner.period
    lo = scenario.planner.path_parameter_bounds[0]
    assert np.all(log["path_parameters"][after, 0] == lo)
    assert np.all(log["computation_parameters"][after, 0] == 2.0)
    before = (log.times > 30.0) & (log.times < 60.0)
    assert np.any(log["computation_parameters"][before, 0] > 2.0)  # it spent before the drop
    replan = Simulate(
        LoadNamedScenario("survey", [layers[0].replace("lowest", "replan")] + layers[1:])
    )
    assert np.any(replan["computation_parameters"][replan.times > 70.0, 0] > 2.0)
