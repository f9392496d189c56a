"""Planner-scheduler: output MPC with MathematicalProgram + IPOPT (paper 003 Eq. 16, Alg. 2).

Every h_T [s] the planner turns the estimated energy state q̂ [W], the SoC b0 [-], the period T [s]
and the fraction of the survey still to cover into the path parameter c1 [m²] and the σ
computation parameters c2 [table units].

**The NLP (Alg. 2 l. 16, Eq. 16).** Horizon of N steps of h_T; parameters held over each step,
normalised c̃ = (c − c̲)/(c̄ − c̲) ∈ [0, 1]. The energy model is linear, so q is eliminated:
with the exact discretisation q⁺ = A_d q + B Δg_k and Δg_k = g(c_k) − g(c_{k−1}), the sum of the
jumps telescopes and the output at any time t in step k is

    y(t) = C expm(A (t − t0)) q̂ + g(c_k) − g(c_prev) =: f(t) + g(c_k) − g(c_prev),

with f the free response of the Fourier model from q̂ (computed with the exact rotation blocks of
:func:`~eaplan_drake.energy_model.DiscreteFourierMatrices`) and c_prev the parameters applied now.
The Rint battery ḃ = −k_b I(y)/Q_c does not depend on b, so RK4 over a step reduces to Simpson's
rule on f at the start, middle and end of the step (exact up to O(h⁵)):

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
It is solved with :class:`~pydrake.solvers.IpoptSolver` explicitly, warm-started from the previous
solution shifted by one step, with the IPOPT options ``max_wall_time`` and ``max_iter``.

**Integer parameters.** The relaxed optimum is mapped to the table grid step by step: at step k
the chosen grid point is the one with the best objective Σ_i w2 (1 − c̃_i)² among all grid points
whose output satisfies y ≤ b·Q_c·V at the start and end of the step, checked with the *exact*
table g and the SoC predicted under the already mapped steps (for σ = 1: the largest admissible
grid value that keeps the constraint). If none does, the lowest grid point is taken (infeasible
step). For σ = 1 the relaxed optimum therefore only matters through the slack (infeasibility)
and the warm start; the exact table decides the grid value. Non-integer parameters
(``integer=False``) take the largest point on the path c̲ → relaxed optimum → c̄ that satisfies the
exact constraint (bisection).

**Path rule (Alg. 2 l. 17–27).** The model and the battery are rolled forward (exact f, exact g,
Simpson) under the mapped trajectory, then with the last parameters held, until b reaches the
reserve SoC (or a brown-out): that time is t_b. The remaining coverage time is
t_r(c1) = f_cov · t(c1), with f_cov the fraction of the survey still to cover and
t(c1) = ν c1 + τ the linear coverage-time model of Eq. 10 through (c̲1, t̲) and (c̄1, t̄). The
largest c1 with t_r(c1) ≤ t_b is, in closed form, c1* = c̲1 + (t_b / f_cov − t̲)/ν, clipped to
[c̲1, c̄1] (the lowest when even c̲1 does not fit); c1 then moves towards c1* by at most δ1 per
update (rate limit against chattering).
"""

import dataclasses as dc
import itertools
import math
import time

import numpy as np
from pydrake.autodiffutils import ExtractGradient, ExtractValue, InitializeAutoDiff
from pydrake.solvers import IpoptSolver, MathematicalProgram, SolverOptions
from pydrake.systems.framework import LeafSystem

from eaplan_drake.battery import IsBrownout, PowerBudget, SocDerivative
from eaplan_drake.computation import ComputationTable
from eaplan_drake.energy_model import FreeResponseMatrix, StateSize
from eaplan_drake.params import BatteryParams, PlannerParams

__all__ = [
    "ChoosePathParameter",
    "CoverageTimeModel",
    "FreeResponse",
    "MakePlannerProgram",
    "Planner",
    "PlannerProgram",
    "PlannerScheduler",
    "PlannerSolution",
    "SimpsonSoc",
]

