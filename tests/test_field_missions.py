"""Missions out, read back: the QGroundControl plan (json and our field reader), the WPL 110 file
(pymavlink's MAVWPLoader) and the Paparazzi flight plan (xml.etree and the structure of
Paparazzi's flight_plan.dtd; the DTD itself through lxml with ``PAPARAZZI_HOME``); geometry
within 1 m; home, takeoff, return or landing, each format's altitude frame, and the route inside
each format's own fence."""

import json
import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

pytest.importorskip("shapely")
pyproj = pytest.importorskip("pyproj")

from eaplan_drake.field.decompose import ChooseSweepDirection  # noqa: E402
from eaplan_drake.field.geodesy import LocalFrame  # noqa: E402
from eaplan_drake.field.missions import (  # noqa: E402
    APPROACH_DISTANCE,
    MAV_CMD_DO_LAND_START,
    MAV_CMD_NAV_LAND,
    MAV_CMD_NAV_LOITER_TURNS,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_TAKEOFF,
    MAV_CMD_NAV_WAYPOINT,
    MissionEnds,
    MissionItems,
    WriteMissions,
)
from eaplan_drake.field.readers import FieldFromLocal, ReadField  # noqa: E402
from eaplan_drake.field.route import MakeRoute  # noqa: E402

FRAME = LocalFrame(10.3250, 55.4720)
ALTITUDE = 60.0
GROUND = 470.0
HOME = (-80.0, -50.0)  # the launch point, outside the field
LANDING = MissionEnds(HOME, GROUND, "land", (0.0, -1.0))


def Field():
    return FieldFromLocal(
        [(0, 0), (500, 0), (500, 400), (300, 400), (300, 200), (200, 200), (200, 400), (0, 400)],
        [[(60, 60), (60, 140), (140, 140), (140, 60)]],
        FRAME,
    )


@pytest.fixture(scope="module")
def survey(tmp_path_factory):
    field = Field()
    choice = ChooseSweepDirection(field.Polygon(), 10.0)
    route = MakeRoute(choice.decomposition, 10.0, 62.45)
    out = tmp_path_factory.mktemp("missions")
    paths = WriteMissions(out, route, field, altitude=ALTITUDE, cruise_speed=15.0)
    return field, route, paths


@pytest.fixture(scope="module")
def landing(survey, tmp_path_factory):
    """The same survey from a launch point outside the field at 470 m AMSL, ending in a
    landing."""
    field, route, _ = survey
    out = tmp_path_factory.mktemp("landing")
    paths = WriteMissions(out, route, field, altitude=ALTITUDE, cruise_speed=15.0, ends=LANDING)
    return field, route, paths


def Expected(route, field, ends=None):
    """(command, local point) of every item with a position (a return to launch has none)."""
    items = MissionItems(route, field, altitude=ALTITUDE, ends=ends or MissionEnds())
    return [
        (i.command, np.array(i.local)) for i in items if i.command != MAV_CMD_NAV_RETURN_TO_LAUNCH
    ]


def Distances(frame, lonlat, local):
    return np.linalg.norm(frame.ToLocal(lonlat) - np.asarray(local), axis=1)


