"""Tests of the Kalman estimator on the energy-model state (paper 003 Alg. 2 l. 28–29).

The convergence figures are printed; measure them with
``python3 -m pytest -q -s tests/test_estimator.py -k convergence``.
"""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.primitives import LogVectorOutput

from eaplan_drake.energy.estimator import EnergyEstimator, KalmanPredict, KalmanStep, KalmanUpdate
from eaplan_drake.energy.fourier import ModelOrder
from eaplan_drake.params import EstimatorParams

H = 0.01  # 100 Hz
T_REF = 46.0
Q_TRUE = np.array([31.0, 3.0, -2.0, 1.5, 1.0, -0.8, 0.6])  # mean ≈ 31 W, harmonics of a few W
THRESHOLD = 0.3  # W


def _rotation(order, period, h):
    """A_d written out (test-side): blockdiag(1, [[cos, sin], [−sin, cos]] of angle ωjh)."""
    Ad = np.eye(2 * order + 1)
    for j in range(1, order + 1):
        a = 2 * math.pi * j * h / period
        k = 2 * j - 1
        Ad[k : k + 2, k : k + 2] = [[math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]]
    return Ad


def _truth(n, periods, g, q0=Q_TRUE):
    """True power y_k = C q_k + g_k over n steps, with period T_k; g enters α0 like the model."""
    C = np.zeros(q0.size)
    C[0] = 1.0
    C[1::2] = 1.0
    q = np.array(q0, dtype=float)
    q[0] -= g[0]  # q0 is the total at t = 0; α0 holds the motion part, g added on top
    y = np.empty(n)
    for k in range(n):
        y[k] = C @ q + g[k]
        q = _rotation(3, periods[k], H) @ q
    return y


class _Samples(LeafSystem):
    """Plays back recorded vectors: output value = samples[k] at t = k h (one port per row)."""

    def __init__(self, *rows):
        super().__init__()
        self._rows = [np.asarray(r, dtype=float) for r in rows]
        for i, _ in enumerate(self._rows):
            self.DeclareVectorOutputPort(
                f"y{i}", 1, lambda context, output, i=i: self._Calc(context, output, i)
            )

    def _Calc(self, context, output, i):
        k = min(int(round(context.get_time() / H)), self._rows[i].size - 1)
        output.SetAtIndex(0, self._rows[i][k])


def _run(z, g, periods, params=None, initial_q=None, log_outputs=("estimated_power",)):
    """Runs EnergyEstimator on recorded inputs in a Diagram; returns (times, logs, est, ctx)."""
    builder = DiagramBuilder()
    est = builder.AddSystem(EnergyEstimator(3, T_REF, params or EstimatorParams(), initial_q))
    src = builder.AddSystem(_Samples(z, g, periods))
    for i, name in enumerate(("measured_power", "computation_power", "period")):
        builder.Connect(src.get_output_port(i), est.GetInputPort(name))
    loggers = [LogVectorOutput(est.GetOutputPort(n), builder, H) for n in log_outputs]
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo((len(z) - 1) * H)
    context = simulator.get_context()
    logs = [lg.FindLog(context) for lg in loggers]
    times = logs[0].sample_times()
    return times, [lg.data() for lg in logs], est, est.GetMyContextFromRoot(context)


def _convergence_time(times, error, threshold=THRESHOLD):
    """First time after which |error| stays below threshold (inf if it never does)."""
    bad = np.flatnonzero(~(np.abs(error) < threshold))
    if bad.size == 0:
        return float(times[0])
    if bad[-1] + 1 >= times.size:
        return math.inf
    return float(times[bad[-1] + 1])


def _reference_signal(duration, seed, drop=0.0):
    n = int(round(duration / H)) + 1
    g = np.full(n, 10.2)
    periods = np.full(n, T_REF)
    y = _truth(n, periods, g)
    rng = np.random.default_rng(seed)
    z = y + rng.normal(0.0, 0.5, n)
    if drop:
        z[rng.uniform(size=n) < drop] = np.nan
    return z, g, periods, y


