"""Risk of battery faults for the planner: a fault model, the tail of the total SoC drop, the excess
risk of a plan over the lowest plan, and the statistics that certify a risk level.

Plain functions over numpy, deterministic. Units: time [s], rates [1/s], SoC fractions [-].

**Fault model.** Drops arrive as a Poisson process N(t) of rate λ [1/s]; their sizes X_1, X_2, ...
[-] are i.i.d. (:class:`UniformDrops`, :class:`ExponentialDrops`, :class:`EmpiricalDrops`) and
independent of the arrivals. Over an exposure τ [s] the total drop is compound Poisson::

    S(τ) = X_1 + ... + X_N(τ),      P(S(τ) > m) = Σ_n e^(-λτ) (λτ)^n / n! · Q_n(m),
    Q_n(m) = P(X_1 + ... + X_n > m),   Q_0(m) = [m < 0].

:func:`TotalDropTail` stops the sum where a Chernoff bound puts the Poisson tail below 1e-12, so it
is exact to 1e-12 (from below). Q_n is the Irwin–Hall CDF for uniform sizes (in a Bernstein form
that never cancels), the Erlang survival for exponential ones, an exact n-fold convolution for a
list.

**Excess risk.** A candidate plan p has remaining mission time τ_p [s] and margin m_p [-] (predicted
end SoC with no further fault, minus the reserve); the lowest plan 0 from the same state has τ_0,
m_0. Assumptions:

- A1: a plan spends time and SoC uniformly along the rest of the survey (progress u in [0, 1]).
- A2: the mission fails when the drops exceed the margin (SoC never rises, so the end is the lowest
  point; ending exactly at the reserve completes).
- A3: fallback: at the first drop the planner switches to the lowest plan for the rest.
- A4: both flights see the same world (drop times from now, and sizes).

With the first drop at t = u·τ_p, plan p has spent u of its SoC and flies the remaining 1 − u of the
survey as the lowest plan would, for τ_0 (1 − u) seconds::

    M(u) = u·m_p + (1 − u)·m_0                      margin left at the first drop
    F_p  = {T_1 <= τ_p, X_1 + S(T_1, T_1 + τ_0 (1 − u)] > M(u)}  or  {T_1 > τ_p, m_p < 0}
    F_0  = {S(0, τ_0] > m_0}
    R(p) = P(F_p and not F_0)                       the excess risk

R(p) is the probability that the mission fails although the lowest plan from the same state would
have completed. The first drop is the split point: before it the flight is the deterministic plan p;
T_1 ~ Exp(λ) is a stopping time, so later arrivals are again Poisson and independent of (T_1, X_1);
and later drops change no decision, the rest being the lowest plan already. So, with Λ = λτ::

    P(F_p) = e^(-Λ_p) [m_p < 0]
           + ∫_0^1 Λ_p e^(-Λ_p u) Σ_n Pois(n; Λ_0 (1 − u)) Q_(n+1)(M(u)) du.

If τ_0 <= τ_p and m_p <= m_0, then F_0 is inside F_p: with a drop at t <= τ_0, p's window ends at
t + τ_0 (1 − t/τ_p) >= τ_0, so p suffers every drop the lowest plan does, against M(u) <= m_0; with
none by τ_0, F_0 means m_0 < 0, and then m_p < 0 and M(u) < 0 fail p too. Hence, exactly::

    R(p) = P(F_p) − P(S(τ_0) > m_0).

A plan that only spends more SoC per second (same path, τ_p = τ_0, more computation) is exposed as
long; its excess comes from the margin u (m_0 − m_p) already spent when the first drop comes. A
plan that also flies longer meets its first drop sooner (Λ_p > Λ_0 per unit of progress) and is
exposed after τ_0, up to t + τ_0 (1 − u). Out of that order (a candidate better than the lowest in
time or margin) :func:`ExcessRiskBounds` falls back to the bound min(P(F_p), 1 − P(F_0)).

Evaluation: M(u) is linear, so every Q_(n+1)(M(u)) is monotone on a cell of u and bounded by its
values at the edges. The cells are the union of ``cells`` equal steps in u and ``cells`` equal steps
in first-drop probability; the smooth weights (density of T_1 times the Poisson weights of the
later drops) are integrated by 8-point Gauss–Legendre to rounding error (checked against
:func:`TotalDropTail`). This brackets P(F_p) between a lower and an upper sum at most
(1 − e^(-Λ_p)) / cells · Σ_n (Q_(n+1)(m_p) − Q_(n+1)(m_0)) apart; :func:`ExcessRisk` returns the
upper one (conservative to the 1e-12 of the truncations).

Recursive feasibility: for the lowest plan F_p = F_0, so its excess risk is 0 (returned exactly),
and the constraint R(p) <= ε admits it from every state, after every drop. Its own risk P(F_0) is
the world's, not an excess, and is reported apart. ε bounds one decision given the state (the
mpc spends one budget per mission, :mod:`eaplan_drake.planning.risk_margin`); the rate over whole
missions is what Monte Carlo over worlds certifies (:mod:`eaplan_drake.studies.certify`). In a
thin world (m_0 small against the drops) the lowest plan survives by little, and a plan that
spends more loses those worlds: its excess risk is large.
"""

