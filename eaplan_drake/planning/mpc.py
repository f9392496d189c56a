"""Mission-feasible MPC: the default planner formulation (beyond paper 003).

Every h_T [s] the planner chooses the path parameter c1 [m²] and the σ computation parameters
c2 [table units] from the estimated energy state q̂ [W] (and the variance of its mean α0 [W²]),
the SoC b0 [-], the period T [s] and the exact remaining survey time t_rem(c1_j) [s] at the M
values c1_1 < … < c1_M of a grid (the sequencer's ``remaining_time``: the plan's staircase in the
current wind, whole repetitions, not the Eq. 10 line).

**Why not the paper's formulation.** Its output constraint y ≤ b·Q_c·V (Def. III.3) compares
watts with watt-hours and is infeasible for every c2 once b < ≈ 0.64, so the slack, not the
energy budget, decides c2; its c1 comes from the Eq. 10 line, off by up to 132 s against the
plan; and it plans to a zero margin. This formulation decides c1 and c2 together on the plan the
aircraft will actually fly.

**The plan.** The decision is the pair (c1, c2) the *rest of the mission* is flown with (a
shrinking-horizon MPC with one move block: the horizon is the rest of the survey, re-planned every
h_T). Committing to the plan matters for c1: it only shapes the path when a turn is entered, so a
rule that is judged one step ahead ("highest quality now") would report a high c1 between turns
and cut it at each turn. With q̂ the prediction of the power is

    y(t) = C expm(A t) q̂ + g(c2) − g(c_now) =: f(t) + Δg(c2),        t ≥ 0 from now,

(:func:`~eaplan_drake.energy.fourier.FreeResponseMatrix`, exact rotation blocks), and the Rint
battery ḃ = −k_b I(y)/Q_c gives the SoC b(t; c2) by Simpson's rule on the grid of h_T
(:func:`~eaplan_drake.planning.prediction.SimpsonSoc`, exact up to O(h⁵) per step), linearly
interpolated in
between. The plan (c1_j, c2) is *feasible* when

    b(t_rem(c1_j); c2) ≥ b_res + m(t_rem(c1_j))                                    (1)
    b(h_T; c2) − b(h_T; c̲2) + b(t_rem(c̲1); c̲2) ≥ b_res + m(t_rem(c̲1))              (2)

and no load on the way browns the battery out. (2) is the recursive-feasibility condition: from
the predicted state after this step, falling back to the lowest-quality parameters (c̲1, c̲2)
still completes the survey above the reserve b_res plus the margin. (Over one step the aircraft
flies the same path whatever c1 is, so the fallback's remaining time after the step is
t_rem(c̲1) − h_T.) If the predictions hold, the plan chosen now stays feasible at the next step,
so the problem never becomes infeasible by the planner's own doing; when a fault or any surprise
makes even the lowest plan infeasible, the planner says so (``mission_feasible`` = 0) and flies
the lowest plan. While only the uncertainty term or the fault reserve excludes the lowest plan
(the estimate has not settled yet, or the fault reserve is partly spent) it flies the lowest
plan without the flag.

**Margin.** m(t) = m_floor + m_fault(t) + z · s_b · t · σ_α0 for a plan with t seconds of survey
left: a configurable floor (0.02); a reserve for battery faults nobody can foresee,
m_fault(t) = R_f · min(1, t/τ_f) (``fault_reserve`` R_f = 0.10 by default, one fault of the size
of the reference plan i's, −6 % and −9 %; ``fault_reserve_time`` τ_f = 300 s by default: faults
come at a rate, so the reserve shrinks with the exposure that is left; τ_f = 0 holds R_f to the
end); and z
standard deviations of the drain error that an error σ_α0 = sqrt(P_00) [W] of the estimated mean
power causes over t seconds, with s_b = k_b/(Q_c sqrt(V² − 4 R_r y0)) [1/(W s)] the SoC rate per
watt at the mean load y0 = α̂0. m never grows as the survey goes on (t only decreases), so the
margin does not break recursive feasibility.

**What is guaranteed, and what cannot be.** Before the planner first acts (``warmup``: the
estimate of the mean power is unreliable before about one period) the aircraft flies the lowest
plan (``warmup_parameters: lowest``), so nothing is spent before the first check. From then on,
while the predictions hold, the lowest plan ends at least b_res + m_floor + m_fault above empty
after every step; an SoC drop d ≤ m_fault(t) (the drops of a flight adding up to at most the
reserve held when they come) leaves it at least b_res + m_floor, and the planner then flies the
lowest plan when it must: the survey is completed. Larger drops are not covered, and no policy
can cover them without giving up quality everywhere: if the lowest plan ends ε above the reserve
in a world with a drop late in the flight, every policy that has spent more than ε by then
fails, and before the drop the world looks the same as one without it. The fault reserve sets
that trade (:ref:`policy-guarantee`).

**Objective.** The paper's metric rewards the time-weighted mean of ½c̃1 + ½c̃2; the planner
maximises the quality of the plan, J = (w1 c̃1 + w2 mean_i c̃2_i)/(w1 + w2) with c̃ the parameters
normalised to [0, 1] by their bounds. Ties are broken by the larger end SoC.

**The discrete problem and its NLP.** c1 ranges over the M grid values, c2 over the table's
grid (integer parameters). Brute force (:meth:`MissionProblem.BruteForce`) enumerates it exactly.
The NLP (:class:`~eaplan_drake.planning.relaxation.MissionProgram`, ``MathematicalProgram`` +
IPOPT or SNOPT (``planner.solver``), bounded by iterations only) is
its continuous relaxation: variables c̃1 ∈ [0, 1] and c̃2 ∈ [0, 1]^σ, linear cost −J, and the
constraints (1), (2) with t_rem(c̃1) replaced by the lower convex hull of the staircase (the
tightest convex under-estimate: with it the relaxation's optimum sits at the ends of plateaus,
where the discrete optimum lies; smoothed by a monotone C¹ cubic) and g
the smooth surrogate of the table (quadratic least-squares fit, or the Eq. 11 line). The relaxed
optimum is mapped back exactly: the c2 grid points that bracket it (and the lowest) each get the
largest grid c1 feasible with the exact table and the exact staircase, and the best of those by
J is the start of a local search that moves c2 one grid step at a time (each with its largest
feasible c1) while the plan improves; the result is the decision. A failed solve keeps the previous
c1 and takes the best c2 that the exact check admits at it. The mapping reads c̃2 only through the
grid points that bracket it, so when every bracket leads to one plan
(:meth:`MissionProblem.DeterminedDecision`) that plan is the decision and no solve is run: the
same decision at a fraction of the cost.
"""