def _worst_prediction_error(q_hat, q_true):
    """Bound on max over a period of |C expm(Aτ)(q̂ − q)|: |e0| + Σ_j ‖(e_αj, e_βj)‖ [W]."""
    e = q_hat - q_true
    return np.abs(e[:, 0]) + np.hypot(e[:, 1::2], e[:, 2::2]).sum(axis=1)


# -- pure functions -------------------------------------------------------------------------------


def test_joseph_update_equals_standard_form_and_skips_nan():
    rng = np.random.default_rng(1)
    M = rng.normal(size=(7, 7))
    P = M @ M.T + 0.1 * np.eye(7)
    q = rng.normal(size=7)
    C = np.array([[1.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0]])
    R = 0.25
    q1, P1 = KalmanUpdate(q, P, C, R, 31.0)
    K = P @ C.T / (C @ P @ C.T + R)
    np.testing.assert_allclose(q1, q + K[:, 0] * (31.0 - (C @ q)[0]), atol=1e-12)
    np.testing.assert_allclose(P1, (np.eye(7) - K @ C) @ P, atol=1e-12)
    assert np.array_equal(P1, P1.T)
    for bad in (np.nan, np.inf):
        q2, P2 = KalmanUpdate(q, P, C, R, bad)
        assert q2 is q and P2 is P
    Ad = _rotation(3, T_REF, H)
    q3, P3 = KalmanPredict(q, P, Ad, 1e-6 * np.eye(7))
    np.testing.assert_allclose(q3, Ad @ q, atol=1e-14)
    np.testing.assert_allclose(P3, Ad @ P @ Ad.T + 1e-6 * np.eye(7), atol=1e-12)
    assert np.array_equal(P3, P3.T)
    # ½(X + Xᵀ) formed from (½A_d) P A_dᵀ is the symmetrised X to the bit
    X = Ad.dot(P).dot(Ad.T)
    np.testing.assert_array_equal(P3, 0.5 * (X + X.T) + 1e-6 * np.eye(7))
    q4, P4 = KalmanPredict(q, P, Ad, 1e-6 * np.eye(7), half_Ad=0.5 * Ad)
    assert np.array_equal(q4, q3) and np.array_equal(P4, P3)
    # Joseph form: (I − KC) P (I − KC)ᵀ + K R Kᵀ written out with m×m products
    L = np.eye(7) - K @ C
    np.testing.assert_allclose(P1, L @ P @ L.T + R * K @ K.T, rtol=0.0, atol=1e-12)


def test_kalman_step_written_in_place_is_the_same_bit_for_bit():
    """``out`` = the prior's own storage (as the system uses it) gives exactly the new arrays,
    for a sample, a dropped sample, and with and without a known input step."""
    rng = np.random.default_rng(5)
    Ad = _rotation(3, T_REF, H)
    C = np.array([1.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0])
    Q = 1e-6 * np.eye(7)
    A = rng.normal(size=(7, 7))
    q, P = rng.normal(size=7), A @ A.T + np.eye(7)
    for z, dg in ((31.0, 0.0), (np.nan, 0.0), (29.5, 1.25), (np.inf, -0.5)):
        q_new, P_new = KalmanStep(q, P, z, dg, Ad, C, Q, 0.25)
        q_mem, P_mem = q.copy(), P.copy()
        q_out, P_out = KalmanStep(q_mem, P_mem, z, dg, Ad, C, Q, 0.25, out=(q_mem, P_mem))
        assert q_out is q_mem and P_out is P_mem
        assert np.array_equal(q_mem, q_new) and np.array_equal(P_mem, P_new)
        q, P = q_new, P_new


def test_covariance_stays_symmetric_positive_definite():
    rng = np.random.default_rng(2)
    Ad = _rotation(3, T_REF, H)
    C = np.array([1.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0])
    q, P = np.zeros(7), 100.0 * np.eye(7)
    for k in range(20_000):
        z = 31.0 + rng.normal() if k % 3 else np.nan
        q, P = KalmanStep(q, P, z, 0.0, Ad, C, 1e-6 * np.eye(7), 0.25)
        if k % 2000 == 0:
            assert np.array_equal(P, P.T)
            assert np.linalg.eigvalsh(P).min() > 0.0
    assert np.all(np.isfinite(q))


