"""The documentation's examples run and print what they say (README: one system in your own
diagram)."""

import subprocess
import sys
from pathlib import Path

import pytest

from eaplan_drake.energy.battery import RintCurrent
from eaplan_drake.params import BatteryParams

EXAMPLES = Path(__file__).resolve().parents[1] / "docs" / "examples"


def test_one_system_example_prints_the_rint_soc_after_100_s():
    out = subprocess.run(
        [sys.executable, str(EXAMPLES / "one_system.py")],
        capture_output=True,
        text=True,
        check=True,
        timeout=120,
    ).stdout
    p = BatteryParams()
    # b(t) = 1 − k_b I(y) t / Q_c under a constant y = 33 W (Lemma III.3), within one 0.01 s step
    current = RintCurrent(33.0, p.voltage, p.internal_resistance)
    expected = 1.0 - p.k_b * current * 100.0 / p.capacity
    printed = float(out.strip().rsplit(" ", 1)[-1])
    assert printed == pytest.approx(expected, abs=6e-5)
    assert "SoC after 100 s: 0.9806" in out
