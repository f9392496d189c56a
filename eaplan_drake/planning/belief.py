"""A belief over the fault model that learns from the flight: a Gamma posterior over the drop rate,
a conjugate posterior over exponential drop sizes, and the tail of the total drop and the excess
risk of a plan under the posterior predictive.

Plain functions over numpy, deterministic. Units: time [s], rates [1/s], SoC fractions [-].
The fault model with a known rate and sizes is :mod:`eaplan_drake.planning.risk`'s; here the rate
λ [1/s] (and the scale of exponential sizes) is uncertain and is averaged over its posterior.

**The rate.** Given λ, drops arrive as a Poisson process. The belief is a Gamma distribution::

    λ ~ Gamma(α, β),   p(λ) = β^α λ^(α−1) e^(−βλ) / Γ(α),   E λ = α/β,   Var λ = α/β²,

shape α [-] (the drops the belief is worth) and rate β [s] (the flight time it is worth).
A stretch of τ seconds flown with n drops has likelihood ∝ λ^n e^(−λτ), so the update is
conjugate (:meth:`RateBelief.Update`)::

    Gamma(α, β)  →  Gamma(α + n, β + τ),

and every quiet minute (n = 0) counts: it adds 60 s to β and lowers the mean. The order of the
stretches does not matter, so a flight's belief depends only on its drops and its time flown.

**The prior from a fleet's records** (:meth:`RateBelief.FromRecords`): k drops seen in T seconds
of flight update the weak prior Gamma(α_0, α_0/λ_d) to Gamma(α_0 + k, α_0/λ_d + T), with
λ_d = 0.003/s (the planner's default point rate) and α_0 = 1/2 (``prior_drops``). A fleet with no
records gets the weak prior itself. Why: α_0 = 1/2 is the shape of Jeffreys' prior for a Poisson
rate (whose posterior Gamma(k + 1/2, T) has intervals close to the exact Garwood ones), and the
weight β_0 = α_0/λ_d = 167 s is the least that keeps the belief proper with no records while its
mean stays today's default. Records of an hour outweigh it: 3 drops in 10 h give Gamma(3.5, 36167 s)
against Jeffreys' Gamma(3.5, 36000 s), and 167 s of quiet flight already halve the prior's mean.
A point rate λ is the limit α → ∞ with α/β = λ (:meth:`RateBelief.PointMass`).

**The predictive count.** Averaged over the belief, the drops N(τ) in an exposure τ [s] are
negative binomial (:func:`NegativeBinomialPmf`)::

    P(N = n) = ∫ Pois(n; λτ) p(λ) dλ = Γ(α + n) / (Γ(α) n!) · p^α (1 − p)^n,   p = β/(β + τ),

mean ατ/β, variance ατ/β · (1 + τ/β): more spread than the Poisson of the same mean by the
factor 1 + τ/β. It is computed in log space with the odds θ = (1 − p)/p = τ/β:
log P(n) = Σ_(j<n) log(α + j) − log n! − α log1p(θ) + n (log θ − log1p(θ)), which keeps its
digits up to α = 1e11 (the Poisson limit: tested against the Poisson pmf to 1e-7 there).
:func:`NegativeBinomialCutoff` stops the sums where the mass beyond is below 1e-12: the ratio
of successive terms r_j = (α + j)/(j + 1) · (1 − p) tends to 1 − p monotonically, so wherever
ρ = max(r_(n+1), 1 − p) < 1 the mass beyond n is at most P(n + 1)/(1 − ρ).

**The sizes** (:func:`UpdateSizes`). An :class:`~eaplan_drake.planning.risk.EmpiricalDrops` list
grows by each observed size (rounded to 0.001, so that the n-fold sums keep a bounded support).
Exponential sizes with an uncertain rate ϑ = 1/μ [1/SoC] have the conjugate belief
ϑ ~ Gamma(a, b) (:class:`ExponentialSizeBelief`): sizes x_1..x_k update it to
Gamma(a + k, b + Σ x_i), and a single size is Lomax, P(X > x) = (b/(b + x))^a. The sizes of one
world share ϑ, so the tail of their sum is the Gamma mixture of the Erlang tails, a negative
binomial CDF of positive terms::

    Q̄_n(m) = E_ϑ P(Poisson(ϑm) ≤ n − 1) = P(NB(a, b/(b + m)) ≤ n − 1).

The records' prior is Gamma(k, Σ x_i) (the posterior of the scale-invariant 1/ϑ), and with no
records k_0 pseudo-sizes at the mean μ_0: Gamma(k_0, k_0 μ_0). Uniform and exponential sizes of a
known scale (:class:`~eaplan_drake.planning.risk.UniformDrops`,
:class:`~eaplan_drake.planning.risk.ExponentialDrops`) do not learn: a uniform's bounds have no
conjugate update that stays uniform, and a size outside them leaves the belief unchanged (a user
who expects the world to be harsher than the bounds uses a list or an exponential belief).
:func:`LearningSizes` turns them into models that learn, worth K = 6 sizes by default: U[a, b]
into the K values a + (b − a) j/K (each the top of a K-th of the range, so never lighter than the
uniform), Exp(μ) into Gamma(K, K μ). A list of K prior values grown by n observed ones is the
predictive of a Dirichlet process of concentration K around the prior; its sizes are then taken
as independent draws of that predictive (the process's draws within one world are exchangeable,
not independent: a plug-in, exact as n grows).

**The total drop** (:func:`BeliefDropTail`). The rate and the sizes' scale are independent a
posteriori (the likelihood factors into the counts' and the sizes'), so with the size-sum tails
Q̄_n of the predictive sizes (the point models' Q_n, or the mixture above)::

    P(S(τ) > m) = E_λ Σ_n Pois(n; λτ) Q̄_n(m) = Σ_n NB(n; α, β/(β + τ)) Q̄_n(m).

Q̄_n(m) rises with n (sizes are positive), so once a level is within 1e-13 of 1 at every margin
the later ones are taken equal to it (from below, by at most 1e-13): the uniform's Irwin–Hall
tails are not needed beyond a few dozen drops however heavy the counts' tail is.

**The excess risk** (:func:`BeliefExcessRisk`). Under the belief a world first draws λ, then
flies as :mod:`eaplan_drake.planning.risk` assumes (A1–A4: fallback to the lowest plan at the
first drop), so R(p) = P(F_p and not F_0) is the mixture of the Poisson excess risk::

    R_B(p) = E_λ R(p | λ) = E_λ P(F_p | λ) − E_λ P(F_0 | λ)     (τ_0 <= τ_p, m_p <= m_0)

(F_0 ⊂ F_p holds world by world, so the difference survives the mixture). The mixture has an
exact form, without a quadrature over λ: in P(F_p | λ) the first drop at u = T_1/τ_p and the
later counts enter as λτ_p e^(−λτ_p u) · Pois(n; λτ_0 (1 − u)), and with
E[λ^(n+1) e^(−λc)] = Γ(α + n + 1) β^α / (Γ(α) (β + c)^(α+n+1)), c = τ_p u + τ_0 (1 − u),::

    E_λ[λτ_p e^(−λτ_p u) Pois(n; λτ_0 (1 − u))] = f_1(u) · NB(n; α + 1, (β + τ_p u)/(β + c)),
    f_1(u) = α (τ_p/β) (1 + τ_p u/β)^(−α−1),

    P_B(F_p) = (β/(β + τ_p))^α [m_p < 0] + ∫_0^1 f_1(u) Σ_n NB(n; α + 1, ·) Q̄_(n+1)(M(u)) du,
    P_B(F_0) = P(S(τ_0) > m_0) under the belief,

f_1 the predictive density of the first drop (its survival is Lomax, (β/(β + τ_p u))^α), and the
later counts the predictive of the belief updated by that drop, Gamma(α + 1, β + τ_p u): the
fallback learns from the first drop. The u-integral is bracketed as in
:mod:`eaplan_drake.planning.risk`: Q̄_(n+1)(M(u)) is monotone on cells of u (``cells`` equal steps
in u and in the first drop's predictive probability), the positive weights are integrated by
8-point Gauss–Legendre, and the lower and upper sums are at most
P_B(T_1 <= τ_p)/cells · Σ_n (Q̄_(n+1)(m_p) − Q̄_(n+1)(m_0)) apart; :func:`BeliefExcessRisk`
returns the upper one. There is no quadrature over λ, so no error from it: the only errors are
the bracket (returned) and the truncations (1e-12 of the counts, 1e-13 of the saturated sizes).
For a point belief (α → ∞, α/β = λ) the weights tend to the Poisson ones and R_B to
:func:`~eaplan_drake.planning.risk.ExcessRisk` (tested at α = 1e8 to 1e-6, and against the
Gauss–Laguerre mixture of :func:`~eaplan_drake.planning.risk.ExcessRisk` over λ). The lowest plan's
excess is exactly 0 (returned as such), so a constraint R_B <= ε keeps the fallback admissible
after every update, and out of the order τ_0 <= τ_p, m_p <= m_0 the bound
min(P_B(F_p), 1 − P_B(F_0)) is returned, as there.

**Cost.** Measured once (median of 15 runs, 2 shared cores, numpy 2.4): 64 candidate plans,
τ_p from 300 to 700 s and m_p from 0.12 to 0, against τ_0 = 300 s, m_0 = 0.12, ``cells`` = 64;
the ratio is to :func:`~eaplan_drake.planning.risk.ExcessRisk` of the point rate λ = α/β with the
same sizes (the known-scale exponential of mean 0.05 for the size belief) in the same run:

=====================================  ======================  ===========  ================
belief                                 sizes                   ExcessRisk   BeliefExcessRisk
=====================================  ======================  ===========  ================
no records, Gamma(0.5, 167 s)          U[0, 0.15]              76 ms        133 ms (1.75×)
3 drops in 10 h, Gamma(3.5, 36167 s)   U[0, 0.15]              27 ms        28 ms (1.0×)
point, Gamma(1e8, 1e8/0.003 s)         U[0, 0.15]              72 ms        72 ms (1.0×)
no records                             Exp(mean 0.05)          14 ms        80 ms (5.8×)
no records                             ϑ ~ Gamma(2, 0.1)       14 ms        87 ms (6.3×)
=====================================  ======================  ===========  ================

The cost is the sizes' tails at (n_max + 1) counts for every cell edge and the weights at
n_max counts for every node: a wide belief (small α) has a long count tail (n_max = 66 for
Gamma(0.5, 167 s) over 300 s, against 14 for the point rate), which the uniform's saturation
absorbs and the exponential's does not. One :func:`BeliefDropTail` costs 0.1–0.15 ms against
0.02–0.04 ms for :func:`~eaplan_drake.planning.risk.TotalDropTail` (whose one-pair form is
specialised). On the shared machine the ratios moved between runs (the point belief's from 1.0
to 1.6, the exponential sizes' from 3.6 to 5.8): read them as factors, not digits.
"""

