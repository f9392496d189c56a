"""The margin m(t) [-] the mpc asks a plan with t [s] of survey left to keep above the reserve
b_res (:doc:`/planner`, Eq. (3)), one model per kind of reserve:

    m(t) = m_floor + m_fault(t) + z s_b σ_α0 t,

- :class:`FloorMargin`: m_floor alone (no fault reserve, no uncertainty): the check of "nominally
  feasible";
- :class:`FixedReserveMargin`: m_fault(t) = R_f (``planner.reserve: fixed``, τ_f = 0);
- :class:`TimedReserveMargin`: m_fault(t) = R_f min(1, t/τ_f) (``reserve: fixed``, τ_f > 0);
- :class:`RiskMargin`: m_fault(t) = m_req(t), the margin that keeps a plan's excess risk within
  the step's budget ε_k (``reserve: risk``, :mod:`eaplan_drake.planning.risk_margin`), built for one
  planner step by :class:`RiskReserve`;
- :class:`UnpricedMargin`: m_fault = +∞, a step the risk tables cannot price (the lowest plan's
  own margin not finite, or its exposure beyond what the tables hold): no plan is feasible, and
  the planner flies the lowest plan and says so.

Each answers m(t) (:meth:`Margin.At`), dm/dt (:meth:`Margin.Slope`) and the margin the
recursive-feasibility condition (2) asks of the lowest plan (:meth:`Margin.Recursive`). A margin
is built for one planner step (its uncertainty rate z s_b σ_α0 [1/s] is the step's).
"""

import math

import numpy as np
from pydrake.common.containers import namedview

from eaplan_drake.params import MAX_EXPECTED_DROPS, PlannerParams
from eaplan_drake.planning.belief import PRIOR_DROPS, RateBelief
from eaplan_drake.planning.interpolation import Pchip, PchipSlopes, PchipValue
from eaplan_drake.planning.learnt_sizes import DirichletDrops
from eaplan_drake.planning.risk import FaultModel, TotalDropTail
from eaplan_drake.planning.risk_margin import (
    UNREACHABLE_MARGIN,
    ExcessRiskTable,
    ExposureBucket,
    FaultModelFromParams,
    FirstDropBudget,
    RiskTable,
)

__all__ = [
    "LEARNT_SIZES",
    "NEGLIGIBLE_NODE",
    "FixedReserveMargin",
    "FloorMargin",
    "Margin",
    "RiskMargin",
    "RiskMemory",
    "RiskReserve",
    "StepMargin",
    "TimedReserveMargin",
    "UnpricedMargin",
]


NEGLIGIBLE_NODE = 1e-6
"""A rate node of a belief's quadrature with less weight than this [-] is left to the table's
slack (counted as failure of every plan but the lowest: ≤ 1e-6 more excess risk per node, and
the high rates' long count tails are not summed)."""


LEARNT_SIZES = 4
"""How many detected drop sizes the mpc's memory keeps for its learnt sizes (``prior_sizes``):
the first ones of a flight; later drops still halve the budget."""

RiskMemory = namedview(
    "RiskMemory",
    ["predicted_soc", "drops", "anchor_end", "anchor_margin"]
    + [f"size_{i + 1}" for i in range(LEARNT_SIZES)]
    + ["first_budget"],
)
"""The tail of :class:`~eaplan_drake.planning.policies.MpcPolicy`'s memory with ``reserve: risk``
(after the warm start): ``predicted_soc`` b̂ [-], the SoC the last step predicted for now
(``UNSET`` before the first step); ``drops``, the drops detected so far; ``anchor_end`` [s], the
time at which the lowest plan of the state where the current budget opened ends (``UNSET`` until
a step sets it: at the first step, and after each drop); ``anchor_margin`` m_a [-], that plan's
fault-free margin; ``size_1`` … the sizes of the first :data:`LEARNT_SIZES` drops [-] (b̂ − b at
the drop, rounded up to :data:`~eaplan_drake.planning.belief.SIZE_RESOLUTION`; 0 until seen);
``first_budget`` ε_0 [-] with ``planner.first_budget: reach``, set at the first step
(:meth:`RiskReserve.FirstBudget`; ``UNSET`` before it, and with ``half``)."""


