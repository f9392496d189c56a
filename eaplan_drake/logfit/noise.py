"""The noise of the energy model identified from a power series: the innovation likelihood and
its maximiser, the multi-step prediction error, and the levels whose q_0 is chosen for the
horizons. The model, the filter and the predictions are those of
:mod:`eaplan_drake.logfit.filtering`.

**Noise from data.** :func:`FitNoise` maximises the innovation (prediction-error) log-likelihood

    ℓ(θ) = −½ Σ_{k ≥ k_0} (log 2π s_k + e_k² / s_k),   e_k = z_k − C q̂⁻_k,  s_k = C P⁻_k Cᵀ + R,

over θ = (log R, log q_n, log q_0, log q_d, log τ) with a deterministic Nelder–Mead search,
where (q̂⁻, P⁻) come from :func:`~eaplan_drake.logfit.filtering.FilterPowerSeries`. The first
k_0 samples (one period, at most a fifth of the record) are the filter's start-up and are left
out. From then on the filter runs with the steady-state gain (the standard steady-state
approximation of the exact likelihood, and cheap); with a period that changes it starts at that
covariance and runs the exact time-varying recursion (s_k varies).

**Noise for the horizons.** The likelihood scores one-step predictions only; the planner uses
the model up to a period ahead. :func:`FitNoise` with ``criterion="horizons"`` minimises the
multi-step error instead: Σ_H log MSE_H over 1 step, T/4, T/2 and T (:func:`MultiStepError`
with ``relative=True``, so each horizon's relative error counts equally and the one-step error
is not traded away for the longer ones). The predictions depend on the noise ratios only, so
their common scale is then the likelihood's (:func:`LikelihoodScaledNoise`).
:func:`FitLevelNoise` chooses the q_0 of a level (the local level, or the r = 0 model's) by
the multi-step error.
"""

import dataclasses as dc
import math

import numpy as np

from eaplan_drake.logfit.filtering import (
    FilterPowerSeries,
    HorizonSteps,
    InitialState,
    NoiseParameters,
    PeriodSeries,
    PredictAhead,
    PredictionErrors,
)

__all__ = [
    "FitLevelNoise",
    "FitNoise",
    "InnovationLogLikelihood",
    "LEVEL_RATIOS",
    "LikelihoodScaledNoise",
    "MultiStepError",
    "NOISE_CRITERIA",
]


NOISE_CRITERIA = ("likelihood", "horizons")
"""How :func:`FitNoise` fits the noise: innovation likelihood, or multi-step error."""


LEVEL_RATIOS = tuple(10.0 ** (0.25 * i) for i in range(-32, 5))
"""Candidate q_0/R [-] of :func:`FitLevelNoise` (10⁻⁸ … 10, four per decade)."""


def _BurnIn(n: int, period_steps: int) -> int:
    """k_0: the filter's start-up samples left out of the scores (one period, at most a fifth of
    the n samples, at least one)."""
    return max(1, min(period_steps, n // 5))


def InnovationLogLikelihood(
    z, time_step: float, order: int, period, noise: NoiseParameters, initial_state=None
) -> float:
    """ℓ(θ) of the module docstring [-] (higher is better); ``period`` as in
    :func:`~eaplan_drake.logfit.filtering.FilterPowerSeries`."""
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

    θ = log10 of (R, q_n, q_0, q_d, τ) (q_d, τ only with ``aperiodic``; q_0 searched when ``level``
    is True, else fixed: 0 for False, the value for a number); τ in [Δt, 50 T]. Nelder–Mead from
    ``start`` (default: R from the lag-one differences, small q's, τ = 10 s). ``period``: T [s] or
    T_k per sample (:func:`~eaplan_drake.logfit.filtering.PeriodSeries`; the bound uses the nominal
    T).
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
            q0[aperiodic] = InitialState(z, dt, noise.Model(order), period)
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


def MultiStepError(
    z, time_step: float, order: int, period, noise, first_target: int, relative: bool = False
) -> float:
    """Σ over H ∈ {1 step, T/4, T/2, T} of the mean squared error MSE_H [W²] of ŷ_{k+H|k}
    (:func:`~eaplan_drake.logfit.filtering.PredictAhead` after
    :func:`~eaplan_drake.logfit.filtering.FilterPowerSeries` over z) for the targets k + H ≥
    ``first_target`` (every horizon has the same targets; each prediction uses z up to its origin k
    only). The held-out criterion of :func:`~eaplan_drake.logfit.fit.FitPowerModel` (targets after
    the fitting window) and the fitting criterion of :func:`FitLevelNoise`. ``relative``:
    Σ_H log MSE_H instead [-] (scale free: each horizon's relative error counts equally), the
    criterion of :func:`FitNoise` with ``criterion="horizons"``."""
    z = np.asarray(z, dtype=float).reshape(-1)
    states, _, _ = FilterPowerSeries(z, time_step, order, period, noise)
    total = 0.0
    for H in HorizonSteps(PeriodSeries(period, z.size)[0], time_step):
        origins = np.arange(max(int(first_target) - H, 0), z.size - H)
        if origins.size == 0:
            continue
        pred = PredictAhead(states, order, period, time_step, noise, H)
        mse = PredictionErrors(pred, z, origins, H)[0] ** 2
        total += math.log(max(mse, 1e-300)) if relative else mse
    return total


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
