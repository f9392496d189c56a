"""The simulation (eaplan_drake.simulation): the event times, progress chunks, and how a flight
ends (short flights)."""

import numpy as np

from eaplan_drake.energy.battery import STATUS_BROWNOUT, STATUS_RESERVE
from eaplan_drake.loading import LoadScenario
from eaplan_drake.resolve import ResolveScenario
from eaplan_drake.simulation import EndReason, Simulate, _EventTime

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
    without = Simulate(ResolveScenario(scenario))  # resolved by the caller: the same flight
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
