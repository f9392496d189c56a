"""Stratified and importance-sampled battery faults with exact likelihood ratios.

The declared fault process p (``FaultModelParams``): drops arrive as a Poisson process of rate
λ [1/s] over the flight's horizon T = ``simulation.time_limit`` [s], with i.i.d. sizes X of
density f. Only drops inside the flight can lose a mission, so a proposal changes the process on
a *window* [0, τ*] [s] that covers the flights (τ* <= T) and leaves it as declared after. On the
window the number of drops n is Poisson(λτ*) (stratum n, probability p_n = e^(−λτ*) (λτ*)^n / n!,
exact), their times uniform, their sizes f.

A :class:`FaultProposal` draws the window's drops from the *defensive mixture*
q = β·p + (1 − β)·p̃: with probability β (``mix``) as declared, otherwise n from a count table π
(``counts``) and sizes from the exponentially tilted f_θ(x) = e^(θx) f(x) / M(θ) (``size_tilt``
θ [1/SoC]; M(θ) = E[e^(θX)]; times uniform as declared). The likelihood ratio of a world whose
window holds n drops of raw sizes x_1..x_n is exact::

    R = (π_n / p_n) · Π_j e^(θ x_j) / M(θ),     W = p / q = 1 / (β + (1 − β) R) <= 1 / β,

so every weight is bounded by B = 1 / β (what the anytime bound needs,
:mod:`eaplan_drake.studies.bounds`). Two rules fill p̃:

- *stratified* (:func:`StratifiedProposal`): π_n ∝ p_n·a_n, sizes as declared, where a_n is the
  allocation: Neyman's √(r_n (1 − r_n)) from the strata's loss rates r_n measured on a pilot
  (with a floor, so that no stratum with faults is left out), or 1 on every stratum with a drop.
  Stratum 0 keeps its β·p_0 share: no stratum is assumed safe, and its worlds weigh 1 / β.
- *importance* (:func:`TiltedProposal`): π = Poisson(λ̃ τ*) and θ by one step of the
  cross-entropy method over a pilot (:func:`CrossEntropyTilt`): λ̃ and the tilted mean size are
  the weighted means of the drops in the pilot's *elite* worlds (its losses, or the worlds with
  the largest total drop in the window when losses are too few), never below the declared ones.
"""

import dataclasses as dc
import math

import numpy as np

from eaplan_drake.params import MAX_FAULTS, BatteryFault, FaultModelParams
from eaplan_drake.planning.risk import PoissonCutoff, PoissonPmf

__all__ = [
    "CountProbabilities",
    "CrossEntropyTilt",
    "DrawProposedFaults",
    "DrawWindows",
    "FaultProposal",
    "SizeLogRatio",
    "StratifiedProposal",
    "TiltedMeanSize",
    "TiltedProposal",
    "WorldWeights",
]


@dc.dataclass(frozen=True)
class FaultProposal:
    """How the drops in the window [0, ``window``] are drawn (see the module docstring)."""

    window: float
    """τ* [s], in (0, T]."""
    mix: float = 0.5
    """β: probability of the declared draw, in (0, 1]; every weight is at most 1 / β."""
    counts: tuple[float, ...] = ()
    """π_n for n = 0..len − 1 (sums to 1); empty: the declared Poisson counts."""
    size_tilt: float = 0.0
    """θ [1/SoC]: sizes of the tilted draw have density ∝ e^(θx) f(x)."""

    @property
    def weight_bound(self) -> float:
        """B = 1 / β."""
        return 1.0 / self.mix

    def Validate(self, model: FaultModelParams, horizon: float) -> "FaultProposal":
        if not (math.isfinite(self.window) and 0.0 < self.window <= horizon):
            raise ValueError(f"window: must be in (0, {horizon:g}] s, got {self.window!r}")
        if not 0.0 < self.mix <= 1.0:
            raise ValueError(f"mix: must be in (0, 1], got {self.mix!r}")
        pi = np.asarray(self.counts, dtype=float)
        if pi.size and (np.any(pi < 0) or abs(pi.sum() - 1.0) > 1e-9 or pi.size > MAX_FAULTS):
            raise ValueError(f"counts: need at most {MAX_FAULTS} probabilities summing to 1")
        if not math.isfinite(self.size_tilt) or abs(self.size_tilt) > 1e4:
            raise ValueError(f"size_tilt: must be finite, |θ| <= 1e4, got {self.size_tilt!r}")
        if model.sizes == "exponential" and self.size_tilt >= 1.0 / model.size_mean:
            raise ValueError("size_tilt: must be below 1 / size_mean for exponential sizes")
        return self


def CountProbabilities(model: FaultModelParams, window: float) -> np.ndarray:
    """p_n = P(n drops in [0, window]) for n = 0..n_max, the Poisson mass beyond n_max below
    1e-12."""
    mean = model.rate * window
    if mean <= 0.0:
        return np.array([1.0])
    return PoissonPmf(np.array(mean), PoissonCutoff(float(mean)))


