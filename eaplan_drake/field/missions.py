"""Missions out: a route's waypoints and turns as a QGroundControl plan, a WPL 110 waypoint file
(ArduPilot, Mission Planner, QGroundControl) and a Paparazzi flight plan.

The route (:class:`~eaplan_drake.field.route.Route`, local east-north [m]) becomes mission items
in WGS84 through the field's :class:`~eaplan_drake.field.geodesy.LocalFrame`, between a start
and an end (:class:`MissionEnds`):

- item 0, *home* (the launch point), at ``ends.home`` (default: the start of the first line);
- a takeoff (``MAV_CMD_NAV_TAKEOFF`` = 22) at home, climbing to the flight altitude;
- each survey line: a waypoint (``MAV_CMD_NAV_WAYPOINT`` = 16) at its start and one at its end;
- each arc of a turn: ``MAV_CMD_NAV_LOITER_TURNS`` (18) at the circle's centre, param 1 the
  turns flown (angle / 2π, a fraction: ArduPlane and PX4 round or ignore fractions differently,
  so the next line's start waypoint is what ends the turn), param 3 the radius [m], positive
  clockwise and negative counter-clockwise (MAVLink's convention);
- a turn's straight piece: a waypoint at its end;
- transits are the straight flight to the next line's start waypoint;
- the end: ``MAV_CMD_NAV_RETURN_TO_LAUNCH`` (20; ``ends.end = "rtl"``, the default), or a
  landing (``"land"``): ``MAV_CMD_DO_LAND_START`` (189), a waypoint at the approach fix
  :data:`APPROACH_DISTANCE` from home at :data:`APPROACH_HEIGHT`, and ``MAV_CMD_NAV_LAND`` (21)
  at home.

Altitudes, each in its format's own frame: the flight altitude ``altitude`` [m] is above home;
home is at ``ends.ground_alt`` [m AMSL]. MAVLink items use frame 3
(``MAV_FRAME_GLOBAL_RELATIVE_ALT``, above home); home itself is frame 0 at ``ground_alt`` AMSL
(WPL item 0, QGroundControl's ``plannedHomePosition``). The QGroundControl plan (``.plan``,
JSON, file version 1, mission version 2, geofence version 2) also holds the geofence: the
``inclusion`` polygon (the field, or the airspace the mission declares) and the ``exclusions``
(QGroundControl stores [latitude, longitude]). Paparazzi's altitudes are AMSL: its flight plan
has ``ground_alt`` = ``ends.ground_alt`` and ``alt`` = ground_alt + altitude.

The Paparazzi flight plan (XML) has home, the line ends and turn centres as waypoints (lat/lon
attributes), the inclusion polygon as a sector, and blocks ``Holding`` (wait at home),
``Takeoff`` (full throttle at 15° pitch towards the first line until the security height),
``Survey`` (``go`` stages, ``hmode="route"`` along each line, and ``circle`` stages with
Paparazzi's radius sign: positive clockwise, negative counter-clockwise, that end after the
turn's share of a circle, ``NavCircleCount()``), ``Standby`` (circling home: the return) and,
with a landing, ``Land`` (the approach fix, then a glide to the touchdown point at home). It
follows Paparazzi's ``conf/flight_plans/flight_plan.dtd`` (not shipped here: Paparazzi is GPL).

Files are UTF-8 with LF line ends. Coordinates are written with 8 decimals (≈ 1 mm); angles in
degrees, distances in metres.
"""

import dataclasses as dc
import json
import math
import xml.sax.saxutils
from pathlib import Path

import numpy as np

from eaplan_drake.field.readers import Field
from eaplan_drake.field.route import Route

__all__ = [
    "APPROACH_DISTANCE",
    "APPROACH_HEIGHT",
    "MAV_CMD_DO_LAND_START",
    "MAV_CMD_NAV_LAND",
    "MAV_CMD_NAV_LOITER_TURNS",
    "MAV_CMD_NAV_RETURN_TO_LAUNCH",
    "MAV_CMD_NAV_TAKEOFF",
    "MAV_CMD_NAV_WAYPOINT",
    "MISSION_ENDS",
    "Fence",
    "MissionEnds",
    "MissionItem",
    "MissionItems",
    "PaparazziFlightPlanText",
    "QgcPlanText",
    "WplText",
    "WriteMissions",
]

