"""The paper's planner (paper 003 Eq. 16, Alg. 2): the ``paper`` and ``greedy_authors`` policies.

Every h_T [s] the planner turns the estimated energy state q̂ [W], the SoC b0 [-], the period T [s]
and the fraction of the survey still to cover into the path parameter c1 [m²] and the σ
computation parameters c2 [table units].

**The NLP (Alg. 2 l. 16, Eq. 16).** Horizon of N steps of h_T; parameters held over each step,
normalised c̃ = (c − c̲)/(c̄ − c̲) ∈ [0, 1]. The energy model is linear, so q is eliminated:
with the exact discretisation q⁺ = A_d q + B Δg_k and Δg_k = g(c_k) − g(c_{k−1}), the sum of the
jumps telescopes and the output at any time t in step k is

    y(t) = C expm(A (t − t0)) q̂ + g(c_k) − g(c_prev) =: f(t) + g(c_k) − g(c_prev),

with f the free response of the Fourier model from q̂ (computed with the exact rotation blocks of
:func:`~eaplan_drake.energy.fourier.DiscreteFourierMatrices`) and c_prev the parameters applied now.
The Rint battery ḃ = −k_b I(y)/Q_c does not depend on b, so RK4 over a step reduces to Simpson's
rule on f at the start, middle and end of the step (exact up to O(h⁵);
:func:`~eaplan_drake.planning.prediction.SimpsonSocSteps`, the one rollout of every policy):

    b_{k+1} = b_k − (h k_b / Q_c) · [I(y_k⁰) + 4 I(y_k^½) + I(y_k¹)] / 6,   b_0 = b0 (Eq. 16f).

The output constraint (Def. III.3) y ≤ b·Q_c·V is imposed at the start and the end of every step,
with a slack s_k ≥ 0 per step. Decision variables: c̃2 (N×σ), c̃1 (N), s (N); the SoC is
eliminated too, so one vector-valued nonlinear constraint (2N rows, analytic Jacobian) is all the
NLP has besides bounds and a quadratic cost ("merely squared controls", maximise quality):

    min  Σ_k [ w2 Σ_i (1 − c̃2_{k,i})² + w1 (1 − c̃1_k)² ] + w_s Σ_k s_k.

The slack penalty is linear (exact L1 penalty): with a quadratic one the bound s ≥ 0 is
degenerate when the constraint is inactive and IPOPT (quasi-Newton Hessian in Drake) needed up to
its iteration limit; with (1 − c̃)² replaced by −c̃² (the paper's literal "max squared controls")
the same happened. Inside the NLP g is smooth: by default a least-squares quadratic fit to the
table (max error 0.17 W on the PedNet table, against 0.97 W for the Eq. 11 line); the Eq. 11
scaling factors (``power_model: linear``) are the paper's choice. The path parameter does not
enter the energy dynamics (its columns of B are zero, Eq. 12), so in the NLP it only carries its
cost; Alg. 2 l. 17–27 decides it (below).

The program is built once (:func:`MakePlannerProgram`) and updated per step: the free response,
b0 and g(c_prev) live in a buffer read by the constraint, the slack bounds are updated in place.
It is solved with IPOPT (or SNOPT, ``planner.solver``;
:func:`~eaplan_drake.planning.nlp.MakeSolver`),
warm-started from the previous solution shifted by one step, bounded by ``max_iterations`` (and
``max_wall_time`` when set). Drake hands the constraint AutoDiffXd variables to get its Jacobian;
the callback computes the Jacobian analytically (no AutoDiff arithmetic) and only packs it.

**Integer parameters.** The relaxed optimum is mapped to the table grid step by step: at step k
the chosen grid point is the one with the best objective Σ_i w2 (1 − c̃_i)² among all grid points
whose output satisfies y ≤ b·Q_c·V at the start and end of the step, checked with the *exact*
table g and the SoC predicted under the already mapped steps (for σ = 1: the largest admissible
grid value that keeps the constraint). If none does, the lowest grid point is taken (infeasible
step). The mapping enumerates the grid and never reads the relaxed optimum, so with integer
parameters :meth:`Planner.Plan` does not solve the NLP at all: the decision is the one the
mapping gives after any successful solve (:meth:`Planner.Relax` still solves it, e.g. to inspect
the slack). Non-integer parameters (``integer=False``) solve it and take the largest point on the
path c̲ → relaxed optimum → c̄ that satisfies the exact constraint (bisection); a failed solve
then falls back to the largest c2 the exact check admits and keeps c1.

**Path rule (Alg. 2 l. 17–27).** The model and the battery are rolled forward (exact f, exact g,
Simpson) under the mapped trajectory, then with the last parameters held, until b reaches the
reserve SoC (or a brown-out): that time is t_b
(:func:`~eaplan_drake.planning.prediction.TimeToReserve`).
The remaining coverage time is t_r(c1) = f_cov · t(c1), with f_cov the fraction of the survey
still to cover and t(c1) = ν c1 + τ the linear coverage-time model of Eq. 10 through (c̲1, t̲)
and (c̄1, t̄). The largest c1 with t_r(c1) ≤ t_b is, in closed form,
c1* = c̲1 + (t_b / f_cov − t̲)/ν, clipped to [c̲1, c̄1] (the lowest when even c̲1 does not fit); c1
then moves towards c1* by at most δ1 per update (rate limit against chattering).
"""

