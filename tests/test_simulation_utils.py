"""Pieces of the simulation layer: metric, log files, DOT canonicalisation (no flight), and how
a flight ends (short flights)."""

import json

import numpy as np
import pytest

from eaplan_drake.energy.battery import STATUS_BROWNOUT, STATUS_RESERVE
from eaplan_drake.flightlog import FlightLog, LoadFlightLog, QualityMetric
from eaplan_drake.loading import LoadScenario
from eaplan_drake.output.graphviz import CanonicalDot
from eaplan_drake.simulation import EndReason, Simulate, _EventTime


def test_metric_matches_hand_computation():
    t = np.linspace(0.0, 100.0, 101)
    c1 = np.where(t < 50.0, 0.0, -1000.0)[:, None]  # c̃1 = 1 then 0
    c2 = np.full((101, 1), 6.0)  # c̃2 = 0.5 on [2, 10]
    metric, m1, m2 = QualityMetric(t, c1, c2, (-1000.0, 0.0), ([2.0], [10.0]), 0.40, 0.30, True)
    assert m1 == pytest.approx(0.5, abs=0.01)
    assert m2 == pytest.approx(0.5, abs=1e-12)
    assert metric == pytest.approx((0.5 * m1 + 0.5 * m2) / 0.10, rel=1e-12)


def test_metric_fails_below_reserve_or_incomplete():
    t = np.array([0.0, 1.0])
    c = np.zeros((2, 1))
    assert QualityMetric(t, c, c + 10, (-1000, 0), ([2], [10]), 0.29, 0.30, True)[0] is None
    assert QualityMetric(t, c, c + 10, (-1000, 0), ([2], [10]), 0.50, 0.30, False)[0] is None
    # Lowest parameters throughout: P = 0 (plan II).
    low = QualityMetric(t, c - 1000, c + 2, (-1000, 0), ([2], [10]), 0.6, 0.3, True)
    assert low[0] == 0.0


def test_log_round_trip_and_atomic_files(tmp_path):
    log = FlightLog(
        times=np.arange(5.0),
        signals={"soc": np.linspace(1, 0.9, 5)[:, None], "position": np.ones((5, 2))},
        summary={"status": "complete", "metric": None, "duration": 4.0},
    )
    log.Save(tmp_path / "run")
    back = LoadFlightLog(tmp_path / "run")
    np.testing.assert_array_equal(back.times, log.times)
    np.testing.assert_array_equal(back["position"], log["position"])
    assert back.summary == log.summary
    assert json.loads((tmp_path / "run" / "summary.json").read_text())["status"] == "complete"
    assert sorted(p.name for p in (tmp_path / "run").iterdir()) == ["log.npz", "summary.json"]


def test_canonical_dot_renumbers_ids_in_order():
    a = "digraph _17 {\nsubgraph cluster17diagram {\ns12 -> s13\ns17in:0:e -> s12:u0:w\n}}"
    b = "digraph _4 {\nsubgraph cluster4diagram {\ns2 -> s3\ns4in:0:e -> s2:u0:w\n}}"
    assert CanonicalDot(a) == CanonicalDot(b)
    assert CanonicalDot(a).startswith("digraph _0 {")


# -- termination and chunks (short flights) ----------------------------------------------------


def test_event_time_is_the_periodic_event_time_drake_computes():
    h = 0.01
    for t in [0.0, 0.005, 0.37, 1.0, 3.0, 59.999, 60.0, 123.456, 394.65, 1500.0]:
        k = round(t / h)
        k = k + 1 if k * h < t else k
        assert _EventTime(t, h) == k * h  # the same product, bit for bit
        assert t <= _EventTime(t, h) < t + h
    for n in range(1, 1500):  # whole seconds land on the 100 Hz grid, not one step later
        assert _EventTime(float(n), h) == round(n / h) * h == n


def test_progress_chunks_do_not_change_the_flight():
    scenario = LoadScenario(data="simulation: {time_limit: 3.0}\n")
    calls = []
    with_progress = Simulate(scenario, lambda t, b, c: calls.append((t, b, c)), 0.37)
    without = Simulate(scenario)
    np.testing.assert_array_equal(with_progress.times, without.times)
    for name, values in without.signals.items():
        np.testing.assert_array_equal(with_progress[name], values, err_msg=name)
    times = [t for t, _, _ in calls]
    assert len(times) == 8  # 0.37, 0.74, …, 2.96 s, each at the next 100 Hz update
    for k, t in enumerate(times, start=1):
        assert 0.37 * k <= t < 0.37 * k + 0.01 + 1e-9
    assert all(0.0 < b <= 1.0 and 0.0 <= c <= 1.0 for _, b, c in calls)


def test_reserve_ends_the_flight_at_the_battery_update_that_reaches_it():
    scenario = LoadScenario(data="battery: {reserve_soc: 0.995}\nsimulation: {time_limit: 60}\n")
    log = Simulate(scenario)
    s = log.summary
    assert s["status"] == STATUS_RESERVE == "reserve_reached"
    assert not s["completed"] and s["metric"] is None
    assert 0.995 - 1e-4 < s["final_soc"] <= 0.995  # one 10 ms step at ≈ 30 W is ≈ 1.6e-5
    assert s["duration"] == round(s["duration"] / 0.01) * 0.01  # an update time of the battery
    assert 1.0 < s["duration"] < 60.0


def test_brownout_ends_the_flight_at_the_first_update():
    # V²/(4 R_r) = 14.8² / 8 ≈ 27 W: the ≈ 30 W load cannot be delivered.
    scenario = LoadScenario(data="battery: {internal_resistance: 2.0}\n")
    log = Simulate(scenario)
    assert log.summary["status"] == STATUS_BROWNOUT == "brownout"
    assert log.summary["duration"] == 0.0
    assert log.summary["final_soc"] == 1.0


def test_end_reason_names_each_status():
    scenario = LoadScenario(data="simulation: {time_limit: 100}\n")
    assert EndReason("complete", 394.65, scenario, 0.0) == "survey complete at 394.6 s"
    assert "reserve SoC 0.3 at 12.0 s, 40 % of the survey left" in EndReason(
        "reserve_reached", 12.0, scenario, 0.4
    )
    assert EndReason("brownout", 0.0, scenario, 1.0).startswith("battery browned out")
    assert EndReason("time_limit", 100.0, scenario, 0.5).startswith("time limit 100 s reached")
    assert EndReason("ended by x: stop", 5.0, scenario, 0.5) == (
        "ended by x: stop at 5.0 s, 50 % of the survey left"
    )
