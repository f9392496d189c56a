"""The risk-aware reserve of the mpc policy (``planner.reserve: risk``): for each plan, the margin
it must keep so that its excess risk under the declared fault model is at most ε.

:mod:`eaplan_drake.planning.risk` defines the excess risk R(p) of a plan p (remaining time τ_p
[s], fault-free margin m_p [-]) over the lowest plan (τ_0, m_0) from the same state, with the
fallback to the lowest plan at the first drop::

    R(p) = P(F_p) − P(F_0),
    P(F_p) = ∫_0^1 Λ_p e^(−Λ_p u) Σ_n Pois(n; Λ_0 (1 − u)) Q_(n+1)(u m_p + (1 − u) m_0) du,
    P(F_0) = Σ_n Pois(n; Λ_0) Q_n(m_0),

Λ = λτ the expected drops, Q_n(m) = P(X_1 + … + X_n > m) for the drop sizes X. The planner
evaluates it for every c1 of its grid at every step, so :class:`ExcessRiskTable` tabulates Q_n once
per fault model on a grid of margins (step ``margin_step``) and integrates u by composite
Gauss–Legendre. The table is read conservatively: Q at the grid point below the margin in P(F_p)
(Q falls with m, so that is an upper bound), and P(F_0) is exact
(:func:`~eaplan_drake.planning.risk.TotalDropTail`), so the tabulated R is never below the exact
one, and above it by at most the change of Q over one grid step (tested against
:func:`~eaplan_drake.planning.risk.ExcessRiskBounds`).

:meth:`ExcessRiskTable.RequiredMargin` inverts R in m_p by bisection: m_req(τ_p) is the smallest
margin with R ≤ ε (0 when even m_p = 0 is within ε; +inf when no m_p ≤ m_0 is: longer exposure
alone costs more than ε). The mpc's constraint (1) then reads b(t_rem(c1_j); c2) ≥ b_res +
m_floor + z s_b σ t + m_req(t_rem(c1_j)) in place of the fixed fault reserve. The lowest plan
itself always meets it (its R is 0, so m_req(τ_0) ≤ m_0): the constraint never removes the
fallback, and recursive feasibility holds as with the fixed reserve.

**One budget per mission, not per decision.** Measured from the lowest plan of the *current*
state, R lets every step spend ε anew: a plan that spent its ε leaves a thinner lowest plan, from
which the next step measures (and spends) again, and the mission's excess failure rate climbs
above ε (8.8 % at ε = 0.05 on 57 feasible worlds). The mpc therefore anchors the baseline where a
budget opens (:class:`~eaplan_drake.planning.policies.MpcPolicy`): with (τ_a, m_a) the lowest plan
as it stood then (τ_a counted down with the clock), the excess is measured from

    P_base = min(P(F_0), P(S(τ_a) > m_a))

(``baseline_failure`` of :meth:`ExcessRiskTable.RequiredMargin`),

so spending never lowers what later steps count as the world's own risk (and a better estimate of
the world is used when it is better). The lowest plan keeps R = 0 (the fallback stays
admissible). Before the first drop the budget is ε_0 = ε/2; a detected drop (the SoC more
than :data:`~eaplan_drake.planning.policies.FALLBACK_DROP` below the one-step prediction) opens
the next, ε_k = ε/2^(k+1), anchored at the state after the drop: summed over any number of
drops, the budgets stay within ε. With
``after_drop: lowest`` the aircraft flies the lowest plan after the first drop instead (A3 of
:mod:`eaplan_drake.planning.risk` exactly).
"""

import functools
import math

import numpy as np

from eaplan_drake.params import FaultModelParams
from eaplan_drake.planning.risk import (
    EmpiricalDrops,
    ExponentialDrops,
    FaultModel,
    PoissonCutoff,
    PoissonPmf,
    TotalDropTail,
    UniformDrops,
)

__all__ = [
    "UNREACHABLE_MARGIN",
    "ExcessRiskTable",
    "ExposureBucket",
    "FaultModelFromParams",
    "FirstDropBudget",
    "RiskTable",
]

