"""Fields flown by the sequencer: seeded random non-convex fields with 0–2 holes, and the
shipped field.

For each random field (``eaplan_drake.field.random_fields.RandomField(seed, holes=seed % 3)``)
at c1 = 0 in still air: the area its swaths (x_d along the survey lines) cover, how far lines
and turns reach outside it, and the guidance loop's flight (``FlyTracking`` at the fast rates):
whether it completes and its time against the plan's nominal time. Then the pre-flight
prediction (``eaplan-drake plan``: time and SoC of the static lowest plan) against the same plan
flown with the whole closed loop, on the shipped field and three random ones.

    python3 benchmarks/bench_fields.py [--fields 20] [--out benchmarks/results/fields.json]

Prints one row per field and a summary; writes the rows (JSON) whole or not at all.

With ``--missions``, instead: the missions of the shipped field and ``--fields`` random ones
(the funen scenario's lowest plan over each, its airspace as the geofence, a landing at home),
exported and read back through the real parsers installed: pymavlink (WPL), MAVSDK ≥ 4 (the QGC
plan and the WPL file, in process on a ``raw://`` link), xml.etree (Paparazzi; lxml against
Paparazzi's DTD when ``PAPARAZZI_HOME`` is set). Per field: the largest distance between an item
read back and the route's own item [m] (≤ 1 m; for Paparazzi's waypoints, which are not one per
item, the distance to the nearest item), and the points of the route, the legs home and
the items read back that lie outside the fence read back from the QGC plan (0).

    python3 benchmarks/bench_fields.py --missions [--fields 5]
"""

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from eaplan_drake.field.plan import LowestPlanEnergy  # noqa: E402
from eaplan_drake.field.random_fields import RandomField  # noqa: E402
from eaplan_drake.field.readers import FieldGeoJsonText  # noqa: E402
from eaplan_drake.field.source import FieldCoverage  # noqa: E402
from eaplan_drake.files import AtomicWrite, StrictJson  # noqa: E402
from eaplan_drake.flight.stages import APPROACH  # noqa: E402
from eaplan_drake.loading import LoadNamedScenario  # noqa: E402
from eaplan_drake.params import Scenario  # noqa: E402
from eaplan_drake.rates import WithRates  # noqa: E402
from eaplan_drake.resolve import ResolveScenario  # noqa: E402
from eaplan_drake.simulation import Simulate  # noqa: E402
from eaplan_drake.studies.tracking import FlyTracking  # noqa: E402
from eaplan_drake.studies.worlds import LowestPlan  # noqa: E402

LO, HI = -1000.0, 0.0


def RandomRow(seed: int) -> dict:
    field = RandomField(seed, holes=seed % 3)
    s = WithRates(Scenario(), "fast")
    s.wind.speed = 0.0
    source = FieldCoverage(
        field,
        s.coverage,
        start=(-250.0, -250.0),
        airspeed=s.vehicle.airspeed,
        initial_c1=HI,
        k_e=s.guidance.k_e,
        c1_bounds=(LO, HI),
        initial_heading_deg=45.0,
    )
    stages = source.Stages(HI)
    out = {"line": 0.0, "turn": 0.0}
    for st in stages:
        if st.primitive != APPROACH:
            kind = "line" if st.primitive in (0, 2) else "turn"
            out[kind] = max(out[kind], source.DistanceOutside(st))
    approach = next(i for i, st in enumerate(stages) if st.primitive != APPROACH)
    predicted = source.CoverageTime(HI, s.vehicle.airspeed)
    flight = FlyTracking(s, source, HI, t_max=1.5 * predicted + 120.0)
    return {
        "field": f"random {seed}",
        "holes": len(field.holes),
        "cells": len(source.decomposition.cells),
        "area_ha": field.area / 1e4,
        "covered": source.SwathCoverage(HI),
        "line_outside_m": out["line"],
        "turn_outside_m": out["turn"],
        "complete": flight["complete"],
        "time_s": flight["t_end"],
        "predicted_s": predicted,
        "approach_stages": approach,
    }


def PredictionRow(name: str, scenario) -> dict:
    scenario.wind.speed = 0.0
    scenario = WithRates(LowestPlan(scenario), "fast")
    resolved = ResolveScenario(scenario)
    predicted = LowestPlanEnergy(resolved.plan.plan, scenario)
    stages = resolved.plan.Stages(LO)
    approach = next(i for i, st in enumerate(stages) if st.primitive != APPROACH)
    result = Simulate(scenario)
    stage = result["stage"][:, 0]
    k = int(np.argmax(stage > approach - 0.5))
    t0, soc0 = result.times[k], result["soc"][k, 0]
    flown = result.summary["duration"] - t0
    drop = soc0 - result.summary["final_soc"]
    predicted_drop = predicted["initial_soc"] - predicted["final_soc"]
    return {
        "field": name,
        "complete": result.summary["completed"],
        "flown_s": flown,
        "predicted_s": predicted["time"],
        "time_error": flown / predicted["time"] - 1.0,
        "soc_drop": drop,
        "predicted_soc_drop": predicted_drop,
        "soc_error": drop - predicted_drop,
    }