import copy
import dataclasses as dc
import itertools
import math

import numpy as np

from eaplan_drake.energy.battery_model import AsBatteryModel
from eaplan_drake.energy.computation import ComputationTable
from eaplan_drake.energy.fourier import FreeResponseMatrix, StateSize
from eaplan_drake.params import MAX_TIME_LIMIT, BatteryParams, PlannerParams
from eaplan_drake.planning.grid_search import GridSearch
from eaplan_drake.planning.prediction import (
    GridCandidates,
    PowerSurrogate,
    SimpsonSoc,
)
from eaplan_drake.planning.relaxation import _Pchip, _PchipSlopes
from eaplan_drake.planning.risk_margin import (
    UNREACHABLE_MARGIN,
    ExposureBucket,
    FaultModelFromParams,
    RiskTable,
)
from eaplan_drake.planning.smooth import SmoothModel

__all__ = [
    "MissionDecision",
    "MissionProblem",
]


@dc.dataclass
class MissionDecision:
    """One answer of the mission problem (indices into the problem's grids)."""

    path_index: int
    """j: c1 = grid[j]."""
    candidate_index: int
    """k: c2 = candidates[k] (or the continuous ``computation_parameters``)."""
    path_parameter: float
    """c1 [m²]."""
    computation_parameters: np.ndarray
    """c2 (σ,) [table units]."""
    quality: float
    """J of the plan [-]."""
    end_soc: float
    """Predicted SoC at the end of the survey under the plan [-]."""
    margin: float
    """Margin m(t_rem) the plan keeps above the reserve [-]."""
    feasible: bool
    """The plan satisfies (1) and (2); False only when even the lowest plan does not."""