def _LogMgf(model: FaultModelParams, theta: float) -> float:
    """log M(θ) = log E[e^(θX)] of the declared sizes (exponential: of the uncapped X)."""
    if theta == 0.0:
        return 0.0
    if model.sizes == "uniform":
        a, b = model.size_bounds
        s = theta * (b - a)
        return theta * a + math.log(math.expm1(s) / s) if s > -700 else theta * a - math.log(-s)
    if model.sizes == "exponential":
        return -math.log1p(-theta * model.size_mean)
    v = np.asarray(model.size_values, dtype=float)
    top = float(np.max(theta * v))
    return top + math.log(float(np.mean(np.exp(theta * v - top))))


def SizeLogRatio(model: FaultModelParams, theta: float, raw) -> np.ndarray:
    """log f_θ(x) / f(x) of raw drawn sizes (before the 1e-6 floor; an exponential size drawn
    above 1 is stored as 1, an atom whose ratio is e^θ)."""
    x = np.asarray(raw, dtype=float)
    if theta == 0.0:
        return np.zeros(x.shape)
    ratio = theta * x - _LogMgf(model, theta)
    if model.sizes == "exponential":
        ratio = np.where(x >= 1.0, theta, ratio)
    return ratio


def _DrawSizes(rng, model: FaultModelParams, theta, shape) -> np.ndarray:
    """Raw sizes of ``shape`` from f_θ (θ = 0: the declared f; ``theta`` broadcasts)."""
    u = rng.uniform(size=shape)
    theta = np.broadcast_to(np.asarray(theta, dtype=float), shape)
    tilted = theta != 0.0
    safe = np.where(tilted, theta, 1.0)
    if model.sizes == "uniform":
        a, b = model.size_bounds
        x = a + np.log1p(u * np.expm1(safe * (b - a))) / safe
        return np.where(tilted, x, a + (b - a) * u)
    if model.sizes == "exponential":
        mean = model.size_mean / (1.0 - theta * model.size_mean)
        return np.minimum(-mean * np.log1p(-u), 1.0)
    v = np.asarray(model.size_values, dtype=float)
    p = np.exp(theta[..., None] * v - np.max(theta[..., None] * v, axis=-1, keepdims=True))
    cdf = np.cumsum(p, axis=-1) / p.sum(axis=-1, keepdims=True)
    return v[np.minimum(np.sum(cdf <= u[..., None], axis=-1), v.size - 1)]


def WorldWeights(model: FaultModelParams, proposal: FaultProposal, counts, log_size_ratio):
    """W = p / q (exact) of worlds whose windows hold ``counts`` drops with
    Σ_j log f_θ(x_j) / f(x_j) = ``log_size_ratio`` (:func:`SizeLogRatio` summed per world)."""
    n = np.asarray(counts, dtype=int)
    if not proposal.counts and proposal.size_tilt == 0.0:
        return np.ones(n.shape)
    mean = model.rate * proposal.window
    pi = np.asarray(proposal.counts or CountProbabilities(model, proposal.window), dtype=float)
    inside = n < pi.size
    pi_n = np.where(inside, pi[np.minimum(n, pi.size - 1)], 0.0)
    log_fact = np.array([math.lgamma(k + 1.0) for k in range(int(n.max(initial=0)) + 1)])
    log_p = n * math.log(mean) - mean - log_fact[n] if mean > 0.0 else np.zeros(n.shape)
    with np.errstate(divide="ignore"):
        log_r = np.log(pi_n) - log_p + np.asarray(log_size_ratio, dtype=float)
    r = np.exp(np.minimum(log_r, 700.0))
    return 1.0 / (proposal.mix + (1.0 - proposal.mix) * r)


def DrawWindows(rng: np.random.Generator, model, proposal: FaultProposal, worlds: int):
    """(counts, raw sizes, W) of ``worlds`` windows drawn from ``proposal``: sizes has shape
    (worlds, largest count), NaN beyond each world's count."""
    declared = rng.uniform(size=worlds) < proposal.mix
    declared |= not proposal.counts and proposal.size_tilt == 0.0
    n = rng.poisson(model.rate * proposal.window, size=worlds)
    if proposal.counts:
        pi = np.asarray(proposal.counts, dtype=float)
        n = np.where(declared, n, rng.choice(pi.size, p=pi / pi.sum(), size=worlds))
    n = np.minimum(n, MAX_FAULTS)
    theta = np.where(declared, 0.0, proposal.size_tilt)
    sizes = _DrawSizes(rng, model, theta[:, None], (worlds, int(n.max(initial=0))))
    sizes[np.arange(sizes.shape[1]) >= n[:, None]] = np.nan
    ratio = np.nansum(SizeLogRatio(model, proposal.size_tilt, sizes), axis=1)
    return n, sizes, WorldWeights(model, proposal, n, ratio)


