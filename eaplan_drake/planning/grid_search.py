"""The exact answer on an integer table's grid, by the grid's indices: the best of the grid rows
that bracket a relaxed c̃2 and the local search from it, methods of
:class:`~eaplan_drake.planning.mpc.MissionProblem` (:meth:`MissionProblem.MapRelaxed
<eaplan_drake.planning.mpc.MissionProblem.MapRelaxed>` and :meth:`MissionProblem.DeterminedDecision
<eaplan_drake.planning.mpc.MissionProblem.DeterminedDecision>` call them; derivation in
:mod:`eaplan_drake.planning.mpc`)."""

import itertools

import numpy as np

__all__ = ["GridSearch"]


class GridSearch:
    """The grid search of one planner step; mixed into
    :class:`~eaplan_drake.planning.mpc.MissionProblem`, whose step data and per-step caches it
    reads (the table's grids, the feasible rows, the quality, the margin setting)."""

    def _MapOnGrid(self, c_relaxed):
        """:meth:`MapRelaxed` of an integer table, on the grid's indices: the same candidates in
        the same order, each row's best c1 computed once per step (:meth:`_GridBest`)."""
        return self._GridDecision(self._Climb(self._BracketBest(self._Brackets(c_relaxed))))

    def _Brackets(self, c_relaxed) -> tuple[tuple[int, ...], ...]:
        """Per dimension, the indices of the grid points that bracket c_relaxed (the one at or
        above it and the one below, or the first alone)."""
        brackets = []
        for grid, c in zip(self.table.parameter_grids, c_relaxed, strict=True):
            i = int(np.clip(np.searchsorted(grid, c - 1e-9), 0, grid.size - 1))
            brackets.append(tuple(sorted({max(i - 1, 0), i})))
        return tuple(brackets)

    def _BracketBest(self, brackets) -> tuple[int, ...] | None:
        """The best of the bracketing grid rows and the lowest (:meth:`_GridBestOf`)."""
        return self._GridBestOf([*itertools.product(*brackets), self._lowest_index])

    def _Climb(self, best: tuple[int, ...]) -> tuple[int, ...]:
        """The local search from the grid row ``best``: move c2 one grid step in any dimension
        (each with its largest feasible c1) while that improves the plan. Every move raises the
        rank strictly, so the end depends on the start only: computed once per step and margin
        setting for each start."""
        key = (best, self._margin_rate, self._faults_counted)
        end = self._climb_cache.get(key)
        if end is not None:
            return end
        grids = self.table.parameter_grids
        for _ in range(self.candidates.shape[0]):
            neighbours = [
                best[:d] + (i2,) + best[d + 1 :]
                for d, grid in enumerate(grids)
                for i2 in (best[d] - 1, best[d] + 1)
                if 0 <= i2 < grid.size
            ]
            found = self._GridBestOf([best, *neighbours])
            if found is None or found == best:
                break
            best = found
        self._climb_cache[key] = best
        return best

    def _GridDecision(self, index: tuple[int, ...]):
        """The :class:`~eaplan_drake.planning.mpc.MissionDecision` of the grid row with these
        indices at its largest feasible c1."""
        _, j, end = self._GridBest(index)
        c2 = self._GridRow(index)[0]
        return self._Decision(j, self._CandidateIndex(c2), c2, end, True)

    def _GridRow(self, index: tuple[int, ...]) -> tuple[np.ndarray, float]:
        """(c2 [table units], g(c2) [W]) of the grid point with these indices (kept)."""
        row = self._grid_rows.get(index)
        if row is None:
            grids = self.table.parameter_grids
            c2 = np.array([float(g[i]) for g, i in zip(grids, index, strict=True)])
            row = self._grid_rows[index] = (c2, self._Row(c2)[0])
        return row

    def _GridBest(self, index: tuple[int, ...]):
        """((quality, end SoC), j, end SoC) of the grid row's largest feasible c1_j, None if it
        has none: :meth:`BestOf`'s ranking of one row, computed once per step."""
        key = (index, self._margin_rate, self._faults_counted)
        if key not in self._row_best:
            c2, power = self._GridRow(index)
            ok, end = self.FeasibleRow(power)
            hits = np.flatnonzero(ok)
            best = None
            if hits.size:
                j = int(hits[-1])
                rank = (round(self.Quality(j, self._Row(c2)[1]), 12), float(end[j]))
                best = (rank, j, float(end[j]))
            self._row_best[key] = best
        return self._row_best[key]

    def _GridBestOf(self, indices):
        """The first of the grid rows with the best :meth:`_GridBest` rank; None if none."""
        best, best_rank = None, None
        for index in indices:
            found = self._GridBest(index)
            if found is not None and (best_rank is None or found[0] > best_rank):
                best, best_rank = index, found[0]
        return best
