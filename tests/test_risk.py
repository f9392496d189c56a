"""Tests of eaplan_drake.planning.risk: analytic values, seeded Monte Carlo, bounds, bad inputs."""

import itertools
import math
from fractions import Fraction

import numpy as np
import pytest

from eaplan_drake.planning.risk import (
    EmpiricalDrops,
    ExcessRisk,
    ExcessRiskBounds,
    ExponentialDrops,
    FaultModel,
    MarginAtRisk,
    TotalDropTail,
    UniformDrops,
)

SIZES = {
    "uniform": UniformDrops(0.02, 0.1),
    "exponential": ExponentialDrops(0.05),
    "empirical": EmpiricalDrops([0.06, 0.09, 0.06, 0.03]),
}


def SampleSizes(sizes, rng, shape):
    if isinstance(sizes, UniformDrops):
        return rng.uniform(sizes.a, sizes.b, shape)
    if isinstance(sizes, ExponentialDrops):
        return rng.exponential(sizes.mean, shape)
    return rng.choice(np.asarray(sizes.values), shape)


def SampleWorlds(model, horizon, worlds, rng):
    """Drop times (sorted, inf where there is none) and sizes on [0, horizon], one row a world."""
    counts = rng.poisson(model.rate * horizon, worlds)
    width = max(int(counts.max()), 1)
    times = rng.uniform(0.0, horizon, (worlds, width))
    times[np.arange(width) >= counts[:, None]] = np.inf
    return np.sort(times, axis=1), SampleSizes(model.sizes, rng, (worlds, width))


def StandardError(p, n):
    return math.sqrt(max(p * (1.0 - p), 1.0 / n) / n)


def IrwinHallExact(n, x):
    """P(U_1 + ... + U_n <= x), the alternating sum in exact rational arithmetic."""
    x = Fraction(x)
    terms = ((-1) ** k * math.comb(n, k) * (x - k) ** n for k in range(min(n, math.floor(x)) + 1))
    return float(sum(terms) / math.factorial(n))


# Fault model and bad inputs.


@pytest.mark.parametrize(
    "make, field",
    [
        (lambda: FaultModel(-0.01, UniformDrops(0.01, 0.1)), "FaultModel.rate"),
        (lambda: FaultModel(math.nan, UniformDrops(0.01, 0.1)), "FaultModel.rate"),
        (lambda: FaultModel(0.01, "uniform"), "FaultModel.sizes"),
        (lambda: UniformDrops(0.2, 0.1), "UniformDrops.a"),
        (lambda: UniformDrops(0.1, 0.1), "UniformDrops.a"),
        (lambda: UniformDrops(math.nan, 0.1), "UniformDrops.a"),
        (lambda: UniformDrops(0.1, 1.5), "UniformDrops.b"),
        (lambda: ExponentialDrops(math.nan), "ExponentialDrops.mean"),
        (lambda: ExponentialDrops(0.0), "ExponentialDrops.mean"),
        (lambda: EmpiricalDrops([0.1, math.nan]), r"EmpiricalDrops.values\[1\]"),
        (lambda: EmpiricalDrops([0.1, -0.2]), r"EmpiricalDrops.values\[1\]"),
        (lambda: EmpiricalDrops([]), "EmpiricalDrops.values"),
    ],
)
def test_bad_fault_model_names_the_field(make, field):
    with pytest.raises(ValueError, match=field):
        make()


def test_bad_arguments_name_the_field():
    model = FaultModel(0.01, SIZES["uniform"])
    cases = [
        (lambda: TotalDropTail(model, math.nan, 0.1), "exposure"),
        (lambda: TotalDropTail(model, -1.0, 0.1), "exposure"),
        (lambda: TotalDropTail(model, 1e5, 0.1), "exposure"),
        (lambda: TotalDropTail(model, 100.0, [0.1, math.nan]), "margin"),
        (lambda: MarginAtRisk(model, 100.0, 1.0), "eps"),
        (lambda: MarginAtRisk(model, 100.0, math.nan), "eps"),
        (lambda: ExcessRisk(model, math.nan, 0.1, 100.0, 0.2), "plan_time"),
        (lambda: ExcessRisk(model, 100.0, math.inf, 100.0, 0.2), "plan_margin"),
        (lambda: ExcessRisk(model, 100.0, 0.1, -5.0, 0.2), "lowest_time"),
        (lambda: ExcessRisk(model, 100.0, 0.1, 100.0, math.nan), "lowest_margin"),
        (lambda: ExcessRisk(model, 100.0, 0.1, 100.0, 0.2, cells=2.5), "cells"),
    ]
    for call, field in cases:
        with pytest.raises(ValueError, match=field):
            call()


