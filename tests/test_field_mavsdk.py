"""Missions out, read back by MAVSDK (the native ``mavsdk`` package, 4.x): the QGroundControl
plan through ``MissionRaw.import_qgroundcontrol_mission`` and the WPL 110 file through
``MissionRaw.import_mission_planner_mission``; every item's command, frame, altitude and position
(within 1 m of the route's own item) and the geofence MAVSDK reads (the route inside it).

MAVSDK needs a system to give a ``MissionRaw``: the test makes one in process, on a ``raw://``
connection (bytes passed by hand, no network endpoint, no server process) fed one heartbeat that
pymavlink encodes. Skipped when mavsdk (≥ 4) or pymavlink is not installed."""

import time

import numpy as np
import pytest

pytest.importorskip("shapely")
pytest.importorskip("pyproj")
mavsdk = pytest.importorskip("mavsdk", reason="mavsdk (the native binding, >= 4) not installed")
try:
    from mavsdk.plugins.mission_raw import MissionRaw
except ImportError:  # mavsdk < 4: the gRPC package, another API
    pytest.skip("mavsdk >= 4 (the native binding) is needed", allow_module_level=True)
mavlink = pytest.importorskip("pymavlink.dialects.v20.common", reason="pymavlink not installed")

from test_field_missions import ALTITUDE, FRAME, GROUND, HOME, LANDING, Field  # noqa: E402

from eaplan_drake.field.airspace import MakeAirspace, PointsOutside, RoutePoints  # noqa: E402
from eaplan_drake.field.decompose import ChooseSweepDirection  # noqa: E402
from eaplan_drake.field.missions import (  # noqa: E402
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    Fence,
    MissionItems,
    WriteMissions,
)
from eaplan_drake.field.plan import WithHomeLegs  # noqa: E402
from eaplan_drake.field.route import MakeRoute  # noqa: E402
from eaplan_drake.params import Scenario  # noqa: E402

FENCE_VERTEX_INCLUSION = 5001  # MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
FENCE_VERTEX_EXCLUSION = 5002  # MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION
MISSION_TYPE_FENCE = 1


@pytest.fixture(scope="module")
def mission_raw():
    """MAVSDK's MissionRaw plugin on an in-process ``raw://`` link (no socket)."""
    sdk = mavsdk.Mavsdk(
        mavsdk.Configuration.create_with_component_type(mavsdk.ComponentType.GROUND_STATION)
    )
    try:
        assert sdk.add_any_connection("raw://") == mavsdk.ConnectionResult.SUCCESS
        sdk.subscribe_raw_bytes_to_be_sent(lambda data: None)  # what MAVSDK sends goes nowhere
        link = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
        heartbeat = link.heartbeat_encode(
            mavlink.MAV_TYPE_FIXED_WING, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 0
        ).pack(link)
        for _ in range(100):  # the system appears once MAVSDK's thread has read the heartbeat
            sdk.pass_received_raw_bytes(heartbeat)
            if sdk.system_count():
                break
            time.sleep(0.02)
        systems = sdk.get_systems()
        assert systems, "MAVSDK saw no system from the heartbeat"
        yield MissionRaw(systems[0])
    finally:
        sdk.destroy()


@pytest.fixture(scope="module")
def survey(tmp_path_factory):
    field = Field()  # the field, frame, home and landing of the other missions' tests
    route = MakeRoute(ChooseSweepDirection(field.Polygon(), 10.0).decomposition, 10.0, 62.45)
    scenario = Scenario()
    scenario.wind.speed = 10.0
    airspace = MakeAirspace(
        route, field, scenario, home=HOME, extra_points=[LANDING.ApproachFix(route)]
    )
    fence = airspace.Fence()
    out = tmp_path_factory.mktemp("mavsdk")
    paths = WriteMissions(
        out, route, field, altitude=ALTITUDE, cruise_speed=15.0, ends=LANDING, fence=fence
    )
    return field, route, paths, fence


def _Local(items):
    """The items' positions [m] in the test's frame (MISSION_ITEM_INT: degE7)."""
    return FRAME.ToLocal([[it.y * 1e-7, it.x * 1e-7] for it in items])