_MAX_GRID_POINTS = 100_000
_FEASIBILITY_TOL = 1e-9  # [W]


# -- pure helpers -------------------------------------------------------------------------------


def FreeResponse(q_hat, order: int, period: float, step: float, num_points: int) -> np.ndarray:
    """f(k·step) = C expm(A k·step) q̂ for k = 0 … num_points − 1 [W] (exact rotation blocks,
    :func:`~eaplan_drake.energy_model.FreeResponseMatrix`)."""
    rows = FreeResponseMatrix(order, period, step, num_points)
    return rows @ np.asarray(q_hat, dtype=float).reshape(-1)


def SimpsonSoc(y_half, soc0: float, battery: BatteryParams, step: float) -> np.ndarray:
    """SoC at the nodes of steps of length ``step`` [s] for the load y sampled every step/2.

    ``y_half`` holds y at t = 0, step/2, step, … (2n + 1 samples for n steps) [W]. ḃ does not
    depend on b, so RK4 is Simpson's rule: b_{k+1} = b_k + step·(ḃ⁰ + 4ḃ^½ + ḃ¹)/6. Returns the
    n + 1 node values (not clipped). Brown-out loads use the current at the maximum power.
    """
    bdot = np.asarray(SocDerivative(np.asarray(y_half, dtype=float), battery))
    drop = step * (bdot[0:-2:2] + 4.0 * bdot[1:-1:2] + bdot[2::2]) / 6.0
    return soc0 + np.concatenate(([0.0], np.cumsum(drop)))


@dc.dataclass(frozen=True)
class CoverageTimeModel:
    """Linear coverage time t(c1) = ν c1 + τ [s] of paper 003 Eq. 10 (ρ = 1).

    Through (c̲1, t̲) and (c̄1, t̄): ``times`` = (t at c̲1, t at c̄1) [s], ``bounds`` = (c̲1, c̄1) [m²].
    """

    bounds: tuple[float, float]
    times: tuple[float, float]

    def __post_init__(self):
        lo, hi = (float(v) for v in self.bounds)
        t_lo, t_hi = (float(v) for v in self.times)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
            raise ValueError(
                f"path_parameter_bounds: need finite c1_min <= c1_max, got {self.bounds}"
            )
        if not (math.isfinite(t_lo) and math.isfinite(t_hi) and 0.0 < t_lo <= t_hi):
            raise ValueError(
                "coverage_time_bounds: need finite 0 < t(c1_min) <= t(c1_max) [s], "
                f"got {self.times}"
            )
        object.__setattr__(self, "bounds", (lo, hi))
        object.__setattr__(self, "times", (t_lo, t_hi))

    @property
    def nu(self) -> float:
        """ν [s/m²] (0 for a degenerate range c̲1 = c̄1)."""
        lo, hi = self.bounds
        return 0.0 if hi == lo else (self.times[1] - self.times[0]) / (hi - lo)

    @property
    def tau(self) -> float:
        """τ [s]."""
        return self.times[0] - self.nu * self.bounds[0]

    def __call__(self, c1) -> float:
        return self.nu * float(c1) + self.tau


def ChoosePathParameter(
    time_to_reserve: float,
    coverage_remaining: float,
    model: CoverageTimeModel,
    previous: float | None = None,
    max_step: float = math.inf,
    deadband: float = 0.0,
) -> float:
    """Alg. 2 l. 24–27: the largest c1 with coverage_remaining · t(c1) ≤ t_b, else c̲1.

    Closed form from the linear model (Eq. 10); then c1 moves from ``previous`` towards it by at
    most ``max_step`` [m²] (rate limit; no limit when ``previous`` is None). Hysteresis: a rise
    smaller than ``deadband`` [m²] is not taken (cuts always are), so that the jump of the
    remaining fraction after a re-plan (whole repetitions) does not make c1 chatter.
    """
    lo, hi = model.bounds
    t_b = max(float(time_to_reserve), 0.0)
    fraction = min(max(float(coverage_remaining), 0.0), 1.0)
    if fraction * model(hi) <= t_b:
        target = hi
    elif fraction * model(lo) > t_b or model.nu <= 0.0:
        target = lo
    else:  # fraction > 0 and ν > 0 here
        target = min(max((t_b / fraction - model.tau) / model.nu, lo), hi)
    if previous is None or not math.isfinite(previous):
        return target
    if previous < target < previous + deadband:
        return float(previous)
    return min(max(target, previous - max_step), previous + max_step)


