"""The ``eaplan-drake plan FIELD`` command: its arguments and what it runs (the command line's
other commands are in :mod:`eaplan_drake.cli`). Imports the ``[field]`` extra only when run."""

import json
import math
import sys
from pathlib import Path

from eaplan_drake.loading import OverrideFromAssignment

__all__ = ["DOES_NOT_FIT", "AddPlanParser", "RunPlanCommand"]

DOES_NOT_FIT = 4
"""Exit status of ``plan`` when the lowest plan ends below the reserve."""


def _ParseLonLat(text: str, option: str):
    cells = text.split(",")
    try:
        lon, lat = (float(c) for c in cells)
    except ValueError:
        raise ValueError(f"{option}: expected LON,LAT in degrees, got {text!r}") from None
    if not (abs(lon) <= 180.0 and abs(lat) <= 90.0):
        raise ValueError(
            f"{option}: expected LON in [-180, 180] and LAT in [-90, 90], got {text!r}"
        )
    return lon, lat


def PlanHomeAltitude(path) -> float | None:
    """The home altitude [m AMSL] of a QGroundControl ``.plan`` (``mission.plannedHomePosition``
    [φ, λ, h]), or None for another file or a plan without one."""
    path = Path(path)
    if path.suffix != ".plan":
        return None
    try:
        home = json.loads(path.read_text(encoding="utf-8"))["mission"]["plannedHomePosition"]
        alt = float(home[2])
    except (OSError, ValueError, KeyError, IndexError, TypeError):
        return None
    return alt if math.isfinite(alt) else None


def _NearestVertex(field, point):
    import numpy as np

    vertices = np.asarray(field.exterior)
    return vertices[int(np.argmin(np.linalg.norm(vertices - np.asarray(point), axis=1)))]


def _GivenHome(args, scenario, field):
    """Home [m] as given (``--home``, else ``coverage.home``; with ``--home-vertex`` the field's
    vertex nearest to it), or None."""
    import numpy as np

    lonlat = _ParseLonLat(args.home, "--home") if args.home else scenario.coverage.home
    if not lonlat:
        return None
    home = field.frame.ToLocal(np.array([lonlat], dtype=float))[0]
    return _NearestVertex(field, home) if args.home_vertex else home


def _MissionEnds(args, scenario, field, route, home):
    """The :class:`~eaplan_drake.field.missions.MissionEnds` of the command line and scenario
    (``home`` [m] as given, or None: the first line's start, or with ``--home-vertex`` the
    field's vertex nearest to it), and where the ground altitude came from."""
    from eaplan_drake.field.missions import MissionEnds

    coverage = scenario.coverage
    if args.ground_alt is not None:
        ground, source = args.ground_alt, "--ground-alt"
    elif coverage.ground_alt != 0.0:
        ground, source = coverage.ground_alt, "coverage.ground_alt"
    elif (from_plan := PlanHomeAltitude(args.field)) is not None:
        ground, source = from_plan, "the plan's home"
    else:
        ground, source = 0.0, None
    approach = None
    wind = scenario.wind
    if wind.speed > 0.0:
        a = math.radians(wind.direction_deg)
        approach = (math.cos(a), math.sin(a))  # downwind of home: the landing flies into the wind
    end = args.end or coverage.mission_end
    ends = MissionEnds(None, float(ground), end, approach).Check()
    if home is None:
        home = ends.Home(route)
        home = _NearestVertex(field, home) if args.home_vertex else home
    return MissionEnds((float(home[0]), float(home[1])), float(ground), end, approach), source


def _Airspace(plan, scenario, ends):
    """The airspace of ``plan`` from ``ends.home`` (and the landing's approach fix), and the
    check of the route, home legs included, against its fence as exported (through WGS84 at the
    files' 8 decimals); raises :class:`~eaplan_drake.field.airspace.AirspaceError` when a point
    leaves it."""
    import numpy as np

    from eaplan_drake.field.airspace import (
        AirspaceError,
        MakeAirspace,
        PointsOutside,
        RoutePoints,
    )
    from eaplan_drake.field.missions import Fence
    from eaplan_drake.field.plan import WithHomeLegs

    coverage, field = scenario.coverage, plan.field
    extra = [ends.ApproachFix(plan.route)] if ends.end == "land" else []
    airspace = MakeAirspace(
        plan.route,
        field,
        scenario,
        margin=coverage.airspace_margin,
        home=ends.home,
        extra_points=extra,
        no_fly=field.holes if coverage.no_fly_holes else (),
    )
    fence = airspace.Fence()
    if plan.no_fly is not None and extra:  # the landing's approach, flown straight
        from eaplan_drake.field.nofly import Hits
        from eaplan_drake.field.route import Leg

        end, fix, home = (
            tuple(float(v) for v in p) for p in (plan.route.legs[-1].end, *extra, ends.home)
        )
        if Hits([Leg("home", end, fix, 1.0), Leg("home", fix, home, 1.0)], plan.no_fly):
            raise AirspaceError(
                "coverage.no_fly_holes: the landing's approach (from the route's end to its fix "
                "and home) crosses a no-fly polygon: land elsewhere (--home) or end with rtl"
            )

    def Exported(ring):
        lonlat = np.round(field.frame.ToLonLat(ring), 8)
        return field.frame.ToLocal(lonlat)

    exported = Fence(Exported(fence.inclusion), tuple(Exported(h) for h in fence.exclusions))
    points = np.concatenate(
        [RoutePoints(WithHomeLegs(plan.route, ends.home)), np.asarray([ends.home, *extra])]
    )
    check = PointsOutside(points, exported)
    if check["outside"] or check["in_no_fly"]:
        raise AirspaceError(
            f"the route leaves its own fence ({check['outside']} points outside, "
            f"{check['in_no_fly']} in no-fly polygons): not written"
        )
    return airspace, check


