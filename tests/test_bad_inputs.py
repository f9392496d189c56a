"""Bad input, through the command line and the Python API: one clear line naming the key (or
``file:line:col``), exit status 2, and an end before any flight. Each case runs under an alarm
(``_Bounded``) so that a case that hangs fails instead of blocking the suite; none asserts a
duration. The kill tests SIGKILL a short run and a save loop and check that no half-written or
orphaned file is left."""

import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from eaplan_drake.cli import main as cli_main
from eaplan_drake.diagram import LOGGED_SIGNALS
from eaplan_drake.errors import ScenarioError
from eaplan_drake.flight.plant import FixedWingDynamics, NonFiniteCommandError
from eaplan_drake.loading import LoadScenario
from eaplan_drake.params import Scenario
from eaplan_drake.resolve import PeakCircleHeadingRate, ResolveScenario, TriggerDistance

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "eaplan_drake" / "data"
REFERENCE_PLAN = (DATA / "reference_plan.pln").read_text()
TABLE = "fps,watts\n2,5.2\n5,7.4\n10,10.2\n"

ALARM_SECONDS = 60
"""A case still running after this long is a hang (every case here fails in < 5 s)."""


class _HangError(Exception):
    pass


def _Bounded(fn, *args):
    def on_alarm(signum, frame):
        raise _HangError(f"still running after {ALARM_SECONDS} s")

    previous = signal.signal(signal.SIGALRM, on_alarm)
    signal.alarm(ALARM_SECONDS)
    try:
        return fn(*args)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def _Plan(trigger_line_7=None, extra=""):
    """The reference plan with line 7 (a triggering point) replaced, or extra text appended."""
    lines = REFERENCE_PLAN.splitlines()
    if trigger_line_7 is not None:
        lines[6] = trigger_line_7
    return "\n".join(lines) + "\n" + extra


