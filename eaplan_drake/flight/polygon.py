"""The convex survey polygon of a Zamboni-like plan, in the local sweep frame of one of its edges
(:class:`CoveragePolygon`)."""

import numpy as np

from eaplan_drake.flight.stages import _rot_ccw, _rot_cw

__all__ = ["CoveragePolygon"]


def _ConvexHull(points: np.ndarray) -> list[int]:
    """Indices of the strict convex hull vertices, counter-clockwise (monotone chain)."""
    order = sorted(range(len(points)), key=lambda i: (points[i, 0], points[i, 1]))

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    scale = float(np.max(np.abs(points))) + 1.0
    tol = 1e-12 * scale * scale
    lower: list[int] = []
    for i in order:
        while len(lower) >= 2 and cross(points[lower[-2]], points[lower[-1]], points[i]) <= tol:
            lower.pop()
        lower.append(i)
    upper: list[int] = []
    for i in reversed(order):
        while len(upper) >= 2 and cross(points[upper[-2]], points[upper[-1]], points[i]) <= tol:
            upper.pop()
        upper.append(i)
    return lower[:-1] + upper[:-1]


class CoveragePolygon:
    """A validated convex polygon with the local sweep frame of one of its edges.

    Local coordinates: p = origin + ξ e1 + η e2 with e2 the inward unit normal of edge
    (v_i, v_{i+1}), e1 = e2 rotated by −90°, origin v_i. ``width`` W = max η over the polygon.
    """

    def __init__(self, vertices, line_edge: int = 0, key: str = "coverage"):
        try:
            P = np.array(vertices, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{key}.polygon: expected a list of [x, y] vertices [m]") from None
        if P.ndim != 2 or P.shape[1] != 2:
            raise ValueError(f"{key}.polygon: expected a list of [x, y] vertices [m], got {P}")
        if not np.all(np.isfinite(P)):
            raise ValueError(f"{key}.polygon: vertices must be finite, got {P.tolist()}")
        n = len(P)
        if n < 3:
            raise ValueError(f"{key}.polygon: degenerate polygon: needs >= 3 vertices, got {n}")
        scale = float(np.ptp(P, axis=0).max())
        for i in range(n):
            for j in range(i + 1, n):
                if np.linalg.norm(P[i] - P[j]) <= 1e-9 * max(scale, 1.0):
                    raise ValueError(
                        f"{key}.polygon: degenerate polygon: vertices {i} and {j} coincide "
                        f"at {P[i].tolist()}"
                    )
        hull = _ConvexHull(P)
        area = (
            0.5
            * abs(
                sum(
                    P[hull[k], 0] * P[hull[(k + 1) % len(hull)], 1]
                    - P[hull[(k + 1) % len(hull)], 0] * P[hull[k], 1]
                    for k in range(len(hull))
                )
            )
            if len(hull) >= 3
            else 0.0
        )
        if len(hull) < 3 or area <= 1e-9 * scale * scale:
            raise ValueError(f"{key}.polygon: degenerate polygon: all vertices are collinear")
        on_hull = set(hull)
        for i in range(n):
            if i in on_hull:
                continue
            if self._StrictlyInside(P[hull], P[i], scale):
                raise ValueError(
                    f"{key}.polygon: non-convex polygon: vertex {i} {P[i].tolist()} lies inside "
                    "the convex hull of the others"
                )
            raise ValueError(
                f"{key}.polygon: degenerate polygon: vertex {i} {P[i].tolist()} lies on a "
                "straight edge between two others (collinear vertices)"
            )
        if not (isinstance(line_edge, int | np.integer) and 0 <= line_edge < n):
            raise ValueError(
                f"{key}.line_edge: must be an integer in [0, {n - 1}], got {line_edge}"
            )
        i, j = int(line_edge), (int(line_edge) + 1) % n
        pos = {v: k for k, v in enumerate(hull)}
        if (pos[i] - pos[j]) % n not in (1, n - 1):
            raise ValueError(
                f"{key}.line_edge: vertices {i} and {j} are not neighbours on the polygon's "
                "boundary (the pair is a diagonal); list the vertices in boundary order or pick "
                "another edge"
            )
        u = (P[j] - P[i]) / np.linalg.norm(P[j] - P[i])
        e2 = _rot_ccw(u)
        if np.min((P - P[i]) @ e2) < -1e-9 * scale:
            e2 = -e2
        self.vertices = P
        self.hull = P[hull]
        self.origin = P[i].copy()
        self.e2 = e2
        self.e1 = _rot_cw(e2)
        self.local = np.column_stack(
            [(self.hull - self.origin) @ self.e1, (self.hull - self.origin) @ self.e2]
        )
        self.local[np.abs(self.local[:, 1]) < 1e-9 * scale, 1] = 0.0
        self.width = float(self.local[:, 1].max())
        self.area = area
        self._scale = scale

    @staticmethod
    def _StrictlyInside(hull: np.ndarray, p: np.ndarray, scale: float) -> bool:
        m = len(hull)
        for k in range(m):
            a, b = hull[k], hull[(k + 1) % m]
            cross = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
            if cross <= 1e-9 * scale * scale:
                return False
        return True

    def ToWorld(self, xi: float, eta: float) -> np.ndarray:
        return self.origin + xi * self.e1 + eta * self.e2

    def Chord(self, eta: float) -> tuple[float, float]:
        """(ξ_lo, ξ_hi): the extent of the polygon along e1 at offset η (clipped to [0, W])."""
        eta = min(max(eta, 0.0), self.width)
        values = []
        for (xa, ya), (xb, yb) in self._Edges():
            if ya == yb:
                if abs(ya - eta) <= 1e-9 * self._scale:
                    values += [xa, xb]
                continue
            if (ya - eta) * (yb - eta) <= 0.0:
                values.append(xa + (eta - ya) / (yb - ya) * (xb - xa))
        if not values:  # numerically at a vertex
            etas = [ya for _, ya in self._Corners()]
            k = min(range(len(etas)), key=lambda i: abs(etas[i] - eta))
            values = [self._Corners()[k][0]]
        return min(values), max(values)

    def _Corners(self) -> list[tuple[float, float]]:
        """The hull's corners (ξ, η) [m] in the local frame, as Python floats (kept: the plan
        reads chords thousands of times, and a float is read faster than an array's element)."""
        corners = self.__dict__.get("_corners")
        if corners is None:
            corners = self.__dict__["_corners"] = [(float(x), float(y)) for x, y in self.local]
        return corners

    def _Edges(self) -> list[tuple[tuple[float, float], tuple[float, float]]]:
        """The hull's edges as pairs of :meth:`_Corners`, in order (kept)."""
        edges = self.__dict__.get("_edges")
        if edges is None:
            c = self._Corners()
            edges = self.__dict__["_edges"] = [(c[k], c[(k + 1) % len(c)]) for k in range(len(c))]
        return edges

    def __getstate__(self):
        state = dict(self.__dict__)
        for cache in ("_band_extents", "_corners", "_edges"):  # caches, rebuilt on use
            state.pop(cache, None)
        return state

    def BandExtent(self, eta: float, half_width: float) -> tuple[float, float]:
        """(ξ_lo, ξ_hi): the polygon's extent along e1 over the band [η − h, η + h] (cached per
        (η, h): a plan's repetitions share their bands with their neighbours)."""
        cache = self.__dict__.setdefault("_band_extents", {})
        key = (eta, half_width)
        extent = cache.get(key)
        if extent is None:
            if len(cache) >= 4096:
                cache.clear()
            extent = cache[key] = self._BandExtent(eta, half_width)
        return extent

    def _BandExtent(self, eta: float, half_width: float) -> tuple[float, float]:
        lo_eta = min(max(eta - half_width, 0.0), self.width)
        hi_eta = min(max(eta + half_width, 0.0), self.width)
        etas = [lo_eta, hi_eta] + [e for _, e in self._Corners() if lo_eta < e < hi_eta]
        chords = [self.Chord(e) for e in etas]
        return min(c[0] for c in chords), max(c[1] for c in chords)
