"""The airspace a field survey declares: the turn excursion E(R, w) and the wind's stretch
against their closed forms, the default margin as the smallest that works, the route inside its
fence by check, and one line for a margin too small or a no-fly polygon the route crosses."""

import math

import numpy as np
import pytest

shapely = pytest.importorskip("shapely")
pytest.importorskip("pyproj")

from eaplan_drake.field.airspace import (  # noqa: E402
    TRACKING_ALLOWANCE,
    AirspaceError,
    AirspaceMargin,
    MakeAirspace,
    PointsOutside,
    RoutePoints,
    TurnExcursion,
    TurnStretch,
)
from eaplan_drake.field.decompose import ChooseSweepDirection  # noqa: E402
from eaplan_drake.field.geodesy import LocalFrame  # noqa: E402
from eaplan_drake.field.readers import FieldFromLocal  # noqa: E402
from eaplan_drake.field.route import MakeRoute  # noqa: E402
from eaplan_drake.params import Scenario  # noqa: E402

R_MIN = 62.45


@pytest.fixture(scope="module")
def survey():
    field = FieldFromLocal(
        [(0, 0), (500, 0), (520, 400), (300, 380), (300, 200), (200, 200), (180, 400), (0, 400)],
        [[(60, 60), (60, 140), (140, 140), (140, 60)]],
        LocalFrame(10.3250, 55.4720),
    )
    choice = ChooseSweepDirection(field.Polygon(), 25.0)
    return field, MakeRoute(choice.decomposition, 25.0, R_MIN)


def test_turn_excursion_is_r_for_wide_turns_and_up_to_1_plus_sqrt3_r_for_omega_turns():
    assert TurnExcursion(60.0, 120.0) == 60.0
    assert TurnExcursion(60.0, 500.0) == 60.0
    assert TurnExcursion(1.0, 1.0) == pytest.approx(1.0 + math.sqrt(4.0 - 1.5**2), rel=1e-15)
    assert TurnExcursion(60.0, 0.0) == pytest.approx((1.0 + math.sqrt(3.0)) * 60.0, rel=1e-15)
    # continuous where the Ω turn becomes two quarter circles (w = 2R)
    assert TurnExcursion(60.0, 120.0 - 1e-9) == pytest.approx(60.0, abs=1e-3)


def test_the_wind_stretches_turns_only_past_the_bank_limit():
    r_air = 15.0**2 / (9.80665 * math.tan(math.radians(45.0)))  # 22.94 m
    assert TurnStretch(15.0, 0.0, 45.0, R_MIN) == 1.0
    assert TurnStretch(15.0, 5.0, 45.0, R_MIN) == 1.0  # 40.8 m < r_min
    expected = r_air * (25.0 / 15.0) ** 2 / R_MIN  # 63.7 m: tailwind at 10 m/s
    assert TurnStretch(15.0, 10.0, 45.0, R_MIN) == pytest.approx(expected, rel=1e-12)
    assert TurnStretch(15.0, 10.0, 45.0, R_MIN) == pytest.approx(1.0205, abs=1e-4)


def test_route_points_lie_on_the_route(survey):
    _, route = survey
    points = RoutePoints(route, step=2.0)
    turn = next(leg for leg in route.legs if leg.radius > 0.0)
    arc = RoutePoints(type(route)((turn,), route.theta_deg, route.spacing, R_MIN))
    np.testing.assert_allclose(np.linalg.norm(arc - turn.center, axis=1), turn.radius, rtol=1e-12)
    np.testing.assert_allclose(arc[[0, -1]], [turn.start, turn.end], atol=1e-9)
    assert len(points) > route.Length() / 2.0  # every ≈ 2 m


