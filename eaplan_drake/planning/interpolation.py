"""The interpolants the mpc's smooth model is made of (:doc:`/planner`, "the NLP"): the cubic
Hermite basis, monotone cubic Hermite interpolation (PCHIP, Fritsch–Carlson) and the lower convex
hull of a staircase. Plain functions of floats or arrays (the same operations for both)."""

import bisect

import numpy as np

__all__ = ["HermiteBasis", "HermiteBasisSlope", "LowerHull", "Pchip", "PchipSlopes", "PchipValue"]


def HermiteBasis(s):
    """(h00, h10, h01, h11)(s): the cubic Hermite basis on s ∈ [0, 1] (p(s) = h00 y0 + h10 h d0 +
    h01 y1 + h11 h d1 on an interval of width h)."""
    return 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2


def HermiteBasisSlope(s):
    """d/ds of :func:`HermiteBasis` (divide by the interval's width for d/dt)."""
    return 6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s, 3 * s**2 - 2 * s


def LowerHull(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Indices of the vertices of the lower convex hull of the points (x, y), x ascending."""
    hull: list[int] = []
    for k in range(x.size):
        while len(hull) >= 2:
            i, j = hull[-2], hull[-1]
            if (y[j] - y[i]) * (x[k] - x[i]) >= (y[k] - y[i]) * (x[j] - x[i]):
                hull.pop()  # j lies on or above the chord i–k
            else:
                break
        hull.append(k)
    return np.array(hull, dtype=int)


def Pchip(x: np.ndarray, y: np.ndarray, d: np.ndarray, t) -> tuple:
    """(value, slope) of the cubic Hermite interpolant of (x, y) with node slopes ``d`` at ``t``
    (an array, or a scalar for Python floats; constant beyond the ends, and exactly y at the
    nodes)."""
    if np.ndim(t) == 0:
        return _PchipAt(x, y, d, float(t))
    t = np.asarray(t, dtype=float)
    if x.size == 1:
        return np.full_like(t, y[0]), np.zeros_like(t)
    i, h, s, value = _PchipValues(x, y, d, t)
    dh00, dh10, dh01, dh11 = HermiteBasisSlope(s)
    dh00, dh10, dh01, dh11 = dh00 / h, dh10 / h, dh01 / h, dh11 / h
    slope = dh00 * y[i] + dh10 * h * d[i] + dh01 * y[i + 1] + dh11 * h * d[i + 1]
    inside = (t >= x[0]) & (t <= x[-1])
    return value, np.where(inside, slope, 0.0)


def PchipValue(x: np.ndarray, y: np.ndarray, d: np.ndarray, t):
    """The value of :func:`Pchip` alone (the same operations, no slope)."""
    if np.ndim(t) == 0:
        return _PchipAt(x, y, d, float(t))[0]
    t = np.asarray(t, dtype=float)
    if x.size == 1:
        return np.full_like(t, y[0])
    return _PchipValues(x, y, d, t)[-1]


def _PchipValues(x, y, d, t):
    """The interval index i, its width h, s in [0, 1] and the value of :func:`Pchip` at the
    array ``t`` (x.size >= 2)."""
    tc = np.clip(t, x[0], x[-1])
    i = np.clip(np.searchsorted(x, tc, side="right") - 1, 0, x.size - 2)
    h = x[i + 1] - x[i]
    s = (tc - x[i]) / h
    h00, h10, h01, h11 = HermiteBasis(s)
    value = h00 * y[i] + h10 * h * d[i] + h01 * y[i + 1] + h11 * h * d[i + 1]
    return i, h, s, value


def _PchipAt(x: np.ndarray, y: np.ndarray, d: np.ndarray, t: float) -> tuple[float, float]:
    """:func:`Pchip` at one point, in Python floats: the same operations in the same order
    (the solver's constraints and the per-plan margins call it thousands of times a flight)."""
    if x.size == 1:
        return float(y[0]), 0.0
    xs = x.tolist()
    tc = min(max(t, xs[0]), xs[-1])
    i = min(max(bisect.bisect_right(xs, tc) - 1, 0), len(xs) - 2)
    y0, y1, d0, d1 = float(y[i]), float(y[i + 1]), float(d[i]), float(d[i + 1])
    h = xs[i + 1] - xs[i]
    s = (tc - xs[i]) / h
    h00, h10, h01, h11 = HermiteBasis(s)
    value = h00 * y0 + h10 * h * d0 + h01 * y1 + h11 * h * d1
    dh00, dh10, dh01, dh11 = HermiteBasisSlope(s)
    dh00, dh10, dh01, dh11 = dh00 / h, dh10 / h, dh01 / h, dh11 / h
    slope = dh00 * y0 + dh10 * h * d0 + dh01 * y1 + dh11 * h * d1
    return value, (slope if xs[0] <= t <= xs[-1] else 0.0)


def PchipSlopes(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Node derivatives of the monotone cubic interpolant of (x, y) (Fritsch–Carlson)."""
    if x.size < 2:
        return np.zeros_like(y)
    delta = (np.diff(y) / np.diff(x)).tolist()
    d = np.zeros_like(y)
    d[0], d[-1] = delta[0], delta[-1]
    xs = x.tolist()  # the same arithmetic on Python floats (read faster than array elements)
    for k in range(1, len(xs) - 1):
        a, b = delta[k - 1], delta[k]
        if a * b > 0.0:  # weighted harmonic mean; 0 at a local extremum or a plateau
            w1 = 2 * (xs[k + 1] - xs[k]) + (xs[k] - xs[k - 1])
            w2 = (xs[k + 1] - xs[k]) + 2 * (xs[k] - xs[k - 1])
            d[k] = (w1 + w2) / (w1 / a + w2 / b)
    return d
