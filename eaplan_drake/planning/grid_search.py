"""The exact answer of a planner step from a relaxed optimum (:doc:`/planner`, "mapping back"):
functions of a :class:`~eaplan_drake.planning.mpc.MissionStep`.

The relaxed c̃2 is read only through the grid points that bracket it (:func:`Brackets`); each
bracketing row and the lowest get their largest feasible c1, the best of them by (J, end SoC)
starts a local search that moves c2 one grid step at a time while the plan improves
(:func:`LocalSearch`). On an integer table this runs on the grid's indices (:func:`MapOnGrid`), and
when every bracket the relaxed point could have leads to one plan, that plan is the answer of
any solve (:func:`DeterminedDecision`): no solve is needed.
"""

import itertools

import numpy as np

__all__ = [
    "BracketBest",
    "Brackets",
    "Climb",
    "DeterminedDecision",
    "LocalSearch",
    "MapOnGrid",
    "MapRelaxed",
    "OptionBrackets",
    "Relaxed",
]


def Relaxed(table, u2_relaxed) -> np.ndarray:
    """c2 [table units] of the relaxed c̃2 (clipped to [0, 1]) on ``table``'s box."""
    return table.lower + np.clip(np.asarray(u2_relaxed, float), 0.0, 1.0) * (
        table.upper - table.lower
    )


def Brackets(table, c_relaxed) -> tuple[tuple[int, ...], ...]:
    """Per dimension, the indices of the grid points that bracket c_relaxed (the one at or above
    it and the one below, or the first alone)."""
    brackets = []
    for grid, c in zip(table.parameter_grids, c_relaxed, strict=True):
        i = int(np.clip(np.searchsorted(grid, c - 1e-9), 0, grid.size - 1))
        brackets.append(tuple(sorted({max(i - 1, 0), i})))
    return tuple(brackets)


def OptionBrackets(table, span) -> tuple:
    """Every distinct :func:`Brackets` a relaxed c̃2 can have on ``table`` (``span``: the width of
    each dimension's box [table units], 1 where it is empty): in each dimension the lowest value
    alone or a pair of neighbours."""
    options = []
    for grid, lo, width in zip(table.parameter_grids, table.lower, span, strict=True):
        mids = 0.5 * (grid[:-1] + grid[1:])
        options.append([0.0, *((mids - lo) / width)])
    return tuple(
        dict.fromkeys(Brackets(table, Relaxed(table, u2)) for u2 in itertools.product(*options))
    )


def LocalSearch(start, neighbours, best_of, same, max_moves: int):
    """The one local search of the grid mapping: from ``start``, move to
    ``best_of(current, neighbours(current))`` (the best of the current plan and its neighbours,
    None if none is feasible) while that is not ``same`` as the current one, at most
    ``max_moves`` times."""
    best = start
    for _ in range(max_moves):
        found = best_of(best, neighbours(best))
        if found is None or same(found, best):
            break
        best = found
    return best


def BracketBest(step, brackets) -> tuple[int, ...] | None:
    """The best of the bracketing grid rows and the lowest, by :meth:`MissionStep.GridBest
    <eaplan_drake.planning.mpc.MissionStep.GridBest>` (the first of equals)."""
    return _GridBestOf(step, [*itertools.product(*brackets), step.problem.lowest_index])


def _GridBestOf(step, indices):
    best, best_rank = None, None
    for index in indices:
        found = step.GridBest(index)
        if found is not None and (best_rank is None or found[0] > best_rank):
            best, best_rank = index, found[0]
    return best


def _GridNeighbours(grids):
    def Neighbours(index):
        return [
            index[:d] + (i2,) + index[d + 1 :]
            for d, grid in enumerate(grids)
            for i2 in (index[d] - 1, index[d] + 1)
            if 0 <= i2 < grid.size
        ]

    return Neighbours


