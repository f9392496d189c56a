"""The pack's usable capacity estimated in flight (``planner.capacity: estimated``): the estimate
against its closed form, the pack the planner then prices with, and flights on a worn and a
healthy pack."""

import dataclasses as dc
import math

import numpy as np
import pytest

from eaplan_drake.diagram import MakeResolvedPolicy
from eaplan_drake.energy.battery_model import AsBatteryModel
from eaplan_drake.errors import ScenarioError
from eaplan_drake.loading import LayerScenario, LoadNamedScenario, OverrideFromAssignment
from eaplan_drake.output.summary_text import FormatSummary
from eaplan_drake.params import BatteryParams, PlannerParams
from eaplan_drake.params.bounds import MIN_BATTERY_HEALTH
from eaplan_drake.planning.capacity import (
    HEALTH_RESOLUTION,
    PRIOR_FALL,
    HealthEstimate,
    PlannedPack,
)
from eaplan_drake.planning.margins import RiskMemory
from eaplan_drake.planning.policies import MpcPolicy
from eaplan_drake.resolve import ResolveScenario
from eaplan_drake.simulation import Simulate


def test_the_estimate_is_the_ratio_of_the_sums_with_the_nominal_pack_as_prior():
    w = PRIOR_FALL
    # (Σ Δ̂ + w) / (Σ Δ + w), rounded to the grid
    assert HealthEstimate(0.30, 0.30 / 0.8) == pytest.approx((0.30 + w) / (0.375 + w), abs=0.005)
    assert HealthEstimate(0.03, 0.03 / 0.8) == pytest.approx(0.81)  # 0.815: the prior's pull
    assert HealthEstimate(3.0, 3.0 / 0.8) == pytest.approx(0.80)
    # no fall yet: the label
    assert HealthEstimate(0.0, 0.0) == 1.0
    # half the data weighs as much as the prior: half-way between the label and the data (0.5)
    assert HealthEstimate(w * 0.5, w) == pytest.approx((1.5 * w) / (2.0 * w), abs=0.005)
    # more data than the prior: the data
    assert HealthEstimate(100 * w * 0.9, 100 * w) == pytest.approx(0.90, abs=HEALTH_RESOLUTION)


def test_the_estimate_never_exceeds_the_label_nor_leaves_the_health_range():
    assert HealthEstimate(0.5, 0.4) == 1.0  # a pack is never believed to hold more than its label
    assert HealthEstimate(0.01, 5.0) == MIN_BATTERY_HEALTH
    assert HealthEstimate(0.3, -0.02) == 1.0  # the SoC rose: nothing learnt against the label
    for predicted, observed in ((0.2, 0.21), (0.2, 0.3), (0.33, 0.41)):
        h = HealthEstimate(predicted, observed)
        assert MIN_BATTERY_HEALTH <= h <= 1.0
        assert round(h / HEALTH_RESOLUTION) == pytest.approx(h / HEALTH_RESOLUTION, abs=1e-9)


def test_bad_falls_are_one_line_naming_what_is_wrong():
    with pytest.raises(ValueError, match="prior_fall: must be > 0"):
        HealthEstimate(0.1, 0.1, prior_fall=0.0)
    with pytest.raises(ValueError, match="must be finite"):
        HealthEstimate(math.nan, 0.1)
    with pytest.raises(ValueError, match="must be finite"):
        HealthEstimate(0.1, math.inf)


def test_the_planned_pack_falls_one_over_its_health_as_fast_and_ignores_the_true_health():
    nominal = AsBatteryModel(BatteryParams())
    worn = PlannedPack(BatteryParams(), 0.8)
    truth_elsewhere = PlannedPack(BatteryParams(health=0.5), 0.8)  # the scenario's truth
    loads = np.array([20.0, 35.0, 50.0])
    np.testing.assert_allclose(worn.SocRate(loads), nominal.SocRate(loads) / 0.8, rtol=1e-12)
    np.testing.assert_allclose(truth_elsewhere.SocRate(loads), worn.SocRate(loads), rtol=0)
    np.testing.assert_allclose(
        worn.SocRateSlope(loads), nominal.SocRateSlope(loads) / 0.8, rtol=1e-12
    )
    assert worn.reserve_soc == nominal.reserve_soc


