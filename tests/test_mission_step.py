"""The planner's objects by lifetime, each built and tested alone: the per-flight
:class:`MissionProblem`, the per-step :class:`MissionStep`, each margin model, the smooth model
and the grid mapping reproduce, bit for bit, the numbers the planner computed for the same states
before it was laid out by lifetime (tests/golden/mission_steps.json: 24 states, three reserves,
one- and two-parameter tables), and a step depends on its own state only."""

import json
from pathlib import Path

import numpy as np
import pytest

from eaplan_drake.energy.computation import LoadComputationTable
from eaplan_drake.params import AUTHORS_K_B, BatteryParams, FaultModelParams, PlannerParams
from eaplan_drake.planning.grid_search import DeterminedDecision
from eaplan_drake.planning.margins import (
    FixedReserveMargin,
    FloorMargin,
    RiskMargin,
    RiskReserve,
    StepMargin,
    TimedReserveMargin,
)
from eaplan_drake.planning.mpc import MissionProblem

BATTERY = BatteryParams(k_b=AUTHORS_K_B)
"""The battery the golden states were computed with (the papers' pack, the authors' scaling)."""
GOLDEN = json.loads((Path(__file__).parent / "golden" / "mission_steps.json").read_text())
POINT_BELIEF = FaultModelParams().PointModel()
"""The point fault model the golden risk steps were computed with (no belief, no learning)."""
SETTINGS = {
    "fixed": {"reserve": "fixed", "fault_reserve_time": 0.0},
    "timed": {"reserve": "fixed", "fault_reserve_time": 300.0},
    "risk": {"reserve": "risk", "fault_model": POINT_BELIEF},
}
MARGIN_KINDS = {"fixed": FixedReserveMargin, "timed": TimedReserveMargin, "risk": RiskMargin}


@pytest.fixture(scope="module")
def problems():
    out = {}
    for name in ("pednet_jetson_nano", "two_parameters"):
        table = LoadComputationTable(name)
        for setting, planner in SETTINGS.items():
            out[name, setting] = MissionProblem(
                PlannerParams(**planner), table, GOLDEN["order"], BATTERY, GOLDEN["grid"]
            )
    return out


def _Step(problems, case):
    pb = problems[case["table"], case["setting"]]
    step = pb.StepFromState(
        case["q"], case["var"], case["soc"], GOLDEN["period"], case["t_rem"], pb.table.upper
    )
    return pb, step


@pytest.mark.parametrize("index", range(len(GOLDEN["cases"])))
def test_a_step_reproduces_the_planner_bit_for_bit(problems, index):
    case = GOLDEN["cases"][index]
    pb, step = _Step(problems, case)
    times = np.array(GOLDEN["times"])
    margin = step.margin
    assert isinstance(margin, MARGIN_KINDS[case["setting"]])
    assert margin.At(times).tolist() == case["margin"]
    assert margin.FaultReserve(times).tolist() == case["fault_reserve"]
    assert [margin.Slope(t) for t in GOLDEN["times"]] == case["slope"]
    assert [float(margin.Recursive(t)) for t in GOLDEN["times"]] == case["recursive"]
    low, d = step.Lowest(), step.BruteForce()
    assert [low.path_index, low.candidate_index, low.end_soc, low.margin, low.feasible] == case[
        "lowest"
    ]
    assert step.NominallyFeasible() == case["nominal"]
    assert [d.path_index, d.candidate_index, d.end_soc, d.margin, d.quality, d.feasible] == case[
        "brute"
    ]
    determined = DeterminedDecision(step)
    if determined is not None:
        determined = [determined.path_index, determined.candidate_index]
    assert determined == case["determined"]
    assert [step.RecursiveSlack(float(g)) for g in pb.candidate_power] == case["slack"]
    g_high = float(pb.candidate_power[-1])
    t5 = float(case["t_rem"][5])
    assert [list(step.smooth.Soc(g_high, t)) for t in (0.0, 37.3, t5)] == case["smooth"]
    assert [list(step.smooth.RemainingTime(u)) for u in (0.0, 0.33, 0.8)] == case["remaining"]
    if case["setting"] == "risk":
        assert list(margin.lowest_state) == case["lowest_state"]
        assert step.risk_budget == PlannerParams().risk


