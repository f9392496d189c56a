"""The math behind the pictures (eaplan_drake.output.plot_math) against analytic answers."""

import math

import numpy as np
import pytest

from eaplan_drake.output.plot_math import (
    ParameterSteps,
    RobustRange,
    Runs,
    TimeMarkStep,
    UncoveredArea,
    UncoveredRadius,
)
from eaplan_drake.params import Scenario


def test_uncovered_area_of_a_square_swept_by_one_line():
    square = [[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]]
    line = np.array([[50.0, -10.0], [50.0, 110.0]])  # two points: the path is resampled
    _, _, mask, fraction = UncoveredArea(square, line, radius=10.0, resolution=1.0)
    assert fraction == pytest.approx(0.8, abs=0.02)  # a 20 m band of 100 m swept
    assert not mask[:, 45:55].any() and mask[:, :38].all() and mask[:, 62:].all()
    assert UncoveredArea(square, [[500.0, 500.0]], 10.0)[3] == 1.0
    assert UncoveredArea(square, line, radius=80.0)[3] == 0.0
    with pytest.raises(ValueError, match="resolution"):
        UncoveredArea(square, line, radius=1.0, resolution=0.0)


def test_uncovered_radius_is_half_the_widest_line_spacing():
    # r1 = 70 + 10/2 = 75 m, r2(−1000) = sqrt(70² − 1000) m (paper 003 Eq. 14).
    assert UncoveredRadius(Scenario()) == pytest.approx(75.0 - math.sqrt(3900.0), abs=1e-12)


def test_robust_range_ignores_a_start_up_spike():
    values = np.r_[48.0, 30.0 + np.sin(np.linspace(0.0, 20.0, 2000))]
    lo, hi = RobustRange(values)
    assert hi < 32.0 and lo > 28.0 and lo < 29.0
    assert RobustRange([np.nan, np.inf]) == (0.0, 1.0)
    lo, hi = RobustRange([5.0, 5.0], pad=0.1)
    assert lo < 5.0 < hi


def test_time_mark_step_runs_and_parameter_steps():
    assert [TimeMarkStep(d) for d in (0.0, 45.0, 120.0, 395.0, 600.0, 601.0, 5000.0)] == [
        5.0,
        5.0,
        20.0,
        60.0,
        60.0,
        120.0,
        600.0,
    ]
    assert TimeMarkStep(3600.0 * 25) == 3600.0 * 3
    assert Runs([0, 1, 1, 0, 1]) == [(1, 3), (4, 5)]
    assert Runs([]) == [] and Runs([1, 1]) == [(0, 2)]
    t = np.arange(0.0, 20.0, 1.0)
    c1 = np.r_[np.zeros(5), np.full(2, -100.0), -101.0, -102.0, np.full(11, -400.0)]
    # Steps of ≥ 50: at 5 s (−100) and 9 s (−400, merged away within 5 s of 5 s); drift of
    # 1 m² per step is not a step.
    assert ParameterSteps(t, c1, 50.0).tolist() == [5]
    assert ParameterSteps(t, c1, 50.0, merge=3.0).tolist() == [5, 9]
    assert ParameterSteps(t[:1], c1[:1], 50.0).size == 0
