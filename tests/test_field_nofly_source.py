"""A simulated flight around no-fly holes (field/nofly_source.py): with
``coverage.no_fly_holes: true`` the stages at the lowest and highest c1, and after a re-plan to
another c1 mid-flight, keep the clearance from the hole; they continue themselves after every
stage; a short flight in wind has no sample in the hole; no way around it is one line naming
``coverage.no_fly_holes``."""

import numpy as np
import pytest

shapely = pytest.importorskip("shapely")
pytest.importorskip("pyproj")

from test_field_missions import FRAME, Field  # noqa: E402
from test_field_source import HI, LO, Source  # noqa: E402

from eaplan_drake.errors import ScenarioError  # noqa: E402
from eaplan_drake.field.nofly import CLEARANCE  # noqa: E402
from eaplan_drake.field.readers import FieldFromLocal, FieldGeoJsonText  # noqa: E402
from eaplan_drake.field.source import AvoidingFieldCoverage  # noqa: E402
from eaplan_drake.flight.stages import APPROACH, StagePoints  # noqa: E402


@pytest.fixture(scope="module")
def avoiding():
    field = Field()
    return field, Source(field, cls=AvoidingFieldCoverage)


def Closest(stages, field) -> float:
    """The least distance [m] of the stages' paths (sampled every 1 m) from the field's holes."""
    points = np.concatenate(
        [np.asarray(shapely.LineString(StagePoints(s, 1.0)).segmentize(1.0).coords) for s in stages]
    )
    holes = [shapely.Polygon(h) for h in field.holes]
    return min(float(np.min(shapely.distance(h, shapely.points(points)))) for h in holes)


def test_the_stages_at_the_lowest_and_highest_c1_keep_out_of_the_buffered_hole(avoiding):
    field, source = avoiding
    for c1 in (LO, HI):
        stages = source.Stages(c1)
        assert Closest(stages, field) >= CLEARANCE - 0.01
        for i, stage in enumerate(stages):  # the anchors continue the same plan
            assert source.StagesAfter(stage.index, stage.anchor, c1) == stages[i + 1 :], i
    # without the polygons the same field's stages overfly the hole
    plain = Source(field)
    assert Closest(plain.Stages(HI), field) == 0.0
    # at the lowest c1 the survey lines are the pre-flight route's (which keeps out of it)
    lines = [(s.entry, s.trigger) for s in source.Stages(LO) if s.primitive in (0, 2)]
    legs = [(g.start, g.end) for g in source.plan.route.legs if g.kind == "line"]
    np.testing.assert_allclose(np.array(lines)[1:], np.array(legs)[1:], atol=1e-9)


def test_a_replan_to_another_c1_mid_flight_still_keeps_out(avoiding):
    field, source = avoiding
    stages = source.Stages(LO)
    places = len(source.cell_order)
    cells = [int(s.anchor[1]) if s.anchor[3] >= 0 else -1 for s in stages]  # −1: no cell
    before_last = max(k for k, place in enumerate(cells) if place == places - 2)
    for i in range(0, len(stages), 3):
        for c1 in (HI, -600.0):
            replanned = source.Replan(stages, i, c1)
            assert replanned[: i + 1] == stages[: i + 1]
            assert Closest(replanned[i:], field) >= CLEARANCE - 0.01, (i, c1)
            if i <= before_last:  # the later cells at c1
                assert replanned[-1].c1 == c1 and replanned[-1].primitive != APPROACH


def SmallField():
    outer = [(0, 0), (300, 0), (300, 250), (0, 250)]
    return FieldFromLocal(outer, [[(110, 90), (190, 90), (190, 160), (110, 160)]], FRAME)