MAV_CMD_NAV_WAYPOINT = 16
MAV_CMD_NAV_LOITER_TURNS = 18
MAV_CMD_NAV_RETURN_TO_LAUNCH = 20
MAV_CMD_NAV_LAND = 21
MAV_CMD_NAV_TAKEOFF = 22
MAV_CMD_DO_LAND_START = 189
_FRAME_GLOBAL = 0
_FRAME_MISSION = 2
_FRAME_GLOBAL_RELATIVE_ALT = 3

MISSION_ENDS = ("rtl", "land")
"""How a mission ends: ``rtl`` (return to launch, then the autopilot's own loiter or landing) or
``land`` (an approach and a landing at home)."""
APPROACH_DISTANCE = 250.0
"""Distance of a landing's approach fix from the touchdown point at home [m]."""
APPROACH_HEIGHT = 30.0
"""Height of the approach fix above home [m] (or the flight altitude if lower)."""
TAKEOFF_PITCH_DEG = 15.0
"""Pitch of the takeoff climb [deg] (MAV_CMD_NAV_TAKEOFF param 1, Paparazzi's takeoff)."""


@dc.dataclass(frozen=True)
class MissionEnds:
    """Where a mission starts and ends, and the ground's altitude."""

    home: tuple[float, float] | None = None
    """Home, the launch point, in the local frame [m]; None: the first line's start."""
    ground_alt: float = 0.0
    """Altitude of the ground at home [m AMSL]."""
    end: str = "rtl"
    """One of :data:`MISSION_ENDS`."""
    approach: tuple[float, float] | None = None
    """With ``end = "land"``: the direction from home to the approach fix (a landing flies the
    opposite way: into the wind when this is the wind's direction); None: towards the route's
    last point."""

    def Home(self, route: Route) -> np.ndarray:
        """Home [m]: :attr:`home`, or the first line's start."""
        if self.home is not None:
            return np.asarray(self.home, dtype=float)
        lines = [leg for leg in route.legs if leg.kind == "line"]
        if not lines:
            raise ValueError("the route has no survey line")
        return np.asarray(lines[0].start, dtype=float)

    def ApproachFix(self, route: Route) -> np.ndarray:
        """The landing's approach fix [m]: :data:`APPROACH_DISTANCE` from home along
        :attr:`approach` (or towards the route's last point)."""
        home = self.Home(route)
        u = np.asarray(
            self.approach if self.approach is not None else np.subtract(route.legs[-1].end, home),
            dtype=float,
        )
        norm = float(np.linalg.norm(u))
        u = u / norm if norm > 1e-9 else np.array([1.0, 0.0])
        return home + APPROACH_DISTANCE * u

    def Check(self) -> "MissionEnds":
        if self.end not in MISSION_ENDS:
            raise ValueError(f"end: must be one of {', '.join(MISSION_ENDS)}, got {self.end!r}")
        if not math.isfinite(self.ground_alt) or abs(self.ground_alt) > 9000.0:
            raise ValueError(
                f"ground_alt: must be in [-9000, 9000] m AMSL, got {self.ground_alt!r}"
            )
        return self


@dc.dataclass(frozen=True)
class Fence:
    """A mission's geofence in the local frame [m]: the inclusion polygon it must stay in, and
    exclusion polygons it must stay out of."""

    inclusion: np.ndarray
    """(n, 2) ring [m]."""
    exclusions: tuple[np.ndarray, ...] = ()
    """Each (m, 2) ring [m]."""

    @staticmethod
    def OfField(field: Field) -> "Fence":
        """The field as the inclusion polygon, no exclusion (its holes may be overflown)."""
        return Fence(np.asarray(field.exterior, dtype=float), ())


@dc.dataclass(frozen=True)
class MissionItem:
    """One MAVLink mission item."""

    command: int
    """MAV_CMD."""
    lat: float
    """φ [deg] (0 for a return to launch)."""
    lon: float
    """λ [deg] (0 for a return to launch)."""
    alt: float
    """[m], in ``frame``."""
    params: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    """Params 1–4."""
    frame: int = _FRAME_GLOBAL_RELATIVE_ALT
    """MAV_FRAME."""
    local: tuple[float, float] = (0.0, 0.0)
    """The point in the local frame [m] (home for a return to launch)."""


