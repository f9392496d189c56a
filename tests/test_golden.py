"""The headline numbers (README's results table) of the reference and default-planner flights,
pinned in ``tests/golden/flights.json`` (``python3 tests/golden/regenerate.py`` rewrites it)."""

import json
import math
import sys
from pathlib import Path

import pytest

GOLDEN_DIR = Path(__file__).resolve().parent / "golden"
sys.path.insert(0, str(GOLDEN_DIR))
from regenerate import HeadlineNumbers  # noqa: E402

from eaplan_drake.output.reference import CompareScenarios  # noqa: E402
from eaplan_drake.simulation import Simulate  # noqa: E402

GOLDEN = json.loads((GOLDEN_DIR / "flights.json").read_text())

TOLERANCES = {"duration": 0.5, "final_soc": 2e-3, "quality": 2e-3}
"""Absolute tolerances: duration [s], final SoC [-], quality [-]; the metric P within 1 %."""


def test_the_golden_file_holds_every_compare_flight():
    assert sorted(GOLDEN) == sorted(s.name for _, s in CompareScenarios())
    assert GOLDEN["plan_i"]["metric"] > 10.0  # the README's headline plan i, P ≈ 10.3


@pytest.mark.slow
@pytest.mark.parametrize("index", range(len(GOLDEN)))
def test_flight_matches_its_headline_numbers(index):
    _, scenario = CompareScenarios()[index]
    want = GOLDEN[scenario.name]
    got = HeadlineNumbers(Simulate(scenario).summary)
    assert got["policy"] == want["policy"]
    assert got["status"] == want["status"]
    for key, tol in TOLERANCES.items():
        assert got[key] == pytest.approx(want[key], abs=tol), key
    if want["metric"] is None:
        assert got["metric"] is None
    else:
        assert math.isclose(got["metric"], want["metric"], rel_tol=0.01), (got, want)
