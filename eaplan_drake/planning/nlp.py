"""The NLP solver of the planner programs (``planner.solver``: IPOPT or SNOPT, both in Drake).

Both are bounded by ``planner.max_iterations`` (IPOPT iterations, SNOPT major iterations), and
by ``planner.max_wall_time`` only when that opt-in real-time budget is set (then a flight
depends on the machine's speed).
"""

from pydrake.solvers import IpoptSolver, SnoptSolver, SolverOptions

from eaplan_drake.params import PlannerParams

__all__ = ["MakeSolver"]


def MakeSolver(planner: PlannerParams, *, tolerance: float):
    """(solver, SolverOptions) for ``planner.solver`` with the iteration (and optional wall-time)
    limits of ``planner`` and the optimality/feasibility ``tolerance``, quiet.

    Raises ValueError naming ``planner.solver`` when that solver is not available in this Drake.
    """
    if planner.solver == "snopt":
        solver = SnoptSolver()
    else:
        solver = IpoptSolver()
    if not (solver.available() and solver.enabled()):
        raise ValueError(f"planner.solver: {planner.solver} is not available in this Drake build")
    options = SolverOptions()
    sid = solver.id()
    if planner.solver == "snopt":
        options.SetOption(sid, "Major iterations limit", int(planner.max_iterations))
        options.SetOption(sid, "Major optimality tolerance", float(tolerance))
        options.SetOption(sid, "Major feasibility tolerance", float(tolerance))
        if planner.max_wall_time > 0.0:  # opt-in real-time budget
            options.SetOption(sid, "Time limit", float(planner.max_wall_time))
    else:
        if planner.max_wall_time > 0.0:  # opt-in real-time budget: results then depend on the CPU
            options.SetOption(sid, "max_wall_time", float(planner.max_wall_time))
        options.SetOption(sid, "max_iter", int(planner.max_iterations))
        options.SetOption(sid, "tol", float(tolerance))
        options.SetOption(sid, "print_level", 0)
        options.SetOption(sid, "sb", "yes")
    return solver, options