def test_steps_are_independent_of_each_other_and_of_their_order(problems):
    """Two live steps of one problem, made in any order, answer as steps made alone."""
    cases = [c for c in GOLDEN["cases"] if c["table"] == "two_parameters"]
    steps = [_Step(problems, c)[1] for c in reversed(cases)]
    for step, case in zip(reversed(steps), cases, strict=True):
        d = step.BruteForce()
        assert [d.path_index, d.candidate_index, d.end_soc] == case["brute"][:3]


def test_the_risk_budget_is_an_argument_of_the_step(problems):
    case = next(c for c in GOLDEN["cases"] if c["setting"] == "risk" and c["brute"][-1])
    pb = problems[case["table"], "risk"]
    args = (case["q"], case["var"], case["soc"], GOLDEN["period"], case["t_rem"], pb.table.upper)
    loose, tight = pb.StepFromState(*args, budget=0.2), pb.StepFromState(*args, budget=1e-4)
    assert (loose.risk_budget, tight.risk_budget) == (0.2, 1e-4)
    # a smaller budget never asks a smaller margin, and never gives a better plan
    assert np.all(tight.MarginRow() >= loose.MarginRow())
    assert tight.BruteForce().quality <= loose.BruteForce().quality
    # the lowest plan itself keeps its excess risk at 0 whatever the budget
    assert tight.Lowest().feasible == loose.Lowest().feasible


def test_margin_models_alone():
    t = np.array([0.0, 75.0, 150.0, 299.0, 300.0, 800.0])
    timed = TimedReserveMargin(0.02, 0.0, 0.12, 300.0)
    np.testing.assert_allclose(timed.FaultReserve(t), 0.12 * np.minimum(1.0, t / 300.0), atol=0)
    np.testing.assert_allclose(timed.At(t), 0.02 + 0.12 * np.minimum(1.0, t / 300.0), atol=1e-15)
    assert timed.Slope(150.0) == pytest.approx(0.12 / 300.0, rel=1e-12)
    assert timed.Slope(450.0) == 0.0
    # the margin never grows as the survey goes on, so a plan feasible now stays feasible
    assert np.all(np.diff(timed.At(np.linspace(0.0, 900.0, 91))) >= 0.0)
    held = FixedReserveMargin(0.02, 1e-4, 0.12)
    np.testing.assert_allclose(held.At(t), 0.14 + 1e-4 * t, atol=1e-15)
    assert held.Slope(10.0) == 1e-4 and held.Recursive(100.0) == held.At(100.0)
    floor = FloorMargin(0.02)
    assert floor.At(t).tolist() == [0.02] * t.size and floor.Slope(5.0) == 0.0
    planner = PlannerParams(reserve="fixed", fault_reserve_time=0.0)
    assert isinstance(StepMargin(planner, 0.0), FixedReserveMargin)
    risk = RiskMargin(0.02, 1e-4, [100.0, 200.0, 400.0], [0.0, 0.03, 0.05], (100.0, 0.2), 0.01)
    assert risk.At(200.0) == pytest.approx(0.02 + 0.03 + 0.02, abs=1e-15)
    assert risk.At(1000.0) == pytest.approx(0.02 + 0.05 + 0.1, abs=1e-15)  # constant beyond
    assert risk.Recursive(200.0) == pytest.approx(0.02 + 0.02, abs=1e-15)  # no fault term
    assert risk.Slope(1000.0) == 1e-4


def test_the_risk_reserve_margin_is_within_the_budget_and_below_the_lowest_plans():
    reserve = RiskReserve(PlannerParams(reserve="risk"))
    times = np.array([150.0, 150.0, 300.0, 500.0])
    margin = reserve.Margin(0.0, times, 150.0, 0.2, 0.01)
    assert margin.times.tolist() == [150.0, 300.0, 500.0]  # the staircase's distinct times
    assert margin.margins[0] <= 0.2  # the lowest plan keeps its own margin
    assert np.all(np.diff(margin.margins) >= 0.0)  # longer plans need more
    looser = reserve.Margin(0.0, times, 150.0, 0.2, 0.04)
    assert np.all(looser.margins <= margin.margins)