def _CheckItems(read, expected):
    """``read``: MAVSDK's items, one per item of ``expected`` (the route's mission)."""
    assert len(read) == len(expected)
    assert [it.command for it in read] == [e.command for e in expected]
    assert [it.frame for it in read] == [e.frame for e in expected]
    assert [it.z for it in read] == pytest.approx([e.alt for e in expected], abs=1e-3)
    assert [it.param3 for it in read] == pytest.approx([e.params[2] for e in expected], abs=1e-3)
    placed = [i for i, e in enumerate(expected) if e.command != MAV_CMD_NAV_RETURN_TO_LAUNCH]
    error = np.linalg.norm(
        _Local([read[i] for i in placed]) - np.array([expected[i].local for i in placed]), axis=1
    )
    assert error.max() < 1.0


def test_the_qgc_plan_imports_through_mavsdk(mission_raw, survey):
    field, route, paths, fence = survey
    data = mission_raw.import_qgroundcontrol_mission(str(paths["qgc_plan"]))
    home, *items = data.mission_items
    # MAVSDK puts the plan's plannedHomePosition first (AMSL), then the plan's items
    # (MAV_FRAME_GLOBAL = 0, or its _INT twin 5, both AMSL)
    assert home.frame in (0, 5) and home.z == pytest.approx(GROUND)
    assert np.linalg.norm(_Local([home])[0] - HOME) < 1.0
    _CheckItems(items, MissionItems(route, field, altitude=ALTITUDE, ends=LANDING)[1:])
    # the geofence MAVSDK reads: the inclusion polygon, no exclusion, and the route inside it
    vertices = [g for g in data.geofence_items if g.mission_type == MISSION_TYPE_FENCE]
    assert {g.command for g in vertices} == {FENCE_VERTEX_INCLUSION}
    inclusion = _Local(vertices)
    assert len(inclusion) == len(fence.inclusion)
    assert np.linalg.norm(inclusion - fence.inclusion, axis=1).max() < 1.0
    points = np.concatenate([RoutePoints(WithHomeLegs(route, HOME)), _Local(items)])
    report = PointsOutside(points, Fence(inclusion, ()))
    assert report["outside"] == 0 and report["in_no_fly"] == 0


def test_the_wpl_file_imports_through_mavsdk(mission_raw, survey):
    field, route, paths, _ = survey
    data = mission_raw.import_mission_planner_mission(str(paths["wpl"]))
    # MAVSDK adds the file's item 0 (home) as a home item of its own, then keeps every line
    added, *items = data.mission_items
    assert added.command == items[0].command and (added.x, added.y) == (items[0].x, items[0].y)
    _CheckItems(items, MissionItems(route, field, altitude=ALTITUDE, ends=LANDING))
    assert data.geofence_items == []


def test_mavsdk_reads_the_exclusion_fences_as_exported(mission_raw, survey, tmp_path):
    """A no-fly polygon exported as an exclusion comes back from MAVSDK as its own polygon
    (``MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION``), every vertex within 1 m, after the
    inclusion polygon."""
    field, route, _, fence = survey
    ring = np.array([(70.0, 70.0), (70.0, 130.0), (130.0, 130.0), (130.0, 70.0)])
    paths = WriteMissions(
        tmp_path,
        route,
        field,
        altitude=ALTITUDE,
        cruise_speed=15.0,
        ends=LANDING,
        fence=Fence(fence.inclusion, (ring,)),
    )
    data = mission_raw.import_qgroundcontrol_mission(str(paths["qgc_plan"]))
    vertices = [g for g in data.geofence_items if g.mission_type == MISSION_TYPE_FENCE]
    inclusion = [g for g in vertices if g.command == FENCE_VERTEX_INCLUSION]
    exclusion = [g for g in vertices if g.command == FENCE_VERTEX_EXCLUSION]
    assert len(inclusion) + len(exclusion) == len(vertices)
    assert [g.param1 for g in exclusion] == [len(ring)] * len(ring)  # the polygon's vertex count
    assert np.linalg.norm(_Local(exclusion) - ring, axis=1).max() < 1.0
    assert np.linalg.norm(_Local(inclusion) - fence.inclusion, axis=1).max() < 1.0
