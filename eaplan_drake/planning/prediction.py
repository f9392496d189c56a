"""Prediction helpers shared by every planner policy (paper 003 Eq. 10, 16f, Alg. 2 l. 17–27).

Pure functions over numpy, one implementation each:

- :func:`FreeResponse`: f(t) = C expm(A t) q̂, the free response of the energy model [W].
- :func:`SimpsonSocSteps` (:func:`SimpsonSoc` for a load without jumps): *the* SoC rollout, on
  the scenario's battery model (:class:`~eaplan_drake.energy.battery_model.BatteryModel`; the
  Rint battery ḃ = −k_b I(y)/Q_c of Lemma III.3, saturating at brown-out, by default). ḃ does
  not depend on b, so RK4 over a step of length h reduces to Simpson's rule on the load at its
  start, middle and end (exact up to O(h⁵)):

      b_{k+1} = b_k + h · (ḃ(y_k⁰) + 4 ḃ(y_k^½) + ḃ(y_k¹)) / 6.

  :func:`SimpsonSocSensitivity` is its derivative with respect to a load offset held over each
  step (the NLPs' analytic Jacobians), from the model's ∂ḃ/∂y
  (:meth:`~eaplan_drake.energy.battery_model.BatteryModel.SocRateSlope`).

- :func:`TimeToReserve`: t_b of Alg. 2 l. 17–23 from that rollout.
- :class:`CoverageTimeModel` and :func:`ChoosePathParameter`: the Eq. 10 line t(c1) = ν c1 + τ
  (ν, τ from :func:`~eaplan_drake.flight.coverage.ScalingFactors`) and the path rule of Alg. 2 l.
  24–27.
- :func:`GridCandidates`: the admissible grid points of c2 and their exact table power.
- :class:`PowerSurrogate`: the smooth model ĝ of the computation table inside the NLPs (quadratic
  least-squares fit, or the Eq. 11 line of
  :meth:`~eaplan_drake.energy.computation.ComputationTable.scaling_factors`).

Each function that takes ``battery`` accepts a battery model or the ``battery`` parameters (then
the model they name, :func:`~eaplan_drake.energy.battery_model.AsBatteryModel`).
"""

import dataclasses as dc
import itertools
import math

import numpy as np

from eaplan_drake.energy.battery_model import AsBatteryModel, BatteryModel
from eaplan_drake.energy.computation import ComputationTable
from eaplan_drake.energy.fourier import FreeResponseMatrix
from eaplan_drake.flight.coverage import ScalingFactors
from eaplan_drake.params import BatteryParams

__all__ = [
    "ChoosePathParameter",
    "CoverageTimeModel",
    "FreeResponse",
    "GridCandidates",
    "MAX_GRID_POINTS",
    "PowerSurrogate",
    "SimpsonSoc",
    "SimpsonSocOfRates",
    "SimpsonSocSensitivity",
    "SimpsonSteps",
    "SimpsonSocSteps",
    "StepLoads",
    "TimeToReserve",
]


MAX_GRID_POINTS = 100_000
"""Largest number of grid combinations of the computation table the planners enumerate."""


def GridCandidates(table: ComputationTable) -> tuple[np.ndarray, np.ndarray]:
    """(every grid point of the table (K×σ, the product of its parameter grids in order), the
    exact power g of each (K,) [W]); ValueError naming ``table`` beyond :data:`MAX_GRID_POINTS`."""
    n_grid = math.prod(g.size for g in table.parameter_grids)
    if n_grid > MAX_GRID_POINTS:
        raise ValueError(
            f"table: {n_grid} grid combinations, at most {MAX_GRID_POINTS} are supported"
        )
    points = np.array(list(itertools.product(*table.parameter_grids)), dtype=float)
    return points, np.array([table.power(c) for c in points])