class Margin:
    """m(t) = m_floor + m_fault(t) + rate · t [-]; a subclass defines the fault reserve m_fault.

    Args:
        floor: m_floor [-] (``planner.margin_floor``).
        rate: z s_b σ_α0 [1/s], the growth of the drain error with the time left.
    """

    def __init__(self, floor: float, rate: float):
        self.floor = float(floor)
        self.rate = float(rate)

    def FaultReserve(self, t):
        """m_fault(t) [-] at the remaining times t [s] (an array)."""
        raise NotImplementedError

    def FaultReserveSlope(self, t: float) -> float:
        """dm_fault/dt [1/s] at the remaining time t [s] (right derivative at a kink)."""
        raise NotImplementedError

    def At(self, t):
        """m(t) [-] for the remaining time t [s]."""
        t = np.asarray(t, dtype=float)
        return self.floor + self.FaultReserve(t) + self.rate * t

    def Slope(self, t: float) -> float:
        """dm/dt [1/s] at the remaining time t [s] (right derivative at a kink)."""
        return self.rate + self.FaultReserveSlope(t)

    def Recursive(self, t):
        """The margin (2) asks of the lowest plan after this step [-]: m(t)."""
        return self.At(t)


class FloorMargin(Margin):
    """m(t) = m_floor: neither the uncertainty term nor a fault reserve."""

    def __init__(self, floor: float):
        super().__init__(floor, 0.0)

    def FaultReserve(self, t):
        return np.zeros_like(t)

    def FaultReserveSlope(self, t: float) -> float:
        return 0.0


class FixedReserveMargin(Margin):
    """m_fault(t) = R_f [-] whatever the time left (``fault_reserve_time`` = 0)."""

    def __init__(self, floor: float, rate: float, reserve: float):
        super().__init__(floor, rate)
        self.reserve = float(reserve)

    def FaultReserve(self, t):
        return np.full_like(t, self.reserve)

    def FaultReserveSlope(self, t: float) -> float:
        return 0.0


class TimedReserveMargin(Margin):
    """m_fault(t) = R_f min(1, t/τ_f) [-]: faults come at a rate, so the reserve shrinks with the
    exposure left (``fault_reserve`` R_f, ``fault_reserve_time`` τ_f > 0 [s])."""

    def __init__(self, floor: float, rate: float, reserve: float, reserve_time: float):
        super().__init__(floor, rate)
        self.reserve = float(reserve)
        self.reserve_time = float(reserve_time)

    def FaultReserve(self, t):
        return self.reserve * np.minimum(1.0, np.maximum(t, 0.0) / self.reserve_time)

    def FaultReserveSlope(self, t: float) -> float:
        return self.reserve / self.reserve_time if t < self.reserve_time else 0.0


class RiskMargin(Margin):
    """m_fault(t) = m_req(t) [-]: the risk margin of one planner step, the PCHIP interpolant of its
    values at the step's remaining times (constant beyond them; :class:`RiskReserve` builds it).

    (2) asks only m_floor + rate · t of the lowest plan: its own fault risk is the world's, what
    every policy falls back to.

    Attributes:
        times: the remaining times [s] of the nodes (ascending).
        margins: m_req at ``times`` [-].
        lowest_state: (τ_0 [s], m_0 [-]): the lowest plan's remaining time and fault-free margin
            the excess risk is measured against.
        budget: ε_k [-], the excess risk the step may spend.
    """

    def __init__(self, floor, rate, times, margins, lowest_state, budget):
        super().__init__(floor, rate)
        self.times = np.asarray(times, dtype=float)
        self.margins = np.asarray(margins, dtype=float)
        self.slopes = PchipSlopes(self.times, self.margins)
        self.lowest_state = (float(lowest_state[0]), float(lowest_state[1]))
        self.budget = float(budget)

    def FaultReserve(self, t):
        return PchipValue(self.times, self.margins, self.slopes, t)

    def FaultReserveSlope(self, t: float) -> float:
        return float(Pchip(self.times, self.margins, self.slopes, t)[1])

    def Recursive(self, t):
        return self.floor + self.rate * np.asarray(t, dtype=float)


class UnpricedMargin(Margin):
    """m_fault(t) = +∞: a step whose risk cannot be priced (``why`` says what was out of range);
    (2) asks m_floor + rate · t of the lowest plan, as with :class:`RiskMargin`."""

    def __init__(self, floor: float, rate: float, why: str):
        super().__init__(floor, rate if math.isfinite(rate) else 0.0)
        self.why = why

    def FaultReserve(self, t):
        return np.full_like(t, np.inf)

    def FaultReserveSlope(self, t: float) -> float:
        return 0.0

    def Recursive(self, t):
        return self.floor + self.rate * np.asarray(t, dtype=float)


