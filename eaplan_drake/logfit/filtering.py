"""The energy model over a recorded power series: its uniform grid, its period (one T or the
period in force T_k at each sample), its noise, the Kalman filter and the predictions ahead.

Model (see :mod:`eaplan_drake.energy.fourier`): Fourier order r and period T [s], optionally with
the aperiodic AR(1) load d (time constant τ [s], intensity q_d [W²/s]), sampled every Δt [s]:

    q_{k+1} = A_d q_k + w_k,   w_k ~ N(0, diag(q_n, …, q_n, Q_dd)),
    z_k     = C q_k + v_k,     v_k ~ N(0, R).

The filter is the one of :mod:`eaplan_drake.energy.estimator` (its gain
:func:`~eaplan_drake.energy.estimator.KalmanGain`, Q from
:func:`~eaplan_drake.energy.fourier.ProcessNoiseMatrix`; tested against
:func:`~eaplan_drake.energy.estimator.KalmanUpdate` /
:func:`~eaplan_drake.energy.estimator.KalmanPredict`). With one period it runs with the
steady-state gain (:func:`SteadyStateCovariance`, the time-invariant filter's limit).

**A period that changes.** Every function taking ``period`` also takes T_k [s] per sample (the
period in force, :func:`PeriodInForce` of a period log): the filter is then the exact
time-varying one, re-discretised per T_k as the estimator does (:func:`FilterPowerSeries`), and
the prediction holds the period in force at its origin (:func:`PredictAhead`).
"""

import dataclasses as dc
import math

import numpy as np

from eaplan_drake.energy.estimator import KalmanGain, KalmanPredict, KalmanUpdate
from eaplan_drake.energy.fourier import (
    AugmentedOrder,
    DiscreteEnergyMatrices,
    FitFourierSeries,
    OutputMatrix,
    ProcessNoiseMatrix,
    StateSize,
    TransitionMatrices,
)

__all__ = [
    "FilterPowerSeries",
    "HorizonSteps",
    "InitialState",
    "NoiseParameters",
    "PeriodInForce",
    "PeriodSeries",
    "PredictAhead",
    "PredictionErrors",
    "SteadyStateCovariance",
    "UniformPowerSeries",
]


@dc.dataclass(frozen=True)
class NoiseParameters:
    """Noise of the model at the log's step Δt."""

    measurement_noise: float
    """R [W²]."""
    process_noise: float
    """q_n per step Δt on each Fourier state [W²]."""
    mean_process_noise: float = 0.0
    """q_0, extra per step Δt on α0 [W²]."""
    aperiodic_time_constant: float = 0.0
    """τ [s]; 0: no aperiodic state."""
    aperiodic_noise: float = 0.0
    """q_d [W²/s]."""

    def Model(self, order: int):
        """r, or AugmentedOrder(r, τ) when τ > 0."""
        if self.aperiodic_time_constant > 0.0:
            return AugmentedOrder(int(order), self.aperiodic_time_constant)
        return int(order)

    def Scaled(self, factor: float) -> "NoiseParameters":
        """Every variance (R, q_n, q_0, q_d) times ``factor`` [-]; τ kept."""
        return dc.replace(
            self,
            measurement_noise=factor * self.measurement_noise,
            process_noise=factor * self.process_noise,
            mean_process_noise=factor * self.mean_process_noise,
            aperiodic_noise=factor * self.aperiodic_noise,
        )


def UniformPowerSeries(times, power, time_step: float | None = None):
    """(t, z) on a uniform grid of step Δt [s] (default: the median spacing) by linear
    interpolation; non-finite samples are dropped first. Needs increasing times."""
    t = np.asarray(times, dtype=float).reshape(-1)
    y = np.asarray(power, dtype=float).reshape(-1)
    if t.shape != y.shape:
        raise ValueError(f"times and power must have the same length, got {t.size}, {y.size}")
    keep = np.isfinite(t) & np.isfinite(y)
    t, y = t[keep], y[keep]
    if t.size < 16:
        raise ValueError(f"power log: needs at least 16 finite samples, got {t.size}")
    if not np.all(np.diff(t) > 0.0):
        raise ValueError("power log: times must be strictly increasing")
    dt = float(np.median(np.diff(t))) if time_step is None else float(time_step)
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f"time_step: must be finite and > 0 [s], got {time_step!r}")
    grid = t[0] + dt * np.arange(int(math.floor((t[-1] - t[0]) / dt + 1e-9)) + 1)
    return grid, np.interp(grid, t, y)