import dataclasses as dc
import functools
import math
import threading

import numpy as np

from eaplan_drake.errors import CheckCount, CheckNumber
from eaplan_drake.params import MAX_EXPECTED_DROPS

__all__ = [
    "EmpiricalDrops",
    "ExcessRisk",
    "ExcessRiskBounds",
    "ExponentialDrops",
    "FaultModel",
    "MarginAtRisk",
    "PoissonCutoff",
    "PoissonPmf",
    "TotalDropTail",
    "UniformDrops",
]

POISSON_TAIL = 1e-12
"""Poisson mass beyond the last count summed (the tails are exact to this, from below)."""

MAX_SUPPORT = 200_000
"""Largest number of distinct values of an n-fold sum of :class:`EmpiricalDrops`."""

_GAUSS_NODES, _GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(8)


def _CheckArray(name: str, value, *, nonnegative: bool, what: str) -> np.ndarray:
    """``value`` as a float array, finite (and >= 0), or a ValueError naming the first bad entry."""
    x = np.asarray(value, dtype=float)
    bad = ~np.isfinite(x) | ((x < 0.0) if nonnegative else False)
    if np.any(bad):
        first = x[bad].ravel()[0]
        rule = "finite and >= 0" if nonnegative else "finite"
        raise ValueError(f"{name}: must be {rule} {what}, got {first}")
    return x


def _Out(x: np.ndarray):
    """A float for a 0-d result, else the array."""
    return float(x) if np.ndim(x) == 0 else x


@functools.lru_cache(maxsize=64)
def _LogFactorials(n_max: int) -> np.ndarray:
    """log k! for k = 0..n_max (cached; do not modify)."""
    return np.array([math.lgamma(k + 1.0) for k in range(n_max + 1)])


def PoissonPmf(mean: np.ndarray, n_max: int) -> np.ndarray:
    """e^(-Λ) Λ^n / n! for n = 0..n_max, shape mean.shape + (n_max + 1,), computed in log space."""
    mean = np.asarray(mean, dtype=float)[..., None]
    k = np.arange(n_max + 1)
    if mean.size and mean.min() > 0.0:  # every Λ > 0 (none NaN): nothing to mask
        return np.exp(k * np.log(mean) - mean - _LogFactorials(n_max))
    log_mean = np.log(np.where(mean > 0.0, mean, 1.0))
    pmf = np.exp(k * log_mean - mean - _LogFactorials(n_max))
    return np.where(mean > 0.0, pmf, (k == 0).astype(float))


def PoissonCutoff(mean: float) -> int:
    """Smallest n_max with P(N > n_max) < POISSON_TAIL for N ~ Poisson(mean), by the Chernoff bound
    P(N >= k) <= e^(-Λ) (eΛ/k)^k (k > Λ)."""
    if type(mean) not in (float, np.float64) or not 0.0 < mean < _CUTOFF_MEANS:
        return _PoissonCutoffArrays(mean)
    mean = float(mean)
    stop = int(mean + 20.0 * math.sqrt(mean) + 60.0)
    logs = _LogCounts(stop)
    base = 1.0 + math.log(mean)
    # the bound of each k in turn from the first above the mean, as the arrays below compute it
    for k in range(math.floor(mean) + 1, stop):
        if -mean + k * (base - logs[k]) < _LOG_POISSON_TAIL:
            return k - 1
    return _PoissonCutoffArrays(mean)


_CUTOFF_MEANS = 1e6
"""Means :func:`PoissonCutoff` scans count by count (larger ones take the array form)."""

_LOG_POISSON_TAIL = math.log(POISSON_TAIL)
_LOG_COUNTS = [[0.0]]
"""``np.log(k)`` at index k >= 1 as floats (index 0 unused), grown on demand."""