# (category, case id, files {name: text or bytes}, YAML scenario text, expected in the message)
# Scenario YAML may refer to the files by their relative names (resolved against its folder).
CASES = [
    # -- powprofiler tables --------------------------------------------------------------------
    ("table", "not a number", {"t.csv": "fps,watts\n2,5.2\n5,abc\n"}, "", "t.csv:3:3"),
    ("table", "wrong columns", {"t.csv": "fps,watts\n2,5.2\n5,7.4,1\n"}, "", "t.csv:3"),
    ("table", "unsorted", {"t.csv": "fps,watts\n5,5.2\n2,7.4\n"}, "", "t.csv:3"),
    ("table", "duplicate key", {"t.csv": "fps,watts\n2,5.2\n2,7.4\n"}, "", "t.csv:3"),
    ("table", "one row", {"t.csv": "fps,watts\n2,5.2\n"}, "", "t.csv"),
    ("table", "negative watts", {"t.csv": "fps,watts\n2,5.2\n10,-1\n"}, "", "t.csv:3:4"),
    ("table", "nan watts", {"t.csv": "fps,watts\n2,5.2\n10,nan\n"}, "", "t.csv:3:4"),
    ("table", "not UTF-8", {"t.csv": b"fps,watts\n2,5.2\n10,\xff\n"}, "", "t.csv:3:4"),
    ("table", "empty", {"t.csv": ""}, "", "t.csv"),
    ("table", "missing file", {}, "", "t.csv"),
    (
        "table",
        "incomplete grid",
        {"t.csv": "a,b,watts\n1,1,5\n1,2,6\n2,1,7\n"},
        "computation: {initial_parameters: [1, 1]}\n",
        "t.csv",
    ),
    (
        "table",
        "too many rows",
        {"t.csv": "fps,watts\n" + "".join(f"{i},{5 + i * 1e-4}\n" for i in range(10_001))},
        "",
        "more than 10000 data rows",
    ),
    (
        "table",
        "count mismatch",
        {"t.csv": TABLE},
        "computation: {initial_parameters: [2, 5]}\n",
        "computation.initial_parameters",
    ),
    (
        "table",
        "initial value outside",
        {"t.csv": TABLE},
        "computation: {initial_parameters: [11]}\n",
        "computation.initial_parameters[0]",
    ),
    # -- plan files ----------------------------------------------------------------------------
    ("plan", "bad character", {"p.pln": _Plan("-10, 20 $")}, "", "p.pln:7:"),
    ("plan", "unknown name", {"p.pln": _Plan("-10, z")}, "", "p.pln:7:6"),
    (
        "plan",
        "flat 2000-term sum",
        {"p.pln": _Plan("-10, " + "+".join(["1"] * 2000))},
        "",
        "p.pln:7:",
    ),
    (
        "plan",
        "deep parentheses",
        {"p.pln": _Plan("-10, " + "(" * 40 + "1" + ")" * 40)},
        "",
        "p.pln:7:",
    ),
    ("plan", "trigger far off its path", {"p.pln": _Plan("35, 600")}, "", "p.pln:7:1"),
    ("plan", "empty expression", {"p.pln": _Plan("-10, ")}, "", "p.pln:7:"),
    ("plan", "no stages", {"p.pln": "% nothing\n"}, "", "p.pln"),
    ("plan", "not UTF-8", {"p.pln": REFERENCE_PLAN.encode() + b"\xfe\n"}, "", "p.pln:"),
    ("plan", "missing file", {}, "", "p.pln"),
    (
        "plan",
        "trigger radius huge",
        {"p.pln": REFERENCE_PLAN},
        "coverage: {trigger_radius: 1e9}\n",
        "coverage.trigger_radius",
    ),
    # -- YAML ----------------------------------------------------------------------------------
    ("yaml", "syntax error", {}, "battery: {capacity: [\n", "s.yaml:2:1: invalid YAML"),
    ("yaml", "duplicate key", {}, "battery:\n  capacity: 1\n  capacity: 2\n", "s.yaml:3:3"),
    ("yaml", "duplicate top key", {}, "name: a\nname: b\n", "duplicate key 'name'"),
    ("yaml", "not UTF-8", {}, b"name: \xe9t\xe9\n", "s.yaml:1:7"),
    ("yaml", "not a mapping", {}, "- 1\n- 2\n", "mapping"),
    ("yaml", "unknown key", {}, "battery: {capasity: 3}\n", "battery.capasity"),
    ("yaml", "wrong type", {}, "battery: {capacity: three}\n", "battery.capacity"),
    ("yaml", "string for a bool", {}, "computation: {integer: 'false'}\n", "computation.integer"),
    (
        "yaml",
        "yes for a bool",
        {},
        "sensor: {averaging: yes}\n",
        "sensor.averaging: expected true or false, got 'yes'",
    ),
    ("yaml", "table named on", {}, "computation: {table: on}\n", "/on': no such file"),
    ("yaml", "removed planner switch", {}, "planner: {enabled: false}\n", "switch is 'policy'"),
    # -- upper bounds on work ------------------------------------------------------------------
    ("bounds", "sensor rate", {}, "sensor: {rate: 1e6}\n", "sensor.rate"),
    ("bounds", "estimator rate", {}, "estimator: {rate: 1e6}\n", "estimator.rate"),
    ("bounds", "log period", {}, "simulation: {log_period: 1e-9}\n", "simulation.log_period"),
    ("bounds", "time limit", {}, "simulation: {time_limit: 1e9}\n", "simulation.time_limit"),
    ("bounds", "max step", {}, "simulation: {max_step: 1e-9}\n", "simulation.max_step"),
    (
        "bounds",
        "steps",
        {},
        "simulation: {time_limit: 19000}\nsensor: {rate: 1000}\n",
        "simulation.time_limit",
    ),
    ("bounds", "horizon", {}, "planner: {horizon: 1000}\n", "planner.horizon"),
    # -- rates: every rate an integer multiple of one base (issue 14) ----------------------------
    ("rates", "sensor off the base", {}, "sensor: {rate: 30}\n", "sensor.rate: its period must"),
    (
        "rates",
        "estimator off the base",
        {},
        "simulation: {max_step: 0.05}\nsensor: {rate: 20}\nestimator: {rate: 15}\n",
        "estimator.rate: its period must be an integer multiple of the base period 0.05 s",
    ),
    (
        "rates",
        "plant off the base",
        {},
        "simulation: {max_step: 0.015}\n",
        "simulation.max_step: its period must",
    ),
    (
        "rates",
        "averaging above the base",
        {},
        "simulation: {max_step: 0.05}\nsensor: {averaging: true}\n",
        "sensor.rate: with sensor.averaging must be <= 1 / simulation.max_step = 20 Hz",
    ),
    (
        "rates",
        "native rate below the averaging sensor's",
        {},
        "sensor: {rate: 100, averaging: true, native_rate: 50}\n",
        "sensor.native_rate: with sensor.averaging must be an integer multiple of sensor.rate",
    ),
    (
        "rates",
        "estimator faster than the averaging sensor",
        {},
        "sensor: {rate: 10, averaging: true}\n",
        "estimator.rate: with sensor.averaging must be <= sensor.rate = 10 Hz",
    ),
    ("bounds", "planner period", {}, "planner: {period: 1e-4}\n", "planner.period"),
    (
        "bounds",
        "huge field",
        {},
        "coverage: {polygon: [[0, 0], [1e7, 0], [1e7, 1e7], [0, 1e7]]}\n",
        "coverage.polygon",
    ),
    (
        "bounds",
        "many faults",
        {},
        "battery: {faults: [" + ", ".join(["{time: 1, soc_drop: 0.001}"] * 101) + "]}\n",
        "battery.faults",
    ),
    # -- cross-field constraints ---------------------------------------------------------------
    (
        "cross",
        "reserve above initial",
        {},
        "battery: {initial_soc: 0.3, reserve_soc: 0.3}\n",
        "battery.reserve_soc",
    ),
    (
        "cross",
        "empty c1(0)",
        {},
        "planner: {initial_path_parameters: []}\n",
        "planner.initial_path_parameters",
    ),
    (
        "cross",
        "trigger radius huge",
        {},
        "coverage: {trigger_radius: 1e9}\n",
        "coverage.trigger_radius",
    ),
    (
        "cross",
        "circle beyond the bank limit",
        {},
        "vehicle: {max_bank_angle_deg: 5}\n",
        "coverage.min_turning_radius",
    ),
    ("cross", "circle in too much wind", {}, "wind: {speed: 14}\n", "coverage.min_turning_radius"),
    ("cross", "wind above airspeed", {}, "wind: {speed: 20}\n", "wind.speed"),
    (
        "cross",
        "equal c1 bounds",
        {},
        "planner: {path_parameter_bounds: [0, 0]}\n",
        "planner.path_parameter_bounds: need c1_min = r_min² − r² <= lo < hi <= 0 [m²] "
        "(r2 = sqrt(r² + c1) may not exceed r), got [0, 0]",
    ),
    (
        "cross",
        "c1 bounds below r_min",
        {},
        "planner: {path_parameter_bounds: [-5000, 0]}\n",
        "planner.path_parameter_bounds: need c1_min = r_min² − r² = -1000 <= lo",
    ),
    (
        "cross",
        "exponential fault sizes of mean 1",
        {},
        "planner: {fault_model: {sizes: exponential, size_mean: 1}}\n",
        "planner.fault_model.size_mean",
    ),
    (
        "cross",
        "a survey longer than the risk tables price",
        {},
        "vehicle: {airspeed: 0.001}\nwind: {speed: 0}\n",
        "planner.fault_model.rate: 0.003/s × 4077167 s of survey at the lowest plan "
        "(vehicle.airspeed = 0.001 m/s",
    ),
    # -- numerics ------------------------------------------------------------------------------
    (
        "numerics",
        "huge covariance",
        {},
        "estimator: {initial_covariance: 1e300}\n",
        "estimator.initial_covariance",
    ),
    (
        "numerics",
        "huge process noise",
        {},
        "estimator: {process_noise: 1e300}\n",
        "estimator.process_noise",
    ),
    ("numerics", "infinite capacity", {}, "battery: {capacity: .inf}\n", "battery.capacity"),
    ("numerics", "huge guidance gain", {}, "guidance: {k_e: 1e300}\n", "guidance.k_e"),
    (
        "numerics",
        "far initial position",
        {},
        "vehicle: {initial_position: [1e100, 0]}\n",
        "vehicle.initial_position[0]",
    ),
    # -- output --------------------------------------------------------------------------------
    ("output", "name with ..", {}, "name: ../../x\n", "name"),
    ("output", "absolute name", {}, "name: /tmp/x\n", "name"),
    ("output", "empty name", {}, "name: ''\n", "name"),
    ("output", "hidden name", {}, "name: .x\n", "name"),
]
CATEGORIES = sorted({c[0] for c in CASES})