import dataclasses as dc
import functools
import math

import numpy as np

from eaplan_drake.errors import CheckCount, CheckNumber, CheckProbability
from eaplan_drake.params import MAX_EXPECTED_DROPS, FaultModelParams
from eaplan_drake.planning.risk import (
    POISSON_TAIL,
    EmpiricalDrops,
    ExponentialDrops,
    FaultModel,
    UniformDrops,
)

__all__ = [
    "MAX_CUTOFF",
    "PRIOR_DROPS",
    "PRIOR_RATE",
    "QUADRATURE_NODES",
    "SATURATED",
    "SIZE_RESOLUTION",
    "BeliefDropTail",
    "BeliefExcessRisk",
    "BeliefExcessRiskBounds",
    "ExponentialSizeBelief",
    "FaultBelief",
    "LearningSizes",
    "NegativeBinomialCutoff",
    "NegativeBinomialPmf",
    "RateBelief",
    "SaturatedSumTail",
    "UpdateSizes",
]

PRIOR_RATE = FaultModelParams().rate
"""λ_d [1/s]: the mean of the weak prior a fleet with no records gets (the default point rate)."""

PRIOR_DROPS = 0.5
"""α_0 [-]: the drops the weak prior is worth (Jeffreys' 1/2)."""

QUADRATURE_NODES = 8
"""Nodes of :meth:`RateBelief.Quadrature` the mpc's risk reserve prices a rate belief with."""

