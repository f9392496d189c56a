"""No-fly polygons kept out of: the test field of the missions' tests with its hole no-fly plans
a route with no point in the hole and none outside its fence as exported; a square field with a
square hole has the lines its cells give, shortened where their turns would enter; a start the
route cannot leave is refused in one line naming ``coverage.no_fly_holes``."""

import json
import math

import numpy as np
import pytest

shapely = pytest.importorskip("shapely")
pytest.importorskip("pyproj")

from test_field_missions import HOME, LANDING, Field  # noqa: E402

from eaplan_drake.field.airspace import (  # noqa: E402
    AirspaceError,
    MakeAirspace,
    PointsOutside,
    RoutePoints,
)
from eaplan_drake.field.decompose import Decompose  # noqa: E402
from eaplan_drake.field.missions import Fence  # noqa: E402
from eaplan_drake.field.nofly import (  # noqa: E402
    CLEARANCE,
    MakeAvoidingRoute,
    MakeNoFly,
    SurveyPolygon,
    VisibilityPath,
)
from eaplan_drake.field.plan import MakeFieldPlan, WithHomeLegs  # noqa: E402
from eaplan_drake.field.readers import FieldGeoJsonText  # noqa: E402
from eaplan_drake.params import Scenario  # noqa: E402

R_MIN = 62.45


@pytest.fixture(scope="module")
def planned():
    field = Field()
    plan = MakeFieldPlan(field, 10.0, R_MIN, no_fly=field.holes, min_line_length=8.0, start=HOME)
    return field, plan


def test_the_test_field_with_its_hole_no_fly_keeps_out_of_it(planned):
    from eaplan_drake.field.command import _Airspace

    field, plan = planned
    route = plan.route
    hole = shapely.Polygon(field.holes[0])
    points = RoutePoints(route)
    assert int(np.count_nonzero(shapely.contains(hole, shapely.points(points)))) == 0
    assert float(np.min(shapely.distance(hole, shapely.points(points)))) >= CLEARANCE - 1e-2
    scenario = Scenario()
    scenario.coverage.no_fly_holes = True
    airspace = MakeAirspace(route, field, scenario, home=HOME, no_fly=field.holes)  # no refusal
    assert len(airspace.Fence().exclusions) == 1
    _, check = _Airspace(plan, scenario, LANDING)  # the route as exported, home legs included
    assert check["in_no_fly"] == 0 and check["outside"] == 0
    # without the polygons the same field's route overflies the hole
    free = MakeFieldPlan(field, 10.0, R_MIN, min_line_length=8.0, start=HOME).route
    assert np.count_nonzero(shapely.contains(hole, shapely.points(RoutePoints(free)))) > 0


def test_the_plan_command_with_no_fly_holes_writes_a_route_outside_them(tmp_path, capsys):
    from eaplan_drake.cli import main

    path = tmp_path / "field.geojson"
    path.write_text(FieldGeoJsonText(Field()))
    args = ["plan", str(path), "--out", str(tmp_path), "--set", "coverage.no_fly_holes=true"]
    code = main([*args, "--home", "10.3240,55.4715", "--write-missions"])
    assert code in (0, 4)  # 4: the survey scenario's pack is too small, the missions written
    summary = json.loads((tmp_path / "field" / "summary.json").read_text())
    check = summary["airspace"]["check"]
    assert check["in_no_fly"] == 0 and check["outside"] == 0
    assert summary["airspace"]["no_fly"] == 1
    assert 0.5 < summary["no_fly"]["swath_coverage"] < 1.0  # the holes' shadows are not flown
    assert "polygons kept 10 m clear (coverage.no_fly_holes)" in capsys.readouterr().out
    assert (tmp_path / "field" / "mission.plan").exists()


def SquareWithHole():
    outer = shapely.Polygon([(0, 0), (400, 0), (400, 400), (0, 400)])
    hole = [(150, 150), (150, 250), (250, 250), (250, 150)]
    return shapely.Polygon(outer.exterior, [hole]), hole


def CellLines(route):
    out = {}
    for leg in route.legs:
        if leg.kind == "line":
            out.setdefault(leg.cell, []).append(leg)
    return out


def test_a_square_field_with_a_square_hole_has_the_lines_of_its_four_cells():
    # x_d = 10, r_min = 20 (J = 4), c = 10: the hole buffered by c + x_d/2 = 15 leaves a cell
    # 135 m high below it and one above (14 lines each), and two 130 m high beside it (13
    # lines each, running towards the hole)
    field, hole = SquareWithHole()
    no_fly = MakeNoFly([hole])
    survey = SurveyPolygon(field, no_fly, 10.0)
    assert survey.area == pytest.approx(400**2 - 130**2)
    d = Decompose(survey, 0.0)
    assert len(d.cells) == 4
    route = MakeAvoidingRoute(d, 10.0, 20.0, no_fly)
    assert route.Count("line") == 14 + 14 + 13 + 13
    lines = [leg for leg in route.legs if leg.kind == "line"]
    beside = [leg for leg in lines if 135 < leg.start[1] < 265]
    assert len(beside) == 26
    # they stop where their turns keep c from the hole: at least r_min short of the buffer (a
    # U turn, J x_d ≥ 2 r_min), up to (1 + √3) r_min for an Ω turn and more where a turn joins
    # ends not level; a cell's first and last lines have a transit at one end instead
    ends = {id(legs[0]) for legs in CellLines(route).values()}
    ends |= {id(legs[-1]) for legs in CellLines(route).values()}
    near = [min(abs(leg.start[0] - 200), abs(leg.end[0] - 200)) for leg in beside]
    assert min(n for n, leg in zip(near, beside, strict=True) if id(leg) not in ends) >= 80 - 1e-6
    assert max(near) <= 50.0 + CLEARANCE + 2.0 * (1.0 + math.sqrt(3.0)) * 20.0
    assert sum(1 for n in near if abs(n - 80.0) < 1.0) >= 13  # most after U turns: c + r_min
    fence = Fence(np.array([(-500, -500), (900, -500), (900, 900), (-500, 900)], float), (hole,))
    check = PointsOutside(RoutePoints(route), fence)
    assert check["in_no_fly"] == 0 and check["outside"] == 0
    away = shapely.Polygon(hole).buffer(CLEARANCE - 0.01)
    assert not away.intersects(shapely.LineString(RoutePoints(route)))


