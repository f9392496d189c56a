"""Tests of the Rint battery functions (paper 003 Lemma III.3) and the Battery system."""

import math

import numpy as np
import pytest

from eaplan_drake.battery import (
    IsBrownout,
    MaxDeliverablePower,
    PowerBudget,
    RintCurrent,
    SocAfter,
    SocDerivative,
    TimeToSoc,
)
from eaplan_drake.params import BatteryParams

V, R, Q, KB = 14.8, 0.0012, 3.2, 0.00183


def Reference() -> BatteryParams:
    return BatteryParams(voltage=V, internal_resistance=R, capacity=Q, k_b=KB)


# -- pure functions -----------------------------------------------------------------------------


def test_current_solves_the_rint_quadratic():
    # I must satisfy R I² − V I + y = 0 (App. C) and be the root that is 0 at y = 0.
    y = np.array([0.0, 1e-9, 5.0, 33.0, 1000.0, 0.99 * MaxDeliverablePower(V, R)])
    current = RintCurrent(y, V, R)
    np.testing.assert_allclose(R * current**2 - V * current + y, 0.0, atol=1e-9 * V**2 / R)
    assert current[0] == 0.0
    # Naive textbook form agrees where it has no cancellation problem.
    naive = (V - np.sqrt(V**2 - 4 * R * y[2:])) / (2 * R)
    np.testing.assert_allclose(current[2:], naive, rtol=1e-9)
    # Small loads: I ≈ y / V (the resistance hardly matters), exact to first order.
    assert RintCurrent(1e-9, V, R) == pytest.approx(1e-9 / V, rel=1e-12)
    assert isinstance(RintCurrent(33.0, V, R), float)


def test_negative_power_gives_negative_current():
    current = RintCurrent(-5.0, V, R)
    assert current < 0.0
    assert R * current**2 - V * current - 5.0 == pytest.approx(0.0, abs=1e-9)


def test_max_power_and_brownout_never_nan():
    p_max = MaxDeliverablePower(V, R)
    assert p_max == pytest.approx(V**2 / (4 * R), rel=1e-15)
    assert RintCurrent(p_max, V, R) == pytest.approx(V / (2 * R), rel=1e-12)
    over = np.array([p_max * (1 + 1e-9), 2 * p_max, 1e12])
    current = RintCurrent(over, V, R)
    assert np.all(np.isfinite(current))
    np.testing.assert_allclose(current, V / (2 * R), rtol=1e-12)
    assert np.all(IsBrownout(over, V, R))
    assert not IsBrownout(p_max, V, R) and not IsBrownout(33.0, V, R)
    assert math.isfinite(SocDerivative(1e12, Reference()))
    assert math.isfinite(TimeToSoc(1.0, 0.0, 1e12, Reference()))


def test_soc_derivative_matches_lemma():
    p = Reference()
    y = 33.0
    lemma = -KB * (V - math.sqrt(V**2 - 4 * R * y)) / (2 * R * Q)
    assert SocDerivative(y, p) == pytest.approx(lemma, rel=1e-9)
    assert SocDerivative(0.0, p) == 0.0


def test_33_watts_empty_the_reference_battery_in_about_784_s():
    # Issue 2 / DESIGN.md: ≈ 784 s. Closed form: Q_c / (k_b I(33 W)) = 784.09 s.
    t = TimeToSoc(1.0, 0.0, 33.0, Reference())
    assert t == pytest.approx(784.0, abs=0.5)
    # Without the resistance (I = y / V) it would be 784.23 s: R_r matters by ~0.14 s only.
    assert Q * V / (KB * 33.0) - t == pytest.approx(0.14, abs=0.02)


def test_time_to_soc_closed_form_and_edge_cases():
    p = Reference()
    y = np.array([10.0, 33.0, 500.0])
    t = TimeToSoc(0.9, 0.3, y, p)
    # Integrating ḃ over t must land exactly on the target.
    np.testing.assert_allclose(0.9 + SocDerivative(y, p) * t, 0.3, rtol=0, atol=1e-12)
    np.testing.assert_allclose(SocAfter(0.9, y, t, p), 0.3, atol=1e-12)
    assert TimeToSoc(0.5, 0.5, 33.0, p) == 0.0
    assert TimeToSoc(0.5, 0.6, 33.0, p) == 0.0
    assert TimeToSoc(0.5, 0.3, 0.0, p) == math.inf
    assert TimeToSoc(0.5, 0.3, -4.0, p) == math.inf


def test_soc_after_is_clipped_to_empty():
    p = Reference()
    assert SocAfter(0.1, 33.0, 1e4, p) == 0.0
    assert SocAfter(1.0, -100.0, 1e4, p) == 1.0


def test_power_budget_is_b_times_capacity_times_voltage():
    p = Reference()
    assert PowerBudget(1.0, p) == pytest.approx(Q * V, rel=1e-15)  # 47.36, authors' bat.csv row 0
    np.testing.assert_allclose(PowerBudget(np.array([0.0, 0.5]), p), [0.0, 0.5 * Q * V])