SIZE_RESOLUTION = 1e-3
"""Observed sizes [-] are rounded to this before an empirical list grows by them."""

SATURATED = 1e-13
"""A size-sum tail this close to 1 is taken for every later count (module docstring); above the
rounding of the Irwin–Hall tails (a few 1e-16 per level)."""

MAX_CUTOFF = 1_000_000
"""Largest count :func:`NegativeBinomialCutoff` scans to."""

_GAUSS_NODES, _GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(8)


def _LogGammaFront(a: float, x: float) -> float:
    """log(x^a e^(−x) / Γ(a)); for a >= 30 with x = a (1 + d) and Stirling's series for log Γ(a),
    a (log1p(d) − d) + ½ log(a/2π) − 1/(12a) + 1/(360a³) − 1/(1260a⁵) + 1/(1680a⁷), which keeps
    its digits where a log x and log Γ(a) are both ~1e9 (a = 1e8)."""
    if a < 30.0:
        return -x + a * math.log(x) - math.lgamma(a)
    d = x / a - 1.0
    stirling = 1 / (12 * a) - 1 / (360 * a**3) + 1 / (1260 * a**5) - 1 / (1680 * a**7)
    return a * (math.log1p(d) - d) + 0.5 * math.log(a / (2.0 * math.pi)) - stirling


