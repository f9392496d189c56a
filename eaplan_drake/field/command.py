"""The ``eaplan-drake plan FIELD`` command: its arguments and what it runs (the command line's
other commands are in :mod:`eaplan_drake.cli`). Imports the ``[field]`` extra only when run."""

from pathlib import Path

from eaplan_drake.loading import OverrideFromAssignment

__all__ = ["AddPlanParser", "RunPlanCommand"]


def _ParseOrigin(text: str):
    cells = text.split(",")
    try:
        lon, lat = (float(c) for c in cells)
    except ValueError:
        raise ValueError(f"--origin: expected LON,LAT in degrees, got {text!r}") from None
    return lon, lat


def RunPlanCommand(args) -> int:
    """``eaplan-drake plan``: read, decompose and plan the field, print and write the plan."""
    from eaplan_drake.field.geodesy import Require

    Require("shapely")
    Require("pyproj")
    from eaplan_drake.field.plan import (
        BestStaticPlan,
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
    scenario = LoadNamedScenario(args.scenario, [OverrideFromAssignment(a) for a in args.set])
    coverage = scenario.coverage
    low, high = scenario.planner.path_parameter_bounds
    c1 = low if args.c1 is None else args.c1
    if not (low <= c1 <= high):
        raise ValueError(f"--c1: must be in [{low:g}, {high:g}] m² (planner.path_parameter_bounds)")
    spacing = LineSpacing(coverage, c1)
    origin = _ParseOrigin(args.origin) if args.origin else None
    field = ReadField(args.field, index=args.polygon, origin=origin, min_width=spacing)
    plan = MakeFieldPlan(
        field,
        spacing,
        coverage.min_turning_radius,
        theta_deg=args.sweep_deg,
        cells=coverage.field_cells,
        min_line_length=4.0 * coverage.trigger_radius,
    )
    energy = LowestPlanEnergy(plan, scenario)
    summary = Summary(plan, energy)
    summary["lowest_plan_risk"] = LowestPlanRisk(energy, scenario)
    summary["best_static_plan"] = BestStaticPlan(plan, scenario)
    summary["scenario"] = scenario.name
    summary["path_parameter_c1"] = c1
    out = Path(args.out) / Path(args.field).stem
    written = SaveFieldPlan(
        plan, out, summary=summary, altitude=args.altitude, cruise_speed=scenario.vehicle.airspeed
    )
    print(FormatFieldPlan(summary))
    print(f"missions, figure and summary in {out} ({', '.join(p.name for p in written)})")
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
        "mission.xml (Paparazzi), plan.png and summary.json. Needs the [field] extra.",
    )
    p.add_argument("field", help="field file: .geojson, .json, .kml or .plan")
    p.add_argument("--out", default="plan", help="output directory (default: plan/)")
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY.PATH=VALUE",
        help="override a key of the scenario (repeatable): coverage.swath_spacing (line "
        "spacing), coverage.min_turning_radius, vehicle.airspeed, battery.*, computation.table",
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
    p.add_argument(
        "--altitude", type=float, default=50.0, help="flight altitude above home [m] (default 50)"
    )
    p.set_defaults(run=RunPlanCommand)