def test_the_qgc_plan_reads_back(survey):
    field, route, paths = survey
    plan = json.loads(paths["qgc_plan"].read_text())
    assert plan["fileType"] == "Plan" and plan["version"] == 1
    items = plan["mission"]["items"]
    expected = Expected(route, field)[1:]
    assert items[0]["command"] == MAV_CMD_NAV_TAKEOFF
    assert items[-1]["command"] == MAV_CMD_NAV_RETURN_TO_LAUNCH
    items = items[:-1]
    assert [it["command"] for it in items] == [c for c, _ in expected]
    lonlat = [[it["params"][5], it["params"][4]] for it in items]
    assert Distances(FRAME, lonlat, [p for _, p in expected]).max() < 1.0
    turns = [leg for leg in route.legs if leg.kind == "turn"]
    loiters = [it for it in items if it["command"] == MAV_CMD_NAV_LOITER_TURNS]
    assert len(loiters) == len(turns)
    for it, leg in zip(loiters, turns, strict=True):
        assert abs(it["params"][2]) == pytest.approx(leg.radius, abs=1e-3)
        assert (it["params"][2] < 0) == leg.ccw
        assert it["params"][0] == pytest.approx(leg.angle / (2 * math.pi), abs=1e-6)
    assert all(it["params"][6] == ALTITUDE for it in items)
    # the default geofence is the field, and the hole no exclusion (it may be overflown)
    back = ReadField(paths["qgc_plan"], origin=(FRAME.lon, FRAME.lat))
    assert len(back.holes) == 0
    assert np.abs(back.exterior - field.exterior).max() < 1.0


def test_the_wpl_file_reads_back_with_pymavlink(survey):
    mavwp = pytest.importorskip("pymavlink.mavwp")
    field, route, paths = survey
    raw = paths["wpl"].read_bytes()
    assert raw.startswith(b"QGC WPL 110\n") and b"\r" not in raw  # LF line ends
    loader = mavwp.MAVWPLoader()
    expected = Expected(route, field)
    assert loader.load(str(paths["wpl"])) == len(expected) + 1
    wps = [loader.wp(i) for i in range(loader.count())]
    assert wps[-1].command == MAV_CMD_NAV_RETURN_TO_LAUNCH
    wps = wps[:-1]
    assert [w.command for w in wps] == [c for c, _ in expected]
    assert wps[0].current == 1 and wps[0].frame == 0
    assert all(w.frame == 3 and w.z == pytest.approx(ALTITUDE) for w in wps[1:])
    # pymavlink keeps MISSION_ITEM's float32 lat/lon: 0.5 m at worst here
    lonlat = [[w.y, w.x] for w in wps]
    assert Distances(FRAME, lonlat, [p for _, p in expected]).max() < 1.0
    radii = [abs(w.param3) for w in wps if w.command == MAV_CMD_NAV_LOITER_TURNS]
    assert min(radii) >= 62.45 - 1e-3


# The structure of Paparazzi's conf/flight_plans/flight_plan.dtd that the export uses (the DTD
# itself is GPL and not shipped): required attributes, and the children allowed, in order.
REQUIRED = {
    "flight_plan": {"name", "lat0", "lon0", "max_dist_from_home", "ground_alt", "security_height",
                    "alt"},
    "waypoint": {"name"},
    "sector": {"name"},
    "corner": {"name"},
    "block": {"name"},
    "go": {"wp"},
    "circle": {"wp", "radius"},
    "deroute": {"block"},
    "attitude": {"roll"},
    "exception": {"cond", "deroute"},
}  # fmt: skip
FLIGHT_PLAN_ORDER = ["header", "waypoints", "sectors", "variables", "modules", "includes",
                     "exceptions", "blocks"]  # fmt: skip
BLOCK_CHILDREN = {"exception", "while", "heading", "attitude", "manual", "go", "xyz", "set",
                  "call", "call_once", "circle", "deroute", "stay", "follow", "for", "return",
                  "eight", "oval", "home", "path"}  # fmt: skip


