"""A field read from a file as a plan source: the cells' Zamboni-like lines and turns as the
stages the sequencer flies, re-planned in c1 from the next cell on.

The cells and the sweep direction θ are chosen once, for the lowest plan's line spacing
x_d(c̲1) (:func:`~eaplan_drake.field.plan.MakeFieldPlan`; cells convex or monotone, whichever
flies shorter), and so is the order the cells are visited in. At a path parameter c1 [m²] each
cell is flown with the lines of spacing x_d(c1) = 2 r1 − 2 r2(c1)
(:func:`~eaplan_drake.field.plan.LineSpacing`, paper 003 Eq. 14: x_d at c1 = 0, wider below),
in the Zamboni-like order of :mod:`eaplan_drake.field.route`, the first cell as the pre-flight
route enters it, every later one at the end nearest to where the previous cell ended (so at c̲1
the survey is the route of :func:`~eaplan_drake.field.plan.MakeFieldPlan` that ``eaplan-drake
plan`` predicts and exports). The stages, in flight order:

- the *approach* (primitive −1, :data:`~eaplan_drake.flight.stages.APPROACH`): the shortest
  (Dubins) path of radius r_min from the start, along ψ(0) (``vehicle.initial_heading_deg``),
  onto the first line at its start;
- each survey line (primitive 0 or 2, alternately within a cell) with its end as triggering point
  (lines shorter than 4 ε, slivers in sharp corners, are left out);
- each turn (primitive 1 after a line of primitive 0, else 3): a half circle, or the three arcs
  of an Ω turn (:func:`~eaplan_drake.field.route.TurnLegs`), the later arcs
  :data:`CONTINUED`; an arc longer than a half circle is two stages, split at its middle, so that
  the sequencer's "passed the triggering point" test never fires on entry;
- between cells, a *transit* (primitive −1, like the approach: not part of the survey length) to
  the next cell's first line: the shortest turn–straight–turn path of radius r_min
  (:func:`~eaplan_drake.field.route.TransitLegs`).

A leg shorter than 4 ε (``coverage.trigger_radius``: a sliver of a transit or of an Ω turn) is
left out (the sequencer needs 4 ε between triggering points) and the guidance joins the next
stage directly.

Four primitives alternate as in the paper's plan (line, turn, line, turn), so the sequencer's
period T (the time between two entries into the same primitive) is a line pair with its turns.

Re-planning (:meth:`~eaplan_drake.flight.coverage.PlanSource.Replan`) keeps the rest of the cell
being flown (or entered, on its transit) as it is and regenerates the later cells at the new c1.
A stage's anchor is all the source needs to continue: (c1 of its cell, the cell's place in the
visiting order, the cell's orientation 0–3, the leg's place in its cell) on a cell, (c1, the
piece, 0, −1) on the approach, (c1 of the next cell, the transit's start x, y [m], a tag of the
cell, the piece and the heading: −2 − 2(8 k + 2 m + s) for piece m into the cell at place k,
heading ±u(θ)) on a transit; + 0.5 on the second half of a split arc.

Lengths in m, angles in rad, c1 in m².
"""

import math

import numpy as np

from eaplan_drake.field.geodesy import Require
from eaplan_drake.field.nofly_source import AvoidingStages
from eaplan_drake.field.plan import LineSpacing, MakeFieldPlan
from eaplan_drake.field.route import (
    CellLegs,
    CellSweepLines,
    OrderCellLines,
    Route,
    TransitLegs,
    TurnJump,
)
from eaplan_drake.flight.coverage import PlanSource
from eaplan_drake.flight.paths import Circle, Line
from eaplan_drake.flight.stages import APPROACH, NUM_PRIMITIVES, MakeStage, Stage
from eaplan_drake.packaged import PACKAGED_FIELDS, PackagedPath
from eaplan_drake.params import MAX_SURVEY_LINES

