"""TotalDropTail and PoissonCutoff against a copy of their array form (as they were before the path
for one (τ, m) pair): the same values bit for bit, the same shapes and types, the same errors."""

import math

import numpy as np
import pytest

from eaplan_drake.planning import risk
from eaplan_drake.planning.risk import (
    EmpiricalDrops,
    ExponentialDrops,
    FaultModel,
    PoissonCutoff,
    PoissonPmf,
    TotalDropTail,
    UniformDrops,
)

# The reference: the array form, copied.


def RefPoissonCutoff(mean):
    if mean <= 0.0:
        return 0
    k = np.arange(1, int(mean + 20.0 * math.sqrt(mean) + 60.0))
    log_bound = -mean + k * (1.0 + math.log(mean) - np.log(k))
    return int(k[(k > mean) & (log_bound < math.log(risk.POISSON_TAIL))][0]) - 1


def RefIrwinHallCdf(count, x):
    out = np.zeros(x.shape)
    if not x.size:
        return out
    top = int(np.max(count))
    coeffs, log_comb = risk._PaddedBernstein(top)
    i = np.arange(top + 1)
    piece = np.minimum(np.floor(x), count - 1).astype(int)
    t = (x - piece)[:, None]
    column = count[:, None]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        log_basis = log_comb[count, : top + 1] + i * np.log(t) + (column - i) * np.log1p(-t)
        basis = np.where(t == 0.0, i == 0, np.where(t == 1.0, i == column, np.exp(log_basis)))
    terms = coeffs[count, piece, : top + 1] * np.where(i <= column, basis, 0.0)
    order = np.argsort(count, kind="stable")
    levels, starts = np.unique(count[order], return_index=True)
    ends = [*starts[1:].tolist(), count.size]
    for level, lo, hi in zip(levels.tolist(), starts.tolist(), ends, strict=True):
        rows = order[lo:hi]
        out[rows] = np.add.reduce(terms[rows, : level + 1], axis=1)
    return out


def RefUniformSumTail(sizes, n_max, margin):
    m = np.asarray(margin, dtype=float)[..., None]
    n = np.arange(n_max + 1)
    x = (m - n * sizes.a) / (sizes.b - sizes.a)
    inside = (n >= 1) & (x > 0.0) & (x < n)
    count = np.broadcast_to(n, x.shape)[inside]
    x_in = x[inside]
    q = np.where(x <= 0.0, 1.0, 0.0)
    q[..., 0] = (m[..., 0] < 0.0).astype(float)
    q[inside] = RefIrwinHallCdf(count, count - x_in)
    return q


def RefTotalDropTail(model, exposure, margin):
    tau = risk._CheckArray("exposure", exposure, nonnegative=True, what="[s]")
    m = risk._CheckArray("margin", margin, nonnegative=False, what="(SoC fraction)")
    tau, m = np.broadcast_arrays(tau, m)
    expected = model.rate * tau
    risk._CheckExpected("exposure", expected)
    n_max = RefPoissonCutoff(float(np.max(expected, initial=0.0)))
    if isinstance(model.sizes, UniformDrops):
        q = RefUniformSumTail(model.sizes, n_max, m)
    else:
        q = model.sizes.sum_tail(n_max, m)
    tail = np.sum(PoissonPmf(expected, n_max) * q, axis=-1)
    return risk._Out(np.where(m < 0.0, 1.0, np.clip(tail, 0.0, 1.0)))


def Bits(value):
    return type(value), np.shape(value), np.asarray(value, dtype=float).tobytes()


SIZES = [
    UniformDrops(0.0, 0.15),
    UniformDrops(0.02, 0.1),
    ExponentialDrops(0.05),
    EmpiricalDrops([0.06, 0.09, 0.06, 0.03]),
]
RATES = [0.003, 1 / 300, 0.01, 0.05]
PAIRS = {UniformDrops: 2000, ExponentialDrops: 1000, EmpiricalDrops: 250}


def Pairs(sizes, rate, count, rng):
    """Random (τ, m), τ in [0, 1500] s (at most 100 expected drops), m in [-0.05, 0.6], with
    τ = 0, m = 0, margins on the sizes' grid and just above it (Bernstein pieces' ends)."""
    tau = np.minimum(rng.uniform(0.0, 1500.0, count), risk.MAX_EXPECTED_DROPS / rate)
    m = rng.uniform(-0.05, 0.6, count)
    tau[::53], m[::37], m[::43] = 0.0, 0.0, np.round(m[::43], 2)
    if isinstance(sizes, UniformDrops):
        k = rng.integers(0, 8, m[::7].size)
        m[::7] = k * sizes.a + rng.integers(0, 5, k.size) * (sizes.b - sizes.a)
        m[3::29] = k[: m[3::29].size] * sizes.a + rng.choice([5e-324, 1e-20, 1e-17], m[3::29].size)
    return tau, m


