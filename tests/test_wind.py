"""Wind that changes in flight: the Dryden gusts against their analytic variance and spectrum,
the drift's ramp and random walk, and the WindSource system against the plain functions."""

import math

import numpy as np
import pytest
from matplotlib import mlab
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from eaplan_drake.flight.wind import (
    BodyToEarth,
    DriftIncrements,
    DriftStep,
    DrydenFilter,
    DrydenSpectra,
    GustSeries,
    LowAltitudeTurbulence,
    WindSource,
)
from eaplan_drake.loading import LoadScenario
from eaplan_drake.params import ScenarioError, WindDriftParams, WindParams

V = 15.0


def test_the_dryden_densities_integrate_to_the_variance():
    """∫₀^∞ Φ_u dω = ∫₀^∞ Φ_v dω = σ² (MIL-HDBK-1797's one-sided normalisation), here by the
    substitution ω = (V/L) tan θ, which maps [0, ∞) onto [0, π/2) (midpoint rule, 2e5 points)."""
    sigma, length = 1.7, 150.0
    n = 200_000
    theta = (np.arange(n) + 0.5) * (0.5 * math.pi / n)
    omega = V / length * np.tan(theta)
    jacobian = V / length / np.cos(theta) ** 2
    for phi in DrydenSpectra(omega, sigma, length, V):
        assert np.sum(phi * jacobian) * (0.5 * math.pi / n) == pytest.approx(sigma**2, rel=1e-6)


@pytest.mark.parametrize("length,step", [(200.0, 0.01), (30.0, 0.05), (5000.0, 1.0)])
def test_the_discrete_filter_is_the_exact_sampling_of_the_shaping_filter(length, step):
    """Φ P∞ Φᵀ + G Gᵀ = P∞ (stationary), C P∞ Cᵀ = σ² I (u and v of variance σ², uncorrelated),
    and G Gᵀ is Q_d = ∫₀^h e^{As} B Bᵀ e^{Aᵀs} ds (a fine quadrature of the lateral block)."""
    sigma = 2.0
    f = DrydenFilter(sigma, length, V, step)
    phi, g, p_factor, c = f.Matrices()
    p = p_factor @ p_factor.T
    np.testing.assert_allclose(phi @ p @ phi.T + g @ g.T, p, rtol=1e-10, atol=1e-14 * p.max())
    np.testing.assert_allclose(c @ p @ c.T, sigma**2 * np.eye(2), atol=1e-9)
    lam = V / length
    s = (np.arange(100_000) + 0.5) * (step / 100_000)
    e = np.exp(-2.0 * lam * s)
    q = np.array([[e.sum(), (s * e).sum()], [(s * e).sum(), (s * s * e).sum()]]) * (step / 1e5)
    np.testing.assert_allclose((g @ g.T)[1:, 1:], q, rtol=1e-6)
    assert (g @ g.T)[0, 0] == pytest.approx(q[0, 0], rel=1e-6)


@pytest.fixture(scope="module")
def gusts():
    """2^19 samples at h = 0.05 s (26 214 s) of σ = 1.5 m/s, L = 30 m gusts at 15 m/s."""
    return GustSeries(1.5, 30.0, V, 0.05, 11, 2**19)


def test_the_gusts_have_the_dryden_variance(gusts):
    """Sample variances within 5 % of σ² = 2.25 m²/s². The standard error of a sample variance
    of a correlated series is σ² sqrt(2 τ_c / T), τ_c = ∫ρ² dt: 1/λ = L/V = 2 s for u (and less
    for v), T = 26 214 s: 1.2 %, so 5 % is four standard errors (a pass has ≈ 1 − 6e-5)."""
    np.testing.assert_allclose(gusts.var(axis=0), 2.25, rtol=0.05)
    np.testing.assert_allclose(gusts.mean(axis=0), 0.0, atol=0.1)  # standard error ≈ 0.02 m/s
    assert abs(np.corrcoef(gusts.T)[0, 1]) < 0.03  # u and v independent