def PeriodSeries(period, n: int) -> tuple[float, np.ndarray | None]:
    """(T_nominal [s], T_k [s] per sample or None) of a ``period`` argument for n samples.

    ``period`` is one T [s] (returns (T, None)) or n periods T_k [s], the period in force at each
    sample (a time-varying period; returns (T_{n−1}, T_k), or (T, None) when all are equal). The
    nominal period, the last one in force, sets the horizons T/4, T/2, T and the burn-in.
    """
    if np.ndim(period) == 0:
        T = float(period)
        if not (math.isfinite(T) and T > 0.0):
            raise ValueError(f"period: must be finite and > 0 [s], got {period!r}")
        return T, None
    Ts = np.asarray(period, dtype=float).reshape(-1)
    if Ts.size != n:
        raise ValueError(f"period: needs one T per sample ({n}), got {Ts.size}")
    if not np.all(np.isfinite(Ts) & (Ts > 0.0)):
        raise ValueError("period: every T_k must be finite and > 0 [s]")
    if np.all(Ts == Ts[0]):
        return float(Ts[0]), None
    return float(Ts[-1]), Ts


def PeriodInForce(times, period_times, periods) -> np.ndarray:
    """T_k [s] at each of ``times`` [s]: the last of ``periods`` stamped at or before it (the
    first one before the first stamp), i.e. the period a running estimator had in force."""
    tp = np.asarray(period_times, dtype=float).reshape(-1)
    Tp = np.asarray(periods, dtype=float).reshape(-1)
    if tp.size == 0 or tp.shape != Tp.shape or not np.all(np.diff(tp) >= 0.0):
        raise ValueError("period log: needs increasing times and one period per time")
    i = np.searchsorted(tp, np.asarray(times, dtype=float), side="right") - 1
    return Tp[np.clip(i, 0, tp.size - 1)]


def SteadyStateCovariance(Ad, c, Q, R: float, iterations: int = 60) -> np.ndarray:
    """P⁻∞ of the time-invariant filter: the stabilising solution of the filter Riccati equation
    P = A_d P A_dᵀ − A_d P cᵀ (c P cᵀ + R)⁻¹ c P A_dᵀ + Q, by the structure-preserving doubling
    algorithm (A_0 = A_dᵀ, G_0 = cᵀ R⁻¹ c, H_0 = Q; quadratic convergence, H_k → P)."""
    A = np.asarray(Ad, dtype=float).T.copy()
    c = np.reshape(c, -1)
    G = np.outer(c, c) / float(R)
    H = np.asarray(Q, dtype=float).copy()
    eye = np.eye(A.shape[0])
    for _ in range(iterations):
        W = eye + G @ H
        WA = np.linalg.solve(W, A)
        WG = np.linalg.solve(W, G)
        H_next = H + A.T @ H @ WA
        G = G + A @ WG @ A.T
        A = A @ WA
        done = np.max(np.abs(H_next - H)) <= 1e-12 * np.max(np.abs(H_next))
        H = 0.5 * (H_next + H_next.T)
        if done:
            break
    return H


def InitialState(z, time_step: float, model, period):
    """q̂(0): least-squares Fourier fit of the first (up to) two periods (d = 0).

    With a time-varying period T_k the regressors are those of the phase
    θ_k = 2π Σ_{i<k} Δt/T_i (the product of the re-discretised rotations): the fit runs in the
    warped time θ_k T_0 / 2π with the period T_0.
    """
    r = int(model.order) if isinstance(model, AugmentedOrder) else int(model)
    nominal, Ts = PeriodSeries(period, z.size)
    n = min(z.size, max(2 * r + 2, int(round(2.0 * nominal / time_step))))
    if Ts is None:
        t, T0 = time_step * np.arange(n), nominal
    else:
        T0 = float(Ts[0])
        t = np.concatenate(([0.0], np.cumsum(time_step * T0 / Ts[: n - 1])))
    q = FitFourierSeries(t, z[:n], r, T0, at_time=0.0)
    return np.append(q, 0.0) if StateSize(model) > q.size else q