def _MavsdkMissionRaw():
    """MAVSDK's MissionRaw on an in-process raw:// link (no socket), or None without mavsdk 4."""
    try:
        import mavsdk
        from mavsdk.plugins.mission_raw import MissionRaw
        from pymavlink.dialects.v20 import common as mavlink
    except ImportError:
        return None, None
    import time

    sdk = mavsdk.Mavsdk(
        mavsdk.Configuration.create_with_component_type(mavsdk.ComponentType.GROUND_STATION)
    )
    sdk.add_any_connection("raw://")
    sdk.subscribe_raw_bytes_to_be_sent(lambda data: None)
    link = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    heartbeat = link.heartbeat_encode(
        mavlink.MAV_TYPE_FIXED_WING, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 0
    ).pack(link)
    for _ in range(100):
        sdk.pass_received_raw_bytes(heartbeat)
        if sdk.system_count():
            return sdk, MissionRaw(sdk.get_systems()[0])
        time.sleep(0.02)
    sdk.destroy()
    return None, None


def MissionRow(name: str, field_path: str, tmp: Path, mission_raw) -> dict:
    """The field's missions exported and read back (module docstring)."""
    import json
    import os
    import xml.etree.ElementTree as ET

    from pymavlink import mavwp

    from eaplan_drake.field.airspace import MakeAirspace, PointsOutside, RoutePoints
    from eaplan_drake.field.missions import (
        MAV_CMD_NAV_RETURN_TO_LAUNCH,
        Fence,
        MissionEnds,
        MissionItems,
        WriteMissions,
    )
    from eaplan_drake.field.plan import WithHomeLegs

    s = LoadNamedScenario("funen")
    s.coverage.field = field_path
    s = LowestPlan(s)
    plan = ResolveScenario(s).plan
    route, field = plan.plan.route, plan.field
    frame = field.frame
    home = tuple(route.legs[0].start)
    ends = MissionEnds(home, 0.0, "land")
    airspace = MakeAirspace(route, field, s, home=home, extra_points=[ends.ApproachFix(route)])
    out = tmp / name.replace(" ", "_")
    out.mkdir()
    paths = WriteMissions(
        out,
        route,
        field,
        altitude=60.0,
        cruise_speed=s.vehicle.airspeed,
        ends=ends,
        fence=airspace.Fence(),
    )
    expected = MissionItems(route, field, altitude=60.0, ends=ends)
    placed = [i for i, e in enumerate(expected) if e.command != MAV_CMD_NAV_RETURN_TO_LAUNCH]
    want = np.array([expected[i].local for i in placed])
    errors, read_points = {}, []

    def Error(key, lonlat):
        local = frame.ToLocal(lonlat)
        read_points.append(local)
        errors[key] = float(np.max(np.linalg.norm(local - want, axis=1)))

    loader = mavwp.MAVWPLoader()
    loader.load(str(paths["wpl"]))
    wps = [loader.wp(i) for i in range(loader.count())]
    Error("wpl_pymavlink", [[wps[i].y, wps[i].x] for i in placed])
    qgc = json.loads(paths["qgc_plan"].read_text())
    (inclusion,) = [p for p in qgc["geoFence"]["polygons"] if p["inclusion"]]
    fence = Fence(frame.ToLocal([[lon, lat] for lat, lon in inclusion["polygon"]]), ())
    if mission_raw is not None:
        # MAVSDK: the QGC plan's planned home first (item 0 here); the WPL file's item 0 twice
        q = mission_raw.import_qgroundcontrol_mission(str(paths["qgc_plan"])).mission_items
        Error("qgc_mavsdk", [[q[i].y * 1e-7, q[i].x * 1e-7] for i in placed])
        w = mission_raw.import_mission_planner_mission(str(paths["wpl"])).mission_items[1:]
        Error("wpl_mavsdk", [[w[i].y * 1e-7, w[i].x * 1e-7] for i in placed])
    root = ET.fromstring(paths["paparazzi"].read_text())
    wp = [
        (float(w.get("lon")), float(w.get("lat")))
        for w in root.find("waypoints")
        if not w.get("name").startswith("A")
    ]
    local = frame.ToLocal(wp)
    read_points.append(local)
    nearest = np.min(np.linalg.norm(local[:, None, :] - want[None, :, :], axis=2), axis=1)
    errors["paparazzi_xml"] = float(np.max(nearest))
    dtd = Path(os.environ.get("PAPARAZZI_HOME", "/nonexistent")) / "conf/flight_plans"
    valid = None  # no DTD here
    if (dtd / "flight_plan.dtd").is_file():
        from lxml import etree

        valid = bool(etree.DTD(str(dtd / "flight_plan.dtd")).validate(
            etree.parse(str(paths["paparazzi"]))
        ))  # fmt: skip
    points = np.concatenate([RoutePoints(WithHomeLegs(route, home)), *read_points])
    check = PointsOutside(points, fence)
    return {
        "field": name,
        "items": len(expected),
        "errors_m": errors,
        "round_trip_m": max(errors.values()),
        "points": check["points"],
        "outside": check["outside"],
        "paparazzi_dtd_valid": valid,
    }