class RiskReserve:
    """The risk reserve of a flight (``planner.reserve: risk``): the fault model and its risk
    tables (built once per exposure bucket and kept), from which each step's
    :class:`RiskMargin` is computed.

    Args:
        planner: the planner parameters (``fault_model``, ``margin_floor``).
    """

    def __init__(self, planner: PlannerParams):
        self.stated_model = FaultModelFromParams(planner.fault_model)
        """The stated point model (``rate``, the sizes as stated)."""
        self.fault_model = FaultModelFromParams(
            planner.fault_model, planner.fault_model.prior_size_scale
        )
        """The point model the planner prices with before any update: the stated rate, and the
        stated sizes times ``prior_size_scale``."""
        fault = planner.fault_model
        self.rate_belief = None
        """The belief over the rate before the flight (a
        :class:`~eaplan_drake.planning.belief.RateBelief` when ``fault_model`` holds one, from
        its ``prior_drops`` and records), or None: the point rate."""
        if fault.HoldsBelief():
            self.rate_belief = RateBelief.FromRecords(
                int(fault.recorded_drops),
                float(fault.recorded_hours) * 3600.0,
                prior_rate=float(fault.rate),
                prior_drops=float(fault.prior_drops) or PRIOR_DROPS,
            )
        self.prior_sizes = float(fault.prior_sizes)
        """K [-], the sizes the declared size model is worth (0: the sizes do not learn)."""
        self.floor = float(planner.margin_floor)
        self._tables: dict = {}
        self.prior_rate = (
            self.fault_model.rate if self.rate_belief is None else self.rate_belief.mean
        )
        """λ̄ [1/s], the mean rate believed before the flight: the stated ``rate``, or the
        belief's mean after the fleet's records."""
        rate = self.prior_rate
        bucket = math.inf
        if rate > 0.0:  # the largest table whose expected drops stay within the risk module's
            bucket = ExposureBucket(0.0)
            while rate * 2.0 * bucket <= MAX_EXPECTED_DROPS:
                bucket *= 2.0
            if rate * bucket > MAX_EXPECTED_DROPS:
                bucket = 0.0
        self.max_exposure = bucket
        """The longest exposure [s] the risk tables price (λ × it ≤ ``MAX_EXPECTED_DROPS``); a
        plan longer than this cannot be priced and is infeasible."""

    def FirstBudget(self, eps: float, exposure: float) -> float:
        """ε_0 [-] of ``planner.first_budget: reach`` for the budget ``eps`` ε [-] and the
        longest plan's remaining time ``exposure`` τ [s]
        (:func:`~eaplan_drake.planning.risk_margin.FirstDropBudget` at :attr:`prior_rate`)."""
        return FirstDropBudget(eps, self.prior_rate, exposure)

    def Model(self, observed=()) -> FaultModel:
        """The fault model after the drop sizes ``observed`` [-] detected in flight: the declared
        one, or with ``prior_sizes`` K > 0 and some sizes observed, its rate with the learnt
        sizes :class:`~eaplan_drake.planning.learnt_sizes.DirichletDrops` (K, the observed
        sizes)."""
        if not observed or self.prior_sizes <= 0.0:
            return self.fault_model
        sizes = DirichletDrops(self.fault_model.sizes, tuple(observed), self.prior_sizes)
        return FaultModel(self.fault_model.rate, sizes)

    def Table(self, exposure: float, observed=(), flown: float = 0.0, drops: int = 0):
        """The :class:`~eaplan_drake.planning.risk_margin.ExcessRiskTable` of :meth:`Model`
        (``observed``) for exposures up to ``exposure`` [s] (kept per bucket and sizes); with a
        rate belief, priced under it after ``flown`` [s] with ``drops`` detected (a table of the
        step: its quadrature nodes, those the tables cannot hold left to the table's slack; None
        when the tables hold none of them)."""
        bucket = ExposureBucket(float(exposure))
        model = self.Model(observed)
        if self.rate_belief is not None:
            belief = self.rate_belief.Update(max(float(flown), 0.0), int(drops))
            nodes, weights = belief.Quadrature()
            keep = (nodes * bucket <= MAX_EXPECTED_DROPS) & (weights >= NEGLIGIBLE_NODE)
            if not keep.any():  # every rate the belief holds is beyond the tables
                return None
            model = FaultModel(belief.mean, model.sizes)
            return ExcessRiskTable(model, bucket, rates=(nodes[keep], weights[keep]))
        key = (bucket, model)
        table = self._tables.get(key)
        if table is None:
            table = self._tables[key] = RiskTable(model, bucket)
        return table

    def DropTail(self, times, margins) -> np.ndarray:
        """P(S(τ) > m) [-] for exposures ``times`` τ [s] and ``margins`` m [-] (arrays of one
        shape) under the stated point model (:attr:`stated_model`: ``rate`` and the sizes as
        stated, :func:`~eaplan_drake.planning.risk.TotalDropTail`): what a plan that never
        updates (``static_takeoff``) is priced with. The doubting, learning belief is the mpc's:
        its caution before the first drop is paid back only by what the flight teaches, and a
        static plan learns nothing."""
        times, margins = np.asarray(times, float), np.asarray(margins, float)
        return TotalDropTail(self.stated_model, times, margins)

    def Margin(
        self,
        rate,
        times,
        lowest_time,
        lowest_margin,
        budget,
        anchor=None,
        observed=(),
        flown: float = 0.0,
        drops: int = 0,
    ) -> RiskMargin:
        """The step's :class:`RiskMargin`.

        Args:
            rate: z s_b σ_α0 [1/s].
            times: the grid's remaining times [s] (capped at the prediction's length; any order).
            lowest_time: τ_0 = t_rem(c̲1) [s].
            lowest_margin: m_0 [-], the lowest plan's fault-free margin above b_res + m_floor +
                rate · τ_0.
            budget: ε_k [-].
            anchor: (τ_a [s] still to fly, m_a [-]), the lowest plan where the budget opened: the
                excess is measured from min(P(F_0), P(S(τ_a) > m_a)); None: from P(F_0).
            observed: the drop sizes [-] detected so far (the sizes learn from them, see
                :meth:`Model`).
            flown: the time flown [s] (a rate belief learns from it, see :meth:`Table`).
            drops: the drops detected so far (likewise).
        """
        times = np.asarray(times, dtype=float)
        if np.all(times[1:] >= times[:-1]):  # the staircase ascends: np.unique without its sort
            times = times[np.concatenate(([True], times[1:] != times[:-1]))]
        else:
            times = np.unique(times)
        m_0, tau_0 = float(lowest_margin), float(lowest_time)
        if not (math.isfinite(m_0) and math.isfinite(rate)):
            return UnpricedMargin(
                self.floor, rate, "the lowest plan's predicted margin is not finite"
            )
        if not tau_0 <= self.max_exposure:
            return UnpricedMargin(
                self.floor,
                rate,
                f"the lowest plan's {tau_0:.0f} s of survey exceed the {self.max_exposure:g} s "
                "the fault model's tables price",
            )
        priced = times <= self.max_exposure
        table = self.Table(float(times[priced][-1]), observed, flown, drops)
        if table is None:
            return UnpricedMargin(
                self.floor,
                rate,
                f"after {int(drops)} drops the fault rate believed is beyond what the tables price",
            )
        # P(F_0) of the lowest plan, and of the anchor's when there is one: in one call
        pairs = [(tau_0, m_0)]
        if anchor is not None:
            tau_a, m_a = anchor
            if math.isfinite(m_a) and tau_a <= self.max_exposure:
                pairs.append((max(tau_a, 0.0), m_a))
        failures = table.LowestFailures(*np.array(pairs, dtype=float).T)
        baseline = float(failures[1]) if len(pairs) > 1 else None
        margins = np.full(times.size, np.inf)
        margins[priced] = table.RequiredMargin(
            times[priced], tau_0, m_0, float(budget), baseline, lowest_failure=failures[0]
        )
        # a plan no margin keeps within ε (or too long to price: its excess risk counts as 1)
        # needs more than the lowest plan has: just above m_0 (not +inf), which excludes it as
        # surely and keeps the NLP's constraint gentle
        margins = np.minimum(margins, max(m_0, 0.0) + UNREACHABLE_MARGIN)
        return RiskMargin(self.floor, rate, times, margins, (lowest_time, m_0), budget)


def StepMargin(planner: PlannerParams, rate: float) -> Margin:
    """The fixed-reserve margin of ``planner`` for a step whose uncertainty rate is ``rate``
    [1/s]: :class:`FixedReserveMargin` when ``fault_reserve_time`` is 0, else
    :class:`TimedReserveMargin`."""
    floor, reserve = float(planner.margin_floor), float(planner.fault_reserve)
    reserve_time = float(planner.fault_reserve_time)
    if reserve_time <= 0.0:
        return FixedReserveMargin(floor, rate, reserve)
    return TimedReserveMargin(floor, rate, reserve, reserve_time)
