"""Tests of the power-log reader, the model fit and ``eaplan-drake fit``."""

import dataclasses as dc
import math
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from eaplan_drake.cli import main
from eaplan_drake.energy.estimator import KalmanPredict, KalmanUpdate
from eaplan_drake.energy.fourier import AugmentedOrder, DiscreteEnergyMatrices, OutputMatrix
from eaplan_drake.loading import LayerScenario, LoadNamedScenario, LoadScenario, ShippedNames
from eaplan_drake.logfit.filtering import (
    FilterPowerSeries,
    HorizonSteps,
    NoiseParameters,
    PeriodInForce,
    PeriodSeries,
    PredictAhead,
    SteadyStateCovariance,
    UniformPowerSeries,
)
from eaplan_drake.logfit.fit import FitPowerLog, FitPowerModel, SyntheticPower
from eaplan_drake.logfit.noise import (
    NOISE_CRITERIA,
    FitLevelNoise,
    FitNoise,
    InnovationLogLikelihood,
    LikelihoodScaledNoise,
    MultiStepError,
)
from eaplan_drake.logfit.powerlog import (
    PowerLogError,
    ReadPeriodLog,
    ReadPowerLog,
    ReferenceDirectory,
)
from eaplan_drake.logfit.result import HORIZONS_SUFFIX, NOISE_CRITERIA_TEXT, PowerModelFit
from eaplan_drake.logfit.scores import BaselinePrediction, ScorePredictions

DATA = resources.files("eaplan_drake") / "data"
T = 46.0


def _synthetic(seed, tau=15.0, sigma=3.0, noise=0.5, dt=0.5, duration=1200.0):
    """Periodic power + AR(1) load (τ, σ) + white noise, on a uniform grid."""
    return SyntheticPower(seed, tau, sigma, noise, dt, duration, period=T)


def test_steady_state_covariance_solves_the_riccati_equation():
    model = AugmentedOrder(2, 10.0)
    Ad, _ = DiscreteEnergyMatrices(model, T, 0.5)
    c = OutputMatrix(model)[0]
    Q = np.diag([1e-3, 1e-4, 1e-4, 1e-4, 1e-4, 0.2])
    R = 0.25
    P = SteadyStateCovariance(Ad, c, Q, R)
    u = P @ c
    residual = Ad @ (P - np.outer(u, u) / (c @ u + R)) @ Ad.T + Q - P
    assert np.max(np.abs(residual)) < 1e-10 * np.max(np.abs(P))
    assert np.all(np.linalg.eigvalsh(P) > 0.0)


