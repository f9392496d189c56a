"""The budget before the first detected drop (``planner.first_budget``): the closed form of
FirstDropBudget against the sum it replaces and against sampling, its bounds, and the mpc that
sets it once at its first step and halves from ε/4 after a drop."""

import dataclasses as dc
import math

import numpy as np
import pytest
from test_risk_margin import GRID, _RiskPolicy  # noqa: E402

from eaplan_drake.errors import ScenarioError
from eaplan_drake.flight.coverage import MakeCoveragePlan
from eaplan_drake.params import CoverageParams, PlannerParams, VehicleParams
from eaplan_drake.planning.margins import RiskMemory, RiskReserve
from eaplan_drake.planning.risk import PoissonPmf
from eaplan_drake.planning.risk_margin import FirstDropBudget
from eaplan_drake.studies.worlds import RandomPlannerObservation


@pytest.fixture(scope="module")
def plan():
    return MakeCoveragePlan(CoverageParams(), VehicleParams(), c1=0.0, k_e=0.05)


@pytest.mark.parametrize("rate, exposure", [(0.003, 706.0), (0.003, 1402.0), (0.01, 300.0)])
def test_the_first_budget_is_what_the_later_budgets_leave_weighed_by_their_chance(rate, exposure):
    eps = 0.05
    pmf = PoissonPmf(np.array(rate * exposure), 200)
    at_least = 1.0 - np.concatenate(([0.0], np.cumsum(pmf)[:-1]))  # P(N >= k), k = 0..200
    k = np.arange(1, 201)
    left = eps - float(np.sum(at_least[1:] * eps / 2.0 ** (k + 1)))
    assert FirstDropBudget(eps, rate, exposure) == pytest.approx(left, rel=1e-12)


def test_the_first_budget_matches_sampled_drops():
    rng = np.random.default_rng(41)
    eps, rate, exposure = 0.05, 0.003, 900.0
    drops = rng.poisson(rate * exposure, 200_000)
    sampled = 0.5 * eps * (1.0 + np.mean(2.0**-drops))
    sigma = 0.5 * eps * np.std(2.0**-drops) / math.sqrt(drops.size)
    assert abs(FirstDropBudget(eps, rate, exposure) - sampled) < 4.0 * sigma


def test_the_mean_rate_is_conservative_under_a_gamma_belief():
    """E[2^(−N)] under Gamma(α, β)–Poisson is (β/(β + τ/2))^α >= e^(−(α/β) τ/2) (Jensen)."""
    eps = 0.05
    for shape, rate_scale, tau in [(0.5, 166.7, 711.0), (2.0, 666.7, 1400.0), (40.0, 1e4, 500.0)]:
        predictive = 0.5 * eps * (1.0 + (rate_scale / (rate_scale + tau / 2.0)) ** shape)
        at_mean = FirstDropBudget(eps, shape / rate_scale, tau)
        assert at_mean <= predictive and at_mean >= eps / 2.0


def test_the_first_budget_lies_between_half_and_all_of_eps():
    assert FirstDropBudget(0.05, 0.0, 1e9) == 0.05  # no drops at a rate of 0
    assert FirstDropBudget(0.05, 0.003, 0.0) == 0.05
    assert FirstDropBudget(0.05, 0.003, math.inf) == 0.025
    for bad, name in [
        ((0.0, 0.003, 1.0), "eps"),
        ((0.05, -1.0, 1.0), "rate"),
        ((0.05, 0.003, math.nan), "exposure"),
    ]:
        with pytest.raises(ValueError, match=name):
            FirstDropBudget(*bad)


def test_the_reserve_prices_the_first_budget_at_the_rate_believed_before_the_flight():
    point = PlannerParams(reserve="risk")
    point.fault_model.prior_drops = 0.0
    assert RiskReserve(point).FirstBudget(0.05, 706.0) == pytest.approx(0.05 * 0.6734, abs=1e-5)
    learning = RiskReserve(PlannerParams(reserve="risk"))  # the default belief's mean: the rate
    assert learning.FirstBudget(0.05, 706.0) == pytest.approx(0.05 * 0.6734, abs=1e-5)


def test_the_first_budget_is_a_planner_key():
    with pytest.raises(ScenarioError, match="planner.first_budget"):
        PlannerParams(first_budget="all").Validate("planner")


def test_the_mpc_sets_its_first_budget_once_and_halves_after_a_drop(table, plan):
    policy = _RiskPolicy(table, risk=0.04, first_budget="reach")
    half = _RiskPolicy(table, risk=0.04)
    h = policy.problem.step_length
    rng = np.random.default_rng(3)
    while True:
        o = RandomPlannerObservation(rng, plan, GRID, table.parameter_grids[0])
        if policy.Step(o, policy.InitialMemory()).Lowest().feasible and o.soc > 0.5:
            break
    expected = policy.problem.risk_reserve.FirstBudget(0.04, float(np.max(o.remaining_time)))
    assert 0.02 < expected < 0.04
    d = policy.Plan(o, policy.InitialMemory())
    tail = RiskMemory(d.memory[-len(RiskMemory.get_fields()) :])
    assert tail.first_budget == expected
    assert RiskMemory(half.Plan(o, half.InitialMemory()).memory[-len(tail[:]) :]).first_budget < 0
    later = dc.replace(
        o, time=o.time + h, soc=tail.predicted_soc, remaining_time=o.remaining_time * 2
    )
    assert policy.Step(later, d.memory).risk_budget == expected  # held, not re-priced
    d = policy.Plan(later, d.memory)
    tail = RiskMemory(d.memory[-len(RiskMemory.get_fields()) :])
    dropped = dc.replace(o, time=o.time + 2 * h, soc=tail.predicted_soc - 0.05)
    assert policy.Step(dropped, d.memory).risk_budget == 0.01  # ε/4 after the first drop
