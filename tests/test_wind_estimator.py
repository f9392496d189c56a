"""The aircraft's wind estimate against a known wind (constant, ramping, with gusts), the
sequencer's staircase priced in it, and the wiring of ``wind.staircase``."""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from eaplan_drake.diagram import MakeEaplanDiagram
from eaplan_drake.flight.coverage import ZamboniCoverage
from eaplan_drake.flight.plant import FixedWingArcPlant, GroundVelocity
from eaplan_drake.flight.sequencer import StageSequencer, StaircaseWind
from eaplan_drake.flight.stages import StageTime
from eaplan_drake.flight.wind import DrydenFilter, GustSeries, WindSource
from eaplan_drake.flight.wind_estimator import (
    EstimatorStep,
    WindEstimateStep,
    WindEstimator,
    WindFilterGain,
    WindMeasurement,
)
from eaplan_drake.loading import LoadScenario
from eaplan_drake.params import CoverageParams, GuidanceParams, VehicleParams, WindParams

V = 15.0


def test_the_measurement_is_the_wind_of_the_ground_velocity():
    for heading in (0.0, 1.0, -2.5, 7.0):
        wind = (3.0, -4.5)
        m = WindMeasurement(GroundVelocity(heading, wind, V), heading, V)
        np.testing.assert_allclose(m, wind, atol=1e-13)


def _Filter(measurements, estimate, gain):
    out = []
    for m in measurements:
        out.append(estimate)
        estimate = WindEstimateStep(estimate, m, gain)
    return np.array(out)


def test_a_constant_wind_is_reached_as_one_minus_alpha_to_the_k():
    gain = WindFilterGain(10.0, 0.01)
    assert gain == pytest.approx(1.0 - math.exp(-0.001), rel=1e-12)
    w = np.array([6.0, -2.0])
    estimate = _Filter(np.tile(w, (3000, 1)), (0.0, 0.0), gain)
    k = np.arange(3000)[:, None]
    np.testing.assert_allclose(w - estimate, w * (1.0 - gain) ** k, rtol=1e-9, atol=1e-12)


def test_a_ramping_wind_is_followed_with_the_lag_r_h_over_alpha():
    h, tau, r = 0.01, 10.0, 0.05  # 3 m/s per minute
    gain = WindFilterGain(tau, h)
    t = np.arange(20_000) * h  # 200 s: 20 time constants
    wind = np.stack([r * t, -0.5 * r * t], axis=1)
    estimate = _Filter(wind, (0.0, 0.0), gain)
    lag = r * h / gain
    assert lag == pytest.approx(r * (tau + h / 2), rel=1e-4)
    np.testing.assert_allclose(wind[-1] - estimate[-1], [lag, -0.5 * lag], rtol=1e-6)


def _StationaryCovariance(a, q):
    """P = A P Aᵀ + Q of a stable discrete system (the Kronecker form, n² unknowns)."""
    n = a.shape[0]
    return np.linalg.solve(np.eye(n * n) - np.kron(a, a), q.reshape(-1)).reshape(n, n)


def test_with_gusts_the_error_has_the_variance_of_the_joint_linear_system():
    """Gusts (σ = 1.5 m/s, L = 30 m, so V/L = 0.5 1/s) on a zero mean wind, τ = 2 s: the joint
    system z = (x_u, x_1, x_2, ŵ_u, ŵ_v), z' = [[Φ, 0], [αC, (1 − α)I]] z + [G; 0] n has the
    stationary covariance P; the estimate's error against the mean wind (ŵ) and against the wind
    (C x − ŵ) have the variances of P. 2^19 samples at h = 0.05 s (T = 26 214 s) match within
    10 %; on eight seeds not used here the largest deviation was 4.7 %."""
    h, tau = 0.05, 2.0
    f = DrydenFilter(1.5, 30.0, V, h)
    phi, g, _, c = f.Matrices()
    alpha = WindFilterGain(tau, h)
    a = np.zeros((5, 5))
    a[:3, :3], a[3:, :3], a[3:, 3:] = phi, alpha * c, (1.0 - alpha) * np.eye(2)
    b = np.zeros((5, 3))
    b[:3] = g
    p = _StationaryCovariance(a, b @ b.T)
    to_mean = np.hstack([np.zeros((2, 3)), np.eye(2)])
    to_wind = np.hstack([c, -np.eye(2)])
    # The longitudinal estimate passes the share (1/τ) / (V/L + 1/τ) = 0.5 of σ² (continuous
    # first-order filter on a first-order gust; the discrete one within 0.1 %).
    assert (to_mean @ p @ to_mean.T)[0, 0] == pytest.approx(2.25 * 0.5, rel=1e-3)
    gusts = GustSeries(1.5, 30.0, V, h, 21, 2**19)
    estimate = _Filter(gusts, (0.0, 0.0), alpha)[2000:]  # after 50 τ
    np.testing.assert_allclose(estimate.var(axis=0), np.diag(to_mean @ p @ to_mean.T), rtol=0.1)
    np.testing.assert_allclose(
        (gusts[2000:] - estimate).var(axis=0), np.diag(to_wind @ p @ to_wind.T), rtol=0.1
    )


