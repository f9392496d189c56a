"""Anytime-valid bounds of an excess-failure rate from weighted worlds, and the chance that a claim
passes (power). Plain functions over numpy; arrays may carry leading axes (independent runs).

**What is bounded.** World i is drawn from a proposal q_i (the declared world distribution p, or
a tilted one chosen before world i is flown) and carries its exact likelihood ratio
W_i = p(x_i) / q_i(x_i) <= B_i, where B_i is known before the world is drawn
(:mod:`eaplan_drake.studies.sampling`). Its outcome is F_i (the lowest plan completes: the world
is *feasible*) and E_i (feasible, and the policy is lost: an *excess failure*). The rate certify
speaks of is the conditional one, ρ = P(E) / P(F) under p (k / n of plain counting). For any m::

    Z_i(m) = W_i (E_i − m F_i),      E_q[Z_i(m) | worlds before i] = P(E) − m P(F),

which is 0 at m = ρ whatever the proposals were. So the *capital*::

    K_t(m) = Π_(i<=t) (1 − λ_i Z_i(m)),   0 <= λ_i <= c / B_i,  c = 0.9,

with bets λ_i fixed before world i is flown (from worlds 1..i−1 only), is a non-negative
martingale at m = ρ, and by Ville's inequality P(K_t(ρ) >= 1/α for some t) <= α. Each factor is
positive and increasing in m, so {m : K_t(m) < 1/α} = [0, U_t) and **U_t is a one-sided upper
bound of ρ at level 1 − α that holds at every t at once** (a confidence sequence): it stays
valid when a run is stopped at a time chosen from the data (``--until-decided``), extended, or
killed. This is the betting construction of Waudby-Smith and Ramdas (JRSS-B 2024) applied to the
weighted differences; it assumes only that the worlds are independent draws, that the weights are
exact and that B_i bounds them. Losses may happen in any stratum: none is assumed safe.

The bets are the approximate Kelly fraction for the claim at ε, λ_i = −μ̂ / (σ̂² + μ̂²) clipped
to [0, c / B_i], with μ̂, σ̂² the running mean and variance of Z(ε) (one prior pseudo-world at
−ε/2 with variance ε). A lower bound (``side="lower"``) bets the other way; it only decides when
a run may stop because the claim can no longer pass.

Plain counting with a fixed number of worlds keeps the exact Clopper–Pearson bound
(:func:`~eaplan_drake.studies.statistics.ClopperPearsonUpper`), whose power is computed exactly
(:func:`PlainPower`); the betting bound pays for its validity under any stopping with more
worlds at W = 1 and wins when the weights are small on the worlds that are lost.
"""

import math

import numpy as np

__all__ = [
    "BetFractions",
    "Capital",
    "CertifyThreshold",
    "LowerBound",
    "PlainPower",
    "SequentialDecision",
    "SequentialPower",
    "UpperBound",
    "WorldsForPower",
]

MAX_BET = 0.9
"""c: the largest bet as a fraction of 1 / B_i (each factor stays >= 1 − c > 0)."""


def _Arrays(weights, excess, feasible, bounds):
    w = np.asarray(weights, dtype=float)
    e = np.asarray(excess, dtype=float)
    f = np.asarray(feasible, dtype=float)
    b = np.broadcast_to(np.asarray(bounds, dtype=float), w.shape)
    if not (w.shape == e.shape == f.shape) or w.shape[-1:] == (0,):
        raise ValueError("weights, excess, feasible: need equal non-empty shapes")
    if np.any(w < 0) or np.any(w > b * (1 + 1e-12)) or np.any(b <= 0):
        raise ValueError("weights: must be in [0, B] with B > 0 (the bound of each world)")
    if np.any(e > f):
        raise ValueError("excess: an excess failure needs a feasible world")
    return w, e, f, b


def BetFractions(weights, excess, feasible, bounds, eps: float, side: str = "upper"):
    """λ_i (predictable: from worlds before i) for the upper (``side="upper"``: betting that the
    rate is below ``eps``) or the lower bound, same shape as ``weights``."""
    w, e, f, b = _Arrays(weights, excess, feasible, bounds)
    z = w * (e - eps * f)
    n = np.arange(1, z.shape[-1] + 1)
    prior_mean, prior_var = -0.5 * eps, eps
    before = np.concatenate([np.zeros(z.shape[:-1] + (1,)), np.cumsum(z, axis=-1)[..., :-1]], -1)
    squares = np.cumsum(z * z, axis=-1)
    squares = np.concatenate([np.zeros(z.shape[:-1] + (1,)), squares[..., :-1]], -1)
    mean = (prior_mean + before) / n
    second = (prior_var + prior_mean**2 + squares) / n
    var = np.maximum(second - mean**2, 1e-12)
    sign = -1.0 if side == "upper" else 1.0
    kelly = sign * mean / (var + mean**2)
    return np.clip(kelly, 0.0, MAX_BET / b)


def Capital(weights, excess, feasible, bets, m, side: str = "upper"):
    """log K_t(m) for t = 1..n (the upper side: Π (1 − λ_i Z_i(m)); the lower: Π (1 + λ_i Z_i(m)));
    ``m`` broadcasts against the leading axes."""
    w = np.asarray(weights, dtype=float)
    z = w * (np.asarray(excess, float) - np.asarray(m, float)[..., None] * np.asarray(feasible))
    sign = -1.0 if side == "upper" else 1.0
    return np.cumsum(np.log1p(sign * np.asarray(bets) * z), axis=-1)