__all__ = [
    "CONTINUED",
    "AvoidingFieldCoverage",
    "FieldCoverage",
    "FieldPath",
    "MakeFieldPlanSource",
]

CONTINUED = NUM_PRIMITIVES
"""Primitive of a stage that continues a turn (an Ω turn's later arcs, a split arc's second
half): part of the survey, outside the sequencer's primitives 0–3 that measure the period."""


def FieldPath(name_or_path: str) -> str:
    """The file of ``coverage.field``: a packaged field's
    (:data:`~eaplan_drake.packaged.PACKAGED_FIELDS`) or the path."""
    return PackagedPath(PACKAGED_FIELDS, name_or_path)


def _Left(d) -> np.ndarray:
    return np.array([-d[1], d[0]], dtype=float)


def _Unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


class FieldCoverage(PlanSource):
    """The survey of a field with holes (:class:`~eaplan_drake.field.readers.Field`) as a
    function of c1 (module docstring).

    Args:
        field: the field, local east-north [m].
        coverage: the scenario's :class:`~eaplan_drake.params.CoverageParams` (x_d, r, r_min, ε).
        start: the aircraft's start position [m].
        airspeed: v_a [m/s].
        initial_c1: c1 of the initial plan [m²], within ``c1_bounds``.
        k_e: the field gain of every path [1/m].
        c1_bounds: [c̲1, c̄1] [m²], with r2(c̲1) ≥ r_min.
        initial_heading_deg: ψ(0) [deg from east, counter-clockwise] at ``start``.
        cells: ``best``, ``convex`` or ``monotone``
            (:func:`~eaplan_drake.field.plan.MakeFieldPlan`).
        no_fly: no-fly polygons [m] the pre-flight plan keeps out of (its cells are the field's
            minus them); the stages keep out of them in
            :class:`AvoidingFieldCoverage`.
    """

    def __init__(
        self,
        field,
        coverage,
        *,
        start,
        airspeed: float,
        initial_c1: float,
        k_e: float,
        c1_bounds,
        initial_heading_deg: float = 0.0,
        cells: str = "best",
        no_fly=(),
    ):
        self.field = field
        self.r = float(coverage.turning_radius)
        self.r_min = float(coverage.min_turning_radius)
        self.min_leg = 4.0 * float(coverage.trigger_radius)
        self.k_e = float(k_e)
        self._coverage = coverage
        self.start = np.array(start, dtype=float).reshape(2)
        psi = math.radians(float(initial_heading_deg))
        self.heading = np.array([math.cos(psi), math.sin(psi)])
        lo = float(c1_bounds[0])
        if not (lo >= self.r_min**2 - self.r**2 - 1e-6):
            raise ValueError(
                f"planner.path_parameter_bounds: c1 = {lo:g} m² makes r2 < r_min; at least "
                f"r_min² − r² = {self.r_min**2 - self.r**2:g}"
            )
        plan = MakeFieldPlan(
            field,
            LineSpacing(coverage, lo),
            self.r_min,
            cells=cells,
            min_line_length=self.min_leg,
            no_fly=no_fly,
        )
        self.plan = plan
        self.decomposition = plan.choice.decomposition
        self.theta_deg = float(self.decomposition.theta_deg)
        self.cell_order = tuple(dict.fromkeys(leg.cell for leg in plan.route.legs if leg.cell >= 0))
        super().__init__(c1_bounds, initial_c1=initial_c1, airspeed=airspeed)

    # -- legs --------------------------------------------------------------------------------------

    def Spacing(self, c1: float) -> float:
        """x_d(c1) [m] of the lines at c1."""
        return float(LineSpacing(self._coverage, c1))

    def _CellLines(self, place: int, c1: float, position, orientation=None, heading=None):
        """(orientation, legs) of the cell at ``place`` in the visiting order at c1, entered
        from ``position`` travelling along ``heading`` (:func:`OrderCellLines`)."""
        spacing = self.Spacing(c1)
        cell = self.decomposition.cells[self.cell_order[place]]
        lines = CellSweepLines(cell, self.theta_deg, spacing, self.min_leg)
        jump = TurnJump(spacing, self.r_min)
        _, code, seq = OrderCellLines(lines, jump, position, orientation, heading, self.r_min)
        return code, CellLegs(seq, self.r_min, self.cell_order[place])

    def SwathCoverage(self, c1: float) -> float:
        """The fraction [0, 1] of the field's area that the swaths of the survey lines cover at
        c1: each line's stage buffered by x_d(c1)/2 on either side."""
        shapely = Require("shapely")
        half = 0.5 * self.Spacing(c1)
        swaths = shapely.union_all(
            [
                shapely.LineString([s.entry, s.trigger]).buffer(half)
                for s in self.Stages(c1)
                if s.primitive in (0, 2)
            ]
        )
        polygon = self.field.Polygon()
        return float(swaths.intersection(polygon).area / polygon.area)

    def DistanceOutside(self, stage, step: float = 5.0) -> float:
        """How far [m] the path of ``stage`` gets from the field (0 where it stays inside), its
        points sampled every ≈ ``step`` [m] (:func:`~eaplan_drake.flight.stages.StagePoints`,
        lines cut into pieces of at most ``step``)."""
        from eaplan_drake.flight.stages import StagePoints

        shapely = Require("shapely")
        path = shapely.LineString(StagePoints(stage, step)).segmentize(step)
        polygon = self.field.Polygon()
        return max(float(polygon.distance(shapely.Point(p))) for p in path.coords)

    # -- stages ------------------------------------------------------------------------------------

    def _LegStages(self, leg, index: int, primitive: int, c1, anchor) -> list[Stage]:
        """The stages of one leg (a loop turn is two)."""
        start, end = np.asarray(leg.start), np.asarray(leg.end)
        if leg.radius == 0.0:
            path = Line(start, _Left(_Unit(end - start)), s=1.0, k_e=self.k_e)
            return [MakeStage(index, path, end, primitive, c1, start, leg.length, anchor)]
        center = np.asarray(leg.center)
        path = Circle(center, leg.radius, s=-1.0 if leg.ccw else 1.0, k_e=self.k_e)
        if leg.angle <= math.pi + 1e-9:
            return [MakeStage(index, path, end, primitive, c1, start, leg.length, anchor)]
        half = 0.5 * leg.angle * (1.0 if leg.ccw else -1.0)
        c, s = math.cos(half), math.sin(half)
        middle = center + np.array([[c, -s], [s, c]]) @ (start - center)
        second = (*anchor[:3], anchor[3] + 0.5)
        then = APPROACH if primitive == APPROACH else CONTINUED
        return [
            MakeStage(index, path, middle, primitive, c1, start, 0.5 * leg.length, anchor),
            MakeStage(index + 1, path, end, then, c1, middle, 0.5 * leg.length, second),
        ]

    def _Heading(self, s: int) -> np.ndarray:
        """The lines' direction u(θ) (s = 0) or −u(θ) (s = 1)."""
        theta = math.radians(self.theta_deg)
        u = np.array([math.cos(theta), math.sin(theta)])
        return u if s == 0 else -u

    def _Side(self, leg) -> int:
        """s of the direction of travel of a line ``leg`` (:meth:`_Heading`)."""
        return 0 if np.subtract(leg.end, leg.start) @ self._Heading(0) > 0.0 else 1

    def _Transit(self, k: int, c1: float, position, s: int):
        """(orientation, legs of the cell at ``place`` k at c1 entered from ``position``, the
        transit pieces from ``position`` travelling along :meth:`_Heading` (s))."""
        code, legs = self._CellLines(k, c1, position, heading=self._Heading(s))
        line = np.subtract(legs[0].end, legs[0].start)
        pieces = TransitLegs(position, self._Heading(s), legs[0].start, line, self.r_min)
        return code, legs, pieces

    def _TransitStages(self, k, c1, position, s, pieces, index, first=0) -> list[Stage]:
        """The stages of the transit ``pieces[first:]`` into the cell at ``place`` k. Their
        anchor is (c1, x, y, tag): the transit's start (x, y) [m] and tag = −2 − 2(8k + 2m + s)
        for piece m (+ 0.5 on the second half of a split arc)."""
        stages: list[Stage] = []
        for m in range(first, len(pieces)):
            if pieces[m].length < self.min_leg:
                continue
            anchor = (c1, float(position[0]), float(position[1]), self._Tag(k, m, s))
            stages += self._LegStages(pieces[m], index, APPROACH, c1, anchor)
            index = stages[-1].index + 1
        return stages

    def _Tag(self, k: int, m: int, s: int) -> float:
        """The transit anchor's tag of piece m into the cell at place k, along
        :meth:`_Heading` (s) (module docstring)."""
        return -2.0 - 2.0 * (8 * k + 2 * m + s)

    def _Cells(self, place: int, c1: float, position, s: int, index: int) -> list[Stage]:
        """The stages of the cells from ``place`` on at c1, each after its transit from
        ``position`` [m] travelling along :meth:`_Heading` (s); the first cell (place 0) after
        the approach instead."""
        stages: list[Stage] = []
        for k in range(place, len(self.cell_order)):
            if k == 0:
                code, legs = self._CellLines(0, c1, None)
            else:
                code, legs, pieces = self._Transit(k, c1, position, s)
                stages += self._TransitStages(k, c1, position, s, pieces, index)
                index = stages[-1].index + 1 if stages else index
            stages += self._CellStages(legs, k, code, c1, index, 0)
            index = stages[-1].index + 1
            position, s = np.asarray(legs[-1].end), self._Side(legs[-1])
        return stages

    def _CellStages(self, legs, place, code, c1, index, first) -> list[Stage]:
        """The stages of a cell's ``legs[first:]``: line k has primitive 0 (k even) or 2, the
        first arc of the turn after it 1 or 3; the later arcs of an Ω turn and the second half
        of a split arc are :data:`CONTINUED` (no period is measured on them)."""
        stages: list[Stage] = []
        lines = sum(1 for leg in legs[:first] if leg.kind == "line")
        after_line = first > 0 and legs[first - 1].kind == "line"
        for j in range(first, len(legs)):
            leg = legs[j]
            if leg.kind == "line":
                primitive = 0 if lines % 2 == 0 else 2
                lines += 1
            elif leg.length < self.min_leg:  # a sliver of an Ω turn: the guidance joins it
                continue
            else:
                primitive = (1 if lines % 2 == 1 else 3) if after_line else CONTINUED
            after_line = leg.kind == "line"
            stages += self._LegStages(leg, index, primitive, c1, (c1, place, code, j))
            index = stages[-1].index + 1
        return stages

    def _ApproachStages(self, c1: float, legs, first: int = 0, index: int = 0) -> list[Stage]:
        """The approach from pieces ``first`` on: the Dubins path of radius r_min from the start,
        along ψ(0), onto the first line of the first cell (``legs``) at c1. Anchor (c1, m, 0,
        −1) for piece m (+ 0.5 on the second half of a split arc)."""
        line = np.subtract(legs[0].end, legs[0].start)
        pieces = TransitLegs(self.start, self.heading, legs[0].start, line, self.r_min)
        return self._ApproachPieceStages(c1, pieces, 0, first, index)

    def _ApproachPieceStages(self, c1, pieces, key: int, first: int, index: int) -> list[Stage]:
        """The stages of the approach ``pieces`` from piece ``first`` on, anchored (c1, m,
        ``key``, −1) for piece m; a piece shorter than 4 ε is left out, but never the last."""
        kept = [m for m, leg in enumerate(pieces) if leg.length >= self.min_leg]
        kept = kept or [len(pieces) - 1]  # at least one stage: onto the first line
        stages: list[Stage] = []
        for m in kept:
            if m < first:
                continue
            anchor = (c1, float(m), float(key), -1.0)
            stages += self._LegStages(pieces[m], index, APPROACH, c1, anchor)
            index = stages[-1].index + 1
        return stages

    def _Stages(self, c1: float) -> tuple[Stage, ...]:
        # The first cell is entered as the pre-flight route enters it (its first orientation):
        # at c̲1 the stages are the lines and turns of that route.
        _, legs = self._CellLines(0, c1, None)
        approach = self._ApproachStages(c1, legs)
        return (*approach, *self._Cells(0, c1, None, 0, len(approach)))

    def _StagesAfter(self, index: int, anchor, c1: float) -> tuple[Stage, ...]:
        c1_a, a1, a2, j = anchor
        half = j != math.floor(j)
        first = index - (1 if half else 0)  # the index of the leg's first stage
        if -1.0 <= j < 0.0:  # an approach piece: the rest of it and the first cell at c1_a
            k = 0
            _, legs = self._CellLines(0, c1_a, None)
            stages = self._ApproachStages(c1_a, legs, int(round(a1)), first)
            rest = [st for st in stages if st.index > index]
            nxt = (rest[-1].index if rest else index) + 1
            rest += self._CellStages(legs, 0, 0, c1_a, nxt, 0)
        elif j < -1.0:  # a transit piece into cell k: the rest of it, then the cell, at c1_a
            n = int(round((-2.0 - math.floor(j)) / 2.0))
            k, m, s = n // 8, (n % 8) // 2, n % 2
            position = np.array([a1, a2])
            code, legs, pieces = self._Transit(k, c1_a, position, s)
            stages = self._TransitStages(k, c1_a, position, s, pieces, first, m)
            rest = [st for st in stages if st.index > index]
            nxt = (rest[-1].index if rest else index) + 1
            rest += self._CellStages(legs, k, code, c1_a, nxt, 0)
        else:  # leg j of the cell at ``place`` (or the second half of its arc, j + 0.5)
            k, code = int(round(a1)), int(round(a2))
            _, legs = self._CellLines(k, c1_a, None, code)
            stages = self._CellStages(legs, k, code, c1_a, first, int(math.floor(j)))
            rest = [st for st in stages if st.index > index]
        nxt = (rest[-1].index if rest else index) + 1
        end, s = np.asarray(legs[-1].end), self._Side(legs[-1])
        return (*rest, *self._Cells(k + 1, c1, end, s, nxt))

    # -- as flown ----------------------------------------------------------------------------------

    def LegOf(self, stage: Stage):
        """The route :class:`~eaplan_drake.field.route.Leg` a stage of this plan flies (both
        halves of a split arc give the same leg); None for the approach."""
        c1_a, a1, a2, j = stage.anchor
        if -1.0 <= j < 0.0:
            return None
        if j < -1.0:  # transit piece m into the cell at place k
            n = int(round((-2.0 - math.floor(j)) / 2.0))
            k, m, s = n // 8, (n % 8) // 2, n % 2
            return self._Transit(k, c1_a, np.array([a1, a2]), s)[2][m]
        legs = self._CellLines(int(round(a1)), c1_a, None, int(round(a2)))[1]
        return legs[int(math.floor(j))]

    def FlownRoute(self, stages) -> Route:
        """The route of the stages a flight flew
        (:func:`~eaplan_drake.flight.coverage.FlownStages`): its lines, turns and transits as
        flown, each cell at the spacing it was flown with (the route's ``spacing`` is the lowest
        plan's). Missions are written from it as from the
        pre-flight route (:func:`~eaplan_drake.field.missions.WriteMissions`)."""
        legs, last = [], None
        for stage in stages:
            key = (*stage.anchor[:3], math.floor(stage.anchor[3]))
            leg = None if key == last else self.LegOf(stage)
            last = key
            if leg is not None:
                legs.append(leg)
        return Route(
            tuple(legs),
            theta_deg=self.theta_deg,
            spacing=self.plan.route.spacing,
            min_turning_radius=self.r_min,
        )