def _AroundToHome(plan, home):
    """``plan`` with its way from and back to ``home`` [m] around its no-fly polygons
    (:func:`~eaplan_drake.field.nofly.WithHomeTransits`); as it is without them."""
    if plan.no_fly is None:
        return plan
    import dataclasses as dc

    from eaplan_drake.field.nofly import WithHomeTransits

    return dc.replace(plan, route=WithHomeTransits(plan.route, home, plan.no_fly))


def _NotFitLine(summary: dict, scenario) -> str:
    """The one line of a plan whose lowest plan ends below the reserve."""
    e = summary["lowest_plan"]
    battery = scenario.battery
    usable = (e["initial_soc"] - e["reserve_soc"]) * battery.Energy()
    drawn = (e["initial_soc"] - e["final_soc_unclamped"]) * battery.Energy()
    r = e["reserve_reached"]
    return (
        f"the survey does not fit: its lowest plan draws {drawn / 3600.0:.2f} Wh, the pack "
        f"gives {usable / 3600.0:.2f} Wh above the {e['reserve_soc']:.2f} reserve: "
        f"{(drawn - usable) / 3600.0:.2f} Wh missing; the reserve is reached "
        f"{100.0 * r['fraction']:.0f} % along the route; missions not written "
        "(--write-missions writes them)"
    )


def RunPlanCommand(args) -> int:
    """``eaplan-drake plan``: read, decompose and plan the field, print and write the plan."""
    from eaplan_drake.field.geodesy import Require

    Require("shapely")
    Require("pyproj")
    from eaplan_drake.field.plan import (
        AirspaceSummary,
        BestStaticPlan,
        EndsSummary,
        FormatFieldPlan,
        LineSpacing,
        LowestPlanEnergy,
        LowestPlanRisk,
        MakeFieldPlan,
        SaveFieldPlan,
        Summary,
    )
    from eaplan_drake.field.readers import ReadField
    from eaplan_drake.loading import LoadNamedScenario

    if not (args.altitude > 0.0 and args.altitude < 10_000.0):
        raise ValueError(f"--altitude: must be in (0, 10000) m above home, got {args.altitude!r}")
    if args.ground_alt is not None and not abs(args.ground_alt) <= 9000.0:
        raise ValueError(f"--ground-alt: must be in [-9000, 9000] m AMSL, got {args.ground_alt!r}")
    scenario = LoadNamedScenario(args.scenario, [OverrideFromAssignment(a) for a in args.set])
    coverage = scenario.coverage
    low, high = scenario.planner.path_parameter_bounds
    c1 = low if args.c1 is None else args.c1
    if not (low <= c1 <= high):
        raise ValueError(f"--c1: must be in [{low:g}, {high:g}] m² (planner.path_parameter_bounds)")
    spacing = LineSpacing(coverage, c1)
    origin = _ParseLonLat(args.origin, "--origin") if args.origin else None
    field = ReadField(args.field, index=args.polygon, origin=origin, min_width=spacing)
    given_home = _GivenHome(args, scenario, field)
    plan = MakeFieldPlan(
        field,
        spacing,
        coverage.min_turning_radius,
        theta_deg=args.sweep_deg,
        cells=coverage.field_cells,
        min_line_length=4.0 * coverage.trigger_radius,
        start=given_home,
        no_fly=field.holes if coverage.no_fly_holes else (),
    )
    ends, ground_source = _MissionEnds(args, scenario, field, plan.route, given_home)
    home = ends.Home(plan.route)
    plan = _AroundToHome(plan, home)
    energy = LowestPlanEnergy(plan, scenario, home)
    summary = Summary(plan, energy)
    summary["lowest_plan_risk"] = LowestPlanRisk(energy, scenario)
    summary["best_static_plan"] = BestStaticPlan(plan, scenario, home=home)
    summary["scenario"] = scenario.name
    summary["path_parameter_c1"] = c1
    summary["mission"] = EndsSummary(field, ends, args.altitude, ground_source)
    airspace, check = _Airspace(plan, scenario, ends)
    summary["airspace"] = AirspaceSummary(airspace, check)
    fits = energy["final_soc"] >= energy["reserve_soc"]
    out = Path(args.out) / Path(args.field).stem
    written = SaveFieldPlan(
        plan,
        out,
        summary=summary,
        altitude=args.altitude,
        cruise_speed=scenario.vehicle.airspeed,
        ends=ends,
        airspace=airspace,
        missions=fits or args.write_missions,
    )
    print(FormatFieldPlan(summary))
    what = "missions, figure and summary" if fits or args.write_missions else "figure and summary"
    print(f"{what} in {out} ({', '.join(p.name for p in written)})")
    if not fits:
        print(f"eaplan-drake: {_NotFitLine(summary, scenario)}", file=sys.stderr)
        return DOES_NOT_FIT
    return 0


