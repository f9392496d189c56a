"""The plan command on the shipped field: summary, files (missions, figure, summary) and their
agreement; one line for a bad field or option; ``plan --help`` without pydrake."""

import json
import re
import subprocess
import sys
from importlib import resources

import numpy as np
import pytest

shapely = pytest.importorskip("shapely")
pytest.importorskip("pyproj")

from eaplan_drake.cli import main  # noqa: E402
from eaplan_drake.field.command import DOES_NOT_FIT  # noqa: E402
from eaplan_drake.field.decompose import Decompose, IsConvex  # noqa: E402
from eaplan_drake.field.plan import LineSpacing  # noqa: E402
from eaplan_drake.field.readers import ReadField  # noqa: E402
from eaplan_drake.params import CoverageParams  # noqa: E402

SHIPPED = str(resources.files("eaplan_drake") / "data" / "funen_field.geojson")


def test_the_shipped_field_is_non_convex_with_a_hole():
    field = ReadField(SHIPPED)
    polygon = field.Polygon()
    assert len(field.holes) == 1 and field.notes == ()
    assert polygon.convex_hull.area > 1.05 * (polygon.area + shapely.Polygon(field.holes[0]).area)
    assert 5e4 < field.area < 1e5  # 5 to 10 ha
    d = Decompose(polygon, 30.0)
    assert all(IsConvex(c.vertices) for c in d.cells)
    assert sum(shapely.Polygon(c.vertices).area for c in d.cells) == pytest.approx(
        polygon.area, rel=1e-6
    )


def test_line_spacing_is_x_d_at_c1_0_and_wider_at_the_lowest_plan():
    coverage = CoverageParams()
    assert LineSpacing(coverage, 0.0) == pytest.approx(10.0, abs=1e-12)
    # 2 r1 − 2 r2(−1000) = 150 − 2 sqrt(3900)
    assert LineSpacing(coverage, -1000.0) == pytest.approx(150.0 - 2.0 * 3900**0.5, abs=1e-12)