def test_the_paparazzi_flight_plan_is_well_formed_and_follows_the_dtd(survey):
    field, route, paths = survey
    text = paths["paparazzi"].read_text()
    assert '<!DOCTYPE flight_plan SYSTEM "flight_plan.dtd">' in text
    root = ET.fromstring(text)
    assert root.tag == "flight_plan"
    for el in root.iter():
        assert REQUIRED.get(el.tag, set()) <= set(el.attrib), el.tag
    order = [c.tag for c in root]
    assert order == sorted(order, key=FLIGHT_PLAN_ORDER.index) and "blocks" in order
    names = [w.get("name") for w in root.find("waypoints")]
    assert len(names) == len(set(names))
    for el in root.iter():
        for attr in ("wp", "from"):
            if el.tag in ("go", "circle") and el.get(attr):
                assert el.get(attr) in names
    (sector,) = root.find("sectors")
    corners = [c.get("name") for c in sector]
    assert len(corners) >= 3 and set(corners) <= set(names)
    blocks = {b.get("name"): b for b in root.find("blocks")}
    assert list(blocks) == ["Holding", "Takeoff", "Survey", "Standby"]
    assert list(blocks["Survey"])[-1].get("block") == "Standby"  # the return: circle home
    for b in blocks.values():
        assert {c.tag for c in b} <= BLOCK_CHILDREN
        for c in b:
            if c.tag == "deroute":
                assert c.get("block") in blocks
    # geometry: lines' ends and the turns' centres and radii
    frame = LocalFrame(float(root.get("lon0")), float(root.get("lat0")))
    wp = {w.get("name"): [float(w.get("lon")), float(w.get("lat"))] for w in root.find("waypoints")}
    stages = list(blocks["Survey"])
    goes = [s for s in stages if s.tag == "go" and s.get("from")]
    lines = [leg for leg in route.legs if leg.kind == "line"]
    assert len(goes) == len(lines)
    for g, leg in zip(goes, lines, strict=True):
        ends = [wp[g.get("from")], wp[g.get("wp")]]
        assert Distances(frame, ends, [leg.start, leg.end]).max() < 1.0
    circles = [s for s in stages if s.tag == "circle"]
    turns = [leg for leg in route.legs if leg.kind == "turn"]
    for c, leg in zip(circles, turns, strict=True):
        assert Distances(frame, [wp[c.get("wp")]], [leg.center]).max() < 1.0
        assert float(c.get("radius")) == pytest.approx(
            -leg.radius if leg.ccw else leg.radius, abs=1e-3
        )
    corner_points = [wp[n] for n in corners]
    assert Distances(frame, corner_points, field.exterior).max() < 1.0


def test_a_bad_altitude_or_end_is_one_line(survey):
    field, route, _ = survey
    with pytest.raises(ValueError, match=r"altitude: must be in \(0, 10000\) \[m above home\]"):
        MissionItems(route, field, altitude=-5.0)
    with pytest.raises(ValueError, match=r"end: must be one of rtl, land, got 'loiter'"):
        MissionItems(route, field, altitude=50.0, ends=MissionEnds(end="loiter"))
    assert MAV_CMD_NAV_WAYPOINT == 16


def test_the_wpl_landing_starts_at_home_and_lands_there_in_its_own_frames(landing):
    mavwp = pytest.importorskip("pymavlink.mavwp")
    field, route, paths = landing
    loader = mavwp.MAVWPLoader()
    loader.load(str(paths["wpl"]))
    wps = [loader.wp(i) for i in range(loader.count())]
    home = [[wps[0].y, wps[0].x]]
    assert Distances(FRAME, home, [HOME]).max() < 1.0
    assert wps[0].frame == 0 and wps[0].z == pytest.approx(GROUND)  # home: AMSL
    assert wps[1].command == MAV_CMD_NAV_TAKEOFF and wps[1].frame == 3
    assert Distances(FRAME, [[wps[1].y, wps[1].x]], [HOME]).max() < 1.0
    assert wps[1].z == pytest.approx(ALTITUDE)  # above home
    assert [w.command for w in wps[-3:]] == [
        MAV_CMD_DO_LAND_START,
        MAV_CMD_NAV_WAYPOINT,
        MAV_CMD_NAV_LAND,
    ]
    fix, land = wps[-2], wps[-1]
    assert land.frame == 3 and land.z == 0.0
    assert Distances(FRAME, [[land.y, land.x]], [HOME]).max() < 1.0
    # the approach fix is 250 m from home along the stated approach (south): the landing flies
    # north, into a wind blowing towards the south
    approach = FRAME.ToLocal([[fix.y, fix.x]])[0]
    np.testing.assert_allclose(approach, np.add(HOME, (0.0, -APPROACH_DISTANCE)), atol=1.0)
    survey_items = [w for w in wps[2:-3]]
    expected = Expected(route, field, LANDING)[2:-3]
    assert [w.command for w in survey_items] == [c for c, _ in expected]
    lonlat = [[w.y, w.x] for w in survey_items]
    assert Distances(FRAME, lonlat, [p for _, p in expected]).max() < 1.0