def test_a_flight_in_wind_around_a_hole_completes_without_a_sample_in_it(tmp_path):
    from eaplan_drake.field.airspace import RoutePoints
    from eaplan_drake.flight.coverage import FlownStages
    from eaplan_drake.loading import LoadNamedScenario
    from eaplan_drake.rates import WithRates
    from eaplan_drake.resolve import ResolveScenario
    from eaplan_drake.simulation import Simulate
    from eaplan_drake.studies.worlds import LowestPlan

    field = SmallField()
    path = tmp_path / "small.geojson"
    path.write_text(FieldGeoJsonText(field))
    scenario = LoadNamedScenario("funen")
    scenario.coverage.field = str(path)
    scenario.coverage.no_fly_holes = True
    scenario.wind.speed, scenario.wind.direction_deg = 10.0, 45.0
    scenario = LowestPlan(scenario)
    plan = ResolveScenario(scenario).plan
    assert isinstance(plan, AvoidingFieldCoverage)
    log = Simulate(WithRates(scenario, "fast"))
    assert log.summary["completed"]
    points = shapely.points(log["position"])
    hole = shapely.Polygon(field.holes[0])
    assert np.count_nonzero(shapely.contains(hole, points)) == 0
    # the route as flown (the missions written after the flight) keeps out of it too
    stages = FlownStages(plan, log["stage"][:, 0], log["flown_path_parameter"][:, 0])
    route = plan.FlownRoute(stages)
    assert route.Count("line") == sum(1 for s in stages if s.primitive in (0, 2))
    assert hole.distance(shapely.LineString(RoutePoints(route))) >= CLEARANCE - 0.01


def test_no_way_around_the_hole_is_one_line_naming_the_key(tmp_path):
    from eaplan_drake.loading import LoadNamedScenario
    from eaplan_drake.resolve import ResolveScenario

    path = tmp_path / "small.geojson"
    path.write_text(FieldGeoJsonText(SmallField()))
    scenario = LoadNamedScenario("funen")
    scenario.coverage.field = str(path)
    scenario.coverage.no_fly_holes = True
    scenario.vehicle.initial_position = [150.0, 125.0]  # in the hole: no approach leaves it
    with pytest.raises(ScenarioError, match=r"coverage\.no_fly_holes: no approach") as e:
        ResolveScenario(scenario)
    assert "\n" not in str(e.value)


def test_every_c1_of_the_planners_grid_is_checked_before_the_flight():
    """The grid policies choose c1 on the planner's grid: each of its values is checked before
    the flight (strictly: a cell no transit reaches there is refused, never left out)."""

    class Recording(AvoidingFieldCoverage):
        def _Chain(self, *args, strict=False, **kwargs):
            if strict:
                checked.append(args[4])
            return super()._Chain(*args, strict=strict, **kwargs)

    checked = []
    grid = np.linspace(LO, HI, 5)
    Source(Field(), -300.0, cls=Recording, checked_c1=grid)
    assert sorted(set(checked)) == sorted({*grid.tolist(), -300.0})


def test_an_off_grid_c1_without_an_approach_flies_the_first_cell_at_the_checked_c1_below():
    """A policy may choose c1 off the planner's grid (the paper's): where no approach keeps out
    at it, the plan at that c1 is still built, its first cell at the largest checked c1 below it
    and the later cells at c1, and it continues itself after every stage."""
    from eaplan_drake.field.airspace import AirspaceError

    off_grid = -430.0

    class NoApproachAt(AvoidingFieldCoverage):  # no approach keeps out at off_grid
        def _Approach(self, c1):
            if c1 == off_grid:
                raise AirspaceError("coverage.no_fly_holes: no approach (injected)")
            return super()._Approach(c1)

    field = Field()
    grid = np.linspace(LO, HI, 5)  # -1000, -750, -500, -250, 0
    source = Source(field, cls=NoApproachAt, checked_c1=grid)
    with pytest.raises(AirspaceError):  # the injected failure is real
        source._Approach(off_grid)
    stages = source.Stages(off_grid)
    assert stages[0].primitive == APPROACH and stages[0].c1 == -500.0
    survey = [s for s in stages if s.primitive != APPROACH]
    assert survey[-1].c1 == off_grid  # the later cells at the chosen c1
    assert Closest(stages, field) >= CLEARANCE - 0.01
    for i, stage in enumerate(stages):
        assert source.StagesAfter(stage.index, stage.anchor, off_grid) == stages[i + 1 :], i
    assert source.SurveyLength(off_grid) > 0.0
