"""A field from a file flown by the sequencer (field/source.py): the stages are the pre-flight
route, they continue themselves after every stage, a re-plan keeps the cell being flown, random
non-convex fields with holes are covered, and flights complete where the pre-flight plan says."""

import math

import numpy as np
import pytest

shapely = pytest.importorskip("shapely")
pytest.importorskip("pyproj")

from eaplan_drake.errors import ScenarioError  # noqa: E402
from eaplan_drake.field.plan import LineSpacing, LowestPlanEnergy  # noqa: E402
from eaplan_drake.field.random_fields import RandomField  # noqa: E402
from eaplan_drake.field.readers import FieldGeoJsonText, ReadField  # noqa: E402
from eaplan_drake.field.source import FieldCoverage, FieldPath  # noqa: E402
from eaplan_drake.flight.stages import APPROACH, ArcAngle  # noqa: E402
from eaplan_drake.loading import LoadNamedScenario  # noqa: E402
from eaplan_drake.params import Scenario  # noqa: E402
from eaplan_drake.resolve import ResolveScenario  # noqa: E402

LO, HI = -1000.0, 0.0
RANDOM_SEEDS = range(20)


def Source(field, c1=LO, start=(-150.0, -150.0), cls=FieldCoverage, **kwargs):
    """``cls`` (a field coverage) over ``field`` with the default scenario's coverage, from
    ``start`` [m], starting at c1 [m²] over [LO, HI] (``kwargs``: the class's own arguments)."""
    s = Scenario()
    return cls(
        field,
        s.coverage,
        start=start,
        airspeed=s.vehicle.airspeed,
        initial_c1=c1,
        k_e=s.guidance.k_e,
        c1_bounds=(LO, HI),
        **kwargs,
    )


@pytest.fixture(scope="module")
def funen():
    return Source(ReadField(FieldPath("funen_field")))


@pytest.fixture(scope="module")
def randoms():
    return {seed: Source(RandomField(seed, holes=seed % 3)) for seed in (0, 4, 8)}


def test_random_fields_are_seeded_non_convex_and_have_their_holes():
    for seed in RANDOM_SEEDS:
        field = RandomField(seed, holes=seed % 3)
        polygon = field.Polygon()
        assert polygon.is_valid and len(field.holes) == seed % 3
        outer = shapely.Polygon(field.exterior)
        assert outer.convex_hull.area >= 1.03 * outer.area
        np.testing.assert_array_equal(field.exterior, RandomField(seed, holes=seed % 3).exterior)
    assert not np.array_equal(RandomField(1).exterior, RandomField(2).exterior)


def test_at_the_lowest_plan_the_stages_are_the_pre_flight_route(funen, randoms):
    eps = Scenario().coverage.trigger_radius
    for source in (funen, *randoms.values()):
        route = source.plan.route
        assert route.spacing == pytest.approx(LineSpacing(Scenario().coverage, LO))
        stages = source.Stages(LO)
        assert stages[0].primitive == APPROACH
        survey = [s for s in stages if s.primitive != APPROACH]
        legs = [leg for leg in route.legs if leg.kind != "transit"]
        slivers = sum(g.length for g in legs if g.kind == "turn" and g.length < 4.0 * eps)
        assert sum(s.length for s in survey) == pytest.approx(
            sum(g.length for g in legs) - slivers, rel=1e-9
        )
        lines = [s for s in survey if s.primitive in (0, 2)]
        assert len(lines) == route.Count("line")
        for stage, leg in zip(lines, [g for g in legs if g.kind == "line"], strict=True):
            np.testing.assert_allclose(stage.entry, leg.start, atol=1e-9)
            np.testing.assert_allclose(stage.trigger, leg.end, atol=1e-9)


@pytest.mark.parametrize("c1", [LO, -400.0, HI])
def test_the_stages_after_every_stage_continue_the_same_plan(funen, randoms, c1):
    for source in (funen, *randoms.values()):
        stages = source.Stages(c1)
        for i, stage in enumerate(stages):
            assert source.StagesAfter(stage.index, stage.anchor, c1) == stages[i + 1 :], i
            assert stage.index == i


