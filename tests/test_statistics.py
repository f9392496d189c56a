"""The statistics of studies (eaplan_drake.studies.statistics) against exact binomial sums."""

import math
from fractions import Fraction

import numpy as np
import pytest

from eaplan_drake.studies.statistics import ClopperPearsonUpper, WorldsNeeded


def BinomialCdf(k, n, p):
    p = Fraction(p)
    return float(sum(math.comb(n, i) * p**i * (1 - p) ** (n - i) for i in range(k + 1)))


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: ClopperPearsonUpper(5, 3), "failures"),
        (lambda: ClopperPearsonUpper(1, 0), "trials"),
        (lambda: ClopperPearsonUpper(1.5, 10), "failures"),
        (lambda: ClopperPearsonUpper(1, 10, 1.5), "confidence"),
        (lambda: WorldsNeeded(0.0), "eps"),
    ],
)
def test_bad_arguments_are_one_line_naming_them(call, name):
    with pytest.raises(ValueError, match=rf"^{name}: ") as e:
        call()
    assert "\n" not in str(e.value)


@pytest.mark.parametrize(
    "k, n, conf", [(1, 10, 0.95), (3, 50, 0.95), (7, 300, 0.95), (2, 40, 0.99), (19, 20, 0.9)]
)
def test_clopper_pearson_against_binomial_sums(k, n, conf):
    p = ClopperPearsonUpper(k, n, conf)
    assert BinomialCdf(k, n, p) == pytest.approx(1.0 - conf, abs=1e-10)
    assert BinomialCdf(k, n, p - 1e-7) > 1.0 - conf
    assert k / n < p < 1.0


def test_clopper_pearson_edges_and_known_values():
    assert ClopperPearsonUpper(10, 10) == 1.0
    for n in [1, 20, 299, 10_000]:
        assert ClopperPearsonUpper(0, n) == pytest.approx(1.0 - 0.05 ** (1.0 / n), rel=1e-12)
    assert ClopperPearsonUpper(1, 10) == pytest.approx(0.3941633, abs=1e-7)
    bounds = [ClopperPearsonUpper(k, 100) for k in range(0, 101, 10)]
    assert np.all(np.diff(bounds) > 0.0)


def test_worlds_needed():
    assert WorldsNeeded(0.01) == 299
    assert WorldsNeeded(0.05) == 59
    assert WorldsNeeded(0.01, confidence=0.99) == 459
    for eps in [0.01, 0.05, 0.1]:
        n = WorldsNeeded(eps)
        assert ClopperPearsonUpper(0, n) <= eps < ClopperPearsonUpper(0, n - 1)
