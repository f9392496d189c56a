"""Fit the energy model to a recorded power series and score its predictions.

Model (see :mod:`eaplan_drake.energy.fourier`): Fourier order r and period T [s], optionally with
the aperiodic AR(1) load d (time constant τ [s], intensity q_d [W²/s]), sampled every Δt [s]:

    q_{k+1} = A_d q_k + w_k,   w_k ~ N(0, diag(q_n, …, q_n, Q_dd)),
    z_k     = C q_k + v_k,     v_k ~ N(0, R).

**Noise from data.** :func:`FitNoise` maximises the innovation (prediction-error) log-likelihood

    ℓ(θ) = −½ Σ_{k ≥ k_0} (log 2π s_k + e_k² / s_k),   e_k = z_k − C q̂⁻_k,  s_k = C P⁻_k Cᵀ + R,

over θ = (log R, log q_n, log q_d, log τ) with a deterministic Nelder–Mead search, where (q̂⁻, P⁻)
come from the Kalman filter of :mod:`eaplan_drake.energy.estimator` (its gain
:func:`~eaplan_drake.energy.estimator.KalmanGain`, Q from
:func:`~eaplan_drake.energy.fourier.ProcessNoiseMatrix`; tested against
:func:`~eaplan_drake.energy.estimator.KalmanUpdate` /
:func:`~eaplan_drake.energy.estimator.KalmanPredict`).
The first k_0 samples (one
period, at most a fifth of the record) are the filter's start-up from a diffuse prior and are left
out. From then on the filter runs with the steady-state gain (:func:`SteadyStateCovariance`,
the time-invariant filter's limit; this makes ℓ cheap and is the standard steady-state
approximation of the exact likelihood). With a period that changes (below) the filter starts
at that covariance and runs the exact time-varying recursion (s_k varies).

**Order by a held-out criterion.** :func:`FitPowerModel` fits every candidate order (noise by
likelihood, Nelder–Mead from the default start and from the previous order's optimum: two
local optima, both candidates) on the first 70 % of the training record and keeps the one whose
predictions at 1 step, T/4, T/2 and T ahead have the smallest mean squared error, summed over
the four horizons, for the targets in the remaining 30 % (:func:`MultiStepError`; origins before
the split count, so every horizon has the same held-out targets). The same criterion decides
whether the level random walk q_0 is kept (a structural choice like r: the likelihood prefers a
quickly adapting level, best one step ahead but not always T ahead), and compares two levels
fitted for the horizons (:func:`FitLevelNoise`: the local level, y = α0 a random walk, and the
r = 0 model with its q_0 re-chosen), whose q_0 is chosen by the multi-step error on the first
70 % itself. The chosen structure's noise is then refitted on the whole training record.

**Noise for the horizons.** The likelihood scores one-step predictions only; the planner uses
the model up to a period ahead. So the chosen structure (order, AR(1) load, walk) gets a second
noise fit that minimises its multi-step error on the first 70 % instead (:func:`FitNoise` with
``criterion="horizons"``: Σ_H log MSE_H over the four horizons, :func:`MultiStepError` with
``relative=True``, so each horizon's relative error counts equally and the one-step error is
not traded away for the longer ones; Nelder–Mead from the likelihood optimum; the predictions
depend on the noise ratios only, so their common scale is then the likelihood's,
:func:`LikelihoodScaledNoise`). It is one more candidate of the held-out criterion; when it
wins, the whole-record refit uses that criterion too (:attr:`PowerModelFit.noise_criterion`).
The model and the estimator are the same; only the noise values differ.

**A period that changes.** Every function taking ``period`` also takes T_k [s] per sample (the
period in force, :func:`PeriodInForce` of a period log): the filter is then the exact
time-varying one, re-discretised per T_k as the estimator does (:func:`FilterPowerSeries`), the
prediction holds the period in force at its origin, and the baselines use it too.

**Scores.** :func:`ScorePredictions` fits on the first half of a log and scores RMSE and MAE [W]
of the predictions made from origins in the second half, against three baselines: last value,
one-period moving average, and the value one period before the target (seasonal naive; both
with the period in force at the origin when it varies).
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
from eaplan_drake.rates import RescaledProcessNoise

__all__ = [
    "BASELINES",
    "BaselinePrediction",
    "CheckLogLength",
    "FilterPowerSeries",
    "FitNoise",
    "FitPowerLog",
    "FitPowerModel",
    "FormatScores",
    "FRAGMENT_ORDERS",
    "HELD_OUT_SPLIT",
    "LogFit",
    "PlotLogFit",
    "HORIZONS_SUFFIX",
    "HorizonSteps",
    "InnovationLogLikelihood",
    "FitLevelNoise",
    "LEVEL_RATIOS",
    "LikelihoodScaledNoise",
    "MinimumSamples",
    "NOISE_CRITERIA",
    "NOISE_CRITERIA_TEXT",
    "ModelName",
    "MultiStepError",
    "ORDERS",
    "PeriodInForce",
    "PeriodSeries",
    "NoiseParameters",
    "PowerModelFit",
    "PredictAhead",
    "SCENARIO_MAX_ORDER",
    "ScorePredictions",
    "SteadyStateCovariance",
    "SyntheticPower",
    "UniformPowerSeries",
]

BASELINES = ("last value", "moving average", "seasonal naive")
"""The three baselines of :func:`ScorePredictions`."""

HORIZON_NAMES = ("1 step", "T/4", "T/2", "T")


def SyntheticPower(
    seed: int,
    tau: float = 15.0,
    sigma: float = 3.0,
    noise: float = 0.5,
    dt: float = 0.5,
    duration: float = 1200.0,
    period: float = 46.0,
):
    """(t [s], y [W]) on a uniform grid of step ``dt``: periodic power (``period`` T, mean 30 W,
    three harmonics) + an AR(1) load of time constant ``tau`` [s] and standard deviation
    ``sigma`` [W] + white noise of ``noise`` [W]; the test signal of the fit and its benchmark."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, dt)
    w = 2.0 * math.pi / period
    y = 30.0 + 3.0 * np.cos(w * t) + 2.0 * np.sin(2 * w * t) + np.cos(3 * w * t + 1.0)
    phi = math.exp(-dt / tau)
    e = rng.normal(0.0, sigma * math.sqrt(1.0 - phi * phi), t.size)
    d = np.zeros(t.size)
    for k in range(1, t.size):
        d[k] = phi * d[k - 1] + e[k]
    return t, y + d + rng.normal(0.0, noise, t.size)


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