def _GammaCdf(a: float, x: float) -> float:
    """The regularized lower incomplete gamma P(a, x) (series below a + 1, Lentz's continued
    fraction for the complement above), to about 1e-15."""
    if x <= 0.0:
        return 0.0
    log_front = _LogGammaFront(a, x)
    if x < a + 1.0:
        term = total = 1.0 / a
        ap = a
        for _ in range(int(1000 + 50.0 * math.sqrt(a))):
            ap += 1.0
            term *= x / ap
            total += term
            if term < total * 1e-17:
                break
        return min(1.0, total * math.exp(log_front))
    tiny = 1e-300
    b = x + 1.0 - a
    c, d = 1.0 / tiny, 1.0 / b
    h = d
    for i in range(1, int(1000 + 50.0 * math.sqrt(a))):
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        d = tiny if abs(d) < tiny else d
        c = b + an / c
        c = tiny if abs(c) < tiny else c
        d = 1.0 / d
        h *= d * c
        if abs(d * c - 1.0) < 1e-16:
            break
    return max(0.0, 1.0 - math.exp(log_front) * h)


@dc.dataclass(frozen=True)
class RateBelief:
    """The belief λ ~ Gamma(``shape`` α [-], ``rate`` β [s]) over the drop rate λ [1/s]."""

    shape: float
    rate: float

    def __post_init__(self):
        shape = CheckNumber("RateBelief.shape", self.shape, 0.0, 1e12, "[-]", open_low=True)
        rate = CheckNumber("RateBelief.rate", self.rate, 0.0, 1e15, "[s]", open_low=True)
        object.__setattr__(self, "shape", shape)
        object.__setattr__(self, "rate", rate)

    @classmethod
    def FromRecords(
        cls,
        drops: int = 0,
        flight_time: float = 0.0,
        *,
        prior_rate: float = PRIOR_RATE,
        prior_drops: float = PRIOR_DROPS,
    ) -> "RateBelief":
        """The posterior of the weak prior Gamma(α_0, α_0/λ_d) (``prior_drops`` α_0, ``prior_rate``
        λ_d [1/s]) after a fleet's records: ``drops`` k seen in ``flight_time`` T [s]."""
        prior_rate = CheckNumber("prior_rate", prior_rate, 0.0, 0.1, "[1/s]", open_low=True)
        prior_drops = CheckNumber("prior_drops", prior_drops, 0.0, 1e6, "[-]", open_low=True)
        return cls(prior_drops, prior_drops / prior_rate).Update(flight_time, drops)

    @classmethod
    def PointMass(cls, rate: float, shape: float = 1e8) -> "RateBelief":
        """A belief so narrow it is the point rate λ [1/s] (α = ``shape``, β = α/λ)."""
        rate = CheckNumber("rate", rate, 0.0, 0.1, "[1/s]", open_low=True)
        return cls(shape, shape / rate)

    def Update(self, flight_time: float, drops: int = 0) -> "RateBelief":
        """The conjugate update by ``flight_time`` τ [s] flown with ``drops`` n:
        Gamma(α + n, β + τ)."""
        tau = CheckNumber("flight_time", flight_time, 0.0, 1e12, "[s]")
        n = CheckCount("drops", drops, 0, 1e9)
        return RateBelief(self.shape + n, self.rate + tau)

    @property
    def mean(self) -> float:
        """E λ = α/β [1/s]."""
        return self.shape / self.rate

    @property
    def variance(self) -> float:
        """Var λ = α/β² [1/s²]."""
        return self.shape / self.rate**2

    def Cdf(self, rate) -> float:
        """P(λ <= ``rate``) [-] for a rate [1/s]."""
        return _GammaCdf(self.shape, self.rate * max(float(rate), 0.0))

    def Quantile(self, probability: float) -> float:
        """The rate λ_q [1/s] with P(λ <= λ_q) = ``probability`` q in (0, 1), by bisection to a
        relative 1e-13."""
        q = CheckProbability("probability", probability)
        hi = self.mean + 10.0 * math.sqrt(self.variance)
        while self.Cdf(hi) < q:
            hi *= 2.0
        lo = 0.0
        while hi - lo > 1e-13 * hi:
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if self.Cdf(mid) < q else (lo, mid)
        return hi

    def Quadrature(self, nodes: int = QUADRATURE_NODES) -> tuple[np.ndarray, np.ndarray]:
        """Rates λ_i [1/s] and weights w_i [-] with E g(λ) ≈ Σ_i w_i g(λ_i): Gauss's rule for the
        weight λ^(α−1) e^(−βλ) (generalised Gauss–Laguerre, from the eigenvalues of its Jacobi
        matrix, diagonal 2k + α, off-diagonal √(k (k + α − 1)), divided by β), exact for
        polynomials in λ of degree 2·``nodes`` − 1; the weights sum to 1."""
        x, weights = _GaussLaguerre(self.shape, CheckCount("nodes", nodes, 1, 64))
        return x / self.rate, weights.copy()

    def CountPmf(self, exposure, n_max: int) -> np.ndarray:
        """The predictive P(N(τ) = n), n = 0..n_max, over ``exposure`` τ [s] (broadcasts):
        NB(α, β/(β + τ)), shape τ.shape + (n_max + 1,)."""
        return NegativeBinomialPmf(self.shape, np.asarray(exposure, dtype=float) / self.rate, n_max)