def FreeResponse(q_hat, order, period: float, step: float, num_points: int) -> np.ndarray:
    """f(k·step) = C expm(A k·step) q̂ for k = 0 … num_points − 1 [W] (exact rotation blocks,
    :func:`~eaplan_drake.energy.fourier.FreeResponseMatrix`)."""
    rows = FreeResponseMatrix(order, period, step, num_points)
    return rows @ np.asarray(q_hat, dtype=float).reshape(-1)


def StepLoads(y_half, dg=0.0) -> np.ndarray:
    """The load at the start, middle and end of each step, shape (3, n, …) [W], from samples every
    step/2 along axis 0 (2n + 1 of them) plus an offset ``dg`` held over each step (scalar, or
    (n, …): the offset may jump at the nodes, so a node's end and start samples differ)."""
    y = np.asarray(y_half, dtype=float)
    return np.stack((y[0:-2:2] + dg, y[1:-1:2] + dg, y[2::2] + dg))


def SimpsonSocSteps(
    y_steps, soc0, battery: BatteryModel | BatteryParams, step: float
) -> np.ndarray:
    """SoC [-] at the n + 1 nodes of n steps of length ``step`` [s] from b_0 = ``soc0``.

    ``y_steps`` (3, n, …): the load at the start, middle and end of each step [W]
    (:func:`StepLoads`); further axes are independent loads. ḃ does not depend on b, so RK4 is
    Simpson's rule, b_{k+1} = b_k + step·(ḃ⁰ + 4ḃ^½ + ḃ¹)/6, with ḃ of the battery model
    (:meth:`~eaplan_drake.energy.battery_model.BatteryModel.SocRate`; for Rint a brown-out load
    draws the current at the maximum power). Not clipped.
    """
    bdot = np.asarray(AsBatteryModel(battery).SocRate(np.asarray(y_steps, dtype=float)))
    drop = step * (bdot[0] + 4.0 * bdot[1] + bdot[2]) / 6.0
    zero = np.zeros((1,) + drop.shape[1:])
    return soc0 + np.concatenate((zero, np.cumsum(drop, axis=0)))


def SimpsonSoc(y_half, soc0, battery: BatteryModel | BatteryParams, step: float) -> np.ndarray:
    """:func:`SimpsonSocSteps` for a load y sampled every step/2 (2n + 1 samples along axis 0,
    y at t = 0, step/2, step, …) [W]: the SoC [-] at the n + 1 nodes. A step's end sample is the
    next one's start, so ḃ is evaluated once per sample (element-wise: the same values as on
    :func:`StepLoads`' three rows)."""
    bdot = np.asarray(AsBatteryModel(battery).SocRate(np.asarray(y_half, dtype=float)))
    return SimpsonSocOfRates(bdot, soc0, step)


def SimpsonSteps(values_half, step: float) -> np.ndarray:
    """step·(v⁰ + 4v^½ + v¹)/6 of each of the n steps [value·s] from samples every step/2 along
    axis 0 (2n + 1 of them): Simpson's rule per step."""
    v = values_half
    return step * (v[0:-2:2] + 4.0 * v[1:-1:2] + v[2::2]) / 6.0


def SimpsonSocOfRates(rate_half, soc0, step: float) -> np.ndarray:
    """SoC [-] at the n + 1 nodes from b_0 = ``soc0`` and ḃ [1/s] sampled every step/2 along axis
    0 (2n + 1 samples): :func:`SimpsonSoc` when the rates are already known."""
    drop = SimpsonSteps(rate_half, step)
    zero = np.zeros((1,) + drop.shape[1:])
    return soc0 + np.concatenate((zero, np.cumsum(drop, axis=0)))


def SimpsonSocSensitivity(
    y_steps, battery: BatteryModel | BatteryParams, step: float
) -> np.ndarray:
    """∂(b_{k+1} − b_k)/∂δ_k [1/W] of :func:`SimpsonSocSteps`: each step's SoC change
    differentiated by a load offset δ_k held over that step, shape (n, …)."""
    slope = np.asarray(AsBatteryModel(battery).SocRateSlope(np.asarray(y_steps, dtype=float)))
    return step * (slope[0] + 4.0 * slope[1] + slope[2]) / 6.0


