"""Mission-feasible MPC: the default planner formulation (beyond paper 003); the derivation, its
equations (1)–(3) and what is guaranteed are on the :doc:`/planner` page.

Every h_T [s] the planner chooses the pair (c1 [m²], c2 [table units]) the rest of the mission is
flown with, from the estimated energy state q̂ [W] (and Var(α̂0) [W²]), the SoC b0 [-], the period
T [s] and the exact remaining survey time t_rem(c1_j) [s] at the M values of a c1 grid. A plan
(c1_j, c2) is feasible when it ends above b_res + m(t_rem(c1_j)) (1) and the lowest plan still
does after this step (2); the objective is the plan's quality J = (w1 c̃1 + w2 mean c̃2)/(w1 + w2).

Three lifetimes, three objects:

- :class:`MissionProblem`: what depends on the scenario only (grids, candidates, weights, the
  risk tables), built once per flight; :meth:`MissionProblem.Step` starts a step;
- :class:`MissionStep`: what depends on the state of one planner step (the prediction b(t; c2),
  the step's :class:`~eaplan_drake.planning.margins.Margin`, the feasible rows and every answer),
  with its memo, dropped with it; a :class:`StepPrediction` holds the margin-free part, shared by
  the step and its floor-only twin (:meth:`MissionStep.NominallyFeasible`);
- the answers: :meth:`MissionStep.BruteForce`, the exact grid mapping of a relaxed optimum and the
  decision that needs no solve (:mod:`eaplan_drake.planning.grid_search`), the NLP relaxation
  (:class:`~eaplan_drake.planning.relaxation.MissionProgram` on the step's
  :class:`~eaplan_drake.planning.smooth.SmoothModel`).
"""

import copy
import dataclasses as dc
import math

import numpy as np

from eaplan_drake.energy.battery_model import AsBatteryModel, BatteryModel
from eaplan_drake.energy.computation import ComputationTable
from eaplan_drake.energy.fourier import FreeResponseMatrix, StateSize
from eaplan_drake.params import MAX_TIME_LIMIT, BatteryParams, PlannerParams
from eaplan_drake.planning import grid_search
from eaplan_drake.planning.capacity import PlannedPack
from eaplan_drake.planning.margins import (
    FloorMargin,
    Margin,
    RiskReserve,
    StepMargin,
    UnpricedMargin,
)
from eaplan_drake.planning.prediction import GridCandidates, PowerSurrogate, SimpsonSoc
from eaplan_drake.planning.smooth import SmoothModel

__all__ = [
    "MissionDecision",
    "MissionProblem",
    "MissionStep",
    "StaircaseSteps",
    "StepPrediction",
]


def StaircaseSteps(remaining_time, resolution: float) -> np.ndarray:
    """t_rem(c1_j) [s] with every step of the staircase at its longest time.

    The remaining time is whole repetitions (or lines) of the route: grid values of c1 on the
    same step fly the same repetitions and differ only by their turns' lengths (up to 1.6 s on
    ``survey``, against 52 s or more between steps). Remaining times that, sorted, follow each
    other by less than ``resolution`` [s] (the planner's period h: it cannot act between them)
    are one step, and each takes the step's longest time. The plans of a step are then priced
    alike (energy to the end, risk of the exposure), conservatively, and the planner chooses
    among them by quality alone: c1 no longer follows sub-second differences of turn length in
    and out of the feasible set at every step."""
    t = np.asarray(remaining_time, dtype=float).reshape(-1)
    if t.size < 2:
        return t.copy()
    order = np.argsort(t, kind="stable")
    ascending = t[order]
    step = np.concatenate(([0], np.cumsum(np.diff(ascending) >= float(resolution))))
    starts = np.flatnonzero(np.diff(step, prepend=-1))
    longest = np.maximum.reduceat(ascending, starts)
    out = np.empty_like(t)
    out[order] = longest[step]
    return out


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


