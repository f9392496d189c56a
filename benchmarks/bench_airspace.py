"""Does the flown track stay inside the airspace a field survey declares, and is that airspace no
wider than it needs to be?

For each field (the shipped one, a random non-convex field with a hole, an 18 ha non-convex
field with a hole drawn by hand, and ``nofly``: the missions' tests' 17 ha field with an 80 m
square hole, tests/test_field_missions.py, flown with ``coverage.no_fly_holes: true``) and each
of ``--directions`` wind directions at ``--wind`` m/s, flies the static lowest plan with the
whole closed loop at the paper's rates (``simulate``'s), and measures, from the first survey
stage on (the approach from ``vehicle.initial_position`` is not part of the mission): the
samples of the track outside the declared airspace (default margin,
:mod:`eaplan_drake.field.airspace`, for that wind speed) and the largest distance of the track
from the field; and over the whole track the samples inside the no-fly polygons (the holes of a
field flown with ``coverage.no_fly_holes: true``). Prints one row per flight and per field the
samples out and in no-fly polygons and the margin over the largest excursion flown (the target:
every flight 0 samples out and 0 in no-fly polygons, and margin ≤ 1.2 × the largest excursion).

    python3 benchmarks/bench_airspace.py [--wind 10] [--directions 8]
        [--fields funen,random,l18,nofly] [--out benchmarks/results/airspace.json]

Writes the rows (JSON) whole or not at all.
"""

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from eaplan_drake.field.airspace import MakeAirspace, PointsOutside
from eaplan_drake.field.geodesy import LocalFrame
from eaplan_drake.field.random_fields import RandomField
from eaplan_drake.field.readers import FieldFromLocal, FieldGeoJsonText
from eaplan_drake.files import AtomicWrite, StrictJson
from eaplan_drake.flight.stages import APPROACH
from eaplan_drake.loading import LoadNamedScenario
from eaplan_drake.resolve import ResolveScenario
from eaplan_drake.simulation import Simulate
from eaplan_drake.studies.worlds import LowestPlan


def L18Field():
    """An 18 ha L-shaped field with a pond, in the local frame of a point in Jutland."""
    outer = [(0, 0), (600, 0), (600, 200), (250, 200), (250, 450), (0, 450), (0, 0)]
    hole = [(80, 120), (160, 110), (170, 190), (90, 200)]
    return FieldFromLocal(outer[:-1], [hole], LocalFrame(9.52, 56.15), source="l18")


def NoFlyField():
    """The missions' tests' field (tests/test_field_missions.py): a 17 ha U with an 80 m square
    hole, flown with ``coverage.no_fly_holes: true``."""
    outer = [(0, 0), (500, 0), (500, 400), (300, 400), (300, 200), (200, 200), (200, 400), (0, 400)]
    hole = [(60, 60), (60, 140), (140, 140), (140, 60)]
    return FieldFromLocal(outer, [hole], LocalFrame(10.3250, 55.4720), source="nofly")


NO_FLY = {"nofly"}
"""The fields flown with ``coverage.no_fly_holes: true``."""


def Fields(tmp: Path) -> dict:
    out = {}
    fields = (("random", RandomField(7, holes=1)), ("l18", L18Field()), ("nofly", NoFlyField()))
    for name, field in fields:
        path = tmp / f"{name}.geojson"
        path.write_text(FieldGeoJsonText(field))
        out[name] = str(path)
    out["funen"] = "funen_field"
    return out


def FlightRow(name: str, field_path: str, wind: float, direction: float) -> dict:
    import shapely

    s = LoadNamedScenario("funen")
    s.coverage.field = field_path
    s.coverage.no_fly_holes = name in NO_FLY
    s.battery.capacity = 3.2  # 47 Wh: every flight completes
    s.simulation.time_limit = 4000.0
    s.wind.speed, s.wind.direction_deg = wind, direction
    s = LowestPlan(s)
    plan = ResolveScenario(s).plan
    route = plan.plan.route
    home = route.legs[0].start
    no_fly = plan.field.holes if s.coverage.no_fly_holes else ()
    airspace = MakeAirspace(route, plan.field, s, home=home, no_fly=no_fly)
    stages = plan.Stages(float(s.planner.path_parameter_bounds[0]))
    approach = next(i for i, st in enumerate(stages) if st.primitive != APPROACH)
    log = Simulate(s)
    stage = log["stage"][:, 0]
    track = log["position"][stage > approach - 0.5]
    check = PointsOutside(track, airspace.Fence())
    in_no_fly = PointsOutside(log["position"], airspace.Fence())["in_no_fly"]
    outline = shapely.Polygon(plan.field.exterior)
    flown = float(np.max(shapely.distance(outline, shapely.points(track))))
    return {
        "field": name,
        "area_ha": plan.field.area / 1e4,
        "wind_speed": wind,
        "wind_direction_deg": direction,
        "status": log.summary["status"],
        "samples": check["points"],
        "outside": check["outside"],
        "in_no_fly": in_no_fly,
        "farthest_out_m": check["farthest_out_m"],
        "margin_m": airspace.margin,
        "route_excursion_m": airspace.required["route_m"],
        "flown_excursion_m": flown,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--wind", type=float, default=10.0)
    parser.add_argument("--directions", type=int, default=8)
    parser.add_argument("--fields", default="funen,random,l18,nofly")
    parser.add_argument("--out", default="benchmarks/results/airspace.json")
    args = parser.parse_args(argv)
    rows = []
    print("field   ha    wind dir  status    samples  out  no-fly  margin m  route m  flown m")
    with tempfile.TemporaryDirectory() as tmp:
        paths = Fields(Path(tmp))
        for name in args.fields.split(","):
            for k in range(args.directions):
                r = FlightRow(name, paths[name], args.wind, 360.0 * k / args.directions)
                rows.append(r)
                print(
                    f"{name:<7} {r['area_ha']:4.1f} {r['wind_speed']:4.0f} "
                    f"{r['wind_direction_deg']:4.0f}  {r['status']:<9} {r['samples']:7d} "
                    f"{r['outside']:4d} {r['in_no_fly']:7d} {r['margin_m']:8.1f} "
                    f"{r['route_excursion_m']:8.1f} "
                    f"{r['flown_excursion_m']:8.1f}",
                    flush=True,
                )
    print()
    for name in args.fields.split(","):
        mine = [r for r in rows if r["field"] == name]
        flown = max(r["flown_excursion_m"] for r in mine)
        print(
            f"{name}: {sum(r['outside'] for r in mine)} samples outside the airspace and "
            f"{sum(r['in_no_fly'] for r in mine)} in no-fly polygons in {len(mine)} flights; "
            f"margin {mine[0]['margin_m']:.1f} m = "
            f"{mine[0]['margin_m'] / flown:.3f} × the largest excursion flown ({flown:.1f} m)"
        )
    AtomicWrite(Path(args.out), lambda f: f.write(StrictJson({"flights": rows})), binary=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