def test_the_default_margin_is_the_route_excursion_and_holds_the_route(survey):
    field, route = survey
    scenario = Scenario()
    scenario.wind.speed = 0.0
    outline = shapely.Polygon(field.exterior)
    far = float(np.max(shapely.distance(outline, shapely.points(RoutePoints(route)))))
    required = AirspaceMargin(route, field, scenario)
    assert required["route_m"] == pytest.approx(far, abs=1e-9)
    assert required["stretch"] == 1.0
    assert required["margin"] == pytest.approx(far + TRACKING_ALLOWANCE, abs=1e-9)
    assert 0.0 < required["line_m"] <= 0.5 * route.spacing + 1e-6
    # Ω turns exist here: the excursion is between r_min and (1 + √3) r_min beyond the lines
    assert R_MIN < far <= required["line_m"] + TurnExcursion(R_MIN, 0.0) + 1e-6
    home = (-150.0, -120.0)  # the launch point outside the field
    airspace = MakeAirspace(route, field, scenario, home=home)
    fence = airspace.Fence()
    assert fence.exclusions == ()  # the hole may be overflown
    check = PointsOutside(np.concatenate([RoutePoints(route), [home]]), fence)
    assert check["outside"] == 0 and check["points"] > 1000
    # the fence is the field's outline and the corridors home, widened by the margin (+ the
    # 1 m of its simplification), no more
    ring = shapely.Polygon(fence.inclusion)
    corridors = shapely.LineString([route.legs[-1].end, home, route.legs[0].start])
    widened = shapely.union(outline, corridors).buffer(airspace.margin + 2.0)
    assert ring.difference(widened).area == pytest.approx(0.0, abs=1e-6)
    assert ring.covers(outline.buffer(airspace.margin))


def test_in_wind_the_turns_part_is_stretched(survey):
    field, route = survey
    scenario = Scenario()
    scenario.wind.speed = 10.0
    required = AirspaceMargin(route, field, scenario)
    k = TurnStretch(15.0, 10.0, 45.0, R_MIN)
    turns = required["route_m"] - required["line_m"]
    assert required["margin"] == pytest.approx(
        required["line_m"] + k * turns + TRACKING_ALLOWANCE, rel=1e-12
    )


def test_a_margin_too_small_is_one_line_naming_the_smallest_that_works(survey):
    field, route = survey
    scenario = Scenario()
    smallest = AirspaceMargin(route, field, scenario)["margin"]
    with pytest.raises(AirspaceError) as e:
        MakeAirspace(route, field, scenario, margin=50.0)
    message = str(e.value)
    assert "\n" not in message
    assert message.startswith("coverage.airspace_margin: 50 m is too small for this route")
    assert message.endswith(f"the smallest that works is {math.ceil(smallest * 10) / 10:.1f} m")
    wider = MakeAirspace(route, field, scenario, margin=smallest + 40.0)
    assert wider.margin == smallest + 40.0
    assert PointsOutside(RoutePoints(route), wider.Fence())["outside"] == 0


def test_a_no_fly_polygon_the_route_crosses_is_one_line(survey):
    field, route = survey
    with pytest.raises(AirspaceError, match=r"^no-fly polygon 0: the route crosses it"):
        MakeAirspace(route, field, Scenario(), no_fly=[field.holes[0]])
    away = [(800.0, 800.0), (820.0, 800.0), (820.0, 820.0)]
    airspace = MakeAirspace(route, field, Scenario(), no_fly=[away])
    assert len(airspace.Fence().exclusions) == 1


def test_a_field_flights_figure_draws_the_field_its_hole_and_airspace():
    from eaplan_drake.field.readers import ReadField
    from eaplan_drake.field.source import FieldPath
    from eaplan_drake.loading import LoadNamedScenario
    from eaplan_drake.output.path_plot import SurveyShapes

    scenario = LoadNamedScenario("funen")
    shapes = SurveyShapes(scenario)
    field = ReadField(FieldPath("funen_field"))
    np.testing.assert_allclose(shapes["outline"], field.exterior)
    assert len(shapes["holes"]) == 1
    airspace = shapely.Polygon(shapes["airspace"])
    assert airspace.covers(shapely.Polygon(field.exterior).buffer(150.0))
    # the reference survey keeps its polygon, and has no declared airspace
    plain = SurveyShapes(Scenario())
    np.testing.assert_allclose(plain["outline"], Scenario().coverage.polygon)
    assert plain["holes"] == [] and plain["airspace"] is None


def test_a_given_margin_too_small_is_refused_before_the_flight():
    from eaplan_drake.errors import ScenarioError
    from eaplan_drake.loading import LoadNamedScenario
    from eaplan_drake.resolve import ResolveScenario

    scenario = LoadNamedScenario("funen")
    scenario.coverage.airspace_margin = 40.0
    with pytest.raises(ScenarioError, match=r"coverage\.airspace_margin: 40 m is too small"):
        ResolveScenario(scenario)