def _Bound(weights, excess, feasible, bounds, eps, confidence, side):
    w, e, f, b = _Arrays(weights, excess, feasible, bounds)
    lam = BetFractions(w, e, f, b, eps, side)
    level = -math.log1p(-confidence)
    lo = np.zeros(w.shape[:-1])
    hi = np.ones(w.shape[:-1])
    for _ in range(60):  # log K_n(m) increases with m on the upper side, decreases below
        m = 0.5 * (lo + hi)
        rejected = Capital(w, e, f, lam, m, side)[..., -1] >= level
        too_high = rejected if side == "upper" else ~rejected
        hi = np.where(too_high, m, hi)
        lo = np.where(too_high, lo, m)
    return hi if side == "upper" else lo


def UpperBound(weights, excess, feasible, bounds, eps: float, confidence: float = 0.95):
    """U_n: the anytime-valid upper confidence bound of ρ after all n worlds (1 when the capital
    never reaches 1 / α below m = 1), with bets tuned for a claim at ``eps``."""
    return _Bound(weights, excess, feasible, bounds, eps, confidence, "upper")


def LowerBound(weights, excess, feasible, bounds, eps: float, confidence: float = 0.95):
    """L_n: the anytime-valid lower confidence bound of ρ after all n worlds."""
    return _Bound(weights, excess, feasible, bounds, eps, confidence, "lower")


def SequentialDecision(weights, excess, feasible, bounds, eps: float, confidence: float = 0.95):
    """(certified, refuted) first world counts (1-based; 0 when never): the first t with
    U_t <= ``eps`` (the claim at ε holds at ``confidence``) and the first t with L_t > ``eps``
    (the claim can no longer pass)."""
    w, e, f, b = _Arrays(weights, excess, feasible, bounds)
    level = -math.log1p(-confidence)
    out = []
    for side in ("upper", "lower"):
        lam = BetFractions(w, e, f, b, eps, side)
        hit = Capital(w, e, f, lam, np.full(w.shape[:-1], eps), side) >= level
        out.append(np.where(hit.any(axis=-1), hit.argmax(axis=-1) + 1, 0))
    return out[0], out[1]


def SequentialPower(weights, excess, feasible, bounds, eps, worlds: int, *, runs=400, seed=0):
    """P(certified within N worlds) for N = 1..``worlds``, estimated by re-drawing ``runs`` runs
    from the measured worlds (bootstrap: the rate, weights and strata as measured so far) and
    running :func:`SequentialDecision` on each."""
    w, e, f, b = _Arrays(weights, excess, feasible, bounds)
    rng = np.random.default_rng(seed)
    pick = rng.integers(0, w.size, size=(runs, worlds))
    certified, _ = SequentialDecision(w[pick], e[pick], f[pick], b[pick], eps)
    hit = np.where(certified > 0, certified, worlds + 1)
    return np.array([np.mean(hit <= n) for n in range(1, worlds + 1)])


def _LogBinomialPmf(n: int, p: float) -> np.ndarray:
    """log P(Binomial(n, p) = k) for k = 0..n."""
    k = np.arange(n + 1)
    log_fact = np.concatenate(([0.0], np.cumsum(np.log(np.arange(1.0, n + 1.0)))))
    log_comb = log_fact[n] - log_fact - log_fact[::-1]
    if p <= 0.0:
        return np.where(k == 0, 0.0, -np.inf)
    if p >= 1.0:
        return np.where(k == n, 0.0, -np.inf)
    return log_comb + k * math.log(p) + (n - k) * math.log1p(-p)


def CertifyThreshold(feasible: int, eps: float, confidence: float = 0.95) -> int:
    """The most excess failures k that still certify at ``eps`` with ``feasible`` worlds
    (ClopperPearsonUpper(k, n) <= ε, i.e. P(Binomial(n, ε) <= k) <= 1 − confidence); −1 when
    none does."""
    if feasible <= 0:
        return -1
    cdf = np.cumsum(np.exp(_LogBinomialPmf(int(feasible), float(eps))))
    return int(np.count_nonzero(cdf <= 1.0 - confidence)) - 1


def PlainPower(rate, feasible_fraction, worlds: int, eps, confidence: float = 0.95) -> float:
    """P(plain counting certifies at ``eps`` with ``worlds`` worlds) when the excess-failure rate
    is ``rate`` and a world is feasible with probability ``feasible_fraction``: the binomial
    number of feasible worlds, then the binomial number of failures against
    :func:`CertifyThreshold` (exact)."""
    feasible = np.exp(_LogBinomialPmf(int(worlds), float(feasible_fraction)))
    power = 0.0
    for n in np.flatnonzero(feasible > 1e-15):
        k = CertifyThreshold(int(n), eps, confidence)
        if k >= 0:
            power += feasible[n] * float(np.sum(np.exp(_LogBinomialPmf(int(n), rate)[: k + 1])))
    return min(power, 1.0)


def WorldsForPower(power, target: float = 0.9, largest: int = 100_000) -> int | None:
    """Worlds N (1 to ``largest``) with ``power(N)`` >= ``target`` and ``power(N − 1)`` below
    it, found by a doubling search, then bisection; None beyond ``largest``. Counting's power
    saw-tooths in N (the number of failures allowed jumps), so a few more worlds can have a
    slightly smaller chance: N is where the chance reaches the target, not a guarantee."""
    n = 16
    while power(n) < target:
        if n >= largest:
            return None
        n = min(2 * n, largest)
    lo, hi = n // 2, n
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if power(mid) >= target else (mid, hi)
    return hi
