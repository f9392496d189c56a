"""A field's survey as flown with ``coverage.no_fly_holes: true``: the stages of
:class:`~eaplan_drake.field.source.FieldCoverage` kept out of the field's holes at every c1 the
in-flight planner re-plans to, by the rules of :mod:`eaplan_drake.field.nofly`.

The pre-flight plan at c̲1 (its cells those of the field minus the holes buffered by
c + x_d(c̲1)/2, :func:`~eaplan_drake.field.nofly.SurveyPolygon`, wider than at any higher c1)
fixes the cells and the order they are visited in. At a path parameter c1 each cell's lines at
x_d(c1) are shortened where their turns would enter the holes buffered by c, in each orientation
0–3 (:func:`~eaplan_drake.field.nofly.ClearCellLines`). The first cell is flown in its first
orientation that keeps a line (as the pre-flight route), after the *approach* from
``vehicle.initial_position`` along ψ(0) (if none onto it keeps out, in the orientation of the
shortest approach that does); every later cell in the orientation whose transit from
the previous cell's last line is shortest (:func:`~eaplan_drake.field.nofly.NextCell`): the
Dubins path when it keeps out, else the visibility path around the holes flown through its
corners (straight pieces and arcs, each a stage,
:func:`~eaplan_drake.field.nofly.AvoidingTransit`); where none keeps out the last line's end and
the first line's start are shortened by s r_min (s of :data:`~eaplan_drake.field.nofly.ENTRY_CUTS`,
:func:`~eaplan_drake.field.nofly.EntryInto`; the approach shortens the first line only), and
where that fails too the last line is left out, as in the pre-flight route
(:func:`~eaplan_drake.field.nofly.AvoidingLegs`). Where no transit keeps out the plan is
refused in one line naming ``coverage.no_fly_holes``, checked before the flight at c̲1, the
initial c1, c̄1 and every c1 of the planner's grid (the values the mpc and the other grid
policies choose); at another c1 (the paper's policy chooses c1 off the grid) a cell that no
transit reaches is left out, and where no approach keeps out the first cell is flown at the
largest checked c1 below it (a flight never stops on a route it cannot build). Pieces shorter
than 4 ε are left out as in :class:`~eaplan_drake.field.source.FieldCoverage`.

A re-plan regenerates the later cells at the new c1, and with them the end of the current cell
(its last line's cut, the lines left out); only when the line being flown is its last line, or
one the new end would leave out, the cell keeps its end, and the transit shortens the next first
line alone.

Anchors (:attr:`~eaplan_drake.flight.stages.Stage.anchor`; + 0.5 on the second half of a split
arc): on a cell (c1 of the cell, its place k in the visiting order, o + 4 e + 20 x, the leg's
place in the cell) with o the orientation, e the index in ``ENTRY_CUTS`` of the first line's
cut and x = (the last line's cut) + 5 (the lines left out at the end); on the approach (c1, the
piece, o + 4 e, −1); on a transit (c1 of the next cell, the transit's start x, y [m],
−2 − 2(s + 2(m + :data:`PIECES` (o + 4 (e + 5 k))))) for piece m into the cell at place k,
heading ±u(θ) (s = 0, 1).

Lengths in m, c1 in m².
"""

import math

import numpy as np

from eaplan_drake.field.airspace import AirspaceError
from eaplan_drake.field.nofly import (
    ENTRY_CUTS,
    KEY,
    AvoidingTransit,
    ClearCellLines,
    EntryInto,
    NextCell,
    _Cut,
)
from eaplan_drake.field.route import CellLegs, CellSweepLines, TurnJump
from eaplan_drake.flight.coverage import _Memoized
from eaplan_drake.flight.stages import Stage

__all__ = ["PIECES", "AvoidingStages"]

PIECES = 1000
"""Transit pieces a transit anchor's tag has room for (module docstring)."""

_CUTS = len(ENTRY_CUTS)