def test_the_gusts_have_the_dryden_spectrum(gusts):
    """Welch's estimate (4096-sample Hann segments, half overlapping: 255 segments) averaged over
    four bands of 0.05–1 Hz is within 10 % of the Dryden densities Φ_u, Φ_v (per Hz: 2π Φ(2πf)).
    Each bin's estimate has a standard error of ≈ 7 % (≈ 230 degrees of freedom); a band holds
    ≥ 20 bins (≥ 10 independent under the Hann window), so a band's is ≤ 2.5 % and 10 % is four
    of them. Aliasing at the 20 Hz sampling adds < 0.3 % below 1 Hz."""
    h = 0.05
    for i in range(2):
        density, f = mlab.psd(
            gusts[:, i],
            NFFT=4096,
            Fs=1.0 / h,
            window=mlab.window_hanning,
            noverlap=2048,
            detrend=mlab.detrend_none,
        )
        dryden = 2.0 * math.pi * DrydenSpectra(2.0 * math.pi * f, 1.5, 30.0, V)[i]
        edges = [0.05, 0.15, 0.3, 0.6, 1.0]
        for lo, hi in zip(edges[:-1], edges[1:], strict=True):
            band = (f >= lo) & (f < hi)
            assert band.sum() >= 20
            ratio = density[band].mean() / dryden[band].mean()
            assert ratio == pytest.approx(1.0, abs=0.1), (i, lo, hi, ratio)


def test_the_low_altitude_scales_of_mil_hdbk_1797():
    # At 1000 ft the low-altitude forms give σ_u = σ_w = 0.1 W₂₀ and L_u = 1000 ft.
    sigma, length = LowAltitudeTurbulence(304.8, 10.0)
    assert sigma == pytest.approx(1.0) and length == pytest.approx(304.8)
    # At 100 ft in light turbulence (W₂₀ = 15 kn): 0.1 · 7.717 / 0.2593^0.4 and 100 / 0.2593^1.2 ft.
    sigma, length = LowAltitudeTurbulence(30.48, 15 * 1852 / 3600)
    assert sigma == pytest.approx(1.324, abs=2e-3)
    assert length == pytest.approx(505.3 * 0.3048, rel=2e-3)
    with pytest.raises(ValueError, match="altitude"):
        LowAltitudeTurbulence(400.0, 5.0)


def test_the_drift_ramps_and_stays_within_its_bounds():
    drift = DriftIncrements(
        WindDriftParams(speed_rate=1.2, direction_rate_deg=-30.0, max_speed=9.0), 0.01
    )
    speed, direction = 5.0, 0.0
    for _ in range(6000):  # 60 s at h = 0.01 s
        speed, direction = DriftStep(speed, direction, (0.0, 0.0), drift)
    assert speed == pytest.approx(6.2, abs=1e-9)
    assert math.degrees(direction) == pytest.approx(-30.0, abs=1e-9)
    for _ in range(30_000):  # another 5 minutes: clipped at the bound
        speed, direction = DriftStep(speed, direction, (0.0, 0.0), drift)
    assert speed == 9.0
    down = DriftIncrements(WindDriftParams(speed_rate=-10.0), 1.0)
    assert DriftStep(0.1, 0.0, (0.0, 0.0), down)[0] == 0.0


def test_the_random_walk_spreads_by_its_sigma_per_minute():
    """After one minute of steps the speed's and the direction's spread is σ_s, σ_θ; 4000 walks
    give the sample standard deviation within 5 % (its standard error is 1.1 %)."""
    drift = DriftIncrements(
        WindDriftParams(speed_sigma=0.8, direction_sigma_deg=20.0, max_speed=1e3), 1.0
    )
    rng = np.random.default_rng(5)
    z = rng.standard_normal((4000, 60, 2))
    ends = []
    for walk in z:
        speed, direction = 500.0, 0.0
        for zk in walk:
            speed, direction = DriftStep(speed, direction, zk, drift)
        ends.append((speed - 500.0, math.degrees(direction)))
    np.testing.assert_allclose(np.std(ends, axis=0), [0.8, 20.0], rtol=0.05)