def _ScenarioFile(tmp_path, case) -> Path:
    category, _, files, yaml_text, _ = case
    for name, text in files.items():
        (tmp_path / name).write_bytes(text if isinstance(text, bytes) else text.encode())
    body = yaml_text if isinstance(yaml_text, bytes) else yaml_text.encode()
    if category == "table" and b"table:" not in body:
        body = _Merge(body, b"computation", b"table: t.csv")
    if category == "plan" and b"plan_file:" not in body:
        body = _Merge(body, b"coverage", b"plan_file: p.pln")
    path = tmp_path / "s.yaml"
    path.write_bytes(body)
    return path


def _Merge(body: bytes, section: bytes, entry: bytes) -> bytes:
    """Adds ``entry`` to the flow mapping ``section: {...}`` of ``body``, or a new section."""
    start = body.find(section + b": {")
    if start < 0:
        return body + section + b": {" + entry + b"}\n"
    at = start + len(section) + 3
    return body[:at] + entry + b", " + body[at:]


def _Ids(cases):
    return [f"{c[0]}-{c[1]}" for c in cases]


@pytest.mark.parametrize("case", CASES, ids=_Ids(CASES))
def test_cli_bad_input_is_one_line_exit_2(case, tmp_path, capsys):
    scenario = _ScenarioFile(tmp_path, case)
    out = tmp_path / "out"
    status = _Bounded(cli_main, ["simulate", str(scenario), "--out", str(out)])
    err = capsys.readouterr().err
    assert status == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("eaplan-drake: scenario error: ")
    assert case[4] in lines[0], lines[0]
    assert "Traceback" not in err
    assert not out.exists()  # failed before any flight or file


