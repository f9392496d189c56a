"""The risk reserve that learns in flight: the rate belief priced by its quadrature against the
exact belief excess risk, the learnt sizes, and what a quiet minute and a drop do to a margin."""

import numpy as np
import pytest

from eaplan_drake.params import POINT_MODEL_VALUES, FaultModelParams, PlannerParams
from eaplan_drake.planning.belief import (
    BeliefExcessRisk,
    FaultBelief,
    RateBelief,
)
from eaplan_drake.planning.learnt_sizes import DirichletDrops
from eaplan_drake.planning.margins import RiskReserve, UnpricedMargin
from eaplan_drake.planning.risk import FaultModel, UniformDrops
from eaplan_drake.planning.risk_margin import ExcessRiskTable

SIZES = UniformDrops(0.0, 0.15)
PLANS = [(400.0, 0.2), (350.0, 0.1), (300.0, 0.05), (320.0, 0.22)]


@pytest.mark.parametrize("shape, rate", [(0.5, 167.0), (2.0, 667.0), (3.5, 36167.0)])
def test_quadrature_is_exact_for_polynomials_of_the_rate(shape, rate):
    belief = RateBelief(shape, rate)
    nodes, weights = belief.Quadrature(8)
    assert weights.sum() == pytest.approx(1.0, abs=1e-14)
    # E λ^k = Γ(α + k) / (Γ(α) β^k)
    moment = 1.0
    for k in range(1, 16):
        moment *= (shape + k - 1) / rate
        assert float(weights @ nodes**k) == pytest.approx(moment, rel=1e-9)


@pytest.mark.parametrize("shape, rate", [(0.5, 167.0), (2.0, 667.0), (0.5, 467.0)])
def test_the_belief_table_is_the_exact_belief_excess_risk(shape, rate):
    """The table's mixture over 8 rates against BeliefExcessRisk with fine cells (its lower and
    upper sums): within the margin grid's step of the upper one, never below the lower one."""
    belief = RateBelief(shape, rate)
    nodes, weights = belief.Quadrature()
    keep = nodes * 1024.0 <= 100.0
    table = ExcessRiskTable(
        FaultModel(belief.mean, SIZES), 1024.0, rates=(nodes[keep], weights[keep])
    )
    for tau_p, m_p in PLANS:
        exact = BeliefExcessRisk(FaultBelief(belief, SIZES), tau_p, m_p, 300.0, 0.25, cells=256)
        got = float(table.Risk(tau_p, m_p, 300.0, 0.25))
        assert exact - 2e-4 <= got <= exact + 2e-3, (tau_p, m_p, got, exact)


def test_a_point_belief_table_is_the_point_table():
    """A belief of α = 1e8 drops is the point rate: the same risks to 1e-6."""
    belief = RateBelief.PointMass(0.003)
    nodes, weights = belief.Quadrature()
    mixed = ExcessRiskTable(FaultModel(0.003, SIZES), 1024.0, rates=(nodes, weights))
    point = ExcessRiskTable(FaultModel(0.003, SIZES), 1024.0)
    for tau_p, m_p in PLANS:
        assert float(mixed.Risk(tau_p, m_p, 300.0, 0.25)) == pytest.approx(
            float(point.Risk(tau_p, m_p, 300.0, 0.25)), abs=1e-6
        )
    times = np.array([300.0, 350.0, 400.0, 500.0])
    np.testing.assert_allclose(
        mixed.RequiredMargin(times, 300.0, 0.25, 0.02),
        point.RequiredMargin(times, 300.0, 0.25, 0.02),
        atol=2e-3,
    )


POINT = POINT_MODEL_VALUES
"""The point model of the stated rate and sizes (no belief, no learning)."""


def _Reserve(**fault) -> RiskReserve:
    planner = PlannerParams(reserve="risk", fault_model=FaultModelParams(**{**POINT, **fault}))
    return RiskReserve(planner)


def _Margins(reserve, **history) -> np.ndarray:
    times = np.array([300.0, 350.0, 400.0, 450.0])
    return reserve.Margin(0.0, times, 300.0, 0.25, 0.025, None, **history).margins