import copy
import dataclasses as dc
import math
import time

import numpy as np
from pydrake.autodiffutils import ExtractGradient, ExtractValue, InitializeAutoDiff
from pydrake.solvers import MathematicalProgram

from eaplan_drake.energy.battery_model import AsBatteryModel
from eaplan_drake.energy.computation import ComputationTable
from eaplan_drake.energy.fourier import FreeResponseMatrix, StateSize
from eaplan_drake.params import MAX_TIME_LIMIT, BatteryParams, PlannerParams
from eaplan_drake.planning.nlp import MakeSolver
from eaplan_drake.planning.prediction import (
    ChoosePathParameter,
    CoverageTimeModel,
    GridCandidates,
    PowerSurrogate,
    SimpsonSocSensitivity,
    SimpsonSocSteps,
    StepLoads,
    TimeToReserve,
)

__all__ = [
    "MakePlannerProgram",
    "Planner",
    "PlannerProgram",
    "PlannerSolution",
]

_FEASIBILITY_TOL = 1e-9  # [W]


# -- the program --------------------------------------------------------------------------------


class PlannerProgram:
    """The NLP of Eq. 16 for one planner step, built once and updated in place.

    Attributes:
        prog: the MathematicalProgram.
        computation_variables: c̃2, normalised computation parameters, shape (N, σ).
        path_variables: c̃1, normalised path parameter, shape (N,).
        slack_variables: s ≥ 0 of the output constraint per step [W], shape (N,).
        variables: all of them in that order (flattened), the layout of initial guesses.
    """

    def __init__(self, planner: PlannerParams, table: ComputationTable, battery: BatteryParams):
        planner.Validate("planner")
        battery.Validate("battery")
        N, sigma = planner.horizon, table.num_parameters
        self.horizon, self.num_computation = N, sigma
        self.step = float(planner.period)
        self.surrogate = PowerSurrogate(table, planner.power_model)
        self._battery = AsBatteryModel(copy.deepcopy(battery))
        self._budget_per_soc = float(self._battery.PowerBudget(1.0))
        # Per step: free response f at the 2N + 1 half-steps, b0, ĝ(c_prev).
        self._free = np.zeros(2 * N + 1)
        self._soc0 = 1.0
        self._g_prev = 0.0
        strict_lower = np.tril(np.ones((N, N)), -1)
        self._mask_start = strict_lower  # b_k depends on steps j < k
        self._mask_end = strict_lower + np.eye(N)  # b_{k+1} on steps j ≤ k

        prog = MathematicalProgram()
        c2 = prog.NewContinuousVariables(N, sigma, "c2")
        c1 = prog.NewContinuousVariables(N, "c1")
        s = prog.NewContinuousVariables(N, "s")
        prog.AddBoundingBoxConstraint(0.0, 1.0, c2.reshape(-1))
        prog.AddBoundingBoxConstraint(0.0, 1.0, c1)
        self._slack_bounds = prog.AddBoundingBoxConstraint(0.0, 1.0, s)
        w2, w1 = float(planner.computation_weight), float(planner.path_weight)
        n2 = N * sigma
        # Σ w (1 − c̃)² = Σ w c̃² − 2w c̃ + w
        prog.AddQuadraticCost(2 * w2 * np.eye(n2), -2 * w2 * np.ones(n2), w2 * n2, c2.reshape(-1))
        prog.AddQuadraticCost(2 * w1 * np.eye(N), -2 * w1 * np.ones(N), w1 * N, c1)
        prog.AddLinearCost(float(planner.slack_weight) * np.ones(N), 0.0, s)
        self._constraint_vars = np.concatenate((c2.reshape(-1), s))
        prog.AddConstraint(
            self._OutputConstraint,
            np.full(2 * N, -np.inf),
            np.zeros(2 * N),
            self._constraint_vars,
            description="output_constraint",
        )
        self.prog = prog
        self.computation_variables = c2
        self.path_variables = c1
        self.slack_variables = s
        self.variables = np.concatenate((c2.reshape(-1), c1, s))

        self.solver, self.options = MakeSolver(planner, tolerance=1e-6)

    def SetData(self, free_response, soc: float, previous_computation_parameters) -> None:
        """Per-step data: f at t0 + k·h/2, k = 0 … 2N [W]; b0 [-]; c_prev [table units]."""
        f = np.asarray(free_response, dtype=float).reshape(-1)
        if f.size != 2 * self.horizon + 1:
            raise ValueError(
                f"free_response: expected {2 * self.horizon + 1} samples, got {f.size}"
            )
        self._free[:] = f
        self._soc0 = float(soc)
        u_prev = (np.asarray(previous_computation_parameters, float) - self.surrogate.lower) / (
            self.surrogate.span
        )
        self._g_prev = float(self.surrogate.value(u_prev.reshape(1, -1))[0])
        # Largest possible violation (b ≥ 0, ĝ ≤ its max on the box) bounds the slack.
        g_max = (
            self.surrogate.const
            + np.sum(np.abs(self.surrogate.linear))
            + np.sum(np.abs(self.surrogate.hessian))
        )
        s_max = max(float(np.max(f)) + g_max - self._g_prev, 0.0) + 1.0
        self._slack_bounds.evaluator().set_bounds(
            np.zeros(self.horizon), np.full(self.horizon, s_max)
        )

    def _Model(self, u) -> tuple[np.ndarray, np.ndarray]:
        """(load at the start, middle and end of each step (3×N) [W], SoC at the N + 1 nodes [-])
        for normalised c̃2 = u (N×σ), with the surrogate ĝ and the current data."""
        dg = self.surrogate.value(u) - self._g_prev
        ys = StepLoads(self._free, dg)
        return ys, SimpsonSocSteps(ys, self._soc0, self._battery, self.step)

    def Outputs(self, u) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Model of the NLP for normalised c̃2 = u (N×σ): (y at the step starts, y at the step
        ends [W], SoC at the N + 1 nodes [-]), with the surrogate ĝ and the current data."""
        u = np.asarray(u, dtype=float).reshape(self.horizon, self.num_computation)
        ys, soc = self._Model(u)
        return ys[0], ys[2], soc

    def _OutputConstraint(self, x):
        """[y_k⁰ − b_k·Q_c·V − s_k; y_k¹ − b_{k+1}·Q_c·V − s_k] (≤ 0), analytic Jacobian."""
        autodiff = x.dtype == object
        xv = ExtractValue(x).reshape(-1) if autodiff else np.asarray(x, dtype=float)
        N, sigma = self.horizon, self.num_computation
        u = xv[: N * sigma].reshape(N, sigma)
        s = xv[N * sigma :]
        ys, soc = self._Model(u)
        budget = self._battery.PowerBudget(soc)
        out = np.concatenate((ys[0] - budget[:-1] - s, ys[2] - budget[1:] - s))
        if not autodiff:
            return out
        # b_k depends on the offsets of the steps j < k: ∂b_k/∂u_j = ∂Δb_j/∂δ_j · ∇ĝ(u_j).
        grad = self.surrogate.gradient(u)  # N×σ
        dsoc = SimpsonSocSensitivity(ys, self._battery, self.step)  # ∂Δb_j/∂δ_j (N,)
        cross = (-self._budget_per_soc * dsoc)[:, None] * grad  # ∂(−b·Q_c·V)/∂u_j
        J = np.zeros((2 * N, N * sigma + N))
        Ju = J[:, : N * sigma].reshape(2 * N, N, sigma)
        Ju[:N] = self._mask_start[:, :, None] * cross[None, :, :]
        Ju[N:] = self._mask_end[:, :, None] * cross[None, :, :]
        idx = np.arange(N)
        Ju[idx, idx, :] += grad
        Ju[N + idx, idx, :] += grad
        J[idx, N * sigma + idx] = -1.0
        J[N + idx, N * sigma + idx] = -1.0
        return InitializeAutoDiff(out, J @ ExtractGradient(x))

    def Solve(self, initial_guess):
        """Solves from ``initial_guess`` (layout of ``variables``) with the chosen solver."""
        return self.solver.Solve(self.prog, np.asarray(initial_guess, float), self.options)


def MakePlannerProgram(
    planner: PlannerParams, table: ComputationTable, battery: BatteryParams
) -> PlannerProgram:
    """Builds the planner NLP (Eq. 16) once; see :class:`PlannerProgram` and the module notes.

    Returns the program object with ``prog`` and its decision variables
    (``computation_variables`` N×σ, ``path_variables`` N, ``slack_variables`` N, all normalised
    parameters in [0, 1], slack in W); set the step's data with ``SetData`` and ``Solve``.
    """
    return PlannerProgram(planner, table, battery)


# -- one planner step ---------------------------------------------------------------------------


@dc.dataclass
class PlannerSolution:
    """Result of one planner step (all parameters in table units / m²)."""

    computation_parameters: np.ndarray
    """c2 to apply now (σ,)."""
    path_parameter: float
    """c1 to apply now [m²] (rate-limited)."""
    computation_trajectory: np.ndarray
    """Mapped (admissible) c2 over the horizon (N×σ)."""
    relaxed_computation: np.ndarray | None
    """Relaxed NLP optimum over the horizon (N×σ); None when no NLP was solved (integer
    parameters: :meth:`Planner.Relax` gives it) or the solve failed."""
    slack: np.ndarray | None
    """Output-constraint slack per step [W]; None when ``relaxed_computation`` is."""
    soc_prediction: np.ndarray
    """SoC at the N + 1 nodes under the mapped trajectory (exact g, Simpson) [-]; NaN after a
    failed solve (no prediction)."""
    time_to_reserve: float
    """t_b [s] until the reserve SoC (or brown-out) under the mapped trajectory, capped at the
    longest coverage time; NaN after a failed solve (no prediction)."""
    success: bool
    """The step was planned (False: failed solve or invalid input, deterministic fallback)."""
    feasible: bool
    """The applied c2 keeps y ≤ b·Q_c·V over the first step with the exact table."""
    status: str
    solve_time: float
    """Wall time of the NLP solve [s] (0 when none was needed)."""
    warm_start: np.ndarray
    """Initial guess for the next step (solution shifted by one step)."""


class Planner:
    """One planner step of Alg. 2 (NLP, integer mapping, path rule) as a plain Python object.

    Args:
        planner: planner parameters (horizon, weights, bounds, IPOPT limits).
        table: the computation power table g (exact; grids = admissible values).
        order: Fourier order r of the energy model (q̂ has 2r + 1 entries).
        battery: Rint battery parameters (reserve_soc is the t_b target).
        coverage_time_bounds: (t at c̲1, t at c̄1) [s] of the linear coverage-time model.
        integer: computation parameters take only grid values (then :meth:`Plan` needs no NLP).

    The parameters are copied: later changes to the caller's objects do not reach the planner.
    """

    def __init__(
        self,
        planner: PlannerParams,
        table: ComputationTable,
        order: int,
        battery: BatteryParams,
        coverage_time_bounds,
        integer: bool = True,
    ):
        planner = copy.deepcopy(planner)
        battery = copy.deepcopy(battery)
        self.params = planner
        self.table = table
        self.order = order  # int r, or AugmentedOrder (energy_model)
        self.state_size = StateSize(order)
        self.battery = battery
        self.battery_model = AsBatteryModel(battery)
        self.coverage_time = CoverageTimeModel(
            tuple(planner.path_parameter_bounds), tuple(coverage_time_bounds)
        )
        self.integer = bool(integer)
        self.program = MakePlannerProgram(planner, table, battery)
        N, h = planner.horizon, float(planner.period)
        self.horizon, self.step = N, h
        self.lower, self.upper, self.span = table.lower, table.upper, table.upper - table.lower
        self._budget_per_soc = float(self.battery_model.PowerBudget(1.0))
        # Candidates of the integer mapping, best objective first (ties: larger parameters).
        grid, power = GridCandidates(table)
        u = (grid - self.lower) / self.span
        score = np.sum((1.0 - u) ** 2, axis=1)
        order_idx = np.lexsort((-np.sum(u, axis=1), score))
        self.candidates = grid[order_idx]
        """Grid points of c2, best objective first (ties: larger parameters)."""
        self.candidate_power = power[order_idx]
        self._lowest_candidate = int(np.flatnonzero(np.all(self.candidates == self.lower, 1))[0])
        # Rollout length: t_b is only needed up to the longest remaining coverage time, and never
        # beyond the longest flight a scenario may ask for (bounds the rows in memory).
        longest = min(float(self.coverage_time.times[1]), MAX_TIME_LIMIT)
        self._num_half = 2 * max(N, math.ceil(longest / h) + 1) + 1
        self._rows_period = None
        self._rows = None
        self.num_variables = self.program.variables.size

    def LowestWarmStart(self) -> np.ndarray:
        """Initial guess at the lowest parameters and zero slack."""
        return np.zeros(self.num_variables)

    def ResponseRows(self, period: float) -> np.ndarray:
        """[C; C A_h; …] at the half steps h_T/2 of the rollout for the period T [s] (cached)."""
        if self._rows_period != period:
            self._rows = FreeResponseMatrix(self.order, period, 0.5 * self.step, self._num_half)
            self._rows_period = period
        return self._rows

    def StepFeasible(self, f3, dg, soc) -> tuple[np.ndarray, np.ndarray]:
        """(y ≤ b·Q_c·V at the start and the end of one step, SoC at its end) for the load
        offsets ``dg`` [W] (array) given the free response at the step's start, middle, end."""
        dg = np.atleast_1d(dg)
        loads = StepLoads(np.asarray(f3, dtype=float)[:, None], dg[None, :])  # 3×1×K
        soc_end = SimpsonSocSteps(loads, soc, self.battery_model, self.step)[1]
        ok = (f3[0] + dg <= self._budget_per_soc * soc + _FEASIBILITY_TOL) & (
            f3[2] + dg <= self._budget_per_soc * soc_end + _FEASIBILITY_TOL
        )
        return ok, soc_end

    def _MapStep(self, f3, relaxed_c, g_prev, soc):
        """Admissible c for one step: (c, feasible, SoC at the end of the step)."""
        if self.integer:
            ok, soc_end = self.StepFeasible(f3, self.candidate_power - g_prev, soc)
            hits = np.flatnonzero(ok)
            i = int(hits[0]) if hits.size else self._lowest_candidate  # none: the lowest
            return self.candidates[i].copy(), bool(hits.size), float(soc_end[i])
        # Continuous: the largest feasible point on the path c̲ → relaxed → c̄ (λ = 0, 1, 2).
        c_mid = self.table.clamp(relaxed_c)

        def at(lam):
            if lam <= 1.0:
                return self.lower + lam * (c_mid - self.lower)
            return c_mid + (lam - 1.0) * (self.upper - c_mid)

        def check(lam):
            return self.StepFeasible(f3, self.table.power(at(lam)) - g_prev, soc)

        if check(2.0)[0][0]:
            lo = 2.0
        elif not check(0.0)[0][0]:
            lo = 0.0
        else:
            lo, hi = 0.0, 2.0
            for _ in range(40):  # bisection (feasibility is monotone along the path for g ↑)
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if check(mid)[0][0] else (lo, mid)
        ok, soc_end = check(lo)
        return at(lo), bool(ok[0]), float(soc_end[0])

    def TimeToReserve(self, f_half, dg_steps, soc0: float) -> float:
        """t_b [s] of :func:`~eaplan_drake.planning.prediction.TimeToReserve` with this planner's
        battery
        and step: ``f_half`` the free response at t0 + k·h/2 [W], ``dg_steps`` the planned
        g(c_k) − g(c_prev) [W] (the last one held), ``soc0`` [-]."""
        return TimeToReserve(f_half, dg_steps, soc0, self.battery_model, self.step)

    def Fallback(
        self, path_parameter: float, status: str, warm=None, computation=None
    ) -> PlannerSolution:
        """After a failed solve: c1 kept (the lowest if not finite), c2 = ``computation`` (the
        largest the exact check admits, from :meth:`Plan`) or the lowest."""
        N = self.horizon
        lo1 = self.coverage_time.bounds[0]
        c1 = path_parameter if math.isfinite(path_parameter) else lo1
        c2 = self.lower.copy() if computation is None else np.asarray(computation, float)
        return PlannerSolution(
            computation_parameters=c2.copy(),
            path_parameter=float(c1),
            computation_trajectory=np.tile(c2, (N, 1)),
            relaxed_computation=None,
            slack=None,
            soc_prediction=np.full(N + 1, np.nan),
            time_to_reserve=math.nan,
            success=False,
            feasible=False,
            status=status,
            solve_time=0.0,
            warm_start=self.LowestWarmStart() if warm is None else warm,
        )

    def Relax(self, f_half, soc: float, computation_parameters, warm_start=None):
        """Solves the NLP (Eq. 16) of one step: ``f_half`` the free response at t0 + k·h/2
        (at least 2N + 1 samples) [W], b0 = ``soc`` [-], the parameters c_prev applied now and an
        initial guess (layout of ``PlannerProgram.variables``; None: the lowest).

        Returns (x, status, solve time [s]); x is None after a failed solve (never raised).
        """
        prog = self.program
        prog.SetData(np.asarray(f_half, float)[: 2 * self.horizon + 1], soc, computation_parameters)
        x0 = self.LowestWarmStart() if warm_start is None else np.asarray(warm_start, float)
        t0 = time.perf_counter()
        try:
            result = prog.Solve(x0)
            ok = result.is_success()
            status = result.get_solution_result().name
        except RuntimeError as e:  # solver/Drake errors are a failed solve, never raised
            result, ok, status = None, False, f"error: {e}"
        solve_time = time.perf_counter() - t0
        x = result.get_x_val() if ok else None
        if ok and not np.all(np.isfinite(x)):
            x, status = None, "non-finite solution"
        return x, status, solve_time

    def _Unpack(self, x, x0):
        """(relaxed c2 [N × σ, table units], slack [N], next warm start) of the relaxed solution
        ``x`` (None: no NLP was solved; the warm start stays ``x0``): the next warm start is
        ``x`` shifted by one step, its last step repeated."""
        if x is None:
            return None, None, x0
        N, sigma = self.horizon, self.table.num_parameters
        nc = N * sigma
        u = np.clip(x[:nc].reshape(N, sigma), 0.0, 1.0)
        slack = x[nc + N :].copy()
        relaxed = self.lower + u * self.span
        warm = np.concatenate(
            (
                np.vstack((u[1:], u[-1:])).reshape(-1),
                np.concatenate((x[nc + 1 : nc + N], x[nc + N - 1 : nc + N])),
                np.concatenate((slack[1:], slack[-1:])),
            )
        )
        return relaxed, slack, warm

    def _MapTrajectory(self, f_half, relaxed, g_prev, soc: float):
        """The horizon mapped onto admissible values with the exact table, step by step
        (``_MapStep``): (c2 per step [N × σ], SoC at the N + 1 nodes, whether the first
        step is feasible)."""
        N, sigma = self.horizon, self.table.num_parameters
        mapped = np.empty((N, sigma))
        soc_nodes = np.empty(N + 1)
        soc_nodes[0] = soc
        feasible_first = True
        for k in range(N):
            c, feasible, soc_nodes[k + 1] = self._MapStep(
                f_half[2 * k : 2 * k + 3],
                None if relaxed is None else relaxed[k],
                g_prev,
                soc_nodes[k],
            )
            mapped[k] = c
            if k == 0:
                feasible_first = feasible
        return mapped, soc_nodes, feasible_first

    def Plan(
        self,
        energy_coefficients,
        soc: float,
        period: float,
        coverage_remaining: float,
        computation_parameters,
        path_parameter: float,
        warm_start=None,
    ) -> PlannerSolution:
        """One planner step from q̂ [W], b0, T [s], the coverage fraction left, the parameters
        applied now (c2, c1) and an initial guess (None: the lowest parameters)."""
        q = np.asarray(energy_coefficients, dtype=float).reshape(-1)
        c_prev = np.asarray(computation_parameters, dtype=float).reshape(-1)
        if q.size != self.state_size:
            raise ValueError(f"energy_coefficients: expected {self.state_size}, got {q.size}")
        inputs = np.concatenate((q, c_prev, [soc, period, coverage_remaining, path_parameter]))
        if not np.all(np.isfinite(inputs)) or period <= 0.0:
            return self.Fallback(path_parameter, "invalid input (non-finite or period <= 0)")
        f_half = self.ResponseRows(float(period)) @ q
        x0 = self.LowestWarmStart() if warm_start is None else np.asarray(warm_start, float)
        if self.integer:  # the mapping enumerates the grid: the relaxed optimum is not read
            x, status, solve_time = None, "integer parameters: exact mapping, no NLP", 0.0
        else:
            x, status, solve_time = self.Relax(f_half, soc, c_prev, x0)
            if x is None:  # deterministic fallback: the largest c2 the exact check admits now
                c2, _, _ = self._MapStep(f_half[0:3], self.upper, self.table.power(c_prev), soc)
                out = self.Fallback(path_parameter, f"solver failed: {status}", computation=c2)
                out.solve_time = solve_time
                return out
        relaxed, slack, warm = self._Unpack(x, x0)
        g_prev = self.table.power(c_prev)
        mapped, soc_nodes, feasible_first = self._MapTrajectory(f_half, relaxed, g_prev, soc)
        dg = np.array([self.table.power(c) for c in mapped]) - g_prev
        t_b = self.TimeToReserve(f_half, dg, float(soc))
        c1 = ChoosePathParameter(
            t_b,
            coverage_remaining,
            self.coverage_time,
            previous=path_parameter,
            max_step=float(self.params.path_parameter_step),
            deadband=float(self.params.path_parameter_deadband),
        )
        return PlannerSolution(
            computation_parameters=mapped[0].copy(),
            path_parameter=float(c1),
            computation_trajectory=mapped,
            relaxed_computation=relaxed,
            slack=slack,
            soc_prediction=soc_nodes,
            time_to_reserve=t_b,
            success=True,
            feasible=feasible_first,
            status=status,
            solve_time=solve_time,
            warm_start=warm,
        )