def test_the_visibility_path_goes_round_the_corners():
    _, hole = SquareWithHole()
    no_fly = MakeNoFly([hole])
    path = VisibilityPath(np.array([100.0, 200.0]), np.array([300.0, 200.0]), no_fly, 10.0)
    corners = np.array(path[1:-1])
    assert len(corners) == 2 and set(np.round(corners[:, 0])) == {140.0, 260.0}
    length = sum(math.dist(a, b) for a, b in zip(path[:-1], path[1:], strict=True))
    assert length == pytest.approx(2 * math.hypot(40, 60) + 120)


def test_a_start_the_route_cannot_leave_is_one_line_naming_the_key():
    field, hole = SquareWithHole()
    no_fly = MakeNoFly([hole])
    d = Decompose(SurveyPolygon(field, no_fly, 10.0), 0.0)
    with pytest.raises(AirspaceError, match=r"^coverage\.no_fly_holes: ") as e:
        MakeAvoidingRoute(d, 10.0, 20.0, no_fly, start=(200.0, 200.0))
    assert "\n" not in str(e.value)


def test_without_no_fly_polygons_the_plan_is_unchanged():
    field = Field()
    a = MakeFieldPlan(field, 10.0, R_MIN, min_line_length=8.0)
    b = MakeFieldPlan(field, 10.0, R_MIN, min_line_length=8.0, no_fly=())
    assert a.route == b.route and b.no_fly is None
    assert WithHomeLegs(a.route, HOME) == WithHomeLegs(b.route, HOME)


def test_a_random_field_its_way_home_included_keeps_out_of_its_hole():
    from eaplan_drake.field.nofly import WithHomeTransits
    from eaplan_drake.field.random_fields import RandomField

    field = RandomField(11, size=500.0, holes=1)  # its last line heads at the hole
    plan = MakeFieldPlan(field, 25.1, R_MIN, no_fly=field.holes, min_line_length=8.0)
    home = plan.route.legs[0].start
    route = WithHomeLegs(WithHomeTransits(plan.route, home, plan.no_fly), home)
    assert route.legs[-2].kind == "transit" and route.legs[-1].kind == "home"
    points = shapely.points(RoutePoints(route))
    assert not shapely.contains(shapely.Polygon(field.holes[0]), points).any()
    assert float(np.min(shapely.distance(shapely.Polygon(field.holes[0]), points))) >= 9.99


def test_the_turn_home_ends_heading_at_home():
    from eaplan_drake.field.nofly import _TurnToward

    (arc,) = _TurnToward((0.0, 0.0), (1.0, 0.0), (0.0, 200.0), 20.0)
    assert arc.ccw and arc.radius == 20.0 and arc.center == (0.0, 20.0)
    a = math.atan2(arc.end[1] - 20.0, arc.end[0]) + math.pi / 2  # heading at the arc's end
    to_home = math.atan2(200.0 - arc.end[1], -arc.end[0])
    assert abs(a - to_home) < math.radians(0.6)
    assert _TurnToward((0.0, 0.0), (1.0, 0.0), (0.0, 20.0), 20.0) is None  # inside its circle
    assert _TurnToward((0.0, 0.0), (1.0, 0.0), (50.0, 0.0), 20.0) == []


def test_a_landing_approach_across_the_hole_is_one_line_naming_the_key(planned):
    from eaplan_drake.field.command import _Airspace
    from eaplan_drake.field.missions import MissionEnds

    _, plan = planned
    scenario = Scenario()
    scenario.coverage.no_fly_holes = True
    across = MissionEnds(HOME, LANDING.ground_alt, "land", (1.0, 1.0))  # fix beyond the hole
    with pytest.raises(AirspaceError, match=r"^coverage\.no_fly_holes: the landing's approach"):
        _Airspace(plan, scenario, across)


def test_a_hole_that_cuts_the_field_in_two_gives_cells_on_both_sides():
    field = shapely.Polygon(
        [(0, 0), (400, 0), (400, 100), (0, 100)], [[(180, 10), (180, 90), (220, 90), (220, 10)]]
    )
    no_fly = MakeNoFly([field.interiors[0].coords[:-1]])
    survey = SurveyPolygon(field, no_fly, 10.0)  # the hole + 15 m reaches past both edges
    assert survey.geom_type == "MultiPolygon" and len(survey.geoms) == 2
    d = Decompose(survey, 90.0)
    assert len(d.cells) == 2
    route = MakeAvoidingRoute(d, 10.0, 20.0, no_fly)
    assert route.Count("line") == 2 * 17  # 165 m each side at 10 m: ⌈16.5⌉ lines
    assert route.transits == 1
    hole = shapely.Polygon(field.interiors[0])
    assert hole.distance(shapely.LineString(RoutePoints(route))) >= CLEARANCE - 0.01
