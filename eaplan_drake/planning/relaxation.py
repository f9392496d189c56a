"""The continuous relaxation of the mpc's mission problem as a ``MathematicalProgram``
(:class:`MissionProgram`, derivation in :mod:`eaplan_drake.planning.mpc`), and the interpolants
its smooth model is made of: the lower convex hull of the remaining-time staircase and monotone
cubic Hermite (PCHIP, Fritsch–Carlson) interpolation."""

import bisect

import numpy as np
from pydrake.autodiffutils import ExtractGradient, ExtractValue, InitializeAutoDiff
from pydrake.solvers import MathematicalProgram

from eaplan_drake.planning.nlp import MakeSolver

__all__ = ["MissionProgram"]

_CONSTRAINT_SCALE = 100.0
"""The NLP's constraints are in percent of SoC: IPOPT then sees gradients of order one."""


def _LowerHull(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Indices of the vertices of the lower convex hull of the points (x, y), x ascending."""
    hull: list[int] = []
    for k in range(x.size):
        while len(hull) >= 2:
            i, j = hull[-2], hull[-1]
            if (y[j] - y[i]) * (x[k] - x[i]) >= (y[k] - y[i]) * (x[j] - x[i]):
                hull.pop()  # j lies on or above the chord i–k
            else:
                break
        hull.append(k)
    return np.array(hull, dtype=int)


def _Pchip(x: np.ndarray, y: np.ndarray, d: np.ndarray, t) -> tuple[np.ndarray, np.ndarray]:
    """(value, slope) of the cubic Hermite interpolant of (x, y) with node slopes ``d`` at ``t``
    (an array or a scalar; constant beyond the ends, and exactly y at the nodes)."""
    if np.ndim(t) == 0:
        return _PchipAt(x, y, d, float(t))
    t = np.asarray(t, dtype=float)
    if x.size == 1:
        return np.full_like(t, y[0]), np.zeros_like(t)
    tc = np.clip(t, x[0], x[-1])
    i = np.clip(np.searchsorted(x, tc, side="right") - 1, 0, x.size - 2)
    h = x[i + 1] - x[i]
    s = (tc - x[i]) / h
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    value = h00 * y[i] + h10 * h * d[i] + h01 * y[i + 1] + h11 * h * d[i + 1]
    dh00, dh10 = (6 * s**2 - 6 * s) / h, (3 * s**2 - 4 * s + 1) / h
    dh01, dh11 = (-6 * s**2 + 6 * s) / h, (3 * s**2 - 2 * s) / h
    slope = dh00 * y[i] + dh10 * h * d[i] + dh01 * y[i + 1] + dh11 * h * d[i + 1]
    inside = (t >= x[0]) & (t <= x[-1])
    return value, np.where(inside, slope, 0.0)


def _PchipAt(x: np.ndarray, y: np.ndarray, d: np.ndarray, t: float) -> tuple[float, float]:
    """:func:`_Pchip` at one point, in Python floats: the same operations in the same order
    (the solver's constraints and the per-plan margins call it thousands of times a flight)."""
    if x.size == 1:
        return float(y[0]), 0.0
    xs = x.tolist()
    tc = min(max(t, xs[0]), xs[-1])
    i = min(max(bisect.bisect_right(xs, tc) - 1, 0), len(xs) - 2)
    y0, y1, d0, d1 = float(y[i]), float(y[i + 1]), float(d[i]), float(d[i + 1])
    h = xs[i + 1] - xs[i]
    s = (tc - xs[i]) / h
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    value = h00 * y0 + h10 * h * d0 + h01 * y1 + h11 * h * d1
    dh00, dh10 = (6 * s**2 - 6 * s) / h, (3 * s**2 - 4 * s + 1) / h
    dh01, dh11 = (-6 * s**2 + 6 * s) / h, (3 * s**2 - 2 * s) / h
    slope = dh00 * y0 + dh10 * h * d0 + dh01 * y1 + dh11 * h * d1
    return value, (slope if xs[0] <= t <= xs[-1] else 0.0)


def _PchipSlopes(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Node derivatives of the monotone cubic interpolant of (x, y) (Fritsch–Carlson)."""
    if x.size < 2:
        return np.zeros_like(y)
    delta = (np.diff(y) / np.diff(x)).tolist()
    d = np.zeros_like(y)
    d[0], d[-1] = delta[0], delta[-1]
    xs = x.tolist()  # the same arithmetic on Python floats (read faster than array elements)
    for k in range(1, len(xs) - 1):
        a, b = delta[k - 1], delta[k]
        if a * b > 0.0:  # weighted harmonic mean; 0 at a local extremum or a plateau
            w1 = 2 * (xs[k + 1] - xs[k]) + (xs[k] - xs[k - 1])
            w2 = (xs[k + 1] - xs[k]) + 2 * (xs[k] - xs[k - 1])
            d[k] = (w1 + w2) / (w1 / a + w2 / b)
    return d


class MissionProgram:
    """The continuous relaxation of a :class:`~eaplan_drake.planning.mpc.MissionProblem`
    (``problem``) as a ``MathematicalProgram`` solved with IPOPT or SNOPT (derivation in
    :mod:`eaplan_drake.planning.mpc`), built once and re-used every step.

    Attributes:
        prog: the MathematicalProgram.
        path_variable: c̃1 (1,).
        computation_variables: c̃2 (σ,).
        variables: [c̃1, c̃2] (the layout of initial guesses).
    """

    def __init__(self, problem):
        self.problem = problem
        self.scale = _CONSTRAINT_SCALE
        p = problem.params
        sigma = problem.table.num_parameters
        prog = MathematicalProgram()
        u1 = prog.NewContinuousVariables(1, "c1")
        u2 = prog.NewContinuousVariables(sigma, "c2")
        prog.AddBoundingBoxConstraint(0.0, 1.0, u1)
        prog.AddBoundingBoxConstraint(0.0, 1.0, u2)
        prog.AddLinearCost(
            np.concatenate(([-problem._w1], np.full(sigma, -problem._w2 / sigma))),
            0.0,
            np.concatenate((u1, u2)),
        )
        prog.AddConstraint(
            self._Constraints,
            np.zeros(2),
            np.full(2, np.inf),
            np.concatenate((u1, u2)),
            description="mission_feasibility",
        )
        self.prog = prog
        self.path_variable = u1
        self.computation_variables = u2
        self.variables = np.concatenate((u1, u2))
        self.solver, self.options = MakeSolver(p, tolerance=1e-8)

    def _Constraints(self, x):
        """[(1), (2)] at x = [c̃1, c̃2] (≥ 0 when feasible), smooth model, analytic Jacobian."""
        autodiff = x.dtype == object
        xv = ExtractValue(x).reshape(-1) if autodiff else np.asarray(x, dtype=float)
        pb = self.problem
        sur = pb.surrogate
        u1, u2 = float(xv[0]), xv[1:]
        g = float(sur.value(u2.reshape(1, -1))[0])
        t, dt_du1 = pb.RemainingTime(u1)
        b_end, db_dt, db_dg = pb.SmoothSoc(g, t)
        reserve = float(pb.battery.reserve_soc)
        c1 = b_end - reserve - float(pb.Margin(t))
        b_step, _, db_step_dg = pb.SmoothSoc(g, pb.step)
        low_step, low_end, low_margin = pb.SmoothLowestTerms()
        c2 = b_step - low_step + low_end - reserve - low_margin
        out = self.scale * np.array([c1, c2])
        if not autodiff:
            return out
        grad_g = sur.gradient(u2.reshape(1, -1))[0]  # (σ,)
        J = np.zeros((2, xv.size))
        J[0, 0] = (db_dt - pb.MarginSlope(t)) * dt_du1
        J[0, 1:] = db_dg * grad_g
        J[1, 1:] = db_step_dg * grad_g
        return InitializeAutoDiff(out, self.scale * J @ ExtractGradient(x))

    def Solve(self, initial_guess):
        """Solves from ``initial_guess`` (layout of ``variables``) with the chosen solver."""
        guess = np.clip(np.asarray(initial_guess, dtype=float), 0.0, 1.0)
        return self.solver.Solve(self.prog, guess, self.options)