# -- the system ----------------------------------------------------------------------------------


def test_estimator_ports_and_sizes():
    est = EnergyEstimator(3, T_REF, EstimatorParams())
    names = [est.get_input_port(i).get_name() for i in range(est.num_input_ports())]
    assert names == ["measured_power", "computation_power", "period"]
    for name in names:
        assert est.GetInputPort(name).size() == 1
    assert est.GetOutputPort("energy_coefficients").size() == 7
    assert est.GetOutputPort("estimated_power").size() == 1
    assert est.GetOutputPort("covariance_trace").size() == 1
    for i in range(3):
        for j in range(3):
            assert not est.HasDirectFeedthrough(i, j)
    q0 = np.array([30.0, 1.0, 2.0, 0.0, 0.0, 0.0, 0.0])
    est = EnergyEstimator(2, T_REF, EstimatorParams(initial_covariance=4.0), q0[:5])
    context = est.CreateDefaultContext()
    np.testing.assert_array_equal(est.GetOutputPort("energy_coefficients").Eval(context), q0[:5])
    assert est.GetOutputPort("estimated_power").Eval(context)[0] == 31.0
    assert est.EstimatedPower(q0[:5]) == 31.0  # ŷ = C q: α0 + α1 + α2 (the log derives it so)
    assert est.EstimatedPower([0.0, 0.0, 5.0, 0.0, 0.0]) == 0.0  # β1 does not reach y at t_k
    assert est.GetOutputPort("covariance_trace").Eval(context)[0] == pytest.approx(20.0)
    np.testing.assert_array_equal(est.Covariance(context), 4.0 * np.eye(5))
    assert est.time_step == pytest.approx(0.01)


def test_estimator_state_groups_and_copied_params():
    """q̂, P and the memory (g at the previous step, T in use) are the parts of one state group,
    read by Estimate, Covariance and Memory; the system keeps its own copy of the params."""
    params = EstimatorParams(initial_covariance=4.0)
    est = EnergyEstimator(3, T_REF, params, Q_TRUE)
    params.measurement_noise = 99.0
    assert est.params.measurement_noise == 0.25 and est.params is not params
    context = est.CreateDefaultContext()
    assert context.num_discrete_state_groups() == 1
    np.testing.assert_array_equal(est.Estimate(context), Q_TRUE)
    np.testing.assert_array_equal(
        est.GetOutputPort("energy_coefficients").Eval(context), est.Estimate(context)
    )
    np.testing.assert_array_equal(est.Covariance(context), 4.0 * np.eye(7))
    memory = est.Memory(context)
    assert math.isnan(memory.previous_computation_power) and memory.period == T_REF
    z, g, periods, _ = _reference_signal(1.0, seed=8)
    periods[50:] = 30.0
    g[70:] = 12.0
    _, _, est, context = _run(z, g, periods, log_outputs=("energy_coefficients",))
    memory = est.Memory(context)
    assert memory.previous_computation_power == 12.0 and memory.period == 30.0


def test_estimator_bad_arguments():
    with pytest.raises(ValueError, match="order"):
        EnergyEstimator(-1, T_REF)
    with pytest.raises(ValueError, match="initial_period"):
        EnergyEstimator(3, -46.0)
    with pytest.raises(ValueError, match="initial_q"):
        EnergyEstimator(3, T_REF, EstimatorParams(), np.zeros(3))
    with pytest.raises(ValueError, match="estimator.measurement_noise"):
        EnergyEstimator(3, T_REF, EstimatorParams(measurement_noise=0.0))
    with pytest.raises(ValueError, match="estimator"):
        EnergyEstimator(3, T_REF, {"rate": 100.0})