def _RiskStep(problems, case, **kwargs):
    pb = problems[case["table"], "risk"]
    args = (case["q"], case["var"], case["soc"], GOLDEN["period"], case["t_rem"], pb.table.upper)
    return pb, pb.StepFromState(*args, **kwargs)


def test_a_state_the_risk_tables_cannot_price_is_infeasible_and_never_raises(problems):
    case = next(c for c in GOLDEN["cases"] if c["setting"] == "risk" and c["brute"][-1])
    pb, _ = _RiskStep(problems, case)
    exposure = pb.risk_reserve.max_exposure
    assert pb.risk_reserve.fault_model.rate * exposure <= 100.0  # MAX_EXPECTED_DROPS
    # a survey longer than the tables price (a crawling aircraft, a huge field)
    long = dict(case, t_rem=[exposure + 100.0 + t for t in case["t_rem"]])
    _, step = _RiskStep(problems, long)
    assert not step.priced and "exceed" in step.margin.why
    assert not step.Lowest().feasible and not step.BruteForce().feasible
    # an estimate whose prediction browns the battery out: the lowest plan's margin is -inf
    brownout = dict(case, q=[1e6] + case["q"][1:])
    _, step = _RiskStep(problems, brownout)
    assert not step.priced and "not finite" in step.margin.why
    assert not step.Lowest().feasible and not step.NominallyFeasible()
    # an anchor whose margin is not finite (a state that browned out when the budget opened)
    _, step = _RiskStep(problems, case, anchor=(100.0, -np.inf))
    _, plain = _RiskStep(problems, case)
    assert step.priced and step.MarginRow().tolist() == plain.MarginRow().tolist()
    # a fault rate whose tables stop short of the longest plan: only the plans longer than the
    # tables are unpriced, and excluded; the rest are priced as before
    planner = PlannerParams(reserve="risk")
    planner.fault_model.rate = 0.01
    frequent = MissionProblem(planner, pb.table, GOLDEN["order"], BATTERY, GOLDEN["grid"])
    exposure = frequent.risk_reserve.max_exposure
    assert exposure == 8192.0
    t_rem = np.linspace(300.0, exposure + 500.0, len(GOLDEN["grid"]))
    step = frequent.StepFromState(case["q"], 0.0, 1.0, GOLDEN["period"], t_rem, pb.table.upper)
    assert step.priced
    unpriced = step.margin.times > exposure
    reach = step.margin.lowest_state[1] + 0.01  # UNREACHABLE_MARGIN above m_0
    assert unpriced.any() and np.all(step.margin.margins[unpriced] == reach)
    assert np.all(step.margin.margins[~unpriced] <= reach)


def test_the_policy_flies_the_lowest_plan_and_says_so_when_it_cannot_price(problems):
    from eaplan_drake.planning.planner import PlannerObservation
    from eaplan_drake.planning.policies import MpcPolicy

    case = next(c for c in GOLDEN["cases"] if c["setting"] == "risk" and c["brute"][-1])
    pb = problems[case["table"], "risk"]
    policy = MpcPolicy(pb)
    exposure = pb.risk_reserve.max_exposure
    long = [exposure + 100.0 + t for t in case["t_rem"]]
    for t_rem, q in ((long, case["q"]), (case["t_rem"], [1e6] + case["q"][1:])):
        o = PlannerObservation(
            time=100.0,
            energy_coefficients=np.asarray(q),
            mean_power_variance=case["var"],
            soc=case["soc"],
            period=GOLDEN["period"],
            coverage_remaining=0.5,
            remaining_time=np.asarray(t_rem),
            path_parameter=0.0,
            computation_parameters=np.asarray(pb.table.upper, dtype=float),
        )
        d = policy.Plan(o, policy.InitialMemory())
        assert d.kind == "unpriced" and not d.feasible and d.success
        assert d.status.startswith("unpriced: ")
        assert d.path_parameter == pb.grid[0]
        np.testing.assert_array_equal(d.computation_parameters, pb.candidates[pb.lowest_candidate])
