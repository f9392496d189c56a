"""The rule of the loop's rates (eaplan_drake.params.periods): one base period, integer
multiples of it."""

from eaplan_drake.params import IntegerMultiple, TicksPerPeriod


def test_integer_multiple_within_the_rate_tolerance():
    assert IntegerMultiple(3.0) == 3
    assert IntegerMultiple(0.1 / 0.01) == 10  # 10.000000000000002
    assert IntegerMultiple(2.0 * (1.0 + 1e-12)) == 2
    assert IntegerMultiple(2.0 * (1.0 + 1e-6)) == 0
    assert IntegerMultiple(1.5) == 0
    assert IntegerMultiple(0.4) == 0


def test_ticks_per_period_is_the_integer_multiple_of_the_base_tick():
    assert TicksPerPeriod(0.1, 0.01) == 10
    assert TicksPerPeriod(0.2, 0.05) == 4
    assert TicksPerPeriod(0.01, 0.01) == 1  # the tick itself: its own period
    assert TicksPerPeriod(0.015, 0.01) == 1  # not a multiple: its own period
    assert TicksPerPeriod(0.01, 0.02) == 1  # faster than the tick
    assert TicksPerPeriod(0.1, None) == 1
