"""Statistics of studies: exact bounds on a failure probability counted in flown worlds
(:func:`ClopperPearsonUpper`) and the worlds a claim needs (:func:`WorldsNeeded`), used by
:mod:`eaplan_drake.studies.certify`."""

import math

import numpy as np

from eaplan_drake.errors import CheckCount, CheckProbability

__all__ = ["ClopperPearsonUpper", "WorldsNeeded"]


def ClopperPearsonUpper(failures: int, trials: int, confidence: float = 0.95) -> float:
    """Exact one-sided upper confidence bound p_U of a failure probability from ``failures`` k of
    ``trials`` n: the p with P(Binomial(n, p) <= k) = 1 − ``confidence``.

    1 for k = n; 1 − (1 − confidence)^(1/n) for k = 0; otherwise bisection (to the last bit,
    deterministic; the upper end is returned) on the binomial CDF summed in log space."""
    n = CheckCount("trials", trials, 1, math.inf)
    k = CheckCount("failures", failures, 0, n)
    alpha = 1.0 - CheckProbability("confidence", confidence)
    if k == n:
        return 1.0
    if k == 0:
        return float(-np.expm1(math.log(alpha) / n))
    i = np.arange(k + 1)
    log_comb = math.lgamma(n + 1.0) - np.array(
        [math.lgamma(j + 1.0) + math.lgamma(n - j + 1.0) for j in range(k + 1)]
    )
    lo, hi = 0.0, 1.0
    for _ in range(200):
        p = 0.5 * (lo + hi)
        if not lo < p < hi:
            break
        terms = log_comb + i * math.log(p) + (n - i) * math.log1p(-p)
        top = float(terms.max())
        log_cdf = top + math.log(float(np.sum(np.exp(terms - top))))
        lo, hi = (p, hi) if log_cdf > math.log(alpha) else (lo, p)
    return hi


def WorldsNeeded(eps: float, confidence: float = 0.95) -> int:
    """The fewest failure-free trials n with ClopperPearsonUpper(0, n, confidence) <= ``eps``:
    ⌈ln(1 − confidence) / ln(1 − eps)⌉, checked against the bound itself (299 for eps = 0.01,
    59 for eps = 0.05, at 95 %)."""
    eps = CheckProbability("eps", eps)
    conf = CheckProbability("confidence", confidence)
    n = max(1, math.ceil(math.log(1.0 - conf) / math.log1p(-eps)))
    while ClopperPearsonUpper(0, n, conf) > eps:
        n += 1
    while n > 1 and ClopperPearsonUpper(0, n - 1, conf) <= eps:
        n -= 1
    return n