@pytest.mark.parametrize("case", CASES, ids=_Ids(CASES))
def test_api_bad_input_raises_scenario_error(case, tmp_path):
    scenario = _ScenarioFile(tmp_path, case)

    def load_and_resolve():
        return ResolveScenario(LoadScenario(filename=scenario))

    with pytest.raises(ScenarioError) as info:
        _Bounded(load_and_resolve)
    assert case[4] in str(info.value)
    assert "\n" not in str(info.value)


def test_cli_subprocess_bad_table_and_plan_are_one_line(tmp_path):
    """The real process: no traceback, exit status 2, one line (table, then plan)."""
    for case in (CASES[0], CASES[_Ids(CASES).index("plan-flat 2000-term sum")]):
        folder = tmp_path / case[1].replace(" ", "_")
        folder.mkdir()
        scenario = _ScenarioFile(folder, case)
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        run = subprocess.run(
            [sys.executable, "-m", "eaplan_drake", "simulate", str(scenario), "--out", str(folder)],
            capture_output=True,
            text=True,
            timeout=120,
            env=env,
            cwd=tmp_path,
        )
        assert run.returncode == 2, run.stderr
        assert len(run.stderr.strip().splitlines()) == 1, run.stderr
        assert case[4] in run.stderr


@pytest.mark.parametrize(
    "assignment, expected",
    [
        ("sensor.rate=30", "sensor.rate: its period must be an integer multiple"),
        ("estimator.rate=7", "estimator.rate: its period must be an integer multiple"),
        ("computation.integer=off", "computation.integer: expected true or false, got 'off'"),
        ("planner.path_parameter_bounds=[-10, -10]", "planner.path_parameter_bounds: need"),
        ("planner.enabled=false", "planner.enabled: unknown key"),
    ],
)
def test_cli_bad_value_from_set_is_one_line(assignment, expected, tmp_path, capsys):
    out = tmp_path / "out"
    status = _Bounded(cli_main, ["simulate", "plan_i", "--set", assignment, "--out", str(out)])
    err = capsys.readouterr().err
    assert status == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and expected in lines[0], err
    assert "array(" not in err and "Traceback" not in err
    assert not out.exists()


