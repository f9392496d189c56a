"""The math behind the pictures, as plain functions over numpy, each tested on its own: the
points of a plan stage, the part of the survey area left uncovered, robust axis ranges, time-mark
spacing, runs of a mask and the steps of a parameter."""

import math

import numpy as np
from matplotlib.path import Path as MplPath

from eaplan_drake.flight.stages import TurningRadius2
from eaplan_drake.params import Scenario

__all__ = [
    "ParameterSteps",
    "RobustRange",
    "Runs",
    "TimeMarkStep",
    "UncoveredArea",
    "UncoveredRadius",
]


def UncoveredArea(
    polygon, path, radius: float, resolution: float = 2.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The part of the survey ``polygon`` [m] farther than ``radius`` [m] from the flown
    ``path`` [m] (k × 2), on a grid of cell size ``resolution`` [m].

    Returns ``(x, y, mask, fraction)``: the cell centres along x and y, the boolean mask
    (len(y) × len(x), True = inside the polygon and not covered) and the uncovered fraction of
    the polygon's cells.
    """
    poly = np.asarray(polygon, dtype=float)
    if resolution <= 0.0 or radius < 0.0:
        raise ValueError(f"resolution must be > 0 and radius ≥ 0, got {resolution}, {radius}")
    lo, hi = poly.min(axis=0), poly.max(axis=0)
    x = np.arange(lo[0] + resolution / 2, hi[0], resolution)
    y = np.arange(lo[1] + resolution / 2, hi[1], resolution)
    gx, gy = np.meshgrid(x, y)
    inside = MplPath(poly).contains_points(np.column_stack([gx.ravel(), gy.ravel()]))
    inside = inside.reshape(gx.shape)
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    # Resample the path so consecutive points are at most half a cell apart.
    dense = [p[:1]]
    for a, b in zip(p[:-1], p[1:], strict=True):
        k = max(1, int(np.ceil(2.0 * np.linalg.norm(b - a) / resolution)))
        dense.append(a + np.outer(np.arange(1, k + 1) / k, b - a))
    p = np.vstack(dense)
    # Mark the cells the path visits (with a margin of the radius), then dilate by a disk.
    reach = int(np.ceil(radius / resolution)) + 1
    ix = np.floor((p[:, 0] - lo[0]) / resolution).astype(int) + reach
    iy = np.floor((p[:, 1] - lo[1]) / resolution).astype(int) + reach
    hit = np.zeros((len(y) + 2 * reach, len(x) + 2 * reach), dtype=bool)
    ok = (ix >= 0) & (ix < hit.shape[1]) & (iy >= 0) & (iy < hit.shape[0])
    hit[iy[ok], ix[ok]] = True
    covered = np.zeros(gx.shape, dtype=bool)
    for di in range(-reach, reach + 1):
        for dj in range(-reach, reach + 1):
            if (abs(di) - 0.5) ** 2 + (abs(dj) - 0.5) ** 2 > (radius / resolution) ** 2 and (
                di or dj
            ):
                continue
            covered |= hit[reach + di : reach + di + len(y), reach + dj : reach + dj + len(x)]
    mask = inside & ~covered
    fraction = float(mask.sum() / inside.sum()) if inside.any() else 0.0
    return x, y, mask, fraction


def UncoveredRadius(scenario: Scenario) -> float:
    """Half the widest line spacing of the plan [m]: (2 r1 − 2 r2(c̲1)) / 2 with
    r1 = r + x_d/2 and r2 = sqrt(r² + c1) (paper 003 Eq. 14): a point of the survey area
    farther than this from every flown line was not swept at any c1."""
    cov = scenario.coverage
    r1 = cov.turning_radius + 0.5 * cov.swath_spacing
    lo = float(scenario.planner.path_parameter_bounds[0])
    return r1 - TurningRadius2(lo, cov.turning_radius)


def RobustRange(values, quantiles=(0.005, 0.995), pad: float = 0.08) -> tuple[float, float]:
    """(low, high) axis limits that hold the ``quantiles`` of the finite ``values`` widened by
    ``pad`` × their span on each side: a short transient (the estimator's start-up) does not set
    the range."""
    v = np.asarray(values, dtype=float).ravel()
    v = v[np.isfinite(v)]
    if v.size == 0:
        return 0.0, 1.0
    lo, hi = np.quantile(v, quantiles)
    span = hi - lo if hi > lo else max(abs(hi), 1.0)
    return float(lo - pad * span), float(hi + pad * span)


def TimeMarkStep(duration: float, max_marks: int = 10) -> float:
    """The spacing [s] of time marks over ``duration`` [s]: the smallest of 5, 10, 20, 30, 60,
    120, 300, 600, 1200, 1800, 3600 s (then whole hours) that puts at most ``max_marks`` marks."""
    duration = max(float(duration), 0.0)
    for step in (5, 10, 20, 30, 60, 120, 300, 600, 1200, 1800, 3600):
        if duration / step <= max_marks:
            return float(step)
    return 3600.0 * math.ceil(duration / (max_marks * 3600.0))


def Runs(mask) -> list[tuple[int, int]]:
    """The runs of True in the boolean ``mask``: (first, last + 1) index pairs, in order."""
    m = np.asarray(mask, dtype=bool).ravel()
    edges = np.diff(np.r_[0, m.astype(np.int8), 0])
    starts, stops = np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()
    return list(zip(starts, stops, strict=True))


def ParameterSteps(times, values, threshold: float, merge: float = 5.0) -> np.ndarray:
    """Indices of the samples where ``values`` steps by at least ``threshold`` from the previous
    sample (a planner's change of c1, not its small rate-limited drift); a step within ``merge``
    [s] after a kept one is left out."""
    t = np.asarray(times, dtype=float)
    v = np.asarray(values, dtype=float).ravel()
    if v.size < 2:
        return np.zeros(0, dtype=int)
    steps = np.flatnonzero(np.abs(np.diff(v)) >= threshold) + 1
    kept: list[int] = []
    for i in steps:
        if not kept or t[i] - t[kept[-1]] > merge:
            kept.append(int(i))
    return np.array(kept, dtype=int)