def _Fly(wind: WindParams, heading: float, t_end: float, h: float = 0.01, seed: int = 3):
    builder = DiagramBuilder()
    source = builder.AddSystem(
        WindSource(wind, airspeed=V, time_step=h, seed=seed, initial_heading=heading)
    )
    kinematics = builder.AddSystem(ConstantVectorSource([0.0, 0.0, heading, 0.0, 0.0]))
    builder.Connect(kinematics.get_output_port(), source.GetInputPort("kinematics"))
    log_w = LogVectorOutput(source.GetOutputPort("wind"), builder, publish_period=h)
    log_m = LogVectorOutput(source.GetOutputPort("mean_wind"), builder, publish_period=h)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(t_end)
    ctx = simulator.get_context()
    return (
        log_w.FindLog(ctx).data().T.copy(),
        log_m.FindLog(ctx).data().T.copy(),
    )


def test_the_wind_source_adds_the_rotated_gusts_of_the_plain_function_to_the_mean_wind():
    wind = WindParams(speed=4.0, direction_deg=30.0)
    wind.gusts.sigma, wind.gusts.length_scale = 1.0, 100.0
    heading = 2.0
    total, mean = _Fly(wind, heading, 2.0)
    np.testing.assert_allclose(mean, np.tile(wind.Vector(), (len(mean), 1)), atol=1e-12)
    series = GustSeries(1.0, 100.0, V, 0.01, 3, len(total))
    earth = np.array([BodyToEarth(u, v, heading) for u, v in series])
    np.testing.assert_allclose(total - mean, earth, atol=1e-12)
    again, _ = _Fly(wind, heading, 2.0)
    np.testing.assert_array_equal(total, again)  # a pure function of the seed
    other, _ = _Fly(wind, heading, 2.0, seed=4)
    assert not np.allclose(total, other)


def test_the_wind_source_ramps_its_mean_wind():
    wind = WindParams(speed=3.0, direction_deg=90.0)
    wind.drift.speed_rate, wind.drift.direction_rate_deg = 2.0, 60.0
    total, mean = _Fly(wind, 0.0, 30.0, h=0.05)
    np.testing.assert_array_equal(total, mean)  # no gusts
    expected = 3.0 + 2.0 * 0.5  # half a minute
    assert np.hypot(*mean[-1]) == pytest.approx(expected, rel=1e-9)
    assert math.degrees(math.atan2(mean[-1][1], mean[-1][0])) == pytest.approx(120.0, abs=1e-7)


def test_the_changing_wind_keys_are_checked_and_named():
    for data, match in (
        ("wind: {gusts: {sigma: 11}}", r"wind.gusts.sigma: must be in \[0, 10\]"),
        ("wind: {gusts: {length_scale: 0}}", r"wind.gusts.length_scale: must be in \[1, 10000\]"),
        ("wind: {drift: {speed_rate: 20}}", r"wind.drift.speed_rate: must be in \[-10, 10\]"),
        ("wind: {drift: {direction_sigma_deg: -1}}", r"wind.drift.direction_sigma_deg: must be"),
        ("wind: {drift: {speed_sigma: 1, max_speed: 15}}", "wind.drift.max_speed: must be below"),
        ("wind: {speed: 8, drift: {speed_rate: 1, max_speed: 6}}", "must be >= wind.speed = 8"),
        ("wind: {seed: -1}", "wind.seed: must be an integer >= 0"),
        ("wind: {estimator: {time_constant: 0}}", r"wind.estimator.time_constant: must be in"),
        ("wind: {staircase: true}", "wind.staircase"),
    ):
        with pytest.raises(ScenarioError, match=match):
            LoadScenario(data=data)
    # A max_speed above the airspeed is no error while the wind does not drift.
    LoadScenario(data="wind: {drift: {max_speed: 20}}")


def test_the_wind_seed_derives_from_the_scenario_seed():
    s = LoadScenario(data="wind: {seed: 7}")
    assert s.WindSeed() == 7
    s.random_seed = 3
    assert s.WindSeed() not in (7, s.SensorSeed())
    assert s.WindSeed() == LoadScenario(data="random_seed: 3").WindSeed()