def test_relative_paths_resolve_against_the_scenario_folder(tmp_path, monkeypatch):
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "t.csv").write_text(TABLE)
    (tmp_path / "sub" / "s.yaml").write_text(
        "computation: {table: t.csv, initial_parameters: [5]}\n"
    )
    monkeypatch.chdir(tmp_path)  # not the scenario's folder
    resolved = ResolveScenario(LoadScenario(filename="sub/s.yaml"))
    np.testing.assert_allclose(resolved.table.power([5.0]), 7.4, rtol=0, atol=1e-12)


@pytest.mark.parametrize("text", ["1e3", "5e-1", "3.2e0", "-2E+1"])
def test_scientific_notation_without_a_dot_is_a_number(text):
    s = LoadScenario(data=f"vehicle: {{initial_heading_deg: {text}}}\n")
    assert s.vehicle.initial_heading_deg == pytest.approx(float(text), rel=0, abs=0)


def test_duplicate_key_names_both_lines():
    with pytest.raises(ScenarioError, match=r"<yaml>:3:1: invalid YAML: duplicate key 'wind'"):
        LoadScenario(data="wind: {speed: 1}\nname: a\nwind: {speed: 2}\n")


# -- Python API misuse -----------------------------------------------------------------------


def test_api_simulate_checks_its_arguments():
    from eaplan_drake.loading import LoadNamedScenario
    from eaplan_drake.output.save import SaveFlight
    from eaplan_drake.simulation import Simulate

    for bad in ("plan_i", None, {"battery": {}}):
        with pytest.raises(ScenarioError, match="Simulate: scenario: expected a Scenario"):
            Simulate(bad)
    with pytest.raises(ScenarioError, match="progress_interval"):
        Simulate(Scenario(), progress_interval=float("nan"))
    with pytest.raises(ScenarioError, match="progress: expected a callable"):
        Simulate(Scenario(), progress=3)
    with pytest.raises(ScenarioError, match="policy: expected a PlannerPolicy"):
        Simulate(Scenario(), policy="mpc")
    with pytest.raises(ScenarioError, match="LoadNamedScenario: expected"):
        LoadNamedScenario(None)
    with pytest.raises(ScenarioError, match="log: expected a FlightLog"):
        SaveFlight("log", Scenario(), "out")


def test_api_dict_where_params_belong_is_named():
    s = Scenario()
    s.battery = {"capacity": 3.0}
    with pytest.raises(ScenarioError, match=r"^battery: expected a BatteryParams, got dict"):
        s.Validate()
    s = Scenario()
    s.battery.faults = [{"time": 1.0, "soc_drop": 0.1}]
    with pytest.raises(ScenarioError, match=r"^battery.faults\[0\]: expected a BatteryFault"):
        s.Validate()


def test_api_numpy_integers_accepted_booleans_strict():
    s = Scenario()
    s.sensor.seed = np.int64(7)
    s.planner.horizon = np.int32(4)
    s.energy_model.order = np.uint8(2)
    s.Validate()
    assert type(s.sensor.seed) is int and s.sensor.seed == 7
    assert type(s.planner.horizon) is int and s.planner.horizon == 4
    s.computation.integer = "false"
    with pytest.raises(ScenarioError, match="computation.integer: expected true or false"):
        s.Validate()
    s.computation.integer = True
    s.battery.capacity = True
    with pytest.raises(ScenarioError, match="battery.capacity: expected a number"):
        s.Validate()