@pytest.mark.parametrize("sizes", SIZES, ids=lambda s: type(s).__name__)
def test_one_pair_is_the_array_form_bit_for_bit(sizes):
    rng = np.random.default_rng(11)
    checked = 0
    for rate in RATES:
        model = FaultModel(rate, sizes)
        tau, m = Pairs(sizes, rate, PAIRS[type(sizes)], rng)
        pairs = list(zip(tau.tolist(), m.tolist(), strict=True))
        new = [Bits(TotalDropTail(model, t, v)) for t, v in pairs]
        assert new == [Bits(RefTotalDropTail(model, t, v)) for t, v in pairs]
        checked += len(new)
        pairs = list(zip(tau[:40], m[:40], strict=True))  # numpy floats
        new = [Bits(TotalDropTail(model, t, v)) for t, v in pairs]
        assert new == [Bits(RefTotalDropTail(model, t, v)) for t, v in pairs]
    assert checked >= 4 * PAIRS[type(sizes)]


def test_one_pair_of_any_shape_and_type():
    model = FaultModel(0.003, UniformDrops(0.0, 0.15))
    rng = np.random.default_rng(3)
    for t, v in zip(rng.uniform(0.0, 1500.0, 60), rng.uniform(-0.05, 0.6, 60), strict=True):
        for tau, m in [
            (np.float64(t), np.float64(v)),
            (np.array(t), np.array([v])),
            (np.array([[t]]), v),
            (np.array([t]), np.array([[v]])),
            (int(t), v),
            (t, np.float32(v)),
            (np.array([t, t]), v),
        ]:
            assert Bits(TotalDropTail(model, tau, m)) == Bits(RefTotalDropTail(model, tau, m))


def test_one_pair_keeps_the_errors():
    model = FaultModel(0.01, UniformDrops(0.02, 0.1))
    bad = [
        (math.nan, 0.1),
        (-1.0, 0.1),
        (-math.inf, 0.1),
        (math.inf, 0.1),
        (1e5, 0.1),
        (np.array([1e5]), 0.1),
        (100.0, math.nan),
        (100.0, np.array([math.inf])),
        (100.0, -math.inf),
        (100.0, "x"),
    ]
    for tau, m in bad:
        with pytest.raises(ValueError) as ref:
            RefTotalDropTail(model, tau, m)
        with pytest.raises(ValueError) as new:
            TotalDropTail(model, tau, m)
        assert str(new.value) == str(ref.value)


def test_poisson_cutoff_is_the_array_form():
    rng = np.random.default_rng(5)
    means = np.concatenate(
        [
            rng.uniform(0.0, 110.0, 20_000),
            np.linspace(0.0, 100.0, 20_001),
            rng.uniform(0.0, 1e-3, 500),
            [5e-324, 1e-300, 1.0, 2.0, 1e4, 999_999.0, 2e6],
        ]
    )
    for mean in means.tolist():
        assert PoissonCutoff(mean) == RefPoissonCutoff(mean)
    for mean in [np.float64(3.5), 7, np.array(2.5), -1.0, 0.0]:
        assert PoissonCutoff(mean) == RefPoissonCutoff(mean)
    with pytest.raises(ValueError):
        PoissonCutoff(math.nan)


def test_count_logarithms_are_those_of_each_range():
    # PoissonCutoff reads np.log(k) from one table: each value as np.log of a shorter range has it.
    table = risk._LogCounts(3000)
    for stop in range(2, 3000, 7):
        assert np.array_equal(np.log(np.arange(1, stop)), table[1:stop])


@pytest.mark.parametrize("scale", ["unit", "wide", "tiny", "sparse"])
def test_pairwise_row_sums_are_numpys_sums_bit_for_bit(scale):
    # numpy's np.add.reduce of each row's first L values >= 0 (its pairwise summation), for
    # every length 1..128, rows of any width beyond their length
    rng = np.random.default_rng(11)
    for length in range(1, risk.PAIRWISE_BLOCK + 1):
        shape = (60, length + int(rng.integers(0, 12)))
        terms = rng.random(shape)
        if scale == "wide":
            terms *= 10.0 ** rng.uniform(-20.0, 20.0, shape)
        elif scale == "tiny":  # subnormal sums
            terms *= 10.0 ** rng.uniform(-320.0, -300.0, shape)
        elif scale == "sparse":
            terms *= rng.random(shape) < 0.5
        lengths = rng.integers(1, length + 1, shape[0])
        lengths[0] = length
        expected = np.array([np.add.reduce(row[:n]) for row, n in zip(terms, lengths, strict=True)])
        got = risk.PairwiseRowSums(terms, lengths)
        assert np.array_equal(got.view(np.int64), expected.view(np.int64)), length


def test_irwin_hall_is_the_level_by_level_sum_bit_for_bit():
    # all rows at once up to 128 terms, the longer ones level by level: the same numbers
    rng = np.random.default_rng(5)
    for top in (5, 40, 127, 128, 200):
        count = rng.integers(1, top + 1, 3000)
        x = rng.uniform(0.0, 1.0, count.size) * count
        x[::13] = np.floor(x[::13])
        assert np.array_equal(risk._IrwinHallCdf(count, x), RefIrwinHallCdf(count, x))