def test_consecutive_stages_join_arcs_are_at_most_half_circles_and_triggers_are_apart(
    funen, randoms
):
    eps = Scenario().coverage.trigger_radius
    for source in (funen, *randoms.values()):
        for c1 in (LO, HI):
            stages = source.Stages(c1)
            for a, b in zip(stages[:-1], stages[1:], strict=True):
                assert math.dist(a.trigger, b.trigger) >= 4.0 * eps
                assert math.dist(b.entry, a.trigger) < 4.0 * eps  # a sliver left out at most
                if b.is_circle:
                    arc = ArcAngle(b.path, b.entry, b.trigger)
                    assert arc <= math.pi + 1e-6
                    assert b.length == pytest.approx(b.path.radius * arc, rel=1e-6)


def test_a_replan_keeps_the_cell_being_flown_and_respaces_the_later_cells(funen):
    stages = funen.Stages(LO)
    place = [int(s.anchor[1]) if s.anchor[3] >= 0.0 else -1 for s in stages]  # −1: not a cell
    lines = [k for k, s in enumerate(stages) if place[k] == 0 and s.primitive in (0, 2)]
    i = lines[1]  # the second line of the first cell
    replanned = funen.Replan(stages, i, HI)
    end_of_cell = max(k for k in range(len(stages)) if place[k] == 0)
    assert replanned[: end_of_cell + 1] == stages[: end_of_cell + 1]
    later = [s for s in replanned[end_of_cell + 1 :] if s.primitive != APPROACH]
    assert later and all(s.c1 == HI for s in later)
    assert len(replanned) > len(stages)  # the later cells at x_d = 10 m have more lines
    # The remaining-time staircase grows with c1 from any stage.
    times = [funen.TimeAfter(i, stages[i].anchor, c1, 15.0) for c1 in np.linspace(LO, HI, 5)]
    assert np.all(np.diff(times) >= 0.0) and times[-1] > times[0]


@pytest.mark.parametrize("seed", RANDOM_SEEDS)
def test_random_fields_are_covered_and_the_route_stays_near_them(seed):
    """At c1 = 0 the swaths (x_d wide along the lines) cover ≥ 99 % of the field; lines stay
    within x_d/2 of it (they run over their swath band) and turns within (1 + √3) r_min + x_d
    (three arcs between lines closer than 2 r_min swing out that far beyond the line ends)."""
    field = RandomField(seed, holes=seed % 3)
    source = Source(field, HI)
    coverage = Scenario().coverage
    assert source.SwathCoverage(HI) >= 0.99
    for s in source.Stages(HI)[1:]:
        d = source.DistanceOutside(s, step=1.0)
        if s.primitive in (0, 2):
            assert d <= 0.5 * coverage.swath_spacing + 1e-6
        elif s.primitive != APPROACH:
            limit = (1.0 + math.sqrt(3.0)) * coverage.min_turning_radius + coverage.swath_spacing
            assert d <= limit + 1e-6


def test_a_field_scenario_resolves_and_bad_fields_are_one_line(tmp_path):
    resolved = ResolveScenario(LoadNamedScenario("funen"))
    assert isinstance(resolved.plan, FieldCoverage)
    s = LoadNamedScenario("funen")
    s.coverage.plan_file = "reference"
    with pytest.raises(ScenarioError, match=r"^coverage.field: give a field or a plan_file"):
        ResolveScenario(s)
    s = LoadNamedScenario("funen")
    s.coverage.field = str(tmp_path / "missing.geojson")
    with pytest.raises(ScenarioError, match=r"^coverage.field: .*missing.geojson"):
        ResolveScenario(s)
    bad = tmp_path / "line.geojson"
    bad.write_text('{"type": "LineString", "coordinates": [[10, 55], [10.01, 55]]}')
    s.coverage.field = str(bad)
    with pytest.raises(ScenarioError) as e:
        ResolveScenario(s)
    assert str(e.value).startswith("coverage.field: ") and "\n" not in str(e.value)
    s = LoadNamedScenario("funen")
    s.coverage.field_cells = "hexagons"
    with pytest.raises(ScenarioError, match=r"^coverage.field_cells: must be one of"):
        ResolveScenario(s)