class PowerSurrogate:
    """Smooth model ĝ(c̃) of the table on normalised parameters c̃ ∈ [0, 1]^σ (value, gradient)."""

    def __init__(self, table: ComputationTable, kind: str):
        sigma = table.num_parameters
        self.span = table.upper - table.lower
        self.lower = table.lower
        pairs = [(i, j) for i in range(sigma) for j in range(i, sigma)]
        points = np.array(list(itertools.product(*table.parameter_grids)))
        if kind == "quadratic" and points.shape[0] >= 1 + sigma + len(pairs):
            u = (points - self.lower) / self.span
            g = np.array([table.power(p) for p in points])
            X = np.column_stack([np.ones(len(u)), u] + [u[:, i] * u[:, j] for i, j in pairs])
            coef = np.linalg.lstsq(X, g, rcond=None)[0]
            self.const = float(coef[0])
            self.linear = coef[1 : 1 + sigma].copy()
            H = np.zeros((sigma, sigma))
            for (i, j), a in zip(pairs, coef[1 + sigma :], strict=True):
                H[i, j] += a
                H[j, i] += a  # ĝ = const + linᵀu + ½ uᵀHu, H symmetric
            self.hessian = H
            self.kind = "quadratic"
        else:  # Eq. 11: Σ_j ν_j c_j + τ_j, in normalised units
            nu, tau = table.scaling_factors()
            self.const = float(np.sum(nu * self.lower + tau))
            self.linear = nu * self.span
            self.hessian = np.zeros((sigma, sigma))
            self.kind = "linear"

    def value(self, u: np.ndarray) -> np.ndarray:
        """ĝ for each row of u (n×σ) [W]."""
        return self.const + u @ self.linear + 0.5 * np.einsum("ki,ij,kj->k", u, self.hessian, u)

    def gradient(self, u: np.ndarray) -> np.ndarray:
        """∂ĝ/∂c̃ for each row of u (n×σ) [W]."""
        return self.linear + u @ self.hessian


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
        self._battery = battery
        self._budget_per_soc = float(PowerBudget(1.0, battery))
        self._drain_coef = self.step * battery.k_b / battery.capacity  # [1/A]
        V, R = float(battery.voltage), float(battery.internal_resistance)
        self._V2, self._4R = V * V, 4.0 * R
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

        self.solver = IpoptSolver()
        self.options = SolverOptions()
        sid = self.solver.id()
        if planner.max_wall_time > 0.0:  # opt-in real-time budget: results then depend on the CPU
            self.options.SetOption(sid, "max_wall_time", float(planner.max_wall_time))
        self.options.SetOption(sid, "max_iter", int(planner.max_iterations))
        self.options.SetOption(sid, "tol", 1e-6)
        self.options.SetOption(sid, "print_level", 0)
        self.options.SetOption(sid, "sb", "yes")

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

    def Outputs(self, u) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Model of the NLP for normalised c̃2 = u (N×σ): (y at the step starts, y at the step
        ends [W], SoC at the N + 1 nodes [-]), with the surrogate ĝ and the current data."""
        u = np.asarray(u, dtype=float).reshape(self.horizon, self.num_computation)
        dg = self.surrogate.value(u) - self._g_prev
        f = self._free
        ys = np.stack((f[0:-2:2] + dg, f[1:-1:2] + dg, f[2::2] + dg))
        bdot = np.asarray(SocDerivative(ys, self._battery))
        drop = self.step * (bdot[0] + 4.0 * bdot[1] + bdot[2]) / 6.0
        return ys[0], ys[2], self._soc0 + np.concatenate(([0.0], np.cumsum(drop)))

    def _OutputConstraint(self, x):
        autodiff = x.dtype == object
        xv = ExtractValue(x).reshape(-1) if autodiff else np.asarray(x, dtype=float)
        N, sigma = self.horizon, self.num_computation
        u = xv[: N * sigma].reshape(N, sigma)
        s = xv[N * sigma :]
        dg = self.surrogate.value(u) - self._g_prev
        f = self._free
        ys = np.stack((f[0:-2:2] + dg, f[1:-1:2] + dg, f[2::2] + dg))  # 3×N
        disc = np.sqrt(np.maximum(self._V2 - self._4R * ys, 1e-12))
        current = 2.0 * ys / (np.sqrt(self._V2) + disc)
        drain = self._drain_coef * (current[0] + 4.0 * current[1] + current[2]) / 6.0
        soc = self._soc0 - np.concatenate(([0.0], np.cumsum(drain)))
        budget = self._budget_per_soc * soc
        out = np.concatenate((ys[0] - budget[:-1] - s, ys[2] - budget[1:] - s))
        if not autodiff:
            return out
        # ∂drain_j/∂u_j = coef · Simpson(dI/dy) · ∇ĝ(u_j); dI/dy = 1 / sqrt(V² − 4 R y).
        grad = self.surrogate.gradient(u)  # N×σ
        ddrain = self._drain_coef * ((1.0 / disc[0] + 4.0 / disc[1] + 1.0 / disc[2]) / 6.0)
        cross = (self._budget_per_soc * ddrain)[:, None] * grad  # −∂budget_k/∂u_j = +QV ∂drain
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
        """Solves with IPOPT from ``initial_guess`` (layout of :attr:`variables`)."""
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
    """Relaxed NLP optimum over the horizon (N×σ), None if the solve failed."""
    slack: np.ndarray | None
    """Output-constraint slack per step [W], None if the solve failed."""
    soc_prediction: np.ndarray
    """SoC at the N + 1 nodes under the mapped trajectory (exact g, Simpson) [-]; NaN after a
    failed solve (no prediction)."""
    time_to_reserve: float
    """t_b [s] until the reserve SoC (or brown-out) under the mapped trajectory, capped at the
    longest coverage time; NaN after a failed solve (no prediction)."""
    success: bool
    """The NLP solved (False: fallback to the lowest parameters)."""
    feasible: bool
    """The applied c2 keeps y ≤ b·Q_c·V over the first step with the exact table."""
    status: str
    solve_time: float
    """Wall time of the IPOPT solve [s]."""
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
        integer: computation parameters take only grid values.
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
        self.params = planner
        self.table = table
        self.order = order  # int r, or AugmentedOrder (energy_model)
        self.state_size = StateSize(order)
        self.battery = battery
        self.coverage_time = CoverageTimeModel(
            tuple(planner.path_parameter_bounds), tuple(coverage_time_bounds)
        )
        self.integer = bool(integer)
        self.program = MakePlannerProgram(planner, table, battery)
        N, h = planner.horizon, float(planner.period)
        self.horizon, self.step = N, h
        self.lower, self.upper, self.span = table.lower, table.upper, table.upper - table.lower
        self._budget_per_soc = float(PowerBudget(1.0, battery))
        # Candidates of the integer mapping, best objective first (ties: larger parameters).
        n_grid = math.prod(g.size for g in table.parameter_grids)
        if n_grid > _MAX_GRID_POINTS:
            raise ValueError(
                f"table: {n_grid} grid combinations, at most {_MAX_GRID_POINTS} are supported"
            )
        grid = np.array(list(itertools.product(*table.parameter_grids)), dtype=float)
        u = (grid - self.lower) / self.span
        score = np.sum((1.0 - u) ** 2, axis=1)
        order_idx = np.lexsort((-np.sum(u, axis=1), score))
        self.candidates = grid[order_idx]
        """Grid points of c2, best objective first (ties: larger parameters)."""
        self.candidate_power = np.array([table.power(c) for c in self.candidates])
        self._lowest_candidate = int(np.flatnonzero(np.all(self.candidates == self.lower, 1))[0])
        # Rollout length: t_b is only needed up to the longest remaining coverage time.
        self._num_half = 2 * max(N, math.ceil(self.coverage_time.times[1] / h) + 1) + 1
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

    def _StepSoc(self, f3: np.ndarray, dg, soc: float) -> np.ndarray:
        """SoC after one step for load offsets dg (array) given f at start/mid/end."""
        y = f3[:, None] + np.atleast_1d(dg)[None, :]
        bdot = np.asarray(SocDerivative(y, self.battery))
        return soc + self.step * (bdot[0] + 4.0 * bdot[1] + bdot[2]) / 6.0

    def StepFeasible(self, f3, dg, soc) -> tuple[np.ndarray, np.ndarray]:
        """(y ≤ b·Q_c·V at the start and the end of one step, SoC at its end) for the load
        offsets ``dg`` [W] (array) given the free response at the step's start, middle, end."""
        dg = np.atleast_1d(dg)
        soc_end = self._StepSoc(f3, dg, soc)
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
        """t_b [s] (Alg. 2 l. 17–23): time until the SoC reaches the reserve, or a brown-out.

        ``f_half``: free response at t0 + k·h/2 (2n + 1 samples, n steps) [W]; ``dg_steps``:
        g(c_k) − g(c_prev) of the planned steps [W], the last one held to the end. Simpson per
        step, linear interpolation inside the step that crosses; capped at n·h.
        """
        reserve = float(self.battery.reserve_soc)
        if soc0 <= reserve:
            return 0.0
        f_half = np.asarray(f_half, dtype=float)
        dg_steps = np.asarray(dg_steps, dtype=float).reshape(-1)
        n = (f_half.size - 1) // 2
        dg = np.full(n, dg_steps[-1])
        dg[: min(n, dg_steps.size)] = dg_steps[:n]
        ys = np.stack((f_half[0:-2:2] + dg, f_half[1:-1:2] + dg, f_half[2::2] + dg))
        bdot = np.asarray(SocDerivative(ys, self.battery))
        drop = self.step * (bdot[0] + 4.0 * bdot[1] + bdot[2]) / 6.0
        soc = soc0 + np.concatenate(([0.0], np.cumsum(drop)))
        t_b = n * self.step
        below = np.flatnonzero(soc <= reserve)
        if below.size:
            k = int(below[0])  # soc[k − 1] > reserve ≥ soc[k], k ≥ 1
            frac = (soc[k - 1] - reserve) / (soc[k - 1] - soc[k])
            t_b = (k - 1 + frac) * self.step
        brown = IsBrownout(ys, self.battery.voltage, self.battery.internal_resistance)
        steps = np.flatnonzero(np.any(brown, axis=0))
        if steps.size:  # earliest brown-out sample of the first step that has one
            k = int(steps[0])
            t_b = min(t_b, (k + 0.5 * int(np.argmax(brown[:, k]))) * self.step)
        return float(t_b)

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
        N, sigma = self.horizon, self.table.num_parameters
        f_half = self.ResponseRows(float(period)) @ q
        prog = self.program
        prog.SetData(f_half[: 2 * N + 1], soc, c_prev)
        x0 = self.LowestWarmStart() if warm_start is None else np.asarray(warm_start, float)
        t0 = time.perf_counter()
        try:
            result = prog.Solve(x0)
            ok = result.is_success()
            status = result.get_solution_result().name
        except RuntimeError as e:  # IPOPT/Drake errors are a failed solve, never raised
            result, ok, status = None, False, f"error: {e}"
        solve_time = time.perf_counter() - t0
        if ok:
            x = result.get_x_val()
            ok = bool(np.all(np.isfinite(x)))
        if not ok:  # deterministic fallback: the largest c2 the exact check admits now
            c2, _, _ = self._MapStep(f_half[0:3], self.upper, self.table.power(c_prev), soc)
            out = self.Fallback(path_parameter, f"solver failed: {status}", computation=c2)
            out.solve_time = solve_time
            return out
        nc = N * sigma
        u = np.clip(x[:nc].reshape(N, sigma), 0.0, 1.0)
        slack = x[nc + N :].copy()
        relaxed = self.lower + u * self.span
        # Integer mapping with the exact table, step by step.
        g_prev = self.table.power(c_prev)
        mapped = np.empty((N, sigma))
        soc_nodes = np.empty(N + 1)
        soc_nodes[0] = soc
        feasible_first = True
        for k in range(N):
            c, feasible, soc_nodes[k + 1] = self._MapStep(
                f_half[2 * k : 2 * k + 3], relaxed[k], g_prev, soc_nodes[k]
            )
            mapped[k] = c
            if k == 0:
                feasible_first = feasible
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
        warm = np.concatenate(
            (
                np.vstack((u[1:], u[-1:])).reshape(-1),
                np.concatenate((x[nc + 1 : nc + N], x[nc + N - 1 : nc + N])),
                np.concatenate((slack[1:], slack[-1:])),
            )
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


# -- the policy seam ----------------------------------------------------------------------------


@dc.dataclass
class PlannerObservation:
    """What a policy sees at a planner step (the :class:`PlannerScheduler` inputs and state)."""

    time: float
    """t [s]."""
    energy_coefficients: np.ndarray
    """q̂ [W] (2r + 1,)."""
    mean_power_variance: float
    """Var(α̂0) = P_00 of the estimator [W²]."""
    soc: float
    """b [-]."""
    period: float
    """T [s]."""
    coverage_remaining: float
    """Fraction of the survey still to fly [-]."""
    remaining_time: np.ndarray
    """Exact remaining time t_rem(c1_j) at the sequencer's c1 grid [s] (M,)."""
    path_parameter: float
    """c1 applied now [m²]."""
    computation_parameters: np.ndarray
    """c2 applied now (σ,) [table units]."""


@dc.dataclass
class PlannerDecision:
    """What a policy answers: the parameters to apply and its memory for the next step."""

    path_parameter: float
    """c1 [m²]."""
    computation_parameters: np.ndarray
    """c2 (σ,) [table units]."""
    memory: np.ndarray
    """The policy's memory for the next step (e.g. a warm start), kept in the context."""
    success: bool = True
    """False when the policy's solver failed and a deterministic fallback answered."""
    feasible: bool = True
    """False when the policy's constraint (mpc: completing the survey above the reserve plus the
    margin even at the lowest quality; paper: y ≤ b·Q_c·V) cannot be met."""
    status: str = ""
    solve_time: float = 0.0
    """Wall time of the solver [s] (statistics only; never changes a decision)."""


class PlannerPolicy:
    """A planner-scheduler policy: subclass and implement :meth:`Plan` (and
    :meth:`InitialMemory` if the policy remembers anything between steps, e.g. a warm start).

    A policy must be a function of its arguments: any memory goes through ``memory`` (it lives in
    the Drake context), so a simulation depends on its scenario only.
    """

    name = "policy"
    acts = True
    """False for a policy that never changes the parameters (no update event is declared)."""

    def InitialMemory(self) -> np.ndarray:
        """The memory at t = 0 (a vector; may be empty)."""
        return np.zeros(0)

    def Plan(self, observation: PlannerObservation, memory: np.ndarray) -> PlannerDecision:
        raise NotImplementedError


# -- Drake system -------------------------------------------------------------------------------


class PlannerScheduler(LeafSystem):
    """The planner-scheduler of paper 003 Alg. 2 as a periodic discrete system around a policy.

    Every h_T = ``period`` [s], from t = ``warmup`` on, it hands the inputs (q̂ [W], Var(α̂0) [W²],
    b [-], T [s], the coverage fraction left and the exact remaining time at each c1 of the grid
    [s]) and the parameters applied now to ``policy`` (:class:`PlannerPolicy`; see
    :mod:`eaplan_drake.policies`: mpc, paper, greedy, greedy_authors, static) and applies its
    answer. Before the warm-up, and always for a policy that does not act, the outputs hold the
    initial parameters. ``mission_feasible`` is 1 while the policy's constraint can be met and 0
    after a step where it cannot (mpc: not even the lowest-quality plan completes the survey above
    the reserve plus the margin; it then flies the lowest plan).

    Discrete state: [c1] (group 0), [c2] (group 1), [mission_feasible] (group 2), the policy's
    memory (group 3); the outputs are the state (no direct feedthrough, so no algebraic loop).
    The solve statistics (:meth:`statistics`) are Python-side attributes of the System, *not*
    Drake state: they accumulate over every context/simulation of this instance
    (:meth:`reset_statistics`) and never change a decision.

    .. pydrake_system::

        name: PlannerScheduler
        input_ports:
        - energy_coefficients
        - mean_power_variance
        - soc
        - period
        - coverage_remaining
        - remaining_time
        output_ports:
        - path_parameters
        - computation_parameters
        - mission_feasible
    """

    def __init__(
        self,
        policy: PlannerPolicy,
        *,
        table: ComputationTable,
        order: int,
        period: float,
        warmup: float,
        initial_path_parameter: float,
        initial_computation_parameters,
        path_parameter_grid_size: int,
    ):
        super().__init__()
        if not isinstance(policy, PlannerPolicy):
            raise ValueError(f"policy: must be a PlannerPolicy, got {type(policy).__name__}")
        self._policy = policy
        self._table = table
        c2_0 = np.asarray(initial_computation_parameters, dtype=float).reshape(-1)
        if c2_0.size != table.num_parameters or not np.all(np.isfinite(c2_0)):
            raise ValueError(
                f"initial_computation_parameters: expected {table.num_parameters} finite "
                f"value(s), got {initial_computation_parameters!r}"
            )
        if np.any(c2_0 < table.lower) or np.any(c2_0 > table.upper):
            raise ValueError(
                f"initial_computation_parameters: must lie in [{table.lower}, {table.upper}], "
                f"got {c2_0}"
            )
        c1_0 = float(initial_path_parameter)
        for name, value in (("period", period), ("warmup", warmup), ("initial_path", c1_0)):
            if not math.isfinite(value):
                raise ValueError(f"PlannerScheduler.{name}: must be finite, got {value!r}")
        if not period > 0.0 or warmup < 0.0:
            raise ValueError(
                f"PlannerScheduler: need period > 0 and warmup >= 0 [s], got {period!r}, {warmup!r}"
            )
        m = StateSize(order)
        self._energy_port = self.DeclareVectorInputPort("energy_coefficients", m)
        self._variance_port = self.DeclareVectorInputPort("mean_power_variance", 1)
        self._soc_port = self.DeclareVectorInputPort("soc", 1)
        self._period_port = self.DeclareVectorInputPort("period", 1)
        self._coverage_port = self.DeclareVectorInputPort("coverage_remaining", 1)
        self._remaining_port = self.DeclareVectorInputPort(
            "remaining_time", int(path_parameter_grid_size)
        )
        self._c1_index = self.DeclareDiscreteState(np.array([c1_0]))
        self._c2_index = self.DeclareDiscreteState(c2_0)
        self._feasible_index = self.DeclareDiscreteState(np.ones(1))
        memory = np.asarray(policy.InitialMemory(), dtype=float).reshape(-1)
        self._memory_size = memory.size
        # Drake needs a non-empty group: an empty memory is stored as one unused zero.
        self._memory_index = self.DeclareDiscreteState(memory if memory.size else np.zeros(1))
        self._path_port = self.DeclareStateOutputPort("path_parameters", self._c1_index)
        self._computation_port = self.DeclareStateOutputPort(
            "computation_parameters", self._c2_index
        )
        self._feasible_port = self.DeclareStateOutputPort("mission_feasible", self._feasible_index)
        if policy.acts:
            self.DeclarePeriodicDiscreteUpdateEvent(float(period), float(warmup), self._Update)
        self.reset_statistics()

    @property
    def table(self) -> ComputationTable:
        return self._table

    @property
    def policy(self) -> PlannerPolicy:
        """The policy that decides (for inspection and benchmarks)."""
        return self._policy

    def reset_statistics(self) -> None:
        """Clears the solve statistics."""
        self._solves = 0
        self._failures = 0
        self._infeasible = 0
        self._solve_times: list[float] = []
        self._step_times: list[float] = []

    def statistics(self) -> dict:
        """Solve statistics since construction / :meth:`reset_statistics` (Python-side).

        Keys: solves (planner steps), failures (failed solves answered by the deterministic
        fallback), infeasible (steps whose policy constraint could not be met), solve_times and
        step_times [s] (solver only / the whole step), median_solve_time, p95_solve_time,
        median_step_time, p95_step_time [s] (None before the first solve).
        """

        def pct(v, p):
            return float(np.percentile(v, p)) if v else None

        return {
            "policy": self._policy.name,
            "solves": self._solves,
            "failures": self._failures,
            "infeasible": self._infeasible,
            "solve_times": list(self._solve_times),
            "step_times": list(self._step_times),
            "median_solve_time": pct(self._solve_times, 50),
            "p95_solve_time": pct(self._solve_times, 95),
            "median_step_time": pct(self._step_times, 50),
            "p95_step_time": pct(self._step_times, 95),
        }

    def Observe(self, context) -> PlannerObservation:
        """The observation a policy gets in ``context`` (inputs and applied parameters)."""
        return PlannerObservation(
            time=float(context.get_time()),
            energy_coefficients=np.array(self._energy_port.Eval(context)),
            mean_power_variance=float(self._variance_port.Eval(context)[0]),
            soc=float(self._soc_port.Eval(context)[0]),
            period=float(self._period_port.Eval(context)[0]),
            coverage_remaining=float(self._coverage_port.Eval(context)[0]),
            remaining_time=np.array(self._remaining_port.Eval(context)),
            path_parameter=float(context.get_discrete_state(self._c1_index).GetAtIndex(0)),
            computation_parameters=context.get_discrete_state(self._c2_index).get_value().copy(),
        )

    def _Update(self, context, discrete_state) -> None:
        t0 = time.perf_counter()
        memory = context.get_discrete_state(self._memory_index).get_value()
        decision = self._policy.Plan(self.Observe(context), memory[: self._memory_size].copy())
        self._solves += 1
        if not decision.success:
            self._failures += 1
        if not decision.feasible:
            self._infeasible += 1
        discrete_state.get_mutable_vector(self._c1_index).SetAtIndex(
            0, float(decision.path_parameter)
        )
        discrete_state.get_mutable_vector(self._c2_index).SetFromVector(
            np.asarray(decision.computation_parameters, dtype=float)
        )
        discrete_state.get_mutable_vector(self._feasible_index).SetAtIndex(
            0, 1.0 if decision.feasible else 0.0
        )
        if self._memory_size:
            discrete_state.get_mutable_vector(self._memory_index).SetFromVector(
                np.asarray(decision.memory, dtype=float).reshape(-1)
            )
        self._solve_times.append(float(decision.solve_time))
        self._step_times.append(time.perf_counter() - t0)