class AvoidingFieldCoverage(AvoidingStages, FieldCoverage):
    """:class:`FieldCoverage` whose stages keep out of the field's holes at every c1
    (``coverage.no_fly_holes: true``, :mod:`eaplan_drake.field.nofly_source`)."""


def _CheckFieldSize(field, coverage, c1_bounds) -> None:
    """ValueError before any stage is built when the field needs more than
    :data:`~eaplan_drake.params.MAX_SURVEY_LINES` lines at the narrowest line spacing of
    ``c1_bounds`` (at least its narrowest width / that spacing; every c1 of the bounds is
    flown and checked): the rule of the Zamboni plan's own check, from the field's outline
    alone."""
    from eaplan_drake.field.readers import MinimumWidth

    spacing = min(LineSpacing(coverage, float(c1)) for c1 in c1_bounds)
    width = MinimumWidth(field.Polygon())
    lines = math.floor(width / spacing)
    if lines > MAX_SURVEY_LINES:
        raise ValueError(
            f"the field is {width:.0f} m across at its narrowest: at least {lines} survey lines "
            f"at the narrowest spacing ({spacing:g} m; coverage.swath_spacing = "
            f"{coverage.swath_spacing:g} m), at most {MAX_SURVEY_LINES} allowed"
        )


def MakeFieldPlanSource(scenario, initial_c1: float) -> FieldCoverage:
    """The plan source of ``scenario``'s ``coverage.field`` (a GeoJSON, KML or QGroundControl
    file, or a packaged field's name, :func:`FieldPath`, read in the local frame of its first
    vertex, :func:`~eaplan_drake.field.readers.ReadField`; c1 over
    ``planner.path_parameter_bounds``), flown from ``vehicle.initial_position`` at
    ``vehicle.airspeed`` with the field gain ``guidance.k_e``, starting with ``initial_c1`` [m²];
    with ``coverage.no_fly_holes: true`` around the field's holes (:class:`AvoidingFieldCoverage`).
    Needs the ``[field]`` extra. Raises ValueError (or OSError for the file), also when a given
    ``coverage.airspace_margin`` is too small for the lowest plan's route
    (:func:`~eaplan_drake.field.airspace.MakeAirspace`) or no route keeps out of the holes."""
    from eaplan_drake.field.readers import ReadField

    coverage = scenario.coverage
    index = None if coverage.field_polygon < 0 else int(coverage.field_polygon)
    field = ReadField(FieldPath(coverage.field), index=index)
    _CheckFieldSize(field, coverage, scenario.planner.path_parameter_bounds)
    avoid = coverage.no_fly_holes and len(field.holes) > 0
    checked = {"checked_c1": scenario.planner.PathParameterGrid()} if avoid else {}
    source = (AvoidingFieldCoverage if avoid else FieldCoverage)(
        field,
        coverage,
        start=scenario.vehicle.initial_position,
        airspeed=scenario.vehicle.airspeed,
        initial_c1=initial_c1,
        k_e=scenario.guidance.k_e,
        c1_bounds=scenario.planner.path_parameter_bounds,
        initial_heading_deg=scenario.vehicle.initial_heading_deg,
        cells=coverage.field_cells,
        **checked,
    )
    if coverage.airspace_margin >= 0.0 or coverage.no_fly_holes:  # refused before the flight
        from eaplan_drake.field.airspace import MakeAirspace

        route = source.plan.route
        no_fly = field.holes if coverage.no_fly_holes else ()
        MakeAirspace(route, field, scenario, margin=coverage.airspace_margin, no_fly=no_fly)
    return source