def test_fault_model_is_frozen_and_keeps_floats():
    model = FaultModel(1 / 300, EmpiricalDrops([0.06, 0.09]))
    assert model.sizes.values == (0.06, 0.09)
    assert hash(model) == hash(FaultModel(1 / 300, EmpiricalDrops((0.06, 0.09))))
    with pytest.raises(AttributeError):
        model.rate = 1.0


# Sums of n sizes against closed forms.


@pytest.mark.parametrize("n", [1, 2, 3, 12, 30, 60, 100])
def test_uniform_sum_tail_matches_exact_irwin_hall(n):
    sizes = UniformDrops(0.0, 1.0)
    x = np.array([0.3, 1.0, 1.5, n / 3, n / 2, n / 2 + 0.7, n - 0.4, n + 0.1])
    q = sizes.sum_tail(n, x)[:, n]
    exact = [1.0 - IrwinHallExact(n, v) if v < n else 0.0 for v in x]
    np.testing.assert_allclose(q, exact, rtol=0, atol=1e-12)


def test_uniform_sum_tail_known_values_and_shift():
    sizes = UniformDrops(0.0, 1.0)
    q = sizes.sum_tail(12, np.array([1.5, 6.0]))
    assert q[0, 2] == pytest.approx(1.0 - 0.875, abs=1e-14)
    assert q[0, 3] == pytest.approx(0.5, abs=1e-14)
    assert q[1, 12] == pytest.approx(0.5, abs=1e-14)
    shifted = UniformDrops(0.1, 0.3).sum_tail(2, np.array([-0.01, 0.0, 0.2, 0.4, 0.5, 0.6]))
    np.testing.assert_allclose(shifted[:, 0], [1, 0, 0, 0, 0, 0], atol=0)
    np.testing.assert_allclose(shifted[:, 1], [1, 1, 0.5, 0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(shifted[:, 2], [1, 1, 1, 0.5, 0.125, 0.0], atol=1e-14)


def test_exponential_sum_tail_closed_forms():
    mean = 0.05
    m = np.array([0.0, 0.01, 0.1, 0.4])
    q = ExponentialDrops(mean).sum_tail(3, m)
    y = m / mean
    np.testing.assert_allclose(q[:, 0], 0.0, atol=0)
    np.testing.assert_allclose(q[:, 1], np.exp(-y), rtol=1e-13)
    np.testing.assert_allclose(q[:, 2], np.exp(-y) * (1 + y), rtol=1e-13)
    np.testing.assert_allclose(q[:, 3], np.exp(-y) * (1 + y + y * y / 2), rtol=1e-13)


def test_empirical_sum_tail_matches_enumeration():
    values = [0.06, 0.09, 0.06, 0.03]
    m = np.array([-0.1, 0.0, 0.06, 0.1, 0.12, 0.15, 0.2, 0.3])
    q = EmpiricalDrops(values).sum_tail(3, m)
    for n in range(4):
        sums = np.array([round(sum(c), 12) for c in itertools.product(values, repeat=n)])
        exact = [np.mean(sums > v) for v in m]
        np.testing.assert_allclose(q[:, n], exact, rtol=0, atol=1e-14)


# Tail of the compound-Poisson total.


@pytest.mark.parametrize("kind", sorted(SIZES))
def test_tail_edge_cases(kind):
    model = FaultModel(1 / 200, SIZES[kind])
    assert TotalDropTail(model, 300.0, -1e-9) == 1.0
    assert TotalDropTail(model, 0.0, 0.0) == 0.0
    assert TotalDropTail(model, 0.0, 0.3) == 0.0
    assert TotalDropTail(FaultModel(0.0, SIZES[kind]), 1e6, 0.0) == 0.0
    # Any drop exceeds a zero margin: P(S > 0) = P(N >= 1).
    assert TotalDropTail(model, 300.0, 0.0) == pytest.approx(-math.expm1(-1.5), abs=1e-12)


@pytest.mark.parametrize("kind", sorted(SIZES))
def test_tail_small_exposure_is_one_drop(kind):
    model = FaultModel(1e-3, SIZES[kind])
    for m in [0.02, 0.05, 0.07]:
        one = model.sizes.sum_tail(1, np.array(m))[1]
        for tau in [0.1, 1.0, 10.0]:
            lt = model.rate * tau
            assert abs(TotalDropTail(model, tau, m) - lt * one) <= lt * lt


def test_tail_vectorised_equals_scalar_calls():
    model = FaultModel(1 / 150, SIZES["uniform"])
    tau = np.array([[0.0], [50.0], [300.0], [900.0]])
    m = np.array([-0.1, 0.0, 0.05, 0.2, 0.5])
    grid = TotalDropTail(model, tau, m)
    assert grid.shape == (4, 5)
    for i, j in itertools.product(range(4), range(5)):
        assert grid[i, j] == pytest.approx(TotalDropTail(model, tau[i, 0], m[j]), abs=1e-12)


@pytest.mark.parametrize("kind", sorted(SIZES))
def test_tail_monotone(kind):
    model = FaultModel(1 / 100, SIZES[kind])
    by_exposure = TotalDropTail(model, np.linspace(0.0, 2000.0, 41), 0.25)
    by_margin = TotalDropTail(model, 600.0, np.linspace(-0.05, 1.0, 43))
    assert np.all(np.diff(by_exposure) >= -1e-12) and by_exposure[-1] > by_exposure[1]
    assert np.all(np.diff(by_margin) <= 1e-12) and by_margin[-1] < by_margin[2] < by_margin[0]


@pytest.mark.parametrize(
    "kind, rate, tau, m",
    [
        ("uniform", 1 / 200, 400.0, 0.1),
        ("uniform", 1 / 60, 900.0, 0.9),
        ("exponential", 1 / 200, 400.0, 0.1),
        ("exponential", 1 / 100, 600.0, 0.35),
        ("empirical", 1 / 200, 400.0, 0.12),
        ("empirical", 1 / 100, 600.0, 0.3),
    ],
)
def test_tail_against_monte_carlo(kind, rate, tau, m):
    model = FaultModel(rate, SIZES[kind])
    rng = np.random.default_rng(20240611)
    worlds = 200_000
    times, sizes = SampleWorlds(model, tau, worlds, rng)
    # Totals rounded as the module rounds empirical sums: 0.06 + 0.09 + 0.06 + 0.09 is 0.3, which
    # does not exceed a margin of 0.3 (ending exactly at the reserve completes).
    totals = np.round(np.sum(np.where(times <= tau, sizes, 0.0), axis=1), 12)
    estimate = np.mean(totals > m)
    exact = TotalDropTail(model, tau, m)
    assert abs(estimate - exact) <= 4.0 * StandardError(exact, worlds)


@pytest.mark.parametrize("kind", sorted(SIZES))
def test_margin_at_risk(kind):
    model = FaultModel(1 / 200, SIZES[kind])
    eps = 0.01
    tau = np.array([0.0, 1.0, 100.0, 400.0, 900.0])
    m = MarginAtRisk(model, tau, eps)
    assert m[0] == 0.0 and m[1] == 0.0  # P(S > 0) = 1 - e^(-λτ) <= eps
    assert np.all(np.diff(m) >= 0.0) and m[-1] > m[2] > 0.0
    for tau_i, m_i in zip(tau[2:], m[2:], strict=True):
        assert TotalDropTail(model, tau_i, m_i) <= eps
        assert TotalDropTail(model, tau_i, m_i - 1e-9) > eps
    assert MarginAtRisk(model, 400.0, eps) == m[3]  # each entry is bisected on its own


# Excess risk.


def SimulateExcess(model, tau_p, m_p, tau_0, m_0, worlds, rng):
    """Fraction of worlds where p, falling back to the lowest plan at its first drop, fails while
    the lowest plan flown from the start completes (module docstring, A1 to A4)."""
    times, sizes = SampleWorlds(model, max(tau_p, tau_0), worlds, rng)
    lowest_fails = np.sum(np.where(times <= tau_0, sizes, 0.0), axis=1) > m_0
    first = times[:, 0]
    dropped = first <= tau_p
    u = np.where(dropped, first / tau_p, 1.0)
    end = first + tau_0 * (1.0 - u)
    total = np.sum(np.where(times <= end[:, None], sizes, 0.0), axis=1)
    plan_fails = np.where(dropped, total > u * m_p + (1.0 - u) * m_0, m_p < 0.0)
    return np.mean(plan_fails & ~lowest_fails)


@pytest.mark.parametrize(
    "kind, tau_p, m_p, tau_0, m_0",
    [
        ("uniform", 400.0, 0.05, 300.0, 0.12),  # longer and spends more
        ("uniform", 300.0, 0.02, 300.0, 0.12),  # same path, more SoC per second
        ("exponential", 500.0, 0.1, 300.0, 0.2),
        ("exponential", 350.0, -0.01, 300.0, 0.06),  # fails without faults
        ("empirical", 450.0, 0.04, 300.0, 0.13),
        ("empirical", 250.0, 0.15, 300.0, 0.1),  # out of order: the bound only
    ],
)
def test_excess_risk_against_monte_carlo(kind, tau_p, m_p, tau_0, m_0):
    model = FaultModel(1 / 250, SIZES[kind])
    rng = np.random.default_rng(7)
    worlds = 200_000
    estimate = SimulateExcess(model, tau_p, m_p, tau_0, m_0, worlds, rng)
    lower, upper = ExcessRiskBounds(model, tau_p, m_p, tau_0, m_0)
    se = StandardError(estimate, worlds)
    assert lower - 4.0 * se <= estimate <= upper + 4.0 * se
    assert ExcessRisk(model, tau_p, m_p, tau_0, m_0) == upper
    if tau_p >= tau_0 and m_p <= m_0:
        assert upper - lower <= 0.01


@pytest.mark.parametrize("kind", sorted(SIZES))
def test_excess_risk_of_lowest_plan_is_zero(kind):
    model = FaultModel(1 / 200, SIZES[kind])
    tau = np.array([0.0, 50.0, 300.0, 800.0])
    m = np.array([-0.05, 0.0, 0.1, 0.3])
    lower, upper = ExcessRiskBounds(model, tau, m, tau, m)
    np.testing.assert_array_equal(lower, 0.0)
    np.testing.assert_array_equal(upper, 0.0)
    # A plan a hair from the lowest: the quadrature reproduces the exact tail (no false excess).
    assert ExcessRisk(model, tau[2], m[2] - 1e-12, tau[2], m[2]) <= 1e-10


def test_excess_risk_bounds_tighten_with_cells_and_are_monotone():
    model = FaultModel(1 / 250, SIZES["uniform"])
    m_p = np.linspace(0.15, 0.0, 16)
    coarse = np.array(ExcessRiskBounds(model, 400.0, m_p, 300.0, 0.15, cells=16))
    fine = np.array(ExcessRiskBounds(model, 400.0, m_p, 300.0, 0.15, cells=128))
    assert np.all(coarse[0] <= fine[0] + 1e-12) and np.all(fine[1] <= coarse[1] + 1e-12)
    assert np.max(fine[1] - fine[0]) <= 0.25 * np.max(coarse[1] - coarse[0])
    # More SoC spent: more excess risk (the upper bound is monotone in m_p).
    assert np.all(np.diff(fine[1]) >= -1e-12) and fine[1][-1] > fine[1][1] > 0.0
    # Longer exposure: more excess risk, up to the bracket.
    lower, upper = ExcessRiskBounds(model, np.linspace(300.0, 700.0, 9), 0.05, 300.0, 0.15)
    assert np.all(upper[1:] >= lower[:-1] - 1e-12) and lower[-1] > upper[0]


def test_excess_risk_vectorised_over_candidates():
    model = FaultModel(1 / 250, SIZES["exponential"])
    tau_p = np.linspace(300.0, 600.0, 100)
    m_p = np.linspace(0.2, -0.02, 100)
    batch = ExcessRisk(model, tau_p, m_p, 300.0, 0.2)
    assert batch.shape == (100,)
    for i in [0, 17, 63, 99]:
        assert batch[i] == pytest.approx(ExcessRisk(model, tau_p[i], m_p[i], 300.0, 0.2), abs=1e-12)


def test_excess_risk_thin_world():
    """When the lowest plan's own margin is small, spending more costs a large excess risk; with a
    fat margin the same extra spending costs almost none."""
    model = FaultModel(1 / 300, UniformDrops(0.01, 0.08))
    thin = ExcessRisk(model, [300.0, 360.0, 360.0], [0.005, 0.005, -0.01], 300.0, 0.02)
    fat = ExcessRisk(model, [300.0, 360.0, 360.0], [0.385, 0.385, 0.37], 300.0, 0.4)
    assert np.all(thin >= 0.03) and thin[2] >= math.exp(-1.2)
    assert np.all(fat <= 1e-5)
    # A plan that ends below the reserve without faults: the worlds with no drop are excess.
    lower, _ = ExcessRiskBounds(model, 360.0, -0.01, 300.0, 0.02)
    assert lower >= math.exp(-1.2) - 1e-12


def test_irwin_hall_of_a_point_does_not_depend_on_the_points_beside_it():
    # The planner evaluates the lowest plan's tail at one margin per step and the risk table on a
    # grid of thousands: a point's value must be the same, bit for bit, in either batch (the padded
    # evaluation sums each point's own n + 1 terms), also across the evaluation's chunks.
    from eaplan_drake.planning.risk import _IrwinHallCdf

    rng = np.random.default_rng(7)
    count = rng.integers(1, 90, 5000)
    x = rng.uniform(0.0, 1.0, count.size) * count
    x[::11] = np.floor(x[::11])  # piece boundaries, t = 0
    batch = _IrwinHallCdf(count, x)
    single = np.array([_IrwinHallCdf(count[i : i + 1], x[i : i + 1])[0] for i in range(0, 5000, 7)])
    assert np.array_equal(batch[::7], single)
    exact = [IrwinHallExact(int(n), v) for n, v in zip(count[:40], x[:40], strict=True)]
    np.testing.assert_allclose(batch[:40], exact, rtol=0, atol=1e-12)
