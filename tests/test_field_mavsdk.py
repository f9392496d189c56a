"""The exported missions read back by MAVSDK's own importers (MAVSDK-Python 4, its C++ core
loaded in-process): the QGroundControl plan through ``import_qgroundcontrol_mission`` and the WPL
110 file through ``import_mission_planner_mission``. No network: MAVSDK is given a ``raw://``
connection and one autopilot heartbeat (built by pymavlink), which is all its importers need of
a vehicle. Skipped without the ``mavsdk`` package."""

import time

import pytest

pytest.importorskip("shapely")
pytest.importorskip("pyproj")
mavsdk_core = pytest.importorskip("mavsdk.mavsdk")
mavlink2 = pytest.importorskip("pymavlink.dialects.v20.common")

from mavsdk.component_type import ComponentType  # noqa: E402
from mavsdk.plugins.mission_raw.mission_raw import MissionRaw  # noqa: E402
from test_field_missions import (  # noqa: E402
    ALTITUDE,
    FRAME,
    GROUND,
    HOME,
    LANDING,
    Distances,
    Expected,
    landing,  # noqa: F401 (a fixture)
    survey,  # noqa: F401 (a fixture)
)

from eaplan_drake.field.missions import (  # noqa: E402
    MAV_CMD_NAV_LAND,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_TAKEOFF,
)

MAV_FRAME_GLOBAL = 0
MAV_FRAME_GLOBAL_RELATIVE_ALT = 3


class _Sink:
    """Where pymavlink would write its bytes (only ``pack`` is used here)."""

    def write(self, data):
        pass


@pytest.fixture(scope="module")
def importer():
    """MAVSDK's MissionRaw plugin on an in-process autopilot: a ``raw://`` connection fed one
    heartbeat until MAVSDK has discovered the system."""
    core = mavsdk_core.Mavsdk(
        mavsdk_core.Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    )
    core.add_any_connection("raw://")
    link = mavlink2.MAVLink(_Sink(), srcSystem=1, srcComponent=1)
    heartbeat = link.heartbeat_encode(
        mavlink2.MAV_TYPE_FIXED_WING, mavlink2.MAV_AUTOPILOT_PX4, 0, 0, 0
    ).pack(link)
    for _ in range(100):  # discovery runs on MAVSDK's own thread
        core.pass_received_raw_bytes(heartbeat)
        if core.system_count():
            break
        time.sleep(0.02)
    systems = core.get_systems()
    assert systems, "MAVSDK discovered no system from the heartbeat"
    plugin = MissionRaw(systems[0])
    yield plugin
    core.destroy()


def _LonLat(items):
    # MAVSDK's MISSION_ITEM_INT: x = latitude, y = longitude, in 1e-7 degrees
    return [[it.y * 1e-7, it.x * 1e-7] for it in items]


def test_mavsdk_imports_the_qgc_plan_within_1_m(importer, survey):  # noqa: F811
    field, route, paths = survey
    items = importer.import_qgroundcontrol_mission(str(paths["qgc_plan"])).mission_items
    expected = Expected(route, field)[1:]  # the plan's home is not a mission item
    assert items[0].command == MAV_CMD_NAV_TAKEOFF
    assert items[-1].command == MAV_CMD_NAV_RETURN_TO_LAUNCH
    items = items[:-1]
    assert [it.command for it in items] == [c for c, _ in expected]
    assert [it.seq for it in items] == list(range(len(items)))
    assert all(it.frame == MAV_FRAME_GLOBAL_RELATIVE_ALT for it in items)
    assert all(it.z == pytest.approx(ALTITUDE) for it in items)
    assert Distances(FRAME, _LonLat(items), [p for _, p in expected]).max() < 1.0


def test_mavsdk_imports_the_wpl_file_within_1_m(importer, survey):  # noqa: F811
    field, route, paths = survey
    items = importer.import_mission_planner_mission(str(paths["wpl"])).mission_items
    expected = Expected(route, field)
    assert items[-1].command == MAV_CMD_NAV_RETURN_TO_LAUNCH
    items = items[:-1]
    assert [it.command for it in items] == [c for c, _ in expected]
    assert items[0].frame == MAV_FRAME_GLOBAL
    assert all(it.frame == MAV_FRAME_GLOBAL_RELATIVE_ALT for it in items[1:])
    assert Distances(FRAME, _LonLat(items), [p for _, p in expected]).max() < 1.0


def test_mavsdk_reads_the_landing_in_its_frames(importer, landing):  # noqa: F811
    field, route, paths = landing
    items = importer.import_mission_planner_mission(str(paths["wpl"])).mission_items
    home, takeoff, land = items[0], items[1], items[-1]
    assert home.frame == MAV_FRAME_GLOBAL and home.z == pytest.approx(GROUND)  # AMSL
    assert takeoff.command == MAV_CMD_NAV_TAKEOFF and takeoff.z == pytest.approx(ALTITUDE)
    assert land.command == MAV_CMD_NAV_LAND and land.z == 0.0
    assert Distances(FRAME, _LonLat([home, takeoff, land]), [HOME] * 3).max() < 1.0
    expected = Expected(route, field, LANDING)
    assert [it.command for it in items] == [c for c, _ in expected]
    assert Distances(FRAME, _LonLat(items), [p for _, p in expected]).max() < 1.0
    qgc = importer.import_qgroundcontrol_mission(str(paths["qgc_plan"])).mission_items
    assert qgc[-1].command == MAV_CMD_NAV_LAND
    assert Distances(FRAME, _LonLat([qgc[-1]]), [HOME]).max() < 1.0