def _LowestFlight(scenario, approach_stages: int):
    """The static lowest plan (:func:`~eaplan_drake.studies.worlds.LowestPlan`) flown at the
    fast rates in still air: (summary, the time [s] and SoC at the end of the approach, its
    first ``approach_stages`` stages)."""
    from eaplan_drake.rates import WithRates
    from eaplan_drake.simulation import Simulate
    from eaplan_drake.studies.worlds import LowestPlan

    scenario.wind.speed = 0.0
    result = Simulate(WithRates(LowestPlan(scenario), "fast"))
    t, stage, soc = result.times, result["stage"][:, 0], result["soc"][:, 0]
    k = int(np.argmax(stage > approach_stages - 0.5))
    return result.summary, t[k], soc[k]


@pytest.mark.slow
@pytest.mark.parametrize("which", ["funen", 0, 4, 8])
def test_the_pre_flight_plan_predicts_the_flown_lowest_plan(tmp_path, which, randoms):
    """The pre-flight prediction (eaplan-drake plan) of the survey's time and SoC against the
    same plan flown with the whole closed loop: within 2 % and 0.01."""
    scenario = LoadNamedScenario("funen")
    if which != "funen":
        field = RandomField(which, holes=which % 3)
        path = tmp_path / "field.geojson"
        path.write_text(FieldGeoJsonText(field))
        scenario.coverage.field = str(path)
    resolved = ResolveScenario(scenario)
    predicted = LowestPlanEnergy(resolved.plan.plan, scenario)
    stages = resolved.plan.Stages(LO)
    approach = next(i for i, s in enumerate(stages) if s.primitive != APPROACH)
    summary, t0, soc0 = _LowestFlight(scenario, approach)
    assert summary["completed"]
    flown = summary["duration"] - t0
    assert flown == pytest.approx(predicted["time"], rel=0.02)
    drop = predicted["initial_soc"] - predicted["final_soc"]
    assert soc0 - summary["final_soc"] == pytest.approx(drop, abs=0.01)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 4, 8])
def test_a_random_field_is_flown_to_the_end_at_c1_0_in_still_air(randoms, seed):
    from eaplan_drake.rates import WithRates
    from eaplan_drake.studies.tracking import FlyTracking

    s = WithRates(Scenario(), "fast")
    s.wind.speed = 0.0
    source = randoms[seed]
    predicted = source.CoverageTime(HI, s.vehicle.airspeed)
    flight = FlyTracking(s, source, HI, t_max=1.5 * predicted + 120.0)
    assert flight["complete"]
    assert flight["t_end"] == pytest.approx(predicted, rel=0.05)