def test_plant_refuses_a_non_finite_command():
    x = np.array([0.0, 0.0, 0.0])
    for u in (np.nan, np.inf, -np.inf):
        with pytest.raises(NonFiniteCommandError, match="heading_rate_command"):
            FixedWingDynamics(x, u, [0.0, 0.0], 15.0, 0.65)
    np.testing.assert_allclose(FixedWingDynamics(x, 10.0, [1.0, 0.0], 15.0, 0.65), [16, 0, 0.65])


def test_plant_system_refuses_a_non_finite_command():
    from eaplan_drake.flight.plant import FixedWingPlant
    from eaplan_drake.params import VehicleParams

    plant = FixedWingPlant(VehicleParams())
    context = plant.CreateDefaultContext()
    plant.GetInputPort("wind").FixValue(context, [0.0, 0.0])
    plant.GetInputPort("heading_rate_command").FixValue(context, [np.nan])
    with pytest.raises(NonFiniteCommandError):
        plant.EvalTimeDerivatives(context)
    with pytest.raises(NonFiniteCommandError):
        plant.GetOutputPort("motion_power").Eval(context)


# -- the plain functions of the resolution step ----------------------------------------------


def test_peak_circle_heading_rate_matches_the_analytic_cases():
    # Still air: ψ̇ = v_a / R everywhere.
    assert PeakCircleHeadingRate(50.0, 15.0, 0.0) == pytest.approx(0.3, rel=1e-12)
    # In wind the peak is downwind (β = 0): (v_a + w)² / (R v_a).
    for w in (1.0, 5.0, 10.0, 14.0):
        assert PeakCircleHeadingRate(62.45, 15.0, w) == pytest.approx(
            (15.0 + w) ** 2 / (62.45 * 15.0), rel=1e-12
        )
    with pytest.raises(ValueError):
        PeakCircleHeadingRate(50.0, 15.0, 15.0)


def test_trigger_distance_of_lines_and_circles():
    from eaplan_drake.flight.paths import Circle, Line

    line = Line([0.0, 0.0], [0.0, 1.0], k_e=0.05).normalised()
    assert TriggerDistance(line, [3.0, -2.5]) == pytest.approx(2.5, abs=1e-12)
    circle = Circle([1.0, 1.0], 10.0, k_e=0.05).normalised()
    assert TriggerDistance(circle, [1.0, 31.0]) == pytest.approx(20.0, abs=1e-9)
    assert TriggerDistance(circle, [1.0, 1.0]) == pytest.approx(10.0, abs=1e-9)


def test_shipped_scenarios_resolve():
    from eaplan_drake.loading import LoadNamedScenario
    from eaplan_drake.simulation import REFERENCE_SCENARIOS

    for name in (*REFERENCE_SCENARIOS, "survey"):
        resolved = ResolveScenario(LoadNamedScenario(name))
        assert resolved.table.num_parameters == 1


# -- output -----------------------------------------------------------------------------------


def test_summary_is_strict_json(tmp_path):
    from eaplan_drake.flightlog import FlightLog, LoadFlightLog

    log = FlightLog(
        times=np.array([0.0, 1.0]),
        signals={"soc": np.array([[1.0], [0.9]])},
        summary={"metric": np.float64("nan"), "x": [np.inf, 1], "n": np.int64(3)},
    )
    log.Save(tmp_path / "run")
    text = (tmp_path / "run" / "summary.json").read_text()
    summary = json.loads(text, parse_constant=lambda c: pytest.fail(f"non-JSON {c}"))
    assert summary == {"metric": None, "x": [None, 1], "n": 3}
    assert LoadFlightLog(tmp_path / "run").summary == summary