def test_the_system_follows_a_drifting_wind_in_a_closed_loop_with_the_plant():
    """Plant (exact arc, heading held), a wind ramping 3 m/s per minute, the estimator with
    τ = 5 s: after 60 s (12 τ) ŵ lags w̄ by r (h/α + h) along the wind, h/α for the filter and
    h because the plant's ground velocity carries the wind of the step before."""
    h, tau, rate = 0.01, 5.0, 3.0
    wind = WindParams(speed=2.0, direction_deg=45.0)
    wind.drift.speed_rate = rate
    builder = DiagramBuilder()
    vehicle = VehicleParams()
    plant = builder.AddSystem(FixedWingArcPlant(vehicle, step=h))
    source = builder.AddSystem(WindSource(wind, airspeed=V, time_step=h, seed=0))
    estimator = builder.AddSystem(
        WindEstimator(airspeed=V, time_constant=tau, time_step=h, initial_wind=wind.Vector())
    )
    zero = builder.AddSystem(ConstantVectorSource([0.0]))
    builder.Connect(zero.get_output_port(), plant.GetInputPort("heading_rate_command"))
    builder.Connect(source.GetOutputPort("wind"), plant.GetInputPort("wind"))
    builder.Connect(plant.GetOutputPort("kinematics"), source.GetInputPort("kinematics"))
    builder.Connect(plant.GetOutputPort("kinematics"), estimator.GetInputPort("kinematics"))
    log_hat = LogVectorOutput(estimator.GetOutputPort("wind_estimate"), builder, 0.5)
    log_mean = LogVectorOutput(source.GetOutputPort("mean_wind"), builder, 0.5)
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(60.0)
    ctx = simulator.get_context()
    w_hat = log_hat.FindLog(ctx).data()[:, -1]
    w_bar = log_mean.FindLog(ctx).data()[:, -1]
    r = rate / 60.0
    lag = r * (h / WindFilterGain(tau, h) + h)
    direction = np.array([math.cos(math.pi / 4), math.sin(math.pi / 4)])
    np.testing.assert_allclose(w_bar - w_hat, lag * direction, rtol=1e-4)
    assert np.hypot(*w_bar) == pytest.approx(2.0 + rate, rel=1e-9)


def test_the_estimator_step_is_a_power_of_two_times_the_plants():
    assert EstimatorStep(0.01) == 0.08
    assert EstimatorStep(0.005) == 0.08
    assert EstimatorStep(0.1) == 0.1 and EstimatorStep(0.3) == 0.3
    h = 0.01
    step = EstimatorStep(h)
    assert all(k * step == (8 * k) * h for k in range(1, 200_000, 7))  # the same event times


def test_the_staircase_wind_is_capped_below_the_airspeed():
    assert StaircaseWind((3.0, 4.0), V) == (3.0, 4.0)
    np.testing.assert_allclose(StaircaseWind((20.0, 0.0), V), (13.5, 0.0))
    assert StaircaseWind((math.nan, 1.0), V) == (0.0, 0.0)