class AvoidingStages:
    """The stages that keep out of the field's holes (module docstring), mixed into
    :class:`~eaplan_drake.field.source.FieldCoverage` as
    :class:`~eaplan_drake.field.source.AvoidingFieldCoverage` (its arguments; the legs become
    stages by its methods), and ``checked_c1``: more c1 values [m²] to check before the flight
    (the planner's grid, whose values the grid policies choose). Raises
    :class:`~eaplan_drake.field.airspace.AirspaceError` naming ``coverage.no_fly_holes`` when no
    route at c̲1, the initial c1, c̄1 or one of ``checked_c1`` keeps out."""

    def __init__(self, field, coverage, checked_c1=(), **kwargs):
        super().__init__(field, coverage, no_fly=field.holes, **kwargs)
        self.shortest = max(self.min_leg, 1.0)
        checked = (*self.c1_bounds, self.initial_c1, *(float(c) for c in checked_c1))
        self.checked_c1 = tuple(sorted(set(checked)))
        """The c1 values [m²] checked before the flight (ascending)."""
        for c1 in self.checked_c1:
            code, e, _ = self._Approach(c1)
            self._Chain(0, c1, code, e, c1, strict=True)

    @property
    def no_fly(self):
        """The :class:`~eaplan_drake.field.nofly.NoFly` of the field's holes."""
        return self.plan.no_fly

    # -- cells -------------------------------------------------------------------------------------

    def _Lines(self, place: int, c1: float) -> list:
        cell = self.decomposition.cells[self.cell_order[place]]
        return CellSweepLines(cell, self.theta_deg, self.Spacing(c1), self.min_leg)

    @_Memoized(256)
    def _Seq(self, place: int, c1: float, code: int) -> list:
        """The lines of the cell at ``place`` at c1 in orientation ``code``, in flight order and
        shortened where their turns would enter (:func:`ClearCellLines`)."""
        jump = TurnJump(self.Spacing(c1), self.r_min)
        lines = self._Lines(place, c1)
        return ClearCellLines(lines, jump, self.r_min, self.no_fly, code, self.min_leg)

    def _Cut(self, place: int, c1: float, code: int, e: int, x: int) -> list:
        """:meth:`_Seq` with the first line's start cut by e and, x = cut + 5 d, the last d
        lines left out and the last line's end cut by ``cut``."""
        seq = list(self._Seq(place, c1, code))
        if e:
            seq[0] = _Cut(seq[0], (ENTRY_CUTS[e] * self.r_min, 0.0))
        seq = seq[: len(seq) - x // _CUTS]
        if x % _CUTS:
            seq[-1] = _Cut(seq[-1], (0.0, ENTRY_CUTS[x % _CUTS] * self.r_min))
        return seq

    def _Index(self, s: float) -> int:
        """The index in :data:`ENTRY_CUTS` of the cut s [m]."""
        return int(np.argmin([abs(s - k * self.r_min) for k in ENTRY_CUTS]))

    def _SideOf(self, line) -> int:
        return 0 if (line[1] - line[0]) @ self._Heading(0) > 0.0 else 1

    def _FirstCode(self, c1: float) -> int:
        code = next((c for c in range(4) if self._Seq(0, c1, c)), None)
        if code is None:
            raise AirspaceError(f"{KEY}: at c1 = {c1:g} m² the first cell keeps no line clear")
        return code

    def _Around(self, position, heading, place: int, c1: float, code: int, e: int) -> list:
        """The transit pieces from ``position`` [m] along ``heading`` onto the first line (cut
        by e) of the cell at ``place`` at c1 in orientation ``code`` (:func:`AvoidingTransit`:
        the transit :func:`EntryInto` found)."""
        first = self._Cut(place, c1, code, e, 0)[0]
        return AvoidingTransit(
            position, heading, first[0], first[1] - first[0], self.r_min, self.no_fly
        )

    def _Chain(
        self, place: int, c1_k: float, code: int, e: int, c1: float, x=None, strict=False
    ) -> list:
        """[place, c1, orientation, e, x, lines, transit into it, its start, s] of the cell at
        ``place`` (at ``c1_k``, orientation ``code``, first line cut by ``e``) and of each later
        cell at c1, entered from the last line before it (:func:`NextCell`); where no transit
        keeps out the last line before it is left out, as the pre-flight route does, while one
        is left, and else the cell is left out (``strict``: AirspaceError). With ``x`` the first
        cell keeps its end (:meth:`_Cut`: its last line is being flown)."""
        cells = [[place, c1_k, code, e, 0, self._Cut(place, c1_k, code, e, 0), None, None, 0]]
        if x is not None:
            cells[0][4:6] = [x, self._Cut(place, c1_k, code, e, x)]
        for k in range(place + 1, len(self.cell_order)):
            if not any(self._Seq(k, c1, c) for c in range(4)):
                continue
            prev, drop = cells[-1], 0
            fixed = x is not None and len(cells) == 1
            while True:
                seq = prev[5][: len(prev[5]) - drop]
                side = self._SideOf(seq[-1])
                best = NextCell(
                    {k: self._Lines(k, c1)},
                    TurnJump(self.Spacing(c1), self.r_min),
                    [k],
                    lambda i, c, c1=c1: self._Seq(i, c1, c),
                    None if fixed else seq[-1],
                    seq[-1][1],
                    self.r_min,
                    self.no_fly,
                    self.shortest,
                    "transit",
                    heading=self._Heading(side),
                )
                if best is not None or fixed or len(seq) == 1:
                    break
                drop += 1
            if best is None and strict:
                raise AirspaceError(
                    f"{KEY}: at c1 = {c1:g} m² no transit around the no-fly polygons reaches "
                    f"cell {self.cell_order[k]} (their clearance and the turning radius leave no "
                    "way: leave them out, split the field or narrow planner.path_parameter_bounds)"
                )
            if best is None:  # no transit reaches the cell at this c1: it is left out
                continue
            _, _, code_k, (transit, end, first, s) = best
            if not fixed:
                prev[4:6] = [self._Index(s) + _CUTS * drop, [*seq[:-1], end]]
            start = prev[5][-1][1]
            cells.append([k, c1, code_k, self._Index(s), 0, first, transit, start, side])
        return cells

    # -- stages ------------------------------------------------------------------------------------

    def _Tag(self, k: int, m: int, s: int) -> float:
        """The transit anchor's tag of piece m, heading s, for ``k`` = o + 4 (e + 5 place)."""
        return -2.0 - 2.0 * (s + 2 * (m + PIECES * k))

    @staticmethod
    def _Decode(j: float):
        """(place, piece, s, orientation, e) of a transit anchor's tag j."""
        n = int(round((-2.0 - math.floor(j)) / 2.0))
        p = n // (2 * PIECES)
        return p // (4 * _CUTS), (n // 2) % PIECES, n % 2, p % 4, (p // 4) % _CUTS

    def _Emit(self, cells, index: int) -> list[Stage]:
        """The stages of the cells of :meth:`_Chain`, each after its transit."""
        stages: list[Stage] = []
        for k, c1_k, code, e, x, seq, transit, start, side in cells:
            if transit is not None:
                key = code + 4 * (e + _CUTS * k)
                stages += self._TransitStages(key, c1_k, start, side, transit, index)
                index = stages[-1].index + 1 if stages else index
            legs = CellLegs(seq, self.r_min, self.cell_order[k])
            stages += self._CellStages(legs, k, code + 4 * e + 4 * _CUTS * x, c1_k, index, 0)
            index = stages[-1].index + 1
        return stages

    def _Approach(self, c1: float):
        """(orientation, e, pieces) of the approach onto the first cell at c1: in its first
        orientation that keeps a line (the pre-flight route's) if a transit from the start
        keeps out, else in the orientation of the shortest that does (:func:`NextCell`)."""
        code = self._FirstCode(c1)
        seq = self._Seq(0, c1, code)
        entry = EntryInto(
            None, self.start, self.heading, seq, self.r_min, self.no_fly, self.shortest
        )
        if entry is None:
            best = NextCell(
                {0: self._Lines(0, c1)},
                TurnJump(self.Spacing(c1), self.r_min),
                [0],
                lambda i, c: self._Seq(i, c1, c),
                None,
                self.start,
                self.r_min,
                self.no_fly,
                self.shortest,
                "transit",
                heading=self.heading,
            )
            if best is None:
                raise AirspaceError(
                    f"{KEY}: no approach from vehicle.initial_position to the first cell keeps "
                    "out of the no-fly polygons"
                )
            _, _, code, entry = best
        return code, self._Index(entry[3]), entry[0]

    def _ApproachAt(self, c1: float):
        """(c1 of the first cell [m²], orientation, e, pieces): :meth:`_Approach` at c1, or,
        where no approach keeps out at c1 (never at a checked c1: only at one a policy chooses off
        the planner's grid), at the largest checked c1 below it, which does: a flight never
        stops on a route it cannot build."""
        try:
            return (c1, *self._Approach(c1))
        except AirspaceError:
            if c1 in self.checked_c1:
                raise
        below = max(c for c in self.checked_c1 if c <= c1)  # c̲1 is checked: never empty
        return (below, *self._Approach(below))

    def _Stages(self, c1: float) -> tuple[Stage, ...]:
        c1_first, code, e, pieces = self._ApproachAt(c1)
        approach = self._ApproachPieceStages(c1_first, pieces, code + 4 * e, 0, 0)
        cells = self._Chain(0, c1_first, code, e, c1)
        return (*approach, *self._Emit(cells, len(approach)))

    def _StagesAfter(self, index: int, anchor, c1: float) -> tuple[Stage, ...]:
        c1_a, a1, a2, j = anchor
        first = index - (1 if j != math.floor(j) else 0)  # the index of the leg's first stage
        if -1.0 <= j < 0.0:  # an approach piece: the rest of it, then the first cell at c1_a
            k, code, e = 0, int(round(a2)) % 4, int(round(a2)) // 4
            pieces = self._Around(self.start, self.heading, 0, c1_a, code, e)
            stages = self._ApproachPieceStages(c1_a, pieces, code + 4 * e, int(round(a1)), first)
            cells = self._Chain(0, c1_a, code, e, c1)
            leg, at = 0, None
        elif j < -1.0:  # a transit piece into the cell at place k: the rest, then the cell
            k, m, side, code, e = self._Decode(j)
            pieces = self._Around((a1, a2), self._Heading(side), k, c1_a, code, e)
            key = code + 4 * (e + _CUTS * k)
            stages = self._TransitStages(key, c1_a, (a1, a2), side, pieces, first, m)
            cells = self._Chain(k, c1_a, code, e, c1)
            leg, at = 0, None
        else:  # leg j of the cell at place k (or the second half of its arc, j + 0.5)
            k, packed = int(round(a1)), int(round(a2))
            code, e, x = packed % 4, (packed // 4) % _CUTS, packed // (4 * _CUTS)
            cells = self._Chain(k, c1_a, code, e, c1)
            stages, leg, at = [], int(math.floor(j)), first
            ends = [
                len(CellLegs(self._Cut(k, c1_a, code, e, y), self.r_min, -1))
                for y in (x, cells[0][4])
            ]
            if cells[0][4] != x and leg >= min(ends) - 1:  # its last line is being flown
                cells = self._Chain(k, c1_a, code, e, c1, x)
        rest = [st for st in stages if st.index > index]
        nxt = (rest[-1].index if rest else index) + 1
        k, c1_k, code, e, x, seq, _, _, _ = cells[0]
        legs = CellLegs(seq, self.r_min, self.cell_order[k])
        packed = code + 4 * e + 4 * _CUTS * x
        cell = self._CellStages(legs, k, packed, c1_k, nxt if at is None else at, leg)
        rest += [st for st in cell if st.index > index]
        nxt = (rest[-1].index if rest else index) + 1
        return (*rest, *self._Emit(cells[1:], nxt))

    # -- as flown ----------------------------------------------------------------------------------

    def LegOf(self, stage: Stage):
        """The route :class:`~eaplan_drake.field.route.Leg` a stage of this plan flies (both
        halves of a split arc give the same leg); None for the approach."""
        c1_a, a1, a2, j = stage.anchor
        if -1.0 <= j < 0.0:
            return None
        if j < -1.0:
            k, m, side, code, e = self._Decode(j)
            return self._Around((a1, a2), self._Heading(side), k, c1_a, code, e)[m]
        packed = int(round(a2))
        code, e, x = packed % 4, (packed // 4) % _CUTS, packed // (4 * _CUTS)
        seq = self._Cut(int(round(a1)), c1_a, code, e, x)
        return CellLegs(seq, self.r_min, self.cell_order[int(round(a1))])[int(math.floor(j))]
