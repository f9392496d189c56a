"""The pilot's baseline (eaplan_drake.planning.static_plan, policy static_takeoff): the best static
plan at take-off against an independent enumeration of (S1)–(S2), monotone in ε, and held."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from eaplan_drake.energy.computation import LoadComputationTable
from eaplan_drake.params import BatteryParams, FaultModelParams, PlannerParams
from eaplan_drake.planning.mpc import MissionProblem
from eaplan_drake.planning.planner import PlannerObservation
from eaplan_drake.planning.policies import StaticTakeoffPolicy
from eaplan_drake.planning.risk import TotalDropTail
from eaplan_drake.planning.risk_margin import FaultModelFromParams
from eaplan_drake.planning.static_plan import BestStaticPlan

GOLDEN = json.loads((Path(__file__).parent / "golden" / "mission_steps.json").read_text())
CASES = [c for c in GOLDEN["cases"] if c["setting"] == "risk"]


POINT_BELIEF = FaultModelParams().PointModel()
"""The stated point model (no belief): what the independent enumeration prices with."""


def _Problem(table_name, **planner):
    table = LoadComputationTable(table_name)
    planner = PlannerParams(reserve="risk", **{"fault_model": POINT_BELIEF, **planner})
    return MissionProblem(planner, table, GOLDEN["order"], BatteryParams(), GOLDEN["grid"])


def _Step(pb, case, soc=None):
    soc = case["soc"] if soc is None else soc
    return pb.StepFromState(
        case["q"], case["var"], soc, GOLDEN["period"], case["t_rem"], pb.table.upper
    )


@pytest.mark.parametrize("index", range(len(CASES)))
def test_the_best_static_plan_is_the_best_of_an_independent_enumeration(index):
    case = CASES[index]
    pb = _Problem(case["table"])
    step = _Step(pb, case, soc=max(case["soc"], 0.7))
    eps = 0.05
    d = BestStaticPlan(step, eps)
    model = FaultModelFromParams(POINT_BELIEF)
    reserve, floor = BatteryParams().reserve_soc, PlannerParams().margin_floor
    rate = step.margin.rate
    t = np.asarray(case["t_rem"])

    def Margin(power, j):
        return float(step.SocAt(power, t[j])) - reserve - floor - rate * t[j]

    m_0 = Margin(pb.lowest_power, 0)
    assert d.feasible == (m_0 >= 0.0)
    if not d.feasible:
        return
    tail_0 = float(TotalDropTail(model, t[0], m_0))
    best = -math.inf
    for k, c2 in enumerate(pb.candidates):
        for j in range(t.size):
            m = Margin(float(pb.candidate_power[k]), j)
            if m >= 0.0 and float(TotalDropTail(model, t[j], m)) - tail_0 <= eps:
                best = max(best, pb.Quality(j, pb.RowValues(c2)[1]))
    assert d.quality == pytest.approx(best, abs=1e-12)
    # the chosen plan itself satisfies (S1)–(S2)
    m = Margin(pb.RowValues(d.computation_parameters)[0], d.path_index)
    assert m >= 0.0 and float(TotalDropTail(model, t[d.path_index], m)) - tail_0 <= eps + 1e-12


def test_a_larger_risk_never_gives_a_worse_static_plan():
    for case in CASES:
        pb = _Problem(case["table"])
        step = _Step(pb, case, soc=0.8)
        qualities = [BestStaticPlan(step, eps).quality for eps in (0.001, 0.01, 0.05, 0.2)]
        assert qualities == sorted(qualities)


def test_the_policy_chooses_once_and_holds_its_plan():
    case = CASES[0]
    pb = _Problem(case["table"])
    policy = StaticTakeoffPolicy(pb)
    o = PlannerObservation(
        time=60.0,
        energy_coefficients=np.asarray(case["q"]),
        mean_power_variance=case["var"],
        soc=0.8,
        period=GOLDEN["period"],
        coverage_remaining=0.9,
        remaining_time=np.asarray(case["t_rem"]),
        path_parameter=float(pb.grid[0]),
        computation_parameters=np.asarray(pb.table.lower, dtype=float),
    )
    first = policy.Plan(o, policy.InitialMemory())
    assert first.kind == "chosen" and first.feasible
    expected = BestStaticPlan(pb.Step(o, budget=0.05), 0.05)
    assert first.path_parameter == expected.path_parameter
    later = dict(o.__dict__, time=120.0, soc=0.3)  # whatever happens, the plan is held
    held = policy.Plan(PlannerObservation(**later), first.memory)
    assert held.kind == "held" and held.path_parameter == first.path_parameter
    np.testing.assert_array_equal(held.computation_parameters, first.computation_parameters)
    with pytest.raises(ValueError, match="static_takeoff"):
        StaticTakeoffPolicy(
            MissionProblem(
                PlannerParams(reserve="fixed"), pb.table, 3, BatteryParams(), GOLDEN["grid"]
            )
        )