def test_result_directory_is_replaced_as_a_unit(tmp_path):
    from eaplan_drake.files import ResultDirectory

    final = tmp_path / "run"
    with ResultDirectory(final) as tmp:
        (tmp / "old_figure.png").write_text("old")
        (tmp / "log").write_text("1")
    with pytest.raises(RuntimeError):
        with ResultDirectory(final) as tmp:
            (tmp / "log").write_text("2")
            raise RuntimeError("interrupted")
    assert sorted(p.name for p in final.iterdir()) == ["log", "old_figure.png"]
    assert (final / "log").read_text() == "1"
    with ResultDirectory(final) as tmp:
        (tmp / "log").write_text("3")
    assert sorted(p.name for p in final.iterdir()) == ["log"]  # no old figure beside the new log
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]  # no temporary left


# -- kill tests -------------------------------------------------------------------------------


def _SaveLoop(out: str, started) -> None:
    """Saves flights of increasing generation g into ``out`` forever (run in a forked child)."""
    from eaplan_drake.flightlog import FlightLog
    from eaplan_drake.output.save import SaveFlight

    n = 200
    t = np.linspace(0.0, 20.0, n)
    sizes = {"position": 2, "energy_coefficients": 7}
    started.set()
    for g in range(10**6):
        signals = {name: np.zeros((n, sizes.get(name, 1))) for name in LOGGED_SIGNALS}
        signals["generation"] = np.full((n, 1), float(g))
        signals["position"][:, 0] = t
        summary = {"generation": g, "status": "time_limit", "duration": 20.0, "metric": None}
        SaveFlight(FlightLog(times=t, signals=signals, summary=summary), Scenario(), out)


def _CheckResultDirectory(final: Path) -> None:
    """``final`` is absent or complete and of one generation; nothing else in its folder but
    temporaries named with a pid."""
    from eaplan_drake.flightlog import LoadFlightLog

    if final.exists():
        assert sorted(p.name for p in final.iterdir()) == ["flight.png", "log.npz", "summary.json"]
        log = LoadFlightLog(final)
        assert log.summary["generation"] == int(log["generation"][0, 0])
        png = (final / "flight.png").read_bytes()
        assert png.startswith(b"\x89PNG") and png.endswith(b"IEND\xaeB`\x82")


@pytest.mark.slow
def test_kill_during_save_leaves_no_half_written_or_orphaned_file(tmp_path):
    import multiprocessing

    from eaplan_drake.files import ResultDirectory

    rng = random.Random(10)
    final = tmp_path / "out" / "run"
    fork = multiprocessing.get_context("fork")  # the imports are done in the children
    for _ in range(5):  # a save takes 1–3 s here: the kills land in all of its phases
        started = fork.Event()
        child = fork.Process(target=_SaveLoop, args=(str(final), started), daemon=True)
        child.start()
        try:
            assert started.wait(timeout=60)
            time.sleep(rng.uniform(0.0, 3.0))
        finally:
            os.kill(child.pid, signal.SIGKILL)
            child.join(timeout=60)
        _CheckResultDirectory(final)
    # The next save removes what the killed processes left (pid-named temporaries).
    with ResultDirectory(final) as tmp:
        (tmp / "x").write_text("x")
    assert sorted(p.name for p in final.parent.iterdir()) == ["run"]
    assert sorted(p.name for p in final.iterdir()) == ["x"]