def FilterPowerSeries(
    z, time_step: float, order: int, period, noise: NoiseParameters, initial_state=None
):
    """Run the Kalman filter over z (uniform step Δt [s]) from the steady-state covariance.

    q̂(0) is the least-squares Fourier fit of the first two periods (so the start-up is short),
    P⁻(0) = P⁻∞ of (A_d(T_0), C, Q, R) (:func:`SteadyStateCovariance`). With one period T the
    covariance stays there and the filter is the steady-state one (one gain). With a period T_k
    per sample (``period`` an array, see :func:`PeriodSeries`) it is the exact time-varying
    filter of the estimator: :func:`~eaplan_drake.energy.estimator.KalmanUpdate` with z_k, then
    :func:`~eaplan_drake.energy.estimator.KalmanPredict` with A_d(T_k) re-discretised as
    :class:`~eaplan_drake.energy.estimator.EnergyEstimator` does when its period input changes
    (:class:`~eaplan_drake.energy.fourier.TransitionMatrices`). Returns (q̂ (N×m) filtered states
    after the update at each k, e (N) innovations [W], s innovation variance [W²]: one number
    for one period, N for T_k). ``initial_state`` replaces that q̂(0) (m entries).
    """
    z = np.asarray(z, dtype=float).reshape(-1)
    nominal, Ts = PeriodSeries(period, z.size)
    model = noise.Model(order)
    c = OutputMatrix(model)[0]
    m = c.size
    Q = ProcessNoiseMatrix(
        model, noise.process_noise, noise.mean_process_noise, noise.aperiodic_noise, time_step
    )
    R = float(noise.measurement_noise)
    q0 = InitialState(z, time_step, model, period) if initial_state is None else initial_state
    if Ts is not None:
        transition = TransitionMatrices(model, time_step)
        P = SteadyStateCovariance(transition(Ts[0]), c, Q, R)
        states = np.empty((z.size, m))
        e, s = np.empty(z.size), np.empty(z.size)
        q = np.asarray(q0, dtype=float)
        for j in range(z.size):
            e[j] = z[j] - float(c @ q)
            s[j] = float(c @ P @ c) + R
            q, P = KalmanUpdate(q, P, c, R, z[j])
            states[j] = q
            q, P = KalmanPredict(q, P, transition(Ts[j]), Q)
        return states, e, s
    Ad, _ = DiscreteEnergyMatrices(model, nominal, time_step)
    K, _, s = KalmanGain(SteadyStateCovariance(Ad, c, Q, R), c, R)
    F = Ad - np.outer(Ad @ K, c)  # q⁻ ← A_d (I − K c) q⁻ + A_d K z
    G = Ad @ K
    n = z.size
    states = np.empty((n, m))
    e = np.empty(n)
    q = q0
    for j in range(n):
        ej = z[j] - float(c @ q)
        e[j] = ej
        states[j] = q + K * ej
        q = F @ q + G * z[j]
    return states, e, s


def HorizonSteps(period: float, time_step: float) -> tuple[int, int, int, int]:
    """Steps ahead for 1 step, T/4, T/2 and T."""
    P = max(1, int(round(period / time_step)))
    return 1, max(1, round(P / 4)), max(1, round(P / 2)), P


def PredictAhead(states, order: int, period, time_step: float, noise, steps: int):
    """ŷ_{k+H|k} = C A_d(T_k)ᴴ q̂_k [W] for every filtered state q̂_k (H = ``steps``).

    A_d(T)ᴴ is the exact A_d of the step H Δt (the rotation angles add, φᴴ = exp(−H Δt/τ)). With
    a period T_k per sample the period in force at the origin k is held over the horizon, as the
    estimator's and the planner's prediction do.
    """
    states = np.asarray(states)
    model = noise.Model(order)
    C = OutputMatrix(model)[0]
    nominal, Ts = PeriodSeries(period, states.shape[0])
    if Ts is None:
        return states @ (C @ DiscreteEnergyMatrices(model, nominal, int(steps) * time_step)[0])
    values, which = np.unique(Ts, return_inverse=True)
    rows = np.array(
        [C @ DiscreteEnergyMatrices(model, T, int(steps) * time_step)[0] for T in values]
    )
    return np.einsum("km,km->k", states, rows[which])


def PredictionErrors(pred, z, origins, H) -> tuple[float, float]:
    """(RMSE, MAE) [W] of the predictions ``pred[k]`` of z_{k+H} made at each of ``origins`` k."""
    err = pred[origins] - z[origins + H]
    return float(np.sqrt(np.mean(err * err))), float(np.mean(np.abs(err)))