def _InitialState(z, time_step: float, model, period):
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
    q0 = _InitialState(z, time_step, model, period) if initial_state is None else initial_state
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


def _BurnIn(n: int, period_steps: int) -> int:
    return max(1, min(period_steps, n // 5))


def InnovationLogLikelihood(
    z, time_step: float, order: int, period, noise: NoiseParameters, initial_state=None
) -> float:
    """ℓ(θ) of the module docstring [-] (higher is better); ``period`` as in
    :func:`FilterPowerSeries`."""
    _, e, s = FilterPowerSeries(z, time_step, order, period, noise, initial_state)
    nominal, _ = PeriodSeries(period, e.size)
    k0 = _BurnIn(e.size, int(round(nominal / time_step)))
    e = e[k0:]
    s = np.broadcast_to(s, (e.size + k0,))[k0:]
    return float(-0.5 * (np.sum(np.log(2.0 * math.pi * s)) + np.sum(e * e / s)))


def _NelderMead(f, x0, step, max_evals: int = 120, tol: float = 1e-4):
    """Deterministic Nelder–Mead minimisation of f from x0 (simplex of ``step`` per axis)."""
    x0 = np.asarray(x0, dtype=float)
    n = x0.size
    simplex = [x0] + [x0 + step * np.eye(n)[i] for i in range(n)]
    values = [f(x) for x in simplex]
    evals = n + 1
    while evals < max_evals:
        order = np.argsort(values, kind="stable")
        simplex = [simplex[i] for i in order]
        values = [values[i] for i in order]
        if abs(values[-1] - values[0]) <= tol * (1.0 + abs(values[0])):
            break
        centroid = np.mean(simplex[:-1], axis=0)
        xr = centroid + (centroid - simplex[-1])
        fr = f(xr)
        evals += 1
        if fr < values[0]:
            xe = centroid + 2.0 * (centroid - simplex[-1])
            fe = f(xe)
            evals += 1
            simplex[-1], values[-1] = (xe, fe) if fe < fr else (xr, fr)
        elif fr < values[-2]:
            simplex[-1], values[-1] = xr, fr
        else:
            xc = centroid + 0.5 * (simplex[-1] - centroid)
            fc = f(xc)
            evals += 1
            if fc < values[-1]:
                simplex[-1], values[-1] = xc, fc
            else:
                for i in range(1, n + 1):
                    simplex[i] = simplex[0] + 0.5 * (simplex[i] - simplex[0])
                    values[i] = f(simplex[i])
                    evals += 1
    best = int(np.argmin(values))
    return simplex[best], float(values[best])


def FitNoise(
    z,
    time_step: float,
    order: int,
    period,
    aperiodic: bool = True,
    max_evaluations: int = 120,
    start: NoiseParameters | None = None,
    level: bool | float = True,
    criterion: str = "likelihood",
) -> tuple[NoiseParameters, float]:
    """(noise, ℓ): the noise maximising the innovation log-likelihood (module docstring), or
    with ``criterion="horizons"`` the noise ratios minimising the multi-step error
    Σ_H log MSE_H (:func:`MultiStepError` with ``relative=True``; targets from the burn-in plus
    one period T on), scaled by the likelihood (:func:`LikelihoodScaledNoise`: the point
    predictions fix only the ratios), ℓ then being the likelihood at that noise.

    θ = log10 of (R, q_n, q_0, q_d, τ) (q_d, τ only with ``aperiodic``; q_0 searched when
    ``level`` is True, else fixed: 0 for False, the value for a number); τ in [Δt, 50 T].
    Nelder–Mead from ``start`` (default: R from the lag-one differences, small q's, τ = 10 s).
    ``period``: T [s] or T_k per sample (:func:`PeriodSeries`; the bound uses the nominal T).
    """
    if criterion not in NOISE_CRITERIA:
        raise ValueError(f"criterion: one of {', '.join(NOISE_CRITERIA)}, got {criterion!r}")
    z = np.asarray(z, dtype=float).reshape(-1)
    dt = float(time_step)
    var = max(float(np.var(z)), 1e-9)
    tau_lo, tau_hi = dt, 50.0 * PeriodSeries(period, z.size)[0]
    search_level = level is True
    fixed_level = 0.0 if search_level or level is False else float(level)
    names = ["R", "q_n"] + (["q_0"] if search_level else []) + (["q_d", "tau"] if aperiodic else [])

    def unpack(x):
        v = {k: float(10.0**xi) for k, xi in zip(names, x, strict=True)}
        tau = min(max(v["tau"], tau_lo), tau_hi) if aperiodic else 0.0
        q_0 = v.get("q_0", fixed_level)
        return NoiseParameters(v["R"], v["q_n"], q_0, tau, v.get("q_d", 0.0))

    P = max(1, int(round(PeriodSeries(period, z.size)[0] / dt)))
    first = min(_BurnIn(z.size, P) + P, z.size - 2)  # the horizons' first target
    q0 = {}  # q̂(0) depends on the structure only (with or without d), not on θ

    def cost(x):
        if np.any(np.abs(x) > 15.0):
            return 1e30
        noise = unpack(x)
        if aperiodic not in q0:
            q0[aperiodic] = _InitialState(z, dt, noise.Model(order), period)
        if criterion == "horizons":
            v = MultiStepError(z, dt, order, period, noise, first, relative=True)
            return v if math.isfinite(v) else 1e30
        ll = InnovationLogLikelihood(z, dt, order, period, noise, q0[aperiodic])
        return -ll if math.isfinite(ll) else 1e30

    floor = 1e-12 * var
    if start is None:
        white = max(0.25 * float(np.var(np.diff(z))), 1e-6 * var)
        tau0 = min(max(10.0, 2.0 * dt), tau_hi)
        guess = {"R": white, "q_n": 1e-5 * var * dt, "q_0": 1e-3 * var * dt}
        guess.update({"q_d": var / tau0, "tau": tau0})
        step = 1.0
    else:
        guess = {
            "R": start.measurement_noise,
            "q_n": start.process_noise,
            "q_0": start.mean_process_noise,
            "q_d": start.aperiodic_noise,
            "tau": min(max(start.aperiodic_time_constant, tau_lo), tau_hi),
        }
        step = 0.5
    x0 = [math.log10(max(guess[k], floor)) for k in names]
    x, f = _NelderMead(cost, x0, step, max_evals=max_evaluations)
    if criterion == "horizons":
        return LikelihoodScaledNoise(z, dt, order, period, unpack(x), q0.get(aperiodic))
    return unpack(x), -f


def LikelihoodScaledNoise(
    z, time_step: float, order: int, period, noise: NoiseParameters, initial_state=None
) -> tuple[NoiseParameters, float]:
    """(c·noise, ℓ): every variance of ``noise`` (R, q_n, q_0, q_d; τ kept) times the scale c
    that maximises the innovation likelihood ℓ, and that ℓ.

    Scaling Q and R by c scales P⁻ and s_k by c and leaves the gains, the estimates and the
    innovations e_k unchanged, so ℓ(c) = −½ Σ (log 2π c s_k + e_k²/(c s_k)) is maximised at
    c = mean(e_k²/s_k) (k ≥ k_0). Point predictions depend on the noise ratios only; this sets
    the scale (the filter's covariance, the simulated sensor's σ) from the data.
    """
    _, e, s = FilterPowerSeries(z, time_step, order, period, noise, initial_state)
    nominal, _ = PeriodSeries(period, e.size)
    k0 = _BurnIn(e.size, int(round(nominal / time_step)))
    s = np.broadcast_to(s, e.shape)
    c = float(np.mean(e[k0:] ** 2 / s[k0:]))
    if not (math.isfinite(c) and c > 0.0):
        return noise, InnovationLogLikelihood(z, time_step, order, period, noise, initial_state)
    scaled = noise.Scaled(c)
    return scaled, InnovationLogLikelihood(z, time_step, order, period, scaled, initial_state)


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


def BaselinePrediction(name: str, z, period_steps, steps: int) -> np.ndarray:
    """Baseline prediction of z_{k+H} made at k (NaN where it needs samples before the log).

    ``period_steps`` P: one period in samples, or P_k per origin (the period in force at k; the
    moving average then spans the last P_k samples). Seasonal naive is z_{k+H−jP} with
    j = ⌈H/P⌉ whole periods back (j = 1 for H ≤ P), so it never uses a sample after k.
    """
    z = np.asarray(z, dtype=float)
    n, H = z.size, int(steps)
    P = np.broadcast_to(np.asarray(period_steps, dtype=int), (n,))
    k = np.arange(n)
    out = np.full(n, np.nan)
    if name == "last value":
        out[:] = z
    elif name == "moving average":
        c = np.concatenate(([0.0], np.cumsum(z)))
        ok = k + 1 - P >= 0
        out[ok] = (c[k[ok] + 1] - c[k[ok] + 1 - P[ok]]) / P[ok]
    elif name == "seasonal naive":
        back = P * -(-H // P)  # ⌈H/P⌉ periods
        ok = k + H - back >= 0
        out[ok] = z[k[ok] + H - back[ok]]
    else:
        raise ValueError(f"baseline: one of {BASELINES}, got {name!r}")
    return out


def _Errors(pred, z, origins, H):
    err = pred[origins] - z[origins + H]
    return float(np.sqrt(np.mean(err * err))), float(np.mean(np.abs(err)))


@dc.dataclass
class PowerModelFit:
    """Result of :func:`FitPowerModel`."""

    order: int
    """r [-]."""
    period: float
    """T [s] (with a time-varying period: the last one in force in the training record)."""
    time_step: float
    """Δt of the log (after resampling) [s]."""
    noise: NoiseParameters
    """Fitted noise at Δt."""
    log_likelihood: float
    """ℓ on the training record [-]."""
    mean_power: float
    """Mean of the training record [W]."""
    candidates: list
    """(order r, level intensity q_0 [W²/step], held-out score [W²], name) of every candidate
    tried, in order: the orders, the best order without q_0, the best structure with its noise
    fitted for the horizons (its name ends in :data:`HORIZONS_SUFFIX`), then the levels fitted
    for the horizons (local level, then r = 0 with its q_0 re-chosen); name as
    :attr:`model_name`."""
    model_name: str = ""
    """The chosen model in words (:func:`ModelName`): "r=4+AR(1)", "level", "level+AR(1)", …;
    the two levels fitted for the horizons have r = 0 like the ordinary r = 0 model."""
    noise_criterion: str = "likelihood"
    """How the chosen noise was fitted, a key of :data:`NOISE_CRITERIA_TEXT`: "likelihood"
    (innovation likelihood), "horizons" (multi-step error, :func:`FitNoise`) or "level" (one of
    the two levels of :func:`FitLevelNoise`: q_0 by the multi-step error, the rest by
    likelihood)."""

    def ScenarioFragment(self, estimator_rate: float = 100.0) -> str:
        """YAML for ``simulate`` with the fitted model (energy_model and estimator keys);
        ValueError for an order above :data:`SCENARIO_MAX_ORDER`.

        q_n and q_0 are random-walk variances per step, rescaled from the log's step to the
        estimator's step 1/rate (:func:`~eaplan_drake.rates.RescaledProcessNoise`); R is the log's
        per-sample noise (also the simulated sensor's σ = √R); τ and q_d are rate independent.
        """
        if self.order > SCENARIO_MAX_ORDER:
            raise ValueError(
                f"scenario fragment: order r = {self.order} is above energy_model.order's "
                f"largest, {SCENARIO_MAX_ORDER}; fit with orders up to {SCENARIO_MAX_ORDER} "
                "(FRAGMENT_ORDERS)"
            )
        log_rate = 1.0 / self.time_step
        qn = RescaledProcessNoise(self.noise.process_noise, log_rate, estimator_rate)
        q0 = RescaledProcessNoise(self.noise.mean_process_noise, log_rate, estimator_rate)
        tau = self.noise.aperiodic_time_constant
        name = self.model_name or ModelName(self.order, self.noise)
        lines = [
            "# fitted by eaplan-drake fit (order by held-out error; noise by "
            + NOISE_CRITERIA_TEXT[self.noise_criterion]
            + ")",
            f"# model: {name}",
            "sensor:",
            f"  noise_std: {_YamlFloat(math.sqrt(self.noise.measurement_noise))}",
            "energy_model:",
            f"  order: {self.order}",
            f"  initial_period: {_YamlFloat(self.period)}",
            f"  initial_mean_power: {_YamlFloat(max(self.mean_power, 0.0))}",
            "estimator:",
            f"  process_noise: {_YamlFloat(qn)}",
            f"  measurement_noise: {_YamlFloat(self.noise.measurement_noise)}",
            f"  mean_process_noise: {_YamlFloat(q0)}",
        ]
        if tau > 0.0:
            lines += [
                f"  aperiodic_time_constant: {_YamlFloat(tau)}",
                f"  aperiodic_noise: {_YamlFloat(self.noise.aperiodic_noise)}",
            ]
        return "\n".join(lines) + "\n"


def ModelName(order: int, noise: NoiseParameters, horizon: str = "none") -> str:
    """The model in words: "r=<r>" for the Fourier model of order r, with "+AR(1)" when it has
    the aperiodic load (τ > 0) and "+walk" when its level α0 has the random walk q_0 > 0;
    ``horizon`` "local" (the local level of :func:`FitLevelNoise`) is "level", "r0" (the r = 0
    model with q_0 re-chosen for the horizons) "level+AR(1)" (or "level" without τ)."""
    aperiodic = "+AR(1)" if noise.aperiodic_time_constant > 0.0 else ""
    if horizon in ("local", "r0"):
        return "level" + aperiodic
    if horizon != "none":
        raise ValueError(f"horizon: one of none, local, r0, got {horizon!r}")
    walk = "+walk" if noise.mean_process_noise > 0.0 else ""
    return f"r={int(order)}{aperiodic}{walk}"


def _YamlFloat(x: float) -> str:
    """A float YAML 1.1 reads as a float (a dot, a signed exponent), ``.inf`` for ∞."""
    x = float(x)
    if math.isinf(x):
        return ".inf" if x > 0 else "-.inf"
    if x == 0.0 or 1e-3 <= abs(x) < 1e6:
        text = f"{x:.6g}"
        return text if "." in text else text + ".0"
    return f"{x:.6e}"


def MultiStepError(
    z, time_step: float, order: int, period, noise, first_target: int, relative: bool = False
) -> float:
    """Σ over H ∈ {1 step, T/4, T/2, T} of the mean squared error MSE_H [W²] of ŷ_{k+H|k}
    (:func:`PredictAhead` after :func:`FilterPowerSeries` over z) for the targets
    k + H ≥ ``first_target`` (every horizon has the same targets; each prediction uses z up to
    its origin k only). The held-out criterion of :func:`FitPowerModel` (targets after the
    fitting window) and the fitting criterion of :func:`FitLevelNoise`. ``relative``: Σ_H
    log MSE_H instead [-] (scale free: each horizon's relative error counts equally), the
    criterion of :func:`FitNoise` with ``criterion="horizons"``."""
    z = np.asarray(z, dtype=float).reshape(-1)
    states, _, _ = FilterPowerSeries(z, time_step, order, period, noise)
    total = 0.0
    for H in HorizonSteps(PeriodSeries(period, z.size)[0], time_step):
        origins = np.arange(max(int(first_target) - H, 0), z.size - H)
        if origins.size == 0:
            continue
        pred = PredictAhead(states, order, period, time_step, noise, H)
        mse = _Errors(pred, z, origins, H)[0] ** 2
        total += math.log(max(mse, 1e-300)) if relative else mse
    return total


HORIZONS_SUFFIX = " (noise for the horizons)"
"""Appended to a candidate's name in :attr:`PowerModelFit.candidates` when its noise was fitted by
the multi-step error (``criterion="horizons"``)."""

NOISE_CRITERIA_TEXT = {
    "likelihood": "innovation likelihood",
    "horizons": "multi-step error",
    "level": "likelihood, q_0 by multi-step error",
}
""":attr:`PowerModelFit.noise_criterion` in words (printed by ``fit``, in ``fit.yaml``'s header)."""

LEVEL_RATIOS = tuple(10.0 ** (0.25 * i) for i in range(-32, 5))
"""Candidate q_0/R [-] of :func:`FitLevelNoise` (10⁻⁸ … 10, four per decade)."""


def FitLevelNoise(
    z, time_step: float, period: float, base: NoiseParameters | None = None, ratios=LEVEL_RATIOS
) -> NoiseParameters:
    """A level fitted for the multi-step horizons: q_0 of an r = 0 model chosen by
    :func:`MultiStepError` on z (targets after the burn-in and one period T [s], so every origin
    is past the burn-in).

    Without ``base`` the model is the local level (y = α0, α0 a random walk, no aperiodic
    state): its filter is an exponentially weighted mean whose gain depends on λ = q_0/R only;
    λ is the best of ``ratios``, and R [W²] the innovation likelihood's maximiser for that λ,
    R = mean(e_k²/s̃_k) with s̃ the innovation variance for R = 1 (R only scales the
    likelihood). Returns NoiseParameters(R, 0, λR). With ``base`` (the r = 0 noise fitted by
    likelihood, e.g. with the AR(1) load) only q_0 = λR is re-chosen among 0 and λ ∈ ``ratios``
    and the rest is kept: the fast load carries the next step, the slow level the horizon.
    """
    z = np.asarray(z, dtype=float).reshape(-1)
    P = max(1, int(round(period / time_step)))
    k0 = _BurnIn(z.size, P)
    first = min(k0 + P, z.size - 2)
    unit = base if base is not None else NoiseParameters(1.0, 0.0, 0.0)
    R = unit.measurement_noise
    trials = [dc.replace(unit, mean_process_noise=float(lam) * R) for lam in ratios]
    if base is not None:
        trials.append(dc.replace(unit, mean_process_noise=0.0))
    errors = [MultiStepError(z, time_step, 0, period, noise, first) for noise in trials]
    best = trials[int(np.argmin(errors))]
    if base is not None:
        return best
    _, e, s = FilterPowerSeries(z, time_step, 0, period, best)
    R = max(float(np.mean(e[k0:] ** 2 / s)), 1e-12 * max(float(np.var(z)), 1e-9))
    return NoiseParameters(R, 0.0, best.mean_process_noise * R)


NOISE_CRITERIA = ("likelihood", "horizons")
"""How :func:`FitNoise` fits the noise: innovation likelihood, or multi-step error."""

HELD_OUT_SPLIT = 0.7
"""The fraction of the training record on which :func:`FitPowerModel` fits its candidates (the
rest scores them); it must hold one period."""

ORDERS = (0, 1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64)
"""Candidate Fourier orders of :func:`FitPowerModel` (those with 2r + 1 ≤ samples per period)."""

SCENARIO_MAX_ORDER = 20
"""The largest Fourier order a scenario accepts (``energy_model.order`` in
:mod:`eaplan_drake.params`), hence the largest of a :meth:`PowerModelFit.ScenarioFragment`."""

FRAGMENT_ORDERS = tuple(r for r in ORDERS if r <= SCENARIO_MAX_ORDER)
"""The candidate orders of ``eaplan-drake fit``, whose ``fit.yaml`` must load as a scenario
fragment: those of :data:`ORDERS` up to :data:`SCENARIO_MAX_ORDER`."""


def FitPowerModel(
    z,
    time_step: float,
    period,
    orders=ORDERS,
    aperiodic: bool = True,
    max_evaluations: int = 120,
    local_level: bool = True,
) -> PowerModelFit:
    """Fit order and noise to a uniform power series z [W] (step Δt [s], period T [s]).

    ``period`` is T [s] or T_k per sample (:func:`PeriodSeries`; the nominal T sets the
    horizons). Every order of ``orders`` with 2r + 1 ≤ T/Δt has its noise fitted by likelihood on
    the first 70 % (from the default start and from the previous order's higher-likelihood
    optimum; both optima are candidates) and is scored by :func:`MultiStepError` on the last
    30 % (the held-out criterion of the module docstring); then whether the level random walk
    q_0 helps the best order (held out too); with ``local_level`` the two levels of
    :func:`FitLevelNoise` (the local level, and r = 0 with q_0 re-chosen; fitted on the first
    70 %) are candidates scored the same way. The chosen structure's noise is refitted on the
    whole record, from the chosen optimum (likelihood; the levels: :func:`FitLevelNoise`).
    ``aperiodic`` adds the AR(1) load state to the Fourier candidates (False: the paper's model).
    """
    z = np.asarray(z, dtype=float).reshape(-1)
    nominal, Ts = PeriodSeries(period, z.size)
    P = int(round(nominal / time_step))
    split = int(HELD_OUT_SPLIT * z.size)
    if split < P:
        raise ValueError(
            f"power log: the first {100 * HELD_OUT_SPLIT:.0f} % of the {z.size} samples at "
            f"{time_step:.4g} s hold {split * time_step / nominal:.2f} periods of {nominal:.4g} s, "
            "less than the one the fit needs; record longer or check the period"
        )
    head = nominal if Ts is None else Ts[:split]
    candidates = []
    best = warm = level_start = None
    for r in sorted({int(r) for r in orders}):
        if 2 * r + 1 > P:  # more harmonics than one period of samples resolves
            continue
        fits = [FitNoise(z[:split], time_step, r, head, aperiodic, max_evaluations)]
        if warm is not None:  # the previous order's optimum as a second start
            fits.append(
                FitNoise(z[:split], time_step, r, head, aperiodic, max_evaluations // 2, warm)
            )
        warm = max(fits, key=lambda fit: fit[1])[0]
        if r == 0:
            level_start = warm
        for noise, _ in fits:  # both likelihood optima are candidates of the held-out choice
            score = MultiStepError(z, time_step, r, period, noise, split)
            candidates.append((r, noise.mean_process_noise, score, ModelName(r, noise)))
            if best is None or score < best[2]:
                best = (r, noise.mean_process_noise, score, noise)
    if best is None:
        raise ValueError(f"orders: no candidate in {list(orders)} fits a period of {P} samples")
    # Whether the level random walk q_0 helps, by the same held-out criterion.
    r = best[0]
    fixed, _ = FitNoise(
        z[:split], time_step, r, head, aperiodic, max_evaluations // 3, best[3], level=False
    )
    score = MultiStepError(z, time_step, r, period, fixed, split)
    candidates.append((r, 0.0, score, ModelName(r, fixed)))
    level = score >= best[2]
    if not level:
        best = (r, 0.0, score, fixed)
    # The same structure with its noise fitted for the horizons (multi-step error), held out.
    horizons, _ = FitNoise(
        z[:split], time_step, r, head, aperiodic, max_evaluations // 3, best[3], level, "horizons"
    )
    score = MultiStepError(z, time_step, r, period, horizons, split)
    name = ModelName(r, horizons) + HORIZONS_SUFFIX
    candidates.append((r, horizons.mean_process_noise, score, name))
    criterion = "likelihood"
    if score < best[2]:
        best, criterion = (r, horizons.mean_process_noise, score, horizons), "horizons"
    horizon = "none"  # or the level fitted for the horizons that won: "local", "r0"
    if local_level:
        # Levels fitted for the horizons: the local level, and the r = 0 model's q_0 re-chosen.
        bases = {"local": None, "r0": level_start} if level_start is not None else {"local": None}
        for name, base in bases.items():
            walk = FitLevelNoise(z[:split], time_step, nominal, base)
            score = MultiStepError(z, time_step, 0, nominal, walk, split)
            candidates.append((0, walk.mean_process_noise, score, ModelName(0, walk, name)))
            if score < best[2]:
                best, horizon = (0, walk.mean_process_noise, score, walk), name
    if horizon == "none":
        noise, ll = FitNoise(
            z, time_step, r, period, aperiodic, max_evaluations // 3, best[3], level, criterion
        )
        return PowerModelFit(
            r,
            nominal,
            float(time_step),
            noise,
            ll,
            float(z.mean()),
            candidates,
            ModelName(r, noise),
            criterion,
        )
    base = None
    if horizon == "r0":
        base, _ = FitNoise(z, time_step, 0, nominal, aperiodic, max_evaluations // 3, level_start)
    noise = FitLevelNoise(z, time_step, nominal, base)
    ll = InnovationLogLikelihood(z, time_step, 0, nominal, noise)
    name = ModelName(0, noise, horizon)
    return PowerModelFit(
        0, nominal, float(time_step), noise, ll, float(z.mean()), candidates, name, "level"
    )


def ScorePredictions(z, time_step: float, period, fit: PowerModelFit):
    """RMSE and MAE [W] at 1 step, T/4, T/2, T ahead from origins in the second half of z.

    The filter with ``fit``'s model runs over the whole record (it has seen only samples up to
    each origin). ``period``: T [s] or T_k per sample (:func:`PeriodSeries`; the horizons are
    those of the nominal T, the model and the baselines use the period in force at each
    origin). Returns {predictor: {horizon name: (RMSE, MAE)}}, predictors "model" and
    :data:`BASELINES`.
    """
    z = np.asarray(z, dtype=float).reshape(-1)
    nominal, Ts = PeriodSeries(period, z.size)
    states, _, _ = FilterPowerSeries(z, time_step, fit.order, period, fit.noise)
    P = max(1, int(round(nominal / time_step)))
    Pk = P if Ts is None else np.maximum(1, np.round(Ts / time_step).astype(int))
    table = {name: {} for name in ("model",) + BASELINES}
    for label, H in zip(HORIZON_NAMES, HorizonSteps(nominal, time_step), strict=True):
        origins = np.arange(max(z.size // 2, int(np.max(Pk))), z.size - H)
        if origins.size == 0:
            raise ValueError(f"power log: too short to score {label} ahead in its second half")
        pred = PredictAhead(states, fit.order, period, time_step, fit.noise, H)
        table["model"][label] = _Errors(pred, z, origins, H)
        for name in BASELINES:
            table[name][label] = _Errors(BaselinePrediction(name, z, Pk, H), z, origins, H)
    return table


@dc.dataclass
class LogFit:
    """Everything :func:`FitPowerLog` found for one log."""

    fit: PowerModelFit
    """Model fitted on the first half."""
    scores: dict
    """:func:`ScorePredictions` on the second half."""
    times: np.ndarray
    """Uniform grid t [s]."""
    power: np.ndarray
    """z on that grid [W]."""
    period_source: str
    """Where T came from (given, a period log, or the estimate and its confidence)."""
    periods: np.ndarray | None = None
    """T_k [s] in force at each grid time (from a period log), or None: one T."""

    def Period(self):
        """T [s], or T_k [s] per grid sample: the ``period`` argument of the fit functions."""
        return self.fit.period if self.periods is None else self.periods


def FitPowerLog(
    times,
    power,
    period: float | None = None,
    orders=ORDERS,
    aperiodic: bool = True,
    min_confidence: float = 0.5,
    period_log=None,
) -> LogFit:
    """Fit on the first half of a power log and score on the second (module docstring).

    T is ``period`` [s] when given (the plan's period: ground truth for the motion part), else
    :func:`~eaplan_drake.energy.fourier.EstimatePeriodWithConfidence`; a log without a clear
    period raises ValueError saying so (give the period). ``period_log`` = (times [s], T [s])
    on the log's clock instead gives a time-varying period: T_k = :func:`PeriodInForce` at
    each sample, for the model and the baselines alike (the horizons: the last T in force).
    """
    from eaplan_drake.energy.fourier import EstimatePeriodWithConfidence

    t, z = UniformPowerSeries(times, power)
    dt = float(t[1] - t[0])
    if period_log is not None:
        if period is not None:
            raise ValueError("period: give either a period or a period log, not both")
        Ts = PeriodInForce(t, *period_log)
        nominal, varying = PeriodSeries(Ts, z.size)
        CheckLogLength(z.size, dt, nominal, "period log")
        half = z.size // 2
        period = Ts if varying is not None else nominal
        head = Ts[:half] if varying is not None else nominal
        fit = FitPowerModel(z[:half], dt, head, orders, aperiodic)
        source = f"period log ({np.min(Ts):.2f}–{np.max(Ts):.2f} s in force)"
        return LogFit(fit, ScorePredictions(z, dt, period, fit), t, z, source, varying)
    if period is None:
        estimate = EstimatePeriodWithConfidence(t, z, min_confidence=min_confidence)
        if estimate.period is None:
            raise ValueError(f"{estimate.message}; give the plan's period (--period SECONDS)")
        period, source = float(estimate.period), f"estimated: {estimate.message}"
    else:
        period = float(period)
        if not (math.isfinite(period) and period > 0.0):
            raise ValueError(f"--period: must be finite and > 0 [s], got {period!r}")
        source = "given"
    CheckLogLength(z.size, dt, period, source)
    half = z.size // 2
    fit = FitPowerModel(z[:half], dt, period, orders, aperiodic)
    return LogFit(fit, ScorePredictions(z, dt, period, fit), t, z, source)


def MinimumSamples(time_step: float, period: float) -> int:
    """The fewest samples of step Δt [s] that :func:`FitPowerLog` fits and scores with period
    T [s]: the first half (the training record) has one period in its first
    :data:`HELD_OUT_SPLIT`, and the second half has origins T ahead of a target (after the
    first period). About 2.9 periods."""
    P = max(1, int(round(period / time_step)))
    n = 2 * P + 1
    while int(HELD_OUT_SPLIT * (n // 2)) < P or n - P <= max(n // 2, P):
        n += 1
    return n


def CheckLogLength(samples: int, time_step: float, period: float, source: str = "given") -> None:
    """ValueError (one line) when a log of ``samples`` at Δt [s] is too short for the period T
    [s] (:func:`MinimumSamples`); ``source`` says where T came from (``given``, ``estimated``,
    ``period log``; what follows a colon or a parenthesis is left out)."""
    need = MinimumSamples(time_step, period)
    if samples < need:
        where = source.split(":")[0].split(" (")[0]
        raise ValueError(
            f"power log: {samples} samples at {time_step:.4g} s ({samples * time_step:.4g} s) "
            f"cover {samples * time_step / period:.2f} periods of T = {period:.4g} s ({where}); "
            f"fit needs {need} samples ({need * time_step / period:.2f} periods: it fits on the "
            "first half and scores up to T ahead on the second); record longer or check the "
            "period"
        )


def FormatScores(scores: dict) -> str:
    """The score table as text: RMSE / MAE [W] per predictor and horizon."""
    horizons = list(next(iter(scores.values())))
    lines = [f"{'predictor':16s}" + "".join(f"{h:>16s}" for h in horizons)]
    for name, row in scores.items():
        lines.append(
            f"{name:16s}" + "".join(f"{row[h][0]:8.3f} /{row[h][1]:6.3f}" for h in horizons)
        )
    return "\n".join(lines) + "\n(RMSE / MAE [W], origins in the second half, fit on the first)"


def PlotLogFit(result: LogFit):
    """Figure: RMSE per horizon of the model and the baselines; the scored half with the model's
    T/4-ahead prediction."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fit, scores = result.fit, result.scores
    fig, (a, b) = plt.subplots(2, 1, figsize=(9, 6.5))
    horizons = list(scores["model"])
    x = np.arange(len(horizons))
    width = 0.8 / len(scores)
    for i, (name, row) in enumerate(scores.items()):
        a.bar(x + (i - 1.5) * width, [row[h][0] for h in horizons], width, label=name)
    a.set_xticks(x, horizons)
    a.set_ylabel("RMSE [W]")
    name = fit.model_name or ModelName(fit.order, fit.noise)
    a.set_title(f"prediction error, model {name}, T = {fit.period:.1f} s")
    a.legend(fontsize=8)
    dt = fit.time_step
    period = result.Period()
    H = HorizonSteps(PeriodSeries(period, result.power.size)[0], dt)[1]
    states, _, _ = FilterPowerSeries(result.power, dt, fit.order, period, fit.noise)
    pred = PredictAhead(states, fit.order, period, dt, fit.noise, H)
    k = np.arange(result.power.size // 2, result.power.size - H)
    b.plot(result.times, result.power, color="0.6", lw=0.6, label="measured")
    b.plot(result.times[k + H], pred[k], color="tab:orange", lw=0.9, label="model, T/4 ahead")
    b.set_xlabel("t [s]")
    b.set_ylabel("power [W]")
    b.legend(fontsize=8)
    fig.tight_layout()
    return fig