UNREACHABLE_MARGIN = 0.01
"""How far above the lowest plan's margin m_0 [-] the mpc puts m_req of a plan that no margin
keeps within ε: every plan spends at least what the lowest does, so that excludes it, and the
NLP's constraint stays finite and gentle."""


def _Quadrature(panels: int = 4, order: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Nodes u and weights of composite Gauss–Legendre on [0, 1]."""
    nodes, weights = np.polynomial.legendre.leggauss(order)
    edges = np.linspace(0.0, 1.0, panels + 1)
    half = 0.5 * (edges[1:] - edges[:-1])
    u = (0.5 * (edges[:-1] + edges[1:]))[:, None] + half[:, None] * nodes
    return u.ravel(), (half[:, None] * weights).ravel()


_U, _W = _Quadrature()
_ROW = np.arange(_U.size)
_TINY = 1e-150
"""Probabilities below this are taken as 0 [-] (far below every tolerance here)."""
_SEARCH = 32
"""Margins tried per bisection stage of :meth:`ExcessRiskTable.RequiredMargin`."""
_COARSE = 4
"""Every how many of them the coarse pass of the search reads."""

_COARSE_TRIALS = np.arange(0, _SEARCH + 1, _COARSE)
"""The indices k of the coarse pass's trials (0, 4, … 32)."""

_LAST_TRIAL = np.array([_SEARCH])
"""The index k of the last trial, m_p = lo + width (m_0 itself in the first stage)."""


def _Trials(lo: np.ndarray, width: np.ndarray, k) -> np.ndarray:
    """The trial margins lo + width·k/32 [-] of each plan (rows) at the indices k."""
    return lo[:, None] + width[:, None] * k / _SEARCH


def FirstDropBudget(eps: float, rate: float, exposure: float) -> float:
    """ε_0 [-], the budget before the first detected drop that the later budgets
    ε_k = ε/2^(k+1) (k >= 1) leave when each is weighed by the chance of reaching it
    (``planner.first_budget: reach``).

    Budget k is spent only in flights that detect k drops, and it bounds the excess risk
    conditional on getting there, so the mission's excess is at most Σ_k P(N >= k) ε_k, with N the
    drops of the flight (P(N >= 0) = 1). Keeping ε_k for k >= 1 and asking the sum to be ε::

        ε_0 = ε − Σ_(k>=1) P(N >= k) ε/2^(k+1) = ε − (ε/2) E[1 − 2^(−N)] = (ε/2) (1 + E[2^(−N)]),

    since Σ_(k>=1) P(N >= k) 2^(−k) = E[Σ_(k=1..N) 2^(−k)]. For N ~ Poisson(λτ) over an exposure
    τ [s] at the rate λ [1/s], E[2^(−N)] = e^(−λτ/2), so ε_0 = (ε/2)(1 + e^(−λτ/2)), between ε/2
    (many drops expected) and ε (none). Under a Gamma belief over λ the predictive
    E[e^(−λτ/2)] is at least e^(−λ̄τ/2) at its mean λ̄ (Jensen), so the mean rate gives the
    smaller, conservative ε_0. τ must bound the flight's remaining exposure (the longest plan's
    remaining time): a longer flight meets more drops than counted."""
    eps, rate, exposure = float(eps), float(rate), float(exposure)
    if not 0.0 < eps < 1.0:
        raise ValueError(f"eps: must be in (0, 1) [-], got {eps!r}")
    if not (math.isfinite(rate) and rate >= 0.0):
        raise ValueError(f"rate: must be finite and >= 0 [1/s], got {rate!r}")
    if not exposure >= 0.0:  # +inf: as many drops as any flight meets, ε/2
        raise ValueError(f"exposure: must be >= 0 [s], got {exposure!r}")
    expected = rate * exposure if rate > 0.0 else 0.0  # λτ (no drops at a rate of 0)
    return 0.5 * eps * (1.0 + math.exp(-0.5 * expected))


def FaultModelFromParams(params: FaultModelParams, scale: float = 1.0) -> FaultModel:
    """The :class:`~eaplan_drake.planning.risk.FaultModel` a ``planner.fault_model`` declares,
    every size times ``scale`` s >= 1 [-] (capped at 1 SoC; the exponential's mean below 1)."""
    s = float(scale)
    if params.sizes == "uniform":
        a, b = (float(v) for v in params.size_bounds)
        sizes = UniformDrops(min(s * a, 1.0 - 1e-9), min(s * b, 1.0))
    elif params.sizes == "exponential":
        sizes = ExponentialDrops(min(s * float(params.size_mean), 0.999))
    else:
        sizes = EmpiricalDrops(tuple(min(s * float(v), 1.0) for v in params.size_values))
    return FaultModel(float(params.rate), sizes)


def _PoissonWeights(mean, n: int) -> np.ndarray:
    """e^(−Λ) Λ^k / k! for k = 0..n−1 (:func:`~eaplan_drake.planning.risk.PoissonPmf`), with
    values below 1e-150 set to 0: subnormal numbers make the table's products slow."""
    pmf = PoissonPmf(mean, n - 1)
    pmf[pmf < _TINY] = 0.0
    return pmf


def _Counts(mean: float) -> int:
    """Counts 0..n−1 to sum: beyond them the Poisson mass is below 1e-12
    (:func:`~eaplan_drake.planning.risk.PoissonCutoff`)."""
    return PoissonCutoff(mean) + 1


@functools.lru_cache(maxsize=32)
def _SizeTails(sizes, counts: int, margin_step: float) -> np.ndarray:
    """Q_n(m) of ``sizes`` for n = 0..``counts`` on the margins 0, h, … 1 (h = ``margin_step``),
    shape (counts + 1, K), values below 1e-150 set to 0 (kept: tables of one size model share
    it)."""
    margins = np.arange(int(round(1.0 / margin_step)) + 1) * margin_step
    q = np.asarray(sizes.sum_tail(counts, margins))  # (K, counts + 1)
    q = np.ascontiguousarray(np.where(q < _TINY, 0.0, q).T)
    q.flags.writeable = False
    return q


@functools.lru_cache(maxsize=64)
def _Tiled(nodes: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The u-quadrature's nodes and weights repeated for ``nodes`` rates, and their row numbers
    (kept per count; read only)."""
    tiled = np.tile(_U, nodes), np.tile(_W, nodes), np.arange(nodes * _U.size)
    for a in tiled:
        a.flags.writeable = False
    return tiled


class ExcessRiskTable:
    """R(p) and m_req for one fault model, from Q_n tabulated on margins 0, h, 2h, … 1
    (``margin_step`` h [-]) for exposures up to ``max_exposure`` [s].

    ``rates``: a belief over the rate as a quadrature, (nodes λ_i [1/s], weights w_i [-] summing to
    at most 1, see :meth:`~eaplan_drake.planning.belief.RateBelief.Quadrature`); every probability
    is then the mixture Σ_i w_i P(· | λ_i) (the u-quadrature repeated for each node), and the
    weight missing from the nodes (1 − Σ w_i, rates too high to tabulate) counts as failure of
    every plan but the lowest: conservative. None: the model's point rate (one node of weight 1).
    """

    def __init__(
        self, model: FaultModel, max_exposure: float, margin_step: float = 1e-3, rates=None
    ):
        if not (math.isfinite(max_exposure) and max_exposure > 0.0):
            raise ValueError(f"max_exposure: must be finite and > 0 [s], got {max_exposure!r}")
        if not (1e-5 <= margin_step <= 0.01):
            raise ValueError(f"margin_step: must be in [1e-5, 0.01] [-], got {margin_step!r}")
        self.model = model
        self.max_exposure = float(max_exposure)
        self.step = float(margin_step)
        self.point = rates is None
        if self.point:
            self.nodes, self.weights, self.slack = np.array([model.rate]), np.ones(1), 0.0
            self.u, self.w, self.row = _U, _W, _ROW
        else:
            self.nodes = np.asarray(rates[0], dtype=float)
            self.weights = np.asarray(rates[1], dtype=float)
            self.slack = max(0.0, 1.0 - float(self.weights.sum()))
            self.u, self.w, self.row = _Tiled(self.nodes.size)
        self.top_rate = float(self.nodes.max())
        self.counts = _Counts(self.top_rate * self.max_exposure) + 1
        # a belief's counts move with it: its tails are kept for counts rounded up to 32s
        kept = self.counts if self.point else -(-self.counts // 32) * 32
        self.q = _SizeTails(model.sizes, kept, self.step)[: self.counts + 1]  # (counts + 1, K)
        self._mixed_key, self._mixed = None, None

    def _CountsFor(self, *means) -> int:
        # the largest of np.max(m, initial=0.0) (a NaN kept as it is)
        largest = max(max(float(m.max()), 0.0) if m.size else 0.0 for m in map(np.asarray, means))
        if largest > self.top_rate * self.max_exposure * (1.0 + 1e-9):
            raise ValueError(
                f"exposure: at most {self.max_exposure:g} s for this table, got "
                f"{largest / self.top_rate:g} s"
            )
        return min(_Counts(largest), self.counts)

    def _TotalDropTail(self, tau_0, m_0):
        if self.point:
            return TotalDropTail(self.model, tau_0, m_0)
        # Σ_i w_i Σ_n Pois(n; λ_i τ_0) Q_n(m_0): the size tails once for every node, and of all
        # the margins at once (each pair's own counts read from them: Q_n(m) is pointwise)
        tau, m = np.broadcast_arrays(np.asarray(tau_0, float), np.asarray(m_0, float))
        out = np.empty(tau.shape)
        counts = [PoissonCutoff(self.top_rate * float(t)) for t in tau.ravel()]
        tails = self.model.sizes.sum_tail(max(counts, default=0), m.ravel())
        for k, (t, margin, n_max) in enumerate(zip(tau.ravel(), m.ravel(), counts, strict=True)):
            q = tails[k, : n_max + 1]
            tail = float(self.weights @ (PoissonPmf(self.nodes * float(t), n_max) @ q))
            out.flat[k] = 1.0 if margin < 0.0 else min(max(tail, 0.0), 1.0)
        return out

    def LowestFailure(self, lowest_time, lowest_margin) -> np.ndarray:
        """P(F_0) = P(S(τ_0) > m_0) [-]: the lowest plan's own risk, exact
        (:func:`~eaplan_drake.planning.risk.TotalDropTail`, once per distinct (τ_0, m_0); with
        ``rates``, its mixture over the nodes)."""
        tau_0, m_0 = np.broadcast_arrays(
            np.asarray(lowest_time, dtype=float), np.asarray(lowest_margin, dtype=float)
        )
        if tau_0.size == 1:
            return np.asarray(self._TotalDropTail(tau_0, m_0)).reshape(tau_0.shape)
        pairs, inverse = np.unique(
            np.stack([tau_0.ravel(), m_0.ravel()]), axis=1, return_inverse=True
        )
        tails = np.atleast_1d(self._TotalDropTail(pairs[0], pairs[1]))
        return tails[inverse.reshape(-1)].reshape(tau_0.shape)

    def LowestFailures(self, lowest_times, lowest_margins) -> np.ndarray:
        """:meth:`LowestFailure` of each pair (τ_0 [s], m_0 [-]) of two 1-d arrays, each the same
        number as its own call gives (with a rate belief, the size tails of all the pairs in one
        call)."""
        times = np.asarray(lowest_times, dtype=float)
        margins = np.asarray(lowest_margins, dtype=float)
        if self.point:
            pairs = zip(times, margins, strict=True)
            return np.array([float(self.LowestFailure(t, m)) for t, m in pairs])
        return np.asarray(self._TotalDropTail(times, margins), dtype=float)

    def Risk(self, plan_time, plan_margin, lowest_time, lowest_margin) -> np.ndarray:
        """R(p) [-] of plans (τ_p [s], m_p [-]) against the lowest plan (τ_0 [s], m_0 [-]);
        broadcasts; 0 for the lowest plan itself; never below the exact value."""
        tau_p, m_p, tau_0, m_0 = np.broadcast_arrays(
            *(
                np.asarray(a, dtype=float)
                for a in (plan_time, plan_margin, lowest_time, lowest_margin)
            )
        )
        return self._Excess(tau_p, m_p, tau_0, m_0, self.LowestFailure(tau_0, m_0))

    def _Excess(self, tau_p, m_p, tau_0, m_0, fail_0, exposure=None) -> np.ndarray:
        """:meth:`Risk` of broadcast arrays, given the lowest plan's own P(F_0) ``fail_0`` (and
        the plans' :meth:`_Exposure` against a single τ_0)."""
        if tau_0.size and np.all(tau_0 == tau_0.flat[0]):
            fail_p = self._PlanFailure(tau_p, m_p, float(tau_0.flat[0]), m_0, exposure)
        else:  # one lowest plan per candidate
            fail_p = np.vectorize(self._PlanFailure)(tau_p, m_p, tau_0, m_0)
        ordered = (tau_p >= tau_0) & (m_p <= m_0)
        risk = np.where(ordered, fail_p - fail_0, np.minimum(fail_p, 1.0 - fail_0))
        lowest = (tau_p == tau_0) & (m_p == m_0)
        return np.where(lowest, 0.0, np.clip(risk, 0.0, 1.0))

    def _Mixed(self, tau_0: float, n: int, columns: int | None = None) -> np.ndarray:
        """G_u(m) on the margin grid (U, K) for the lowest plan time τ_0 [s] and n counts, the
        last one kept (the search of :meth:`RequiredMargin` reads it at every stage); with
        ``columns``, only the first ``columns`` margins of the grid (those the search reads)."""
        if self._mixed_key != (tau_0, n, columns):
            if self.point:
                later = _PoissonWeights(self.model.rate * tau_0 * (1.0 - _U), n)  # (U, n)
            else:  # the u-quadrature for each node in turn (N·U, n)
                later = _PoissonWeights(((self.nodes * tau_0)[:, None] * (1.0 - _U)).ravel(), n)
            self._mixed = later @ self.q[1 : n + 1, :columns]
            self._mixed_key = (tau_0, n, columns)
        return self._mixed

    def _Exposure(self, tau_p, tau_0: float, columns: int | None = None) -> tuple:
        """What P(F_p) needs of the plans' times τ_p [s] alone, for every trial margin: Λ_p,
        G_u on the margin grid (U, K; the first ``columns`` margins only, when given), the
        quadrature weights times the first drop's density Λ_p e^(−Λ_p u), and e^(−Λ_p)."""
        if self.point:
            lam = self.model.rate
            mean_p = lam * np.asarray(tau_p, dtype=float)
            n = self._CountsFor(mean_p, lam * tau_0)
            mixed = self._Mixed(float(tau_0), n, columns)  # (U, K): G_u on the margin grid
            weighted = _W * (mean_p[..., None] * np.exp(-mean_p[..., None] * _U))
            return mixed, weighted, np.exp(-mean_p)
        tau = np.asarray(tau_p, dtype=float)
        mean_p = tau[..., None] * self.nodes  # (..., N)
        n = self._CountsFor(mean_p, self.top_rate * tau_0)
        mixed = self._Mixed(float(tau_0), n, columns)  # (N·U, K)
        density = mean_p[..., None] * np.exp(-mean_p[..., None] * _U)  # (..., N, U)
        weighted = (self.weights[:, None] * density).reshape(tau.shape + (-1,)) * self.w
        return mixed, weighted, np.exp(-mean_p) @ self.weights

    def _PlanFailure(self, tau_p, m_p, tau_0: float, m_0, exposure=None) -> np.ndarray:
        """P(F_p) (an upper bound) for plans against one lowest plan time τ_0: the drops after
        the first one, G_u(m) = Σ_n Pois(n; Λ_0 (1 − u)) Q_(n+1)(m), tabulated once over the
        margin grid for the quadrature's u, then read at M(u) for every plan. ``exposure``: the
        plans' :meth:`_Exposure`, when the caller reads many margins of the same plans."""
        mixed, weighted, none = exposure or self._Exposure(tau_p, tau_0)
        u = self.u
        margin = u * np.asarray(m_p)[..., None] + (1.0 - u) * np.asarray(m_0)[..., None]
        # the grid point at or below each margin (truncation is the floor of these m >= 0), read
        # from the flattened (U, K) table
        index = (np.clip(margin, 0.0, 1.0) / self.step).astype(int) + self.row * mixed.shape[1]
        tail = np.where(margin < 0.0, 1.0, np.take(mixed, index))  # (..., U)
        fail = np.sum(weighted * tail, axis=-1) + none * (np.asarray(m_p) < 0.0)
        return fail if self.point else fail + self.slack

    def RequiredMargin(
        self,
        plan_time,
        lowest_time: float,
        lowest_margin: float,
        eps: float,
        baseline_failure: float | None = None,
        lowest_failure: float | None = None,
    ):
        """m_req(τ_p) [-] for each plan time τ_p [s]: the smallest m_p ≤ m_0 with R ≤ ``eps``,
        to m_0 / 32² (two stages of 32 margins each, rounded up: conservative, deterministic);
        0 if m_p = 0 already is; +inf if not even m_0 is. With m_0 ≤ 0 (the lowest plan fails
        without any fault) it is 0: nothing to protect.

        ``baseline_failure``: the failure probability [-] the excess is measured from when it is
        below the lowest plan's own P(F_0) (the mission's anchor, see the module docstring):
        R = P(F_p) − min(P(F_0), baseline), never less conservative than against P(F_0).
        ``lowest_failure``: the lowest plan's P(F_0) [-] when the caller has it
        (:meth:`LowestFailure` of (``lowest_time``, ``lowest_margin``)), else computed here."""
        tau_p = np.asarray(plan_time, dtype=float).reshape(-1)
        m_0 = float(lowest_margin)
        if m_0 <= 0.0 or tau_p.size == 0:
            return np.zeros_like(tau_p)
        # the exposure of a plan is the same for all its trial margins: computed once per plan
        # (broadcast over the trials)
        tau = tau_p[:, None]
        tau_0, lowest = np.asarray(float(lowest_time)), np.asarray(m_0)
        fail_0 = lowest_failure
        if fail_0 is None:
            fail_0 = self.LowestFailure(float(lowest_time), m_0)  # once for every trial
        fail_0 = np.asarray(fail_0, dtype=float)
        if baseline_failure is not None:
            fail_0 = np.minimum(fail_0, float(baseline_failure))
        # every trial margin and M(u) lie in [0, m_0]: the grid's margins up to m_0 are read
        # (floor(M/h) ≤ floor(m_0/h) + 1 with rounding), the rest is never computed
        columns = min(self.q.shape[1], int(m_0 / self.step) + 2)
        mixed, weighted, _ = self._Exposure(tau, float(tau_0), columns)  # e^(−Λ_p): m_p < 0 only
        search = _Search(self, tau, tau_0, lowest, fail_0, eps, mixed, weighted)
        # R falls as the margin grows: a plan that even m_p = m_0 does not keep within ε keeps
        # no margin within it (+inf, most plans late in a flight); the others are searched
        lo, width = np.zeros_like(tau_p), np.full_like(tau_p, m_0)
        rows = np.flatnonzero(search.Within(_Trials(lo, width, _LAST_TRIAL))[:, 0])
        hi = np.full_like(tau_p, np.inf)
        if rows.size:
            search, lo, width = search.Rows(rows), lo[rows], width[rows]
            for _ in range(2):
                first = search.FirstWithin(lo, width)
                hi[rows] = lo + width * first / _SEARCH
                lo = np.where(first > 0, hi[rows] - width / _SEARCH, hi[rows])
                width = hi[rows] - lo
        return hi


class _Search:
    """R ≤ ε of trial margins for plans of times τ_p (rows) against one lowest plan (τ_0, m_0 > 0):
    :meth:`ExcessRiskTable._Excess` ≤ ε with what does not depend on the trial margin computed
    once (the same operations on the same values). Every trial margin m_p is in [0, m_0], so
    M(u) = u m_p + (1 − u) m_0 is never negative: the branches of a negative margin drop out."""

    def __init__(self, table, tau, tau_0, m_0, fail_0, eps, mixed, weighted):
        self.table, self.tau_0, self.m_0 = table, tau_0, m_0
        self.fail_0, self.eps = fail_0, eps
        self.mixed = mixed
        self.u = table.u
        self.rest = (1.0 - self.u) * m_0[..., None]  # (1 − u) m_0 of M(u)
        self.offset = table.row * self.mixed.shape[1]
        self._SetPlans(tau, weighted)
        self.spare = 1.0 - fail_0
        self.capped = not float(m_0) < 1.0
        # clip(R, 0, 1) ≤ ε is R ≤ ε for 0 ≤ ε < 1 (and NaN fails both)
        self.clipped = not 0.0 <= eps < 1.0

    def Rows(self, rows) -> "_Search":
        """The same search for the plans ``rows`` only."""
        search = object.__new__(_Search)  # what does not depend on the plans is shared
        search.__dict__.update(self.__dict__)
        search._SetPlans(self.tau[rows], self.weighted[rows])
        return search

    def _SetPlans(self, tau, weighted) -> None:
        """The plans' times τ_p (rows) and their quadrature weights, and what follows from them."""
        self.tau, self.weighted = tau, weighted
        self.longer, self.level = tau >= self.tau_0, tau == self.tau_0
        self.all_longer, self.any_level = bool(self.longer.all()), bool(self.level.any())

    def Within(self, trials) -> np.ndarray:
        """R ≤ ε at the trial margins (rows, k) [-], all in [0, m_0]."""
        margin = self.u * trials[..., None] + self.rest
        if self.capped:  # m_0 > 1: the margins above 1 read the grid's last column
            margin = np.minimum(margin, 1.0)
        index = (margin / self.table.step).astype(int) + self.offset
        fail_p = np.add.reduce(self.weighted * np.take(self.mixed, index), axis=-1)
        if not self.table.point:
            fail_p = fail_p + self.table.slack
        ordered = trials <= self.m_0
        if not self.all_longer:
            ordered &= self.longer
        risk = np.where(ordered, fail_p - self.fail_0, np.minimum(fail_p, self.spare))
        within = (np.clip(risk, 0.0, 1.0) if self.clipped else risk) <= self.eps
        if self.any_level:  # the lowest plan itself: R = 0
            within |= self.level & (trials == self.m_0)
        return within

    def FirstWithin(self, lo, width) -> np.ndarray:
        """The first of the trials m = lo + width·k/32, k = 0..32, with R ≤ ε (32 if none) per
        plan. R falls as the margin grows, so the trials are read coarse to fine: every 4th,
        then the 3 between the first within ε and the one before it: the same answer as reading
        all 33, from 12 of them."""
        ok = self.Within(_Trials(lo, width, _COARSE_TRIALS))
        some = ok.any(axis=1)
        c = np.where(some, np.argmax(ok, axis=1), _COARSE_TRIALS.size - 1)
        between = np.maximum(c - 1, 0)[:, None] * _COARSE + np.arange(1, _COARSE)
        fine = self.Within(_Trials(lo, width, between))
        first = np.where(fine.any(axis=1), between[:, 0] + np.argmax(fine, axis=1), c * _COARSE)
        return np.where((c == 0) | ~some, c * _COARSE, first)


@functools.lru_cache(maxsize=16)
def _CachedTable(model: FaultModel, exposure_bucket: float) -> ExcessRiskTable:
    return ExcessRiskTable(model, exposure_bucket)


def RiskTable(model: FaultModel, exposure: float) -> ExcessRiskTable:
    """The :class:`ExcessRiskTable` of ``model`` for exposures up to ``exposure`` [s], built once
    per process for each power of two of seconds (at least 1024 s) and reused: a pure function of
    its arguments, so flights stay deterministic."""
    return _CachedTable(model, ExposureBucket(exposure))


def ExposureBucket(exposure: float) -> float:
    """The exposure [s] :func:`RiskTable` builds its table for: the smallest power of two of
    seconds, at least 1024 s, not below ``exposure``."""
    bucket = 1024.0
    while bucket < exposure:
        bucket *= 2.0
    return bucket
