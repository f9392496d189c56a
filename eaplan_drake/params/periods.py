"""One base period for the loop's rates: the test of "an integer multiple" between periods, and
the scenario check that every rate is one."""

from eaplan_drake.params.checks import _check

RATE_TOLERANCE = 1e-9
"""Relative tolerance of "an integer multiple" between the periods of the rates [-]."""


def IntegerMultiple(ratio: float) -> int:
    """n when ``ratio`` is an integer n >= 1 within :data:`RATE_TOLERANCE` (relative, at least
    absolute), else 0: the one test of "an integer multiple" between the rates' periods."""
    n = round(ratio)
    return n if n >= 1 and abs(ratio - n) <= RATE_TOLERANCE * max(ratio, 1.0) else 0


def TicksPerPeriod(period: float, time_step: float | None) -> int:
    """n when ``period`` [s] is an integer multiple n >= 2 of the loop's base tick ``time_step``
    [s] (relative tolerance :data:`RATE_TOLERANCE`), else 1. A system with n > 1 declares its
    event at the tick and acts every n-th tick: Drake's event times k·period and (k·n)·time_step
    differ in the last bit unless n is a power of two, and a sample taken one ulp late would see
    the other systems after their update."""
    if time_step is None or not period > 0.0 or not time_step > 0.0:
        return 1
    n = IntegerMultiple(float(period) / float(time_step))
    return n if n >= 2 else 1


def _CheckRates(scenario) -> None:
    """Every rate of ``scenario`` (a :class:`~eaplan_drake.params.Scenario`) an integer multiple
    of one base, so that event times coincide: the periods simulation.max_step, 1/sensor.rate and
    1/estimator.rate [s] are each an integer multiple of the smallest of them (relative tolerance
    :data:`RATE_TOLERANCE`). With sensor.averaging the base is max_step (a sample averages whole
    base steps), native_rate is an integer multiple of the sensor's rate and the estimator is no
    faster than the sensor (each averaged sample is used once, with R/n)."""
    h = scenario.simulation.max_step
    periods = {
        "simulation.max_step": (h, f"{h:g} s"),
        "sensor.rate": (1.0 / scenario.sensor.rate, f"{scenario.sensor.rate:g} Hz"),
        "estimator.rate": (1.0 / scenario.estimator.rate, f"{scenario.estimator.rate:g} Hz"),
    }
    base_key = min(periods, key=lambda k: periods[k][0])
    base = periods[base_key][0]
    for key, (period, shown) in periods.items():
        ratio = period / base
        _check(
            IntegerMultiple(ratio) >= 1,
            key,
            f"its period must be an integer multiple of the base period {base:g} s "
            f"({base_key}; every rate an integer multiple of one base, so that event times "
            f"coincide), got {shown} (period {period:g} s = {ratio:g} base periods)",
        )
    if scenario.sensor.averaging:
        _check(
            IntegerMultiple(scenario.sensor.native_rate / scenario.sensor.rate) >= 1,
            "sensor.native_rate",
            f"with sensor.averaging must be an integer multiple of sensor.rate = "
            f"{scenario.sensor.rate:g} Hz, got {scenario.sensor.native_rate:g}",
        )
        _check(
            scenario.sensor.rate <= (1.0 + RATE_TOLERANCE) / h,
            "sensor.rate",
            f"with sensor.averaging must be <= 1 / simulation.max_step = {1.0 / h:g} Hz (a sample "
            f"averages whole base steps), got {scenario.sensor.rate:g}",
        )
        _check(
            scenario.estimator.rate <= scenario.sensor.rate * (1.0 + RATE_TOLERANCE),
            "estimator.rate",
            f"with sensor.averaging must be <= sensor.rate = {scenario.sensor.rate:g} Hz (each "
            f"averaged sample is used once, with R/n), got {scenario.estimator.rate:g}",
        )