def TimeToReserve(
    f_half, dg_steps, soc0: float, battery: BatteryModel | BatteryParams, step: float
) -> float:
    """t_b [s] (Alg. 2 l. 17–23): time until the SoC reaches ``battery.reserve_soc``, or a
    brown-out, under the load y = f + Δg.

    ``f_half``: free response at t0 + k·step/2 (2n + 1 samples, n steps) [W]; ``dg_steps``:
    g(c_k) − g(c_prev) of the planned steps [W], the last one held to the end. SoC by
    :func:`SimpsonSocSteps`, linear interpolation inside the step that crosses; the earliest
    brown-out sample of the first step that has one; capped at n·step. 0 when soc0 is at or
    below the reserve.
    """
    battery = AsBatteryModel(battery)
    reserve = float(battery.reserve_soc)
    if soc0 <= reserve:
        return 0.0
    f_half = np.asarray(f_half, dtype=float)
    dg_steps = np.asarray(dg_steps, dtype=float).reshape(-1)
    n = (f_half.size - 1) // 2
    dg = np.full(n, dg_steps[-1])
    dg[: min(n, dg_steps.size)] = dg_steps[:n]
    ys = StepLoads(f_half, dg)
    soc = SimpsonSocSteps(ys, soc0, battery, step)
    t_b = n * step
    below = np.flatnonzero(soc <= reserve)
    if below.size:
        k = int(below[0])  # soc[k − 1] > reserve ≥ soc[k], k ≥ 1
        frac = (soc[k - 1] - reserve) / (soc[k - 1] - soc[k])
        t_b = (k - 1 + frac) * step
    brown = battery.IsBrownout(ys)
    steps = np.flatnonzero(np.any(brown, axis=0))
    if steps.size:  # earliest brown-out sample of the first step that has one
        k = int(steps[0])
        t_b = min(t_b, (k + 0.5 * int(np.argmax(brown[:, k]))) * step)
    return float(t_b)


@dc.dataclass(frozen=True)
class CoverageTimeModel:
    """Linear coverage time t(c1) = ν c1 + τ [s] of paper 003 Eq. 10 (ρ = 1).

    Through (c̲1, t̲) and (c̄1, t̄): ``times`` = (t at c̲1, t at c̄1) [s], ``bounds`` = (c̲1, c̄1) [m²].
    ν [s/m²] and τ [s] are :func:`~eaplan_drake.flight.coverage.ScalingFactors` (ν = 0, τ = t̲ for a
    degenerate range c̲1 = c̄1).
    """

    bounds: tuple[float, float]
    times: tuple[float, float]
    nu: float = dc.field(init=False)
    """ν [s/m²]."""
    tau: float = dc.field(init=False)
    """τ [s]."""

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
        if hi > lo:
            nu, tau = (float(v[0]) for v in ScalingFactors((lo, hi), (t_lo, t_hi)))
        else:
            nu, tau = 0.0, t_lo
        object.__setattr__(self, "nu", nu)
        object.__setattr__(self, "tau", tau)

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
    """Smooth model ĝ(c̃) of the table on normalised parameters c̃ ∈ [0, 1]^σ (value, gradient).

    ``kind`` "quadratic": least-squares quadratic fit to the table's grid (when the grid has
    enough points); "linear": the Eq. 11 line Σ_j ν_j c_j + τ_j of
    :meth:`~eaplan_drake.energy.computation.ComputationTable.scaling_factors`.
    """

    def __init__(self, table: ComputationTable, kind: str):
        sigma = table.num_parameters
        self.span = table.upper - table.lower
        self.lower = table.lower
        pairs = [(i, j) for i in range(sigma) for j in range(i, sigma)]
        points, g = GridCandidates(table)
        if kind == "quadratic" and points.shape[0] >= 1 + sigma + len(pairs):
            u = (points - self.lower) / self.span
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