@pytest.mark.slow
def test_the_shipped_field_is_flown_with_the_default_planner(tmp_path):
    """``simulate funen`` at the fast rates: the mpc policy completes the non-convex field with
    its hole above the reserve, at a higher quality than the lowest plan's 0."""
    from eaplan_drake.rates import WithRates
    from eaplan_drake.simulation import Simulate

    scenario = LoadNamedScenario("funen")
    assert scenario.planner.policy == "mpc"
    log = Simulate(WithRates(scenario, "fast"))
    s = log.summary
    assert s["completed"] and s["coverage_remaining"] == 0.0
    assert s["final_margin"] > 0.0 and s["quality"] > 0.05
    assert np.all(np.diff(log["stage"][:, 0]) >= 0.0)  # the stages follow each other
    # As flown: the stages replayed from the log are the plan's at the c1 each cell was flown
    # with, and the missions written from them hold every line flown, in the flown order.
    from eaplan_drake.field.readers import ReadField as Read
    from eaplan_drake.field.source import MakeFieldPlanSource
    from eaplan_drake.flight.coverage import FlownStages
    from eaplan_drake.output.save import SaveFlownMissions

    c1 = log["flown_path_parameter"][:, 0]
    assert c1.min() < c1.max()  # the planner re-spaced some cells
    plan = MakeFieldPlanSource(scenario, float(c1[0]))
    stages = FlownStages(plan, log["stage"][:, 0], c1)
    assert [st.index for st in stages] == sorted(set(log["stage"][:, 0].astype(int)))
    route = plan.FlownRoute(stages)
    flown = [plan.LegOf(st) for st in stages]
    lines = [leg for leg in route.legs if leg.kind == "line"]
    assert lines == [g for g in dict.fromkeys(flown) if g is not None and g.kind == "line"]
    for st, leg in zip(stages, flown, strict=True):  # each line stage flies its route line
        if leg is not None and leg.kind == "line":
            assert st.entry == pytest.approx(leg.start, abs=1e-9)
            assert st.trigger == pytest.approx(leg.end, abs=1e-9)
    written = SaveFlownMissions(log, scenario, tmp_path)
    assert sorted(p.name for p in written) == ["flown.plan", "flown.waypoints", "flown.xml"]
    # the geofence is the airspace of the route flown: it holds that route, read back
    import shapely

    from eaplan_drake.field.airspace import RoutePoints

    back = Read(str(tmp_path / "flown.plan"), origin=(plan.field.frame.lon, plan.field.frame.lat))
    fence = shapely.Polygon(back.exterior)
    assert fence.covers(shapely.Polygon(plan.field.exterior).buffer(150.0))
    inside = shapely.covers(fence, shapely.points(RoutePoints(route)))
    assert np.count_nonzero(~inside) == 0
    with pytest.raises(ValueError, match="goes from stage"):
        FlownStages(plan, [stages[0].index, stages[0].index + 5, 1], c1[:3])


def test_a_multipolygon_field_is_flown_by_the_polygon_the_scenario_names(tmp_path):
    import json
    from pathlib import Path

    from eaplan_drake.resolve import ResolveScenario

    funen = json.loads(Path(FieldPath("funen_field")).read_text())
    ring = funen["features"][0]["geometry"]["coordinates"]
    shifted = [[[lon + 0.02, lat] for lon, lat in r] for r in ring]
    path = tmp_path / "two.geojson"
    path.write_text(json.dumps({"type": "MultiPolygon", "coordinates": [ring, shifted]}))
    with pytest.raises((ScenarioError, ValueError), match=r"2 polygons .*coverage\.field_polygon"):
        ResolveScenario(LoadNamedScenario("funen", [f"coverage: {{field: '{path}'}}"]))
    for index in (0, 1):
        layer = f"coverage: {{field: '{path}', field_polygon: {index}}}"
        resolved = ResolveScenario(LoadNamedScenario("funen", [layer]))
        assert resolved.plan.field.area == pytest.approx(
            ResolveScenario(LoadNamedScenario("funen")).plan.field.area, rel=1e-3
        )
    with pytest.raises(ScenarioError, match=r"coverage\.field_polygon: must be an integer in \[-1"):
        LoadNamedScenario("funen", ["coverage: {field_polygon: -2}"])


def test_a_field_too_large_to_plan_is_refused_from_its_outline(tmp_path, monkeypatch):
    """A 50 km field is refused from its outline and spacing before any stage is built."""
    import json

    from eaplan_drake.field import source
    from eaplan_drake.resolve import ResolveScenario

    lon, lat = 10.0, 55.3
    square = [
        [lon, lat],
        [lon + 0.78, lat],
        [lon + 0.78, lat + 0.45],
        [lon, lat + 0.45],
        [lon, lat],
    ]
    path = tmp_path / "big.geojson"
    path.write_text(json.dumps({"type": "Polygon", "coordinates": [square]}))

    def Built(*args, **kwargs):
        raise AssertionError("the plan's stages were built before the refusal")

    monkeypatch.setattr(source, "FieldCoverage", Built)
    with pytest.raises(
        ScenarioError, match=r"coverage\.field: the field is \d+ m across .* at most 2000"
    ):
        ResolveScenario(LoadNamedScenario("funen", [f"coverage: {{field: '{path}'}}"]))