class MissionProblem(GridSearch, SmoothModel):
    """The exact discrete problem of one planner step (see the module docstring).

    Args:
        planner: planner parameters (period h_T, weights, margin, grid of c1).
        table: the computation power table g (exact; its grid = the admissible c2).
        order: Fourier order r of the energy model (q̂ has 2r + 1 entries).
        battery: Rint battery parameters (reserve_soc is b_res).
        path_parameter_grid: the M values of c1 [m²] (ascending) of ``remaining_time``.
        integer: c2 takes only grid values (else the NLP's continuous optimum is a candidate).

    The parameters are copied: later changes to the caller's objects do not reach the problem.
    """

    def __init__(
        self,
        planner: PlannerParams,
        table: ComputationTable,
        order: int,
        battery: BatteryParams,
        path_parameter_grid,
        integer: bool = True,
    ):
        planner = copy.deepcopy(planner)
        battery = copy.deepcopy(battery)
        self.params = planner
        self.table = table
        self.battery = battery
        self.battery_model = AsBatteryModel(battery)
        self.order = order  # int r, or AugmentedOrder (energy_model)
        self.state_size = StateSize(order)
        self.integer = bool(integer)
        self.step = float(planner.period)
        grid = np.asarray(path_parameter_grid, dtype=float).reshape(-1)
        if grid.size < 1 or not np.all(np.isfinite(grid)) or np.any(np.diff(grid) <= 0.0):
            raise ValueError(
                f"path_parameter_grid: need ascending finite values [m²], got {grid!r}"
            )
        self.grid = grid
        lo1, hi1 = (float(v) for v in planner.path_parameter_bounds)
        self.path_bounds = (lo1, hi1)
        self.u1 = np.clip((grid - lo1) / (hi1 - lo1), 0.0, 1.0) if hi1 > lo1 else np.ones_like(grid)
        self.lower, self.upper = table.lower, table.upper
        self.span = np.where(self.upper > self.lower, self.upper - self.lower, 1.0)
        self.candidates, self.candidate_power = GridCandidates(table)
        self._candidate_keys = tuple(dict.fromkeys(float(g) for g in self.candidate_power))
        self.candidate_u2 = np.mean((self.candidates - self.lower) / self.span, axis=1)
        self.lowest_candidate = int(np.flatnonzero(np.all(self.candidates == self.lower, 1))[0])
        w1, w2 = float(planner.path_weight), float(planner.computation_weight)
        self._w1, self._w2 = w1 / (w1 + w2), w2 / (w1 + w2)
        self.surrogate = PowerSurrogate(table, planner.power_model)
        self._rows_key = None
        self._rows = None
        self._cache: dict = {}
        self._smooth_cache: dict = {}
        self._row_cache: dict = {}
        self._best_cache: dict = {}
        self._row_values: dict = {}
        self._candidate_index: dict = {}
        self._grid_rows: dict = {}
        self._row_best: dict = {}
        self._climb_cache: dict = {}
        self._option_brackets = None
        self._lowest_cache: dict = {}
        self._margin_rows: dict = {}
        self._recursive_cache: dict = {}
        self._nodes = np.zeros(0)
        self._hull_slopes = None
        lowest_row = self.candidates[self.lowest_candidate]
        grids = table.parameter_grids
        self._lowest_index = tuple(
            int(np.flatnonzero(g == v)[0]) for g, v in zip(grids, lowest_row, strict=True)
        )
        self._margin_floor = float(planner.margin_floor)
        self._fault_reserve = float(planner.fault_reserve)
        self._fault_time = float(planner.fault_reserve_time)
        self._faults_counted = True
        self._max_steps = math.ceil(MAX_TIME_LIMIT / self.step)
        self._fault_model = None
        if planner.reserve == "risk":
            self._fault_model = FaultModelFromParams(planner.fault_model)
            self._risk_tables: dict = {}
            self._risk = float(planner.risk)
            self._risk_anchor = None
            self._risk_times = self._risk_margins = self._risk_slopes = np.zeros(1)
            self.lowest_risk_state = (0.0, 0.0)

    # -- per-step data -------------------------------------------------------------------------

    def SetState(
        self,
        energy_coefficients,
        mean_power_variance: float,
        soc: float,
        period: float,
        remaining_time,
        computation_parameters,
    ) -> None:
        """The step's data: q̂ [W], Var(α̂0) [W²], b0 [-], T [s], t_rem at the grid [s], c_now."""
        q = np.asarray(energy_coefficients, dtype=float).reshape(-1)
        t_rem = np.asarray(remaining_time, dtype=float).reshape(-1)
        if q.size != self.state_size:
            raise ValueError(f"energy_coefficients: expected {self.state_size}, got {q.size}")
        if t_rem.size != self.grid.size:
            raise ValueError(f"remaining_time: expected {self.grid.size}, got {t_rem.size}")
        self.q = q
        self.soc0 = float(soc)
        self.t_rem = np.maximum(t_rem, 0.0)
        self.g_now = float(self.table.power(np.asarray(computation_parameters, dtype=float)))
        h = self.step
        # The prediction covers the longest plan, but never more than the longest flight a
        # scenario may ask for (MAX_TIME_LIMIT): a plan longer than that cannot be completed
        # (it is infeasible, below), and the free-response rows stay bounded in memory.
        n = max(2, min(math.ceil(float(np.max(self.t_rem)) / h), self._max_steps) + 2)
        self._beyond = self.t_rem > (n - 2) * h
        key = float(period)
        if self._rows_key != key or self._rows.shape[0] < 2 * n + 1:
            # a pure function of T: the rows of fewer points are the leading rows of more
            # (FreeResponseMatrix stacks them by doubling), so the longest is kept
            self._rows = FreeResponseMatrix(self.order, key, 0.5 * h, 2 * n + 1)
            self._rows_key = key
        self.f_half = self._rows[: 2 * n + 1] @ q
        self.n = n
        self._hull_slopes = None  # the NLP's T(c̃1), built when a solve first reads it
        self._cache = {}
        self._smooth_cache = {}
        self._row_cache = {}
        self._best_cache = {}
        self._row_best = {}
        self._climb_cache = {}
        self._lowest_cache = {}
        self._margin_rows = {}
        self._recursive_cache = {}
        s_b = -float(self.battery_model.SocRateSlope(max(float(q[0]), 0.0)))
        sigma = math.sqrt(max(float(mean_power_variance), 0.0))
        p = self.params
        self._margin_rate = float(p.margin_sigmas) * s_b * sigma  # [1/s]
        if self._fault_model is not None:
            self._SetRiskMargins()

    @property
    def risk_budget(self) -> float:
        """ε_k [-]: the excess risk the steps may spend (the last :meth:`SetRiskBudget`, else
        ``planner.risk``); 0 with the fixed reserve, which keeps no stated risk."""
        return self._risk if self._fault_model is not None else 0.0

    def SetRiskBudget(self, budget: float, anchor: tuple[float, float] | None = None) -> None:
        """The excess risk ε_k [-] the next steps may spend (``reserve: risk``) and the mission's
        anchor (τ_a [s] still to fly, m_a [-]): the lowest plan as it stood when the budget was
        opened (:class:`~eaplan_drake.planning.policies.MpcPolicy`); None: the lowest plan from
        the current state is the anchor. Takes effect at the next :meth:`SetState`."""
        self._risk = float(budget)
        self._risk_anchor = None if anchor is None else (float(anchor[0]), float(anchor[1]))

    def _SetRiskMargins(self) -> None:
        """m_req at the grid's remaining times (``reserve: risk``): against the lowest plan's
        fault-free margin m_0 = b(t_rem(c̲1); c̲2) − b_res − m_floor − z s_b σ t_rem(c̲1), the
        excess measured from min(P(F_0), P(S(τ_a) > m_a)) when an anchor is set."""
        t_low = float(self.t_rem[0])
        g_low = float(self.candidate_power[self.lowest_candidate])
        m_0 = (
            float(self.SocAt(g_low, t_low))
            - float(self.battery.reserve_soc)
            - self._margin_floor
            - self._margin_rate * t_low
        )
        self.lowest_risk_state = (t_low, m_0)
        times = np.minimum(self.t_rem, (self.n - 2) * self.step)
        if np.all(times[1:] >= times[:-1]):  # the staircase ascends: np.unique without its sort
            times = times[np.concatenate(([True], times[1:] != times[:-1]))]
        else:
            times = np.unique(times)
        bucket = ExposureBucket(float(times[-1]))
        table = self._risk_tables.get(bucket)
        if table is None:  # RiskTable's own table for the bucket, kept (its cache key hashes)
            table = self._risk_tables[bucket] = RiskTable(self._fault_model, bucket)
        baseline = None
        if self._risk_anchor is not None:
            tau_a, m_a = self._risk_anchor
            baseline = float(table.LowestFailure(max(tau_a, 0.0), m_a))
        margins = table.RequiredMargin(times, t_low, m_0, self._risk, baseline)
        self._risk_times = times
        # a plan no margin keeps within ε needs more than the lowest plan has: just above m_0
        # (not +inf), which excludes it as surely and keeps the NLP's constraint gentle
        self._risk_margins = np.minimum(margins, max(m_0, 0.0) + UNREACHABLE_MARGIN)
        self._risk_slopes = _PchipSlopes(times, self._risk_margins)

    def SetObservation(self, observation) -> None:
        """:meth:`SetState` from a :class:`~eaplan_drake.planning.planner.PlannerObservation`."""
        o = observation
        self.SetState(
            o.energy_coefficients,
            o.mean_power_variance,
            o.soc,
            o.period,
            o.remaining_time,
            o.computation_parameters,
        )

    def FaultReserve(self, t):
        """m_fault(t) [-] for the remaining time t [s]: ``fault_reserve`` · min(1, t/τ_f), the
        whole reserve when τ_f = ``fault_reserve_time`` is 0; with ``reserve: risk`` the risk
        margin m_req(t), linear between the grid's remaining times."""
        t = np.asarray(t, dtype=float)
        if not self._faults_counted:
            return np.zeros_like(t)
        if self._fault_model is not None:
            return _Pchip(self._risk_times, self._risk_margins, self._risk_slopes, t)[0]
        if self._fault_time <= 0.0:
            return np.full_like(t, self._fault_reserve)
        return self._fault_reserve * np.minimum(1.0, np.maximum(t, 0.0) / self._fault_time)

    def Margin(self, t):
        """m(t) [-] for the remaining time t [s]."""
        t = np.asarray(t, dtype=float)
        return self._margin_floor + self.FaultReserve(t) + self._margin_rate * t

    def RecursiveMargin(self, t):
        """The margin (2) asks of the lowest plan after this step [-]: m(t) with the fixed
        reserve; with ``reserve: risk`` only m_floor + z s_b σ t (the lowest plan's own fault
        risk is the world's: it is what every policy falls back to)."""
        if self._fault_model is None:
            return self.Margin(t)
        return self._margin_floor + self._margin_rate * np.asarray(t, dtype=float)

    def MarginSlope(self, t: float) -> float:
        """dm/dt [1/s] at the remaining time t [s] (right derivative at a kink)."""
        slope = self._margin_rate
        if not self._faults_counted:
            return slope
        if self._fault_model is not None:
            return slope + float(
                _Pchip(self._risk_times, self._risk_margins, self._risk_slopes, t)[1]
            )
        if 0.0 < self._fault_time and t < self._fault_time:
            slope += self._fault_reserve / self._fault_time
        return slope

    def SocCurve(self, power: float) -> np.ndarray:
        """b at the nodes k·h_T (k = 0 … n) under the held computation power g(c2) = ``power``
        [W]; −inf from the first node whose step contains a brown-out load."""
        key = float(power)
        if key not in self._cache:
            # a step reads the curves of all its candidate powers (and rarely another): all of
            # them at once, as the columns of one load (every operation is element-wise along
            # the powers, so each column is the curve of its power alone)
            keys = [key]
            if key in self._candidate_keys:
                keys = [k for k in self._candidate_keys if k not in self._cache]
            offsets = np.array([k - self.g_now for k in keys])
            y = self.f_half[:, None] + offsets
            socs = SimpsonSoc(y, self.soc0, self.battery_model, self.step)
            browns = self.battery_model.IsBrownout(y)
            for column, k in enumerate(keys):
                soc = np.ascontiguousarray(socs[:, column])
                brown = browns[:, column]
                if np.any(brown):
                    first = int(np.argmax(brown))
                    soc[(first + 1) // 2 :] = -np.inf
                self._cache[k] = soc
        return self._cache[key]

    def SocAt(self, power: float, t):
        """b(t; c2) [-] by linear interpolation of :meth:`SocCurve` (t in [0, n·h_T])."""
        soc = self.SocCurve(power)
        if self._nodes.size != soc.size:
            self._nodes = np.arange(soc.size) * self.step
        return np.interp(np.asarray(t, dtype=float), self._nodes, soc)

    def RecursiveSlack(self, power: float) -> float:
        """Left side minus right side of (2) [-] for the computation power ``power`` [W]."""
        key = (self._margin_rate, self._faults_counted)
        low = self._recursive_cache.get(key)
        if low is None:  # the lowest plan's terms, once per step and margin setting
            g_low = float(self.candidate_power[self.lowest_candidate])
            t_low = float(self.t_rem[0])
            low = self._recursive_cache[key] = (
                float(self.SocAt(g_low, self.step)),
                float(self.SocAt(g_low, t_low)),
                float(self.RecursiveMargin(t_low)),
            )
        b_low_next, b_low_end, margin = low
        return (
            float(self.SocAt(power, self.step))
            - b_low_next
            + b_low_end
            - float(self.battery.reserve_soc)
            - margin
        )

    def FeasibleRow(self, power: float) -> tuple[np.ndarray, np.ndarray]:
        """(feasible (M,), end SoC (M,)) of the plans (c1_j, c2) for g(c2) = ``power`` [W]
        (computed once per step for each power and margin setting: the arrays are shared, read
        only)."""
        key = (float(power), self._margin_rate, self._faults_counted)
        row = self._row_cache.get(key)
        if row is None:
            end = self.SocAt(power, self.t_rem)
            ok = (end >= float(self.battery.reserve_soc) + self._MarginRow()) & ~self._beyond
            if self.RecursiveSlack(power) < 0.0:
                ok = np.zeros_like(ok)
            row = self._row_cache[key] = (ok, end)
        return row

    def Quality(self, j: int, u2: float) -> float:
        """J of the plan (c1_j, c2 with mean normalised value u2) [-]."""
        return self._w1 * float(self.u1[j]) + self._w2 * float(u2)

    # -- answers -------------------------------------------------------------------------------

    def _Decision(self, j: int, k: int, c2, end: float, feasible: bool) -> MissionDecision:
        u2 = self._Row(c2)[1]
        return MissionDecision(
            path_index=int(j),
            candidate_index=int(k),
            path_parameter=float(self.grid[j]),
            computation_parameters=np.asarray(c2, dtype=float).copy(),
            quality=self.Quality(j, u2),
            end_soc=float(end),
            margin=self._MarginAt(int(j)),
            feasible=bool(feasible),
        )

    def _MarginRow(self) -> np.ndarray:
        """m(t_rem) [-] at the grid's remaining times, computed once per step and margin setting
        (the same for every power; shared, read only)."""
        key = (self._margin_rate, self._faults_counted)
        margins = self._margin_rows.get(key)
        if margins is None:
            margins = self._margin_rows[key] = self.Margin(self.t_rem)
        return margins

    def _MarginAt(self, j: int) -> float:
        """m(t_rem(c1_j)) [-]: element j of :meth:`_MarginRow` (every term of m is elementwise,
        and the risk margin's interpolant is exactly its value at the nodes t_rem(c1_j) and
        constant beyond the last one: the same number as m of t_rem(c1_j) alone)."""
        return float(self._MarginRow()[j])

    def Lowest(self) -> MissionDecision:
        """The lowest plan (c̲1, c̲2), with its feasibility (computed once per step and margin
        setting; the answer is shared, read only)."""
        key = (self._margin_rate, self._faults_counted)
        low = self._lowest_cache.get(key)
        if low is None:
            k = self.lowest_candidate
            ok, end = self.FeasibleRow(float(self.candidate_power[k]))
            low = self._lowest_cache[key] = self._Decision(
                0, k, self.candidates[k], end[0], bool(ok[0])
            )
        return low

    def NominallyFeasible(self) -> bool:
        """The lowest plan ends above ``reserve_soc + margin_floor`` on the estimate (neither the
        uncertainty term nor the fault reserve counted): when it does not, the survey is
        infeasible; when only those terms exclude it, the planner flies the lowest plan to keep
        as much of them as it can."""
        saved = self._margin_rate, self._faults_counted
        self._margin_rate, self._faults_counted = 0.0, False
        try:
            return self.Lowest().feasible
        finally:
            self._margin_rate, self._faults_counted = saved

    def _Row(self, c2) -> tuple[float, float]:
        """(g(c2) [W], mean normalised c̃2 [-]) of a c2 row, computed once per row."""
        key = tuple(float(v) for v in c2)
        row = self._row_values.get(key)
        if row is None:
            c2 = np.asarray(c2, dtype=float)
            row = float(self.table.power(c2)), float(np.mean((c2 - self.lower) / self.span))
            self._row_values[key] = row
        return row

    def _CandidateIndex(self, c2) -> int:
        """k of the candidate row c2 (−1 if it is none of them), computed once per row."""
        key = tuple(float(v) for v in c2)
        if key not in self._candidate_index:
            self._candidate_index[key] = _RowIndex(self.candidates, c2)
        return self._candidate_index[key]

    def BestOf(self, candidates, powers, path_index_limit: int | None = None):
        """The best feasible plan over the c2 ``candidates`` (rows) with exact ``powers`` [W],
        each with its largest feasible grid c1 (at most ``path_index_limit``); None if none
        (remembered for the step: a pure function of its arguments and the step's data)."""
        key = (
            tuple(tuple(float(v) for v in c2) for c2 in candidates),
            tuple(float(g) for g in powers),
            path_index_limit,
            self._margin_rate,
            self._faults_counted,
        )
        if key not in self._best_cache:
            self._best_cache[key] = self._BestOf(candidates, powers, path_index_limit)
        return self._best_cache[key]

    def _BestOf(self, candidates, powers, path_index_limit):
        best, best_key = None, None
        for c2, power in zip(candidates, powers, strict=True):
            ok, end = self.FeasibleRow(float(power))
            if path_index_limit is not None:
                ok = ok & (np.arange(ok.size) <= path_index_limit)
            hits = np.flatnonzero(ok)
            if not hits.size:
                continue
            j = int(hits[-1])
            u2 = self._Row(c2)[1]
            key = (round(self.Quality(j, u2), 12), float(end[j]))
            if best_key is None or key > best_key:
                best_key = key
                best = (j, c2, float(end[j]))
        return best

    def BruteForce(self) -> MissionDecision:
        """The exact optimum of the discrete problem by enumeration of every (c1_j, c2_k)."""
        low = self.Lowest()
        if not low.feasible:
            return low
        j, c2, end = self.BestOf(self.candidates, self.candidate_power)
        k = self._CandidateIndex(c2)
        return self._Decision(j, k, c2, end, True)

    def MapRelaxed(self, u2_relaxed) -> MissionDecision:
        """The exact answer from a relaxed c̃2 (σ,): the best of its bracketing grid points and
        the lowest (and the relaxed point itself if not integer), each with its largest feasible
        c1, then improved by one-grid-step moves of c2."""
        low = self.Lowest()
        if not low.feasible:
            return low
        c_relaxed = self._Relaxed(u2_relaxed)
        if self.integer:
            return self._MapOnGrid(c_relaxed)
        # the bracketing grid values (the grids ascend strictly: the same order as the indices)
        brackets = [
            [float(grid[i]) for i in indices]
            for grid, indices in zip(
                self.table.parameter_grids, self._Brackets(c_relaxed), strict=True
            )
        ]
        rows = [np.array(p) for p in itertools.product(*brackets)]
        rows.append(self.candidates[self.lowest_candidate])
        powers = [self._Row(r)[0] for r in rows]
        rows.append(c_relaxed)  # not an integer table: the relaxed point is a candidate too
        powers.append(self.table.power(c_relaxed))
        best = self.BestOf(rows, powers)
        # Local search from the rounded point: move c2 one grid step in any dimension (each
        # with its largest feasible c1) while that improves the plan.
        grids = self.table.parameter_grids
        for _ in range(self.candidates.shape[0]):
            j, c2, end = best
            neighbours = []
            for d, grid in enumerate(grids):
                i = int(np.argmin(np.abs(grid - c2[d])))
                for i2 in (i - 1, i + 1):
                    if 0 <= i2 < grid.size:
                        n = np.array(c2, dtype=float)
                        n[d] = grid[i2]
                        neighbours.append(n)
            found = self.BestOf([c2, *neighbours], [self._Row(r)[0] for r in [c2, *neighbours]])
            if found is None or np.array_equal(found[1], c2):
                break
            best = found
        j, c2, end = best
        k = self._CandidateIndex(c2)
        return self._Decision(j, k, c2, end, True)

    def _Relaxed(self, u2_relaxed) -> np.ndarray:
        """c2 [table units] of the relaxed c̃2 (clipped to [0, 1])."""
        return self.lower + np.clip(np.asarray(u2_relaxed, float), 0.0, 1.0) * (
            self.upper - self.lower
        )

    def DeterminedDecision(self) -> MissionDecision | None:
        """The answer of :meth:`MapRelaxed` when it does not depend on the relaxed c̃2, else None.

        :meth:`MapRelaxed` reads c̃2 only through the grid points that bracket it: in each
        dimension the lowest value alone (c̃2 at its lower bound) or a pair of neighbours. When
        every combination of those leads to the same plan, that plan is the mapped answer of
        any successful solve, so the NLP need not be solved. Integer tables only (otherwise the
        relaxed point itself is a candidate); None when the lowest plan is infeasible.
        """
        if not self.integer or not self.Lowest().feasible:
            return None
        if self._option_brackets is None:  # they depend on the table only
            options = []
            for grid, lo, span in zip(
                self.table.parameter_grids, self.lower, self.span, strict=True
            ):
                mids = 0.5 * (grid[:-1] + grid[1:])
                options.append([0.0, *((mids - lo) / span)])
            self._option_brackets = tuple(
                dict.fromkeys(
                    self._Brackets(self._Relaxed(u2)) for u2 in itertools.product(*options)
                )
            )
        first = None
        for brackets in self._option_brackets:
            best = self._Climb(self._BracketBest(brackets))
            if first is None:
                first = best
            elif best != first:  # another row: another c2 (the grids ascend strictly)
                return None
        return self._GridDecision(first)

    def KeepPathParameter(self, path_parameter: float) -> MissionDecision:
        """Failed-solve answer: c1 kept (the largest grid value not above it) with the best c2
        that the exact check admits there; if none, the best plan with a lower c1; the lowest
        plan (with its feasibility) if none at all."""
        low = self.Lowest()
        if not low.feasible:
            return low
        j = int(np.clip(np.searchsorted(self.grid, float(path_parameter) + 1e-9) - 1, 0, None))
        best = None
        for k in np.lexsort((-self.candidate_power, -self.candidate_u2)):  # best c2 first
            ok, end = self.FeasibleRow(float(self.candidate_power[k]))
            if ok[j]:
                best = (j, self.candidates[k], float(end[j]))
                break
        if best is None:
            best = self.BestOf(self.candidates, self.candidate_power, j)
        j, c2, end = best
        return self._Decision(j, self._CandidateIndex(c2), c2, end, True)


def _RowIndex(rows: np.ndarray, row) -> int:
    hits = np.flatnonzero(np.all(np.isclose(rows, np.asarray(row)), axis=1))
    return int(hits[0]) if hits.size else -1