@functools.lru_cache(maxsize=64)
def _GaussLaguerre(shape: float, nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes x_i and normalised weights of Gauss's rule for the weight x^(α−1) e^(−x) (α =
    ``shape``): the eigenvalues of the Jacobi matrix and the squared first components of its
    eigenvectors. A pure function of α (kept: a flight's belief changes its rate β at every step,
    its shape only at a drop); the arrays are read-only."""
    k = np.arange(nodes)
    a = shape - 1.0
    jacobi = np.diag(2.0 * k + a + 1.0)
    off = np.sqrt(k[1:] * (k[1:] + a))
    jacobi += np.diag(off, 1) + np.diag(off, -1)
    x, vectors = np.linalg.eigh(jacobi)
    weights = vectors[0] ** 2
    weights = weights / weights.sum()
    x.flags.writeable = weights.flags.writeable = False
    return x, weights


def _CheckArray(name: str, value, *, nonnegative: bool, what: str) -> np.ndarray:
    x = np.asarray(value, dtype=float)
    bad = ~np.isfinite(x) | ((x < 0.0) if nonnegative else False)
    if np.any(bad):
        rule = "finite and >= 0" if nonnegative else "finite"
        raise ValueError(f"{name}: must be {rule} {what}, got {x[bad].ravel()[0]}")
    return x


def NegativeBinomialPmf(shape: float, odds, n_max: int) -> np.ndarray:
    """Γ(α + n)/(Γ(α) n!) p^α (1 − p)^n for n = 0..n_max, ``shape`` α > 0 and ``odds``
    θ = (1 − p)/p >= 0 (broadcast; τ/β for the predictive count), shape θ.shape + (n_max + 1,),
    in log space (module docstring)."""
    shape = CheckNumber("shape", shape, 0.0, 1e12, "[-]", open_low=True)
    n_max = CheckCount("n_max", n_max, 0, MAX_CUTOFF)
    theta = _CheckArray("odds", odds, nonnegative=True, what="[-]")
    return _NegativeBinomialPmf(shape, theta, n_max)


def _NegativeBinomialPmf(shape: float, theta: np.ndarray, n_max: int) -> np.ndarray:
    """:func:`NegativeBinomialPmf` of checked arguments."""
    theta = theta[..., None]
    k = np.arange(n_max + 1)
    rising = np.concatenate([[0.0], np.cumsum(np.log(shape + np.arange(n_max)))])
    log_fact = np.concatenate([[0.0], np.cumsum(np.log(np.arange(1, n_max + 1)))])
    positive = theta > 0.0
    safe = np.where(positive, theta, 1.0)
    log_odds = np.log(safe) - np.log1p(safe)
    pmf = np.exp(rising - log_fact - shape * np.log1p(safe) + k * log_odds)
    return np.where(positive, pmf, (k == 0).astype(float))


def NegativeBinomialCutoff(shape: float, odds: float) -> int:
    """The smallest n_max whose bound P(n_max + 1)/(1 − ρ) (module docstring) on the mass beyond is
    below 1e-12 for NB(``shape`` α, odds θ): sums to n_max are exact to 1e-12, from below.
    ValueError if that is beyond :data:`MAX_CUTOFF` counts."""
    shape = CheckNumber("shape", shape, 0.0, 1e12, "[-]", open_low=True)
    theta = CheckNumber("odds", odds, 0.0, 1e12, "[-]")
    return _Cutoff(shape, theta) if theta > 0.0 else 0


@functools.lru_cache(maxsize=1024)
def _Cutoff(shape: float, theta: float) -> int:
    """:func:`NegativeBinomialCutoff` for θ > 0 (kept per (α, θ): a flight asks the same ones)."""
    q = theta / (1.0 + theta)
    mean = shape * theta
    stop = int(min(mean + 40.0 * math.sqrt(mean * (1.0 + theta)) + 100.0, MAX_CUTOFF))
    while True:
        log_pmf = np.log(np.maximum(_NegativeBinomialPmf(shape, np.array(theta), stop), 1e-320))
        n = np.arange(stop)
        ratio = np.maximum((shape + n + 1.0) / (n + 2.0) * q, q)
        with np.errstate(divide="ignore"):
            log_bound = log_pmf[1:] - np.log1p(-np.minimum(ratio, 1.0))
        found = np.flatnonzero((ratio < 1.0) & (log_bound < math.log(POISSON_TAIL)))
        if found.size:
            return int(found[0])
        if stop >= MAX_CUTOFF:
            raise ValueError(
                f"odds: the counts' tail is too heavy to sum (shape {shape:g}, odds {theta:g})"
            )
        stop = min(2 * stop, MAX_CUTOFF)


@dc.dataclass(frozen=True)
class ExponentialSizeBelief:
    """Exponential drop sizes [-] whose rate ϑ = 1/μ [1/SoC] is uncertain: ϑ ~ Gamma(``shape`` a,
    ``scale`` b [-]); a single size is Lomax, P(X > x) = (b/(b + x))^a."""

    shape: float
    scale: float

    def __post_init__(self):
        shape = CheckNumber(
            "ExponentialSizeBelief.shape", self.shape, 0.0, 1e9, "[-]", open_low=True
        )
        scale = CheckNumber(
            "ExponentialSizeBelief.scale", self.scale, 0.0, 1e9, "(SoC fraction)", open_low=True
        )
        object.__setattr__(self, "shape", shape)
        object.__setattr__(self, "scale", scale)

    @classmethod
    def FromMean(cls, mean: float, prior_sizes: float = 2.0) -> "ExponentialSizeBelief":
        """``prior_sizes`` k_0 pseudo-sizes of mean ``mean`` μ_0 [-]: Gamma(k_0, k_0 μ_0)."""
        mean = CheckNumber("mean", mean, 0.0, 1.0, "(SoC fraction)", open_low=True, open_high=True)
        prior_sizes = CheckNumber("prior_sizes", prior_sizes, 0.0, 1e9, "[-]", open_low=True)
        return cls(prior_sizes, prior_sizes * mean)

    def Update(self, sizes) -> "ExponentialSizeBelief":
        """The conjugate update by observed sizes x_i [-]: Gamma(a + k, b + Σ x_i)."""
        x = np.atleast_1d(np.asarray(sizes, dtype=float))
        if x.size and not np.all(np.isfinite(x) & (x >= 0.0)):
            raise ValueError(f"sizes: must be finite and >= 0 (SoC fraction), got {x.tolist()}")
        return ExponentialSizeBelief(self.shape + x.size, self.scale + float(np.sum(x)))

    @property
    def upper(self) -> float:
        """The largest size [-] (unbounded)."""
        return math.inf

    @property
    def mean(self) -> float:
        """The predictive mean size b/(a − 1) [-] (inf for a <= 1)."""
        return self.scale / (self.shape - 1.0) if self.shape > 1.0 else math.inf

    def sum_tail(self, n_max: int, margin) -> np.ndarray:
        """Q̄_n(m) = P(NB(a, b/(b + m)) <= n − 1) for n = 0..n_max, the tail of the sum of n sizes
        of one world (sharing ϑ), shape margin.shape + (n_max + 1,)."""
        m = np.asarray(margin, dtype=float)
        pmf = _NegativeBinomialPmf(self.shape, np.maximum(m, 0.0) / self.scale, max(n_max - 1, 0))
        cdf = np.cumsum(pmf[..., :n_max], axis=-1)
        q = np.concatenate([np.zeros(m.shape + (1,)), cdf], axis=-1)
        return np.where(m[..., None] < 0.0, 1.0, np.minimum(q, 1.0))


Sizes = UniformDrops | ExponentialDrops | EmpiricalDrops | ExponentialSizeBelief
"""The size models a :class:`FaultBelief` holds."""


def LearningSizes(sizes: Sizes, prior_sizes: int = 6) -> Sizes:
    """The learning counterpart of a point size model, worth ``prior_sizes`` K observed sizes:
    U[a, b] becomes the list a + (b − a) j/K, j = 1..K (rounded up to :data:`SIZE_RESOLUTION`),
    which is stochastically larger than U[a, b], so its tails Q_n are never below the uniform's;
    Exp(μ) becomes :meth:`ExponentialSizeBelief.FromMean` (μ, K); a list or a belief is kept."""
    k = CheckCount("prior_sizes", prior_sizes, 1, 1000)
    if isinstance(sizes, UniformDrops):
        values = sizes.a + (sizes.b - sizes.a) * np.arange(1, k + 1) / k
        steps = np.ceil(np.round(values / SIZE_RESOLUTION, 9)) * SIZE_RESOLUTION
        return EmpiricalDrops(tuple(np.minimum(steps, 1.0).tolist()))
    if isinstance(sizes, ExponentialDrops):
        return ExponentialSizeBelief.FromMean(sizes.mean, k)
    return sizes


def UpdateSizes(sizes: Sizes, observed) -> Sizes:
    """The size model after ``observed`` drop sizes [-]: an empirical list grows by them (rounded to
    :data:`SIZE_RESOLUTION`, sizes in (0, 1]), an :class:`ExponentialSizeBelief` takes its
    conjugate update; uniform and known-scale exponential sizes stay as they are."""
    x = np.atleast_1d(_CheckArray("observed", observed, nonnegative=True, what="(SoC fraction)"))
    if isinstance(sizes, ExponentialSizeBelief):
        return sizes.Update(x)
    if isinstance(sizes, EmpiricalDrops) and x.size:
        rounded = np.clip(np.round(x / SIZE_RESOLUTION) * SIZE_RESOLUTION, SIZE_RESOLUTION, 1.0)
        return EmpiricalDrops(sizes.values + tuple(rounded.tolist()))
    return sizes


@dc.dataclass(frozen=True)
class FaultBelief:
    """What the planner believes about faults: a :class:`RateBelief` over the rate and the sizes'
    model (learning or not, :func:`UpdateSizes`)."""

    rate: RateBelief
    sizes: Sizes

    def __post_init__(self):
        if not isinstance(self.rate, RateBelief):
            raise ValueError(
                f"FaultBelief.rate: must be a RateBelief, got {type(self.rate).__name__}"
            )
        if not isinstance(self.sizes, Sizes):
            raise ValueError(
                "FaultBelief.sizes: must be UniformDrops, ExponentialDrops, EmpiricalDrops or "
                f"ExponentialSizeBelief, got {type(self.sizes).__name__}"
            )

    def Update(self, flight_time: float, drop_sizes=()) -> "FaultBelief":
        """The belief after ``flight_time`` τ [s] flown with the drops of ``drop_sizes`` [-]."""
        x = np.atleast_1d(np.asarray(drop_sizes, dtype=float))
        return FaultBelief(self.rate.Update(flight_time, x.size), UpdateSizes(self.sizes, x))

    def PointModel(self) -> FaultModel | None:
        """The :class:`~eaplan_drake.planning.risk.FaultModel` with the mean rate, when the sizes
        are a point model (None for an :class:`ExponentialSizeBelief`)."""
        if isinstance(self.sizes, ExponentialSizeBelief):
            return None
        return FaultModel(self.rate.mean, self.sizes)


def _CheckExpected(name: str, belief: RateBelief, exposure: np.ndarray) -> None:
    expected = belief.mean * float(np.max(exposure, initial=0.0))
    if expected > MAX_EXPECTED_DROPS:
        raise ValueError(
            f"{name}: mean rate·{name} must be <= {MAX_EXPECTED_DROPS:g} expected drops, "
            f"got {expected:g}"
        )


def SaturatedSumTail(sizes: Sizes, n_max: int, margin) -> np.ndarray:
    """``sizes.sum_tail(n_max, margin)``, levels past the first one within :data:`SATURATED` of 1 at
    every margin (checked at 16, 32, 64, … levels) taken equal to it: Q_n rises with n, so this is
    from below, by at most SATURATED. ``margin`` m [-] broadcasts; shape m.shape + (n_max + 1,)."""
    n_max = CheckCount("n_max", n_max, 0, MAX_CUTOFF)
    margin = _CheckArray("margin", margin, nonnegative=False, what="(SoC fraction)")
    level = min(n_max, 16)
    while True:
        q = sizes.sum_tail(level, margin)
        if level == n_max:
            return q
        if np.all(q[..., -1] >= 1.0 - SATURATED):
            rest = np.repeat(q[..., -1:], n_max - level, axis=-1)
            return np.concatenate([q, rest], axis=-1)
        level = min(2 * level, n_max)


def BeliefDropTail(belief: FaultBelief, exposure, margin):
    """P(S(τ) > m) under the belief: Σ_n NB(n; α, β/(β + τ)) Q̄_n(m) over ``exposure`` τ [s] and
    ``margin`` m [-] (broadcast); exact to 1e-12 + 1e-13 from below; 1 for m < 0."""
    tau = _CheckArray("exposure", exposure, nonnegative=True, what="[s]")
    m = _CheckArray("margin", margin, nonnegative=False, what="(SoC fraction)")
    tau, m = np.broadcast_arrays(tau, m)
    _CheckExpected("exposure", belief.rate, tau)
    n_max = NegativeBinomialCutoff(
        belief.rate.shape, float(np.max(tau, initial=0.0)) / belief.rate.rate
    )
    pmf = belief.rate.CountPmf(tau, n_max)
    tail = np.sum(pmf * SaturatedSumTail(belief.sizes, n_max, m), axis=-1)
    out = np.where(m < 0.0, 1.0, np.clip(tail, 0.0, 1.0))
    return float(out) if out.ndim == 0 else out


def _FallbackFailureBounds(belief: FaultBelief, tau_p, m_p, tau_0, m_0, cells: int):
    """Lower and upper sums of P_B(F_p) (module docstring) over flat arrays of candidates."""
    alpha, beta = belief.rate.shape, belief.rate.rate
    s = np.linspace(0.0, 1.0, cells + 1)
    x_p = (tau_p / beta)[:, None]
    reach = -np.expm1(-alpha * np.log1p(x_p))  # P_B(T_1 <= τ_p)
    with np.errstate(divide="ignore", invalid="ignore"):
        u_prob = np.expm1(-np.log1p(-reach * s) / alpha) / np.where(x_p > 0.0, x_p, 1.0)
    u_prob = np.where(x_p > 0.0, np.minimum(u_prob, 1.0), s)
    u_prob[:, -1] = 1.0
    edges = np.sort(np.concatenate([np.broadcast_to(s, u_prob.shape), u_prob], axis=1), axis=1)
    half = 0.5 * (edges[:, 1:] - edges[:, :-1])[..., None]
    u = 0.5 * (edges[:, 1:] + edges[:, :-1])[..., None] + half * _GAUSS_NODES
    x_p = x_p[..., None]
    first = half * _GAUSS_WEIGHTS * alpha * x_p * np.exp(-(alpha + 1.0) * np.log1p(x_p * u))
    odds = (tau_0 / beta)[:, None, None] * (1.0 - u) / (1.0 + x_p * u)
    n_max = NegativeBinomialCutoff(alpha + 1.0, float(np.max(tau_0, initial=0.0)) / beta)
    weight = np.einsum("pcq,pcqn->pcn", first, _NegativeBinomialPmf(alpha + 1.0, odds, n_max))
    left = m_0[:, None] - (m_0 - m_p)[:, None] * edges
    q = SaturatedSumTail(belief.sizes, n_max + 1, left)[..., 1:]
    q_low = np.minimum(q[:, :-1], q[:, 1:])
    q_high = np.maximum(q[:, :-1], q[:, 1:])
    none = np.exp(-alpha * np.log1p(tau_p / beta)) * (m_p < 0.0)
    low = none + np.einsum("pcn,pcn->p", weight, q_low)
    return low, none + np.einsum("pcn,pcn->p", weight, q_high)


def BeliefExcessRiskBounds(
    belief: FaultBelief, plan_time, plan_margin, lowest_time, lowest_margin, *, cells: int = 64
):
    """(lower, upper) bounds of the excess risk R_B(p) [-] under the belief (module docstring),
    arguments as :func:`~eaplan_drake.planning.risk.ExcessRiskBounds` (τ_p, τ_0 [s]; m_p, m_0 [-];
    broadcast). Both are 0 for the lowest plan itself; their gap shrinks as 1/``cells``."""
    cells = CheckCount("cells", cells, 1, 4096)
    args = [
        _CheckArray("plan_time", plan_time, nonnegative=True, what="[s]"),
        _CheckArray("plan_margin", plan_margin, nonnegative=False, what="(SoC fraction)"),
        _CheckArray("lowest_time", lowest_time, nonnegative=True, what="[s]"),
        _CheckArray("lowest_margin", lowest_margin, nonnegative=False, what="(SoC fraction)"),
    ]
    shape = np.broadcast_shapes(*(a.shape for a in args))
    tau_p, m_p, tau_0, m_0 = (np.broadcast_to(a, shape).ravel() for a in args)
    _CheckExpected("plan_time", belief.rate, tau_p)
    _CheckExpected("lowest_time", belief.rate, tau_0)
    low_p, high_p = np.empty(tau_p.size), np.empty(tau_p.size)
    n_max = NegativeBinomialCutoff(
        belief.rate.shape + 1.0, float(np.max(tau_0, initial=0.0)) / belief.rate.rate
    )
    chunk = max(1, 4_000_000 // ((2 * cells + 1) * _GAUSS_NODES.size * (n_max + 2)))
    for j in range(0, tau_p.size, chunk):
        part = slice(j, j + chunk)
        low_p[part], high_p[part] = _FallbackFailureBounds(
            belief, tau_p[part], m_p[part], tau_0[part], m_0[part], cells
        )
    fail_0 = np.asarray(BeliefDropTail(belief, tau_0, m_0))
    ordered = (tau_p >= tau_0) & (m_p <= m_0)
    upper = np.where(ordered, high_p - fail_0, np.minimum(high_p, 1.0 - fail_0))
    lowest = (tau_p == tau_0) & (m_p == m_0)
    upper = np.where(lowest, 0.0, np.clip(upper, 0.0, 1.0))
    lower = np.where(lowest, 0.0, np.clip(low_p - fail_0, 0.0, upper))
    if shape == ():
        return float(lower[0]), float(upper[0])
    return lower.reshape(shape), upper.reshape(shape)


def BeliefExcessRisk(
    belief: FaultBelief, plan_time, plan_margin, lowest_time, lowest_margin, *, cells: int = 64
):
    """R_B(p) [-]: the upper bound of :func:`BeliefExcessRiskBounds` (conservative; exactly 0 for
    the lowest plan). Broadcasts."""
    _, upper = BeliefExcessRiskBounds(
        belief, plan_time, plan_margin, lowest_time, lowest_margin, cells=cells
    )
    return upper
