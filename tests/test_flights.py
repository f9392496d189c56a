"""The four reference flights of paper 003 Sec. V end to end (the acceptance test of the loop).

Each flight is simulated once per test session (≈ 5–12 s wall each).
"""

import json

import numpy as np
import pytest

from eaplan_drake.cli import main as cli_main
from eaplan_drake.loading import LoadNamedScenario
from eaplan_drake.simulation import Simulate

pytestmark = pytest.mark.slow

_LOGS = {}


def _Flight(name):
    if name not in _LOGS:
        _LOGS[name] = Simulate(LoadNamedScenario(name))
    return _LOGS[name]


def _Finite(log):
    for name, values in log.signals.items():
        if name == "measured_power":  # dropped samples would be NaN (none in these scenarios)
            continue
        if name == "predicted_soc":  # NaN until the planner acts, and for a policy with no plan
            assert not np.any(np.isinf(values)), name
            continue
        assert np.all(np.isfinite(values)), name


def test_plan_I_static_full_quality_fails_at_the_reserve():
    log = _Flight("plan_I")
    s = log.summary
    assert s["status"] == "reserve_reached"
    assert not s["completed"] and s["metric"] is None
    assert s["final_soc"] == pytest.approx(0.30, abs=2e-3)
    assert log["coverage_remaining"][-1, 0] > 0.2  # far from done
    np.testing.assert_array_equal(log["path_parameters"][:, 0], 0.0)
    np.testing.assert_array_equal(log["computation_parameters"][:, 0], 10.0)
    assert s["planner"]["solves"] == 0
    _Finite(log)


def test_plan_II_static_lowest_quality_completes_with_zero_metric():
    log = _Flight("plan_II")
    s = log.summary
    assert s["status"] == "complete"
    assert s["metric"] == 0.0
    assert s["final_soc"] > 0.5
    # Coverage time at c1 = −1000 in 5 m/s wind: the paper's 318.7 s within 10 %.
    assert s["duration"] == pytest.approx(318.7, rel=0.10)
    _Finite(log)


def test_plan_i_completes_above_the_reserve_cutting_c1_at_each_fault():
    log = _Flight("plan_i")
    s = log.summary
    assert s["status"] == "complete"
    assert s["final_soc"] > 0.30
    assert s["metric"] is not None and s["metric"] > 0.0
    assert s["planner"]["failures"] == 0
    t, c1 = log.times, log["path_parameters"][:, 0]
    for fault in (93.0, 270.0):
        before = c1[np.searchsorted(t, fault) - 1]
        after = c1[np.searchsorted(t, fault + 3.0)]
        assert after < before, f"c1 not cut after the fault at {fault} s"
    # Shorter than a c1 = 0 survey (≈ 767 s in this wind), longer than a c1 = −1000 one (≈ 288 s).
    assert 300.0 < s["duration"] < 700.0
    _Finite(log)


def test_plan_ii_raises_c1_once_the_estimate_is_ready_and_completes():
    log = _Flight("plan_ii")
    s = log.summary
    assert s["status"] == "complete"
    assert s["final_soc"] > 0.30
    t, c1 = log.times, log["path_parameters"][:, 0]
    first_rise = t[np.flatnonzero(c1 > -1000.0)[0]]
    assert 60.0 <= first_rise <= 100.0  # the paper: ≈ 85 s
    assert s["metric"] > 0.0
    _Finite(log)


def test_cli_simulate_writes_log_and_plots(tmp_path, capsys):
    scenario = tmp_path / "short.yaml"
    scenario.write_text("name: short\nsimulation: {time_limit: 20.0}\n")
    assert cli_main(["simulate", str(scenario), "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "time_limit" in out
    assert sorted(p.name for p in (tmp_path / "short").iterdir()) == [
        "flight.png",
        "log.npz",
        "summary.json",
    ]


def test_cli_simulate_at_the_fast_rates(tmp_path, capsys):
    scenario = tmp_path / "short.yaml"
    scenario.write_text("name: short\nsimulation: {time_limit: 20.0}\n")
    assert cli_main(["simulate", str(scenario), "--rates", "fast", "--out", str(tmp_path)]) == 0
    assert "time_limit" in capsys.readouterr().out
    log = np.load(tmp_path / "short_fast" / "log.npz")
    summary = json.loads((tmp_path / "short_fast" / "summary.json").read_text())
    assert summary["duration"] == pytest.approx(20.0)
    assert np.all(np.isfinite(log["soc"]))


def test_cli_simulate_applies_the_rate_preset_before_set(tmp_path, capsys):
    # As a study's rates and set: --set comes last, so a rate it sets is checked, not overwritten.
    args = ["simulate", "plan_I", "--rates", "fast", "--set", "sensor.rate=30", "--out"]
    assert cli_main([*args, str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith("eaplan-drake: scenario error: simulation.max_step: its period must")
    assert "(sensor.rate; every rate an integer multiple of one base" in err[0]


def test_cli_bad_scenario_is_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("battery: {capacity: -3}\n")
    assert cli_main(["simulate", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == "eaplan-drake: scenario error: battery.capacity: must be > 0, got -3"
    assert cli_main(["simulate", "no_such_plan"]) == 2
    assert "not a YAML file nor a shipped scenario" in capsys.readouterr().err