def test_the_qgc_plan_home_is_amsl_and_its_items_relative(landing):
    field, route, paths = landing
    plan = json.loads(paths["qgc_plan"].read_text())
    mission = plan["mission"]
    lat, lon, alt = mission["plannedHomePosition"]
    assert Distances(FRAME, [[lon, lat]], [HOME]).max() < 1.0 and alt == GROUND
    assert mission["globalPlanAltitudeMode"] == 1  # relative to home
    items = mission["items"]
    assert all(it["frame"] == 3 and it["AltitudeMode"] == 1 for it in items)
    assert items[0]["command"] == MAV_CMD_NAV_TAKEOFF and items[0]["Altitude"] == ALTITUDE
    assert [it["command"] for it in items[-3:]] == [
        MAV_CMD_DO_LAND_START,
        MAV_CMD_NAV_WAYPOINT,
        MAV_CMD_NAV_LAND,
    ]
    assert items[-1]["Altitude"] == 0.0


def test_the_paparazzi_plan_is_amsl_from_home_to_the_landing(landing):
    field, route, paths = landing
    root = ET.fromstring(paths["paparazzi"].read_text())
    assert float(root.get("ground_alt")) == GROUND
    assert float(root.get("alt")) == GROUND + ALTITUDE  # Paparazzi's alt is AMSL
    wp = {w.get("name"): w for w in root.find("waypoints")}
    frame = LocalFrame(float(root.get("lon0")), float(root.get("lat0")))

    def At(name):
        w = wp[name]
        return frame.ToLocal([[float(w.get("lon")), float(w.get("lat"))]])[0]

    np.testing.assert_allclose(At("HOME"), HOME, atol=1.0)
    np.testing.assert_allclose(At("TD"), HOME, atol=1.0)
    assert float(wp["TD"].get("alt")) == GROUND
    blocks = {b.get("name"): b for b in root.find("blocks")}
    assert list(blocks) == ["Holding", "Takeoff", "Survey", "Standby", "Land"]
    (go,) = [s for s in blocks["Takeoff"] if s.tag == "go"]
    assert go.get("from") == "HOME"
    assert list(blocks["Survey"])[-1].get("block") == "Land"
    land = [(s.tag, s.get("wp")) for s in blocks["Land"] if s.tag == "go"]
    assert land == [("go", "AF"), ("go", "TD")]


def test_line_ends_are_lf_in_every_format(survey, landing):
    for _, _, paths in (survey, landing):
        for path in paths.values():
            assert b"\r" not in path.read_bytes(), path.name


@pytest.fixture(scope="module")
def fenced(survey, tmp_path_factory):
    """The landing survey with its declared airspace as the geofence."""
    from eaplan_drake.field.airspace import MakeAirspace
    from eaplan_drake.params import Scenario

    field, route, _ = survey
    scenario = Scenario()
    scenario.wind.speed = 10.0
    fix = LANDING.ApproachFix(route)
    airspace = MakeAirspace(route, field, scenario, home=HOME, extra_points=[fix])
    out = tmp_path_factory.mktemp("fenced")
    paths = WriteMissions(
        out,
        route,
        field,
        altitude=ALTITUDE,
        cruise_speed=15.0,
        ends=LANDING,
        fence=airspace.Fence(),
    )
    return field, route, paths, airspace


