"""The Zamboni plan's remaining-time staircase (PlanSource.TimeAfter, the sequencer's
``remaining_time``): timed per repetition without building the stages, it must stay bit for bit
its definition, the sum of StageTime over StagesAfter in the order of the stages."""

import math

import numpy as np
import pytest

from eaplan_drake.flight.coverage import ZamboniCoverage
from eaplan_drake.flight.paths import Line
from eaplan_drake.flight.polygon import CoveragePolygon
from eaplan_drake.flight.stages import ArcStart, GroundSpeed, LineSpeed, StageTime
from eaplan_drake.params import CoverageParams, GuidanceParams

V_A = 15.0
GRID = (-1000.0, -612.5, -437.25, -120.0, 0.0)
WINDS = ((0.0, 0.0), (5.0, -3.0), (-7.5, 11.25), (0.0, 9.0))


def _Fields() -> list[CoverageParams]:
    """The reference rectangle, the same rotated by 30° (slanted lines) and random convex
    polygons wide enough for several repetitions."""
    fields = [CoverageParams()]
    rect = np.array(CoverageParams().polygon, dtype=float)
    c, s = math.cos(math.pi / 6.0), math.sin(math.pi / 6.0)
    fields.append(CoverageParams(polygon=(rect @ np.array([[c, s], [-s, c]])).round(3).tolist()))
    rng = np.random.default_rng(5)
    while len(fields) < 5:
        n = int(rng.integers(3, 8))
        angles = np.sort(rng.uniform(0.0, 2.0 * np.pi, n))
        radii = rng.uniform(200.0, 360.0, n)
        vertices = np.column_stack([radii * np.cos(angles), radii * np.sin(angles)]).round(1)
        edge = int(rng.integers(0, n))
        try:
            if CoveragePolygon(vertices.tolist(), edge).width >= 450.0:
                fields.append(CoverageParams(polygon=vertices.tolist(), line_edge=edge))
        except ValueError:
            continue
    return fields


FIELDS = _Fields()


def _Plan(params: CoverageParams) -> ZamboniCoverage:
    poly = CoveragePolygon(params.polygon, params.line_edge)
    start = poly.ToWorld(-40.0, 150.0)
    k_e = GuidanceParams().k_e
    return ZamboniCoverage(params, start=start, airspeed=V_A, initial_c1=0.0, k_e=k_e)


def _Flown(plan: ZamboniCoverage) -> tuple:
    """The stages of a flight that changes c1 in the middle of repetitions (on the half circle
    and on the second line), at a repetition's last stage and on a first line."""
    stages = plan.Stages(0.0)
    i = 0
    for primitive, c1 in ((1, -1000.0), (2, -437.25), (3, -120.0), (0, -612.5), (2, 0.0)):
        later = [j for j in range(i + 1, len(stages) - 1) if stages[j].primitive == primitive]
        if not later:
            break
        i = later[0]
        stages = plan.Replan(stages, i, c1)
    return stages


def _Definition(plan, stage, c1, wind) -> float:
    rest = plan.StagesAfter(stage.index, stage.anchor, c1)
    return float(sum(StageTime(s, V_A, np.array(wind)) for s in rest))


@pytest.mark.parametrize("field", range(len(FIELDS)))
def test_the_staircase_is_the_sum_of_the_stage_times_after_every_flown_stage(field):
    params = FIELDS[field]
    staircase, definition = _Plan(params), _Plan(params)
    flown = _Flown(definition)
    assert len({s.c1 for s in flown}) >= 4  # the flight did change c1 mid-repetition
    for wind in WINDS:
        for stage in flown:
            for c1 in GRID:
                expected = _Definition(definition, stage, c1, wind)
                got = staircase.TimeAfter(stage.index, stage.anchor, c1, V_A, wind)
                assert got == expected, (field, wind, stage.index, c1)


@pytest.mark.parametrize("field", [0, 1, 3])
def test_the_half_circles_kept_per_repetition_are_those_of_its_stages(field):
    """The wind-free half circles the staircase keeps per repetition (_RepArcs: ArcStart and
    length) are, bit for bit, those of the circles _RepStages builds, at every c1 of the grid."""
    plan = _Plan(FIELDS[field])
    for c1 in GRID:
        prev_eta_u = None
        for k, eta_d, r2, c1_rep in plan._Reps(0, plan.x_d / 2.0, c1):
            stages = plan._RepStages(k, eta_d, r2, c1_rep, prev_eta_u)
            _, arc1, _, arc2 = plan._RepArcs(eta_d, r2, prev_eta_u)
            circles = [s for s in stages if s.is_circle]
            assert [arc1] + ([] if arc2 is None else [arc2]) == [
                (ArcStart(s.path, s.entry), s.length) for s in circles
            ]
            prev_eta_u = eta_d + 2.0 * plan.r1


def test_the_staircase_depends_on_its_arguments_only():
    """Caches filled in another order (another plan object, stages and c1 reversed) give the
    same numbers."""
    params = FIELDS[2]
    one, other = _Plan(params), _Plan(params)
    flown = _Flown(one)
    wind = (5.0, -3.0)
    forward = [[one.TimeAfter(s.index, s.anchor, c1, V_A, wind) for c1 in GRID] for s in flown]
    other.Stages(-1000.0)  # stages built before the times
    backward = [
        [other.TimeAfter(s.index, s.anchor, c1, V_A, wind) for c1 in reversed(GRID)][::-1]
        for s in reversed(flown)
    ][::-1]
    assert forward == backward


def test_the_staircase_refuses_the_winds_that_stage_time_refuses():
    plan = _Plan(FIELDS[0])
    stages = plan.Stages(0.0)
    for stage in (stages[0], stages[2], stages[4]):  # approach, half circle, second circle
        for wind in ((V_A, 0.0), (0.0, -20.0), (math.nan, 0.0)):
            with pytest.raises(ValueError, match="wind"):
                plan.TimeAfter(stage.index, stage.anchor, -437.25, V_A, wind)


@pytest.mark.parametrize("normal", [(1.0, 0.0), (1.0, -0.0), (-0.0, -1.0), (0.6, -0.8)])
def test_a_line_has_one_ground_speed_at_every_point(normal):
    """LineSpeed (what the staircase times a line with) does not depend on the point."""
    points = [(0.0, 0.0), (-115.0, 146.0), (35.5, -11.25), (-0.0, 7.0), (1e5, -3e4)]
    for s in (1.0, -1.0):
        line = Line((3.0, -2.0), normal, s=s, k_e=0.1)
        for wind in ((0.0, 0.0), (0.0, -4.0), (-4.0, 0.0), (3.0, 5.5)):
            w = np.array(wind)
            speeds = {LineSpeed(line, p, V_A, w) for p in points}
            assert len(speeds) == 1
            t = line.tangent(points[1])
            assert speeds == {GroundSpeed(t / np.linalg.norm(t), V_A, w)}