class MissionProblem:
    """The mission problem of one flight: what depends on the scenario only.

    Args:
        planner: planner parameters (period h_T, weights, margin, reserve, risk, fault model).
        table: the computation power table g (exact; its grid = the admissible c2).
        order: Fourier order r of the energy model (q̂ has 2r + 1 entries).
        battery: Rint battery parameters (reserve_soc is b_res).
        path_parameter_grid: the M values of c1 [m²] (ascending) of ``remaining_time``.
        integer: c2 takes only grid values (else the NLP's continuous optimum is a candidate).

    The parameters are copied: later changes to the caller's objects do not reach the problem.
    The memos it keeps (free-response rows per period, per-row values, risk tables) are pure
    functions of their keys.
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
        self.reserve_soc = float(battery.reserve_soc)
        self.order = order  # int r, or AugmentedOrder (energy_model)
        self.state_size = StateSize(order)
        self.integer = bool(integer)
        self.step_length = float(planner.period)
        """h_T [s]."""
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
        self.candidate_keys = tuple(dict.fromkeys(float(g) for g in self.candidate_power))
        """The distinct candidate powers [W] (the columns a step's SoC curves are computed in)."""
        self.candidate_u2 = np.mean((self.candidates - self.lower) / self.span, axis=1)
        self.lowest_candidate = int(np.flatnonzero(np.all(self.candidates == self.lower, 1))[0])
        self.lowest_power = float(self.candidate_power[self.lowest_candidate])
        """g(c̲2) [W]."""
        lowest_row = self.candidates[self.lowest_candidate]
        self.lowest_index = tuple(
            int(np.flatnonzero(g == v)[0])
            for g, v in zip(table.parameter_grids, lowest_row, strict=True)
        )
        """The grid indices of c̲2."""
        w1, w2 = float(planner.path_weight), float(planner.computation_weight)
        self.weights = (w1 / (w1 + w2), w2 / (w1 + w2))
        """(w1, w2) normalised to sum 1."""
        self.surrogate = PowerSurrogate(table, planner.power_model)
        self.max_steps = math.ceil(MAX_TIME_LIMIT / self.step_length)
        self.risk_reserve = RiskReserve(planner) if planner.reserve == "risk" else None
        """The flight's :class:`~eaplan_drake.planning.margins.RiskReserve` (``reserve: risk``),
        else None."""
        self._rows_key = None
        self._rows = None
        self._row_values: dict = {}
        self._candidate_index: dict = {}
        self._grid_rows: dict = {}
        self._option_brackets = None
        self._packs = {1.0: self.battery_model}

    # -- what depends on the scenario only ----------------------------------------------------

    def Quality(self, j: int, u2: float) -> float:
        """J of the plan (c1_j, c2 with mean normalised value u2) [-]."""
        w1, w2 = self.weights
        return w1 * float(self.u1[j]) + w2 * float(u2)

    def RowValues(self, c2) -> tuple[float, float]:
        """(g(c2) [W], mean normalised c̃2 [-]) of a c2 row (kept per row)."""
        key = tuple(float(v) for v in c2)
        row = self._row_values.get(key)
        if row is None:
            c2 = np.asarray(c2, dtype=float)
            row = float(self.table.power(c2)), float(np.mean((c2 - self.lower) / self.span))
            self._row_values[key] = row
        return row

    def CandidateIndex(self, c2) -> int:
        """k of the candidate row c2 (−1 if it is none of them; kept per row)."""
        key = tuple(float(v) for v in c2)
        if key not in self._candidate_index:
            hits = np.flatnonzero(np.all(np.isclose(self.candidates, np.asarray(c2)), axis=1))
            self._candidate_index[key] = int(hits[0]) if hits.size else -1
        return self._candidate_index[key]

    def GridRow(self, index: tuple[int, ...]) -> tuple[np.ndarray, float]:
        """(c2 [table units], g(c2) [W]) of the grid point with these indices (kept)."""
        row = self._grid_rows.get(index)
        if row is None:
            grids = self.table.parameter_grids
            c2 = np.array([float(g[i]) for g, i in zip(grids, index, strict=True)])
            row = self._grid_rows[index] = (c2, self.RowValues(c2)[0])
        return row

    def OptionBrackets(self) -> tuple:
        """:func:`~eaplan_drake.planning.grid_search.OptionBrackets` of the table (kept)."""
        if self._option_brackets is None:
            self._option_brackets = grid_search.OptionBrackets(self.table, self.span)
        return self._option_brackets

    def FreeResponseRows(self, period: float, count: int) -> np.ndarray:
        """The first ``count`` rows of the free response at the half-steps k·h_T/2 [-] for the
        period T [s] (:func:`~eaplan_drake.energy.fourier.FreeResponseMatrix`): a pure function
        of T whose rows of fewer points are the leading rows of more, so the longest is kept."""
        key = float(period)
        if self._rows_key != key or self._rows.shape[0] < count:
            self._rows = FreeResponseMatrix(self.order, key, 0.5 * self.step_length, count)
            self._rows_key = key
        return self._rows[:count]

    # -- a step --------------------------------------------------------------------------------

    def PackModel(self, health: float) -> BatteryModel:
        """The battery model of the pack with the usable fraction ``health`` of its label
        (:func:`~eaplan_drake.planning.capacity.PlannedPack`; 1: the nominal
        ``battery_model``), kept per value."""
        key = float(health)
        if key not in self._packs:
            self._packs[key] = PlannedPack(self.battery_model.params, key)
        return self._packs[key]

    def Step(
        self,
        observation,
        budget: float | None = None,
        anchor=None,
        observed=(),
        drops: int = 0,
        health: float = 1.0,
    ) -> "MissionStep":
        """The :class:`MissionStep` of a
        :class:`~eaplan_drake.planning.planner.PlannerObservation` (see :meth:`StepFromState`)."""
        o = observation
        return self.StepFromState(
            o.energy_coefficients,
            o.mean_power_variance,
            o.soc,
            o.period,
            o.remaining_time,
            o.computation_parameters,
            budget=budget,
            anchor=anchor,
            observed=observed,
            flown=o.time,
            drops=drops,
            health=health,
        )

    def StepFromState(
        self,
        energy_coefficients,
        mean_power_variance: float,
        soc: float,
        period: float,
        remaining_time,
        computation_parameters,
        *,
        budget: float | None = None,
        anchor=None,
        observed=(),
        flown: float = 0.0,
        drops: int = 0,
        health: float = 1.0,
    ) -> "MissionStep":
        """The step of the state q̂ [W], Var(α̂0) [W²], b0 [-], T [s], t_rem at the grid [s] and
        c_now; with ``reserve: risk`` its excess-risk ``budget`` ε_k [-] (None: ``planner.risk``)
        and the mission's ``anchor`` (τ_a [s] still to fly, m_a [-]): the lowest plan as it
        stood when the budget opened (None: the lowest plan of this state), the drop sizes
        ``observed`` [-] so far, the time ``flown`` [s] and the ``drops`` detected (the risk
        reserve's belief learns from them); every SoC on the pack of usable fraction ``health``
        [-] of its label (:meth:`PackModel`)."""
        model = self.PackModel(health)
        prediction = StepPrediction(
            self, energy_coefficients, soc, period, remaining_time, computation_parameters, model
        )
        q0 = float(prediction.q[0])
        s_b = -float(model.SocRateSlope(max(q0, 0.0)))
        sigma = math.sqrt(max(float(mean_power_variance), 0.0))
        rate = float(self.params.margin_sigmas) * s_b * sigma  # [1/s]
        if self.risk_reserve is None:
            return MissionStep(self, prediction, StepMargin(self.params, rate))
        budget = float(self.params.risk) if budget is None else float(budget)
        if anchor is not None:
            anchor = (float(anchor[0]), float(anchor[1]))
        t_low = float(prediction.t_rem[0])
        m_0 = (
            float(prediction.SocAt(self.lowest_power, t_low))
            - self.reserve_soc
            - float(self.params.margin_floor)
            - rate * t_low
        )
        times = np.minimum(prediction.t_rem, (prediction.n - 2) * self.step_length)
        margin = self.risk_reserve.Margin(
            rate, times, t_low, m_0, budget, anchor, observed, flown, drops
        )
        return MissionStep(self, prediction, margin)


class StepPrediction:
    """The margin-free part of a planner step: the state and the predicted SoC b(t; c2) [-].

    y(t) = C expm(A t) q̂ + g(c2) − g(c_now) on the half-steps of h_T, integrated by Simpson's rule
    on the battery model (:func:`~eaplan_drake.planning.prediction.SimpsonSoc`). The prediction
    covers the longest plan, but never more than the longest flight a scenario may ask for
    (MAX_TIME_LIMIT): a plan longer than that cannot be completed (``beyond``: it is infeasible).

    It holds q̂ (``q``, [W]), b0 (``soc0``), the remaining times at the grid (``t_rem`` [s],
    ≥ 0), g(c_now) (``g_now`` [W]), the number ``n`` of steps it covers, the free response at
    the half steps (``f_half`` [W]) and the grid's plans longer than it (``beyond``).
    """

    def __init__(
        self, problem, energy_coefficients, soc, period, remaining_time, c_now, battery_model=None
    ):
        q = np.asarray(energy_coefficients, dtype=float).reshape(-1)
        t_rem = np.asarray(remaining_time, dtype=float).reshape(-1)
        if q.size != problem.state_size:
            raise ValueError(f"energy_coefficients: expected {problem.state_size}, got {q.size}")
        if t_rem.size != problem.grid.size:
            raise ValueError(f"remaining_time: expected {problem.grid.size}, got {t_rem.size}")
        self.battery_model = problem.battery_model if battery_model is None else battery_model
        self.candidate_keys = problem.candidate_keys
        self.step_length = h = problem.step_length
        self.q = q
        self.soc0 = float(soc)
        self.t_rem = np.maximum(t_rem, 0.0)
        self.g_now = float(problem.table.power(np.asarray(c_now, dtype=float)))
        n = max(2, min(math.ceil(float(np.max(self.t_rem)) / h), problem.max_steps) + 2)
        self.beyond = self.t_rem > (n - 2) * h
        self.f_half = problem.FreeResponseRows(period, 2 * n + 1) @ q
        self.n = n
        self._curves: dict = {}
        self._nodes = np.zeros(0)

    def SocCurve(self, power: float) -> np.ndarray:
        """b at the nodes k·h_T (k = 0 … n) under the held computation power g(c2) = ``power``
        [W]; −inf from the first node whose step contains a brown-out load."""
        key = float(power)
        if key not in self._curves:
            # a step reads the curves of all its candidate powers (and rarely another): all of
            # them at once, as the columns of one load (every operation is element-wise along
            # the powers, so each column is the curve of its power alone)
            keys = [key]
            if key in self.candidate_keys:
                keys = [k for k in self.candidate_keys if k not in self._curves]
            offsets = np.array([k - self.g_now for k in keys])
            y = self.f_half[:, None] + offsets
            socs = SimpsonSoc(y, self.soc0, self.battery_model, self.step_length)
            browns = self.battery_model.IsBrownout(y)
            for column, k in enumerate(keys):
                soc = np.ascontiguousarray(socs[:, column])
                brown = browns[:, column] | np.isnan(y[:, column])
                if np.any(brown):
                    first = int(np.argmax(brown))
                    soc[(first + 1) // 2 :] = -np.inf
                self._curves[k] = soc
        return self._curves[key]

    def SocAt(self, power: float, t):
        """b(t; c2) [-] by linear interpolation of :meth:`SocCurve` (t in [0, n·h_T])."""
        soc = self.SocCurve(power)
        if self._nodes.size != soc.size:
            self._nodes = np.arange(soc.size) * self.step_length
        return np.interp(np.asarray(t, dtype=float), self._nodes, soc)


class MissionStep:
    """One planner step of a :class:`MissionProblem`: its prediction and its margin, and every
    answer from them (feasible rows, the lowest plan, the best plans), each computed once: the
    memo lives and dies with the step.

    Args:
        problem: the flight's :class:`MissionProblem`.
        prediction: the step's :class:`StepPrediction`.
        margin: the step's :class:`~eaplan_drake.planning.margins.Margin` m(t).
    """

    def __init__(self, problem: MissionProblem, prediction: StepPrediction, margin: Margin):
        self.problem = problem
        self.prediction = prediction
        self.margin = margin
        self.t_rem = prediction.t_rem
        self._rows: dict = {}
        self._memo: dict = {}
        self._grid_best: dict = {}
        self._margin_row = None
        self._lowest = None
        self._recursive = None
        self._nominal = None
        self._smooth = None

    @property
    def priced(self) -> bool:
        """False when the step's risk cannot be priced (an
        :class:`~eaplan_drake.planning.margins.UnpricedMargin`): no plan is feasible."""
        return not isinstance(self.margin, UnpricedMargin)

    @property
    def risk_budget(self) -> float:
        """ε_k [-]: the excess risk the step may spend; 0 with the fixed reserve, which keeps no
        stated risk."""
        return getattr(self.margin, "budget", 0.0)

    @property
    def smooth(self) -> SmoothModel:
        """The NLP's :class:`~eaplan_drake.planning.smooth.SmoothModel` of the step (built when
        first read)."""
        if self._smooth is None:
            self._smooth = SmoothModel(self)
        return self._smooth

    def Memo(self, key, compute):
        """``compute()``, computed once per step for ``key`` (a pure function of the step)."""
        value = self._memo.get(key, _MISSING)
        if value is _MISSING:
            value = self._memo[key] = compute()
        return value

    def SocAt(self, power: float, t):
        """b(t; c2) [-] of the prediction (:meth:`StepPrediction.SocAt`)."""
        return self.prediction.SocAt(power, t)

    def MarginRow(self) -> np.ndarray:
        """m(t_rem) [-] at the grid's remaining times (the same for every power; read only)."""
        if self._margin_row is None:
            self._margin_row = self.margin.At(self.t_rem)
        return self._margin_row

    def RecursiveSlack(self, power: float) -> float:
        """Left side minus right side of (2) [-] for the computation power ``power`` [W]."""
        if self._recursive is None:  # the lowest plan's terms, once per step
            g_low = self.problem.lowest_power
            h = self.problem.step_length
            t_low = float(self.t_rem[0])
            self._recursive = (
                float(self.SocAt(g_low, h)),
                float(self.SocAt(g_low, t_low)),
                float(self.margin.Recursive(t_low)),
            )
        b_low_next, b_low_end, margin = self._recursive
        return (
            float(self.SocAt(power, self.problem.step_length))
            - b_low_next
            + b_low_end
            - self.problem.reserve_soc
            - margin
        )

    def FeasibleRow(self, power: float) -> tuple[np.ndarray, np.ndarray]:
        """(feasible (M,), end SoC (M,)) of the plans (c1_j, c2) for g(c2) = ``power`` [W]
        (computed once per power: the arrays are shared, read only)."""
        key = float(power)
        row = self._rows.get(key)
        if row is None:
            end = self.SocAt(power, self.t_rem)
            ok = (end >= self.problem.reserve_soc + self.MarginRow()) & ~self.prediction.beyond
            if self.RecursiveSlack(power) < 0.0:
                ok = np.zeros_like(ok)
            row = self._rows[key] = (ok, end)
        return row

    def Decision(self, j: int, k: int, c2, end: float, feasible: bool) -> MissionDecision:
        """The :class:`MissionDecision` of the plan (c1_j, c2) (k: its candidate index)."""
        pb = self.problem
        u2 = pb.RowValues(c2)[1]
        return MissionDecision(
            path_index=int(j),
            candidate_index=int(k),
            path_parameter=float(pb.grid[j]),
            computation_parameters=np.asarray(c2, dtype=float).copy(),
            quality=pb.Quality(j, u2),
            end_soc=float(end),
            # every term of m is elementwise, and the risk margin's interpolant is exactly its
            # value at the nodes t_rem(c1_j): element j of the row is m of t_rem(c1_j) alone
            margin=float(self.MarginRow()[int(j)]),
            feasible=bool(feasible),
        )

    def Lowest(self) -> MissionDecision:
        """The lowest plan (c̲1, c̲2), with its feasibility (shared, read only)."""
        if self._lowest is None:
            pb = self.problem
            k = pb.lowest_candidate
            ok, end = self.FeasibleRow(pb.lowest_power)
            self._lowest = self.Decision(0, k, pb.candidates[k], end[0], bool(ok[0]))
        return self._lowest

    def NominallyFeasible(self) -> bool:
        """The lowest plan ends above ``reserve_soc + margin_floor`` on the estimate: the lowest
        plan checked against a :class:`~eaplan_drake.planning.margins.FloorMargin` (neither the
        uncertainty term nor the fault reserve). When it does not, the survey is infeasible;
        when only those terms exclude it, the planner flies the lowest plan to keep as much of
        them as it can."""
        if self._nominal is None:
            floor = FloorMargin(float(self.problem.params.margin_floor))
            self._nominal = MissionStep(self.problem, self.prediction, floor)
        return self._nominal.Lowest().feasible

    def BestOf(self, candidates, powers, path_index_limit: int | None = None):
        """The best feasible plan (j, c2, end SoC) over the c2 ``candidates`` (rows) with exact
        ``powers`` [W], each with its largest feasible grid c1 (at most ``path_index_limit``);
        None if none. Ranked by (quality, end SoC); the first of equals wins."""
        key = (
            "best",
            tuple(tuple(float(v) for v in c2) for c2 in candidates),
            tuple(float(g) for g in powers),
            path_index_limit,
        )
        return self.Memo(key, lambda: self._BestOf(candidates, powers, path_index_limit))

    def _BestOf(self, candidates, powers, path_index_limit):
        pb = self.problem
        best, best_key = None, None
        for c2, power in zip(candidates, powers, strict=True):
            ok, end = self.FeasibleRow(float(power))
            if path_index_limit is not None:
                ok = ok & (np.arange(ok.size) <= path_index_limit)
            hits = np.flatnonzero(ok)
            if not hits.size:
                continue
            j = int(hits[-1])
            key = (round(pb.Quality(j, pb.RowValues(c2)[1]), 12), float(end[j]))
            if best_key is None or key > best_key:
                best_key = key
                best = (j, c2, float(end[j]))
        return best

    def GridBest(self, index: tuple[int, ...]):
        """((quality, end SoC), j, end SoC) of the grid row with these indices at its largest
        feasible c1_j, None if it has none: :meth:`BestOf`'s ranking of one row (kept)."""
        found = self._grid_best.get(index, _MISSING)
        if found is _MISSING:
            found = self._grid_best[index] = self._GridBest(index)
        return found

    def _GridBest(self, index):
        pb = self.problem
        c2, power = pb.GridRow(index)
        ok, end = self.FeasibleRow(power)
        hits = np.flatnonzero(ok)
        if not hits.size:
            return None
        j = int(hits[-1])
        rank = (round(pb.Quality(j, pb.RowValues(c2)[1]), 12), float(end[j]))
        return (rank, j, float(end[j]))

    def BruteForce(self) -> MissionDecision:
        """The exact optimum of the discrete problem by enumeration of every (c1_j, c2_k)."""
        low = self.Lowest()
        if not low.feasible:
            return low
        pb = self.problem
        j, c2, end = self.BestOf(pb.candidates, pb.candidate_power)
        return self.Decision(j, pb.CandidateIndex(c2), c2, end, True)

    def KeepPathParameter(self, path_parameter: float) -> MissionDecision:
        """Failed-solve answer: c1 kept (the largest grid value not above it) with the best c2
        that the exact check admits there; if none, the best plan with a lower c1; the lowest
        plan (with its feasibility) if none at all."""
        low = self.Lowest()
        if not low.feasible:
            return low
        pb = self.problem
        j = int(np.clip(np.searchsorted(pb.grid, float(path_parameter) + 1e-9) - 1, 0, None))
        best = None
        for k in np.lexsort((-pb.candidate_power, -pb.candidate_u2)):  # best c2 first
            ok, end = self.FeasibleRow(float(pb.candidate_power[k]))
            if ok[j]:
                best = (j, pb.candidates[k], float(end[j]))
                break
        if best is None:
            best = self.BestOf(pb.candidates, pb.candidate_power, j)
        j, c2, end = best
        return self.Decision(j, pb.CandidateIndex(c2), c2, end, True)


_MISSING = object()