def _CheckAltitude(altitude: float) -> None:
    if not (math.isfinite(altitude) and 0.0 < altitude < 10_000.0):
        raise ValueError(f"altitude: must be in (0, 10000) [m above home], got {altitude!r}")


def MissionItems(
    route: Route, field: Field, *, altitude: float, ends: MissionEnds = MissionEnds()
) -> list[MissionItem]:
    """The mission items of ``route`` (see the module docstring); ``altitude`` [m above
    home]."""
    _CheckAltitude(altitude)
    ends.Check()
    home = tuple(ends.Home(route))
    zero = (0.0,) * 4
    points = [(MAV_CMD_NAV_WAYPOINT, home, zero, _FRAME_GLOBAL, ends.ground_alt)]
    takeoff = (TAKEOFF_PITCH_DEG, 0.0, 0.0, 0.0)
    points.append((MAV_CMD_NAV_TAKEOFF, home, takeoff, _FRAME_GLOBAL_RELATIVE_ALT, altitude))
    for leg in route.legs:
        if leg.kind == "line":
            points.append((MAV_CMD_NAV_WAYPOINT, leg.start, zero, 3, altitude))
            points.append((MAV_CMD_NAV_WAYPOINT, leg.end, zero, 3, altitude))
        elif leg.kind == "turn" and leg.radius == 0.0:  # a turn's straight piece
            points.append((MAV_CMD_NAV_WAYPOINT, leg.end, zero, 3, altitude))
        elif leg.kind == "turn":
            turns = leg.angle / (2.0 * math.pi)
            radius = -leg.radius if leg.ccw else leg.radius
            points.append(
                (MAV_CMD_NAV_LOITER_TURNS, leg.center, (turns, 0.0, radius, 0.0), 3, altitude)
            )
    if ends.end == "rtl":
        points.append((MAV_CMD_NAV_RETURN_TO_LAUNCH, home, zero, _FRAME_MISSION, 0.0))
    else:
        fix = tuple(ends.ApproachFix(route))
        height = min(APPROACH_HEIGHT, altitude)
        points.append((MAV_CMD_DO_LAND_START, fix, zero, 3, 0.0))
        points.append((MAV_CMD_NAV_WAYPOINT, fix, zero, 3, height))
        points.append((MAV_CMD_NAV_LAND, home, zero, 3, 0.0))
    lonlat = field.frame.ToLonLat(np.array([p[1] for p in points]))
    items = []
    for (cmd, xy, params, frame, alt), (lon, lat) in zip(points, lonlat, strict=True):
        if cmd == MAV_CMD_NAV_RETURN_TO_LAUNCH:
            lon = lat = 0.0
        items.append(
            MissionItem(cmd, float(lat), float(lon), float(alt), tuple(params), frame, tuple(xy))
        )
    return items


def _R(value: float, digits: int = 8) -> float:
    return round(float(value), digits)


def QgcPlanText(
    route: Route,
    field: Field,
    *,
    altitude: float,
    cruise_speed: float,
    ends: MissionEnds = MissionEnds(),
    fence: Fence | None = None,
) -> str:
    """The QGroundControl ``.plan`` JSON of ``route`` over ``field``; ``fence`` (default: the
    field, :meth:`Fence.OfField`) is its geofence."""  # fmt: skip
    items = MissionItems(route, field, altitude=altitude, ends=ends)
    fence = Fence.OfField(field) if fence is None else fence
    mission_items = []
    for k, item in enumerate(items[1:], start=1):
        params = [_R(p, 6) for p in item.params]
        if item.command == MAV_CMD_NAV_TAKEOFF:
            params[3] = None  # yaw: none
        mission_items.append(
            {
                "AMSLAltAboveTerrain": None,
                "Altitude": _R(item.alt, 3),
                "AltitudeMode": 1,
                "autoContinue": True,
                "command": item.command,
                "doJumpId": k,
                "frame": item.frame,
                "params": [*params, _R(item.lat), _R(item.lon), _R(item.alt, 3)],
                "type": "SimpleItem",
            }
        )

    def polygon(ring, inclusion):
        lonlat = field.frame.ToLonLat(np.asarray(ring, dtype=float))
        return {
            "fenceAction": 0,
            "inclusion": inclusion,
            "polygon": [[_R(lat), _R(lon)] for lon, lat in lonlat],
            "version": 1,
        }

    home_item = items[0]
    plan = {
        "fileType": "Plan",
        "geoFence": {
            "circles": [],
            "polygons": [polygon(fence.inclusion, True)]
            + [polygon(h, False) for h in fence.exclusions],
            "version": 2,
        },
        "groundStation": "QGroundControl",
        "mission": {
            "cruiseSpeed": _R(cruise_speed, 3),
            "firmwareType": 0,
            "globalPlanAltitudeMode": 1,
            "hoverSpeed": 5,
            "items": mission_items,
            "plannedHomePosition": [_R(home_item.lat), _R(home_item.lon), _R(home_item.alt, 3)],
            "vehicleType": 1,
            "version": 2,
        },
        "rallyPoints": {"points": [], "version": 2},
        "version": 1,
    }
    return json.dumps(plan, indent=4, allow_nan=False) + "\n"