def Climb(step, start: tuple[int, ...]) -> tuple[int, ...]:
    """The local search from the grid row ``start`` on the grid's indices. Every move raises the
    rank strictly, so the end depends on the start only: computed once per step and start."""
    pb = step.problem

    def Search():
        return LocalSearch(
            start,
            _GridNeighbours(pb.table.parameter_grids),
            lambda index, neighbours: _GridBestOf(step, [index, *neighbours]),
            lambda a, b: a == b,
            pb.candidates.shape[0],
        )

    return step.Memo(("climb", start), Search)


def GridDecision(step, index: tuple[int, ...]):
    """The :class:`~eaplan_drake.planning.mpc.MissionDecision` of the grid row with these indices
    at its largest feasible c1."""
    _, j, end = step.GridBest(index)
    c2 = step.problem.GridRow(index)[0]
    return step.Decision(j, step.problem.CandidateIndex(c2), c2, end, True)


def MapOnGrid(step, c_relaxed):
    """:func:`MapRelaxed` of an integer table, on the grid's indices."""
    start = BracketBest(step, Brackets(step.problem.table, c_relaxed))
    return GridDecision(step, Climb(step, start))


def MapRelaxed(step, u2_relaxed):
    """The exact answer of ``step`` from a relaxed c̃2 (σ,): the best of its bracketing grid
    points and the lowest (and the relaxed point itself if not integer), each with its largest
    feasible c1, then improved by one-grid-step moves of c2. The lowest plan (with its
    feasibility) when it is infeasible."""
    low = step.Lowest()
    if not low.feasible:
        return low
    pb = step.problem
    table = pb.table
    c_relaxed = Relaxed(table, u2_relaxed)
    if pb.integer:
        return MapOnGrid(step, c_relaxed)
    # the bracketing grid values (the grids ascend strictly: the same order as the indices)
    brackets = [
        [float(grid[i]) for i in indices]
        for grid, indices in zip(table.parameter_grids, Brackets(table, c_relaxed), strict=True)
    ]
    rows = [np.array(p) for p in itertools.product(*brackets)]
    rows.append(pb.candidates[pb.lowest_candidate])
    powers = [pb.RowValues(r)[0] for r in rows]
    rows.append(c_relaxed)  # not an integer table: the relaxed point is a candidate too
    powers.append(table.power(c_relaxed))
    grids = table.parameter_grids

    def Neighbours(plan):
        c2 = plan[1]
        out = []
        for d, grid in enumerate(grids):
            i = int(np.argmin(np.abs(grid - c2[d])))
            for i2 in (i - 1, i + 1):
                if 0 <= i2 < grid.size:
                    n = np.array(c2, dtype=float)
                    n[d] = grid[i2]
                    out.append(n)
        return out

    def BestOfRows(plan, neighbours):
        c2s = [plan[1], *neighbours]
        return step.BestOf(c2s, [pb.RowValues(r)[0] for r in c2s])

    best = LocalSearch(
        step.BestOf(rows, powers),
        Neighbours,
        BestOfRows,
        lambda a, b: np.array_equal(a[1], b[1]),
        pb.candidates.shape[0],
    )
    j, c2, end = best
    return step.Decision(j, pb.CandidateIndex(c2), c2, end, True)


def DeterminedDecision(step):
    """The answer of :func:`MapRelaxed` when it does not depend on the relaxed c̃2, else None.

    :func:`MapRelaxed` reads c̃2 only through the grid points that bracket it: when every
    combination of those (:func:`OptionBrackets`) leads to the same plan, that plan is the mapped
    answer of any successful solve, so the NLP need not be solved. Integer tables only
    (otherwise the relaxed point itself is a candidate); None when the lowest plan is infeasible.
    """
    pb = step.problem
    if not pb.integer or not step.Lowest().feasible:
        return None
    first = None
    for brackets in pb.OptionBrackets():
        best = Climb(step, BracketBest(step, brackets))
        if first is None:
            first = best
        elif best != first:  # another row: another c2 (the grids ascend strictly)
            return None
    return GridDecision(step, first)