def AddPlanParser(sub) -> None:
    """The ``plan`` subcommand's arguments."""
    p = sub.add_parser(
        "plan",
        help="read a field (GeoJSON, KML, QGC .plan), decompose it, print the survey plan, "
        "write missions and a figure",
        description="Read FIELD (WGS84 polygon with holes: .geojson/.json, .kml, or a "
        "QGroundControl .plan's survey or geofence polygon), decompose it into convex "
        "boustrophedon cells for the sweep direction of the shortest route, print the plan "
        "(cells, direction, lines, path length, time and energy of the static lowest plan) and "
        "write DIR/<field>/: mission.plan (QGroundControl), mission.waypoints (WPL 110), "
        "mission.xml (Paparazzi), plan.png and summary.json. Each mission takes off at home, "
        "flies the survey and returns to launch or lands, inside the airspace it declares: the "
        "field plus coverage.airspace_margin (default: the smallest that works, from the turning "
        "radius, the line spacing and the wind), its inclusion geofence. The battery is the "
        "scenario's, as on its label (--set battery.capacity_mah=3300 --set battery.cells=4, or "
        "battery.energy_wh). A survey that does not fit the battery "
        f"(the lowest plan ends below the reserve) exits with status {DOES_NOT_FIT} and writes no "
        "mission unless --write-missions. Needs the [field] extra.",
    )
    p.add_argument("field", help="field file: .geojson, .json, .kml or .plan")
    p.add_argument("--out", default="plan", help="output directory (default: plan/)")
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY.PATH=VALUE",
        help="override a key of the scenario (repeatable): coverage.swath_spacing (line "
        "spacing), coverage.min_turning_radius, coverage.airspace_margin, coverage.no_fly_holes, "
        "coverage.ground_alt, vehicle.airspeed, wind.speed, battery.* (capacity_mah, cells, "
        "energy_wh, ...), computation.table",
    )
    p.add_argument(
        "--scenario", default="survey", help="scenario whose vehicle, battery and computation "
        "are used (shipped name or YAML; default survey)",
    )  # fmt: skip
    p.add_argument("--polygon", type=int, default=None, help="which polygon of several (0-based)")
    p.add_argument(
        "--origin", default="", metavar="LON,LAT", help="origin of the local frame [deg] "
        "(default: the field's first vertex)",
    )  # fmt: skip
    p.add_argument(
        "--sweep-deg", type=float, default=None, help="direction of the lines [deg from east, "
        "counter-clockwise] (default: the shortest route)",
    )  # fmt: skip
    p.add_argument(
        "--c1",
        type=float,
        default=None,
        help="path parameter c1 [m²] that sets the line spacing 2 r1 − 2 r2(c1) (default: its "
        "lower bound, the static lowest plan; 0 gives coverage.swath_spacing)",
    )
    _AddMissionArguments(p)
    p.set_defaults(run=RunPlanCommand)


def _AddMissionArguments(p) -> None:
    """The ``plan`` arguments of the missions: altitudes, home, end, and whether to write them."""
    p.add_argument(
        "--altitude", type=float, default=50.0, help="flight altitude above home [m] (default 50)"
    )
    p.add_argument(
        "--ground-alt",
        type=float,
        default=None,
        metavar="M",
        help="altitude of the ground at home [m AMSL] (default: coverage.ground_alt, else a "
        "QGroundControl plan's home altitude, else 0 with a note); MAVLink altitudes are above "
        "home, Paparazzi's are AMSL",
    )
    p.add_argument(
        "--home",
        default="",
        metavar="LON,LAT",
        help="home, the launch point [deg] (default: coverage.home, else the first line's start)",
    )
    p.add_argument(
        "--home-vertex",
        action="store_true",
        help="home at the field's vertex nearest to --home (or to the first line's start)",
    )
    p.add_argument(
        "--end",
        choices=("rtl", "land"),
        default=None,
        help="how the missions end: return to launch, or an approach into the wind and a landing "
        "at home (default: coverage.mission_end, rtl)",
    )
    p.add_argument(
        "--write-missions",
        action="store_true",
        help="write the missions even when the survey does not fit the battery",
    )