def _LogCounts(stop: int) -> list[float]:
    """At index k = 1..stop − 1 the value of k in ``np.log(np.arange(1, stop))``."""
    logs = _LOG_COUNTS[0]
    if len(logs) < stop:
        size = max(stop, 2 * len(logs), 512)
        logs = _LOG_COUNTS[0] = [0.0, *np.log(np.arange(1, size)).tolist()]
    return logs


def _PoissonCutoffArrays(mean: float) -> int:
    """:func:`PoissonCutoff` over an array of counts (any mean it takes; errors as they come)."""
    if mean <= 0.0:
        return 0
    k = np.arange(1, int(mean + 20.0 * math.sqrt(mean) + 60.0))
    log_bound = -mean + k * (1.0 + math.log(mean) - np.log(k))
    return int(k[(k > mean) & (log_bound < math.log(POISSON_TAIL))][0]) - 1


def _CheckExpected(name: str, expected: np.ndarray) -> None:
    if np.any(expected > MAX_EXPECTED_DROPS):
        raise ValueError(
            f"{name}: rate·{name} must be <= {MAX_EXPECTED_DROPS:g} expected drops, "
            f"got {float(np.max(expected)):g}"
        )


def _IrwinHallCdf(count: np.ndarray, x: np.ndarray) -> np.ndarray:
    """P(U_1 + ... + U_n <= x) for U_i ~ U[0, 1], flat arrays of counts n >= 1 and x in [0, n].

    The alternating sum (1/n!) Σ_k (-1)^k C(n, k) (x - k)^n cancels catastrophically for large n
    (at n = 100, x = 50 no digit is left), so this uses a stable form instead: on each piece
    [k, k + 1] the CDF F_n is a polynomial of degree n in t = x - k, written in the Bernstein basis
    B_(i,n)(t) = C(n, i) t^i (1 - t)^(n-i). From F_n(x) = ∫_(x-1)^x F_(n-1)(y) dy and the integrals
    of the Bernstein basis, its coefficients are averages of the previous level's::

        c(n)[k, i] = (Σ_(l >= i) c(n-1)[k-1, l] + Σ_(l < i) c(n-1)[k, l]) / n,

    with c(n-1)[-1, ·] = 0 and c(n-1)[n-1, ·] = 1 outside [0, n-1], so every coefficient is in
    [0, 1] and F_n(x) = Σ_i c(n)[k, i] B_(i,n)(t) is a convex combination: no cancellation.
    Cost O(n²) per level, O(n) per point.
    """
    out = np.zeros(x.shape)
    if not x.size:
        return out
    top = int(np.max(count))
    coeffs, log_comb = _PaddedBernstein(top)
    i = np.arange(top + 1)
    for chunk in range(0, x.size, _IRWIN_HALL_CHUNK):
        n = count[chunk : chunk + _IRWIN_HALL_CHUNK]
        piece = np.minimum(np.floor(x[chunk : chunk + _IRWIN_HALL_CHUNK]), n - 1).astype(int)
        t = (x[chunk : chunk + _IRWIN_HALL_CHUNK] - piece)[:, None]
        column = n[:, None]
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            log_basis = log_comb[n, : top + 1] + i * np.log(t) + (column - i) * np.log1p(-t)
            basis = np.where(t == 0.0, i == 0, np.where(t == 1.0, i == column, np.exp(log_basis)))
        terms = coeffs[n, piece, : top + 1] * np.where(i <= column, basis, 0.0)
        part = out[chunk : chunk + _IRWIN_HALL_CHUNK]
        # each point's sum over exactly its n + 1 terms (the same summation as an unpadded row):
        # up to 128 terms all rows at once, the longer ones level by level
        short = n < PAIRWISE_BLOCK
        if short.all():
            part[:] = PairwiseRowSums(terms, n + 1)
            continue
        part[short] = PairwiseRowSums(terms[short], n[short] + 1)
        longer = np.flatnonzero(~short)
        order = longer[np.argsort(n[longer], kind="stable")]
        levels, starts = np.unique(n[order], return_index=True)
        ends = [*starts[1:].tolist(), order.size]
        for level, lo, hi in zip(levels.tolist(), starts.tolist(), ends, strict=True):
            rows = order[lo:hi]
            part[rows] = np.add.reduce(terms[rows, : level + 1], axis=1)
    return out


PAIRWISE_BLOCK = 128
"""The longest row numpy's ``np.add.reduce`` sums in one block of its pairwise summation (it splits
longer rows in halves first): the rows :func:`PairwiseRowSums` takes."""