def _G(value: float) -> str:
    """A number as WPL writes it: plain decimal, no exponent."""
    text = f"{float(value):.8f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def WplText(
    route: Route, field: Field, *, altitude: float, ends: MissionEnds = MissionEnds()
) -> str:
    """The ``QGC WPL 110`` text of ``route``: one tab-separated line per item (index, current,
    frame, command, params 1–4, latitude, longitude, altitude, autocontinue), LF line ends;
    item 0 is home."""
    items = MissionItems(route, field, altitude=altitude, ends=ends)
    rows = ["QGC WPL 110"]
    for k, item in enumerate(items):
        cells = [str(k), "1" if k == 0 else "0", str(item.frame), str(item.command)]
        cells += [_G(p) for p in item.params]
        cells += [f"{item.lat:.8f}", f"{item.lon:.8f}", _G(item.alt), "1"]
        rows.append("\t".join(cells))
    return "\n".join(rows) + "\n"


def _PaparazziStages(route: Route):
    """(waypoints [(name, local point)], ``Survey`` block stages) of ``route``."""
    waypoints, stages = [], []
    for k, leg in enumerate(route.legs):
        if leg.kind == "line":
            a, b = f"L{k}_S", f"L{k}_E"
            waypoints += [(a, leg.start), (b, leg.end)]
            stages.append(f'      <go wp="{a}"/>')
            stages.append(f'      <go from="{a}" wp="{b}" hmode="route"/>')
        elif leg.kind == "turn" and leg.radius == 0.0:  # a turn's straight piece
            e = f"T{k}_E"
            waypoints.append((e, leg.end))
            stages.append(f'      <go wp="{e}"/>')
        elif leg.kind == "turn":
            c = f"T{k}_C"
            waypoints.append((c, leg.center))
            radius = -leg.radius if leg.ccw else leg.radius
            turns = leg.angle / (2.0 * math.pi)
            stages.append(
                f'      <circle wp="{c}" radius="{radius:.3f}" until="NavCircleCount() &gt; '
                f'{turns:.4f}"/>'
            )
    return waypoints, stages