def DrawProposedFaults(
    rng: np.random.Generator, model: FaultModelParams, horizon: float, proposal: FaultProposal
) -> tuple[list, float, int]:
    """(faults, W, stratum): the drops of one world over [0, ``horizon``] [s] drawn from
    ``proposal`` in its window and as declared after it, their exact weight W and the number of
    drops in the window (the stratum). At most ``MAX_FAULTS`` drops are kept (the earliest)."""
    window = proposal.window
    counts, raw, weights = DrawWindows(rng, model, proposal, 1)
    n = int(counts[0])
    times = np.sort(rng.uniform(0.0, window, size=n))
    later = min(int(rng.poisson(model.rate * (horizon - window))), MAX_FAULTS - n)
    times = np.concatenate((times, np.sort(rng.uniform(window, horizon, size=later))))
    sizes = np.concatenate((raw[0, :n], _DrawSizes(rng, model, 0.0, later)))
    faults = [
        BatteryFault(time=float(t), soc_drop=float(max(x, 1e-6)))
        for t, x in zip(times, sizes, strict=True)
    ]
    return faults, float(weights[0]), n


def StratifiedProposal(
    model: FaultModelParams, window: float, *, mix: float = 0.5, allocation=None, floor=0.2
) -> FaultProposal:
    """π_n ∝ p_n a_n: ``allocation`` a_n per stratum n (e.g. √(r_n (1 − r_n)) of a pilot), each
    stratum with a drop given at least ``floor`` × the largest a_n; default a_n = 1 for n >= 1,
    0 for n = 0 (the declared share β·p_0 still draws stratum 0)."""
    p = CountProbabilities(model, window)
    a = np.ones(p.size)
    if allocation is not None:
        given = np.asarray(allocation, dtype=float)[: p.size]
        a[: given.size] = given
        a[given.size :] = given.max() if given.size else 1.0
    a = np.maximum(a, floor * max(float(a[1:].max(initial=0.0)), 1e-12))
    a[0] = 0.0 if allocation is None else a[0]
    pi = p * a
    if pi.sum() <= 0.0:
        return FaultProposal(window=window, mix=1.0)
    return FaultProposal(window=window, mix=mix, counts=tuple(float(x) for x in pi / pi.sum()))


def TiltedProposal(
    model: FaultModelParams, window: float, rate: float, size_tilt: float, *, mix: float = 0.5
) -> FaultProposal:
    """π = Poisson(``rate`` · window) (to 1e-12, renormalised), sizes tilted by ``size_tilt``."""
    pi = CountProbabilities(dc.replace(model, rate=rate), window)[:MAX_FAULTS]
    counts = tuple(float(x) for x in pi / pi.sum())
    return FaultProposal(window=window, mix=mix, counts=counts, size_tilt=float(size_tilt))


def TiltedMeanSize(model: FaultModelParams, theta: float) -> float:
    """E_θ[X] of the tilted sizes [-] (exponential: of the uncapped X)."""
    if model.sizes == "exponential":
        return model.size_mean / (1.0 - theta * model.size_mean)
    if model.sizes == "uniform":
        a, b = model.size_bounds
        s = theta * (b - a)
        if abs(s) < 1e-6:
            return 0.5 * (a + b) + (b - a) * s / 12.0
        return a + (b - a) * (1.0 / -math.expm1(-s) - 1.0 / s)
    v = np.asarray(model.size_values, dtype=float)
    p = np.exp(theta * v - np.max(theta * v))
    return float(np.sum(p * v) / p.sum())


def CrossEntropyTilt(
    model: FaultModelParams, window: float, counts, mean_sizes, weights, elite
) -> tuple[float, float]:
    """(λ̃ [1/s], θ [1/SoC]): one cross-entropy step from pilot worlds (their window counts,
    mean raw drop sizes, weights W and a boolean ``elite`` mask): λ̃ τ* is the W-weighted mean
    count of the elite worlds and θ gives the tilted sizes their W-weighted mean size (per drop).
    λ̃ is kept in [λ, 5λ] and θ >= 0, so that a tilt never draws fewer or smaller drops than
    declared, nor absurdly many; with no elite world, the declared (λ, 0)."""
    n = np.asarray(counts, dtype=float)
    s = np.asarray(mean_sizes, dtype=float)
    w = np.asarray(weights, dtype=float) * np.asarray(elite, dtype=bool)
    if w.sum() <= 0.0:
        return model.rate, 0.0
    rate = float(np.sum(w * n) / w.sum()) / window
    rate = min(max(rate, model.rate), 5.0 * model.rate)
    if np.sum(w * n) <= 0.0:
        return rate, 0.0
    target = float(np.sum(w * n * np.nan_to_num(s)) / np.sum(w * n))
    if model.sizes == "exponential":
        lo, hi = 0.0, 0.5 / model.size_mean
    else:
        values = model.size_bounds if model.sizes == "uniform" else model.size_values
        lo, hi = 0.0, 20.0 / max(max(values) - min(values), 1e-9)
    target = min(max(target, TiltedMeanSize(model, lo)), TiltedMeanSize(model, hi))
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if TiltedMeanSize(model, mid) < target else (lo, mid)
    return rate, 0.5 * (lo + hi)