@pytest.mark.slow
def test_kill_during_a_run_leaves_no_half_written_file(tmp_path):
    rng = random.Random(11)
    scenario = tmp_path / "short.yaml"
    scenario.write_text("name: short\nsimulation: {time_limit: 5.0}\n")
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    for _ in range(2):
        proc = subprocess.Popen(
            [sys.executable, "-m", "eaplan_drake", "simulate", str(scenario), "--out", str(out)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        try:
            assert proc.stderr.readline().startswith("simulating short")  # imports done
            time.sleep(rng.uniform(0.0, 3.0))
        finally:
            proc.send_signal(signal.SIGKILL)
            proc.wait(timeout=60)
        if (out / "short").exists():
            names = sorted(p.name for p in (out / "short").iterdir())
            assert names == ["flight.png", "log.npz", "summary.json"]
            json.loads((out / "short" / "summary.json").read_text())
    assert cli_main(["simulate", str(scenario), "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["short"]
    assert sorted(p.name for p in (out / "short").iterdir()) == [
        "flight.png",
        "log.npz",
        "summary.json",
    ]


# -- numerics at run time ---------------------------------------------------------------------


def test_a_non_finite_estimate_ends_the_flight_with_numerical_failure(monkeypatch):
    """An estimator whose covariance turns NaN after 3 s (a stand-in for any numerical
    breakdown) ends the flight at the next check with status numerical_failure."""
    from eaplan_drake.energy.estimator import EnergyEstimator
    from eaplan_drake.simulation import NUMERICS_CHECK_PERIOD, Simulate

    update = EnergyEstimator._Update

    def broken(self, context, discrete_state):
        update(self, context, discrete_state)
        if context.get_time() >= 3.0:
            discrete_state.get_mutable_value(self._state_index)[self._P_part][0] = np.nan  # P[0, 0]

    monkeypatch.setattr(EnergyEstimator, "_Update", broken)
    scenario = LoadScenario(data="planner: {warmup: 60}\nsimulation: {time_limit: 20.0}\n")
    log = Simulate(scenario)
    assert log.summary["status"] == "numerical_failure"
    assert 3.0 <= log.summary["duration"] <= 3.0 + NUMERICS_CHECK_PERIOD + 0.011
    json.loads(json.dumps(log.summary, allow_nan=False))


def test_largest_accepted_variances_keep_the_log_finite():
    from eaplan_drake.params import MAX_VARIANCE
    from eaplan_drake.simulation import Simulate

    scenario = LoadScenario(
        data=f"estimator: {{initial_covariance: {MAX_VARIANCE}, process_noise: {MAX_VARIANCE}, "
        "measurement_noise: 1e-9}\nplanner: {warmup: 60}\nsimulation: {time_limit: 10.0}\n"
    )
    log = Simulate(scenario)
    assert log.summary["status"] == "time_limit"
    for name, values in log.signals.items():
        if name == "predicted_soc":  # NaN until the planner acts (here: never)
            assert not np.any(np.isinf(values)), name
        elif name != "measured_power":  # a dropped sample is NaN by design (sensor.py)
            assert np.all(np.isfinite(values)), name


def test_cli_unusable_out_is_one_line_before_the_flight(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    status = _Bounded(cli_main, ["simulate", "plan_i", "--out", str(blocker / "sub")])
    err = capsys.readouterr().err
    assert status == 2
    assert err.strip().splitlines() == [
        f"eaplan-drake: file error: {blocker / 'sub'}: Not a directory"
    ]


def test_a_full_disk_names_the_file_it_could_not_write(tmp_path):
    """ENOSPC from a write carries no file name: the error names the file, and nothing of it is
    left behind."""
    import errno

    from eaplan_drake.files import AtomicWrite

    def full(f):
        raise OSError(errno.ENOSPC, "No space left on device")

    target = tmp_path / "summary.json"
    with pytest.raises(OSError) as info:
        AtomicWrite(target, full, binary=False)
    assert info.value.errno == errno.ENOSPC and info.value.filename == str(target)
    assert list(tmp_path.iterdir()) == []


def test_a_field_flight_that_ends_before_its_first_line_keeps_its_log(tmp_path, capsys):
    """A brown-out, an early fault or a short time limit before the first survey line: the log,
    summary and figure are saved, and the missions as flown (nothing to export) are skipped with
    a line in the summary."""
    args = ["simulate", "funen", "--out", str(tmp_path)]
    args += ["--set", "battery.faults=[{time: 5, soc_drop: 0.75}]"]
    assert _Bounded(cli_main, args) == 0
    out = capsys.readouterr().out
    assert "not written     the missions as flown: the flight ended before its first" in out
    saved = sorted(p.name for p in (tmp_path / "funen").iterdir())
    assert saved == ["flight.png", "log.npz", "summary.json"]
    summary = json.loads((tmp_path / "funen" / "summary.json").read_text())
    assert summary["skipped_exports"] and summary["status"] == "reserve_reached"