def test_filter_equals_the_estimator_kalman_functions_from_the_steady_state():
    """FilterPowerSeries (steady-state gain) = KalmanUpdate/KalmanPredict started at P∞."""
    t, z = _synthetic(1, duration=200.0)
    noise = NoiseParameters(0.3, 1e-5, 1e-4, 15.0, 1.0)
    model = noise.Model(3)
    Ad, _ = DiscreteEnergyMatrices(model, T, 0.5)
    C = OutputMatrix(model)
    Q = np.diag([1e-5 + 1e-4] + [1e-5] * 6 + [0.5 * 1.0 * 15.0 * (1 - math.exp(-1 / 15.0))])
    q0 = np.array([30.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    states, e, s = FilterPowerSeries(z, 0.5, 3, T, noise, initial_state=q0)
    P = SteadyStateCovariance(Ad, C[0], Q, 0.3)
    q = q0
    for k in range(z.size):
        assert e[k] == pytest.approx(z[k] - float(C[0] @ q), abs=1e-9)
        q, P = KalmanUpdate(q, P, C, 0.3, z[k])
        np.testing.assert_allclose(states[k], q, rtol=0.0, atol=1e-8)
        q, P = KalmanPredict(q, P, Ad, Q)


def test_fit_noise_recovers_the_aperiodic_load_and_sensor_noise():
    """τ = 10 s, σ_d = 3 W, σ_v = 0.5 W from 2400 samples (the paper model's Q on q free)."""
    _, z = _synthetic(2, tau=10.0, sigma=3.0, noise=0.5, dt=1.0, duration=2400.0)
    noise, ll = FitNoise(z, 1.0, 3, T, max_evaluations=150, level=False)
    assert math.isfinite(ll)
    assert noise.aperiodic_time_constant == pytest.approx(10.0, rel=0.2)
    stationary = 0.5 * noise.aperiodic_noise * noise.aperiodic_time_constant
    assert math.sqrt(stationary) == pytest.approx(3.0, rel=0.1)
    assert math.sqrt(noise.measurement_noise) == pytest.approx(0.5, rel=0.15)
    assert noise.mean_process_noise == 0.0


def _ar1_plus_noise(seed, n=3000, dt=0.5, tau=15.0, sigma=3.0, noise=0.5):
    """30 W + an AR(1) load (τ [s], stationary σ [W]) + white noise (σ_v [W]); no periodic part."""
    rng = np.random.default_rng(seed)
    phi = math.exp(-dt / tau)
    e = rng.normal(0.0, sigma * math.sqrt(1.0 - phi * phi), n)
    d = np.zeros(n)
    for k in range(1, n):
        d[k] = phi * d[k - 1] + e[k]
    return 30.0 + d + rng.normal(0.0, noise, n)


def test_multi_step_error_relative_sums_the_log_of_each_horizon():
    """MultiStepError is Σ_H MSE_H; relative=True is Σ_H log MSE_H of the same MSE_H."""
    z = _ar1_plus_noise(1, n=600)
    noise = NoiseParameters(0.25, 0.0, 0.0, 15.0, 1.2)
    states, _, _ = FilterPowerSeries(z, 0.5, 0, T, noise)
    mse = []
    for H in HorizonSteps(T, 0.5):
        pred = PredictAhead(states, 0, T, 0.5, noise, H)
        k = np.arange(300 - H, z.size - H)
        mse.append(float(np.mean((pred[k] - z[k + H]) ** 2)))
    assert MultiStepError(z, 0.5, 0, T, noise, 300) == pytest.approx(sum(mse), rel=1e-12)
    relative = MultiStepError(z, 0.5, 0, T, noise, 300, relative=True)
    assert relative == pytest.approx(sum(math.log(v) for v in mse), rel=1e-12)


def test_noise_for_the_horizons_recovers_an_ar1_load():
    """AR(1) load (τ = 15 s, σ = 3 W: q_d = 2σ²/τ = 1.2 W²/s) + white noise (R = 0.25 W²), r = 0.
    The true model's filter is the best predictor at every horizon, so the multi-step fit
    reaches a criterion no worse than the true noise's (it is the minimiser; 0.002 slack for
    the finite search), finds τ within 25 %, and with the scale from the likelihood R and q_d
    within 20 % of the truth."""
    z = _ar1_plus_noise(2, n=4000)
    noise, ll = FitNoise(z, 0.5, 0, T, level=False, criterion="horizons")
    assert math.isfinite(ll) and noise.mean_process_noise == 0.0
    assert noise.aperiodic_time_constant == pytest.approx(15.0, rel=0.25)
    assert noise.measurement_noise == pytest.approx(0.25, rel=0.2)
    assert noise.aperiodic_noise == pytest.approx(1.2, rel=0.2)
    truth = NoiseParameters(0.25, 0.0, 0.0, 15.0, 1.2)
    first = 92 + 92  # burn-in (one period, T/Δt = 92 samples) + one period
    fitted = MultiStepError(z, 0.5, 0, T, noise, first, relative=True)
    assert fitted <= MultiStepError(z, 0.5, 0, T, truth, first, relative=True) + 0.002
    with pytest.raises(ValueError, match="criterion: one of likelihood, horizons"):
        FitNoise(z, 0.5, 0, T, criterion="one step")


def test_likelihood_scaled_noise_maximises_the_likelihood_over_the_scale():
    """c = mean(e²/s) maximises ℓ(c θ): after scaling mean(e²/s) = 1, ℓ is lower at ½ and 2 times
    the scaled noise, the point predictions (gains) are unchanged and τ is kept."""
    z = _ar1_plus_noise(3, n=1200)
    rough = NoiseParameters(3.0, 1e-3, 2e-3, 15.0, 10.0)
    scaled, ll = LikelihoodScaledNoise(z, 0.5, 0, T, rough)
    c = scaled.measurement_noise / rough.measurement_noise
    assert c < 0.5  # the rough noise was too large
    for name in ("process_noise", "mean_process_noise", "aperiodic_noise"):
        assert getattr(scaled, name) == pytest.approx(c * getattr(rough, name), rel=1e-12)
    assert scaled.aperiodic_time_constant == 15.0
    states, e, s = FilterPowerSeries(z, 0.5, 0, T, scaled)
    assert float(np.mean(e[92:] ** 2 / s)) == pytest.approx(1.0, rel=1e-9)
    assert ll == pytest.approx(InnovationLogLikelihood(z, 0.5, 0, T, scaled), rel=1e-12)
    for factor in (0.5, 2.0):
        assert InnovationLogLikelihood(z, 0.5, 0, T, scaled.Scaled(factor)) < ll
    rough_states, _, _ = FilterPowerSeries(z, 0.5, 0, T, rough)
    np.testing.assert_allclose(states, rough_states, rtol=0, atol=1e-9)


def test_noise_for_the_horizons_is_scale_equivariant():
    """Power ×10: the multi-step fit's variances ×100, τ the same (Σ log MSE_H only shifts)."""
    z = _ar1_plus_noise(4, n=1500)
    a, _ = FitNoise(z, 0.5, 1, T, max_evaluations=60, criterion="horizons")
    b, _ = FitNoise(10.0 * z, 0.5, 1, T, max_evaluations=60, criterion="horizons")
    assert b.aperiodic_time_constant == pytest.approx(a.aperiodic_time_constant, rel=1e-6)
    for name in ("measurement_noise", "process_noise", "mean_process_noise", "aperiodic_noise"):
        assert getattr(b, name) == pytest.approx(100.0 * getattr(a, name), rel=1e-6), name


def test_fit_power_model_tries_the_noise_for_the_horizons():
    """The chosen structure with its noise fitted for the horizons is a held-out candidate (its
    name ends in HORIZONS_SUFFIX); the fit says which criterion its noise came from, and so do
    the scenario fragment's header and its name."""
    _, z = _synthetic(5, tau=15.0, sigma=3.0, duration=600.0)
    fit = FitPowerModel(z[: z.size // 2], 0.5, T, orders=(2,), max_evaluations=45)
    names = [c[3] for c in fit.candidates]
    assert sum(name.endswith(HORIZONS_SUFFIX) for name in names) == 1
    text = {
        "likelihood": "innovation likelihood",
        "horizons": "multi-step error",
        "level": "likelihood, q_0 by multi-step error",
    }
    assert f"noise by {text[fit.noise_criterion]})" in fit.ScenarioFragment()
    assert set(NOISE_CRITERIA) < set(NOISE_CRITERIA_TEXT) == set(text)


def test_baselines_on_analytic_signals():
    z = np.arange(100.0)  # a ramp: last value misses by H, the moving average by (P − 1)/2 + H
    P, H = 10, 3
    k = 50
    assert BaselinePrediction("last value", z, P, H)[k] == 50.0
    assert BaselinePrediction("moving average", z, P, H)[k] == pytest.approx(np.mean(z[41:51]))
    assert BaselinePrediction("seasonal naive", z, P, H)[k] == z[k + H - P]
    assert np.isnan(BaselinePrediction("moving average", z, P, H)[P - 2])
    periodic = np.tile(np.arange(P, dtype=float), 10)
    pred = BaselinePrediction("seasonal naive", periodic, P, H)
    np.testing.assert_array_equal(pred[P:-H], periodic[P + H :])
    with pytest.raises(ValueError, match="baseline"):
        BaselinePrediction("oracle", z, P, H)
    assert HorizonSteps(46.0, 0.5) == (1, 23, 46, 92)


def test_model_beats_every_baseline_on_periodic_plus_ar1_load():
    """The issue's synthetic target at T/4 and T/2 (≥ 10 % better) and within 10 % at 1 step."""
    _, z = _synthetic(3, tau=15.0, sigma=3.0, duration=900.0)
    fit = FitPowerModel(z[: z.size // 2], 0.5, T, orders=(2, 3), max_evaluations=100)
    scores = ScorePredictions(z, 0.5, T, fit)
    for h in ("T/4", "T/2"):
        best = min(scores[b][h][0] for b in ("last value", "moving average", "seasonal naive"))
        assert scores["model"][h][0] <= 0.9 * best, (h, scores)
    assert scores["model"]["1 step"][0] <= 1.1 * scores["last value"]["1 step"][0]


def test_uniform_series_and_its_errors():
    t, z = UniformPowerSeries(
        [0.0, 1.0, 2.5, 3.0] * 1 + list(np.arange(4.0, 20.0)), np.arange(20.0)
    )
    assert np.allclose(np.diff(t), 1.0)
    with pytest.raises(ValueError, match="increasing"):
        UniformPowerSeries(np.r_[np.arange(20.0), 5.0], np.arange(21.0))
    with pytest.raises(ValueError, match="at least 16"):
        UniformPowerSeries(np.arange(5.0), np.arange(5.0))
    with pytest.raises(ValueError, match=r"hold 0\.88 periods of 40 s, less than the one"):
        FitPowerModel(np.zeros(50), 1.0, 40.0)


def test_read_px4_battery_status_export():
    with resources.as_file(DATA / "px4_battery_status_example.csv") as path:
        log = ReadPowerLog(path)
    raw = np.genfromtxt(str(DATA / "px4_battery_status_example.csv"), delimiter=",", names=True)
    np.testing.assert_allclose(log.power, raw["voltage_v"] * raw["current_a"])
    np.testing.assert_allclose(log.times, (raw["timestamp"] - raw["timestamp"][0]) * 1e-6)
    assert "voltage_v × current_a" in log.source


def test_read_paparazzi_energy_log():
    with resources.as_file(DATA / "opterra_pprz_energy.csv") as path:
        log = ReadPowerLog(path)
        assert log.times.size == 640
        assert log.times[1] == pytest.approx(0.5)
        assert log.power.mean() == pytest.approx(27.666, abs=1e-3)
        other = ReadPowerLog(path, time_step=0.2)
        assert other.times[-1] == pytest.approx(639 * 0.2)


def test_read_columns_by_option_and_clear_errors(tmp_path):
    f = tmp_path / "log.csv"
    f.write_text("sec,volts,amps\n" + "".join(f"{i},{15 + i % 3},{2 + i % 5}\n" for i in range(30)))
    with pytest.raises(PowerLogError, match=r"log.csv:1: no time column"):
        ReadPowerLog(f)
    log = ReadPowerLog(f, time_column="sec", voltage_column="volts", current_column=2)
    assert log.power[4] == (15 + 1) * (2 + 4)
    with pytest.raises(PowerLogError, match=r"--power-column 'watts' is not a column"):
        ReadPowerLog(f, time_column="sec", power_column="watts")
    bad = tmp_path / "bad.csv"
    bad.write_text("t,power\n0,1\n1,2\n2,x3\n")
    with pytest.raises(PowerLogError, match=r"bad.csv:4:3: not a number: 'x3'"):
        ReadPowerLog(bad)
    empty = tmp_path / "empty.csv"
    empty.write_text("\n\n")
    with pytest.raises(PowerLogError, match="empty file"):
        ReadPowerLog(empty)
    with pytest.raises(PowerLogError, match="missing.csv: no such file"):
        ReadPowerLog(tmp_path / "missing.csv")


def test_scenario_fragment_loads_as_a_scenario():
    fit = PowerModelFit(2, 49.9, 0.5, NoiseParameters(0.01, 1e-6, 1e-4, 16.0, 0.2), 0.0, 24.0, [])
    s = LoadScenario(data=fit.ScenarioFragment(estimator_rate=100.0))
    assert s.energy_model.order == 2 and s.energy_model.initial_period == pytest.approx(49.9)
    assert s.estimator.process_noise == pytest.approx(1e-6 * 0.01 / 0.5)
    assert s.estimator.mean_process_noise == pytest.approx(1e-4 * 0.01 / 0.5)
    assert s.estimator.aperiodic_time_constant == pytest.approx(16.0)
    assert s.estimator.aperiodic_noise == pytest.approx(0.2)
    assert s.sensor.noise_std == pytest.approx(0.1)
    walk = PowerModelFit(1, 40.0, 1.0, NoiseParameters(0.01, 1e-6, 0.0, math.inf, 0.2), 0, 5, [])
    assert math.isinf(LoadScenario(data=walk.ScenarioFragment()).estimator.aperiodic_time_constant)


def test_cli_fit_writes_fragment_and_plot(tmp_path, capsys):
    t, z = _synthetic(4, duration=400.0)
    log = tmp_path / "flight.csv"
    log.write_text(
        "time_s,power_w\n" + "".join(f"{a:.2f},{b:.4f}\n" for a, b in zip(t, z, strict=True))
    )
    out = tmp_path / "out"
    code = main(["fit", str(log), "--period", "46", "--orders", "3", "--out", str(out)])
    text = capsys.readouterr().out
    assert code == 0
    for name in ("model", "last value", "moving average", "seasonal naive", "T/4"):
        assert name in text
    assert (out / "fit.png").stat().st_size > 1000
    assert LoadScenario(filename=out / "fit.yaml").energy_model.order == 3


def test_cli_fit_bad_file_is_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("time,power\n0,1\n1,oops\n")
    assert main(["fit", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"eaplan-drake: input error: {bad}:3:3: not a number: 'oops'"]
    assert not (tmp_path / "o").exists()
    noise = tmp_path / "noise.csv"
    rng = np.random.default_rng(0)
    noise.write_text(
        "t,p\n" + "".join(f"{i},{v:.3f}\n" for i, v in enumerate(rng.normal(size=400)))
    )
    assert main(["fit", str(noise), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no clear period" in err[0] and "--period" in err[0]


@pytest.mark.authors_data
def test_opterra_throttle_log_reads_and_has_the_track_period():
    from eaplan_drake.energy.fourier import EstimatePeriodWithConfidence

    log = ReadPowerLog(
        ReferenceDirectory() / "opterra_flight" / "pprz_throttle.csv", time_column=0, power_column=2
    )
    assert log.times[-1] == pytest.approx(319.5)
    found = EstimatePeriodWithConfidence(log.times, log.power)
    assert found.period == pytest.approx(49.5, rel=0.03)  # the track repeats every ≈ 49.5 s
    assert Path(ReferenceDirectory()).is_dir()


def _phase_signal(dt, periods):
    """Noise-free power of two harmonics on the phase θ_k = 2π Σ_{i<k} Δt/T_i (continuous
    through a change of period)."""
    theta = np.concatenate(([0.0], np.cumsum(2.0 * math.pi * dt / periods[:-1])))
    return 30.0 + 3.0 * np.cos(theta) + 2.0 * np.sin(2.0 * theta), theta


def test_time_varying_period_filter_is_exact_on_a_phase_continuous_signal():
    """T changes 46 → 40 s mid-record: the filter re-discretised per T_k has zero innovations
    and predicts T/4 ahead exactly (holding the period in force); one T does not."""
    dt = 0.5
    Ts = np.where(np.arange(800) < 400, 46.0, 40.0)
    z, theta = _phase_signal(dt, Ts)
    noise = NoiseParameters(1e-6, 1e-12)
    states, e, s = FilterPowerSeries(z, dt, 2, Ts, noise)
    assert s.shape == z.shape and np.max(np.abs(e)) < 1e-6
    H = 10
    pred = PredictAhead(states, 2, Ts, dt, noise, H)
    k = np.arange(400, 800 - H)  # the period in force (40 s) holds over the horizon
    exact = 30.0 + 3.0 * np.cos(theta[k] + 2 * math.pi * H * dt / 40.0)
    exact += 2.0 * np.sin(2.0 * (theta[k] + 2 * math.pi * H * dt / 40.0))
    np.testing.assert_allclose(pred[k], exact, rtol=0.0, atol=1e-6)
    _, e_fixed, _ = FilterPowerSeries(z, dt, 2, 46.0, noise)
    assert np.max(np.abs(e_fixed[400:])) > 0.1
    first, _, _ = FilterPowerSeries(z[:400], dt, 2, 46.0, noise)  # before the change: = one T
    np.testing.assert_allclose(states[:400], first, rtol=0.0, atol=1e-9)


def test_period_series_and_period_in_force():
    assert PeriodSeries(46.0, 5) == (46.0, None)
    assert PeriodSeries(np.full(5, 40.0), 5) == (40.0, None)
    nominal, Ts = PeriodSeries(np.array([40.0, 40.0, 41.0]), 3)
    assert nominal == 41.0 and Ts.size == 3
    with pytest.raises(ValueError, match="period: needs one T per sample"):
        PeriodSeries(np.ones(4), 5)
    with pytest.raises(ValueError, match="period: every T_k"):
        PeriodSeries(np.array([1.0, 0.0]), 2)
    with pytest.raises(ValueError, match="period: must be finite"):
        PeriodSeries(-1.0, 2)
    T = PeriodInForce([0.0, 1.0, 2.5, 9.0], [1.0, 2.0, 5.0], [40.0, 45.0, 50.0])
    np.testing.assert_array_equal(T, [40.0, 40.0, 45.0, 50.0])


def test_seasonal_naive_with_the_period_in_force_never_looks_ahead():
    z = np.arange(60.0)
    P = np.where(np.arange(60) < 30, 10, 6)
    H = 8  # longer than the period in force from k = 30 on: two periods back
    pred = BaselinePrediction("seasonal naive", z, P, H)
    k = np.arange(60)
    assert pred[20] == z[20 + H - 10] and pred[40] == z[40 + H - 12]
    assert np.all(pred[np.isfinite(pred)] <= k[np.isfinite(pred)])
    ma = BaselinePrediction("moving average", z, P, 1)
    assert ma[40] == pytest.approx(np.mean(z[35:41]))


def test_read_authors_period_log(tmp_path):
    f = tmp_path / "perioddata.csv"
    f.write_text("99,1\n100,1.01\n3626,36.27\n")
    t, T = ReadPeriodLog(f)
    np.testing.assert_allclose(t, [0.99, 1.0, 36.26])
    np.testing.assert_array_equal(T, [1.0, 1.01, 36.27])
    f.write_text("99,1\n100,0\n")
    with pytest.raises(PowerLogError, match=r"perioddata.csv:2: needs a step and a period"):
        ReadPeriodLog(f)
    f.write_text("99,1\n\n98,2\n")  # a blank line is skipped, the line number kept
    with pytest.raises(PowerLogError, match=r"perioddata.csv:3: step decreases"):
        ReadPeriodLog(f)
    for step in (0.0, -0.01, float("nan")):  # a step that would fold the log onto one time
        with pytest.raises(PowerLogError, match=r"--period-log-step\) must be a finite number > 0"):
            ReadPeriodLog(f, step)


def test_level_noise_recovers_the_local_level_ratio():
    """Random walk level (q_0 = 0.01 W² per step) + white noise (R = 1 W²): the Kalman level is
    the best predictor at every horizon, so the multi-step criterion picks λ = q_0/R = 0.01
    (within its quarter-decade grid, ±1 step for the finite record) and R by likelihood."""
    rng = np.random.default_rng(5)
    n = 3000
    level = 20.0 + np.cumsum(rng.normal(0.0, 0.1, n))
    z = level + rng.normal(0.0, 1.0, n)
    noise = FitLevelNoise(z, 1.0, 40.0)
    ratio = noise.mean_process_noise / noise.measurement_noise
    assert 10**-2.5 <= ratio <= 10**-1.5
    assert noise.measurement_noise == pytest.approx(1.0, rel=0.15)
    assert noise.process_noise == 0.0 and noise.aperiodic_time_constant == 0.0
    base = NoiseParameters(1.0, 0.0, 5.0, 10.0, 0.1)  # q_0 re-chosen, the rest kept
    again = FitLevelNoise(z, 1.0, 40.0, base)
    assert dc.replace(again, mean_process_noise=5.0) == base
    assert 10**-2.75 <= again.mean_process_noise <= 10**-1.25


def test_fit_chooses_a_level_without_harmonics_for_a_random_walk():
    """No periodic part: a random-walk level (0.05 W per step) + white noise (0.5 W). The held-out
    choice keeps no harmonics, and the level fitted for the horizons is within 2 % of the
    one-period moving average and within 10 % of last value one step ahead."""
    rng = np.random.default_rng(11)
    n = 1600
    z = 40.0 + np.cumsum(rng.normal(0.0, 0.05, n)) + rng.normal(0.0, 0.5, n)
    fit = FitPowerModel(z[: n // 2], 1.0, 40.0, orders=(0, 1), max_evaluations=60)
    assert fit.order == 0 and {c[0] for c in fit.candidates} == {0, 1}
    assert fit.model_name.startswith("level") == (fit.noise_criterion == "level")
    scores = ScorePredictions(z, 1.0, 40.0, fit)
    for h in ("T/4", "T/2", "T"):
        assert scores["model"][h][0] <= 1.02 * scores["moving average"][h][0], (h, scores)
    assert scores["model"]["1 step"][0] <= 1.1 * scores["last value"]["1 step"][0]


def test_fit_power_log_with_a_period_log_uses_the_period_in_force():
    """The period changes 46 → 40 s at 3/4 of the record: with the period log the model and
    seasonal naive both predict T/4 ahead better than with one T (40 s, the last)."""
    dt = 0.5
    t = dt * np.arange(1200)
    Ts = np.where(t < 450.0, 46.0, 40.0)
    z, _ = _phase_signal(dt, Ts)
    z = z + np.random.default_rng(3).normal(0.0, 0.05, z.size)
    log = ([0.0, 450.0], [46.0, 40.0])
    varying = FitPowerLog(t, z, orders=(2,), period_log=log)
    fixed = FitPowerLog(t, z, 40.0, orders=(2,))
    assert varying.periods is not None and varying.periods[0] == 46.0
    assert "period log" in varying.period_source
    for name in ("model", "seasonal naive"):
        assert varying.scores[name]["T/4"][0] < 0.5 * fixed.scores[name]["T/4"][0], name
    assert varying.scores["model"]["T/4"][0] < 0.5 * varying.scores["seasonal naive"]["T/4"][0]
    with pytest.raises(ValueError, match="period: give either"):
        FitPowerLog(t, z, 40.0, period_log=log)


def _WriteLog(path, t, z):
    path.write_text(
        "time_s,power_w\n" + "".join(f"{a:.2f},{b:.5f}\n" for a, b in zip(t, z, strict=True))
    )


def test_cli_fit_with_a_period_log_names_the_model(tmp_path, capsys):
    """--period-log reads the authors' (step, T) rows (0.01 s steps) as the period in force; the
    printout and the fragment name the chosen model and every candidate."""
    dt = 0.5
    t = dt * np.arange(1200)
    z, _ = _phase_signal(dt, np.where(t < 450.0, 46.0, 40.0))
    z = z + np.random.default_rng(3).normal(0.0, 0.05, z.size)
    log, periods, out = tmp_path / "flight.csv", tmp_path / "perioddata.csv", tmp_path / "o"
    _WriteLog(log, t, z)
    periods.write_text("0,46\n45000,40\n")
    args = ["fit", str(log), "--period-log", str(periods), "--orders", "2", "--out", str(out)]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "period log (40.00–46.00 s in force)" in text
    model = next(line for line in text.splitlines() if line.startswith("model "))
    assert "; noise by " in model, model
    name = model.split()[1]
    assert name in ("r=2+AR(1)", "r=2+AR(1)+walk", "level", "level+AR(1)"), model
    candidates = text.split("candidates ")[1].split("\nnoise ")[0]
    assert "r=2+AR(1)" in candidates and "level (q_0" in candidates
    assert f"# model: {name}\n" in (out / "fit.yaml").read_text()


def test_cli_fit_bad_period_log_is_one_line(tmp_path, capsys):
    t, z = _synthetic(4, duration=400.0)
    log, periods = tmp_path / "flight.csv", tmp_path / "perioddata.csv"
    _WriteLog(log, t, z)
    periods.write_text("0,46\n100,x\n")
    out = str(tmp_path / "o")
    assert main(["fit", str(log), "--period-log", str(periods), "--out", out]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"eaplan-drake: input error: {periods}:2"), err
    assert main(["fit", str(log), "--period-log", str(tmp_path / "none.csv"), "--out", out]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "none.csv: no such file" in err[0], err
    periods.write_text("0,46\n")
    assert main(["fit", str(log), "--period", "46", "--period-log", str(periods)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["eaplan-drake: input error: --period, --period-log: give one of them, not both"]
    assert not (tmp_path / "o").exists()


def test_model_names():
    from eaplan_drake.logfit.result import ModelName

    ar = NoiseParameters(1.0, 1e-6, 0.0, 12.0, 0.1)
    assert ModelName(4, ar) == "r=4+AR(1)"
    assert ModelName(0, dc.replace(ar, mean_process_noise=1e-3)) == "r=0+AR(1)+walk"
    assert ModelName(0, NoiseParameters(1.0, 0.0, 1e-3), "local") == "level"
    assert ModelName(0, ar, "r0") == "level+AR(1)"
    assert ModelName(3, NoiseParameters(1.0, 1e-6)) == "r=3"
    with pytest.raises(ValueError, match="horizon"):
        ModelName(0, ar, "other")


def _Run(args, threads):
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if threads is not None:
        env["OPENBLAS_NUM_THREADS"] = str(threads)
    env["PYTHONPATH"] = str(Path(__file__).resolve().parents[1])
    return subprocess.run(
        [sys.executable, *args], env=env, capture_output=True, text=True, timeout=300
    )


def test_cli_sets_one_blas_thread_before_numpy_unless_set():
    code = "import os, eaplan_drake.cli as c; "
    code += "print(c.BLAS_THREADS_SET_BEFORE_NUMPY, os.environ['OPENBLAS_NUM_THREADS'])"
    assert _Run(["-c", code], None).stdout.split() == ["True", "1"]
    assert _Run(["-c", code], 2).stdout.split() == ["True", "2"]


@pytest.mark.slow
def test_cli_fit_result_does_not_depend_on_blas_threads(tmp_path):
    t, z = _synthetic(6, duration=400.0)
    log = tmp_path / "flight.csv"
    _WriteLog(log, t, z)
    fragments = []
    for threads in (1, 2):
        out = tmp_path / f"o{threads}"
        args = ["-m", "eaplan_drake.cli", "fit", str(log), "--period", "46", "--orders", "0,3"]
        done = _Run([*args, "--out", str(out)], threads)
        assert done.returncode == 0, done.stderr
        fragments.append((out / "fit.yaml").read_text())
    assert fragments[0] == fragments[1]


def test_a_log_without_header_needs_its_columns_named(tmp_path, capsys):
    """Several columns and no header: nothing says which is power (it used to be the last column),
    so they must be named; one column is the Paparazzi energy log and needs nothing."""
    f = tmp_path / "log.csv"
    f.write_text("".join(f"{0.5 * i},{30 + i % 7},{i % 3}\n" for i in range(40)))
    with pytest.raises(PowerLogError) as e:
        ReadPowerLog(f)
    assert str(e.value) == (
        f"{f}: no header and 3 columns: name them by 0-based index: --time-column (or "
        "--time-step) and --power-column (or --voltage-column and --current-column)"
    )
    with pytest.raises(PowerLogError, match=r"name them by 0-based index: --power-column \(or"):
        ReadPowerLog(f, time_column=0)
    log = ReadPowerLog(f, time_column=0, power_column=1)
    assert log.power[8] == 31.0 and log.times[8] == 4.0
    assert log.source == "log.csv (no header): time = column 0 (× 1 s), power = column 1"
    assert ReadPowerLog(f, time_step=0.25, power_column=2).times[4] == 1.0
    assert main(["fit", str(f), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(
        f"eaplan-drake: input error: {f}: no header and 3 columns"
    )
    assert not (tmp_path / "o").exists()


def test_a_log_too_short_for_its_period_is_one_line(tmp_path, capsys):
    """400 s at 0.5 s: 2.9 periods of 46 s are needed (the first half fits with a period in its
    first 70 %, the second scores up to T ahead), so T = 150 s is refused up front, saying so."""
    from eaplan_drake.logfit.fit import MinimumSamples

    assert MinimumSamples(0.5, 46.0) == 264  # int(0.7 · 132) = 92 = P; 264 − 92 > 132
    t, z = _synthetic(4, duration=400.0)
    log = tmp_path / "flight.csv"
    _WriteLog(log, t, z)
    assert main(["fit", str(log), "--period", "150", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "eaplan-drake: input error: power log: 800 samples at 0.5 s (400 s) cover 2.67 periods of "
        "T = 150 s (given); fit needs 858 samples (2.86 periods: it fits on the first half and "
        "scores up to T ahead on the second); record longer or check the period"
    ]
    assert not (tmp_path / "o").exists()
    with pytest.raises(ValueError, match=r"periods of T = 46 s \(period log\); fit needs 264"):
        FitPowerLog(t[:200], z[:200], orders=(1,), period_log=([0.0], [46.0]))


SHIPPED_FITS = {
    "seewald2022_plan_I_energy.csv": (["--time-column", "0", "--power-column", "1"], 45.83),
    "opterra_pprz_energy.csv": (["--period", "49.5"], 49.5),
    "px4_battery_status_example.csv": ([], 29.98),
}
"""The command that fits each shipped power log (README "Energy estimator on real power logs")
and the period it prints [s]."""


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SHIPPED_FITS))
def test_every_shipped_power_log_fits_with_its_documented_command(name, tmp_path, capsys):
    args, period = SHIPPED_FITS[name]
    with resources.as_file(DATA / name) as path:
        assert main(["fit", str(path), *args, "--out", str(tmp_path / "o")]) == 0
    text = capsys.readouterr().out
    assert f"period          {period:.2f} s" in text
    rows = {line[:16].strip(): line[16:].split() for line in text.splitlines()}
    model, last = float(rows["model"][0]), float(rows["last value"][0])
    assert model <= 1.1 * last, text  # 1 step ahead: within 10 % of last value or better
    fragment = (tmp_path / "o" / "fit.yaml").read_text()
    for scenario in ShippedNames("scenarios"):  # the fragment layers over every scenario
        s = LayerScenario(LoadNamedScenario(scenario), [fragment])
        assert s.energy_model == LoadScenario(data=fragment).energy_model


def test_fit_orders_stay_within_what_a_scenario_accepts(tmp_path, capsys):
    """fit.yaml must load: `fit` tries orders up to energy_model.order's largest (20), refuses
    --orders above it, and ScenarioFragment refuses such an order."""
    from eaplan_drake.errors import ScenarioError
    from eaplan_drake.logfit.fit import FRAGMENT_ORDERS, ORDERS
    from eaplan_drake.logfit.result import SCENARIO_MAX_ORDER

    assert LoadScenario(data=f"energy_model: {{order: {SCENARIO_MAX_ORDER}}}")
    with pytest.raises(ScenarioError, match="energy_model.order"):
        LoadScenario(data=f"energy_model: {{order: {SCENARIO_MAX_ORDER + 1}}}")
    assert FRAGMENT_ORDERS == tuple(r for r in ORDERS if r <= SCENARIO_MAX_ORDER)
    noise = NoiseParameters(0.01, 1e-6)
    with pytest.raises(ValueError, match="order r = 24 is above energy_model.order's largest"):
        PowerModelFit(24, 40.0, 0.5, noise, 0.0, 24.0, []).ScenarioFragment()
    t, z = _synthetic(4, duration=400.0)
    log = tmp_path / "flight.csv"
    _WriteLog(log, t, z)
    for orders in ("2,24", "x", "-1"):
        assert main(["fit", str(log), "--orders", orders, "--out", str(tmp_path / "o")]) == 2
        assert capsys.readouterr().err.strip().splitlines() == [
            "eaplan-drake: input error: --orders: comma-separated integers in [0, 20] (the largest "
            f"energy_model.order of a scenario), got {orders!r}"
        ]
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_simulate_layers_a_fitted_fragment_over_any_scenario(tmp_path, capsys):
    """`simulate SCENARIO --with fit.yaml` flies the scenario with the fitted energy model (its
    order, hence the estimator's state size) and sensor; repeatable, after --rates, before --set;
    the name gets each file's stem."""
    from eaplan_drake.energy.fourier import AugmentedOrder, StateSize

    t, z = _synthetic(4, duration=400.0)
    log, fit = tmp_path / "flight.csv", tmp_path / "fit"
    _WriteLog(log, t, z)
    assert main(["fit", str(log), "--period", "46", "--orders", "2", "--out", str(fit)]) == 0
    fragment = LoadScenario(filename=fit / "fit.yaml")
    tau = fragment.estimator.aperiodic_time_constant
    order = fragment.energy_model.order
    states = StateSize(AugmentedOrder(order, tau) if tau > 0.0 else order)
    noise = tmp_path / "noise.yaml"
    noise.write_text("sensor: {noise_std: 0.25}\n")
    for scenario in ("plan_i", "plan_II"):
        args = ["simulate", scenario, "--rates", "fast", "--with", str(fit / "fit.yaml")]
        args += ["--with", str(noise), "--set", "simulation.time_limit=3", "--out", str(tmp_path)]
        assert main(args) == 0, capsys.readouterr().err
        out = tmp_path / f"{scenario}_fast_fit_noise"
        assert np.load(out / "log.npz")["energy_coefficients"].shape[1] == states
    capsys.readouterr()


def test_simulate_with_a_bad_fragment_is_one_line_naming_it(tmp_path, capsys):
    cases = {
        "estimator:\n  fooo: 1\n": "estimator.fooo: unknown key (known keys here: ",
        "estimator:\n  process_noise: [1\n": "invalid YAML: ",
        "battery:\n  capacity: -3\n": "battery.capacity: must be > 0, got -3",
    }
    bad = tmp_path / "bad.yaml"
    for text, message in cases.items():
        bad.write_text(text)
        assert main(["simulate", "plan_i", "--with", str(bad), "--out", str(tmp_path / "o")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith(f"eaplan-drake: scenario error: --with {bad}")
        assert message in err[0], err
    missing = str(tmp_path / "none.yaml")
    assert main(["simulate", "plan_i", "--with", missing, "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        f"eaplan-drake: scenario error: --with {missing}: cannot read: No such file or directory"
    ]
    assert not (tmp_path / "o").exists()
