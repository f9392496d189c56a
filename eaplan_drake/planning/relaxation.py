"""The continuous relaxation of the mpc's mission problem as a ``MathematicalProgram``
(:class:`MissionProgram`; :doc:`/planner`, "the NLP"): variables c̃1 ∈ [0, 1] and c̃2 ∈ [0, 1]^σ,
linear cost −J, and the constraints (1) and (2) on a step's
:class:`~eaplan_drake.planning.smooth.SmoothModel`."""

import numpy as np
from pydrake.autodiffutils import ExtractGradient, ExtractValue, InitializeAutoDiff
from pydrake.solvers import MathematicalProgram

from eaplan_drake.planning.nlp import MakeSolver

__all__ = ["MissionProgram"]

_CONSTRAINT_SCALE = 100.0
"""The NLP's constraints are in percent of SoC: IPOPT then sees gradients of order one."""


class MissionProgram:
    """The continuous relaxation of a :class:`~eaplan_drake.planning.mpc.MissionProblem`
    (``problem``) as a ``MathematicalProgram`` solved with IPOPT or SNOPT, built once per flight;
    :meth:`Solve` solves it for one :class:`~eaplan_drake.planning.mpc.MissionStep`.

    Attributes:
        prog: the MathematicalProgram.
        path_variable: c̃1 (1,).
        computation_variables: c̃2 (σ,).
        variables: [c̃1, c̃2] (the layout of initial guesses).
    """

    def __init__(self, problem):
        self.problem = problem
        self.scale = _CONSTRAINT_SCALE
        sigma = problem.table.num_parameters
        w1, w2 = problem.weights
        prog = MathematicalProgram()
        u1 = prog.NewContinuousVariables(1, "c1")
        u2 = prog.NewContinuousVariables(sigma, "c2")
        prog.AddBoundingBoxConstraint(0.0, 1.0, u1)
        prog.AddBoundingBoxConstraint(0.0, 1.0, u2)
        prog.AddLinearCost(
            np.concatenate(([-w1], np.full(sigma, -w2 / sigma))),
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
        self.solver, self.options = MakeSolver(problem.params, tolerance=1e-8)
        self._model = None

    def Constraints(self, step, x) -> np.ndarray:
        """[(1), (2)] × 100 at x = [c̃1, c̃2] (≥ 0 when feasible) on ``step``'s smooth model
        (floats, or ``AutoDiffXd`` for the analytic Jacobian)."""
        x = np.asarray(x)
        self._model = step.smooth
        try:
            return self._Constraints(x if x.dtype == object else x.astype(float))
        finally:
            self._model = None

    def _Constraints(self, x):
        """[(1), (2)] at x = [c̃1, c̃2] (≥ 0 when feasible), smooth model, analytic Jacobian."""
        autodiff = x.dtype == object
        xv = ExtractValue(x).reshape(-1) if autodiff else np.asarray(x, dtype=float)
        model = self._model
        sur = self.problem.surrogate
        reserve = self.problem.reserve_soc
        u1, u2 = float(xv[0]), xv[1:]
        g = float(sur.value(u2.reshape(1, -1))[0])
        t, dt_du1 = model.RemainingTime(u1)
        b_end, db_dt, db_dg = model.Soc(g, t)
        c1 = b_end - reserve - float(model.margin.At(t))
        b_step, _, db_step_dg = model.Soc(g, model.step_length)
        low_step, low_end, low_margin = model.LowestTerms()
        c2 = b_step - low_step + low_end - reserve - low_margin
        out = self.scale * np.array([c1, c2])
        if not autodiff:
            return out
        grad_g = sur.gradient(u2.reshape(1, -1))[0]  # (σ,)
        J = np.zeros((2, xv.size))
        J[0, 0] = (db_dt - model.margin.Slope(t)) * dt_du1
        J[0, 1:] = db_dg * grad_g
        J[1, 1:] = db_step_dg * grad_g
        return InitializeAutoDiff(out, self.scale * J @ ExtractGradient(x))

    def Solve(self, step, initial_guess):
        """Solves the relaxation of ``step`` from ``initial_guess`` (layout of ``variables``) with
        the chosen solver."""
        guess = np.clip(np.asarray(initial_guess, dtype=float), 0.0, 1.0)
        self._model = step.smooth
        try:
            return self.solver.Solve(self.prog, guess, self.options)
        finally:
            self._model = None