def test_plan_prints_the_summary_and_writes_missions_figure_and_summary(tmp_path, capsys):
    code = main(["plan", SHIPPED, "--out", str(tmp_path), "--scenario", "funen"])
    out = capsys.readouterr()
    assert code == 0, out.err
    keys = ("cells", "sweep", "lines", "turns", "path length", "home", "altitudes", "airspace")
    for key in (*keys, "fence check", "lowest plan", "battery"):
        assert any(line.startswith(key) for line in out.out.splitlines()), key
    folder = tmp_path / "funen_field"
    names = {"mission.plan", "mission.waypoints", "mission.xml", "plan.png", "summary.json"}
    assert {p.name for p in folder.iterdir()} == names
    summary = json.loads((folder / "summary.json").read_text())
    parts = summary["line_length_m"] + summary["turn_length_m"] + summary["transit_length_m"]
    assert summary["path_length_m"] == pytest.approx(parts, rel=1e-12)
    e = summary["lowest_plan"]
    # the time includes the flight back home (the first line's start) from the route's end
    assert 0.0 < e["home_legs_m"] < 1000.0
    flown = summary["path_length_m"] + e["home_legs_m"]
    assert e["time"] == pytest.approx(flown / 15.0, rel=1e-12)
    assert e["energy"] == pytest.approx(e["mean_power"] * e["time"], rel=1e-12)
    assert 0.0 < e["final_soc"] < e["initial_soc"]
    assert summary["mission"]["end"] == "rtl" and summary["mission"]["ground_alt_from"] is None
    # the route lies inside its own exported fence; the fence is the airspace, not the field
    airspace = summary["airspace"]
    assert airspace["check"]["outside"] == 0 and airspace["check"]["points"] > 4000
    assert airspace["margin_m"] == pytest.approx(airspace["required"]["margin"], rel=1e-12)
    assert 150.0 < airspace["margin_m"] < 200.0
    assert "ground assumed at 0 m AMSL: give --ground-alt" in out.out
    assert (folder / "plan.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_given_sweep_direction_and_c1_are_used(tmp_path, capsys):
    args = ["plan", SHIPPED, "--out", str(tmp_path), "--sweep-deg", "30", "--c1", "0"]
    assert main([*args, "--set", "battery.capacity=3.2"]) == 0  # 47 Wh
    summary = json.loads((tmp_path / "funen_field" / "summary.json").read_text())
    assert summary["sweep_deg_from_east"] == pytest.approx(30.0)
    assert summary["line_spacing_m"] == pytest.approx(10.0)
    assert "given (--sweep-deg)" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--c1", "5"], r"--c1: must be in \[-1000, 0\]"),
        (["--origin", "10.3"], r"--origin: expected LON,LAT"),
        (["--altitude", "-1"], r"--altitude: must be in \(0, 10000\)"),
        (["--ground-alt", "nan"], r"--ground-alt: must be in \[-9000, 9000\] m AMSL"),
        (["--home", "10.3,95"], r"--home: expected LON in \[-180, 180\] and LAT in \[-90, 90\]"),
        (["--set", "coverage.mission_end=crash"], r"coverage\.mission_end: must be one of"),
        (
            ["--set", "coverage.airspace_margin=50", "--scenario", "funen"],
            r"coverage\.airspace_margin: 50 m is too small for this route: .* the smallest that "
            r"works is 1\d\d\.\d m$",
        ),
        (["--set", "coverage.swath_spacing=-1"], r"coverage\.swath_spacing"),
    ],
)
def test_a_bad_option_is_one_line(tmp_path, capsys, extra, message):
    assert main(["plan", SHIPPED, "--out", str(tmp_path), *extra]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    assert re.search(message, err), err
    assert not (tmp_path / "funen_field").exists()


def test_a_survey_that_does_not_fit_says_so_in_one_line_and_writes_no_mission(tmp_path, capsys):
    # the survey scenario's 7.19 Wh pack: the shipped field needs 5.4 Wh, 5.0 Wh are above the
    # reserve
    code = main(["plan", SHIPPED, "--out", str(tmp_path)])
    out = capsys.readouterr()
    assert code == DOES_NOT_FIT == 4
    (line,) = out.err.strip().splitlines()
    assert re.fullmatch(
        r"eaplan-drake: the survey does not fit: its lowest plan draws 5\.\d\d Wh, the pack gives "
        r"5\.0\d Wh above the 0\.30 reserve: 0\.\d\d Wh missing; the reserve is reached 9\d % "
        r"along the route; missions not written \(--write-missions writes them\)",
        line,
    ), line
    assert {p.name for p in (tmp_path / "funen_field").iterdir()} == {"plan.png", "summary.json"}
    summary = json.loads((tmp_path / "funen_field" / "summary.json").read_text())
    e = summary["lowest_plan"]
    assert e["final_soc"] < e["reserve_soc"] and 0.9 < e["reserve_reached"]["fraction"] < 1.0
    assert "reserve at" in out.out
    # on request the missions are written, with the same status
    assert main(["plan", SHIPPED, "--out", str(tmp_path / "w"), "--write-missions"]) == 4
    assert (tmp_path / "w" / "funen_field" / "mission.waypoints").exists()


def test_an_empty_pack_shows_how_far_below_it_would_go(tmp_path, capsys):
    args = ["plan", SHIPPED, "--out", str(tmp_path), "--set", "battery.capacity=0.2"]
    assert main(args) == 4
    out = capsys.readouterr().out
    assert re.search(r"SoC 1\.000 -> empty \(-\d\.\d\d\d had it no bottom\)", out), out


def test_home_ground_altitude_and_landing_reach_the_missions(tmp_path, capsys):
    field = ReadField(SHIPPED)
    corner = field.ExteriorLonLat()[2]
    home = f"{corner[0] + 0.0005:.6f},{corner[1]:.6f}"  # ≈ 30 m east of the third vertex
    args = ["plan", SHIPPED, "--out", str(tmp_path), "--scenario", "funen", "--home", home]
    args += ["--home-vertex", "--ground-alt", "470", "--end", "land"]
    assert main(args) == 0
    folder = tmp_path / "funen_field"
    summary = json.loads((folder / "summary.json").read_text())
    np.testing.assert_allclose(summary["mission"]["home_m"], field.exterior[2], atol=1e-6)
    assert summary["mission"]["ground_alt_from"] == "--ground-alt"
    plan = json.loads((folder / "mission.plan").read_text())
    assert plan["mission"]["plannedHomePosition"][2] == 470.0
    assert plan["mission"]["items"][-1]["command"] == 21  # MAV_CMD_NAV_LAND
    # read again from the QGC plan just written (its fence, the airspace, is the field now):
    # the ground altitude comes from its home
    again = ["plan", str(folder / "mission.plan"), "--out", str(tmp_path / "again")]
    assert main([*again, "--set", "battery.capacity=3.2", "--sweep-deg", "85"]) == 0
    summary = json.loads((tmp_path / "again" / "mission" / "summary.json").read_text())
    assert summary["mission"]["ground_alt_amsl_m"] == 470.0
    assert summary["mission"]["ground_alt_from"] == "the plan's home"


def test_a_bad_field_is_one_line_naming_it(tmp_path, capsys):
    bad = tmp_path / "bad.geojson"
    bad.write_text('{"type": "Polygon", "coordinates": [[[0, 0], [1, 1], [1, 0], [0, 1], [0, 0]]]}')
    assert main(["plan", str(bad), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(bad) in err and "Self-intersection" in err
    assert "Traceback" not in err


def test_plan_help_imports_no_pydrake():
    code = (
        "import sys\n"
        "from eaplan_drake.cli import main\n"
        "try:\n"
        "    main(['plan', '--help'])\n"
        "except SystemExit:\n"
        "    pass\n"
        "print('pydrake' in sys.modules, 'shapely' in sys.modules)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60
    )
    assert out.stdout.strip().splitlines()[-1] == "False False"


def test_the_pre_flight_fault_risk_of_the_lowest_plan(tmp_path, capsys):
    from eaplan_drake.planning.risk import FaultModel, TotalDropTail, UniformDrops

    assert main(["plan", SHIPPED, "--out", str(tmp_path), "--scenario", "funen"]) == 0
    assert "fault risk      P(drops > margin)" in capsys.readouterr().out
    summary = json.loads((tmp_path / "funen_field" / "summary.json").read_text())
    e, r = summary["lowest_plan"], summary["lowest_plan_risk"]
    model = FaultModel(0.003, UniformDrops(0.0, 0.15))  # the default planner.fault_model
    margin = e["final_soc"] - e["reserve_soc"]
    assert r["margin"] == pytest.approx(margin, abs=1e-12)
    assert r["failure_probability"] == pytest.approx(
        TotalDropTail(model, e["time"], margin), abs=1e-12
    )
    m = r["margin_at_risk"]  # the smallest margin that keeps the risk at ε = 0.05
    assert TotalDropTail(model, e["time"], m) <= 0.05 < TotalDropTail(model, e["time"], m - 1e-6)
    # without faults there is no risk
    assert (
        main(
            ["plan", SHIPPED, "--out", str(tmp_path), "--scenario", "funen"]
            + ["--set", "planner.fault_model.rate=0"]
        )
        == 0
    )
    r0 = json.loads((tmp_path / "funen_field" / "summary.json").read_text())["lowest_plan_risk"]
    assert r0["failure_probability"] == 0.0 and r0["margin_at_risk"] == 0.0


def _Feasible(plan, scenario, c1, c2, lowest):
    """(margin ≥ 0 and excess risk ≤ ε) of the static plan (c1, c2), computed here from the
    route's prediction and the fault model's tail."""
    from eaplan_drake.field.plan import RoutePrediction
    from eaplan_drake.field.route import MakeRoute
    from eaplan_drake.planning.risk import TotalDropTail
    from eaplan_drake.planning.risk_margin import FaultModelFromParams

    coverage = scenario.coverage
    route = MakeRoute(
        plan.choice.decomposition,
        LineSpacing(coverage, c1),
        coverage.min_turning_radius,
        min_line_length=4.0 * coverage.trigger_radius,
    )
    p = RoutePrediction(route, scenario, [c2])
    margin = p["final_soc"] - scenario.battery.reserve_soc
    model = FaultModelFromParams(scenario.planner.fault_model)

    def Tail(tau, m):
        return 1.0 if m < 0.0 else TotalDropTail(model, tau, m)

    if lowest is None:
        return p["time"], margin
    return margin >= 0.0 and Tail(p["time"], margin) - Tail(*lowest) <= scenario.planner.risk


@pytest.mark.parametrize("risk", [0.05, 1.0])
def test_the_best_static_plan_is_the_highest_quality_that_keeps_the_risk(risk):
    from eaplan_drake.field.plan import BestStaticPlan, MakeFieldPlan
    from eaplan_drake.loading import LoadNamedScenario

    scenario = LoadNamedScenario("funen")
    scenario.planner.risk = risk
    coverage = scenario.coverage
    field = ReadField(SHIPPED)
    plan = MakeFieldPlan(
        field,
        LineSpacing(coverage, -1000.0),
        coverage.min_turning_radius,
        min_line_length=4.0 * coverage.trigger_radius,
    )
    best = BestStaticPlan(plan, scenario, grid_size=5)
    assert best["feasible"] and best["plans_tried"] == 5 * 5
    assert best["margin"] >= 0.0 and best["excess_risk"] <= risk
    lowest = _Feasible(plan, scenario, -1000.0, 2.0, None)
    c1, (c2,) = best["path_parameter_c1"], best["computation_parameters"]
    assert _Feasible(plan, scenario, c1, c2, lowest)
    # Every plan of higher quality along either axis is out: a larger c2 at this c1, a larger c1
    # at this c2.
    if c2 < 10.0:
        assert not _Feasible(plan, scenario, c1, c2 + 2.0, lowest)
    if c1 < 0.0:
        assert not _Feasible(plan, scenario, c1 + 250.0, c2, lowest)
    if risk == 1.0:  # only the margin binds: higher quality than at ε = 0.05
        scenario.planner.risk = 0.05
        assert best["quality"] > BestStaticPlan(plan, scenario, grid_size=5)["quality"]


def test_the_point_of_no_return_is_the_first_leg_end_beyond_reach_of_home():
    from eaplan_drake.field.plan import PointOfNoReturn, RoutePrediction
    from eaplan_drake.field.route import MakeRoute
    from eaplan_drake.flight.plant import MotionPowerCoefficients
    from eaplan_drake.loading import LoadNamedScenario
    from eaplan_drake.registry import BATTERY_MODELS

    scenario = LoadNamedScenario("funen")
    rect = shapely.Polygon([(0, 0), (600, 0), (600, 400), (0, 400)])
    route = MakeRoute(Decompose(rect, 0.0), 25.0, 62.45)
    p = RoutePrediction(route, scenario, [2.0])
    assert PointOfNoReturn(route, p, scenario) is None  # 1.6 × the reference battery: plenty
    scenario.battery.capacity = 0.3  # Ah at 14.8 V: 4.4 Wh
    p = RoutePrediction(route, scenario, [2.0])
    pnr = PointOfNoReturn(route, p, scenario)
    assert pnr is not None and 0 < pnr["leg"] < len(route.legs)
    battery = BATTERY_MODELS.Make("rint", scenario.battery)
    p0, _ = MotionPowerCoefficients(scenario.vehicle.airspeed, scenario.vehicle.motion_power)
    home = np.asarray(route.legs[0].start)

    def Back(k):
        d = np.linalg.norm(np.asarray(route.legs[k].end) - home) / scenario.vehicle.airspeed
        return battery.SocAfter(p["soc_after_leg"][k], p0 + p["computation_power"], d)

    assert Back(pnr["leg"]) < scenario.battery.reserve_soc <= Back(pnr["leg"] - 1)
    elapsed = sum(leg.length for leg in route.legs[: pnr["leg"] + 1]) / scenario.vehicle.airspeed
    assert pnr["time_s"] == pytest.approx(elapsed, rel=1e-12)


def test_a_given_home_chooses_the_entry_nearest_to_it():
    from eaplan_drake.field.plan import MakeFieldPlan

    field = ReadField(SHIPPED)
    kwargs = {"theta_deg": 85.0, "min_line_length": 8.0}
    default = MakeFieldPlan(field, 25.1, 62.45, **kwargs)
    gains = []
    for home in field.exterior:  # every corner as the launch point
        plan = MakeFieldPlan(field, 25.1, 62.45, start=home, **kwargs)
        entry = np.linalg.norm(np.subtract(plan.route.legs[0].start, home))
        before = np.linalg.norm(np.subtract(default.route.legs[0].start, home))
        assert entry <= before + 1e-9
        gains.append(before - entry)
        assert plan.route.Count("line") == default.route.Count("line")
    assert max(gains) > 100.0  # from a far corner the entry moves to that side of the field
