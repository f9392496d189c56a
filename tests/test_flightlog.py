"""The flight log (eaplan_drake.flightlog): the quality metric and the log files."""

import json

import numpy as np
import pytest

from eaplan_drake.flightlog import FlightLog, LoadFlightLog, QualityMetric


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