def test_quiet_minutes_lower_the_margin_and_drops_raise_it():
    reserve = _Reserve(prior_drops=1.0)
    start = _Margins(reserve)
    quiet = _Margins(reserve, flown=600.0)
    dropped = _Margins(reserve, flown=100.0, drops=2)
    assert np.all(quiet <= start + 1e-12) and np.any(quiet < start - 1e-3)
    assert np.all(dropped >= start - 1e-12) and np.any(dropped > start + 1e-3)


def test_records_make_the_belief_and_many_hours_are_the_point_rate():
    reserve = _Reserve(rate=0.003, recorded_drops=3, recorded_hours=10.0)
    assert reserve.rate_belief.shape == pytest.approx(3.5)
    assert reserve.rate_belief.rate == pytest.approx(0.5 / 0.003 + 36000.0)
    sure = _Reserve(rate=0.003, recorded_drops=10800, recorded_hours=1e3)
    np.testing.assert_allclose(_Margins(sure), _Margins(_Reserve(rate=0.003)), atol=2e-3)


def test_learnt_sizes_raise_the_margin_after_a_heavy_drop_only_when_asked():
    learning, fixed = _Reserve(prior_sizes=2.0), _Reserve()
    assert isinstance(learning.Model((0.22,)).sizes, DirichletDrops)
    assert fixed.Model((0.22,)) is fixed.fault_model  # prior_sizes 0: the sizes do not learn
    heavy = _Margins(learning, observed=(0.22,), drops=1)
    assert np.all(heavy >= _Margins(fixed, observed=(0.22,), drops=1) - 1e-12)
    assert np.any(heavy > _Margins(fixed) + 1e-3)


@pytest.mark.parametrize(
    "fault, key",
    [
        (dict(prior_drops=-1.0), "planner.fault_model.prior_drops"),
        (dict(recorded_drops=1.5), "planner.fault_model.recorded_drops"),
        (dict(recorded_hours=-2.0), "planner.fault_model.recorded_hours"),
        (dict(prior_sizes=2000.0), "planner.fault_model.prior_sizes"),
        (dict(rate=0.0, recorded_hours=1.0), "planner.fault_model.rate"),
    ],
)
def test_bad_belief_keys_name_the_key(fault, key):
    with pytest.raises(ValueError, match=key):
        FaultModelParams(**fault).Validate()


def test_a_prior_that_doubts_the_label_scales_the_sizes_not_the_worlds():
    from eaplan_drake.studies.certify import WorldFaultModel

    params = FaultModelParams(prior_size_scale=3.0, prior_drops=0.5, prior_sizes=1.0)
    params.Validate()
    reserve = _Reserve(prior_size_scale=3.0)
    assert reserve.fault_model.sizes.b == pytest.approx(0.45, abs=1e-12)
    assert np.all(_Margins(reserve) >= _Margins(_Reserve()) - 1e-12)
    world = WorldFaultModel(params, [])
    assert world.size_bounds == [0.0, 0.15] and not world.HoldsBelief()
    assert world.prior_size_scale == 1.0 and world.prior_sizes == 0.0


def test_a_belief_beyond_the_tables_is_unpriced_not_raised():
    """After more drops than any table prices, the step is unpriced (the lowest plan), never an
    error inside the flight."""
    reserve = _Reserve(prior_drops=0.5)
    margin = reserve.Margin(
        0.0, np.array([300.0, 400.0]), 300.0, 0.25, 0.025, flown=60.0, drops=400
    )
    assert isinstance(margin, UnpricedMargin) and "400 drops" in margin.why


def test_the_point_model_keeps_what_is_stated_and_drops_the_learning():
    belief = FaultModelParams(rate=0.004, size_bounds=[0.02, 0.2], recorded_drops=3)
    belief.recorded_hours = 10.0
    point = belief.PointModel()
    assert belief.HoldsBelief() and not point.HoldsBelief()
    assert point.rate == 0.004 and list(point.size_bounds) == [0.02, 0.2]
    assert {k: getattr(point, k) for k in POINT_MODEL_VALUES} == POINT_MODEL_VALUES
    assert belief.recorded_drops == 3 and belief.prior_drops == 0.5  # the original untouched
    point.size_bounds[0] = 0.1
    assert list(belief.size_bounds) == [0.02, 0.2]
