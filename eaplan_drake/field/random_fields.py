"""Seeded random fields: non-convex polygons with holes, for tests and benchmarks of the cell
decomposition, the route and the flights over it.

:func:`RandomField` draws a star-shaped outer boundary (n vertices at sorted random bearings
around the centre, at radii between ``1 − depth`` and 1 times ``size`` / 2) that is not convex
(its convex hull is at least 3 % larger), and up to ``holes`` small convex holes (random
quadrilaterals) kept inside it with a clearance of ``clearance`` [m]. Everything derives from
``seed`` (``numpy.random.default_rng``). Lengths in m.
"""

import math

import numpy as np

from eaplan_drake.field.geodesy import LocalFrame, Require
from eaplan_drake.field.readers import Field, FieldFromLocal

__all__ = ["RandomField"]


def _Star(rng, n: int, radius: float, depth: float) -> np.ndarray:
    bearings = np.sort(rng.uniform(0.0, 2.0 * math.pi, n))
    bearings += np.linspace(0.0, 2.0 * math.pi, n, endpoint=False) - bearings.mean() + math.pi
    bearings = np.sort(np.mod(bearings, 2.0 * math.pi))
    radii = radius * rng.uniform(1.0 - depth, 1.0, n)
    return np.column_stack((radii * np.cos(bearings), radii * np.sin(bearings)))


def RandomField(
    seed: int,
    *,
    size: float = 400.0,
    holes: int = 0,
    vertices: int = 9,
    depth: float = 0.45,
    clearance: float = 40.0,
) -> Field:
    """A random non-convex field about ``size`` [m] across with ``holes`` (0, 1 or 2) holes,
    drawn from ``seed`` (module docstring), in the local frame of an arbitrary origin (0° E,
    0° N). ValueError when no such field is drawn in 100 tries (e.g. holes too large)."""
    shapely = Require("shapely")
    rng = np.random.default_rng(seed)
    for _ in range(100):
        outer = _Star(rng, vertices, 0.5 * size, depth)
        polygon = shapely.Polygon(outer)
        if not polygon.is_valid or polygon.convex_hull.area < 1.03 * polygon.area:
            continue
        inner = polygon.buffer(-clearance)
        rings, placed = [], []
        for _ in range(holes):
            for _ in range(50):
                c = rng.uniform(-0.3 * size, 0.3 * size, 2)
                hole = _Star(rng, 4, rng.uniform(0.06, 0.12) * size, 0.2) + c
                h = shapely.Polygon(hole)
                if (
                    h.is_valid
                    and inner.contains(h)
                    and all(h.distance(o) > clearance for o in placed)
                ):
                    placed.append(h)
                    rings.append(hole)
                    break
        if len(rings) == holes:
            return FieldFromLocal(outer, rings, LocalFrame(0.0, 0.0), source=f"random field {seed}")
    raise ValueError(f"RandomField: no field with {holes} hole(s) drawn from seed {seed}")