def test_planner_capacity_is_checked_by_name():
    with pytest.raises(ScenarioError, match=r"planner\.capacity: must be one of nominal, "):
        dc.replace(PlannerParams(), capacity="learnt").Validate()


class _Recording(MpcPolicy):
    """The default mpc that keeps, at each step, the SoC read and the SoC its last step
    predicted for now."""

    def __init__(self, problem):
        super().__init__(problem)
        self.pairs = []

    def Plan(self, observation, memory):
        tail = RiskMemory(np.array(memory[self._warm_size : self._risk_end], dtype=float))
        self.pairs.append((float(observation.soc), float(tail.predicted_soc)))
        return super().Plan(observation, memory)


def _Fly(health: float, capacity: str, extra=()):
    sets = [f"battery.health={health}", f"planner.capacity={capacity}", *extra]
    scenario = LayerScenario(LoadNamedScenario("survey"), [OverrideFromAssignment(s) for s in sets])
    resolved = ResolveScenario(scenario)
    policy = _Recording(MakeResolvedPolicy(resolved).problem)
    log = Simulate(resolved, policy=policy)
    return log.summary, np.array(policy.pairs)


def _OneStepRatio(pairs, first: int = 0) -> float:
    """Σ (observed fall) / Σ (predicted fall) over the steps from ``first`` on (no drops here)."""
    soc, predicted = pairs[:, 0], pairs[:, 1]
    observed = soc[:-1] - soc[1:]
    expected = soc[:-1] - predicted[1:]
    return float(np.sum(observed[first:]) / np.sum(expected[first:]))


@pytest.fixture(scope="module")
def worn_flights():
    return {capacity: _Fly(0.85, capacity) for capacity in ("nominal", "estimated")}


def test_on_a_worn_pack_the_estimate_finds_the_health(worn_flights):
    summary, _ = worn_flights["estimated"]
    assert summary["completed"]
    health = summary["planner"]["policy_figures"]["pack_health"]
    assert health == pytest.approx(0.85, abs=0.01)
    assert "pack_health" not in worn_flights["nominal"][0]["planner"]["policy_figures"]
    summary = dict(summary, wall_time=1.0, realtime_factor=1.0)
    assert f"the pack holds {health:.2f} of its label (estimated in flight)" in FormatSummary(
        summary
    )


def test_on_a_worn_pack_the_estimated_planner_predicts_the_soc_it_then_reads(worn_flights):
    """The nominal planner's one-step predictions fall 1/h = 1.18 times too slowly; the
    estimating planner's within 3 % over the whole flight (the prior's pull in the first
    seconds included) and within 1 % after its first 30 steps."""
    assert _OneStepRatio(worn_flights["nominal"][1]) == pytest.approx(1 / 0.85, rel=0.01)
    assert _OneStepRatio(worn_flights["estimated"][1]) == pytest.approx(1.0, abs=0.03)
    assert _OneStepRatio(worn_flights["estimated"][1], first=30) == pytest.approx(1.0, abs=0.01)


def test_on_a_worn_pack_the_estimated_planner_keeps_more_back(worn_flights):
    nominal, estimated = worn_flights["nominal"][0], worn_flights["estimated"][0]
    assert estimated["final_soc"] > nominal["final_soc"] + 0.005
    assert estimated["quality"] < nominal["quality"]


def test_on_a_healthy_pack_the_estimating_planner_flies_as_the_nominal_one():
    nominal, _ = _Fly(1.0, "nominal")
    estimated, _ = _Fly(1.0, "estimated")
    assert estimated["planner"]["policy_figures"]["pack_health"] == 1.0
    for key in ("duration", "final_soc", "quality"):
        assert estimated[key] == nominal[key], key