def PairwiseRowSums(terms: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """``np.add.reduce(terms[r, : lengths[r]])`` for every row r of a 2-d array of values >= 0,
    bit for bit, all rows at once (lengths 1..128, at most the row's width; the values past a row's
    length are not read into its sum).

    numpy sums L <= 128 float64 values a_0..a_(L-1) as: for L < 8, in turn from 0; else in eight
    accumulators r_j = a_j + a_(8+j) + a_(16+j) + ... over the L // 8 whole blocks of 8, combined
    as ((r_0 + r_1) + (r_2 + r_3)) + ((r_4 + r_5) + (r_6 + r_7)), then the last L % 8 values added
    in turn (its pairwise summation, tested against ``np.add.reduce`` for every length). Here the
    values outside a row's whole blocks, and past its length, are replaced by zeros: adding +0 to a
    sum of values >= 0 leaves it as it is."""
    count, width = terms.shape
    blocks = lengths // 8
    most = int(blocks.max(initial=0))
    total = np.zeros(count)
    if most:
        whole = np.where(
            np.arange(8 * most) < 8 * blocks[:, None], terms[:, : 8 * most], 0.0
        )  # (rows, 8 · blocks): each row's whole blocks
        r = whole[:, :8]
        for b in range(1, most):
            r = r + whole[:, 8 * b : 8 * b + 8]
        pairs = r[:, 0::2] + r[:, 1::2]  # r_0 + r_1, r_2 + r_3, r_4 + r_5, r_6 + r_7
        quads = pairs[:, 0::2] + pairs[:, 1::2]
        total = quads[:, 0] + quads[:, 1]
    rest = lengths - 8 * blocks
    longest = int(rest.max(initial=0))
    if longest:
        k = np.arange(longest)
        index = np.minimum(8 * blocks[:, None] + k, width - 1)
        tail = np.where(k < rest[:, None], terms[np.arange(count)[:, None], index], 0.0)
        for j in range(longest):
            total = total + tail[:, j]
    return total


_IRWIN_HALL_CHUNK = 4096
"""Points :func:`_IrwinHallCdf` evaluates at once (bounds its padded arrays' memory)."""


_BERNSTEIN_LOCK = threading.Lock()
_BERNSTEIN = [(np.ones((0, 1)), np.zeros(1))]
"""Level n of :func:`_IrwinHallCdf`'s recursion at index n: the Bernstein coefficients c(n), shape
(n, n + 1), and log C(n, i) for i = 0..n; grown on demand and kept (they depend on n only)."""


def _Bernstein(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Level n of the recursion in :func:`_IrwinHallCdf` (coefficients, log binomials)."""
    with _BERNSTEIN_LOCK:  # a Dask worker's threads may grow it at once
        _GrowBernstein(n)
    return _BERNSTEIN[n]


_PADDED = [None]
"""Levels 0..n of :func:`_IrwinHallCdf`'s recursion padded with zeros into arrays, the last size
built: coefficients (n + 1, n, n + 1) and log binomials (n + 1, n + 1)."""


def _PaddedBernstein(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Levels 0..(at least) n of :func:`_Bernstein`, stacked: ``coeffs[k, piece, i]`` and
    ``log_comb[k, i]``, zero where i > k or piece >= k."""
    with _BERNSTEIN_LOCK:
        padded = _PADDED[0]
        if padded is None or padded[1].shape[0] <= n:
            size = 16 * -(-n // 16)  # whole multiples of 16 levels
            _GrowBernstein(size)
            coeffs = np.zeros((size + 1, size, size + 1))
            log_comb = np.zeros((size + 1, size + 1))
            for k in range(1, size + 1):
                coeffs[k, :k, : k + 1], log_comb[k, : k + 1] = _BERNSTEIN[k]
            padded = _PADDED[0] = (coeffs, log_comb)
    return padded


def _GrowBernstein(n: int) -> None:
    while len(_BERNSTEIN) <= n:
        level = len(_BERNSTEIN)
        previous = _BERNSTEIN[-1][0]
        padded = np.concatenate([np.zeros((1, level)), previous, np.ones((1, level))])
        suffix = np.concatenate(
            [np.cumsum(padded[:, ::-1], axis=1)[:, ::-1], np.zeros((level + 1, 1))], 1
        )
        prefix = np.concatenate([np.zeros((level + 1, 1)), np.cumsum(padded, axis=1)], axis=1)
        log_fact = _LogFactorials(level)
        _BERNSTEIN.append(
            ((suffix[:-1] + prefix[1:]) / level, log_fact[-1] - log_fact - log_fact[::-1])
        )


@dc.dataclass(frozen=True)
class UniformDrops:
    """Drop sizes X ~ U[a, b] [-], 0 <= a < b <= 1 (a fixed size is ``EmpiricalDrops([a])``)."""

    a: float
    b: float

    def __post_init__(self):
        a = CheckNumber("UniformDrops.a", self.a, 0.0, 1.0, "(SoC fraction)", open_high=True)
        b = CheckNumber("UniformDrops.b", self.b, 0.0, 1.0, "(SoC fraction)", open_low=True)
        if not a < b:
            raise ValueError(f"UniformDrops.a: must be < b = {b:g}, got {a:g}")
        object.__setattr__(self, "a", a)
        object.__setattr__(self, "b", b)

    @property
    def upper(self) -> float:
        """The largest size [-]."""
        return self.b

    def sum_tail(self, n_max: int, margin) -> np.ndarray:
        """Q_n(m) = P(X_1 + ... + X_n > m) for n = 0..n_max, shape margin.shape + (n_max + 1,):
        the sum is n·a + (b − a)·H_n, H_n Irwin–Hall, and P(H_n > x) = F_n(n − x) by symmetry."""
        m = np.asarray(margin, dtype=float)[..., None]
        n = np.arange(n_max + 1)
        x = (m - n * self.a) / (self.b - self.a)
        inside = (n >= 1) & (x > 0.0) & (x < n)
        count = np.broadcast_to(n, x.shape)[inside]
        x_in = x[inside]
        q = np.where(x <= 0.0, 1.0, 0.0)
        q[..., 0] = (m[..., 0] < 0.0).astype(float)
        q[inside] = _IrwinHallCdf(count, count - x_in)
        return q


@dc.dataclass(frozen=True)
class ExponentialDrops:
    """Drop sizes X ~ Exp with mean μ [-], 0 < μ < 1 (sizes above 1 empty the battery)."""

    mean: float

    def __post_init__(self):
        soc = "(SoC fraction)"
        mean = CheckNumber(
            "ExponentialDrops.mean", self.mean, 0, 1, soc, open_low=True, open_high=True
        )
        object.__setattr__(self, "mean", mean)

    @property
    def upper(self) -> float:
        """The largest size [-] (unbounded)."""
        return math.inf

    def sum_tail(self, n_max: int, margin) -> np.ndarray:
        """Q_n(m) for n = 0..n_max: the Erlang survival P(Poisson(m/μ) <= n − 1), a sum of positive
        terms (m >= 0), shape margin.shape + (n_max + 1,)."""
        m = np.asarray(margin, dtype=float)
        pmf = PoissonPmf(np.maximum(m, 0.0) / self.mean, max(n_max - 1, 0))[..., :n_max]
        survival = np.concatenate([np.zeros(m.shape + (1,)), np.cumsum(pmf, axis=-1)], axis=-1)
        return np.where(m[..., None] < 0.0, 1.0, survival)


@dc.dataclass(frozen=True)
class EmpiricalDrops:
    """Drop sizes drawn from a list of observed sizes [-], each in (0, 1], equal weights."""

    values: tuple[float, ...]

    def __post_init__(self):
        values = tuple(
            CheckNumber(f"EmpiricalDrops.values[{i}]", v, 0.0, 1.0, "(SoC fraction)", open_low=True)
            for i, v in enumerate(np.atleast_1d(np.asarray(self.values, dtype=object)))
        )
        if not values:
            raise ValueError("EmpiricalDrops.values: must hold at least one size, got none")
        object.__setattr__(self, "values", values)

    @property
    def upper(self) -> float:
        """The largest size [-]."""
        return max(self.values)

    def sum_tail(self, n_max: int, margin) -> np.ndarray:
        """Q_n(m) for n = 0..n_max from the exact distribution of the n-fold sum (convolution over
        the distinct values; sums are rounded to 1e-12 to merge equal ones; at most MAX_SUPPORT)."""
        m = np.asarray(margin, dtype=float)
        values, counts = np.unique(np.asarray(self.values), return_counts=True)
        weights = counts / counts.sum()
        support, probs = np.zeros(1), np.ones(1)
        q = np.empty(m.shape + (n_max + 1,))
        for n in range(n_max + 1):
            if n > 0:
                sums = np.round((support[:, None] + values).ravel(), 12)
                support, inverse = np.unique(sums, return_inverse=True)
                probs = np.bincount(inverse, weights=(probs[:, None] * weights).ravel())
                if support.size > MAX_SUPPORT:
                    raise ValueError(
                        f"EmpiricalDrops.values: the {n}-fold sum has more than {MAX_SUPPORT} "
                        "distinct values; round the sizes (e.g. to 0.001)"
                    )
            above = np.concatenate([np.cumsum(probs[::-1])[::-1], [0.0]])
            q[..., n] = above[np.searchsorted(support, m, side="right")]
        return q


_SIZE_KINDS = (UniformDrops, ExponentialDrops, EmpiricalDrops)


def _IsSizeModel(sizes) -> bool:
    """Whether ``sizes`` answers what a size model must (its tails Q_n and its largest size):
    the learnt predictive of :mod:`eaplan_drake.planning.learnt_sizes` does."""
    return callable(getattr(sizes, "sum_tail", None)) and hasattr(sizes, "upper")


@dc.dataclass(frozen=True)
class FaultModel:
    """Battery faults: drops as a Poisson process of ``rate`` λ >= 0 [1/s] with i.i.d. ``sizes``."""

    rate: float
    sizes: UniformDrops | ExponentialDrops | EmpiricalDrops

    def __post_init__(self):
        rate = CheckNumber("FaultModel.rate", self.rate, 0.0, math.inf, "[1/s]", open_high=True)
        object.__setattr__(self, "rate", rate)
        if not (isinstance(self.sizes, _SIZE_KINDS) or _IsSizeModel(self.sizes)):
            raise ValueError(
                "FaultModel.sizes: must be UniformDrops, ExponentialDrops, EmpiricalDrops or "
                f"a learnt size model, got {type(self.sizes).__name__}"
            )


def TotalDropTail(model: FaultModel, exposure, margin):
    """P(S(τ) > m): the probability that the drops during ``exposure`` τ [s] total more than
    ``margin`` m [-]. Broadcasts τ and m; exact to POISSON_TAIL (1e-12, from below); 1 for m < 0,
    0 for τ = 0 and m >= 0. ValueError if λτ > MAX_EXPECTED_DROPS."""
    one = _OnePair(model, exposure, margin)
    if one is not None:
        tail, shape = one
        return tail if shape == () else np.full(shape, tail)
    tau = _CheckArray("exposure", exposure, nonnegative=True, what="[s]")
    m = _CheckArray("margin", margin, nonnegative=False, what="(SoC fraction)")
    tau, m = np.broadcast_arrays(tau, m)
    expected = model.rate * tau
    _CheckExpected("exposure", expected)
    n_max = PoissonCutoff(float(np.max(expected, initial=0.0)))
    tail = np.sum(PoissonPmf(expected, n_max) * model.sizes.sum_tail(n_max, m), axis=-1)
    return _Out(np.where(m < 0.0, 1.0, np.clip(tail, 0.0, 1.0)))


def _OneValue(value):
    """(x, shape) if ``value`` is one float64 number (a float or an array of size 1), else None."""
    kind = type(value)
    if kind is float or kind is np.float64:
        return float(value), ()
    if kind is np.ndarray and value.size == 1 and value.dtype == np.float64:
        return value.item(), value.shape
    return None


def _OnePair(model: FaultModel, exposure, margin):
    """(tail, shape) of :func:`TotalDropTail` for one valid (τ, m) pair, else None (other inputs,
    and bad ones, which take the array form and its errors). The same operations on the same
    values as the array form: numpy's log and exp on arrays, each sum over the same terms."""
    tau, m = _OneValue(exposure), _OneValue(margin)
    if tau is None or m is None:
        return None
    (tau, tau_shape), (m, m_shape) = tau, m
    expected = model.rate * tau
    if not (0.0 <= tau < math.inf and -math.inf < m < math.inf and expected <= MAX_EXPECTED_DROPS):
        return None
    shape = tau_shape if len(tau_shape) >= len(m_shape) else m_shape
    n_max = PoissonCutoff(expected)
    if m < 0.0:
        return 1.0, shape
    if expected == 0.0:  # no drop: Q_0(m) = 0
        return 0.0, shape
    mean = np.array([expected])
    pmf = np.exp(np.arange(n_max + 1) * np.log(mean) - mean - _LogFactorials(n_max))
    if type(model.sizes) is UniformDrops:
        q = _UniformTailAt(model.sizes, n_max, m)
    else:
        q = model.sizes.sum_tail(n_max, m)
    tail = float(np.add.reduce(pmf * q))
    return (0.0 if tail < 0.0 else 1.0 if tail > 1.0 else tail), shape


def _UniformTailAt(sizes: UniformDrops, n_max: int, m: float) -> np.ndarray:
    """``sizes.sum_tail(n_max, m)`` at one margin m >= 0, level by level."""
    q = [0.0] * (n_max + 1)
    levels, points = [], []
    for n in range(1, n_max + 1):
        x = (m - n * sizes.a) / (sizes.b - sizes.a)
        if x <= 0.0:
            q[n] = 1.0
        elif x < n:
            levels.append(n)
            points.append(n - x)
    if levels:
        for n, value in zip(levels, _IrwinHallCdfAt(tuple(levels), points), strict=True):
            q[n] = value
    return np.array(q)


def _IrwinHallCdfAt(levels: tuple[int, ...], points: list[float]) -> list:
    """:func:`_IrwinHallCdf` of points at distinct levels (counts), its operations on each point's
    own n + 1 terms: the terms of all points in one flat array, then one sum per point."""
    point, i, rest, log_comb, spans = _FlatTerms(levels)
    inner, rows, edges = [], [], []
    for j, (n, x) in enumerate(zip(levels, points, strict=True)):
        piece = min(math.floor(x), n - 1)
        t = x - piece
        rows.append(_BERNSTEIN[n][0][piece])
        if t == 0.0 or t == 1.0:  # the basis is 0 or 1 there (no logarithm)
            edges.append((spans[j], 0 if t == 0.0 else n))
            t = 0.5
        inner.append(t)
    inner = np.array(inner)
    basis = np.exp(log_comb + i * np.log(inner)[point] + rest * np.log1p(-inner)[point])
    for span, one in edges:
        basis[span] = i[span] == one
    terms = np.concatenate(rows) * basis
    return [np.add.reduce(terms[span]) for span in spans]


@functools.lru_cache(maxsize=256)
def _FlatTerms(levels: tuple[int, ...]):
    """For :func:`_IrwinHallCdfAt` (growing the levels): per term its point, i, n − i and
    log C(n, i); each point's slice of the terms."""
    log_comb = np.concatenate([_Bernstein(n)[1] for n in levels])
    i = np.concatenate([np.arange(n + 1) for n in levels])
    rest = np.concatenate([n - np.arange(n + 1) for n in levels])
    point = np.repeat(np.arange(len(levels)), [n + 1 for n in levels])
    ends = np.cumsum([n + 1 for n in levels]).tolist()
    spans = [slice(end - n - 1, end) for n, end in zip(levels, ends, strict=True)]
    return point, i, rest, log_comb, spans


def MarginAtRisk(model: FaultModel, exposure, eps: float, *, tolerance: float = 1e-10):
    """The smallest margin m [-] with P(S(τ) > m) <= ``eps`` over ``exposure`` τ [s] (broadcasts τ).

    Deterministic bisection of each entry on [0, hi] (hi: the largest possible total for bounded
    sizes, else doubled from 1) to a bracket of width <= ``tolerance``; returns the bracket's upper
    end, so the tail there is <= eps and the true minimum is at most ``tolerance`` below. 0 when
    even m = 0 meets eps. eps must be in [1e-9, 1) (above the tails' truncation)."""
    eps = CheckNumber("eps", eps, 1e-9, 1.0, "(probability)", open_high=True)
    tolerance = CheckNumber("tolerance", tolerance, 1e-14, 1.0, "(SoC fraction)")
    tau = _CheckArray("exposure", exposure, nonnegative=True, what="[s]")
    _CheckExpected("exposure", model.rate * tau)
    top = model.sizes.upper
    n_max = np.vectorize(PoissonCutoff, otypes=[float])(model.rate * tau)
    hi = n_max * top if math.isfinite(top) else np.ones(tau.shape)
    for _ in range(64):
        short = np.asarray(TotalDropTail(model, tau, hi)) > eps
        if not np.any(short):
            break
        hi = np.where(short, 2.0 * hi, hi)
    lo = np.zeros(tau.shape)
    for _ in range(200):
        wide = hi - lo > tolerance
        if not np.any(wide):
            break
        mid = 0.5 * (lo + hi)
        above = np.asarray(TotalDropTail(model, tau, mid)) > eps
        lo, hi = np.where(wide & above, mid, lo), np.where(wide & ~above, mid, hi)
    return _Out(np.where(np.asarray(TotalDropTail(model, tau, 0.0)) <= eps, 0.0, hi))


def _FallbackFailureBounds(model, expected_p, m_p, expected_0, m_0, cells):
    """Lower and upper sums of P(F_p) (module docstring) over flat arrays of candidates."""
    s = np.linspace(0.0, 1.0, cells + 1)
    reach = -np.expm1(-expected_p)[:, None]
    rate_p = np.where(expected_p > 0.0, expected_p, 1.0)[:, None]
    with np.errstate(divide="ignore"):
        u_prob = np.where(reach > 0.0, -np.log1p(-reach * s) / rate_p, s)
    u_prob = np.minimum(u_prob, 1.0)
    u_prob[:, -1] = 1.0
    edges = np.sort(np.concatenate([np.broadcast_to(s, u_prob.shape), u_prob], axis=1), axis=1)
    half = 0.5 * (edges[:, 1:] - edges[:, :-1])[..., None]
    u = 0.5 * (edges[:, 1:] + edges[:, :-1])[..., None] + half * _GAUSS_NODES
    first = (
        half * _GAUSS_WEIGHTS * expected_p[:, None, None] * np.exp(-expected_p[:, None, None] * u)
    )
    n_max = PoissonCutoff(float(np.max(expected_0, initial=0.0)))
    later = PoissonPmf(expected_0[:, None, None] * (1.0 - u), n_max)
    weight = np.einsum("pcq,pcqn->pcn", first, later)
    left = m_0[:, None] - (m_0 - m_p)[:, None] * edges
    q = model.sizes.sum_tail(n_max + 1, left)[..., 1:]
    q_low = np.minimum(q[:, :-1], q[:, 1:])
    q_high = np.maximum(q[:, :-1], q[:, 1:])
    none = np.exp(-expected_p) * (m_p < 0.0)
    return none + np.einsum("pcn,pcn->p", weight, q_low), none + np.einsum(
        "pcn,pcn->p", weight, q_high
    )


def ExcessRiskBounds(
    model: FaultModel, plan_time, plan_margin, lowest_time, lowest_margin, *, cells: int = 64
):
    """(lower, upper) bounds of the excess risk R(p) of candidate plans (module docstring).

    ``plan_time`` τ_p and ``lowest_time`` τ_0 [s] are remaining mission times, ``plan_margin`` m_p
    and ``lowest_margin`` m_0 [-] fault-free end SoC minus reserve; all broadcast (one entry per
    candidate). Both bounds are 0 for the lowest plan itself; their gap shrinks as 1/``cells``."""
    cells = CheckCount("cells", cells, 1, 4096)
    args = [
        _CheckArray("plan_time", plan_time, nonnegative=True, what="[s]"),
        _CheckArray("plan_margin", plan_margin, nonnegative=False, what="(SoC fraction)"),
        _CheckArray("lowest_time", lowest_time, nonnegative=True, what="[s]"),
        _CheckArray("lowest_margin", lowest_margin, nonnegative=False, what="(SoC fraction)"),
    ]
    shape = np.broadcast_shapes(*(a.shape for a in args))
    tau_p, m_p, tau_0, m_0 = (np.broadcast_to(a, shape).ravel() for a in args)
    _CheckExpected("plan_time", model.rate * tau_p)
    _CheckExpected("lowest_time", model.rate * tau_0)
    low_p, high_p = np.empty(tau_p.size), np.empty(tau_p.size)
    n_max = PoissonCutoff(float(np.max(model.rate * tau_0, initial=0.0)))
    chunk = max(1, 4_000_000 // ((2 * cells + 1) * _GAUSS_NODES.size * (n_max + 2)))
    for j in range(0, tau_p.size, chunk):
        part = slice(j, j + chunk)
        low_p[part], high_p[part] = _FallbackFailureBounds(
            model, model.rate * tau_p[part], m_p[part], model.rate * tau_0[part], m_0[part], cells
        )
    fail_0 = np.asarray(TotalDropTail(model, tau_0, m_0))
    ordered = (tau_p >= tau_0) & (m_p <= m_0)
    upper = np.where(ordered, high_p - fail_0, np.minimum(high_p, 1.0 - fail_0))
    lowest = (tau_p == tau_0) & (m_p == m_0)
    upper = np.where(lowest, 0.0, np.clip(upper, 0.0, 1.0))
    lower = np.where(lowest, 0.0, np.clip(low_p - fail_0, 0.0, upper))
    return _Out(lower.reshape(shape)), _Out(upper.reshape(shape))


def ExcessRisk(
    model: FaultModel, plan_time, plan_margin, lowest_time, lowest_margin, *, cells: int = 64
):
    """R(p) [-]: the probability that the mission fails although the lowest plan from the same state
    would have completed, under the fallback to the lowest plan at the first drop: the upper bound
    of :func:`ExcessRiskBounds` (conservative; exactly 0 for the lowest plan). Broadcasts."""
    _, upper = ExcessRiskBounds(
        model, plan_time, plan_margin, lowest_time, lowest_margin, cells=cells
    )
    return upper
