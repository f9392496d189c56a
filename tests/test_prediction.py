"""Tests of the planners' shared prediction (planning/prediction.py): free response, Simpson
SoC rollout and its sensitivity, the Eq. 10 coverage-time model and the path rule."""

import numpy as np
import pytest
from planner_cases import COVERAGE_TIMES, ORDER, PERIOD, Q_REF, Fourier

from eaplan_drake.energy.battery import (
    MaxDeliverablePower,
    RintCurrent,
    SocAfter,
    SocDerivative,
    SocDerivativeSlope,
)
from eaplan_drake.energy.computation import LoadComputationTable
from eaplan_drake.flight.coverage import ScalingFactors
from eaplan_drake.params import BatteryParams, PlannerParams
from eaplan_drake.planning.paper import MakePlannerProgram
from eaplan_drake.planning.prediction import (
    ChoosePathParameter,
    CoverageTimeModel,
    FreeResponse,
    SimpsonSoc,
    SimpsonSocSensitivity,
    SimpsonSocSteps,
    SimpsonSteps,
    StepLoads,
)
from eaplan_drake.planning.prediction import TimeToReserve as PureTimeToReserve


def test_free_response_matches_fourier_series():
    t = 0.5 * np.arange(101)
    f = FreeResponse(Q_REF, ORDER, PERIOD, 0.5, t.size)
    np.testing.assert_allclose(f, Fourier(Q_REF, t, PERIOD), atol=1e-9)


def test_simpson_soc_exact_for_constant_and_accurate_for_periodic_load():
    battery = BatteryParams()
    b = SimpsonSoc(np.full(21, 35.0), 0.9, battery, 1.0)
    np.testing.assert_allclose(b, SocAfter(0.9, 35.0, np.arange(11.0), battery), atol=1e-14)
    # Periodic load: Simpson (RK4) per 1 s step vs a fine trapezoid over 10 s.
    t_fine = np.linspace(0.0, 10.0, 200_001)
    bdot = SocDerivative(Fourier(Q_REF, t_fine, PERIOD), battery)
    exact = 0.9 + np.sum(0.5 * (bdot[1:] + bdot[:-1]) * np.diff(t_fine))
    b = SimpsonSoc(Fourier(Q_REF, 0.5 * np.arange(21), PERIOD), 0.9, battery, 1.0)
    assert abs(b[-1] - exact) < 1e-10


def test_simpson_soc_from_half_samples_equals_the_three_row_form_bit_for_bit():
    """SimpsonSoc evaluates ḃ once per half-step sample; the SoC is exactly that of
    SimpsonSocSteps on StepLoads' start, middle and end rows (brown-out loads included)."""
    battery = BatteryParams()
    rng = np.random.default_rng(4)
    for i in range(300):
        n = int(rng.integers(1, 600))
        shape = (2 * n + 1,) + ((int(rng.integers(1, 4)),) if i % 3 == 0 else ())
        y = rng.uniform(-50.0, 400.0, shape)
        y[int(rng.integers(0, 2 * n + 1))] = 1e9 if i % 5 == 0 else y[0]
        soc0, h = rng.uniform(0.0, 1.0), rng.uniform(0.1, 3.0)
        want = SimpsonSocSteps(StepLoads(y), soc0, battery, h)
        assert np.array_equal(SimpsonSoc(y, soc0, battery, h), want)
        # the smooth model's node values and sensitivity, from the same per-sample evaluation
        slope = SocDerivativeSlope(y, battery)
        sensitivity = SimpsonSocSensitivity(StepLoads(y), battery, h)
        assert np.array_equal(SimpsonSteps(slope, h), sensitivity)
        assert np.array_equal(slope[0::2], SocDerivativeSlope(y[0::2], battery))
        assert np.array_equal(SocDerivative(y, battery)[0::2], SocDerivative(y[0::2], battery))


def test_simpson_soc_sensitivity_is_the_analytic_derivative():
    battery = BatteryParams()
    V, R = battery.voltage, battery.internal_resistance
    # Constant load y over a step h: Δb = −h k_b I(y)/Q_c, ∂Δb/∂y = −h k_b / (Q_c sqrt(V² − 4Ry)).
    y = np.array([10.0, 35.0, 1000.0])
    loads = np.broadcast_to(y, (3, 3))
    expected = -2.0 * battery.k_b / (battery.capacity * np.sqrt(V * V - 4.0 * R * y))
    np.testing.assert_allclose(SimpsonSocSensitivity(loads, battery, 2.0), expected, rtol=1e-12)
    # A periodic load: against central differences of the rollout's steps.
    f = Fourier(Q_REF, 0.5 * np.arange(13), PERIOD)
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