def test_estimator_equals_textbook_kalman_filter():
    """Same data (noise, 20 % drops, computation steps, a period change) through the system and
    a plain textbook KF written here: estimates agree to 1e-9."""
    duration = 60.0
    n = int(round(duration / H)) + 1
    k = np.arange(n)
    g = np.where(k < 2000, 8.7, np.where(k < 4000, 10.2, 5.2))
    periods = np.where(k < 3000, T_REF, 30.0)
    y = _truth(n, periods, g)
    rng = np.random.default_rng(3)
    z = y + rng.normal(0.0, 0.5, n)
    z[rng.uniform(size=n) < 0.2] = np.nan
    params = EstimatorParams(initial_covariance=50.0, process_noise=1e-5, measurement_noise=0.3)
    q_init = np.array([25.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    _, (logs,), _, _ = _run(z, g, periods, params, q_init, ("energy_coefficients",))

    # textbook KF: x⁻_k = A x⁺_{k−1} + B u_k, P⁻ = A P A' + Q; K = P⁻C'(CP⁻C' + R)⁻¹;
    # x⁺ = x⁻ + K(z − Cx⁻); P⁺ = (I − KC)P⁻(I − KC)' + KRK'. Logged at t_k: A x⁺_{k−1}.
    C = np.array([[1.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0]])
    B = np.zeros((7, 1))
    B[0, 0] = 1.0
    Q = params.process_noise * np.eye(7)
    R = np.array([[params.measurement_noise]])
    x = q_init.reshape(7, 1).copy()
    P = params.initial_covariance * np.eye(7)
    expected = np.empty((n, 7))
    for i in range(n):
        expected[i] = x[:, 0]
        u = g[i] - g[i - 1] if i > 0 else 0.0
        x = x + B * u
        if np.isfinite(z[i]):
            S = C @ P @ C.T + R
            K = P @ C.T @ np.linalg.inv(S)
            x = x + K @ (z[i] - C @ x)
            L = np.eye(7) - K @ C
            P = L @ P @ L.T + K @ R @ K.T
        A = _rotation(3, periods[i], H)
        x = A @ x
        P = A @ P @ A.T + Q
    assert logs.shape == (7, n)
    np.testing.assert_allclose(logs.T, expected, rtol=0.0, atol=1e-9)
    # and the pure KalmanStep gives the same sequence
    q, P = q_init.copy(), params.initial_covariance * np.eye(7)
    for i in range(n):
        np.testing.assert_allclose(q, expected[i], rtol=0.0, atol=1e-9)
        dg = g[i] - g[i - 1] if i > 0 else 0.0
        A = _rotation(3, periods[i], H)
        q, P = KalmanStep(q, P, z[i], dg, A, C, Q, params.measurement_noise)


def test_estimator_convergence_on_reference_like_signal():
    duration = 4 * T_REF
    z, g, periods, y = _reference_signal(duration, seed=4)
    times, (y_hat, q_hat), est, context = _run(
        z, g, periods, log_outputs=("estimated_power", "energy_coefficients")
    )
    y_true = y[: times.size]
    error = y_hat[0] - y_true
    t_conv = _convergence_time(times, error)
    # q̂ is consistent: the free-running prediction from q̂ over a whole period is within 0.3 W
    n = times.size
    q_true = np.empty((n, 7))
    q = Q_TRUE.copy()
    for i in range(n):
        q_true[i] = q
        q = _rotation(3, T_REF, H) @ q
    t_consistent = _convergence_time(times, _worst_prediction_error(q_hat.T, q_true))
    print(
        f"\nEnergyEstimator, reference-like signal (mean 31 W, T = 46 s, σ = 0.5 W, seed 4): "
        f"|ŷ − y| < {THRESHOLD} W from t = {t_conv:.2f} s; one-period prediction from q̂ "
        f"within {THRESHOLD} W from t = {t_consistent:.2f} s; final max error "
        f"{np.abs(error[-int(T_REF / H) :]).max():.3f} W"
    )
    assert t_conv < 2 * T_REF
    assert t_consistent < 2 * T_REF
    assert np.all(np.isfinite(y_hat))
    P = est.Covariance(context)
    assert np.array_equal(P, P.T) and np.linalg.eigvalsh(P).min() > 0.0
    assert est.GetOutputPort("covariance_trace").Eval(context)[0] == pytest.approx(np.trace(P))


def test_estimator_convergence_with_30_percent_dropped_samples():
    duration = 3 * T_REF
    z, g, periods, y = _reference_signal(duration, seed=5, drop=0.3)
    assert 0.25 < np.mean(np.isnan(z)) < 0.35
    times, (y_hat,), est, context = _run(z, g, periods)
    t_conv = _convergence_time(times, y_hat[0] - y[: times.size])
    print(f"\nEnergyEstimator, 30 % dropped samples (seed 5): converged at t = {t_conv:.2f} s")
    assert t_conv < 2 * T_REF
    P = est.Covariance(context)
    assert np.array_equal(P, P.T) and np.linalg.eigvalsh(P).min() > 0.0


def test_estimator_follows_computation_step_without_transient():
    duration = 150.0
    n = int(round(duration / H)) + 1
    k_step = int(round(120.0 / H))
    g = np.where(np.arange(n) < k_step, 5.2, 10.2)  # 2 fps → 10 fps on the Jetson Nano
    periods = np.full(n, T_REF)
    y = _truth(n, periods, g)
    z = y + np.random.default_rng(6).normal(0.0, 0.5, n)
    times, (y_hat,), _, _ = _run(z, g, periods)
    error = y_hat[0] - y[: times.size]
    before = np.abs(error[k_step - 2000 : k_step])
    # Drake's discrete convention: the jump at t_s shows in ŷ from the next sample on
    after = np.abs(error[k_step + 1 :])
    print(
        f"\nEnergyEstimator, +5 W computation step at 120 s: max |ŷ − y| before "
        f"{before.max():.3f} W, after {after.max():.3f} W"
    )
    assert after.max() < THRESHOLD
    assert after.max() < 2.0 * before.max()
    # The same step *not* announced on computation_power is a transient well beyond the noise.
    times, (y_blind,), _, _ = _run(z, np.full(n, 5.2), periods)
    assert np.abs(y_blind[0] - y[: times.size])[k_step + 1 :].max() > 1.0


def test_estimator_ignores_non_finite_period_and_computation_power():
    z, g, periods, _ = _reference_signal(5.0, seed=7)
    _, (q_ref,), _, _ = _run(z, g, periods, log_outputs=("energy_coefficients",))
    g_bad = g.copy()
    g_bad[100:200] = np.nan  # lost, then back at the same value: no Δg
    periods_bad = periods.copy()
    periods_bad[300:400] = np.inf
    periods_bad[400:] = -1.0
    _, (q_hat,), _, _ = _run(z, g_bad, periods_bad, log_outputs=("energy_coefficients",))
    assert np.all(np.isfinite(q_hat))
    np.testing.assert_array_equal(q_hat, q_ref)


# -- aperiodic load state (opt-in) ----------------------------------------------------------------


def test_estimator_with_aperiodic_state_equals_textbook_kalman_filter():
    """With τ, q_d and q_0 set, the system is the textbook KF on [q, d] with A = blockdiag(A_d, φ),
    C = [C, 1], Q = diag(q_n + q_0, q_n, …, Q_dd), Q_dd = (q_d τ/2)(1 − φ²): agree to 1e-9."""
    duration = 20.0
    n = int(round(duration / H)) + 1
    k = np.arange(n)
    g = np.where(k < 1000, 8.7, 10.2)
    periods = np.full(n, T_REF)
    rng = np.random.default_rng(5)
    z = _truth(n, periods, g) + 2.0 * np.sin(0.3 * k * H) + rng.normal(0.0, 0.5, n)
    tau, q_d, q_0 = 12.0, 0.5, 1e-4
    params = EstimatorParams(
        initial_covariance=50.0,
        process_noise=1e-5,
        measurement_noise=0.3,
        mean_process_noise=q_0,
        aperiodic_time_constant=tau,
        aperiodic_noise=q_d,
    )
    q_init = np.array([25.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    _, (logs,), est, _ = _run(z, g, periods, params, q_init, ("energy_coefficients",))
    assert est.GetOutputPort("energy_coefficients").size() == 8
    phi = math.exp(-H / tau)
    A = np.eye(8)
    A[:7, :7] = _rotation(3, T_REF, H)
    A[7, 7] = phi
    C = np.array([1.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0])
    Q = np.diag([1e-5 + q_0] + [1e-5] * 6 + [0.5 * q_d * tau * (1.0 - phi * phi)])
    R = params.measurement_noise
    x = np.append(q_init, 0.0)
    P = 50.0 * np.eye(8)
    expected = np.empty((n, 8))
    for i in range(n):
        expected[i] = x
        x[0] += g[i] - g[i - 1] if i > 0 else 0.0
        S = C @ P @ C + R
        K = P @ C / S
        x = x + K * (z[i] - C @ x)
        L = np.eye(8) - np.outer(K, C)
        P = L @ P @ L.T + R * np.outer(K, K)
        x = A @ x
        P = A @ P @ A.T + Q
    np.testing.assert_allclose(logs.T, expected, rtol=0.0, atol=1e-9)


def test_estimator_aperiodic_state_follows_an_aperiodic_load_better():
    """Periodic power plus an AR(1) load (τ = 10 s, σ = 2 W): the augmented filter's one-step
    error is smaller than the paper model's (same sensor, same Q on q)."""
    n = int(round(60.0 / H)) + 1
    g = np.full(n, 10.2)
    periods = np.full(n, T_REF)
    rng = np.random.default_rng(11)
    tau, sigma = 10.0, 2.0
    phi = math.exp(-H / tau)
    d = np.zeros(n)
    w = rng.normal(0.0, sigma * math.sqrt(1.0 - phi * phi), n)
    for i in range(1, n):
        d[i] = phi * d[i - 1] + w[i]
    y = _truth(n, periods, g) + d
    z = y + rng.normal(0.0, 0.5, n)
    plain = EstimatorParams(process_noise=1e-6)
    augmented = EstimatorParams(
        process_noise=1e-6, aperiodic_time_constant=tau, aperiodic_noise=2.0 * sigma**2 / tau
    )
    q0 = Q_TRUE.copy()
    errors = []
    for params in (plain, augmented):
        _, (est,), _, _ = _run(z, g, periods, params, q0, ("estimated_power",))
        tail = slice(n // 2, n)
        errors.append(float(np.sqrt(np.mean((est[0, tail] - y[tail]) ** 2))))
    print(
        f"one-step RMS error: paper model {errors[0]:.3f} W, with aperiodic state {errors[1]:.3f} W"
    )
    assert errors[1] < 0.5 * errors[0]


def test_estimator_aperiodic_params_validated():
    from eaplan_drake.errors import ScenarioError

    with pytest.raises(ScenarioError, match="estimator.aperiodic_time_constant"):
        EstimatorParams(aperiodic_time_constant=-1.0).Validate()
    with pytest.raises(ScenarioError, match="estimator.aperiodic_noise"):
        EstimatorParams(aperiodic_noise=-1.0).Validate()
    with pytest.raises(ScenarioError, match="estimator.mean_process_noise"):
        EstimatorParams(mean_process_noise=math.nan).Validate()
    assert ModelOrder(3, EstimatorParams().aperiodic_time_constant) == 3
    assert ModelOrder(2, math.inf).order == 2


def test_closed_loop_carries_the_aperiodic_state_to_the_planner():
    """With τ set in the scenario the estimator, the planner's input and its prediction all use
    the augmented model (m = 2r + 2); the prediction lets d decay as exp(−t/τ)."""
    from eaplan_drake.diagram import MakeEaplanDiagram
    from eaplan_drake.energy.fourier import AugmentedOrder
    from eaplan_drake.params import Scenario
    from eaplan_drake.planning.prediction import FreeResponse

    scenario = Scenario()
    scenario.estimator.aperiodic_time_constant = 15.0
    scenario.estimator.aperiodic_noise = 0.1
    diagram = MakeEaplanDiagram(scenario)
    estimator = diagram.GetSubsystemByName("estimator")
    planner = diagram.GetSubsystemByName("planner")
    m = 2 * scenario.energy_model.order + 2
    assert estimator.GetOutputPort("energy_coefficients").size() == m
    assert planner.GetInputPort("energy_coefficients").size() == m
    q = np.zeros(m)
    q[0], q[-1] = 30.0, 5.0
    f = FreeResponse(q, AugmentedOrder(scenario.energy_model.order, 15.0), 46.0, 1.0, 31)
    np.testing.assert_allclose(f, 30.0 + 5.0 * np.exp(-np.arange(31) / 15.0), atol=1e-12)
