"""Rate presets (eaplan_drake.rates): applying them, the studies' default, the tolerances, and one
flight at the fast rates against the paper's (the rule of one base period:
tests/test_params_periods.py; ticked updates: tests/test_ticks.py)."""

import dataclasses as dc

import numpy as np
import pytest

from eaplan_drake.errors import ScenarioError
from eaplan_drake.loading import LoadNamedScenario
from eaplan_drake.rates import (
    DEFAULT_STUDY_RATES,
    RATE_PRESETS,
    RATE_TOLERANCES,
    FlightDifferences,
    RateSetting,
    RescaledProcessNoise,
    WithinRateTolerances,
    WithRates,
)
from eaplan_drake.simulation import Simulate
from eaplan_drake.studies.sweep import LoadStudy, StudyFlights


def test_rescaled_process_noise_keeps_the_variance_per_second():
    assert RescaledProcessNoise(1e-6, 100.0, 100.0) == 1e-6
    assert RescaledProcessNoise(1e-6, 100.0, 20.0) == pytest.approx(5e-6, rel=1e-15)
    # Variance per second = q · f: the same before and after.
    q = RescaledProcessNoise(3e-6, 50.0, 10.0)
    assert q * 10.0 == pytest.approx(3e-6 * 50.0, rel=1e-15)


def test_paper_preset_changes_nothing_on_a_shipped_scenario():
    for name in ("plan_I", "plan_i"):
        s = LoadNamedScenario(name)
        assert WithRates(s, "paper") == s


def test_fast_preset_sets_every_rate_and_rescales_the_process_noise():
    base = LoadNamedScenario("plan_i")
    base.estimator.mean_process_noise = 2e-6
    fast = RATE_PRESETS["fast"]
    s = WithRates(base, "fast")
    assert s.simulation.max_step == 1.0 / fast.plant
    assert (s.sensor.rate, s.sensor.averaging, s.estimator.rate) == (
        fast.sensor,
        fast.averaging,
        fast.estimator,
    )
    scale = base.estimator.rate / fast.estimator
    assert s.estimator.process_noise == pytest.approx(base.estimator.process_noise * scale)
    assert s.estimator.mean_process_noise == pytest.approx(2e-6 * scale)
    assert base.simulation.max_step == 0.01  # the argument is not modified
    assert WithRates(s, "paper").estimator.process_noise == pytest.approx(1e-6, rel=1e-14)


def test_bad_rates_are_one_line_naming_the_field():
    s = LoadNamedScenario("plan_i")
    with pytest.raises(ScenarioError, match="rates: must be one of paper, fast"):
        WithRates(s, "quick")
    with pytest.raises(ScenarioError, match="sensor.rate: its period must") as info:
        WithRates(s, RateSetting(plant=20.0, sensor=15.0, averaging=False, estimator=15.0))
    assert "\n" not in str(info.value)


def test_studies_fly_the_fast_rates_unless_told(tmp_path):
    assert DEFAULT_STUDY_RATES == "fast"
    text = "base: plan_i\nset: {simulation.time_limit: 12.0}\npolicies: [mpc]\n"
    expected = {
        "": WithRates(LoadNamedScenario("plan_i"), DEFAULT_STUDY_RATES),
        "rates: paper\n": LoadNamedScenario("plan_i"),
        "rates: scenario\n": LoadNamedScenario("plan_i"),
    }
    for extra, reference in expected.items():
        path = tmp_path / "study.yaml"
        path.write_text(text + extra)
        for _, s in StudyFlights(*LoadStudy(path)):
            assert s.simulation.max_step == reference.simulation.max_step
            assert s.sensor.rate == reference.sensor.rate
            assert s.estimator == reference.estimator
            assert s.simulation.time_limit == 12.0  # ``set`` is layered on top
    path.write_text(text + "rates: quick\n")
    with pytest.raises(ScenarioError, match="rates: must be one of paper, fast, scenario"):
        LoadStudy(path)


def _Synthetic(shift=0.0, dy=0.0, **summary):
    t = np.arange(0.0, 30.0, 0.1)
    log = {
        "times": t,
        "position": np.stack([15.0 * t + shift, np.zeros_like(t)], axis=1),
        "estimated": 30.0 + np.sin(t) + dy,
        "true": 30.0 + np.sin(t),
    }
    base = {"status": "complete", "duration": 30.0, "final_soc": 0.5, "c1": -400.0, "c2": [2.0]}
    return {**log, **base, **summary}


def test_flight_differences_and_tolerances():
    ref = _Synthetic()
    d = FlightDifferences(_Synthetic(shift=3.0, dy=0.2, final_soc=0.503, c1=-395.0), ref)
    assert d["max_track"] == pytest.approx(3.0) and d["rms_track"] == pytest.approx(3.0)
    assert d["rms_estimate"] == pytest.approx(0.2) and d["own_estimate"] == pytest.approx(0.2)
    assert d["dsoc"] == pytest.approx(0.003) and d["dc1"] == pytest.approx(5.0)
    assert d["same_status"] and d["same_c2"] and d["dt_rel"] == 0.0
    assert WithinRateTolerances(d)
    for change in (
        {"status": "reserve_reached"},
        {"c2": [4.0]},
        {"duration": 30.0 * 1.02},
        {"final_soc": 0.5 + 2 * RATE_TOLERANCES["final_soc"]},
        {"c1": -400.0 + 2 * RATE_TOLERANCES["path_parameter"]},
        {"dy": 2 * RATE_TOLERANCES["rms_estimate"]},
        {"shift": 2 * RATE_TOLERANCES["max_track"]},
    ):
        assert not WithinRateTolerances(FlightDifferences(_Synthetic(**change), ref)), change


def _Flight(scenario) -> dict:
    log = Simulate(scenario)
    s = log.summary
    return {
        "status": s["status"],
        "duration": s["duration"],
        "final_soc": s["final_soc"],
        "c1": float(log["path_parameters"][-1, 0]),
        "c2": [float(v) for v in log["computation_parameters"][-1]],
        "times": log.times,
        "position": log["position"],
        "estimated": log["estimated_power"][:, 0],
        "true": log["true_power"][:, 0],
    }


@pytest.mark.slow
def test_a_flight_at_the_fast_rates_stays_within_the_tolerances_of_the_paper_rates():
    """plan i for 150 s: the filter's start-up, the planner from 80 s and the fault at 93 s."""
    paper = LoadNamedScenario("plan_i", ["simulation: {time_limit: 150.0}"])
    fast = WithRates(paper, "fast")
    assert fast.simulation.max_step != paper.simulation.max_step
    d = FlightDifferences(_Flight(fast), _Flight(paper))
    assert WithinRateTolerances(d), d


def test_rate_setting_labels():
    assert RATE_PRESETS["paper"].Label() == "P100 S100"
    setting = RateSetting(plant=20.0, sensor=10.0, averaging=True, estimator=10.0)
    assert setting.Label() == "P20 S10 avg"
    assert dc.replace(setting, averaging=False).Label() == "P20 S10 point"
    assert dc.replace(setting, estimator=5.0).Label() == "P20 S10 F5 avg"
    assert dc.replace(setting, sensor=20.0, estimator=20.0).Label() == "P20 S20 avg"