def _Flown(route, wps):
    """Points [m] of what an autopilot flies from the exported items (item 0 home, lat/lon
    [deg]): straight between positions, and each loiter's circle."""
    from eaplan_drake.field.airspace import RoutePoints
    from eaplan_drake.field.plan import WithHomeLegs

    points = [FRAME.ToLocal([[lon, lat]])[0] for _, lat, lon, _ in wps]
    out = [RoutePoints(WithHomeLegs(route, HOME))]
    for a, b in zip(points[:-1], points[1:], strict=True):
        t = np.linspace(0.0, 1.0, 50)[:, None]
        out.append((1.0 - t) * a + t * b)
    for (command, _, _, radius), c in zip(wps, points, strict=True):
        if command == MAV_CMD_NAV_LOITER_TURNS:
            a = np.linspace(0.0, 2.0 * np.pi, 90)
            out.append(c + abs(radius) * np.column_stack([np.cos(a), np.sin(a)]))
    return np.concatenate(out)


def test_every_format_keeps_its_route_inside_its_own_fence(fenced):
    """The fence read back from each file holds the route, the legs home and every item."""
    import shapely

    mavwp = pytest.importorskip("pymavlink.mavwp")
    field, route, paths, airspace = fenced
    plan = json.loads(paths["qgc_plan"].read_text())
    (inclusion,) = [p for p in plan["geoFence"]["polygons"] if p["inclusion"]]
    assert [p for p in plan["geoFence"]["polygons"] if not p["inclusion"]] == []
    fence = shapely.Polygon(FRAME.ToLocal([[lon, lat] for lat, lon in inclusion["polygon"]]))
    assert fence.symmetric_difference(airspace.polygon).area < 1e-4 * fence.area
    loader = mavwp.MAVWPLoader()
    loader.load(str(paths["wpl"]))
    wps = [loader.wp(i) for i in range(loader.count())]
    wpl = [(w.command, w.x, w.y, w.param3) for w in wps]
    qgc = [(it["command"], *it["params"][4:6], it["params"][2]) for it in plan["mission"]["items"]]
    for items in (wpl, qgc):
        flown = _Flown(route, [i for i in items if i[0] != MAV_CMD_NAV_RETURN_TO_LAUNCH])
        out = ~shapely.covers(fence, shapely.points(flown))
        assert np.count_nonzero(out) == 0 and len(flown) > 5000
    root = ET.fromstring(paths["paparazzi"].read_text())
    (sector,) = root.find("sectors")
    wp = {w.get("name"): (float(w.get("lon")), float(w.get("lat"))) for w in root.find("waypoints")}
    sector_polygon = shapely.Polygon(FRAME.ToLocal([wp[c.get("name")] for c in sector]))
    assert root.get("geofence_sector") == sector.get("name") == "Airspace"
    assert sector_polygon.symmetric_difference(fence).area < 1e-4 * fence.area
    flown = FRAME.ToLocal([wp[n] for n in wp if not n.startswith("A")])
    assert np.count_nonzero(~shapely.covers(sector_polygon, shapely.points(flown))) == 0


def test_the_paparazzi_plans_validate_against_paparazzis_own_dtd(survey, landing, fenced):
    """With a Paparazzi checkout (``PAPARAZZI_HOME``, as Paparazzi's own tools set it), every
    flight plan validates against its ``conf/flight_plans/flight_plan.dtd`` (GPL, not shipped)."""
    import os
    from pathlib import Path

    etree = pytest.importorskip("lxml.etree")
    home = os.environ.get("PAPARAZZI_HOME", "")
    dtd_path = Path(home) / "conf" / "flight_plans" / "flight_plan.dtd"
    if not home or not dtd_path.is_file():
        pytest.skip("PAPARAZZI_HOME does not hold conf/flight_plans/flight_plan.dtd")
    dtd = etree.DTD(str(dtd_path))
    for case in (survey, landing, fenced):
        doc = etree.parse(str(case[2]["paparazzi"]))
        assert dtd.validate(doc), dtd.error_log.filter_from_errors()