def test_a_wind_input_reprices_the_staircase_at_the_next_stage_switch():
    plan = ZamboniCoverage(
        CoverageParams(),
        start=(-100.0, 220.0),
        airspeed=V,
        initial_c1=0.0,
        k_e=GuidanceParams().k_e,
    )
    grid = np.linspace(-1000.0, 0.0, 3)
    w0, w1 = np.array([5.0, 0.0]), np.array([-2.0, 6.0])
    kwargs = dict(trigger_radius=2.0, initial_period=46.0, path_parameter_grid=grid)
    priced = StageSequencer(plan, wind=w0, wind_input=True, **kwargs)
    known = StageSequencer(plan, wind=w1, **kwargs)
    assert priced.GetInputPort("wind").size() == 2
    contexts = [priced.CreateDefaultContext(), known.CreateDefaultContext()]
    first = plan.Stages(0.0)[0]
    t0 = priced.GetOutputPort("remaining_time").Eval(contexts[0])
    assert t0[-1] == pytest.approx(
        StageTime(first, V, w0) + plan.TimeAfter(0, first.anchor, 0.0, V, w0)
    )
    priced.GetInputPort("wind").FixValue(contexts[0], w1)
    for seq, ctx in zip((priced, known), contexts, strict=True):
        ctx.SetTime(10.0)
        seq.GetInputPort("position").FixValue(ctx, np.asarray(first.trigger, dtype=float))
        seq.GetInputPort("path_parameters").FixValue(ctx, [0.0])
        ctx.get_mutable_discrete_state().SetFrom(seq.EvalUniquePeriodicDiscreteUpdate(ctx))
    np.testing.assert_array_equal(priced.PricedWind(contexts[0]), w1)
    np.testing.assert_allclose(
        priced.GetOutputPort("remaining_time").Eval(contexts[0]),
        known.GetOutputPort("remaining_time").Eval(contexts[1]),
        rtol=1e-12,
    )


@pytest.mark.parametrize(
    "data,wind_system,estimator,sequencer_wind",
    [
        ("", "ConstantVectorSource", False, None),
        ("wind: {gusts: {sigma: 1.0}}", "WindSource", False, None),
        ("wind: {staircase: estimated}", "ConstantVectorSource", True, "wind_estimator"),
        ("wind: {drift: {speed_sigma: 1.0}, staircase: truth}", "WindSource", False, "wind"),
    ],
)
def test_the_scenario_switches_choose_the_systems_and_the_staircase_wind(
    data, wind_system, estimator, sequencer_wind
):
    diagram = MakeEaplanDiagram(LoadScenario(data=data), log_period=0.0)
    assert type(diagram.GetSubsystemByName("wind")).__name__.startswith(wind_system)
    assert diagram.HasSubsystemNamed("wind_estimator") == estimator
    sequencer = diagram.GetSubsystemByName("sequencer")
    if sequencer_wind is None:
        assert not sequencer.HasInputPort("wind")
        return
    sources = {
        (system.get_name(), system.get_input_port(i).get_name()): source.get_name()
        for (system, i), (source, _) in diagram.connection_map().items()
    }
    assert sources[("sequencer", "wind")] == sequencer_wind


@pytest.mark.slow
def test_a_flight_in_a_changing_world_is_a_function_of_its_scenario():
    """plan i with gusts, a drifting wind, the estimated staircase, a worn pack and a payload
    off its table flies to its end; twice the same scenario gives the same log, bit for bit."""
    from eaplan_drake.loading import LoadNamedScenario
    from eaplan_drake.simulation import Simulate

    overrides = [
        "wind: {gusts: {sigma: 1.5}, drift: {speed_sigma: 1.0, direction_sigma_deg: 15},"
        " staircase: estimated}",
        "battery: {health: 0.9}",
        "computation: {power_offset: 1.5}",
        "random_seed: 4",
    ]
    logs = [Simulate(LoadNamedScenario("plan_i", overrides)) for _ in range(2)]
    assert logs[0].summary["status"] in ("complete", "reserve_reached")
    for name, signal in logs[0].signals.items():
        np.testing.assert_array_equal(signal, logs[1].signals[name], err_msg=name)


@pytest.mark.slow
def test_in_a_constant_wind_the_estimated_and_true_staircases_fly_the_scenarios_flight():
    """The shipped survey (the default mpc policy reads the staircase) in its constant 5 m/s
    wind: the estimate starts at the scenario's wind and measures it, so pricing the staircase
    in it, or in the true mean wind, makes the same decisions and ends at the same SoC."""
    from eaplan_drake.loading import LoadNamedScenario
    from eaplan_drake.simulation import Simulate

    base = Simulate(LoadNamedScenario("survey"))
    for staircase in ("estimated", "truth"):
        log = Simulate(LoadNamedScenario("survey", [f"wind: {{staircase: {staircase}}}"]))
        for name in ("path_parameters", "computation_parameters"):
            np.testing.assert_allclose(log.signals[name], base.signals[name], atol=1e-9)
        assert log.summary["final_soc"] == pytest.approx(base.summary["final_soc"], abs=1e-9)