def PaparazziFlightPlanText(
    route: Route,
    field: Field,
    *,
    altitude: float,
    name: str = "eaplan_survey",
    ends: MissionEnds = MissionEnds(),
    fence: Fence | None = None,
) -> str:
    """The Paparazzi flight plan XML of ``route`` (see the module docstring): ``ground_alt`` =
    ``ends.ground_alt`` and ``alt`` = ground_alt + ``altitude`` [m AMSL]; the sector
    ``Airspace`` is ``fence``'s inclusion polygon (default: the field) and the plan's
    ``geofence_sector``."""  # fmt: skip
    _CheckAltitude(altitude)
    ends.Check()
    frame = field.frame
    fence = Fence.OfField(field) if fence is None else fence
    home_xy = tuple(ends.Home(route))
    ground = float(ends.ground_alt)
    survey_waypoints, stages = _PaparazziStages(route)
    waypoints = [("HOME", home_xy, ground)]
    waypoints += [(n, xy, None) for n, xy in survey_waypoints]
    if ends.end == "land":
        waypoints.append(
            ("AF", tuple(ends.ApproachFix(route)), ground + min(APPROACH_HEIGHT, altitude))
        )
        waypoints.append(("TD", home_xy, ground))
    corners = []
    for i, xy in enumerate(fence.inclusion):
        corners.append(f"A{i}")
        waypoints.append((f"A{i}", xy, None))
    lonlat = frame.ToLonLat(np.array([xy for _, xy, _ in waypoints]))
    span = max(float(np.linalg.norm(np.subtract(xy, home_xy))) for _, xy, _ in waypoints)
    security = min(25.0, 0.5 * altitude)
    q = xml.sax.saxutils.quoteattr
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        '<!DOCTYPE flight_plan SYSTEM "flight_plan.dtd">',
        f'<flight_plan name={q(name)} lat0="{frame.lat:.8f}" lon0="{frame.lon:.8f}" '
        f'max_dist_from_home="{span + 500.0:.0f}" ground_alt="{ground:g}" '
        f'security_height="{security:g}" alt="{ground + altitude:g}" '
        'geofence_sector="Airspace">',
        "  <waypoints>",
    ]
    for (wp, _, alt), (lon, lat) in zip(waypoints, lonlat, strict=True):
        z = "" if alt is None else f' alt="{alt:g}"'
        lines.append(f'    <waypoint name="{wp}" lat="{lat:.8f}" lon="{lon:.8f}"{z}/>')
    lines += ["  </waypoints>", "  <sectors>", '    <sector name="Airspace">']
    lines += [f'      <corner name="{c}"/>' for c in corners]
    lines += ["    </sector>", "  </sectors>", "  <blocks>"]
    first = survey_waypoints[0][0]
    end_block = "Land" if ends.end == "land" else "Standby"
    lines += [
        '    <block name="Holding">',
        '      <attitude roll="0" throttle="0" vmode="throttle" until="FALSE"/>',
        "    </block>",
        '    <block name="Takeoff">',
        f'      <exception cond="GetPosHeight() &gt; {security:g}" deroute="Survey"/>',
        f'      <go from="HOME" wp="{first}" hmode="route" vmode="throttle" throttle="1.0" '
        f'pitch="{TAKEOFF_PITCH_DEG:g}"/>',
        "    </block>",
        '    <block name="Survey">',
        *stages,
        f'      <deroute block="{end_block}"/>',
        "    </block>",
        '    <block name="Standby">',
        f'      <circle wp="HOME" radius="{max(75.0, route.min_turning_radius):.0f}"/>',
        "    </block>",
    ]
    if ends.end == "land":
        lines += [
            '    <block name="Land">',
            '      <go wp="AF"/>',
            '      <go from="AF" wp="TD" hmode="route" vmode="glide"/>',
            '      <attitude roll="0" throttle="0" vmode="throttle" until="FALSE"/>',
            "    </block>",
        ]
    lines += ["  </blocks>", "</flight_plan>"]
    return "\n".join(lines) + "\n"


def WriteMissions(
    directory,
    route: Route,
    field: Field,
    *,
    altitude: float,
    cruise_speed: float,
    ends: MissionEnds = MissionEnds(),
    fence: Fence | None = None,
    stem: str = "mission",
) -> dict[str, Path]:
    """Writes ``stem.plan``, ``stem.waypoints`` (WPL 110) and ``stem.xml`` (Paparazzi) into
    ``directory`` (each whole or not at all); returns their paths by format."""  # fmt: skip
    from eaplan_drake.files import AtomicWrite

    directory = Path(directory)
    texts = {
        "qgc_plan": (
            f"{stem}.plan",
            QgcPlanText(
                route, field, altitude=altitude, cruise_speed=cruise_speed, ends=ends, fence=fence
            ),
        ),
        "wpl": (f"{stem}.waypoints", WplText(route, field, altitude=altitude, ends=ends)),
        "paparazzi": (
            f"{stem}.xml",
            PaparazziFlightPlanText(route, field, altitude=altitude, ends=ends, fence=fence),
        ),
    }
    out = {}
    for kind, (name, text) in texts.items():
        out[kind] = AtomicWrite(
            directory / name, lambda f, t=text: f.write(t.encode("utf-8")), binary=True
        )
    return out