def MissionsMain(args) -> int:
    sdk, mission_raw = _MavsdkMissionRaw()
    rows = []
    print("parsers: pymavlink (WPL), xml.etree (Paparazzi)" + (", MAVSDK (QGC, WPL)" if sdk else
          " (MAVSDK >= 4 not installed)"))  # fmt: skip
    print("field       items  round trip m  worst parser     points  outside")
    try:
        with tempfile.TemporaryDirectory() as tmp:
            cases = [("funen", "funen_field")]
            for seed in range(args.fields):
                path = Path(tmp) / f"random_{seed}.geojson"
                path.write_text(FieldGeoJsonText(RandomField(seed, holes=seed % 3)))
                cases.append((f"random {seed}", str(path)))
            for name, path in cases:
                r = MissionRow(name, path, Path(tmp), mission_raw)
                rows.append(r)
                worst = max(r["errors_m"], key=r["errors_m"].get)
                print(
                    f"{name:<11} {r['items']:>5} {r['round_trip_m']:13.3f}  {worst:<15} "
                    f"{r['points']:>7} {r['outside']:>8}"
                )
    finally:
        if sdk is not None:
            sdk.destroy()
    ok = sum(r["round_trip_m"] <= 1.0 and r["outside"] == 0 for r in rows)
    print(
        f"\n{ok}/{len(rows)} fields: every item within 1 m in every parser and 0 points outside "
        f"the fence; worst round trip {max(r['round_trip_m'] for r in rows):.3f} m"
    )
    text = StrictJson({"missions": rows})
    AtomicWrite(Path(args.out), lambda f: f.write(text), binary=False)
    return 0 if ok == len(rows) else 1


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fields", type=int, default=20)
    parser.add_argument("--out", default=None)
    parser.add_argument("--missions", action="store_true", help="the missions' round trip")
    args = parser.parse_args(argv)
    if args.missions:
        args.out = args.out or "benchmarks/results/fields_missions.json"
        return MissionsMain(args)
    args.out = args.out or "benchmarks/results/fields.json"
    rows = []
    print("field       holes cells  ha   covered  line out  turn out  complete  time/nominal")
    for seed in range(args.fields):
        r = RandomRow(seed)
        rows.append(r)
        print(
            f"{r['field']:<11} {r['holes']:>5} {r['cells']:>5} {r['area_ha']:5.1f} "
            f"{100 * r['covered']:7.2f} % {r['line_outside_m']:7.1f} m {r['turn_outside_m']:7.1f} m"
            f"  {str(r['complete']):>8}  {r['time_s'] / r['predicted_s']:.4f}"
        )
    predictions = []
    with tempfile.TemporaryDirectory() as tmp:
        cases = [("funen", LoadNamedScenario("funen"))]
        for seed in (0, 4, 8):
            path = Path(tmp) / f"random_{seed}.geojson"
            path.write_text(FieldGeoJsonText(RandomField(seed, holes=seed % 3)))
            s = LoadNamedScenario("funen")
            s.coverage.field = str(path)
            cases.append((f"random {seed}", s))
        print("\npre-flight plan vs the same lowest plan flown (still air, fast rates)")
        print("field       complete  flown s  predicted s  time error  SoC drop  predicted  error")
        for name, s in cases:
            p = PredictionRow(name, s)
            predictions.append(p)
            print(
                f"{name:<11} {str(p['complete']):>8} {p['flown_s']:8.1f} {p['predicted_s']:12.1f} "
                f"{100 * p['time_error']:+9.2f} % {p['soc_drop']:9.4f} "
                f"{p['predicted_soc_drop']:10.4f} {p['soc_error']:+.4f}"
            )
    covered = min(r["covered"] for r in rows)
    line_out = max(r["line_outside_m"] for r in rows)
    turn_out = max(r["turn_outside_m"] for r in rows)
    print(
        f"\n{sum(r['complete'] for r in rows)}/{len(rows)} random fields completed at c1 = 0; "
        f"covered >= {100 * covered:.2f} %; lines <= {line_out:.1f} m "
        f"and turns <= {turn_out:.1f} m outside the field; "
        f"prediction within {100 * max(abs(p['time_error']) for p in predictions):.2f} % and "
        f"{max(abs(p['soc_error']) for p in predictions):.4f} SoC"
    )
    text = StrictJson({"random_fields": rows, "predictions": predictions})
    AtomicWrite(Path(args.out), lambda f: f.write(text), binary=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
