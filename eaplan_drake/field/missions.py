"""Missions out: a route's waypoints and turns as a QGroundControl plan, a WPL 110 waypoint file
(ArduPilot, Mission Planner, QGroundControl) and a Paparazzi flight plan.

The route (:class:`~eaplan_drake.field.route.Route`, local east-north [m]) becomes mission items
in WGS84 through the field's :class:`~eaplan_drake.field.geodesy.LocalFrame`:

- item 0, *home*, at ``home`` (default: the start of the first line);
- a takeoff (``MAV_CMD_NAV_TAKEOFF`` = 22) towards the first line;
- each survey line: a waypoint (``MAV_CMD_NAV_WAYPOINT`` = 16) at its start and one at its end;
- each arc of a turn: ``MAV_CMD_NAV_LOITER_TURNS`` (18) at the circle's centre, param 1 the
  turns flown (angle / 2π, a fraction: ArduPlane and PX4 round or ignore fractions differently,
  so the next line's start waypoint is what ends the turn), param 3 the radius [m], positive
  clockwise and negative counter-clockwise (MAVLink's convention);
- a turn's straight piece: a waypoint at its end;
- transits are the straight flight to the next line's start waypoint.

Altitudes are ``altitude`` [m] above home (MAVLink frame 3, ``MAV_FRAME_GLOBAL_RELATIVE_ALT``;
home itself in frame 0 at ``home_altitude`` AMSL [m]). The QGroundControl plan (``.plan``,
JSON, file version 1, mission version 2, geofence version 2) also holds the field as an
inclusion geofence polygon and each hole as an exclusion polygon (QGroundControl stores
[latitude, longitude]); :func:`~eaplan_drake.field.readers.ReadField` reads that field back.

The Paparazzi flight plan (XML) has the line ends and turn centres as waypoints (lat/lon
attributes), the field as a sector, and a ``Survey`` block of ``go`` stages (``hmode="route"``
along each line) and ``circle`` stages (Paparazzi's radius sign: positive clockwise, negative
counter-clockwise) that end after the turn's share of a circle (``NavCircleCount()``); it follows
the element and attribute structure of Paparazzi's ``conf/flight_plans/flight_plan.dtd`` (not
shipped here: Paparazzi is GPL).

Coordinates are written with 8 decimals (≈ 1 mm); angles in degrees, distances in metres.
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
    "MAV_CMD_NAV_LOITER_TURNS",
    "MAV_CMD_NAV_TAKEOFF",
    "MAV_CMD_NAV_WAYPOINT",
    "MissionItem",
    "MissionItems",
    "PaparazziFlightPlanText",
    "QgcPlanText",
    "WplText",
    "WriteMissions",
]

MAV_CMD_NAV_WAYPOINT = 16
MAV_CMD_NAV_LOITER_TURNS = 18
MAV_CMD_NAV_TAKEOFF = 22
_FRAME_GLOBAL = 0
_FRAME_GLOBAL_RELATIVE_ALT = 3


@dc.dataclass(frozen=True)
class MissionItem:
    """One MAVLink mission item."""

    command: int
    """MAV_CMD."""
    lat: float
    """φ [deg]."""
    lon: float
    """λ [deg]."""
    alt: float
    """[m], in ``frame``."""
    params: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    """Params 1–4."""
    frame: int = _FRAME_GLOBAL_RELATIVE_ALT
    """MAV_FRAME."""
    local: tuple[float, float] = (0.0, 0.0)
    """The point in the local frame [m]."""


def MissionItems(
    route: Route, field: Field, *, altitude: float, home=None, home_altitude: float = 0.0
) -> list[MissionItem]:
    """The mission items of ``route`` (see the module docstring); ``home`` [m] in the local
    frame, ``altitude`` above home and ``home_altitude`` AMSL [m]."""
    if not (math.isfinite(altitude) and altitude > 0.0):
        raise ValueError(f"altitude: must be > 0 [m above home], got {altitude!r}")
    lines = [leg for leg in route.legs if leg.kind == "line"]
    if not lines:
        raise ValueError("the route has no survey line")
    home = lines[0].start if home is None else tuple(float(v) for v in home)
    points = []  # (command, local point, params, frame, alt)
    points.append((MAV_CMD_NAV_WAYPOINT, home, (0.0,) * 4, _FRAME_GLOBAL, home_altitude))
    points.append((MAV_CMD_NAV_TAKEOFF, lines[0].start, (15.0, 0.0, 0.0, 0.0), 3, altitude))
    for leg in route.legs:
        if leg.kind == "line":
            points.append((MAV_CMD_NAV_WAYPOINT, leg.start, (0.0,) * 4, 3, altitude))
            points.append((MAV_CMD_NAV_WAYPOINT, leg.end, (0.0,) * 4, 3, altitude))
        elif leg.kind == "turn" and leg.radius == 0.0:  # a turn's straight piece
            points.append((MAV_CMD_NAV_WAYPOINT, leg.end, (0.0,) * 4, 3, altitude))
        elif leg.kind == "turn":
            turns = leg.angle / (2.0 * math.pi)
            radius = -leg.radius if leg.ccw else leg.radius
            points.append(
                (MAV_CMD_NAV_LOITER_TURNS, leg.center, (turns, 0.0, radius, 0.0), 3, altitude)
            )
    lonlat = field.frame.ToLonLat(np.array([p[1] for p in points]))
    return [
        MissionItem(cmd, float(lat), float(lon), float(alt), tuple(params), frame, tuple(xy))
        for (cmd, xy, params, frame, alt), (lon, lat) in zip(points, lonlat, strict=True)
    ]


def _R(value: float, digits: int = 8) -> float:
    return round(float(value), digits)


def QgcPlanText(
    route: Route,
    field: Field,
    *,
    altitude: float,
    cruise_speed: float,
    home=None,
    home_altitude: float = 0.0,
) -> str:
    """The QGroundControl ``.plan`` JSON of ``route`` over ``field``."""  # fmt: skip
    items = MissionItems(route, field, altitude=altitude, home=home, home_altitude=home_altitude)
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

    def fence(ring, inclusion):
        return {
            "fenceAction": 0,
            "inclusion": inclusion,
            "polygon": [[_R(lat), _R(lon)] for lon, lat in ring],
            "version": 1,
        }

    home_item = items[0]
    plan = {
        "fileType": "Plan",
        "geoFence": {
            "circles": [],
            "polygons": [fence(field.ExteriorLonLat(), True)]
            + [fence(h, False) for h in field.HolesLonLat()],
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
    route: Route, field: Field, *, altitude: float, home=None, home_altitude: float = 0.0
) -> str:
    """The ``QGC WPL 110`` text of ``route``: one tab-separated line per item (index, current,
    frame, command, params 1–4, latitude, longitude, altitude, autocontinue); item 0 is home."""
    items = MissionItems(route, field, altitude=altitude, home=home, home_altitude=home_altitude)
    rows = ["QGC WPL 110"]
    for k, item in enumerate(items):
        cells = [str(k), "1" if k == 0 else "0", str(item.frame), str(item.command)]
        cells += [_G(p) for p in item.params]
        cells += [f"{item.lat:.8f}", f"{item.lon:.8f}", _G(item.alt), "1"]
        rows.append("\t".join(cells))
    return "\r\n".join(rows) + "\r\n"


def PaparazziFlightPlanText(
    route: Route,
    field: Field,
    *,
    altitude: float,
    name: str = "eaplan_survey",
    ground_alt: float = 0.0,
    home=None,
) -> str:
    """The Paparazzi flight plan XML of ``route`` (see the module docstring); ``alt`` is
    ``ground_alt + altitude`` [m AMSL]."""  # fmt: skip
    frame = field.frame
    home_xy = route.legs[0].start if home is None else tuple(home)
    waypoints = [("HOME", home_xy)]
    stages = []
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
    corners = []
    for j, ring in enumerate([field.exterior]):
        for i, xy in enumerate(ring):
            corners.append(f"F{j}_{i}")
            waypoints.append((f"F{j}_{i}", xy))
    lonlat = frame.ToLonLat(np.array([xy for _, xy in waypoints]))
    span = max(float(np.linalg.norm(np.asarray(xy) - np.asarray(home_xy))) for _, xy in waypoints)
    q = xml.sax.saxutils.quoteattr
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        '<!DOCTYPE flight_plan SYSTEM "flight_plan.dtd">',
        f'<flight_plan name={q(name)} lat0="{frame.lat:.8f}" lon0="{frame.lon:.8f}" '
        f'max_dist_from_home="{span + 500.0:.0f}" ground_alt="{ground_alt:g}" '
        f'security_height="25" alt="{ground_alt + altitude:g}">',
        "  <waypoints>",
    ]
    for (wp, _), (lon, lat) in zip(waypoints, lonlat, strict=True):
        lines.append(f'    <waypoint name="{wp}" lat="{lat:.8f}" lon="{lon:.8f}"/>')
    lines += ["  </waypoints>", "  <sectors>", '    <sector name="Field">']
    lines += [f'      <corner name="{c}"/>' for c in corners]
    lines += ["    </sector>", "  </sectors>", "  <blocks>"]
    lines += ['    <block name="Standby">', '      <circle wp="HOME" radius="75"/>', "    </block>"]
    lines += [
        '    <block name="Survey">',
        *stages,
        '      <deroute block="Standby"/>',
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
    home=None,
    stem: str = "mission",
) -> dict[str, Path]:
    """Writes ``stem.plan``, ``stem.waypoints`` (WPL 110) and ``stem.xml`` (Paparazzi) into
    ``directory`` (each whole or not at all); returns their paths by format."""  # fmt: skip
    from eaplan_drake.files import AtomicWrite

    directory = Path(directory)
    texts = {
        "qgc_plan": (
            f"{stem}.plan",
            QgcPlanText(route, field, altitude=altitude, cruise_speed=cruise_speed, home=home),
        ),
        "wpl": (f"{stem}.waypoints", WplText(route, field, altitude=altitude, home=home)),
        "paparazzi": (
            f"{stem}.xml",
            PaparazziFlightPlanText(route, field, altitude=altitude, home=home),
        ),
    }
    out = {}
    for kind, (name, text) in texts.items():
        out[kind] = AtomicWrite(
            directory / name, lambda f, t=text: f.write(t.encode("utf-8")), binary=True
        )
    return out
